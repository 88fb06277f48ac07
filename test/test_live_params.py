"""Issue 16, parameters as ROS users expect: a wear_monitor node spinning on an isolated DDS domain, changed
through its parameter services by an rclpy client in another context (what ``ros2 param set`` and
``ros2 param describe`` do): garbage and read-only refused with a reason, a good threshold changes the next
status level, a period re-times its timer, a cross-check (life_error_h < life_warn_h) holds at run time."""
import threading

import pytest

rclpy = pytest.importorskip("rclpy")
from geometry_msgs.msg import WrenchStamped  # noqa: E402
from rcl_interfaces.msg import Parameter as ParameterMsg  # noqa: E402
from rcl_interfaces.msg import ParameterType, ParameterValue  # noqa: E402
from rcl_interfaces.srv import DescribeParameters, SetParameters  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402

from guide_health.nodes.wear_monitor import WearMonitorNode  # noqa: E402

T0 = 1_700_000_000


def stamped(msg, t_s):
    msg.header.stamp.sec = int(t_s)
    msg.header.stamp.nanosec = int(round((t_s - int(t_s)) * 1e9))
    return msg


def feed_strokes(node, strokes=(0.1, 0.3, 0.2), dt=0.02, speed=0.05):
    """6000 N, then strokes home -> L -> home at `speed` (1.2 m slid): remaining life 28.27 h with the
    default guide (K 4.42e-6, H 199e6, b 0.04 m; measured), between the thresholds the tests move."""
    t = T0 + 1.0
    load = stamped(WrenchStamped(), t)
    load.wrench.force.z = 6000.0
    node._on_load(load)
    x = 0.0
    for stroke in strokes:
        for target in (stroke, 0.0):
            while abs(target - x) > 1e-12:
                step = min(speed * dt, abs(target - x))
                x += step if target > x else -step
                t += dt
                msg = stamped(JointState(), t)
                msg.name, msg.position = ["x"], [x]
                node._on_joint(msg)


def value_msg(value):
    if isinstance(value, str):
        return ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value)
    if isinstance(value, int):
        return ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=value)
    return ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=float(value))


class ParamClient:
    """set_parameters / describe_parameters of a remote node, from a private context."""

    def __init__(self, target: str):
        self.context = rclpy.context.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("param_client", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.set_client = self.node.create_client(SetParameters, f"/{target}/set_parameters")
        self.describe_client = self.node.create_client(DescribeParameters, f"/{target}/describe_parameters")
        assert self.set_client.wait_for_service(timeout_sec=20.0)
        assert self.describe_client.wait_for_service(timeout_sec=20.0)

    def _call(self, client, request):
        future = client.call_async(request)
        self.executor.spin_until_future_complete(future, timeout_sec=20.0)
        assert future.done()
        return future.result()

    def set(self, name, value):
        request = SetParameters.Request(parameters=[ParameterMsg(name=name, value=value_msg(value))])
        return self._call(self.set_client, request).results[0]

    def describe(self, name):
        return self._call(self.describe_client, DescribeParameters.Request(names=[name])).descriptors[0]

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


@pytest.fixture
def spinning_node(ros_context, tmp_path):
    """A wear_monitor at remaining life 28.3 h, judged OK (life_warn_h 20, life_error_h 10), spun in a
    background thread; its periodic status is off (diagnostics_period_s 3600), the test calls it."""
    overrides = {"state_file": "", "machine_id": "m1", "life_warn_h": 20.0, "life_error_h": 10.0,
                 "input_align_window_s": 0.0, "diagnostics_period_s": 1000.0, "duty_window_s": 3600.0}
    node = WearMonitorNode(context=ros_context,
                           parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()])
    node.published = []
    node.diag_pub.publish = node.published.append
    feed_strokes(node)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    client = ParamClient("wear_monitor")
    yield node, client
    client.close()
    executor.shutdown()
    thread.join(timeout=5)
    node.close()
    node.destroy_node()


def status_of(node):
    node.publish_diagnostics()
    status = node.published[-1].status[0]
    return status.level[0], status.message, {kv.key: kv.value for kv in status.values}


def test_set_parameters_service_refuses_bad_values_and_applies_good_ones(spinning_node):
    node, client = spinning_node
    level, message, values = status_of(node)
    life_h = float(values["remaining_life_h"])                   # measured 28.27 h
    assert 20.0 < life_h < 30.0 and level == 0, message           # > life_warn_h 20 h: OK

    banana = client.set("life_warn_h", "banana")
    assert not banana.successful and banana.reason == "parameter life_warn_h must be a number, got 'banana'"
    read_only = client.set("hardness_pa", 1.0e9)
    assert not read_only.successful and "read-only" in read_only.reason
    out_of_range = client.set("straightness_warn_fraction", 1.5)     # rclpy: the descriptor's range
    assert not out_of_range.successful and "out of range" in out_of_range.reason
    open_end = client.set("straightness_warn_fraction", 1.0)         # the schema: (0, 1) is open
    assert not open_end.successful and open_end.reason.endswith("straightness_warn_fraction = 1.0 must be in (0, 1)")
    inverted = client.set("life_error_h", 25.0)                  # above life_warn_h 20: cross-check
    assert not inverted.successful and inverted.reason.startswith("life_error_h (25.0 h) must be below life_warn_h")
    too_slow = client.set("diagnostics_period_s", 2000.0)        # duty_window_s 3600 < 3 periods
    assert not too_slow.successful and "at least 3 diagnostics periods" in too_slow.reason
    assert node.get_parameter("life_warn_h").value == 20.0 and node.monitor.params.life_error_h == 10.0
    assert status_of(node)[0] == 0                               # nothing refused reached the model

    good = client.set("life_warn_h", 50)                         # an integer sets the float parameter
    assert good.successful, good.reason
    level, message, _ = status_of(node)
    assert level == 1 and "remaining precision life 28 h" in message     # 28.27 h < 50 h: WARN
    assert client.set("life_error_h", 30.0).successful
    assert status_of(node)[0] == 2                               # 28.27 h < 30 h: ERROR
    assert client.set("diagnostics_period_s", 2.5).successful
    period_ns = [t.timer_period_ns for t in node.periodic.timers.values()]
    assert period_ns == [2_500_000_000]


def test_describe_parameters_carries_unit_range_and_read_only(spinning_node):
    _, client = spinning_node
    hardness = client.describe("hardness_pa")
    assert hardness.read_only and "[Pa]" in hardness.description
    assert (hardness.floating_point_range[0].from_value, hardness.floating_point_range[0].to_value) == (1e6, 1e11)
    warn = client.describe("life_warn_h")
    assert not warn.read_only and "[h]" in warn.description and warn.floating_point_range[0].to_value == 1e7
    window = client.describe("rejected_window_samples")
    assert not window.read_only and window.integer_range[0].from_value == 1
    assert client.describe("guide_type").additional_constraints == "one of: sliding, rolling"


def test_run_time_windows_noise_and_limits_reach_the_model(spinning_node):
    node, client = spinning_node
    monitor = node.monitor
    assert client.set("rejected_window_samples", 7).successful
    assert all(window.maxlen == 7 for window in monitor.recent.values())
    assert list(monitor.recent["joint_states"]) == [None] * 7       # the newest 7 accepted samples kept
    assert client.set("straightness_noise_m", 2e-6).successful and monitor.estimator.noise_sd_m == 2e-6
    assert client.set("input_align_window_s", 0.25).successful and node.feed.window_s == 0.25
    assert client.set("load_max_n", 5000.0).successful and monitor.limits.load_max_n == 5000.0
    assert client.set("input_timeout_s", 42.0).successful and node.updater.input_timeout_s == 42.0


def test_slewing_and_fleet_nodes_apply_their_dynamic_parameters(ros_context):
    from guide_health.nodes.fleet_monitor import FleetMonitorNode
    from guide_health.nodes.slewing_monitor import SlewingMonitorNode

    slewing = SlewingMonitorNode(context=ros_context)
    fleet = FleetMonitorNode(context=ros_context)
    try:
        assert slewing.set_parameters([Parameter("allowable_contact_stress_pa", value=3.0e9)])[0].successful
        assert slewing.core.model.allowable_pa == 3.0e9
        report = slewing.core.model.report_for_roller_load(1.0e5)
        assert report["allowable_MPa"] == 3000.0
        assert not slewing.set_parameters([Parameter("roller_count", value=10)])[0].successful   # read-only
        assert fleet.set_parameters([Parameter("stale_after_s", value=3.0)])[0].successful
        assert fleet.board.stale_after_s == 3.0
        refused = fleet.set_parameters([Parameter("forget_after_s", value=2.0)])[0]        # below stale_after_s
        assert not refused.successful and refused.reason.startswith("forget_after_s (2.0 s) must be above")
    finally:
        slewing.destroy_node()
        fleet.close()
        fleet.destroy_node()


def test_hysteresis_and_latched_error_through_the_parameter_and_acknowledge_services(spinning_node):
    from std_srvs.srv import Trigger

    node, client = spinning_node                                 # life 28.27 h, alarm_clear_margin 0.05
    assert client.set("life_warn_h", 28.5).successful
    assert status_of(node)[0] == 1                               # 28.27 < 28.5: WARN
    assert client.set("life_warn_h", 28.0).successful
    assert status_of(node)[0] == 1                               # 28.27 < 28.0 x 1.05: WARN holds
    assert client.set("alarm_clear_margin", 0.0).successful
    assert status_of(node)[0] == 0                               # no margin: back to OK at once

    assert client.set("life_warn_h", 40.0).successful and client.set("life_error_h", 30.0).successful
    level, _, values = status_of(node)
    assert level == 2 and values["alarm_events"] == "1"
    assert client.set("life_error_h", 10.0).successful and client.set("life_warn_h", 20.0).successful
    level, message, values = status_of(node)
    assert level == 2 and message.startswith("ERROR latched until acknowledged (1 events; first: remaining precision")
    ack = client.node.create_client(Trigger, "/wear_monitor/acknowledge_alarms")
    assert ack.wait_for_service(timeout_sec=20.0)
    response = client._call(ack, Trigger.Request())
    assert response.success and response.message == "acknowledged x precision (1 ERROR events)"
    level, _, values = status_of(node)
    assert level == 0 and values["alarm_latched"] == "0" and values["alarm_events"] == "1"
