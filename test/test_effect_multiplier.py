"""The effect multipliers combined in one place (models/wear/effects/multiplier.combined_multiplier): the live
monitor's effective work (models/wear/effect_wear.EffectWear) equals the offline product, the sum of
W ds x effect_multiplier(material, K(s)/K, duty) with the duty effects' offline forms (the simulator's and the
discrepancy fit's), on random effect parameters and random segments (hypothesis).

Truth: the offline factor forms of each effect module (load_along_rail_factor, wear_rate_change_factor over a
segment, lubrication_interval_factor with relubrications at t = 0, T, 2T, ...), which equal the live forms
where a segment does not straddle t_c and 1 + a tau / T > 0 (both arranged here)."""
from __future__ import annotations

import numpy as np
import pytest

from guide_health.models.wear.effect_wear import EffectWear
from guide_health.models.wear.effects import (
    EffectParameters,
    combined_multiplier,
    effect_multiplier,
    load_along_rail_factor,
    lubrication_interval_factor,
    running_in_factor_mean,
    wear_rate_change_factor,
    wear_rate_multiplier,
)
from guide_health.params.typed import wear_axis_params

hypothesis = pytest.importorskip("hypothesis")
st = hypothesis.strategies

EFFECTS = "running_in,retract_asymmetry,speed_dependent_wear,load_exponent,load_along_rail,wear_rate_change," \
          "lubrication_interval"
T0_S = 1000.0            # the first segment's start [s since the stamps' epoch]


def test_combined_multiplier_is_the_product_of_its_factors():
    material, ri, duty = np.array([0.5, 2.0]), np.array([3.0, 1.0]), np.array([1.0, 0.25])
    assert combined_multiplier(material, ri, duty) == pytest.approx([1.5, 0.5], rel=1e-15)
    assert combined_multiplier(material) == pytest.approx([0.5, 2.0], rel=1e-15)
    e = EffectParameters(load_exponent=2.0, load_reference_n=100.0, retract_wear_factor=3.0)
    m = effect_multiplier(e, np.ones(2), np.array([200.0, 50.0]), np.array([True, False]), ri, duty)
    assert m == pytest.approx([2.0 * 3.0 * 3.0 * 1.0, 0.5 * 1.0 * 1.0 * 0.25], rel=1e-12)


@hypothesis.settings(max_examples=60, deadline=None, derandomize=True)
@hypothesis.given(
    ratio=st.floats(0.0, 5.0), distance_m=st.floats(0.1, 50.0), rho=st.floats(0.2, 5.0),
    lift_m_s=st.floats(0.01, 1.0), exponent=st.floats(0.5, 3.0), gradient=st.floats(-0.4, 0.4),
    factor=st.floats(0.2, 5.0), change_at=st.integers(0, 39), growth=st.floats(-0.9, 3.0),
    interval_s=st.floats(5.0, 200.0), seed=st.integers(0, 2**31 - 1))
def test_live_effective_work_equals_the_offline_product(ratio, distance_m, rho, lift_m_s, exponent, gradient,
                                                        factor, change_at, growth, interval_s, seed):
    rng = np.random.default_rng(seed)
    n = 40
    dt_s = rng.uniform(0.05, 2.0, n)
    t_s = T0_S + np.concatenate(([0.0], np.cumsum(dt_s)))
    t_ns = np.round(t_s * 1e9).astype(np.int64)
    t_s = t_ns * 1e-9                                     # the stamps the live model sees
    x = np.concatenate(([0.1], 0.1 + np.cumsum(rng.uniform(-0.3, 0.3, n))))
    load = rng.uniform(0.0, 5000.0, n)
    change_s = float(t_s[change_at])                      # t_c on a segment boundary: no segment straddles it
    params = wear_axis_params({
        "effects": EFFECTS, "running_in_ratio": ratio, "running_in_distance_m": distance_m,
        "retract_wear_factor": rho, "lift_speed_m_s": lift_m_s, "load_exponent": exponent,
        "load_reference_n": 1000.0, "load_gradient_per_m": gradient, "load_reference_position_m": 0.1,
        "wear_rate_change_factor": factor, "wear_rate_change_stamp_s": change_s,
        "lubrication_wear_growth": growth, "lubrication_interval_s": interval_s,
        "lubrication_reference_stamp_s": T0_S})
    e = EffectParameters.from_params(params)
    live = EffectWear(e, 3600.0, 4)
    ds = np.abs(np.diff(x))
    s_start = np.concatenate(([0.0], np.cumsum(ds)[:-1]))
    live.add_segments(t_ns[:-1], t_ns[1:], x[:-1], x[1:], load, s_start)

    # offline: the cell forms of the simulator and the discrepancy fit, combined by effect_multiplier
    mid_s, seg_s = 0.5 * (t_s[:-1] + t_s[1:]), np.diff(t_s)
    duty = (load_along_rail_factor(0.5 * (x[:-1] + x[1:]), gradient, 0.1)
            * wear_rate_change_factor(mid_s, seg_s, change_s, factor)
            * lubrication_interval_factor(mid_s - T0_S, interval_s, growth))
    ri = running_in_factor_mean(s_start, s_start + ds, ratio, distance_m)
    speed = ds / seg_s
    retract = np.sign(np.diff(x)) == e.retract_sign
    m = effect_multiplier(e, speed, np.maximum(load, 1e-12), retract, ri, duty)
    offline = float(np.sum(load * ds * m))
    assert live.effective_work_nm == pytest.approx(offline, rel=1e-9, abs=1e-9)
    # and the material factors alone are wear_rate_multiplier's (no duty, no running-in)
    plain = effect_multiplier(e, speed, np.maximum(load, 1e-12), retract)
    assert plain == pytest.approx(wear_rate_multiplier(e, speed, np.maximum(load, 1e-12), retract), rel=1e-15)


def test_a_parameter_of_an_effect_not_named_keeps_its_no_effect_value():
    values = {"running_in_ratio": 2.0, "retract_wear_factor": 0.5, "lift_speed_m_s": 0.2, "load_exponent": 1.5,
              "load_gradient_per_m": 0.3, "wear_rate_change_factor": 2.0, "wear_rate_change_stamp_s": 50.0,
              "lubrication_wear_growth": 0.1, "thermal_drift_m_per_k": 1e-6, "stroke_distribution_weight": 0.4}
    only = EffectParameters.from_params(wear_axis_params({**values, "effects": "running_in"}))
    assert only.running_in_ratio == 2.0
    assert (only.retract_wear_factor, only.lift_speed_m_s, only.load_exponent, only.load_gradient_per_m,
            only.wear_rate_change_factor, only.wear_rate_change_time_s, only.lubrication_wear_growth,
            only.thermal_drift_m_per_k, only.stroke_distribution_weight) == (
        1.0, np.inf, 1.0, 0.0, 1.0, np.inf, 0.0, 0.0, 0.0)
    every = EffectParameters.from_params(wear_axis_params({**values, "effects": EFFECTS
                                                           + ",thermal_drift,stroke_distribution"}))
    assert (every.retract_wear_factor, every.lift_speed_m_s, every.load_exponent, every.load_gradient_per_m,
            every.wear_rate_change_factor, every.wear_rate_change_time_s, every.lubrication_wear_growth,
            every.thermal_drift_m_per_k, every.stroke_distribution_weight) == (
        0.5, 0.2, 1.5, 0.3, 2.0, 50.0, 0.1, 1e-6, 0.4)
    assert EffectParameters.from_params(wear_axis_params(values)) is None        # no effect named
