"""`wear_monitor`: live precision monitor of a guideway (thin rclpy adapter around PrecisionMonitor).

Subscribes `joint_states`, `guide/load`, `guide/straightness` (and `guide/temperature`), publishes
`/diagnostics`, `guide/straightness_predicted` and `guide/remaining_life`. Time comes from header stamps,
so a bag replayed at any rate gives the same numbers. State persists in SQLite (`state_file`).

Executor (parameter `executor`): `events` (default) spins rclpy's EventsExecutor with raw subscriptions
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

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64

from guide_health.io.cdr import MISSING, RawMessageDecoder
from guide_health.io.interfaces import JOINT_STATE, WRENCH_STAMPED
from guide_health.diagnostics import (
    EXTRA_PRECISION_KEYS,
    FATIGUE_KEYS,
    PRECISION_KEYS,
    make_array,
    make_status,
)
from guide_health.models.precision import STALE, PrecisionMonitor, StampAlignedFeed
from guide_health.nodes.common import run_node
from guide_health.params import (
    WEAR_MONITOR_DEFAULTS,
    declare_parameters,
    validate_wear_params,
)
from guide_health.io.state_store import StateStore

# Reliable + keep_all: when the callbacks lag, the reader's history fills and a reliable writer waits
# (back-pressure) instead of the reader overwriting unprocessed samples as keep_last would; a sensor
# publishing best-effort or keep_last still connects (the reader's QoS is the weaker side of neither).
DATA_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE)
LOG_THROTTLE_S = 5.0
TIMING_KEYS = ("load_samples", "callback_time_us", "model_time_us")
ROLLING_PRECISION_KEYS = ("lambda", "asperity_load_share", "boundary_share_recent", "boundary_share_total")
EXTRA_FATIGUE_KEYS = ("duty_load_n", "carriages")


def stamp_ns(header) -> int:
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


class WearMonitorNode(Node):
    def __init__(self, **kwargs):
        super().__init__("wear_monitor", **kwargs)
        params = declare_parameters(self, WEAR_MONITOR_DEFAULTS)
        validate_wear_params(params)
        self.params = params
        self.joint = params["joint"]
        self.monitor = PrecisionMonitor(params)
        self.state_key = f"{params['machine_id']}/{self.joint}/precision"
        self.store = StateStore(params["state_file"]) if params["state_file"] else None
        if self.store is not None:
            saved = self.store.load(self.state_key)
            if saved is not None:
                self.monitor.restore(saved)
                self.get_logger().info(
                    f"resumed from {params['state_file']}: {self.monitor.integrator.sliding_distance_m:.1f} m slid, "
                    f"{self.monitor.estimator.count} measurements")
        self.feed = StampAlignedFeed(self.monitor, params["input_align_window_s"])
        self._last_arrival = {"joint_states": None, "guide/load": None}
        self._last_log: dict[str, float] = {}
        self._suppressed: dict[str, int] = {}
        self.temperature_c = math.nan

        self.raw = params.get("executor", "events") == "events"
        if self.raw:
            self._joint_decoder = RawMessageDecoder(JOINT_STATE, ("sec", "nsec", "position", "velocity"),
                                                    self.joint)
            self._load_decoder = RawMessageDecoder(WRENCH_STAMPED, ("sec", "nsec", "fz"))
            self.create_subscription(JointState, "joint_states", self._on_joint_raw, DATA_QOS, raw=True)
            self.create_subscription(WrenchStamped, "guide/load", self._on_load_raw, DATA_QOS, raw=True)
        else:
            self.create_subscription(JointState, "joint_states", self._on_joint, DATA_QOS)
            self.create_subscription(WrenchStamped, "guide/load", self._on_load, DATA_QOS)
        # cost accounting since start: callback wall time per message and the model's part of it
        self._callback_s = 0.0
        self._model_s = 0.0
        self._callbacks = 0
        self.create_subscription(Float64, "guide/straightness", self._on_straightness, DATA_QOS)
        self.create_subscription(Temperature, "guide/temperature", self._on_temperature, DATA_QOS)
        self.diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.pred_pub = self.create_publisher(Float64, "guide/straightness_predicted", 10)
        self.life_pub = self.create_publisher(Float64, "guide/remaining_life", 10)
        self.create_timer(params["diagnostics_period_s"], self.publish_diagnostics)
        if self.store is not None:
            self.create_timer(params["checkpoint_period_s"], self.checkpoint)

    # --- inputs ----------------------------------------------------------------------------------
    def _rejected(self, reason: str | None) -> None:
        if reason is None:
            return
        now = time.monotonic()
        last = self._last_log.get(reason)
        if last is None or now - last >= LOG_THROTTLE_S:
            more = self._suppressed.pop(reason, 0)
            suffix = f" (+{more} more since last report)" if more else ""
            self.get_logger().warning(f"rejected input: {reason}{suffix}")
            self._last_log[reason] = now
        else:
            self._suppressed[reason] = self._suppressed.get(reason, 0) + 1

    def _rejected_all(self, reasons: list) -> None:
        for reason in reasons:
            self._rejected(reason)

    def _on_joint_raw(self, raw: bytes) -> None:
        t0 = time.perf_counter()
        values = self._joint_decoder.decode(raw)
        if values is None or values is MISSING:
            # not the fixed layout, or the joint is absent: the message class gives the exact reason
            try:
                msg = deserialize_message(raw, JointState)
            except Exception:  # noqa: BLE001 - anything undecodable is malformed input
                self._last_arrival["joint_states"] = time.monotonic()
                self._rejected(self.monitor._reject("malformed joint_states message"))
                return
            self._on_joint(msg)
            return
        self._last_arrival["joint_states"] = time.monotonic()
        sec, nsec, position, velocity = values
        t1 = time.perf_counter()
        reasons = self.feed.joint(sec * 1_000_000_000 + nsec, position, 0.0 if velocity != velocity else velocity,
                                  time.monotonic())
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
                self._last_arrival["guide/load"] = time.monotonic()
                self._rejected(self.monitor._reject("malformed guide/load message"))
                return
            self._on_load(msg)
            return
        self._last_arrival["guide/load"] = time.monotonic()
        sec, nsec, force_z = values
        t1 = time.perf_counter()
        reasons = self.feed.load(sec * 1_000_000_000 + nsec, force_z, time.monotonic())
        t2 = time.perf_counter()
        self._rejected_all(reasons)
        self._account(t0, t1, t2)

    def _account(self, t0: float, t1: float, t2: float) -> None:
        self._callback_s += time.perf_counter() - t0
        self._model_s += t2 - t1
        self._callbacks += 1

    def _on_joint(self, msg: JointState) -> None:
        self._last_arrival["joint_states"] = time.monotonic()
        if not msg.name or len(msg.position) == 0:
            self._rejected(self.monitor._reject("empty joint_states arrays"))
            return
        try:
            i = list(msg.name).index(self.joint)
        except ValueError:
            self._rejected(self.monitor._reject(f"joint '{self.joint}' not in joint_states"))
            return
        if i >= len(msg.position):
            self._rejected(self.monitor._reject("joint_states position shorter than name"))
            return
        velocity = msg.velocity[i] if i < len(msg.velocity) else 0.0
        t1 = time.perf_counter()
        reasons = self.feed.joint(stamp_ns(msg.header), float(msg.position[i]), float(velocity), time.monotonic())
        t2 = time.perf_counter()
        self._rejected_all(reasons)
        self._account(t1, t1, t2)   # deserialisation happened before the callback: not measurable here

    def _on_load(self, msg: WrenchStamped) -> None:
        self._last_arrival["guide/load"] = time.monotonic()
        t1 = time.perf_counter()
        reasons = self.feed.load(stamp_ns(msg.header), float(msg.wrench.force.z), time.monotonic())
        t2 = time.perf_counter()
        self._rejected_all(reasons)
        self._account(t1, t1, t2)

    def _on_straightness(self, msg: Float64) -> None:
        self._rejected_all(self.feed.flush_all())    # the joint samples that came before it count
        t = self.monitor.integrator.last_t_ns
        if t is None:
            self._rejected(self.monitor._reject("straightness before any joint_states (no time base)"))
            return
        self._rejected(self.monitor.on_straightness(t, float(msg.data)))

    def _on_temperature(self, msg: Temperature) -> None:
        if math.isfinite(msg.temperature):
            self.temperature_c = float(msg.temperature)

    # --- outputs ---------------------------------------------------------------------------------
    def stale_inputs(self) -> list[str]:
        now = time.monotonic()
        timeout = self.params["input_timeout_s"]
        return [topic for topic, t in self._last_arrival.items() if t is None or now - t > timeout]

    def publish_diagnostics(self) -> None:
        self._rejected_all(self.feed.flush_aged(time.monotonic()))
        report = self.monitor.report()
        n = self._callbacks
        report["callback_time_us"] = self._callback_s / n * 1e6 if n else math.nan
        report["model_time_us"] = self._model_s / n * 1e6 if n else math.nan
        level, message = report["level"], report["message"]
        stale = self.stale_inputs()
        if stale:
            level = STALE
            message = f"no data on {', '.join(stale)} for {self.params['input_timeout_s']:g} s; " + message
        rolling = self.monitor.rolling is not None
        status = make_status(self.get_name(), f"{self.joint} precision", self.params["machine_id"], level,
                             message, report, PRECISION_KEYS + EXTRA_PRECISION_KEYS + TIMING_KEYS
                             + (ROLLING_PRECISION_KEYS if rolling else ()))
        statuses = [status]
        if rolling:
            fatigue = self.monitor.fatigue_report()
            f_level, f_message = fatigue["level"], fatigue["message"]
            if stale:
                f_level, f_message = STALE, f"no data on {', '.join(stale)}; " + f_message
            statuses.append(make_status(self.get_name(), f"{self.joint} fatigue", self.params["machine_id"],
                                        f_level, f_message, fatigue, FATIGUE_KEYS + EXTRA_FATIGUE_KEYS))
        self.diag_pub.publish(make_array(self.get_clock().now().to_msg(), statuses))
        if math.isfinite(report["straightness_um"]):
            self.pred_pub.publish(Float64(data=report["straightness_um"] * 1e-6))
        if not math.isnan(report["remaining_life_h"]):
            self.life_pub.publish(Float64(data=report["remaining_life_h"] * 3600.0))

    def checkpoint(self) -> None:
        if self.store is not None:
            self.store.save({self.state_key: self.monitor.state()})

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
