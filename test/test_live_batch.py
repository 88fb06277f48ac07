"""Live batching (issue 14): StampAlignedFeed.process (the node's batches: samples copied in the callbacks,
validated, aligned and integrated per batch through AxisMonitor.integrate_many) gives the numbers of the
sample-by-sample feed (joint()/load() on arrival), on seeded streams with everything that makes the order
matter: loads overtaking joint samples and arriving late, arrival gaps longer than the window (aged
samples), bad samples of every input rule (one load rejected by one guide's share only), a regrind and a
measure event stamped in the middle of a batch, straightness measurements between batches, a resumed load
state, two guides with unequal shares, the profile model, a rolling guide with temperatures and the live wear
effects."""
import functools
import math
from pathlib import Path

import numpy as np
import pytest

from guide_health.models.wear.axis import AxisMonitor
from guide_health.models.wear.feed import StampAlignedFeed
from guide_health.models.wear.input_rules import StampBase
from guide_health.models.wear.maintenance import MaintenanceEvent
from guide_health.params import machine_axes_params
from guide_health.params.typed import wear_axis_params

ROOT = Path(__file__).resolve().parents[1]
T0_NS = 1_700_000_000_000_000_000
MS = 1_000_000
REL = 1e-12
COMPARED = ("wear_volume_mm3", "straightness_um", "wear_coefficient", "wear_coefficient_low",
            "wear_coefficient_high", "remaining_life_h", "remaining_life_h_low", "remaining_life_h_high",
            "sliding_distance_m", "duty_load_speed_w")
EXACT = ("samples", "load_samples", "measurements", "strokes", "rejected_samples", "rejected_recent_share",
         "samples_missing_estimate", "joint_period_estimate_us", "stroke_min_m", "stroke_max_m")
#: joint samples per stream (100 Hz): 30 s and 20 s hold 3 and 2 standstills, the 6 arrival gaps, the 4
#: measurements, both events and every bad sample (the batches equal the sample-by-sample feed at any length)
N_TWO_GUIDES, N_VARIANT = 3000, 2000


def stream(seed: int, n: int, load_max_primary_n: float):
    """Events (arrival s, kind, values) in arrival order: 100 Hz joints (triangular strokes with 3 um
    jitter and standstills), 50 Hz loads 2-20 kN whose delay against the joints swings from 40 ms early to
    60 ms late (overtaking both ways), bad samples, 6 arrival gaps of 0.7 s (> the 0.5 s window),
    straightness measurements and a regrind / a measure event scheduled ahead of their stamps."""
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    t = T0_NS + k * 10 * MS
    phase = (k * 0.004) % 0.8
    x = 0.05 + np.where((k // 200) % 5 == 4, 0.2, np.abs(phase / 0.4 - 1.0) * 0.4)
    x = x + rng.normal(0.0, 3e-6, n)
    x[rng.choice(n, 8, replace=False)] = math.nan
    x[rng.choice(n, 5, replace=False)] = 9.0                              # out of travel
    back = rng.choice(np.arange(10, n), 6, replace=False)
    t[back] = t[back - 4]                                                 # time going backwards
    joint_arrival = (t - T0_NS) * 1e-9 + rng.uniform(0.0, 2e-3, n)
    lt = T0_NS + np.arange(10, n // 2) * 20 * MS + 5 * MS          # the first 0.2 s without a load
    lw = rng.uniform(2000.0, 20000.0, lt.size)
    lw[rng.choice(np.arange(20, lt.size), 4, replace=False)] = math.nan
    lw[rng.choice(np.arange(20, lt.size), 3, replace=False)] = 1e12
    share_only = np.concatenate(([0], rng.choice(np.arange(20, lt.size), 2, replace=False)))
    lw[share_only] = load_max_primary_n * 1.05         # too big for the primary's share only (the first load)
    lag = 0.01 + 0.05 * np.sin(np.arange(lt.size) / 37.0)
    load_arrival = (lt - T0_NS) * 1e-9 + lag
    events = [(a, "joint", (int(ti), float(xi))) for a, ti, xi in zip(joint_arrival, t, x)]
    events += [(a, "load", (int(ti), float(wi))) for a, ti, wi in zip(load_arrival, lt, lw)]
    span = n * 0.01
    for a in (0.2 * span, 0.28 * span, 0.5 * span, 0.8 * span):       # 2 before the regrind, 2 after
        events.append((a, "straightness", float(rng.uniform(6e-6, 9e-6))))
    events.append((0.30 * span, "event", MaintenanceEvent(T0_NS + int(0.35 * span * 1e9), "regrind", "y", "",
                                                          7e-6, "test")))
    events.append((0.60 * span, "event", MaintenanceEvent(T0_NS + int(0.62 * span * 1e9), "measure", "y",
                                                          "front", 8e-6, "test")))
    for a in rng.uniform(0.0, span, 30):
        events.append((a, "timer", None))
    for a in rng.uniform(0.0, span, 20):
        events.append((a, "temperature", (T0_NS + int(a * 1e9), float(rng.uniform(20.0, 40.0)))))
    events.sort(key=lambda e: e[0])
    gaps = np.zeros(len(events))
    gaps[rng.choice(len(events), 6, replace=False)] = 0.7                # the process stalled: samples age
    shift = np.cumsum(gaps)
    return [(a + s, kind, v) for (a, kind, v), s in zip(events, shift.tolist())]


def run(params, events, batch: int, resumed: bool):
    model = AxisMonitor(wear_axis_params(params))
    if resumed:                       # a node resumed with a saved load: samples before the first new load
        model.gate.load_n, model.gate.load_t_ns = 5000.0, T0_NS - 10**9      # each guide its share of it
        model.gate.load_base = StampBase(T0_NS - 10**9)
    feed = StampAlignedFeed(model, 0.5)
    buf = {"joint": [], "load": [], "after": []}
    reasons = []

    def flush():
        if batch and (buf["joint"] or buf["load"]):
            j = np.array(buf["joint"], dtype=object).reshape(-1, 3)
            ld = np.array(buf["load"], dtype=object).reshape(-1, 3)
            reasons.extend(feed.process(j[:, 0].astype(np.int64), j[:, 1].astype(float), np.zeros(len(j)),
                                        j[:, 2].astype(float), ld[:, 0].astype(np.int64), ld[:, 1].astype(float),
                                        ld[:, 2].astype(float), buf["after"]))
            buf["joint"], buf["load"], buf["after"] = [], [], []

    for now, kind, value in events:
        if kind in ("joint", "load") and batch:
            if kind == "load":
                buf["after"].append(len(buf["joint"]))
            buf[kind].append((*value, now))
            if len(buf["joint"]) + len(buf["load"]) >= batch:
                flush()
            continue
        flush()
        if kind == "joint":
            reasons.extend(feed.joint(*value, 0.0, now))
        elif kind == "load":
            reasons.extend(feed.load(*value, now))
        elif kind == "straightness":                     # AxisChannel.on_straightness
            reasons.extend(feed.flush_all())
            if model.last_t_ns is not None:
                model.on_straightness(model.last_t_ns, value)
        elif kind == "event":
            model.schedule(value)
        elif kind == "timer":                            # the diagnostics timer
            reasons.extend(feed.flush_aged(now))
        else:
            model.on_temperature(*value)
    flush()
    reasons.extend(feed.flush_all())
    model.batches = feed.batches          # [without, with the event loop] (StampAlignedFeed._align_fast)
    return model, reasons


def assert_same(one: AxisMonitor, many: AxisMonitor, reasons_one, reasons_many, n: int):
    assert reasons_one == reasons_many and len(reasons_one) >= 20
    assert [e.key for e in one.events] == [e.key for e in many.events] and len(one.events) == 2
    for name in one.guides:
        a, b = one.guide(name), many.guide(name)
        ra, rb = a.report(), b.report()
        assert ra["measurements"] >= 2 and ra["samples"] > 0.9 * n
        for key in COMPARED:
            assert rb[key] == pytest.approx(ra[key], rel=REL, nan_ok=True), (name, key)
        for key in EXACT:
            assert rb[key] == ra[key] or (math.isnan(ra[key]) and math.isnan(rb[key])), (name, key)
        assert dict(a.rejected) == dict(b.rejected)
        assert {k: list(v) for k, v in a.recent.items()} == {k: list(v) for k, v in b.recent.items()}
        assert (a.load_n, a.load_t_ns, a.joint_base, a.load_base) == (b.load_n, b.load_t_ns, b.joint_base,
                                                                      b.load_base)
        np.testing.assert_allclose(b.estimator.measurement_work_nm, a.estimator.measurement_work_nm, rtol=REL)
        np.testing.assert_allclose(b.integrator.profile_work_n, a.integrator.profile_work_n, rtol=1e-9,
                                   atol=1e-12 * a.integrator.profile_work_n.max())
        assert a.stream_gaps.values() == b.stream_gaps.values()
        if a.rolling is not None:
            fa, fb = a.fatigue_report(), b.fatigue_report()
            for key in ("equivalent_load_n", "travel_km", "life_used_fraction"):
                assert fb[key] == pytest.approx(fa[key], rel=REL), key


def axis_params(**overrides):
    p = dict(machine_axes_params(ROOT / "config" / "machine_xyz.yaml")["y"])    # two ways, shares 0.545/0.455
    p.update(wear_coefficient=4e-6, straightness_limit_m=60e-6, load_max_n=15000.0, **overrides)
    return p


@functools.lru_cache(maxsize=2)
def two_guides_sample_by_sample(resumed: bool) -> tuple:
    """(params, events, the sample-by-sample monitor, its rejections): one reference per `resumed`, shared by
    the batch sizes (read only: the tests compare reports)."""
    params = axis_params()
    events = stream(3, N_TWO_GUIDES, params["load_max_n"] / params["guide_load_shares"][0])
    return (params, events, *run(params, events, 0, resumed))


@pytest.mark.parametrize("batch", [3, 64, 100000])
@pytest.mark.parametrize("resumed", [False, True])
def test_batches_equal_sample_by_sample_two_guides(batch, resumed):
    params, events, one, r1 = two_guides_sample_by_sample(resumed)
    many, rn = run(params, events, batch, resumed)
    assert_same(one, many, r1, rn, N_TWO_GUIDES)
    assert one.batches == [0, 0] and min(many.batches) >= (1 if batch < 10**5 else 0)   # both ways taken
    # the axis's gate judges a load once, at the first guide's share: 3 huge + 3 too big for that share
    assert one.rejected["load above the plausible maximum"] == 6
    for name in one.guides:
        assert one.guide(name).report()["rejected: load above the plausible maximum"] == 6


@pytest.mark.parametrize("variant", ["profile", "rolling", "effects"])
def test_batches_equal_sample_by_sample_profile_rolling_effects(variant):
    if variant == "profile":
        params = axis_params(straightness_model="profile")
    elif variant == "effects":            # the effect-aware live model (segments to EffectWear)
        params = axis_params(effects="running_in,retract_asymmetry,load_exponent", running_in_ratio=2.0,
                             retract_wear_factor=0.5, load_exponent=1.3)
    else:
        nsk = machine_axes_params(ROOT / "config" / "nsk_lh45.yaml")
        params = dict(next(iter(nsk.values())), axis="y", guides=["front", "rear"],
                      guide_load_shares=[0.6, 0.4], load_max_n=15000.0, straightness_limit_m=60e-6)
    events = stream(8, N_VARIANT, params["load_max_n"] / params["guide_load_shares"][0])
    one, r1 = run(params, events, 0, False)
    many, rn = run(params, events, 50, False)
    assert_same(one, many, r1, rn, N_VARIANT)
    assert (many.primary.effect_wear is not None) == (variant == "effects")


# --- the node: raw callbacks copy, batches handled at process_inputs ------------------------------------
def test_node_batches_equal_the_per_message_path_with_bad_messages_inside(ros_context, tmp_path):
    """Two wear_monitor nodes in-process, fed the same messages in the same order: one through the
    deserialised callbacks (every message on arrival), one through the raw callbacks (copied, decoded and
    integrated in batches of 50, split at the messages the batch decoder does not take: a JointState
    without the joint, empty arrays, positions shorter than names, an invalid nanosec, and at straightness
    messages). Loads arrive 50 ms late or 30 ms early. Same state to 1e-12, same rejection counts and
    recent windows."""
    pytest.importorskip("rclpy")
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Float64
    from test_wear_monitor_node import assert_same_state, joint, load, make_node

    nodes = [make_node(ros_context, tmp_path / name, input_align_window_s=60.0) for name in ("a", "b")]
    per_message, batched = nodes
    batched.batch_messages = 50
    rng = np.random.default_rng(4)
    messages = []                                   # ("joint" | "load" | "straightness", message)
    x, direction = 0.0, 1.0
    for k in range(1500):
        t = T0_NS * 1e-9 + 0.02 * k
        x += direction * 0.001
        if not 0.0 < x < 0.3:
            direction = -direction
        messages.append(("joint", joint(t, [x], velocity=[0.05 * direction])))
        if k % 5 == 0:
            lag = 0.05 if (k // 5) % 2 else -0.03
            messages.append(("load", load(t - lag, float(rng.uniform(2000.0, 9000.0)))))
        if k in (300, 900, 1400):
            messages.append(("straightness", Float64(data=6e-6 + k * 1e-9)))
    bad_joint = [joint(0, [0.1], names=("y",)), joint(0, [], names=()), joint(0, [], names=("x",)),
                 joint(0, [0.1, 0.2], names=("z", "x"))]
    for at, msg in zip((101, 102, 555, 556), bad_joint):
        t = messages[at][1].header.stamp
        msg.header.stamp.sec, msg.header.stamp.nanosec = t.sec, t.nanosec + 1000
        messages.insert(at + 1, ("joint", msg))
    late = joint(T0_NS * 1e-9 + 0.02 * 700 + 0.001, [0.1])
    late.header.stamp.nanosec = 4_000_000_000
    messages.insert(800, ("joint", late))
    bad_load = load(T0_NS * 1e-9 + 10.0, 5000.0)
    bad_load.header.stamp.nanosec = 4_000_000_000
    messages.insert(1200, ("load", bad_load))
    messages.insert(1300, ("load", load(T0_NS * 1e-9 + 9.0, math.nan)))
    try:
        for kind, msg in messages:
            if kind == "straightness":
                for node in nodes:
                    node._on_straightness(msg)
            elif kind == "joint":
                per_message._on_joint(msg)
                batched._on_joint_raw(serialize_message(msg))
            else:
                per_message._on_load(msg)
                batched._on_load_raw(serialize_message(msg))
        for node in nodes:
            node.process_inputs()
            node.rejections.log_all(node.feed.flush_all())
        a, b = per_message.monitor, batched.monitor
        assert_same_state(a.state(), b.state())
        assert dict(a.rejected) == dict(b.rejected) and a.rejected.total == 6
        assert {k: list(v) for k, v in a.recent.items()} == {k: list(v) for k, v in b.recent.items()}
        ra, rb = a.report(), b.report()
        for key in COMPARED:
            assert rb[key] == pytest.approx(ra[key], rel=REL, nan_ok=True), key
        assert ra["measurements"] == 3 and ra["samples"] == 1501 and ra["load_samples"] == 300
        assert batched.feed.batches[0] >= 20 and batched._callbacks == len(messages) - 3
    finally:
        for node in nodes:
            node.close()
            node.destroy_node()
