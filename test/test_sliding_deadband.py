"""Sliding deadband (issue 15 a): standstill encoder noise is not sliding, in every path alike.

The motion is written here, independently of guide_health.sim: jerk-limited (minimum-jerk) strokes with
dwells at both ends, sampled at 250 Hz with 1 um encoder noise. Truth: the sum of the stroke lengths.
"""
from __future__ import annotations

import numpy as np
import pytest

from guide_health.analysis.discrepancy.duty import duty_cells_from_runs
from guide_health.models.wear.archard import WearGeometry, WearIntegrator, sliding_positions_m
from guide_health.params import WEAR_MONITOR_DEFAULTS
from guide_health.runs import MachineRun

RATE_HZ = 250.0
NOISE_M = 1e-6
DEADBAND_M = WEAR_MONITOR_DEFAULTS["sliding_deadband_m"]


def jerk_limited_motion(seed: int, duration_s: float = 600.0):
    """(t [s], noisy x [m], true sliding distance [m], standstill share of the samples)."""
    rng = np.random.default_rng(seed)
    t, x, travel = 0.0, 0.0, 0.0
    pieces_t, pieces_x = [], []
    while t < duration_s:
        dwell = rng.uniform(2.0, 12.0)
        target = rng.uniform(0.0, 0.3) if x < 0.05 else 0.0
        length = abs(target - x)
        v_peak = rng.uniform(0.01, 0.08)
        move = 1.875 * length / v_peak                      # peak speed of a minimum-jerk move: 1.875 L / T
        tt = np.arange(t, t + dwell, 1.0 / RATE_HZ)
        pieces_t.append(tt)
        pieces_x.append(np.full(tt.size, x))
        t += dwell
        tm = np.arange(t, t + move, 1.0 / RATE_HZ)
        tau = (tm - t) / move
        pieces_t.append(tm)
        pieces_x.append(x + (target - x) * (10 * tau ** 3 - 15 * tau ** 4 + 6 * tau ** 5))
        t += move
        x = target
        travel += length
    t_knots, x_clean = np.concatenate(pieces_t), np.concatenate(pieces_x)
    keep = t_knots <= t_knots[-1]
    standstill = float(np.mean(np.diff(x_clean) == 0.0))
    x_noisy = x_clean + rng.normal(0.0, NOISE_M, x_clean.size)
    return t_knots[keep], x_noisy[keep], travel, standstill


def reference_ratchet(x: np.ndarray, h: float) -> float:
    """Sliding distance by the definition, one sample at a time: the axis slides on while it moves in its
    direction; a reversal counts (in full) only once it has gone back more than h from its extreme."""
    direction, extreme, start, total = 0, x[0], x[0], 0.0
    for xi in x[1:]:
        if direction == 0:
            if abs(xi - start) > h / 2:
                direction = 1 if xi > start else -1
                total += abs(xi - start)
                extreme = xi
        elif (xi - extreme) * direction > 0:
            total += abs(xi - extreme)
            extreme = xi
        elif (extreme - xi) * direction > h:
            total += abs(extreme - xi)
            extreme = xi
            direction = -direction
    return total


def integrate(t_s, x, deadband_m, chunk=None):
    geo = WearGeometry(contact_width_m=0.04, hardness_pa=199e6, sliding_deadband_m=deadband_m)
    integ = WearIntegrator(geo)
    t_ns = (t_s * 1e9).astype(np.int64)
    w = np.full(x.size, 5000.0)
    step = chunk or x.size
    for lo in range(0, x.size, step):
        integ.advance_many(t_ns[lo:lo + step], x[lo:lo + step], w[lo:lo + step])
    return integ


@pytest.mark.parametrize("seed", [0, 1])
def test_standstill_noise_is_not_sliding(seed):
    t, x, travel, standstill = jerk_limited_motion(seed)
    assert standstill > 0.3                                     # the dwells are a large share of the samples
    raw = integrate(t, x, 0.0).sliding_distance_m
    with_deadband = integrate(t, x, DEADBAND_M)
    print(f"\nseed {seed}: truth {travel:.3f} m, no deadband {raw:.3f} m (+{raw / travel - 1:.2%}), "
          f"deadband {with_deadband.sliding_distance_m:.4f} m ({with_deadband.sliding_distance_m / travel - 1:+.3%})")
    assert raw / travel - 1 > 0.01                               # without: phantom sliding of over 1 %
    assert with_deadband.sliding_distance_m == pytest.approx(travel, rel=0.005)
    # Archard work: the standstill carries no work
    assert with_deadband.archard_work_nm == pytest.approx(5000.0 * travel, rel=0.005)
    # the definition, sample by sample (independent loop)
    assert with_deadband.sliding_distance_m == pytest.approx(reference_ratchet(x, DEADBAND_M), rel=1e-9)


def test_live_replay_and_diagnose_slide_alike():
    t, x, travel, _ = jerk_limited_motion(2, duration_s=120.0)
    whole = integrate(t, x, DEADBAND_M)
    chunked = integrate(t, x, DEADBAND_M, chunk=997)
    live = WearIntegrator(WearGeometry(contact_width_m=0.04, hardness_pa=199e6, sliding_deadband_m=DEADBAND_M))
    t_ns = (t * 1e9).astype(np.int64)
    for ti, xi in zip(t_ns.tolist(), x.tolist()):
        live.advance(ti, xi, 5000.0)
    for other in (chunked, live):
        assert other.sliding_distance_m == pytest.approx(whole.sliding_distance_m, rel=1e-9)
        assert other.archard_work_nm == pytest.approx(whole.archard_work_nm, rel=1e-9)
        assert other.sliding_direction == whole.sliding_direction
    run = MachineRun(joint_t_ns=t_ns, joint_position_m=x, load_t_ns=t_ns[:1] - 1, load_n=np.array([5000.0]),
                     straightness_t_ns=np.zeros(0, np.int64), straightness_m=np.zeros(0))
    cells = duty_cells_from_runs(run, 0.1, sliding_deadband_m=DEADBAND_M)
    assert cells.total_distance_m == pytest.approx(whole.sliding_distance_m, rel=1e-9)
    assert cells.work_nm.sum() == pytest.approx(whole.archard_work_nm, rel=1e-9)


def test_clean_motion_is_unchanged():
    x = np.array([0.0, 1e-3, 2e-3, 1.995e-3, 1e-3, 0.0, 3e-6, 4e-3])
    y, direction = sliding_positions_m(x[1:], x[0], 0, DEADBAND_M)
    # a 5 um turn-back at 2 mm is jitter; every other step slides in full
    assert y.tolist() == pytest.approx([1e-3, 2e-3, 2e-3, 1e-3, 0.0, 0.0, 4e-3], abs=1e-15)
    assert direction == 1
    assert np.abs(np.diff(np.concatenate((x[:1], y)))).sum() == pytest.approx(8e-3, rel=1e-12)
    same, _ = sliding_positions_m(x[1:], x[0], 0, 0.0)
    assert same.tolist() == x[1:].tolist()


def test_one_sample_rule_is_the_array_rule():
    """The live integrator's scalar form equals the vectorised form sample by sample (random walks with
    standstill noise, steps and reversals, several deadbands)."""
    from guide_health.models.wear.archard import sliding_position_m, sliding_positions_m

    rng = np.random.default_rng(7)
    for deadband in (0.0, 1e-6, 1e-5, 1e-3):
        steps = rng.choice([0.0, 1e-6, -1e-6, 3e-5, -3e-5, 2e-3, -2e-3], size=4000) + rng.normal(0, 1e-6, 4000)
        x = np.cumsum(steps)
        expected, _ = sliding_positions_m(x[1:], float(x[0]), 0, deadband)
        y, direction = float(x[0]), 0
        for k, xk in enumerate(x[1:].tolist()):
            y, direction = sliding_position_m(xk, y, direction, deadband)
            assert y == pytest.approx(expected[k], abs=1e-15), (deadband, k)
