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

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from guide_health.diagnostics import ROLLER_CONTACT_KEYS, make_array, make_status
from guide_health.models.slewing.monitor import SLEWING_MONITOR_DEFAULTS, SlewingMonitor
from guide_health.nodes.common import run_node
from guide_health.params import declare_parameters

# reliable keep_all: a lagging node pushes back on a reliable writer instead of dropping loads
DATA_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE)
EXTRA_KEYS = ("p_max_MPa", "p_max_position_mm", "shear_depth_mm", "axial_main_row_max_n",
              "axial_opposite_row_max_n", "radial_row_max_n", "worst_row", "loads_in_period", "rejected_loads")
LOG_THROTTLE_S = 5.0


def wrench_to_loads(msg: WrenchStamped) -> tuple[float, float, float]:
    """(F_a, F_r, M_T) from a WrenchStamped (INTERFACES.md convention)."""
    f, m = msg.wrench.force, msg.wrench.torque
    return float(f.z), math.hypot(f.x, f.y), math.hypot(m.x, m.y)


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
    return run_node("slewing_monitor", SlewingMonitorNode, argv)


if __name__ == "__main__":
    sys.exit(main())
