"""`slewing_monitor`: roller/raceway contact stress of a slewing bearing from its load topic.

Subscribes `slewing/load` (geometry_msgs/WrenchStamped: force.z = F_a, hypot(force.x, force.y) = F_r,
hypot(torque.x, torque.y) = M_T) and publishes `/diagnostics` (task `<bearing> roller contact`) every
`diagnostics_period_s` with the worst case since the last publish; STALE when loads stop. The contact
model (seed 003 Eq. 1, finite-roller end effect, McEwen field) is cached, so a message costs microseconds.
The slewing axis angle (`axis_topic`, joint `axis_joint`, sensor_msgs/JointState) gives the angle travelled:
the status adds the fatigue damage and remaining life per row and the static safety factor (docs/slewing.md).
The damage per row and the angle-counting state are committed every `checkpoint_period_s` (and at shutdown)
to the SQLite `state_file` (guide_health/io/state_store.py) and restored at start; a saved state that does not
read back is refused in one line and the damage starts at zero.

Executor (parameter `executor`; `auto`, the default, is `events` unless `sensor_qos` is `best_effort` or the
node runs on /clock, guide_health/nodes/qos.py resolve_executor): `events` spins rclpy's EventsExecutor, which
handles the messages in arrival order across topics, so a header-less tilting clearance (Float64) is dated
after every axis sample received before it (bag_player's barriers make the arrival order the bag's order).
`single_threaded` (rclpy's SingleThreadedExecutor, with message info for the exact loss count of best-effort
sensors) takes one message per subscription per wait: under a backlog a reading overtakes queued axis samples
and is dated too early.
"""
from __future__ import annotations

import math
import sys
import time

from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from guide_health.errors import InputError
from guide_health.io.state_store import StateStore, resolve_state_path, resume_with
from guide_health.models.slewing.monitor import SlewingMonitor, contact_level
from guide_health.models.slewing.raceway_wear import RACEWAY_WEAR_KEYS, check_wear_state
from guide_health.models.slewing.rating import ROWS
from guide_health.models.slewing.stamp_merge import ANGLE, LOAD, StampMerge
from guide_health.models.wear.input_rules import header_stamp_ns, joint_state_reason
from guide_health.models.wear.state_schema import fingerprint_mismatch
from guide_health.nodes.common import run_node
from guide_health.nodes.live_params import PeriodicTimers, apply_slewing_changes
from guide_health.nodes.qos import SensorSubscriptions, resolve_executor
from guide_health.nodes.status import StatusTask, StatusUpdater
from guide_health.params import SLEWING_MONITOR_SCHEMA, declare_parameters
from guide_health.params.typed import slewing_monitor_params

# data QoS: parameter sensor_qos (guide_health/nodes/qos.py: reliable back-pressure vs best-effort loss)
# status keys (README "Diagnostics"): ROLLER_CONTACT_KEYS always, 'nan' until known; EXTRA_KEYS when known
ROLLER_CONTACT_KEYS = ("roller_load_max_n", "p0_hertz_MPa", "p0_center_MPa", "p0_end_MPa", "end_stress_ratio",
                       "von_mises_max_MPa", "von_mises_depth_mm", "shear_max_MPa", "allowable_MPa")
EXTRA_KEYS = ("p_max_MPa", "p_max_position_mm", "shear_depth_mm", "von_mises_subsurface_max_MPa",
              "von_mises_surface_MPa", "axial_main_row_max_n",
              "axial_opposite_row_max_n", "radial_row_max_n", "worst_row", "loads_in_period", "rejected_loads",
              "messages_lost", "best_effort_topics",
              # saved fatigue states that did not read back at start-up (the damage started at zero)
              "state_refused",
              # models/wear/stream_gaps.py on the load stamps: samples missing by stamp gaps
              "samples_missing_estimate", "load_period_estimate_us", "load_stamp_pauses",
              # rating life per row over the axis angle and static safety (models/slewing/fatigue.py)
              *(f"{kind}_{row}{unit}" for row in ROWS for kind, unit in (
                  ("fatigue_damage", ""), ("fatigue_remaining_life", "_h"), ("dynamic_capacity", "_n"),
                  ("static_capacity", "_n"))),
              "fatigue_governing_row", "static_safety_factor", "static_safety_row", "limiting_curve_safety",
              "oscillation_strokes", "oscillation_strokes_below_critical", "rejected_axis_angles",
              # raceway wear -> tilting clearance, k and the remaining life to the replacement clearance
              *RACEWAY_WEAR_KEYS, "rejected_tilting_clearances")
#: the parameters a saved damage belongs to: another bearing geometry (capacities) refuses the saved state
FINGERPRINT_PARAMS = ("machine_id", "bearing", "roller_count", "radial_roller_count", "roller_diameter_m",
                      "roller_length_m", "raceway_diameter_m", "raceway_hardness_hrc")
LOG_THROTTLE_S = 5.0        # at most one rejected-load warning per period; it carries the running count


def wrench_to_loads(msg: WrenchStamped) -> tuple[float, float, float]:
    """(F_a, F_r, M_T) from a WrenchStamped (INTERFACES.md convention)."""
    f, m = msg.wrench.force, msg.wrench.torque
    return float(f.z), math.hypot(f.x, f.y), math.hypot(m.x, m.y)


class SlewingMonitorNode(Node):
    def __init__(self, **kwargs):
        super().__init__("slewing_monitor", **kwargs)
        params = declare_parameters(self, SLEWING_MONITOR_SCHEMA, on_applied=self._apply_params)
        p = slewing_monitor_params(params)
        self.periodic = PeriodicTimers(self)
        self.core = SlewingMonitor(p)
        self.params = params
        self.updater = StatusUpdater(self, p.machine_id, p.input_timeout_s, alarms=True)
        self.updater.add(StatusTask(f"{p.bearing} roller contact", self._report,
                                    ROLLER_CONTACT_KEYS, EXTRA_KEYS, stale_inputs=("slewing/load",)))
        self.diag_pub = self.updater.publisher
        # the events executor raises SystemError when a callback asks for message info (rclpy 7.1.6)
        self.events = resolve_executor(p.executor, p.sensor_qos, self.get_parameter("use_sim_time").value) == "events"
        self.sensors = SensorSubscriptions(self, p.sensor_qos, p.sensor_queue_depth, with_info=not self.events)
        self.sensors.subscribe(WrenchStamped, "slewing/load", self._on_load)
        self.axis_joint = p.axis_joint
        # loads and angles in stamp order, as the offline analysis takes them (models/slewing/stamp_merge.py)
        self.merge = StampMerge(self._consume, p.input_align_window_s)
        # the axis with the loads' QoS (reliable KEEP_ALL: a lagging node pushes back instead of losing angles)
        self.sensors.subscribe(JointState, p.axis_topic, self._on_axis)
        self.create_subscription(Float64, p.tilting_clearance_topic, self._on_clearance, 10)
        # std_srvs/Trigger maintenance/<axis_joint>/measure: the tilting clearance in maintenance_straightness_m
        self.create_service(Trigger, f"maintenance/{p.axis_joint}/measure", self._on_measure)
        self.periodic.create("diagnostics_period_s", p.diagnostics_period_s, self.publish_diagnostics)
        self.state_key = f"{p.machine_id}/{p.bearing}/slewing_fatigue"
        self.fingerprint = {name: getattr(p, name) for name in FINGERPRINT_PARAMS}
        self.state_refused = 0          # saved states that did not read back (the damage started at zero)
        self.state_reset_applied = False    # state_reset replaced a state of another geometry
        self.state_path = resolve_state_path(p.state_file, p.machine_id, self.get_name())
        self.store = StateStore(self.state_path) if self.state_path is not None else None
        if self.store is not None:
            self._refuse_another_geometry(p.state_reset)
            self._resume()
            self.periodic.create("checkpoint_period_s", p.checkpoint_period_s, self.checkpoint)

    def _refuse_another_geometry(self, reset: bool) -> None:
        """A saved state of another bearing geometry: InputError (one line naming what differs; the node does not
        start and the file is untouched) unless ``state_reset``, which starts from zero and replaces it."""
        saved = self.store.saved_fingerprint(self.state_key)
        diff = fingerprint_mismatch(saved, self.fingerprint) if isinstance(saved, dict) else ""
        if not diff:
            return
        if not reset:
            self.store.close()
            raise InputError(f"state file {self.state_path}: the slewing state '{self.state_key}' was saved for "
                             f"another bearing: {diff}; restore those parameters, move the file away, or start "
                             "with state_reset:=true to start from zero")
        self.get_logger().warning(f"state_reset: the saved state of '{self.state_key}' ({diff}) is not resumed; "
                                  "the fatigue damage and the raceway wear start at zero and the next checkpoint "
                                  "replaces it")
        self.state_reset_applied = True

    def _resume(self) -> None:
        if self.state_reset_applied:
            return
        """The damage and angle-counting state saved under ``state_key``; one that does not read back (not
        JSON, malformed, another bearing): one line, counted, the damage starts at zero."""
        fatigue = self.core.fatigue
        try:
            resumed = resume_with(self.store, self.state_key, self.fingerprint, self._restore)
        except InputError as exc:
            self.state_refused += 1
            what = str(exc).splitlines()[0].rsplit("; ", 1)[0]      # the store's advice does not apply here
            self.get_logger().warning(f"{what}: refused, the fatigue damage starts at zero (the next checkpoint "
                                      "overwrites the saved state)")
            return
        if resumed:
            damage = ", ".join(f"{row} {value:.6g}" for row, value in fatigue.row_damage().items())
            self.get_logger().info(f"resumed from {self.state_path} ({self.state_key}): fatigue damage {damage}, "
                                   f"{fatigue.strokes} strokes")

    def _restore(self, saved: dict) -> None:
        """The fatigue state and, when saved with it, the raceway wear (both checked before either changes)."""
        wear = saved.get("raceway_wear")
        if wear is not None:
            check_wear_state(wear)
        self.core.fatigue.restore(saved)
        if wear is not None:
            self.core.wear.restore(wear)

    def checkpoint(self) -> None:
        """The fatigue state in one transaction (a failed write is logged and retried at the next one)."""
        if self.store is None:
            return
        self.merge.release(time.monotonic())
        try:
            state = {**self.core.fatigue.state(), "raceway_wear": self.core.wear.state()}
            self.store.save({self.state_key: state}, self.fingerprint)
        except InputError as exc:
            self.get_logger().error(str(exc), throttle_duration_sec=60.0)

    def close(self) -> None:
        """Every held sample, the last checkpoint at shutdown; the state file's lock goes with it."""
        self.merge.flush()
        if self.store is not None:
            self.checkpoint()
            self.store.close()
            self.store = None

    def _apply_params(self, changed: dict) -> None:
        """An accepted ``ros2 param set`` (guide_health.nodes.live_params)."""
        apply_slewing_changes(changed, self.core, self.updater, self.periodic)

    def _on_load(self, msg: WrenchStamped) -> None:
        self.updater.touch("slewing/load")
        stamp = header_stamp_ns(msg.header.stamp.sec, msg.header.stamp.nanosec)    # None: no gap estimate
        self.merge.add(LOAD, stamp, (wrench_to_loads(msg), stamp), time.monotonic())

    def _consume(self, kind: int, item) -> None:
        """A load or an angle released by the stamp merge, into the core."""
        if kind == LOAD:
            loads, stamp = item
            reason = self.core.on_loads(*loads, t_ns=stamp)
            if reason:
                self.get_logger().warning(f"rejected load: {reason} ({self.core.rejected} so far)",
                                          throttle_duration_sec=LOG_THROTTLE_S)
            return
        reason = self.core.on_axis_angle(*item)
        if reason:
            self.get_logger().warning(f"rejected axis angle: {reason} ({self.core.rejected_angles} so far)",
                                      throttle_duration_sec=LOG_THROTTLE_S)

    def _on_axis(self, msg: JointState) -> None:
        """The slewing axis angle (joint ``axis_joint``): the angle travelled of the rating life."""
        reason, i = joint_state_reason(msg.name, len(msg.position), self.axis_joint)
        stamp = header_stamp_ns(msg.header.stamp.sec, msg.header.stamp.nanosec)
        if reason is None:
            self.merge.add(ANGLE, stamp, (float(msg.position[i]), stamp), time.monotonic())
            return
        self.core.reject_axis_angle()
        if reason:
            self.get_logger().warning(f"rejected axis angle: {reason} ({self.core.rejected_angles} so far)",
                                      throttle_duration_sec=LOG_THROTTLE_S)

    def _on_clearance(self, msg: Float64) -> None:
        """A measured tilting clearance [m], dated at the latest axis stamp: every sample received before it is
        taken first (the tilting test is made at standstill, so the travel so far is complete)."""
        self.merge.flush()
        reason = self.core.on_tilting_clearance(float(msg.data))
        if reason:
            self.get_logger().warning(f"rejected tilting clearance: {reason} ({self.core.rejected_clearances} so far)")
            return
        wear = self.core.wear
        self.get_logger().info(f"tilting clearance {float(msg.data) * 1e3:.4g} mm at axis stamp "
                               f"{wear.estimator.measurement_t_ns[-1]} ns (clearance per unit k "
                               f"{wear.clearance_per_k:.6g})")

    def _on_measure(self, request, response):
        """maintenance/<axis_joint>/measure: the tilting clearance read [m] in ``maintenance_straightness_m``
        (as `guide-health maintenance NS <axis_joint> measure --value 0.42mm --node slewing_monitor` sets it),
        dated ``maintenance_time_s`` (0 = the latest axis stamp); the values are cleared after the call."""
        names = ("maintenance_guide", "maintenance_straightness_m", "maintenance_time_s", "maintenance_note")
        values = {name: self.get_parameter(name).value for name in names}
        self.set_parameters([Parameter(name, value=SLEWING_MONITOR_SCHEMA[name].default) for name in names])
        self.merge.flush()
        clearance_m, time_s = float(values["maintenance_straightness_m"]), float(values["maintenance_time_s"])
        reason = self.core.on_tilting_clearance(clearance_m, round(time_s * 1e9) if time_s > 0 else None)
        response.success = reason is None
        response.message = reason or (f"tilting clearance {clearance_m * 1e3:.4g} mm entered "
                                      f"({self.core.wear.estimator.count} measurements)")
        return response

    def _report(self) -> tuple:
        level, message, values = self.core.period_report()
        values = {**values, **self.sensors.values(), "state_refused": self.state_refused,
                  "level_clear": self._level_clear(level, values)}
        return level, message + self.sensors.message_suffix(), values

    def _level_clear(self, level, values: dict):
        """The contact level with the thresholds lowered by alarm_clear_margin (models/levels.py hysteresis)."""
        p_max_pa = float(values.get("p_max_MPa", values.get("p0_center_MPa", math.nan))) * 1e6
        if not math.isfinite(p_max_pa):
            return level
        model = self.core.model
        return max(level, contact_level(p_max_pa, model.allowable_pa, model.warn_fraction,
                                        self.core.params.alarm_clear_margin))

    def publish_diagnostics(self) -> None:
        self.merge.release(time.monotonic())         # what waited out the window for the other topic
        self.updater.update()


def main(argv: list[str] | None = None) -> int:
    return run_node("slewing_monitor", SlewingMonitorNode, argv, events_executor=lambda node: node.events)


if __name__ == "__main__":
    sys.exit(main())
