"""Issue 10 (items 1, 2, 3, 6): one bad value never disables the monitor, implausible values are rejected
alike live and offline, a measurement is applied once, the raw decode path rejects what the deserialised
path rejects.

The run is the seed-000 bench (config/bench_000.yaml) simulated for 0.5 h at 10 Hz with straightness every
3.75 min (9 measurements; each rule acts per sample, so a longer run adds only time: the live path feeds
18000 samples one by one); every test compares a run with a bad sample against the same run without it.
"""
from __future__ import annotations

import contextlib
import io
import json
import math
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from guide_health.models.levels import Level
from guide_health.models.wear.feed import StampAlignedFeed
from guide_health.models.wear.input_rules import (
    INVALID_STAMP,
    JOINT_STAMP_JUMP,
    LOAD_ABOVE_MAX,
    LOAD_STAMP_JUMP,
    MEASUREMENT_ALREADY_APPLIED,
    NON_FINITE_JOINT,
    POSITION_OUT_OF_TRAVEL,
    STRAIGHTNESS_ABOVE_MAX,
    RejectionCounter,
    header_stamp_ns,
)
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.params import simulation_params, wear_monitor_params
from guide_health.params.typed import wear_axis_params
from guide_health.runs import MachineRun
from guide_health.sim.machine import simulate_machine

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "config" / "bench_000.yaml"
PARAMS = wear_monitor_params(BENCH)
FUTURE_NS = (2**31 - 1) * 1_000_000_000          # sec = 2^31 - 1, the largest header stamp
REPORT_NUMBERS = ("wear_coefficient", "wear_coefficient_low", "wear_coefficient_high", "remaining_life_h",
                  "straightness_um", "sliding_distance_m", "stroke_min_m", "stroke_max_m", "samples",
                  "load_samples", "measurements")


@pytest.fixture(scope="module")
def bench_run() -> MachineRun:
    sim = simulation_params(BENCH)
    sim.update(duration_h=0.5, joint_state_rate_hz=10.0, load_rate_hz=10.0, measurement_interval_h=0.0625)
    return simulate_machine(PARAMS, sim, seed=4)


def insert(run: MachineRun, topic: str, index: int, t_ns: int, value: float) -> MachineRun:
    """The run with one sample inserted at ``index`` of a topic (joint: position, velocity 0)."""
    if topic == "joint":
        return replace(run, joint_t_ns=np.insert(run.joint_t_ns, index, t_ns),
                       joint_position_m=np.insert(run.joint_position_m, index, value),
                       joint_velocity_m_s=np.insert(run.joint_velocity_m_s, index, 0.0)
                       if run.joint_velocity_m_s.size else run.joint_velocity_m_s)
    if topic == "load":
        return replace(run, load_t_ns=np.insert(run.load_t_ns, index, t_ns), load_n=np.insert(run.load_n, index, value))
    return replace(run, straightness_t_ns=np.insert(run.straightness_t_ns, index, t_ns),
                   straightness_m=np.insert(run.straightness_m, index, value))


def bag_order(run: MachineRun) -> list[tuple[int, int, int]]:
    """(stamp, kind 0 load | 1 straightness | 2 joint, index) in bag order: by stamp (of one stamp: loads,
    joint samples, measurements), a future-stamped outlier where it was inserted."""
    events = ([(int(t), 0, i) for i, t in enumerate(run.load_t_ns)]
              + [(int(t), 1, i) for i, t in enumerate(run.straightness_t_ns)]
              + [(int(t), 2, i) for i, t in enumerate(run.joint_t_ns)])
    return sorted(events, key=lambda e: (_log_t(run, e), (0, 2, 1)[e[1]]))


def batch(run: MachineRun, pieces: int = 1, restart: bool = False) -> PrecisionMonitor:
    """process_run over ``pieces`` consecutive chunks of the bag order; ``restart``: the state goes through
    JSON and a new monitor between chunks, as a node restart does (rejections summed over the runs)."""
    monitor = PrecisionMonitor(wear_axis_params(PARAMS))
    rejected = Counter()
    events = bag_order(run)
    cuts = np.linspace(0, len(events), pieces + 1).astype(int)
    velocity = run.joint_velocity_m_s if run.joint_velocity_m_s.size else np.zeros(run.joint_t_ns.size)
    for a, b in zip(cuts[:-1], cuts[1:]):
        take = [np.array([i for _, kind, i in events[a:b] if kind == k], dtype=np.int64) for k in (0, 1, 2)]
        lo, me, jo = take
        part = MachineRun("x", run.joint_t_ns[jo], run.joint_position_m[jo], velocity[jo],
                          run.load_t_ns[lo], run.load_n[lo], run.straightness_t_ns[me], run.straightness_m[me])
        if restart and a:
            rejected.update(monitor.rejected)
            state = json.loads(json.dumps(monitor.state()))
            monitor = PrecisionMonitor(wear_axis_params(PARAMS))
            monitor.restore(state)
        monitor.process_run(part)
    rejected.update(monitor.rejected)
    monitor.rejected = RejectionCounter(rejected)
    return monitor


def live(run: MachineRun) -> PrecisionMonitor:
    """Sample by sample through StampAlignedFeed (window 0.5 s) in bag order."""
    monitor = PrecisionMonitor(wear_axis_params(PARAMS))
    feed = StampAlignedFeed(monitor.axis, 0.5)
    v = run.joint_velocity_m_s if run.joint_velocity_m_s.size else np.zeros(run.joint_t_ns.size)
    for n, (t, kind, i) in enumerate(bag_order(run)):
        now = n * 1e-3
        if kind == 0:
            feed.load(t, float(run.load_n[i]), now)
        elif kind == 1:
            feed.flush_all()
            monitor.on_straightness(t, float(run.straightness_m[i]))
        else:
            feed.joint(t, float(run.joint_position_m[i]), float(v[i]), now)
    feed.flush_all()
    return monitor


def _log_t(run: MachineRun, event) -> int:
    """A sample's place in the bag: its stamp; a future-stamped outlier where it was inserted."""
    t, kind, i = event
    if t >= FUTURE_NS and i > 0:
        return int((run.load_t_ns, run.straightness_t_ns, run.joint_t_ns)[kind][i - 1]) + 1
    return t


def numbers(monitor: PrecisionMonitor) -> dict:
    report = monitor.report()
    return {k: report[k] for k in REPORT_NUMBERS}


def assert_same_numbers(a: dict, b: dict):
    for key in REPORT_NUMBERS:
        assert a[key] == pytest.approx(b[key], rel=1e-9), key


# --- item 1: one future stamp ------------------------------------------------------------------------
def test_one_future_joint_stamp_does_not_disable_the_monitor_nor_survive_a_restart(bench_run):
    clean = numbers(batch(bench_run))
    assert clean["samples"] == bench_run.joint_t_ns.size and clean["measurements"] == 9
    k = bench_run.joint_t_ns.size // 3
    bad = insert(bench_run, "joint", k, FUTURE_NS, float(bench_run.joint_position_m[k]))
    for monitor in (batch(bad), batch(bad, pieces=3), batch(bad, pieces=3, restart=True), live(bad)):
        assert dict(monitor.rejected) == {JOINT_STAMP_JUMP: 1}
        assert_same_numbers(numbers(monitor), clean)
        assert monitor.report()["level"] == Level.OK


def test_a_genuine_restart_after_a_long_pause_is_a_new_time_base(bench_run):
    """The second half of the run 30 h later: 2 joint and 2 load samples wait for agreement (rejected),
    the third of each starts the new time base; the distance across the pause counts as one segment."""
    half = bench_run.joint_t_ns.size // 2
    t_split = bench_run.joint_t_ns[half]
    pause = 30 * 3600 * 10**9

    def later(t):
        return np.where(t >= t_split, t + pause, t)

    shifted = replace(bench_run, joint_t_ns=later(bench_run.joint_t_ns), load_t_ns=later(bench_run.load_t_ns),
                      straightness_t_ns=later(bench_run.straightness_t_ns))
    for monitor in (batch(shifted), batch(shifted, pieces=4, restart=True), live(shifted)):
        assert dict(monitor.rejected) == {JOINT_STAMP_JUMP: 2, LOAD_STAMP_JUMP: 2}
        assert monitor.integrator.samples == bench_run.joint_t_ns.size - 2
        assert monitor.estimator.count == 9
        assert monitor.integrator.last_t_ns == shifted.joint_t_ns[-1]


def test_mostly_rejected_input_is_warn_naming_the_reason(bench_run):
    """Never OK with most input rejected: the last 60 % of the joint samples 5 m off the rail."""
    x = bench_run.joint_position_m.copy()
    x[int(0.4 * x.size):] += 5.0
    bad = replace(bench_run, joint_position_m=x)
    reports = [m.report() for m in (batch(bad), batch(bad, pieces=5), live(bad))]
    for report in reports:
        assert report["level"] == Level.WARN
        assert f"100% of the last 1000 joint_states samples rejected ({POSITION_OUT_OF_TRAVEL})" in report["message"]
        assert report["rejected_recent_share"] == 1.0
        assert report[f"rejected: {POSITION_OUT_OF_TRAVEL}"] == x.size - int(0.4 * x.size)
    assert reports[0]["message"] == reports[1]["message"] == reports[2]["message"]


# --- item 2: huge finite values ----------------------------------------------------------------------
@pytest.mark.parametrize("topic, value, reason", [
    ("joint", 1e300, POSITION_OUT_OF_TRAVEL),
    ("load", 1e308, LOAD_ABOVE_MAX),
    ("straightness", 1.0, STRAIGHTNESS_ABOVE_MAX),
])
def test_huge_finite_values_are_rejected_alike_live_and_offline(bench_run, topic, value, reason):
    clean = numbers(batch(bench_run))
    stamps = {"joint": bench_run.joint_t_ns, "load": bench_run.load_t_ns,
              "straightness": bench_run.straightness_t_ns}[topic]
    k = stamps.size // 2
    bad = insert(bench_run, topic, k, int(stamps[k - 1] + stamps[k]) // 2, value)
    for monitor in (batch(bad), batch(bad, pieces=3, restart=True), live(bad)):
        assert dict(monitor.rejected) == {reason: 1}
        assert_same_numbers(numbers(monitor), clean)


def test_rolling_guide_load_limit_is_a_multiple_of_the_rating():
    params = wear_monitor_params(ROOT / "config" / "nsk_lh45.yaml")
    monitor = PrecisionMonitor(wear_axis_params(params))
    c = params["dynamic_load_rating_n"] * params["carriages"]
    assert monitor.limits.load_max_n == pytest.approx(params["load_max_rating_multiple"] * c)
    assert monitor.on_load(1, 2.9 * c) is None
    assert monitor.on_load(2, 3.1 * c) == LOAD_ABOVE_MAX


@pytest.mark.parametrize("case", ["loads_1e308", "position_1e300"])
def test_diagnose_with_huge_values_is_no_traceback(bench_run, tmp_path, case):
    """On main both bags made `diagnose` exit 1 with a traceback (the fit found no finite optimum): main() in
    this process (what the console script runs) returns 0 and prints one JSON object."""
    from guide_health.cli.app import main
    from guide_health.io.bag.writer import write_machine_bag

    if case == "loads_1e308":
        w = bench_run.load_n.copy()
        w[w.size // 2:] = 1e308
        bad = replace(bench_run, load_n=w)
    else:
        x = bench_run.joint_position_m.copy()
        x[x.size // 2] = 1e300
        bad = replace(bench_run, joint_position_m=x)
    write_machine_bag(bad, tmp_path / "bag")
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        code = main(["diagnose", str(tmp_path / "bag"), "--params", str(BENCH), "--out", str(tmp_path / "rep"),
                     "--json"])
    assert code == 0, stderr.getvalue()
    out = json.loads(stdout.getvalue())
    assert math.isfinite(out["final"]["rmse_um"]) and out["final"]["rmse_um"] < 5.0


# --- item 3: a measurement is applied once -------------------------------------------------------------
def test_resumed_node_does_not_apply_the_last_measurement_again(bench_run):
    """The node dates a straightness message by the last joint stamp; after a restart from a checkpoint
    taken right after a measurement, `bag_player --start-after-ns <checkpoint stamp>` plays that
    measurement again, dated by the same joint stamp: it is applied once however often that happens."""
    reference = live(bench_run)
    expected = numbers(reference)
    monitor = reference
    for _ in range(5):          # five restarts, each replaying the last measurement
        state = json.loads(json.dumps(monitor.state()))
        monitor = PrecisionMonitor(wear_axis_params(PARAMS))
        monitor.restore(state)
        t_last = monitor.estimator.measurement_t_ns[-1]
        assert monitor.on_straightness(t_last, float(bench_run.straightness_m[-1])) == MEASUREMENT_ALREADY_APPLIED
        # offline: a chunk that starts with the same measurement again
        monitor.process_run(MachineRun("x", straightness_t_ns=np.array([t_last], dtype=np.int64),
                                       straightness_m=bench_run.straightness_m[-1:]))
        assert monitor.rejected == {MEASUREMENT_ALREADY_APPLIED: 2}
        assert_same_numbers(numbers(monitor), expected)
    assert monitor.estimator.count == 9


# --- item 6: the raw decode path -------------------------------------------------------------------------
def test_header_stamp_rule():
    assert header_stamp_ns(5, 999_999_999) == 5_999_999_999
    assert header_stamp_ns(5, 1_000_000_000) is None and header_stamp_ns(5, 4_000_000_000) is None


@pytest.mark.parametrize("path", ["message", "raw"])
def test_nan_velocity_and_nanosec_beyond_a_second_are_rejected_on_both_paths(ros_context, tmp_path, path):
    pytest.importorskip("rclpy")
    from test_wear_monitor_node import T0, feed_cycle, joint, load, make_node, raw_then_batch, snapshot

    node = make_node(ros_context, tmp_path)
    on_joint, on_load = node._on_joint, node._on_load
    if path == "raw":
        on_joint = lambda m: raw_then_batch(node, node._on_joint_raw, m)  # noqa: E731
        on_load = lambda m: raw_then_batch(node, node._on_load_raw, m)  # noqa: E731
    try:
        t = feed_cycle(node, T0 + 1.0)
        before = snapshot(node)
        on_joint(joint(t + 0.5, [0.05], velocity=[math.nan]))
        late = joint(t + 0.5, [0.05])
        late.header.stamp.nanosec = 4_000_000_000
        on_joint(late)
        heavy = load(t + 0.5, 6000.0)
        heavy.header.stamp.nanosec = 4_000_000_000
        on_load(heavy)
        assert snapshot(node) == before
        assert dict(node.monitor.rejected) == {NON_FINITE_JOINT: 1, INVALID_STAMP: 2}
        on_joint(joint(t + 0.5, [0.05]))               # no velocity array: velocity 0, accepted
        assert snapshot(node) != before
    finally:
        node.close()
        node.destroy_node()


def test_a_missing_joint_is_named_in_the_status(bench_run):
    """Offline, a bag without the monitored joint used to say only "waiting for motion"; live, the
    JointState messages without it are rejected and named as the dominant reason."""
    offline = PrecisionMonitor(wear_axis_params(PARAMS))
    offline.process_run(MachineRun("x", load_t_ns=bench_run.load_t_ns, load_n=bench_run.load_n))
    report = offline.report()
    assert report["level"] == Level.WARN
    assert report["message"] == "no wear estimate yet: no joint_states sample of joint 'x' accepted"
    live_monitor = PrecisionMonitor(wear_axis_params(PARAMS))
    for _ in range(10):
        live_monitor.reject_input("joint_states", "joint 'x' not in joint_states")
    assert live_monitor.report()["message"].startswith(
        "100% of the last 10 joint_states samples rejected (joint 'x' not in joint_states) > rejected_share_warn "
        "50%; no wear estimate yet")
