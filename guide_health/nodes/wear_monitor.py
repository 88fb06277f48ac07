"""`wear_monitor`: live precision monitor of a guideway (thin rclpy adapter around PrecisionMonitor).

Subscribes `joint_states`, `guide/load`, `guide/straightness` (and `guide/temperature`), publishes
`/diagnostics`, `guide/straightness_predicted` and `guide/remaining_life`. Time comes from header stamps,
so a bag replayed at any rate gives the same numbers. State persists in SQLite (`state_file`).

Executor (parameter `executor`; `auto`, the default, is `events` unless `sensor_qos` is `best_effort`,
guide_health/nodes/qos.py): `events` spins rclpy's EventsExecutor with raw subscriptions
for joint_states and guide/load, decoded at fixed CDR offsets (guide_health.io.cdr.RawMessageDecoder, a few
us) instead of rclpy deserialisation; it handles messages in arrival order across topics, so a
header-less straightness message is dated by the joint samples published before it. `single_threaded`
is rclpy's SingleThreadedExecutor with deserialised messages (the reference; it takes one message per
subscription per wait, so under a backlog a straightness message overtakes queued joint samples).
"""
from __future__ import annotations

import math
import sys
import time

from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64

from guide_health.errors import InputError
from guide_health.io.cdr import MISSING, RawMessageDecoder
from guide_health.io.interfaces import JOINT_STATE, WRENCH_STAMPED
from guide_health.io.state_store import StateStore, resolve_state_path
from guide_health.models.wear.feed import StampAlignedFeed
from guide_health.models.wear.input_rules import (
    EMPTY_JOINT_STATES,
    INVALID_STAMP,
    JOINT_POSITION_MISSING,
    MALFORMED_JOINT_STATES,
    MALFORMED_LOAD,
    STRAIGHTNESS_WITHOUT_TIME_BASE,
    header_stamp_ns,
    joint_missing,
    rejected_keys,
)
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.models.wear.state_schema import check_precision_state, state_fingerprint
from guide_health.nodes.common import run_node
from guide_health.nodes.live_params import PeriodicTimers, apply_wear_changes
from guide_health.nodes.qos import SensorSubscriptions, resolve_executor
from guide_health.nodes.status import RejectionLog, StatusTask, StatusUpdater
from guide_health.params import WEAR_MONITOR_SCHEMA, declare_parameters
from guide_health.params.wear_monitor import hardness_units_warning

# data QoS: parameter sensor_qos (guide_health/nodes/qos.py: reliable back-pressure vs best-effort loss)
# status keys (README "Diagnostics"): the first tuple of each task always, 'nan' until known; the rest when known
PRECISION_KEYS = ("straightness_um", "straightness_measured_um", "straightness_limit_um", "remaining_life_h",
                  "remaining_life_h_low", "remaining_life_h_high", "wear_volume_mm3", "sliding_distance_m",
                  "wear_coefficient", "lubrication_regime")
EXTRA_PRECISION_KEYS = ("wear_coefficient_low", "wear_coefficient_high", "measurements", "duty_load_speed_w",
                        "stroke_min_m", "stroke_max_m", "strokes", "rejected_samples", "samples",
                        "rejected_recent_share", "messages_lost", "best_effort_topics")
TIMING_KEYS = ("load_samples", "callback_time_us", "model_time_us")
ROLLING_PRECISION_KEYS = ("lambda", "asperity_load_share", "boundary_share_recent", "boundary_share_total")
FATIGUE_KEYS = ("equivalent_load_n", "rating_life_km", "travel_km", "life_used_fraction", "remaining_life_km")
EXTRA_FATIGUE_KEYS = ("duty_load_n", "carriages")
INPUTS = ("joint_states", "guide/load")     # silent for input_timeout_s: every status STALE


def stamp_ns(header) -> int | None:
    """The header stamp [ns], None when invalid (input_rules.header_stamp_ns)."""
    return header_stamp_ns(header.stamp.sec, header.stamp.nanosec)


class WearMonitorNode(Node):
    def __init__(self, **kwargs):
        super().__init__("wear_monitor", **kwargs)
        params = declare_parameters(self, WEAR_MONITOR_SCHEMA, on_applied=self._apply_params)   # validated
        self.periodic = PeriodicTimers(self)
        self.params = params
        self.startup_warnings = [w for w in (hardness_units_warning(params),) if w is not None]
        for warning in self.startup_warnings:     # issue 11 item 3: a real hardness in Pa with seed 000's K
            self.get_logger().warning(warning)
        self.joint = params["joint"]
        self.monitor = PrecisionMonitor(params)
        self.state_key = f"{params['machine_id']}/{self.joint}/precision"
        self.state_path = resolve_state_path(params["state_file"], params["machine_id"], self.get_name())
        self.fingerprint = state_fingerprint(params)
        self.store = StateStore(self.state_path) if self.state_path is not None else None
        if self.store is not None:
            try:
                self._resume()
            except BaseException:
                self.store.close()      # the lock goes at once (a test process builds the next node)
                raise
        self.feed = StampAlignedFeed(self.monitor, params["input_align_window_s"])
        self.rejections = RejectionLog(self.get_logger())
        self.temperature_c = math.nan
        # cost accounting since start: callback wall time per message and the model's part of it
        self._callback_s = 0.0
        self._model_s = 0.0
        self._callbacks = 0

        self.updater = StatusUpdater(self, params["machine_id"], params["input_timeout_s"], alarms=True)
        self.diag_pub = self.updater.publisher
        self.precision_task = f"{self.joint} precision"
        self._add_status_tasks()
        self.raw = resolve_executor(params, self.get_parameter("use_sim_time").value) == "events"
        self._subscribe_inputs()
        self.pred_pub = self.create_publisher(Float64, "guide/straightness_predicted", 10)
        self.life_pub = self.create_publisher(Float64, "guide/remaining_life", 10)
        self.periodic.create("diagnostics_period_s", params["diagnostics_period_s"], self.publish_diagnostics)
        if self.store is not None:
            self.periodic.create("checkpoint_period_s", params["checkpoint_period_s"], self.checkpoint)

    def _apply_params(self, changed: dict) -> None:
        """An accepted ``ros2 param set`` (guide_health.nodes.live_params)."""
        apply_wear_changes(changed, [self.monitor], [self.feed], self.updater, self.periodic)

    def _resume(self) -> None:
        template = self.monitor.state()
        saved = self.store.load(self.state_key, self.fingerprint, lambda s: check_precision_state(s, template))
        if saved is not None:
            try:    # validated whole above: a failure here is a bug, still one line
                self.monitor.restore(saved)
            except (LookupError, TypeError, ValueError, ArithmeticError) as exc:
                raise InputError(f"state file {self.state_path}: {exc}; move it away to start afresh") from None
            self.get_logger().info(
                f"resumed from {self.state_path}: {self.monitor.integrator.sliding_distance_m:.1f} m "
                f"slid, {self.monitor.estimator.count} measurements")

    def _subscribe_inputs(self) -> None:
        p = self.params
        self.sensors = SensorSubscriptions(self, p["sensor_qos"], p["sensor_queue_depth"], with_info=not self.raw)
        subscribe = self.sensors.subscribe
        if self.raw:
            self._joint_decoder = RawMessageDecoder(JOINT_STATE, ("sec", "nsec", "position", "velocity"),
                                                    self.joint, absent=0.0)   # no velocity array: 0
            self._load_decoder = RawMessageDecoder(WRENCH_STAMPED, ("sec", "nsec", "fz"))
            subscribe(JointState, "joint_states", self._on_joint_raw, raw=True)
            subscribe(WrenchStamped, "guide/load", self._on_load_raw, raw=True)
        else:
            subscribe(JointState, "joint_states", self._on_joint)
            subscribe(WrenchStamped, "guide/load", self._on_load)
        subscribe(Float64, "guide/straightness", self._on_straightness)
        subscribe(Temperature, "guide/temperature", self._on_temperature)

    def _add_status_tasks(self) -> None:
        rolling = self.monitor.rolling is not None
        self.updater.add(StatusTask(
            self.precision_task, self._precision_report, PRECISION_KEYS,
            EXTRA_PRECISION_KEYS + TIMING_KEYS + (ROLLING_PRECISION_KEYS if rolling else ())
            + rejected_keys(self.joint), stale_inputs=INPUTS))
        if rolling:
            self.updater.add(StatusTask(f"{self.joint} fatigue", self._fatigue_report, FATIGUE_KEYS,
                                        EXTRA_FATIGUE_KEYS, stale_inputs=INPUTS, stale_prefix="no data on {inputs}; "))

    # --- inputs ----------------------------------------------------------------------------------
    def _rejected(self, reason: str | None) -> None:
        self.rejections.log(reason)

    def _rejected_all(self, reasons: list) -> None:
        self.rejections.log_all(reasons)

    def _on_joint_raw(self, raw: bytes) -> None:
        t0 = time.perf_counter()
        values = self._joint_decoder.decode(raw)
        if values is None or values is MISSING:
            # not the fixed layout, or the joint is absent: the message class gives the exact reason
            try:
                msg = deserialize_message(raw, JointState)
            except Exception:  # noqa: BLE001 - anything undecodable is malformed input
                self.updater.touch("joint_states")
                self._rejected(self.monitor.reject_input("joint_states", MALFORMED_JOINT_STATES))
                return
            self._on_joint(msg)
            return
        self.updater.touch("joint_states")
        sec, nsec, position, velocity = values
        t_ns = header_stamp_ns(sec, nsec)
        if t_ns is None:
            self._rejected(self.monitor.reject_input("joint_states", INVALID_STAMP))
            return
        t1 = time.perf_counter()
        reasons = self.feed.joint(t_ns, position, velocity, time.monotonic())
        t2 = time.perf_counter()
        self._rejected_all(reasons)
        self._account(t0, t1, t2)

    def _on_load_raw(self, raw: bytes) -> None:
        t0 = time.perf_counter()
        values = self._load_decoder.decode(raw)
        if values is None:
            try:
                msg = deserialize_message(raw, WrenchStamped)
            except Exception:  # noqa: BLE001
                self.updater.touch("guide/load")
                self._rejected(self.monitor.reject_input("guide/load", MALFORMED_LOAD))
                return
            self._on_load(msg)
            return
        self.updater.touch("guide/load")
        sec, nsec, force_z = values
        t_ns = header_stamp_ns(sec, nsec)
        if t_ns is None:
            self._rejected(self.monitor.reject_input("guide/load", INVALID_STAMP))
            return
        t1 = time.perf_counter()
        reasons = self.feed.load(t_ns, force_z, time.monotonic())
        t2 = time.perf_counter()
        self._rejected_all(reasons)
        self._account(t0, t1, t2)

    def _account(self, t0: float, t1: float, t2: float) -> None:
        self._callback_s += time.perf_counter() - t0
        self._model_s += t2 - t1
        self._callbacks += 1

    def _on_joint(self, msg: JointState) -> None:
        self.updater.touch("joint_states")
        if not msg.name or len(msg.position) == 0:
            self._rejected(self.monitor.reject_input("joint_states", EMPTY_JOINT_STATES))
            return
        try:
            i = list(msg.name).index(self.joint)
        except ValueError:
            self._rejected(self.monitor.reject_input("joint_states", joint_missing(self.joint)))
            return
        if i >= len(msg.position):
            self._rejected(self.monitor.reject_input("joint_states", JOINT_POSITION_MISSING))
            return
        velocity = msg.velocity[i] if i < len(msg.velocity) else 0.0
        t_ns = stamp_ns(msg.header)
        if t_ns is None:
            self._rejected(self.monitor.reject_input("joint_states", INVALID_STAMP))
            return
        t1 = time.perf_counter()
        reasons = self.feed.joint(t_ns, float(msg.position[i]), float(velocity), time.monotonic())
        t2 = time.perf_counter()
        self._rejected_all(reasons)
        self._account(t1, t1, t2)   # deserialisation happened before the callback: not measurable here

    def _on_load(self, msg: WrenchStamped) -> None:
        self.updater.touch("guide/load")
        t_ns = stamp_ns(msg.header)
        if t_ns is None:
            self._rejected(self.monitor.reject_input("guide/load", INVALID_STAMP))
            return
        t1 = time.perf_counter()
        reasons = self.feed.load(t_ns, float(msg.wrench.force.z), time.monotonic())
        t2 = time.perf_counter()
        self._rejected_all(reasons)
        self._account(t1, t1, t2)

    def _on_straightness(self, msg: Float64) -> None:
        self._rejected_all(self.feed.flush_all())    # the joint samples that came before it count
        t = self.monitor.integrator.last_t_ns
        if t is None:
            self._rejected(self.monitor.rejected.reject(STRAIGHTNESS_WITHOUT_TIME_BASE))
            return
        self._rejected(self.monitor.on_straightness(t, float(msg.data)))

    def _on_temperature(self, msg: Temperature) -> None:
        if math.isfinite(msg.temperature):
            self.temperature_c = float(msg.temperature)

    # --- outputs ---------------------------------------------------------------------------------
    def _precision_report(self) -> tuple[int, str, dict]:
        report = self.monitor.report()
        n = self._callbacks
        report["callback_time_us"] = self._callback_s / n * 1e6 if n else math.nan
        report["model_time_us"] = self._model_s / n * 1e6 if n else math.nan
        report.update(self.sensors.values())
        return report["level"], report["message"] + self.sensors.message_suffix(), report

    def _fatigue_report(self) -> tuple[int, str, dict]:
        fatigue = self.monitor.fatigue_report()
        return fatigue["level"], fatigue["message"], fatigue

    def publish_diagnostics(self) -> None:
        self._rejected_all(self.feed.flush_aged(time.monotonic()))
        report = self.updater.update()[self.precision_task].values
        if math.isfinite(report["straightness_um"]):
            self.pred_pub.publish(Float64(data=report["straightness_um"] * 1e-6))
        if not math.isnan(report["remaining_life_h"]):
            self.life_pub.publish(Float64(data=report["remaining_life_h"] * 3600.0))

    def checkpoint(self) -> None:
        if self.store is not None:
            try:
                self.store.save({self.state_key: self.monitor.state()}, self.fingerprint)
            except InputError as exc:       # disk full, permissions: logged, retried at the next checkpoint
                self.get_logger().error(str(exc), throttle_duration_sec=60.0)

    def close(self) -> None:
        self._rejected_all(self.feed.flush_all())
        if self.store is not None:
            self.checkpoint()
            self.store.close()
            self.store = None


def main(argv: list[str] | None = None) -> int:
    return run_node("wear_monitor", WearMonitorNode, argv, events_executor=lambda node: node.raw)


if __name__ == "__main__":
    sys.exit(main())
