"""The own consistency checks of ``load_exponent`` and ``load_along_rail`` (docs/discrepancy.md, "Every named effect
checked against what it claims"), on duty cells written here (no simulator, no package wear function): 30 h, a
measurement every 10 min, one job per interval (a load and a position): one feed and one retract cell of 12 m
each; two idle windows of 2 h (10-12 h, 20-22 h: the clock runs, nothing slides); the straightness
A0 + alpha sum(work m) + a gauge term + noise 0.3 um in closed form (any alpha is plain Archard wear at some K:
the fit frees K).

- ``load_exponent`` claims the wear rate follows the load (W^n): with a gauge drift in clock time freed beside
  it, n - 1 must stay 3 sd from 0. Jobs at three loads in 2 h blocks with n = 1.6 pass; plain Archard wear
  under loads rising job by job plus a gauge creeping 3 um over the record is fitted by n != 1 (the fit alone,
  > 3 sd) and fails the check (n's signature is the clock's).
- ``load_along_rail`` claims the wear at each position grows with the work done there: with a gauge offset and
  a gauge drift in clock time freed beside it, g must stay 3 sd from 0. Jobs at either end of the rail in
  alternating 3 h blocks with g = 2 /m pass; plain Archard wear with the jobs moving along the rail job by job
  plus the 3 um creep, a 10 um creep (jobs moving over the first half), or a 1 um gauge offset, is fitted by
  g != 0 and fails.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from guide_health.analysis.discrepancy import consistency
from guide_health.analysis.discrepancy.duty import DutyCells
from guide_health.analysis.discrepancy.model import WearProblem
from guide_health.params import wear_monitor_params

JOBS = Path(__file__).resolve().parents[1] / "config" / "machine_jobs.yaml"
HOURS = 30
PER_HOUR = 6                     # measurements per hour
DISTANCE_M = 12.0                # per direction and interval
FEED_M_S, RETRACT_M_S = 0.02, 0.08
WEAR_M = 20e-6                   # the plain wear over the record
NOISE_M = 0.3e-6
CREEP_M = 3e-6                   # the gauge's creep over the record (a ramp in clock time)


def cells_of(load_n: np.ndarray, position_m: np.ndarray, rate_factor: np.ndarray, gauge_m, seed: int) -> DutyCells:
    """The record of the jobs (``load_n``, ``position_m``, the wear rate's factor: one value per measurement
    interval) with the gauge term ``gauge_m(t_s)`` added to the straightness."""
    n_int = HOURS * PER_HOUR
    t = np.arange(n_int + 1) * 3600.0 / PER_HOUR
    k = np.repeat(np.arange(1, n_int + 1), 2)                           # feed and retract cell of each interval
    direction = np.tile([1, -1], n_int)
    load, x, m = (np.repeat(v, 2) for v in (load_n, position_m, rate_factor))
    active = ~np.repeat(IDLE, 2)                                        # the machine stands: no cells
    k, direction, load, x, m = k[active], direction[active], load[active], x[active], m[active]
    work = load * DISTANCE_M
    wear = np.concatenate(([0.0], np.cumsum(np.bincount(k, weights=work * m, minlength=n_int + 1)[1:])))
    params_a0 = wear_monitor_params(JOBS)["straightness_initial_m"]
    y = (params_a0 + WEAR_M * wear / wear[-1] + gauge_m(t)
         + np.random.default_rng(seed).normal(0.0, NOISE_M, t.size))
    n_cells = k.size
    return DutyCells(
        t0_ns=0, interval=k, direction=direction, work_nm=work, distance_m=np.full(n_cells, DISTANCE_M),
        pass_work_n=np.zeros(n_cells), time_s=0.5 * (t[k - 1] + t[k]),
        sliding_distance_m=DISTANCE_M * (np.arange(n_cells) + 0.5), sliding_distance_var_m2=np.zeros(n_cells),
        speed_m_s=np.where(direction == 1, FEED_M_S, RETRACT_M_S), load_n=load, position_m=x,
        pass_length_m=np.full(n_cells, 0.2), measurement_t_s=t, measurement_m=y, temperature_t_s=np.zeros(0),
        temperature_c=np.zeros(0), pass_lengths_m=np.array([0.1, 0.2]), segments=n_cells, rejected_segments=0,
        total_distance_m=DISTANCE_M * n_cells, duration_s=float(t[-1]))


def creep(t_s: np.ndarray) -> np.ndarray:
    return CREEP_M * t_s / t_s[-1]


def no_gauge(t_s: np.ndarray) -> np.ndarray:
    return np.zeros_like(t_s)


def named_and_checked(cells: DutyCells, effect: str, parameter: str, none: float):
    """(the fit with ``effect`` alone: its parameter's sd from ``none``, and the effect's own check)."""
    params = wear_monitor_params(JOBS)
    problem = WearProblem(cells, params)
    fit = problem.fit((effect,))
    z = abs(fit.values[parameter] - none) / fit.std_errors[parameter]
    return fit, z, consistency.own_check(effect, problem, fit)


JOBS_N = HOURS * PER_HOUR
RNG = np.random.default_rng(7)
HOUR_OF_JOB = np.arange(JOBS_N) // PER_HOUR
IDLE = np.isin(HOUR_OF_JOB, (10, 11, 20, 21))                    # two idle windows of 2 h (the clock runs)
BLOCK = HOUR_OF_JOB // 3 % 2 == 1                                # every other 3 h block
LOADS_CYCLING = np.array([600.0, 1400.0, 2500.0])[HOUR_OF_JOB // 2 % 3] * RNG.uniform(0.9, 1.1, JOBS_N)
LOADS_RISING = np.linspace(600.0, 2500.0, JOBS_N)
POSITIONS_ALTERNATING = np.where(BLOCK, 0.32, 0.08) + RNG.uniform(-0.03, 0.03, JOBS_N)
POSITIONS_MOVING = np.linspace(0.05, 0.35, JOBS_N)
ONES = np.ones(JOBS_N)


def test_load_exponent_follows_the_load_passes():
    """n = 1.6 on jobs at three loads in 2 h blocks with two 2 h idle windows (a duty that separates it from a
    drift: two loads and a drift in clock time fit any two wear rates): fitted near 1.6, and a gauge drift freed
    beside it leaves n - 1 beyond 4 sd (measured 5.3)."""
    cells = cells_of(LOADS_CYCLING, np.full(JOBS_N, 0.2), (LOADS_CYCLING / 1000.0) ** 0.6, no_gauge, seed=1)
    fit, z, check = named_and_checked(cells, "load_exponent", "load_exponent", 1.0)
    assert fit.values["load_exponent"] == pytest.approx(1.6, abs=0.05)
    assert check["passed"] and check["sd_from_none"] > 4.0
    assert check["size"] == pytest.approx(0.6, abs=0.1)


def test_load_exponent_that_is_a_clock_time_creep_fails():
    """Plain Archard wear under loads rising job by job plus a 3 um creep: the fit alone finds n != 1 (> 3 sd);
    with the drift freed, n - 1 is within 3 sd of 0 and the check fails (with its numbers in the reason)."""
    cells = cells_of(LOADS_RISING, np.full(JOBS_N, 0.2), ONES, creep, seed=2)
    fit, z, check = named_and_checked(cells, "load_exponent", "load_exponent", 1.0)
    assert z > 3.0
    assert not check["passed"] and check["sd_from_none"] < 3.0
    assert "apart from a gauge drift in clock time" in check["reason"]


def test_load_along_rail_growing_with_the_work_passes():
    """g = 2 /m on jobs at either end of the rail in alternating 3 h blocks: fitted near 2, and a gauge offset and
    drift freed beside it leave g beyond 4 sd (measured 4.7)."""
    x = POSITIONS_ALTERNATING
    x_ref = float(np.mean(x[~IDLE]))            # equal work per job: the work-weighted mean position
    cells = cells_of(np.full(JOBS_N, 1000.0), x, 1.0 + 2.0 * (x - x_ref), no_gauge, seed=3)
    fit, z, check = named_and_checked(cells, "load_along_rail", "load_gradient_per_m", 0.0)
    assert fit.values["load_gradient_per_m"] == pytest.approx(2.0, abs=0.2)
    assert check["passed"] and check["sd_from_none"] > 4.0
    assert check["size"] == pytest.approx(2.0, abs=0.5)


def test_load_along_rail_that_is_a_clock_time_creep_fails():
    """Plain Archard wear with the jobs moving along the rail job by job plus a 3 um creep: the fit alone finds
    g != 0 (> 3 sd); with the offset and drift freed, g is within 3 sd of 0 and the check fails."""
    cells = cells_of(np.full(JOBS_N, 1000.0), POSITIONS_MOVING, ONES, creep, seed=4)
    fit, z, check = named_and_checked(cells, "load_along_rail", "load_gradient_per_m", 0.0)
    assert z > 3.0
    assert not check["passed"] and check["sd_from_none"] < 3.0
    assert "apart from a gauge offset and a gauge drift in clock time" in check["reason"]


def test_load_along_rail_that_is_a_fast_creep_needs_the_drift_freed():
    """The jobs move along the rail over the first 15 h and then stay at its end, the gauge creeps 10 um over the
    record (0.33 um/h): g is fitted at > 4 sd alone and still > 3 sd beside an offset alone (measured 4.5 and
    3.5), so the drift must be freed too: with it the check fails."""
    hours = np.arange(JOBS_N) / PER_HOUR
    x = np.where(hours < 15.0, 0.05 + 0.3 * hours / 15.0, 0.35)
    cells = cells_of(np.full(JOBS_N, 1000.0), x, ONES, lambda t: 10e-6 * t / t[-1], seed=6)
    fit, z, check = named_and_checked(cells, "load_along_rail", "load_gradient_per_m", 0.0)
    assert z > 4.0
    assert not check["passed"] and check["sd_from_none"] < 3.0


def test_load_along_rail_that_is_a_gauge_offset_fails():
    """A gauge or form error there from the first measurement (1 um, A0 given) with the jobs moving along the rail:
    g is fitted at > 5 sd alone and still > 3 sd beside a drift alone (measured 7.7 and 4.1), so the offset must
    be freed too: with it the check fails."""
    cells = cells_of(np.full(JOBS_N, 1000.0), POSITIONS_MOVING, ONES, lambda t: np.full_like(t, 1e-6), seed=5)
    fit, z, check = named_and_checked(cells, "load_along_rail", "load_gradient_per_m", 0.0)
    assert z > 5.0
    assert not check["passed"] and check["sd_from_none"] < 3.0


def test_a_failed_own_check_is_a_reading_outside_the_library():
    """The rule that follows: a failed own check makes the effect a reading and raises the flag's
    outside_library reason (consistency.outside_library), whatever the alternatives' BIC."""
    cells = cells_of(LOADS_RISING, np.full(JOBS_N, 0.2), ONES, creep, seed=2)
    problem = WearProblem(cells, wear_monitor_params(JOBS))
    fit = problem.fit(("load_exponent",))
    check = consistency.check_named_effects(problem, fit, ["load_exponent"])["load_exponent"]
    assert check["status"] == "reading"
    assert consistency.outside_library(check)[0] == check["own_check"]["reason"]
