"""`slewing_monitor`: roller/raceway contact stress of a slewing bearing from its load topic.

Subscribes `slewing/load` (geometry_msgs/WrenchStamped: force.z = F_a, hypot(force.x, force.y) = F_r,
hypot(torque.x, torque.y) = M_T) and publishes `/diagnostics` (task `<bearing> roller contact`) every
`diagnostics_period_s` with the worst case since the last publish; STALE when loads stop. The contact
model (seed 003 Eq. 1, finite-roller end effect, McEwen field) is cached, so a message costs microseconds.
"""
from __future__ import annotations

import math
import sys
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from guide_health.diagnostics import ROLLER_CONTACT_KEYS, make_array, make_status
from guide_health.errors import InputError
from guide_health.models.roller_contact import SLEWING_MONITOR_DEFAULTS, SlewingContactModel, validate_slewing_params
from guide_health.params import declare_parameters

DATA_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
EXTRA_KEYS = ("p_max_MPa", "p_max_position_mm", "shear_depth_mm", "axial_main_row_max_n",
              "axial_opposite_row_max_n", "radial_row_max_n", "worst_row", "loads_in_period", "rejected_loads")
LOG_THROTTLE_S = 5.0


def wrench_to_loads(msg: WrenchStamped) -> tuple[float, float, float]:
    """(F_a, F_r, M_T) from a WrenchStamped (INTERFACES.md convention)."""
    f, m = msg.wrench.force, msg.wrench.torque
    return float(f.z), math.hypot(f.x, f.y), math.hypot(m.x, m.y)


class SlewingMonitor:
    """ROS-free core of the node: worst case per publish period, input validation, levels."""

    def __init__(self, params: dict):
        validate_slewing_params(params)
        self.params = params
        self.model = SlewingContactModel(params)
        self.worst: dict | None = None
        self.last_report: dict | None = None
        self.loads_in_period = 0
        self.rejected = 0
        self.last_problem: str | None = None

    def on_loads(self, axial_n: float, radial_n: float, moment_nm: float) -> str | None:
        """One load sample; returns the rejection reason or None."""
        if not all(math.isfinite(v) for v in (axial_n, radial_n, moment_nm)):
            self.rejected += 1
            self.last_problem = "non-finite load"
            return "non-finite load (NaN/inf) ignored"
        report = self.model.report_for_loads(axial_n, radial_n, moment_nm)
        self.loads_in_period += 1
        if self.worst is None or report["p_max_MPa"] > self.worst["p_max_MPa"]:
            self.worst = report
        return None

    def period_report(self) -> tuple[int, str, dict]:
        """Level, message and values for the period just ended (the worst roller since the last call)."""
        report = self.worst or self.last_report
        values = dict(report or {})
        values["loads_in_period"] = self.loads_in_period
        values["rejected_loads"] = self.rejected
        if report is None:
            level, message = 1, "no valid load received yet"
            if self.last_problem:
                message = f"no valid load received yet ({self.last_problem})"
        else:
            level, message = int(report["level"]), report["message"]
            if report.get("main_row_unloaded") and report.get("opposite_row_unloaded"):
                level, message = max(level, 1), "no axial roller is loaded: " + message
            elif report.get("main_row_partly_unloaded"):
                level = max(level, 1)
                message = ("tilting moment lifts the main row's rollers off on the far side "
                           "(4 M_T / D0 > F_a, the retaining row takes the moment); " + message)
            if self.loads_in_period == 0 and self.rejected:
                level, message = max(level, 1), f"only invalid loads this period ({self.last_problem}); last valid: {message}"
        if report is not None and self.worst is not None:
            self.last_report = self.worst
        self.worst = None
        self.loads_in_period = 0
        return level, message, values


class SlewingMonitorNode(Node):
    def __init__(self, **kwargs):
        super().__init__("slewing_monitor", **kwargs)
        params = declare_parameters(self, SLEWING_MONITOR_DEFAULTS)
        self.core = SlewingMonitor(params)
        self.params = params
        self._last_arrival: float | None = None
        self._last_log = 0.0
        self.create_subscription(WrenchStamped, "slewing/load", self._on_load, DATA_QOS)
        self.diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_timer(params["diagnostics_period_s"], self.publish_diagnostics)

    def _on_load(self, msg: WrenchStamped) -> None:
        self._last_arrival = time.monotonic()
        reason = self.core.on_loads(*wrench_to_loads(msg))
        if reason and time.monotonic() - self._last_log > LOG_THROTTLE_S:
            self.get_logger().warning(f"rejected load: {reason} ({self.core.rejected} so far)")
            self._last_log = time.monotonic()

    def publish_diagnostics(self) -> None:
        level, message, values = self.core.period_report()
        silent = self._last_arrival is None or time.monotonic() - self._last_arrival > self.params["input_timeout_s"]
        if silent:
            level = 3
            message = f"no data on slewing/load for {self.params['input_timeout_s']:g} s; " + message
        status = make_status(self.get_name(), f"{self.params['bearing']} roller contact", self.params["machine_id"],
                             level, message, values, ROLLER_CONTACT_KEYS + EXTRA_KEYS)
        self.diag_pub.publish(make_array(self.get_clock().now().to_msg(), [status]))


def main(argv: list[str] | None = None) -> int:
    rclpy.init(args=argv)
    node = None
    try:
        node = SlewingMonitorNode()
        rclpy.spin(node)
    except InputError as exc:
        print(f"slewing_monitor: error: {exc}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
