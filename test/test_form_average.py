"""The running-in form's uncertainty in the remaining life (models/wear/form_average.py): the forms' closed
forms against numerical integrals, the BIC-weighted interval's invariants, the model file's per-form lists
through the params rules, live == offline with them, and on the bench: the interval contains the true life on
a clear case and widens when the forms disagree (the calibration over 30 seeds per form is slow:
test_life_calibration_per_running_in_form, bench/life_calibration.py)."""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

from guide_health.errors import InputError
from guide_health.models.wear.effect_life import running_in_extra_m_per_rate
from guide_health.models.wear.form_average import (
    RUNNING_IN_FORMS,
    bic_weights,
    form_averaged_interval_s,
    mixture_quantile,
    running_in_form_extra_s,
    running_in_form_factor_spread,
    running_in_form_life_s,
)
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.params import simulation_params, validate_wear_params, wear_monitor_params
from guide_health.params.typed import wear_axis_params
from guide_health.sim.machine import simulate_machine

sys.path.insert(0, str(Path(__file__).resolve().parent))
from live_feed import feed_per_sample  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
JOBS = ROOT / "config" / "machine_jobs.yaml"

FACTOR = {"exponential": lambda s, r, s0: 1 + r * math.exp(-s / s0),
          "hyperbolic": lambda s, r, s0: 1 + r / (1 + s / s0),
          "inverse_square": lambda s, r, s0: 1 + r * (1 + s / s0) ** -2}


@pytest.mark.parametrize("form", RUNNING_IN_FORMS[1:])
def test_form_factor_is_the_mean_over_the_spread(form):
    """Mean of K(s)/K over a uniform spread of sliding distances = (1 / 2h) int K(s)/K ds (quad); no spread:
    the factor at the mean; a spread reaching below s = 0 is clipped there."""
    r, s0 = 2.5, 300.0
    for mean, var in ((450.0, 0.0), (450.0, 120.0 ** 2), (60.0, 200.0 ** 2)):
        h = math.sqrt(3 * var)
        a, b = max(mean - h, 0.0), mean + h
        want = (FACTOR[form](mean, r, s0) if h == 0 else quad(lambda s: FACTOR[form](s, r, s0), a, b)[0] / (b - a))
        got = float(running_in_form_factor_spread(form, np.array([mean]), np.array([var]), r, s0)[0])
        assert got == pytest.approx(want, rel=1e-9)


@pytest.mark.parametrize("form", RUNNING_IN_FORMS)
def test_extra_wear_time_is_the_integral_of_the_decay(form):
    r, s0, s_now, v, horizon = 2.0, 300.0, 900.0, 0.05, 5.0 * 3600.0
    want = quad(lambda t: FACTOR[form](s_now + v * t, r, s0) - 1.0, 0.0, horizon)[0]
    assert running_in_form_extra_s(form, horizon, r, s0, s_now, v) == pytest.approx(want, rel=1e-9)
    if form == "exponential":     # the live model's closed form (effect_life.py)
        assert running_in_extra_m_per_rate(horizon, r, s0, s_now, v) == pytest.approx(want, rel=1e-9)
    life = running_in_form_life_s(form, 50e-6, 1e-9, r, s0, s_now, v)
    extra = running_in_form_extra_s(form, life, r, s0, s_now, v)
    assert 1e-9 * (life + extra) == pytest.approx(50e-6, rel=1e-9) and life < 50e-6 / 1e-9
    assert running_in_form_life_s(form, -1e-6, 1e-9, r, s0, s_now, v) == 0.0
    assert running_in_form_life_s(form, 1e-6, 0.0, r, s0, s_now, v) == math.inf


def test_bic_weights_are_the_schwarz_posterior():
    """Equal BIC: equal weights; a BIC 2 ln 3 higher: a third of the weight; non-finite: 0."""
    assert bic_weights(np.array([5.0, 5.0])) == pytest.approx([0.5, 0.5])
    w = bic_weights(np.array([0.0, 2 * math.log(3.0), math.nan]))
    assert w == pytest.approx([0.75, 0.25, 0.0])


def test_the_averaged_interval_is_the_mixtures_and_the_named_one_alone():
    """One form of weight 1 (the params default): the named life and interval exactly; forms that agree: the
    same; two forms of weight 1/2, the other forecasting e^0.2 longer: the point is the mixture's median (e^0.1,
    by symmetry) and the ends its quantiles at Phi(-z), Phi(z) (checked by its cdf); a form of weight 0.99
    forecasting e^0.2 longer: its own interval, nearly, not joined with the named one (model averaging, not
    the union: the named low end is left behind)."""
    from scipy.special import ndtr

    z, sd = 1.684, 0.02
    life = (100.0, 100.0 * math.exp(-z * sd), 100.0 * math.exp(z * sd))
    assert form_averaged_interval_s(life, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], z) == life
    same = form_averaged_interval_s(life, [0.0, 0.0, 0.0], [0.5, 0.3, 0.2], z)
    assert same == pytest.approx(life, rel=1e-9)
    wide = form_averaged_interval_s(life, [0.0, 0.2, 0.0], [0.5, 0.5, 0.0], z)
    mu = math.log(100.0) + np.array([0.0, 0.2])
    assert wide[0] == pytest.approx(100.0 * math.exp(0.1), rel=1e-9)
    for end, p in ((wide[1], ndtr(-z)), (wide[2], ndtr(z))):
        assert 0.5 * (ndtr((math.log(end) - mu) / sd)).sum() == pytest.approx(p, abs=1e-9)
    assert life[1] < wide[1] < 100.0 and wide[2] > 100.0 * math.exp(0.2)     # the union would keep life[1]
    moved = form_averaged_interval_s(life, [0.0, 0.2, 0.0], [0.01, 0.99, 0.0], z)
    assert moved[1] > life[2]
    assert ndtr((math.log(moved[1]) - mu) / sd) @ [0.01, 0.99] == pytest.approx(ndtr(-z), abs=1e-9)
    assert moved[1] < moved[0] < moved[2]
    # no finite interval: unchanged
    assert form_averaged_interval_s((100.0, 0.0, math.inf), [0, 0.2, 0], [0.5, 0.5, 0], z) == (100.0, 0.0, math.inf)
    assert mixture_quantile(0.5, np.array([1.0, 3.0]), np.array([0.5, 0.5]), 0.1) == pytest.approx(2.0, abs=1e-9)


def test_form_weights_must_sum_to_one():
    p = {**wear_monitor_params(JOBS), "running_in_form_weights": [0.5, 0.2, 0.2]}
    with pytest.raises(InputError, match="running_in_form_weights must sum to 1"):
        validate_wear_params(p)
    validate_wear_params({**p, "running_in_form_weights": [0.5, 0.3, 0.2]})


def test_live_per_sample_path_equals_the_vectorised_path_with_the_forms():
    """The node's per-sample callbacks and process_run give the same averaged life and interval, also after a
    restore; the forms forecasting longer lives move the point (the mixture's median) and the high end up.
    2 h (12 measurements: 1 h leaves an interval so wide that the forms' offsets no longer lift its high end
    by e^0.1) at 2 Hz joints and loads: the per-sample callbacks cost per sample, and the path's equality
    holds at any rate (measured 4e-15 at 2 Hz as at 10 Hz joints, 50 Hz loads)."""
    params = wear_monitor_params(JOBS)
    sim = dict(simulation_params(JOBS), duration_h=2.0, joint_state_rate_hz=2.0, load_rate_hz=2.0)
    run = simulate_machine(params, sim, seed=2, effects={"running_in": 1.0})
    plain = {**params, "effects": "running_in", "running_in_ratio": 1.0, "running_in_distance_m": 300.0,
             "effect_covariance": list(np.diag([1e-14, 0.01, 100.0] + [0.0] * 10).ravel())}
    p = {**plain, "running_in_form_weights": [0.4, 0.4, 0.2], "running_in_form_ln_life_offsets": [0.0, 0.15, 0.07]}
    offline = PrecisionMonitor(wear_axis_params(p))
    offline.process_run(run)
    live = PrecisionMonitor(wear_axis_params(p))
    feed_per_sample(live, run)
    named = PrecisionMonitor(wear_axis_params(plain))
    named.process_run(run)
    a, b, c = offline.report(), live.report(), named.report()
    for key in ("remaining_life_h", "remaining_life_h_low", "remaining_life_h_high"):
        assert b[key] == pytest.approx(a[key], rel=1e-6), key
    # the mixture's median lies between the named form's point and the longest form's (offset 0.15)
    assert c["remaining_life_h"] < a["remaining_life_h"] < c["remaining_life_h"] * math.exp(0.15)
    assert a["remaining_life_h_low"] < a["remaining_life_h"] < a["remaining_life_h_high"]
    assert a["remaining_life_h_high"] > c["remaining_life_h_high"] * math.exp(0.1)
    again = PrecisionMonitor(wear_axis_params(p))
    again.restore(json.loads(json.dumps(offline.state())))
    assert again.report()["remaining_life_h_high"] == pytest.approx(a["remaining_life_h_high"], rel=1e-9)


def bench_case(form: str, seed: int) -> dict:
    sys.path.insert(0, str(ROOT / "bench"))
    from life_calibration import one_run
    return one_run((form, seed, 5.0))


def test_bench_interval_contains_the_truth_and_widens_when_the_forms_disagree():
    """Seed 000's bench, 20 h at 5 Hz, then forecast. The library's form (seed 1): running_in named, its
    interval contains the true life. A hyperbolic running-in (the independent writer's, seed 1): the forms
    disagree (the hyperbolic forecasts a longer life, its weight > 0.3), and the averaged interval contains the
    truth that the named form's alone misses (measured 2026-11-27: truth 4.385 h, named [3.84, 4.26] h)."""
    clear = bench_case("exponential", 1)
    assert clear["named"] == ["running_in"] and clear["life"][1] <= clear["truth_h"] <= clear["life"][2], clear
    hyp = bench_case("hyperbolic", 1)
    assert hyp["named"] == ["running_in"] and hyp["weights"][1] > 0.3 and hyp["offsets"][1] > 0.05, hyp
    assert hyp["life"][1] <= hyp["truth_h"] <= hyp["life"][2], hyp
    assert hyp["named_only"][2] < hyp["truth_h"] < hyp["life"][2], hyp


@pytest.mark.slow
def test_life_calibration_per_running_in_form():
    """60 seeds per running-in form: the library's exponential and two shapes the workflow does not fit with
    (linear to zero at s0, stretched exponential; the independent writer of test_model_file.py), 20 h at 5 Hz
    then forecast (bench/life_calibration.py prints the same table; docs/discrepancy.md). The nominal 90 %
    interval (the BIC-weighted mixture of the forms' forecasts) covers the true remaining life in 83-96 % of the
    seeds of each form (the issue's calibration band: 50 to 57 of 60; with 30 seeds a calibrated interval
    leaves the band with probability 0.26, with 60 seeds 0.09). Measured 2026-11-27 (seeds 100-159): see
    docs/discrepancy.md's table."""
    sys.path.insert(0, str(ROOT / "bench"))
    import multiprocessing as mp

    from life_calibration import covers, one_run, table
    forms = ("exponential", "linear", "stretched_exponential")
    with mp.get_context("spawn").Pool(2) as pool:
        rows = pool.map(one_run, [(form, seed, 5.0) for seed in range(100, 160) for form in forms])
    print("\n".join(table(rows)))
    for form in forms:
        mine = [r for r in rows if r["form"] == form]
        covered = sum(covers(r["life"], r["truth_h"]) for r in mine)
        assert 0.83 <= covered / len(mine) <= 0.96, (form, covered, len(mine))
