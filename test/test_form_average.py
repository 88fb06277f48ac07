"""The running-in form's uncertainty in the remaining life (models/wear/form_average.py): the decay laws' closed
forms against numerical integrals, the BIC-weighted interval's invariants (per-form spreads, the envelope), the
model file's per-form lists through the params rules (and an older file's), live == offline with them, and on
the bench: the interval contains the true life on a clear case, widens when the forms disagree, and is the
envelope under the unexplained-structure flag (the calibration over 60 seeds of five forms is slow:
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
    LIFE_FORMS,
    RUNNING_IN_FORMS,
    bic_weights,
    form_averaged_interval_s,
    life_form_lists,
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
          "inverse_square": lambda s, r, s0: 1 + r * (1 + s / s0) ** -2,
          "inverse_cube_root": lambda s, r, s0: 1 + r / (1 + s / s0) ** (1 / 3),
          "inverse_two_thirds_power": lambda s, r, s0: 1 + r / ((1 + s / s0) ** 2) ** (1 / 3)}


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


def test_a_form_with_a_wider_spread_widens_the_mixture():
    """Per-form spreads (the ln-sd ratios): two forms of weight 1/2 at the same centre, the second with twice the
    carried model's sd: the ends are the quantiles of that mixture (checked by its cdf), wider than the carried
    interval, the point unmoved; ratios all 1: the common-sd mixture; a shorter list covers the leading forms."""
    from scipy.special import ndtr

    z, sd = 1.684, 0.02
    life = (100.0, 100.0 * math.exp(-z * sd), 100.0 * math.exp(z * sd))
    got = form_averaged_interval_s(life, [0.0, 0.0], [0.5, 0.5], z, [1.0, 2.0])
    assert got[0] == pytest.approx(100.0, rel=1e-9) and got[1] < life[1] and got[2] > life[2]
    for end, p in ((got[1], ndtr(-z)), (got[2], ndtr(z))):
        x = math.log(end) - math.log(100.0)
        assert 0.5 * ndtr(x / sd) + 0.5 * ndtr(x / (2 * sd)) == pytest.approx(p, abs=1e-9)
    assert form_averaged_interval_s(life, [0.0, 0.2], [0.5, 0.5], z, [1.0, 1.0]) == \
        pytest.approx(form_averaged_interval_s(life, [0.0, 0.2], [0.5, 0.5], z), rel=1e-12)
    assert form_averaged_interval_s(life, [0.0, 0.2], [0.5, 0.5], z, [1.0]) == \
        pytest.approx(form_averaged_interval_s(life, [0.0, 0.2], [0.5, 0.5], z), rel=1e-12)


def test_the_envelope_spans_every_forms_interval():
    """envelope: the ends are the lowest form's low end and the highest form's high end (each form's interval
    the carried one's, moved by its offset and scaled by its sd ratio), not the mixture's quantiles; the point
    is still the mixture's median; a form of weight 0 (the carried law's own slot) is left out."""
    z, sd = 1.684, 0.02
    life = (100.0, 100.0 * math.exp(-z * sd), 100.0 * math.exp(z * sd))
    d, w, c = [0.0, 0.5, 0.1, -0.05], [0.7, 0.0, 0.2, 0.1], [1.0, 1.0, 2.0, 1.5]
    mixed = form_averaged_interval_s(life, d, w, z, c)
    env = form_averaged_interval_s(life, d, w, z, c, envelope=True)
    assert env[0] == pytest.approx(mixed[0], rel=1e-12)
    assert env[1] == pytest.approx(100.0 * math.exp(-0.05 - z * 1.5 * sd), rel=1e-9)
    assert env[2] == pytest.approx(100.0 * math.exp(0.1 + z * 2.0 * sd), rel=1e-9)
    assert env[1] <= mixed[1] and env[2] >= mixed[2]


def test_a_legacy_model_files_lists_map_onto_the_life_forms():
    """running_in_form_* (exponential, hyperbolic, inverse square; the exponential carried) read as the
    life_form_* lists when those are at their default: the exponential's slot is the carried model's, each
    other form in its own slot, spread ratio 1; given life_form_* lists win."""
    default = ([1.0] + [0.0] * (len(LIFE_FORMS) - 1), [0.0] * len(LIFE_FORMS), [1.0] * len(LIFE_FORMS))
    w, d, c = life_form_lists(*default, [0.5, 0.3, 0.2], [0.0, 0.1, 0.05])
    assert w[0] == 0.5 and w[LIFE_FORMS.index("hyperbolic")] == 0.3 and w[LIFE_FORMS.index("inverse_square")] == 0.2
    assert d[LIFE_FORMS.index("hyperbolic")] == 0.1 and d[LIFE_FORMS.index("inverse_square")] == 0.05
    assert sum(w) == pytest.approx(1.0) and c == [1.0] * len(LIFE_FORMS)
    given = ([0.5, 0.0, 0.5, 0.0, 0.0, 0.0], [0.0, 0.0, 0.3, 0.0, 0.0, 0.0], [1.0, 1.0, 1.5, 1.0, 1.0, 1.0])
    assert life_form_lists(*given, [0.5, 0.3, 0.2], [0.0, 0.1, 0.05]) == tuple(list(x) for x in given)
    assert life_form_lists(*default, [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]) == tuple(list(x) for x in default)


def test_the_decay_laws_stand_in_for_the_running_in_or_the_step():
    """The decay laws are refitted in the place of the running-in, or of a carried effect whose consistency check
    has the decay with sliding distance as its alternative (the step in K); with neither, no forms."""
    from guide_health.analysis.discrepancy.model_file import decay_stand_in
    assert decay_stand_in(["thermal_drift", "running_in"]) == "running_in"
    assert decay_stand_in(["load_exponent", "wear_rate_change"]) == "wear_rate_change"
    assert decay_stand_in(["thermal_drift", "load_exponent"]) is None


@pytest.mark.parametrize("key, n", [("life_form_weights", len(LIFE_FORMS)), ("running_in_form_weights", 3)])
def test_form_weights_must_sum_to_one(key, n):
    p = {**wear_monitor_params(JOBS), key: [0.5, 0.2] + [0.0] * (n - 2)}
    with pytest.raises(InputError, match=f"{key} must sum to 1"):
        validate_wear_params(p)
    validate_wear_params({**p, key: [0.5, 0.5] + [0.0] * (n - 2)})


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
    p = {**plain, "life_form_weights": [0.4, 0.0, 0.4, 0.2, 0.0, 0.0],
         "life_form_ln_life_offsets": [0.0, 0.0, 0.15, 0.07, 0.0, 0.0],
         "life_form_ln_life_sd_ratios": [1.0, 1.0, 1.3, 0.8, 1.0, 1.0]}
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
    # an older model file's lists (the same forms, spread ratio 1) give the same as the new keys with ratios 1
    legacy = PrecisionMonitor(wear_axis_params({**plain, "running_in_form_weights": [0.4, 0.4, 0.2],
                                                "running_in_form_ln_life_offsets": [0.0, 0.15, 0.07]}))
    legacy.process_run(run)
    ones = PrecisionMonitor(wear_axis_params({**p, "life_form_ln_life_sd_ratios": [1.0] * len(LIFE_FORMS)}))
    ones.process_run(run)
    for key in ("remaining_life_h", "remaining_life_h_low", "remaining_life_h_high"):
        assert legacy.report()[key] == pytest.approx(ones.report()[key], rel=1e-12), key


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
    slot = LIFE_FORMS.index("hyperbolic")
    assert hyp["named"] == ["running_in"] and hyp["weights"][slot] > 0.3 and hyp["offsets"][slot] > 0.05, hyp
    assert hyp["life"][1] <= hyp["truth_h"] <= hyp["life"][2], hyp
    assert hyp["named_only"][2] < hyp["truth_h"] < hyp["life"][2], hyp


def test_under_the_flag_the_model_file_asks_for_the_envelope():
    """Two exponential stages (the independent writer's, seed 100; no decay law holds it): the record raises the
    unexplained-structure flag, so the model file asks for the envelope, and the live interval reaches from the
    lowest form's low end to the highest form's high end: it contains the mixture's and the true life (measured
    2026-11-28: truth 4.046 h, envelope [3.47, 4.35] h, the carried model alone [3.47, 3.78] h)."""
    run = bench_case("two_stage", 100)
    assert run["flag"] and run["interval"] == "envelope", run
    ln_half = math.log(run["named_only"][2] / run["named_only"][1]) / 2
    mid = math.log(run["named_only"][1] * run["named_only"][2]) / 2
    top = max(d + c * ln_half for w, d, c in zip(run["weights"], run["offsets"], run["sd_ratios"]) if w > 0)
    assert run["life"][2] == pytest.approx(math.exp(mid + top), rel=1e-6)
    assert run["life"][1] <= run["truth_h"] <= run["life"][2] and run["named_only"][2] < run["truth_h"], run


@pytest.mark.slow
def test_life_calibration_per_running_in_form():
    """60 seeds per running-in form: the library's exponential and four shapes the workflow does not fit with
    (linear to zero at s0, stretched exponential, a power law of exponent 1/2 between two fitted ones, two
    exponential stages; the independent writer of test_model_file.py), 20 h at 5 Hz then forecast
    (bench/life_calibration.py prints the same table; docs/discrepancy.md). The nominal 90 % interval (the
    BIC-weighted mixture of the forms' forecasts) covers the true remaining life in 83-96 % of the seeds of each
    form (the issue's calibration band: 50 to 57 of 60; with 60 seeds a calibrated interval leaves the band
    with probability 0.09). Measured (seeds 100-159): see docs/discrepancy.md's table."""
    sys.path.insert(0, str(ROOT / "bench"))
    import multiprocessing as mp

    from life_calibration import FORMS, covers, one_run, table
    with mp.get_context("spawn").Pool(2) as pool:
        rows = pool.map(one_run, [(form, seed, 5.0) for seed in range(100, 160) for form in FORMS])
    print("\n".join(table(rows)))
    for form in FORMS:
        mine = [r for r in rows if r["form"] == form]
        covered = sum(covers(r["life"], r["truth_h"]) for r in mine)
        assert 0.83 <= covered / len(mine) <= 0.96, (form, covered, len(mine))
