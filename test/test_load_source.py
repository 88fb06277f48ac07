"""load_source model: the normal load of an axis without a load cell from its masses and its motion
(models/wear/load_model.py), against closed forms written here, and the remaining life of a bag replayed
without its load topic against the same bag replayed with it."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from guide_health.analysis.replay import analyse_bag
from guide_health.errors import InputError
from guide_health.io.bag.writer import write_machine_bag
from guide_health.models.wear.load_model import NormalLoadModel, normal_load_n
from guide_health.params import WEAR_MONITOR_DEFAULTS, WEAR_MONITOR_SCHEMA
from guide_health.params.simulation import REALISTIC_MOTION, SIMULATION_SCHEMA
from guide_health.params.typed import wear_axis_params
from guide_health.sim.machine import simulate_machine

G = 9.80665
MASSES = {"moving_mass_kg": 800.0, "workpiece_mass_kg": 200.0, "axis_incline_deg": 30.0, "load_lever_ratio": 0.5,
          "acceleration_window_s": 0.05}


def test_normal_load_closed_forms():
    """W = m g cos(theta) + |m (a + g sin(theta))| e / h: docs/machine.md's numbers."""
    assert normal_load_n(1000.0, 0.0, 0.0, 0.0) == pytest.approx(1000 * G, rel=1e-12)          # x table
    assert normal_load_n(600.0, math.pi / 2, 0.0, 0.35 / 0.5) == pytest.approx(600 * G * 0.7, rel=1e-12)  # z head
    assert normal_load_n(1000.0, 0.0, 2.0, 0.25) == pytest.approx(1000 * G + 1000 * 2.0 * 0.25, rel=1e-12)
    # decelerating a vertical head downwards at g: the drive carries nothing, no couple
    assert normal_load_n(600.0, math.pi / 2, -G, 0.7) == pytest.approx(0.0, abs=1e-9)


def test_acceleration_of_a_uniformly_accelerated_axis_is_exact():
    """x = a t^2 / 2 sampled evenly: both secants over the lag give a exactly once two lags have passed
    (v_i = a (t_i + t_j) / 2, v_i - v_j = a (t_i - t_jj) / 2 with t_i - t_jj = 2 (t_i - t_j))."""
    a = 1.7
    model = NormalLoadModel(1000.0, 0.0, 0.0, 1.0, 0.04)
    t_s = np.arange(0, 1.0, 0.004)
    loads = model.loads_n(1_700_000_000 * 10**9 + np.round(t_s * 1e9).astype(np.int64), 0.5 * a * t_s**2)
    assert loads[0] == pytest.approx(1000 * G, rel=1e-12)          # the first sample: a = 0
    np.testing.assert_allclose(loads[25:], 1000 * G + 1000 * a, rtol=1e-9)


def test_sample_by_sample_equals_arrays_in_any_chunks():
    """The live path (load_n per sample) and the offline path (loads_n over chunks) give the same numbers."""
    rng = np.random.default_rng(3)
    t = 1_700_000_000 * 10**9 + np.cumsum(rng.integers(1_000_000, 9_000_000, 2000))
    x = np.cumsum(rng.normal(0, 1e-4, t.size))
    live = NormalLoadModel(500.0, 50.0, 20.0, 0.4, 0.03)
    one = np.array([live.load_n(int(ti), float(xi)) for ti, xi in zip(t, x)])
    offline = NormalLoadModel(500.0, 50.0, 20.0, 0.4, 0.03)
    cuts = [0, 1, 2, 7, 300, 301, 1500, t.size]
    chunks = np.concatenate([offline.loads_n(t[a:b], x[a:b]) for a, b in zip(cuts, cuts[1:])])
    np.testing.assert_array_equal(one, chunks)


def test_model_needs_a_mass():
    p = dict(WEAR_MONITOR_DEFAULTS, load_source="model")
    with pytest.raises(InputError, match="moving_mass_kg"):
        WEAR_MONITOR_SCHEMA.validate(p)


def _bags(tmp_path, masses_truth: dict, duration_h: float):
    """A jerk-limited run of `duration_h` (no straightness measurements: K stays the prior, so the life is 1 / (K W v)
    and any error of the load shows in it), written twice: with the true loads at every joint stamp on
    guide/load, and without loads. The true loads: the closed form above with the acceleration of the
    noise-free twin's positions by central second differences (exact between the knots of the cubic
    pieces)."""
    sim = SIMULATION_SCHEMA.defaults()
    sim.update(REALISTIC_MOTION, duration_h=duration_h, measurement_interval_h=10.0)
    params = dict(WEAR_MONITOR_DEFAULTS)
    run = simulate_machine(params, sim, seed=5)
    twin = simulate_machine(params, dict(sim, encoder_noise_m=0.0), seed=5)
    dt = np.diff(twin.joint_t_ns) * 1e-9
    x = twin.joint_position_m
    acc = np.zeros(x.size)
    acc[1:-1] = 2 * ((x[2:] - x[1:-1]) / dt[1:] - (x[1:-1] - x[:-2]) / dt[:-1]) / (dt[1:] + dt[:-1])
    m = masses_truth["moving_mass_kg"] + masses_truth["workpiece_mass_kg"]
    theta = math.radians(masses_truth["axis_incline_deg"])
    truth = m * G * math.cos(theta) + np.abs(m * (acc + G * math.sin(theta))) * masses_truth["load_lever_ratio"]
    empty = np.zeros(0)
    topic = dataclasses.replace(run, load_t_ns=run.joint_t_ns.copy(), load_n=truth,
                                straightness_t_ns=empty.astype(np.int64), straightness_m=empty)
    silent = dataclasses.replace(topic, load_t_ns=empty.astype(np.int64), load_n=empty)
    return (write_machine_bag(topic, tmp_path / "topic"), write_machine_bag(silent, tmp_path / "silent"),
            float(np.mean(np.abs(acc))))


def test_model_without_load_topic_matches_the_load_topic(tmp_path):
    """A 7.5 min run (112 500 joint samples at 250 Hz; as the 15 min and 1 h ones: model - topic -5e-6 (15 min
    7e-7), the moving mass 20 % heavy -16.8 % (15 min -16.9 %))."""
    check_model_against_the_load_topic(_bags(tmp_path, MASSES, 0.125))


@pytest.mark.slow
def test_model_without_load_topic_matches_the_load_topic_1h(tmp_path):
    check_model_against_the_load_topic(_bags(tmp_path, MASSES, 1.0))


def check_model_against_the_load_topic(bags) -> None:
    """Remaining life with load_source model and no load topic within 5 % of the same bag with its loads;
    the status names the source; a 20 % mass error is outside 5 % (the comparison can fail)."""
    topic_bag, silent_bag, mean_acc = bags
    assert mean_acc > 0.01                            # the motion accelerates: the inertia term is exercised
    base = dict(WEAR_MONITOR_DEFAULTS)
    _, with_topic, _ = analyse_bag(topic_bag, base)
    _, with_model, _ = analyse_bag(silent_bag, dict(base, load_source="model", **MASSES))
    life_topic, life_model = with_topic["remaining_life_h"], with_model["remaining_life_h"]
    assert with_topic["load_source"] == "topic" and with_model["load_source"] == "model"
    assert math.isfinite(life_topic) and life_topic > 0
    assert life_model == pytest.approx(life_topic, rel=0.05)
    _, heavy, _ = analyse_bag(silent_bag, dict(base, load_source="model", **dict(MASSES, moving_mass_kg=1000.0)))
    assert abs(heavy["remaining_life_h"] / life_topic - 1.0) > 0.10
    # without the model the silent bag has no load: no wear estimate, no life
    _, silent, _ = analyse_bag(silent_bag, base)
    assert math.isnan(silent["remaining_life_h"])


def test_live_feed_one_by_one_equals_batches():
    """The node's two paths with load_source model: StampAlignedFeed.joint per message and .process per batch
    integrate every accepted sample at once with the model's load (nothing waits for a load topic)."""
    from guide_health.models.wear.axis import AxisMonitor
    from guide_health.models.wear.feed import StampAlignedFeed

    params = dict(WEAR_MONITOR_DEFAULTS, load_source="model", **MASSES)
    t = 1_700_000_000 * 10**9 + np.arange(4000, dtype=np.int64) * 20_000_000
    x = 0.1 + 0.1 * np.sin(np.arange(4000) * 0.02)
    one, many = AxisMonitor(wear_axis_params(params)), AxisMonitor(wear_axis_params(params))
    feed_one, feed_many = StampAlignedFeed(one, 0.5), StampAlignedFeed(many, 0.5)
    for ti, xi in zip(t.tolist(), x.tolist()):
        feed_one.joint(ti, xi, 0.0, 0.0)
    assert not feed_one.pending and one.guides["guide"].integrator.samples == t.size
    empty = np.zeros(0)
    for a in range(0, t.size, 700):
        feed_many.process(t[a:a + 700], x[a:a + 700], np.zeros(x[a:a + 700].size), np.zeros(x[a:a + 700].size),
                          empty.astype(np.int64), empty, empty, [])
    r1, r2 = one.report(), many.report()
    assert r1["sliding_distance_m"] == pytest.approx(r2["sliding_distance_m"], rel=1e-12)
    assert r1["wear_volume_mm3"] > 0 and r1["wear_volume_mm3"] == pytest.approx(r2["wear_volume_mm3"], rel=1e-12)
