"""wear_monitor node adapter in-process: bad input rejected without touching state, diagnostics keys and
levels, STALE on silent inputs, SQLite checkpoints."""
import math
from pathlib import Path

import pytest

rclpy = pytest.importorskip("rclpy")
from geometry_msgs.msg import WrenchStamped  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.serialization import serialize_message  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from guide_health.nodes.wear_monitor import PRECISION_KEYS, WearMonitorNode  # noqa: E402

T0 = 1_700_000_000


def make_node(context, tmp_path: Path, **overrides):
    params = {"state_file": str(tmp_path / "state.db"), "joint": "x", "machine_id": "m1",
              "straightness_limit_m": 100e-6, "input_timeout_s": 5.0,
              "input_align_window_s": 0.0}   # integrate on arrival (StampAlignedFeed is tested on its own)
    params.update(overrides)
    node = WearMonitorNode(context=context,
                           parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
    node.published = []
    node.diag_pub.publish = node.published.append
    return node


def joint(t_s: float, position, names=("x",), velocity=None):
    msg = JointState()
    msg.header.stamp.sec = int(t_s)
    msg.header.stamp.nanosec = int(round((t_s - int(t_s)) * 1e9))
    msg.name = list(names)
    msg.position = list(position)
    msg.velocity = list(velocity) if velocity is not None else []
    return msg


def load(t_s: float, force_z: float):
    msg = WrenchStamped()
    msg.header.stamp.sec = int(t_s)
    msg.header.stamp.nanosec = int(round((t_s - int(t_s)) * 1e9))
    msg.wrench.force.z = force_z
    return msg


def feed_cycle(node, t_start: float, strokes=(0.1, 0.3, 0.2), dt=0.02, speed=0.05):
    """Feed strokes home -> L -> home at ``speed`` with 6000 N; returns the end time."""
    t = t_start
    node._on_load(load(t, 6000.0))
    x = 0.0
    t += dt
    node._on_joint(joint(t, [x]))
    for stroke in strokes:
        for target in (stroke, 0.0):
            while abs(target - x) > 1e-12:
                step = min(speed * dt, abs(target - x))
                x += step if target > x else -step
                t += dt
                node._on_joint(joint(t, [x]))
    return t


def raw_then_batch(node, callback, msg):
    """The events-executor path for one message: the raw callback copies it, the batch handles it."""
    callback(msg if isinstance(msg, bytes) else serialize_message(msg))
    node.process_inputs()


def snapshot(node):
    state = node.monitor.state()
    state["integrator"] = {k: (list(v) if isinstance(v, list) else v) for k, v in state["integrator"].items()}
    return repr(state)


@pytest.mark.parametrize("path", ["message", "raw"])
def test_bad_input_is_rejected_and_never_changes_state(ros_context, tmp_path, path):
    node = make_node(ros_context, tmp_path)
    if path == "raw":        # the events-executor path: raw CDR decoded at fixed offsets
        on_joint = lambda m: raw_then_batch(node, node._on_joint_raw, m)  # noqa: E731
        on_load = lambda m: raw_then_batch(node, node._on_load_raw, m)  # noqa: E731
    else:
        on_joint, on_load = node._on_joint, node._on_load
    try:
        t = feed_cycle(node, T0 + 1.0)
        before = snapshot(node)
        bad = [
            ("nan position", lambda: on_joint(joint(t + 1, [math.nan]))),
            ("inf velocity", lambda: on_joint(joint(t + 1, [0.05], velocity=[math.inf]))),
            ("time backwards", lambda: on_joint(joint(t - 5.0, [0.05]))),
            ("unknown joint", lambda: on_joint(joint(t + 1, [0.05], names=("y",)))),
            ("empty arrays", lambda: on_joint(joint(t + 1, [], names=()))),
            ("names without positions", lambda: on_joint(joint(t + 1, [], names=("x",)))),
            ("nan load", lambda: on_load(load(t + 1, math.nan))),
            ("inf load", lambda: on_load(load(t + 1, math.inf))),
            ("load time backwards", lambda: on_load(load(T0, 100.0))),
            ("nan straightness", lambda: node._on_straightness(Float64(data=math.nan))),
            ("negative straightness", lambda: node._on_straightness(Float64(data=-1e-6))),
        ] + ([
            ("malformed joint bytes", lambda: raw_then_batch(node, node._on_joint_raw, b"\x00\x01\x00\x00garbage")),
            ("malformed load bytes", lambda: raw_then_batch(node, node._on_load_raw, b"\x00\x01")),
        ] if path == "raw" else []) + [
        ]
        rejected_before = sum(node.monitor.rejected.values())
        for label, action in bad:
            action()
            assert snapshot(node) == before, label
        assert sum(node.monitor.rejected.values()) - rejected_before == len(bad)
        # a good sample afterwards is still accepted and moves the state
        node._on_joint(joint(t + 1, [0.001]))
        assert snapshot(node) != before
        # the log is throttled: one line per reason within the throttle period, the rest counted
        node._on_joint(joint(t + 0.5, [0.002]))
        node._on_joint(joint(t + 0.5, [0.002]))
        assert node.rejections.suppressed.get("joint_states time going backwards", 0) >= 1
    finally:
        node.close()
        node.destroy_node()


def assert_same_state(a, b, path="state", rel=1e-12):
    """Equal saved states, floats to 1e-12 relative (sums taken in another order); the elements of lists
    (the wear profile along the rail: prefix-sum differences in the batch path) to 1e-9."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for key in a:
            assert_same_state(a[key], b[key], f"{path}.{key}", rel)
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), path
        for k, (x, y) in enumerate(zip(a, b)):
            assert_same_state(x, y, f"{path}[{k}]", 1e-9)
    elif isinstance(a, float):
        assert b == pytest.approx(a, rel=rel, abs=1e-9, nan_ok=True), path
    else:
        assert a == b, path


def test_raw_and_deserialised_paths_give_the_same_state(ros_context, tmp_path):
    nodes = [make_node(ros_context, tmp_path / "a"), make_node(ros_context, tmp_path / "b")]
    raw = nodes[1]
    raw._on_joint = lambda m: raw._on_joint_raw(serialize_message(m))      # copied; handled in batches
    raw._on_load = lambda m: raw._on_load_raw(serialize_message(m))
    try:
        for node in nodes:
            t = feed_cycle(node, T0 + 1.0, strokes=(0.1, 0.25, 0.18))
            node._on_joint(joint(t + 0.02, [0.001, 0.5], names=("x", "z"), velocity=[0.05, 0.0]))  # 2 joints
            node._on_joint(joint(t + 0.04, [0.2, 0.002], names=("z", "x")))                   # reordered
        raw.process_inputs()
        # the raw path integrates in batches (the model's batch path): the same state to rounding
        assert_same_state(nodes[0].monitor.state(), nodes[1].monitor.state())
        assert nodes[1].monitor.integrator.samples == nodes[0].monitor.integrator.samples > 100
        assert nodes[1]._callbacks > 100 and nodes[1]._model_s <= nodes[1]._callback_s
    finally:
        for node in nodes:
            node.close()
            node.destroy_node()


def test_diagnostics_keys_levels_and_stale(ros_context, tmp_path):
    node = make_node(ros_context, tmp_path, input_timeout_s=0.2, life_warn_h=1.0, life_error_h=0.1)
    try:
        node.publish_diagnostics()                     # no input yet: STALE
        status = node.published[-1].status[0]
        assert status.name == "m1/wear_monitor: x precision"
        assert status.hardware_id == "m1"
        assert status.level == b"\x03"
        values = {kv.key: kv.value for kv in status.values}
        assert set(PRECISION_KEYS) <= set(values)
        assert values["remaining_life_h"] == "nan"
        t_end = feed_cycle(node, T0 + 1.0)
        node._on_load(load(t_end, 6000.0))           # fresh: feed_cycle can outlast the 0.2 s timeout under load
        node._on_straightness(Float64(data=16e-6))
        node.publish_diagnostics()
        status = node.published[-1].status[0]
        texts = {kv.key: kv.value for kv in status.values}
        assert texts["load_source"] == "topic" and texts["limit_date_utc"].endswith("Z")   # the text keys
        values = {k: float(v) for k, v in texts.items() if k not in ("lubrication_regime", "load_source", "model_fit")
                  and "_utc" not in k}
        assert status.level == b"\x00", status.message
        assert values["sliding_distance_m"] == pytest.approx(1.2, rel=1e-6)
        # Eq. 7/10 with the observed strokes (l_min 0.1, l_max 0.3): A = 2 K W s / (H b (l_min + l_max))
        k = values["wear_coefficient"]
        expected = 15.0 + 1e6 * 2 * k * 6000 * 1.2 / (199e6 * 0.04 * 0.4)
        assert values["straightness_um"] == pytest.approx(expected, rel=1e-3)
        assert values["straightness_measured_um"] == pytest.approx(16.0)
        assert values["remaining_life_h_low"] <= values["remaining_life_h"] <= values["remaining_life_h_high"]
        import time as _time
        _time.sleep(0.3)                               # inputs silent for longer than input_timeout_s
        node.publish_diagnostics()
        assert node.published[-1].status[0].level == b"\x03"
        assert "no data on" in node.published[-1].status[0].message
    finally:
        node.close()
        node.destroy_node()


def test_limit_passed_is_error(ros_context, tmp_path):
    node = make_node(ros_context, tmp_path, straightness_limit_m=15.5e-6, wear_coefficient=4.42e-5)
    try:
        feed_cycle(node, T0 + 1.0, strokes=(0.1, 0.3) * 5)
        node.publish_diagnostics()
        status = node.published[-1].status[0]
        assert status.level == b"\x02"
        assert "exceeds the limit" in status.message
    finally:
        node.close()
        node.destroy_node()


def test_state_survives_restart(ros_context, tmp_path):
    node = make_node(ros_context, tmp_path)
    t = feed_cycle(node, T0 + 1.0)
    node._on_straightness(Float64(data=16e-6))
    node.checkpoint()
    distance = node.monitor.integrator.sliding_distance_m
    saved_state = snapshot(node)
    saved_report = node.monitor.report()
    node.store.close()              # a crashed process: its lock goes with it, no final checkpoint
    node.destroy_node()                                # no clean close: only the checkpoint survives
    node2 = make_node(ros_context, tmp_path)
    try:
        # complete restoration (interfaces.md): the whole state, counters included, exactly; and the status
        # numbers computed from it. Catches a field left out of state()/restore() (samples, strokes, duty
        # buckets, K measurements, rejection counts) or a float round trip through JSON that is not exact.
        assert snapshot(node2) == saved_state
        restored = node2.monitor.report()
        for key in ("samples", "load_samples", "measurements", "strokes", "rejected_samples"):
            assert restored[key] == saved_report[key], key
        for key in ("straightness_um", "remaining_life_h", "sliding_distance_m", "wear_coefficient",
                    "duty_load_speed_w", "stroke_min_m", "stroke_max_m"):
            assert restored[key] == saved_report[key], key
        assert node2.monitor.estimator.count == 1
        node2._on_joint(joint(t - 1.0, [0.0]))         # already processed stamps are rejected
        assert node2.monitor.integrator.sliding_distance_m == distance
        node2._on_joint(joint(t + 1.0, [0.01]))
        assert node2.monitor.integrator.sliding_distance_m == pytest.approx(distance + 0.01)
    finally:
        node2.close()
        node2.destroy_node()
