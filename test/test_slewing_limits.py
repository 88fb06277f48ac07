"""The manufacturer's static limiting load curve as a parameter table (schema-validated) and the static-safety
key against it; a saved slewing state of another bearing geometry refused at start (docs/slewing.md).

Truths: linear interpolation of the table written in the test; the saved file's bytes before and after.
"""
from __future__ import annotations

import hashlib

import pytest

from guide_health.errors import InputError
from guide_health.params import SLEWING_MONITOR_DEFAULTS
from guide_health.params.typed import slewing_monitor_params

CURVE = {"limiting_curve_axial_load_n": [0.0, 1.0e6, 2.0e6], "limiting_curve_moment_nm": [3.0e6, 2.0e6, 0.5e6]}


def _monitor(**changes):
    from guide_health.models.slewing.monitor import SlewingMonitor

    return SlewingMonitor(slewing_monitor_params({**SLEWING_MONITOR_DEFAULTS, **changes}))


def test_limiting_curve_safety_equals_the_interpolated_table_by_hand():
    """F_a = 600 kN: M_lim = 3e6 + 0.6 (2e6 - 3e6) = 2.4e6 N m; M_T = 1.5e6: safety 1.6 (OK); M_T = 3e6: 0.8,
    an ERROR naming the curve; F_a beyond the table: outside the curve (0)."""
    m = _monitor(**CURVE)
    m.on_axis_angle(0.0, 0)
    m.on_loads(600e3, 0.0, 1.5e6, t_ns=1)
    level, _, values = m.period_report()
    assert values["limiting_curve_safety"] == pytest.approx(2.4e6 / 1.5e6, rel=1e-12)
    assert int(level) < 2
    m.on_loads(600e3, 0.0, 3.0e6, t_ns=2)
    level, message, values = m.period_report()
    assert int(level) == 2 and "limiting load curve" in message and "safety 0.8" in message
    assert values["limiting_curve_safety"] == pytest.approx(0.8, rel=1e-12)
    m.on_loads(2.5e6, 0.0, 1.0e5, t_ns=3)
    assert m.period_report()[2]["limiting_curve_safety"] == 0.0
    # no table: no curve, the key stays infinite
    plain = _monitor()
    plain.on_axis_angle(0.0, 0)
    plain.on_loads(600e3, 0.0, 3.0e6, t_ns=1)
    assert plain.period_report()[2]["limiting_curve_safety"] == float("inf")


@pytest.mark.parametrize("axial, moment, words", [
    ([0.0, 1e6], [3e6], "one allowed moment per axial load"),
    ([0.0], [3e6], "need >= 2 points"),
    ([0.0, 2e6, 1e6], [3e6, 2e6, 1e6], "strictly ascending"),
    ([0.0, 1e6, 2e6], [3e6, 3.5e6, 1e6], "not rising with F_a"),
    ([0.0, 1e6], [3e6, -1.0], ">= 0"),
    ([0.0, "x"], [3e6, 1e6], "list of finite numbers"),
])
def test_the_schema_refuses_a_bad_curve_in_one_line(axial, moment, words):
    from guide_health.params import SLEWING_MONITOR_SCHEMA
    from guide_health.params.schema import coerce_value

    values = dict(SLEWING_MONITOR_DEFAULTS)
    with pytest.raises(InputError, match=words) as info:
        for name, value in (("limiting_curve_axial_load_n", axial), ("limiting_curve_moment_nm", moment)):
            values[name] = coerce_value(name, value, SLEWING_MONITOR_SCHEMA[name].default)
        slewing_monitor_params(values)
    assert "\n" not in str(info.value)


def test_the_curve_parameters_are_tables_with_units():
    from guide_health.params import SLEWING_MONITOR_SCHEMA

    for name, unit in (("limiting_curve_axial_load_n", "N"), ("limiting_curve_moment_nm", "N m")):
        assert SLEWING_MONITOR_SCHEMA[name].type_name == "float[]" and SLEWING_MONITOR_SCHEMA[name].unit == unit


def _node(ros_context, state_file, **overrides):
    from rclpy.parameter import Parameter

    from guide_health.nodes.slewing_monitor import SlewingMonitorNode

    params = [Parameter("state_file", value=str(state_file)), Parameter("input_align_window_s", value=0.0)]
    params += [Parameter(name, value=value) for name, value in overrides.items()]
    node = SlewingMonitorNode(context=ros_context, parameter_overrides=params)
    node.diag_pub.publish = lambda msg: None
    return node


def _digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_state_of_another_geometry_stops_the_node_unless_state_reset(ros_context, tmp_path):
    """Saved with 170 rollers, started with 160: one line naming roller_count 170 (now 160), the node does not
    start and the file's bytes are unchanged; with state_reset:=true it starts from zero and its checkpoint
    replaces the state (then a restart with 160 resumes it)."""
    from geometry_msgs.msg import WrenchStamped
    from sensor_msgs.msg import JointState

    state_file = tmp_path / "slewing.db"
    node = _node(ros_context, state_file)
    try:
        load = WrenchStamped()
        load.wrench.force.z = 5.0e5
        node._on_load(load)
        for k in range(10):
            js = JointState(name=["slew"], position=[0.1 * k])
            js.header.stamp.sec = k + 1
            node._on_axis(js)
        assert node.core.fatigue.row_damage()["upper_axial"] > 0
        node.close()
    finally:
        node.destroy_node()
    before = _digest(state_file)
    with pytest.raises(InputError) as info:
        _node(ros_context, state_file, roller_count=160)
    text = str(info.value)
    assert "\n" not in text and "roller_count 170 (now 160)" in text and "state_reset:=true" in text
    assert _digest(state_file) == before
    node = _node(ros_context, state_file, roller_count=160, state_reset=True)
    try:
        assert node.core.fatigue.row_damage()["upper_axial"] == 0.0 and node.state_refused == 0
        node.close()
    finally:
        node.destroy_node()
    assert _digest(state_file) != before
    node = _node(ros_context, state_file, roller_count=160)      # the replaced state is this geometry's
    node.destroy_node()
