"""Issue 16, QoS: a real wear_monitor process takes data from a best-effort (SensorDataQoS) and a reliable
publisher over Fast DDS on an isolated domain (default sensor_qos auto), and, with best-effort subscriptions
and message info, reports the messages it lost, counted from the writer's sequence numbers, equal to the
loss measured here (published - integrated)."""
import time

import pytest

from guide_health.nodes.qos import LossCounter, resolve_executor


def test_loss_counter_counts_sequence_gaps_of_a_single_writer():
    losses = LossCounter()
    losses.single_writer.update(a=True, b=True, c=False)
    for seq in (1, 2, 5, 6, 10):                       # 2 + 3 lost
        losses.seen("a", {"publication_sequence_number": seq})
    for seq in (7, 8, 1, 2, 4):                        # restart at 1: a new run, not counted; then 1 lost
        losses.seen("b", {"publication_sequence_number": seq})
    for seq in (1, 50, 2, 51):                         # two writers interleaved: not counted
        losses.seen("c", {"publication_sequence_number": seq})
    losses.seen("b", {})
    losses.reported("c", 3)                            # a DDS message_lost event
    assert losses.lost == {"a": 5, "b": 1, "c": 3}
    assert losses.summary() == "9 sensor messages lost (a 5, b 1, c 3)"
    assert LossCounter().summary() == ""


def test_executor_auto_follows_sensor_qos():
    assert resolve_executor("auto", "auto") == "events"
    assert resolve_executor("auto", "best_effort") == "single_threaded"
    assert resolve_executor("events", "best_effort") == "events"
    assert resolve_executor("auto", "auto", use_sim_time=True) == "single_threaded"


rclpy = pytest.importorskip("rclpy")
from geometry_msgs.msg import WrenchStamped  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402

from guide_health.nodes.session import (  # noqa: E402
    DiagnosticsCollector,
    clean_fastdds_shm,
    start_node,
    stop_node,
)

STATUS = "qos_m1/wear_monitor: x precision"   # the nodes below run with machine_id qos_m1
T0 = 1_700_000_000
RELIABLE = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


@pytest.fixture
def ros_env(ros_test_env):
    env = ros_test_env()            # the test's own domain, UDP only (conftest)
    yield env
    clean_fastdds_shm()


class Counted:
    """A status count of the node, read through the collector: ``values(key)`` now (0 before the first
    status); ``counted(key, at_least)`` True once the node reports it (waits up to ``wait_s``; fails the test
    after ``give_up_s`` in all, a node that never counts is broken)."""

    def __init__(self, collector, wait_s=2.0, give_up_s=180.0):
        self.collector, self.wait_s, self.deadline = collector, wait_s, time.monotonic() + give_up_s

    def values(self, key):
        status = self.collector.get(STATUS)
        return 0 if status is None else int(status["values"][key])

    def __call__(self, key, at_least):
        assert time.monotonic() < self.deadline, f"the node never counted {key} >= {at_least}"
        return self.collector.wait_for(STATUS, lambda s: int(s["values"][key]) >= at_least,
                                       timeout=self.wait_s) is not None


class Sensors:
    """joint_states and guide/load publishers in this process, each with its own QoS."""

    def __init__(self, joint_qos, load_qos):
        self.context = rclpy.context.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("test_sensors", context=self.context)
        self.joint = self.node.create_publisher(JointState, "joint_states", joint_qos)
        self.load = self.node.create_publisher(WrenchStamped, "guide/load", load_qos)

    def wait_matched(self, timeout=120.0):
        """Both publishers matched by the node (a reliable reader does not match a best-effort writer:
        this also waits for sensor_qos auto to switch)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if self.joint.get_subscription_count() and self.load.get_subscription_count():
                return True
            time.sleep(0.05)
        return False

    def publish_strokes(self, n, dt=0.01, speed=0.05, stroke=0.2, pause_every=0, pause_s=0.0, t0=T0, x0=0.0,
                        counted=None):
        """A 6000 N load stamped t0 [s], then n joint samples of triangular strokes from x0 [m]; returns the
        sliding distance (the last position in ``last_x``). The load and the first joint sample go alone,
        each until the node's status counts it (``counted(key, at_least)``: a loss count starts at the first
        message received of a writer, and a best-effort sample sent before the node's reader has matched
        this writer is dropped; a repeat of a sample already received is a duplicate stamp, rejected)."""
        loads0, samples0 = counted.values("load_samples"), counted.values("samples")
        wrench = WrenchStamped()
        wrench.header.stamp.sec = t0
        wrench.wrench.force.z = 6000.0
        while True:
            self.load.publish(wrench)
            if counted("load_samples", loads0 + 1):
                break
        x, direction, distance, step = x0, 1.0, 0.0, speed * dt
        for i in range(n):
            t = t0 + 0.01 + i * dt
            msg = JointState()
            msg.header.stamp.sec = int(t)
            msg.header.stamp.nanosec = int(round((t - int(t)) * 1e9))
            msg.name, msg.position = ["x"], [x]
            self.joint.publish(msg)
            while i == 0 and not counted("samples", samples0 + 1):
                self.joint.publish(msg)
            if i < n - 1:
                if not 0.0 <= x + direction * step <= stroke:
                    direction = -direction
                x += direction * step
                distance += step
            if pause_every and i % pause_every == pause_every - 1:
                time.sleep(pause_s)
        self.last_x = x
        return distance

    def close(self):
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


@pytest.mark.ros
def test_best_effort_and_reliable_sensors_both_feed_the_default_node(tmp_path, ros_env):
    collector = DiagnosticsCollector("qos_collector")
    node = start_node("guide_health.nodes.wear_monitor", None,
                      {"diagnostics_period_s": 0.2, "input_align_window_s": 0.0, "input_timeout_s": 30.0,
                       "machine_id": "qos_m1",
                       "state_file": "''"}, ros_env, tmp_path / "node.log")
    sensors = Sensors(qos_profile_sensor_data, RELIABLE)     # joint best effort, load reliable
    try:
        assert sensors.wait_matched(), (tmp_path / "node.log").read_text()
        n = 2000
        # ~2 kHz: the node keeps up
        distance = sensors.publish_strokes(n, pause_every=50, pause_s=0.02, counted=Counted(collector))
        status = collector.wait_for(STATUS, lambda s: int(s["values"]["samples"]) >= n, timeout=180.0)
        assert status is not None, (collector.get(STATUS), (tmp_path / "node.log").read_text())
        values = status["values"]
        assert status["level"] != 3, status["message"]               # not STALE: the data arrived
        assert int(values["best_effort_topics"]) == 1                  # joint_states switched, load reliable
        assert int(values["samples"]) == n and int(values["messages_lost"]) == 0
        assert float(values["sliding_distance_m"]) == pytest.approx(distance, rel=1e-9)
    finally:
        sensors.close()
        stop_node(node)
        collector.close()


@pytest.mark.ros
def test_auto_goes_back_to_reliable_when_the_best_effort_publisher_leaves(tmp_path, ros_env):
    """sensor_qos auto: a best-effort joint_states driver makes the topic best effort; when it is replaced by a
    reliable one, the node subscribes reliably again (best_effort_topics 1 -> 0, logged) and every sample of
    both drivers counts: samples and sliding distance exact, nothing lost."""
    collector = DiagnosticsCollector("qos_collector")
    log = tmp_path / "node.log"
    node = start_node("guide_health.nodes.wear_monitor", None,
                      {"diagnostics_period_s": 0.2, "input_align_window_s": 0.0, "input_timeout_s": 60.0,
                       "machine_id": "qos_m1", "state_file": "''"}, ros_env, log)
    sensors = Sensors(qos_profile_sensor_data, RELIABLE)     # joint best effort
    try:
        assert sensors.wait_matched(), log.read_text()
        first = sensors.publish_strokes(500, pause_every=50, pause_s=0.02, counted=Counted(collector))
        status = collector.wait_for(STATUS, lambda s: int(s["values"]["samples"]) >= 500, timeout=180.0)
        assert status is not None and int(status["values"]["best_effort_topics"]) == 1, log.read_text()
        x_end = sensors.last_x
        sensors.close()
        sensors = Sensors(RELIABLE, RELIABLE)                   # the reliable driver takes over
        status = collector.wait_for(STATUS, lambda s: int(s["values"]["best_effort_topics"]) == 0, timeout=120.0)
        assert status is not None, (collector.get(STATUS), log.read_text())
        assert sensors.wait_matched(), log.read_text()
        second = sensors.publish_strokes(1500, pause_every=50, pause_s=0.02, t0=T0 + 100, x0=x_end,
                                         counted=Counted(collector))
        status = collector.wait_for(STATUS, lambda s: int(s["values"]["samples"]) >= 2000, timeout=180.0)
        assert status is not None, (collector.get(STATUS), log.read_text())
        values = status["values"]
        assert int(values["samples"]) == 2000 and int(values["messages_lost"]) == 0
        assert int(values["best_effort_topics"]) == 0
        assert float(values["sliding_distance_m"]) == pytest.approx(first + second, rel=1e-9)
        assert "no best-effort publisher left; reliable subscription" in log.read_text()
    finally:
        sensors.close()
        stop_node(node)
        collector.close()


@pytest.mark.ros
def test_reported_loss_equals_measured_loss_under_a_burst(tmp_path, ros_env):
    collector = DiagnosticsCollector("qos_collector_burst")
    node = start_node("guide_health.nodes.wear_monitor", None,
                      {"diagnostics_period_s": 0.2, "input_align_window_s": 0.0, "input_timeout_s": 60.0,
                       "machine_id": "qos_m1",
                       "sensor_queue_depth": 5, "sensor_qos": "best_effort", "state_file": "''"},
                      ros_env, tmp_path / "node.log")
    sensors = Sensors(RELIABLE, RELIABLE)      # reliable writers into best-effort KEEP_LAST(5) readers
    try:
        assert sensors.wait_matched(), (tmp_path / "node.log").read_text()
        n = 20000
        sensors.publish_strokes(n, counted=Counted(collector))   # a burst: far faster than the node's callbacks
        status = collector.wait_for(STATUS, lambda s: int(s["values"]["samples"]) + int(
            s["values"]["messages_lost"]) >= n - 1, timeout=180.0)
        assert status is not None, (collector.get(STATUS), (tmp_path / "node.log").read_text())
        values = status["values"]
        lost = int(values["messages_lost"])
        # measured: joint samples published - joint samples the model integrated (all valid, in order);
        # the last sample may still be in flight, hence n - 1 in the wait
        assert lost > 0
        assert lost in (n - int(values["samples"]), n - 1 - int(values["samples"]))
        assert "sensor messages lost (joint_states" in status["message"]
        # the stamp-gap estimate (models/wear/stream_gaps.py) learns the 10 ms period; at this loss (~97 %)
        # many gaps are longer than 1 s of stamps (100 periods) and count as pauses, not loss (measured:
        # 1769 estimated, 68 pauses, 19222 lost): an undercount, never more than the loss
        # (stamps from float seconds near T0: ~240 ns quantisation; measured 9999.991 and 10000.229 us).
        # When more than half of the samples are lost evenly (the batched node on a quiet machine), a block's
        # median is a multiple of the period (stream_gaps' documented blind spot; measured 80000.162 and
        # 139999.866 us, 2256 of 19357 lost counted) and the count covers only the gaps beyond that multiple
        period_us = float(values["joint_period_estimate_us"])
        k = max(1, round(period_us / 10_000.0))
        assert period_us == pytest.approx(10_000.0 * k, abs=0.5 * k)
        missing = int(values["joint_samples_missing_estimate"])
        assert 0 <= missing <= lost and (missing > 0 or k > 1)
        # whether a burst leaves gaps over 100 periods (pauses) depends on how the machine schedules the
        # callbacks (seen: 68 pauses at k = 1; none at k = 8; none at k = 1 under CI's load), so here only
        # that it is a count; the pause rule itself is tested on given stamps in test_stream_gaps*.py
        assert int(values["joint_stamp_pauses"]) >= 0
        assert int(values["best_effort_topics"]) == 4                  # every data topic
    finally:
        sensors.close()
        stop_node(node)
        collector.close()
