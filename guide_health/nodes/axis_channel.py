"""One axis of the wear_monitor node: its model (AxisMonitor), its input topics, status tasks and outputs.

The node owns the shared joint_states subscription and hands every JointState to each axis
(:meth:`AxisChannel.joint_values` / :meth:`AxisChannel.joint_message`); the axis subscribes its own load,
straightness and temperature topics and publishes ``<prefix>/straightness_predicted`` and
``<prefix>/remaining_life`` (prefix ``guide`` for the single-joint node, ``<axis>/guide`` otherwise).
"""
from __future__ import annotations

import math
import time

import numpy as np
from geometry_msgs.msg import WrenchStamped
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from guide_health.io.bag.cdr import RawBatchDecoder, RawMessageDecoder
from guide_health.io.bag.interfaces import JOINT_STATE, WRENCH_STAMPED
from guide_health.models.wear.axis import PRECISION_KEYS, AxisMonitor
from guide_health.models.wear.feed import StampAlignedFeed
from guide_health.models.wear.fit_watch import FIT_STATUS_KEYS
from guide_health.models.wear.input_rules import (
    INVALID_STAMP,
    LOAD_INPUT,
    MALFORMED_JOINT_STATES,
    MALFORMED_LOAD,
    NS_PER_S,
    STRAIGHTNESS_WITHOUT_TIME_BASE,
    header_stamp_ns,
    joint_state_reason,
    rejected_keys,
)
from guide_health.models.wear.maintenance import KINDS, MaintenanceEvent, stamp_text
from guide_health.nodes.status import RejectionLog, StatusTask
from guide_health.params.typed import wear_axis_params

# status keys (README "Diagnostics"): the first tuple of each task always, 'nan' until known; the rest when known
EXTRA_PRECISION_KEYS = ("wear_coefficient_low", "wear_coefficient_high", "measurements", "duty_load_speed_w",
                        "stroke_min_m", "stroke_max_m", "strokes", "rejected_samples", "samples",
                        "rejected_recent_share", "guide", "maintenance_event_count",
                        "last_maintenance", "messages_lost", "best_effort_topics",
                        # saved loaded-model records that did not read back at start-up (nodes/wear_monitor.py)
                        "model_records_refused",
                        # models/wear/stream_gaps.py: samples missing by stamp gaps (what messages_lost misses)
                        "samples_missing_estimate", "joint_samples_missing_estimate",
                        "load_samples_missing_estimate", "joint_period_estimate_us", "joint_stamp_pauses",
                        # the gauge's temperature term (docs/model_file.md): taken off the last measurement
                        "straightness_thermal_correction_um",
                        # where the load comes from; running hours and calendar (models/wear/running_time.py)
                        "load_source", "utilisation", "limit_date_utc", "limit_date_utc_low",
                        "limit_date_utc_high", "idle_since_utc") + FIT_STATUS_KEYS
TIMING_KEYS = ("load_samples", "callback_time_us", "model_time_us")
# a sliding guide has no lubrication regime (absent, not nan)
ROLLING_PRECISION_KEYS = ("lubrication_regime", "lambda", "asperity_load_share", "boundary_share_recent",
                          "boundary_share_total", "oil_viscosity_pa_s", "oil_temperature_c")
FATIGUE_KEYS = ("equivalent_load_n", "rating_life_km", "travel_km", "life_used_fraction", "remaining_life_km")
EXTRA_FATIGUE_KEYS = ("duty_load_n", "carriages", "guide")


def event_text(event: MaintenanceEvent) -> str:
    """'regrind of y front' (the guide when one is named)."""
    return f"{event.kind} of {event.axis}{' ' + event.guide if event.guide else ''}"


def _um(straightness_m: float) -> str:
    """A straightness entered with a call, in um; 'none' when no value was entered."""
    return "none" if math.isnan(straightness_m) else f"{straightness_m * 1e6:.2f} um"


def stamp_ns(header) -> int | None:
    """The header stamp [ns], None when invalid (input_rules.header_stamp_ns)."""
    return header_stamp_ns(header.stamp.sec, header.stamp.nanosec)


class AxisChannel:
    """The live wiring of one axis (``params``: one entry of guide_health.params.machine.axes_params; ``qos``:
    the node's SensorSubscriptions, guide_health/nodes/qos.py, which subscribes under ``sensor_qos``)."""

    def __init__(self, node, params: dict, qos, single: bool):
        self.node = node
        self.params = params
        self.name = params["axis"]
        self.joint = params["joint"]
        self.model_params = wear_axis_params(params)     # as started (the saved state's fingerprint)
        self.model = AxisMonitor(self.model_params)
        self.loaded_model: dict | None = None           # the record of a model file loaded live (model_service)
        self.feed = StampAlignedFeed(self.model, params["input_align_window_s"])
        prefix = "rejected input: " if single else f"rejected input on axis {self.name}: "
        self.rejections = RejectionLog(node.get_logger(), prefix=prefix)
        self.temperature_c = math.nan
        self.load_input = params["load_topic"]
        self.precision_task = f"{self.name} precision"
        self.joint_decoder = RawMessageDecoder(JOINT_STATE, ("sec", "nsec", "position", "velocity"),
                                               self.joint, absent=0.0)   # no velocity array: 0
        self.load_decoder = RawMessageDecoder(WRENCH_STAMPED, ("sec", "nsec", "fz"))
        # batches (events executor): the callbacks copy, AxisChannel.process decodes and feeds
        self.joint_batch = RawBatchDecoder(JOINT_STATE, ("sec", "nsec", "position", "velocity"), self.joint,
                                           absent=0.0)
        self.load_batch = RawBatchDecoder(WRENCH_STAMPED, ("sec", "nsec", "fz"))
        self.loads: list = []             # raw messages copied by on_load_raw, their arrival (monotonic s)
        self.load_arrivals: list = []     # and how many joint messages were copied before each
        self.load_after: list = []
        self.load_from_model = params["load_source"] == "model"    # no load topic: masses and motion
        if not self.load_from_model and node.raw:
            qos.subscribe(WrenchStamped, self.load_input, self.on_load_raw, raw=True)
        elif not self.load_from_model:
            qos.subscribe(WrenchStamped, self.load_input, self.on_load)
        qos.subscribe(Float64, params["straightness_topic"], self.on_straightness)
        qos.subscribe(Temperature, params["temperature_topic"], self.on_temperature)
        out = params["output_prefix"]
        self.pred_pub = node.create_publisher(Float64, f"{out}/straightness_predicted", 10)
        self.life_pub = node.create_publisher(Float64, f"{out}/remaining_life", 10)
        for kind in KINDS:      # std_srvs/Trigger maintenance/<axis>/<kind> (values: maintenance_* parameters)
            node.create_service(Trigger, f"maintenance/{self.name}/{kind}",
                                lambda request, response, kind=kind: self.on_maintenance_call(kind, response))

    def status_tasks(self, report_extras) -> list[StatusTask]:
        """`<axis> precision` (and `<axis> fatigue` for rolling guides); ``report_extras(values)`` adds the
        node's timing numbers."""
        rolling = self.model.rolling is not None
        inputs = ("joint_states",) if self.load_from_model else ("joint_states", self.load_input)

        def precision():
            report = self.model.report()
            report_extras(report)
            return report["level"], report["message"], report

        def fatigue():
            report = self.model.fatigue_report()
            return report["level"], report["message"], report

        tasks = [StatusTask(self.precision_task, precision, PRECISION_KEYS,
                            EXTRA_PRECISION_KEYS + TIMING_KEYS + (ROLLING_PRECISION_KEYS if rolling else ())
                            + rejected_keys(self.joint), stale_inputs=inputs)]
        if rolling:
            tasks.append(StatusTask(f"{self.name} fatigue", fatigue, FATIGUE_KEYS, EXTRA_FATIGUE_KEYS,
                                    stale_inputs=inputs, stale_prefix="no data on {inputs}; "))
        return tasks

    # --- inputs ----------------------------------------------------------------------------------
    def reject(self, stream: str, reason: str) -> None:
        self.rejections.log(self.model.reject_input(stream, reason))

    def joint_values(self, sec: int, nsec: int, position: float, velocity: float,
                     now: float | None = None) -> tuple[float, float]:
        """A decoded JointState sample of this axis (``now``: its arrival, monotonic s; None: now); returns
        the (start, end) perf_counter of the model."""
        t_ns = header_stamp_ns(sec, nsec)
        if t_ns is None:
            self.reject("joint_states", INVALID_STAMP)
            return 0.0, 0.0
        t1 = time.perf_counter()
        reasons = self.feed.joint(t_ns, position, velocity, time.monotonic() if now is None else now)
        t2 = time.perf_counter()
        self.rejections.log_all(reasons)
        return t1, t2

    def joint_message(self, msg: JointState, now: float | None = None) -> tuple[float, float]:
        """A deserialised JointState: this axis's joint picked out, or the message rejected for it."""
        reason, i = joint_state_reason(msg.name, len(msg.position), self.joint)
        if reason is not None:
            self.reject("joint_states", reason)
            return 0.0, 0.0
        velocity = msg.velocity[i] if i < len(msg.velocity) else 0.0
        stamp = msg.header.stamp
        return self.joint_values(stamp.sec, stamp.nanosec, float(msg.position[i]), float(velocity), now)

    def on_load(self, msg: WrenchStamped) -> None:
        self.node.process_inputs()        # the batch before it (when a raw message fell back to this path)
        self.node.updater.touch(self.load_input)
        t1, t2 = self._load(msg.header.stamp.sec, msg.header.stamp.nanosec, float(msg.wrench.force.z))
        self.node.account(t1, t1, t2)   # deserialisation happened before the callback: not measurable here

    def _load(self, sec: int, nsec: int, force_z: float, now: float | None = None) -> tuple[float, float]:
        t_ns = header_stamp_ns(sec, nsec)
        if t_ns is None:
            self.reject(LOAD_INPUT, INVALID_STAMP)
            return 0.0, 0.0
        t1 = time.perf_counter()
        reasons = self.feed.load(t_ns, force_z, time.monotonic() if now is None else now)
        t2 = time.perf_counter()
        self.rejections.log_all(reasons)
        return t1, t2

    def on_load_raw(self, raw: bytes) -> None:
        """The raw guide/load callback (events executor): a copy, handled with the node's batch."""
        self.loads.append(raw)
        self.load_arrivals.append(time.monotonic())
        self.load_after.append(len(self.node.joints))
        if len(self.loads) >= self.node.batch_messages:
            self.node.process_inputs()

    def process(self, jnow: list, decoded, bad: dict) -> float:
        """The batch of this axis: the node's joint messages arrived at ``jnow`` (monotonic s; ``decoded``:
        this axis's RawBatchDecoder result; ``bad``: {index: deserialised message, None if malformed} of those
        the batch path does not take) and the loads copied since the last batch, handled as the callbacks
        did one by one: runs of good messages through StampAlignedFeed.process, the others on the
        per-message path at their place. Returns the model's time [s]."""
        loads, lnow, after = self.loads, self.load_arrivals, np.array(self.load_after, dtype=np.int64)
        self.loads, self.load_arrivals, self.load_after = [], [], []
        if loads:
            self.node.updater.touch(self.load_input, lnow[-1])
        lvalues, lstatus = self.load_batch.decode(loads)
        lbad = np.flatnonzero((lstatus != 0) | (lvalues["nsec"] >= NS_PER_S)).tolist()
        jt = decoded[0]["sec"] * NS_PER_S + decoded[0]["nsec"]
        lt = lvalues["sec"] * NS_PER_S + lvalues["nsec"]
        breaks = sorted([(j, 1, j) for j in bad] + [(int(after[i]), 0, i) for i in lbad])
        model_s, j0, i0 = 0.0, 0, 0
        for pos, is_joint, k in breaks + [(len(jnow), 1, None)]:
            j1, i1 = (pos, int(np.searchsorted(after, pos, side="right"))) if is_joint else (pos, k)
            if j1 > j0 or i1 > i0:
                t1 = time.perf_counter()
                reasons = self.feed.process(jt[j0:j1], decoded[0]["position"][j0:j1], decoded[0]["velocity"][j0:j1],
                                            jnow[j0:j1], lt[i0:i1], lvalues["fz"][i0:i1], lnow[i0:i1],
                                            (after[i0:i1] - j0).tolist())
                model_s += time.perf_counter() - t1
                self.rejections.log_all(reasons)
            if k is None:
                break
            if is_joint:
                self._bad_joint(bad[k], jnow[k])
                j0, i0 = k + 1, i1
            else:
                self._bad_load(loads[k], lnow[k])
                j0, i0 = j1, k + 1
        return model_s

    def _bad_joint(self, msg, now: float) -> None:
        if msg is None:
            self.reject("joint_states", MALFORMED_JOINT_STATES)
        else:
            self.joint_message(msg, now)

    def _bad_load(self, raw: bytes, now: float) -> None:
        """A load message the batch decoder did not take: the per-message path of on_load_raw."""
        values = self.load_decoder.decode(raw)
        if values is None:
            try:
                msg = deserialize_message(raw, WrenchStamped)
            except Exception:  # noqa: BLE001 - anything undecodable is malformed input
                self.reject(LOAD_INPUT, MALFORMED_LOAD)
                return
            values = (msg.header.stamp.sec, msg.header.stamp.nanosec, float(msg.wrench.force.z))
        self._load(*values, now)

    def on_straightness(self, msg: Float64) -> None:
        self.node.process_inputs()
        self.rejections.log_all(self.feed.flush_all())    # the joint samples that came before it count
        t = self.model.last_t_ns
        if t is None:
            self.rejections.log(self.model.reject(STRAIGHTNESS_WITHOUT_TIME_BASE))
            return
        self.rejections.log(self.model.on_straightness(t, float(msg.data)))

    def on_temperature(self, msg: Temperature) -> None:
        """The rolling guide's Walther oil viscosity and the gauge's temperature correction, by stamp as offline; an
        implausible reading or an invalid stamp is a counted rejection."""
        self.node.process_inputs()
        t = stamp_ns(msg.header)
        if t is None:
            self.rejections.log(self.model.reject(INVALID_STAMP))
            return
        reason = self.model.on_temperature(t, float(msg.temperature))
        if reason is not None:
            self.rejections.log(reason)
            return
        self.temperature_c = float(msg.temperature)

    # --- maintenance ---------------------------------------------------------------------------------
    def maintenance_event(self, kind: str, values: dict) -> MaintenanceEvent | str:
        """The event a service call records (values: the node's maintenance_* parameters), or why none."""
        self.node.process_inputs()
        self.rejections.log_all(self.feed.flush_all())     # the present = every joint sample received
        now = self.model.last_t_ns
        if now is None:
            return "no joint_states sample of this axis yet: the event would have no time"
        t_ns = now
        if kind == "measure" and values["maintenance_time_s"] > 0:
            t_ns = int(round(values["maintenance_time_s"] * 1e9))
        a = values["maintenance_straightness_m"]
        return MaintenanceEvent(t_ns, kind, self.name, values["maintenance_guide"], a if a > 0 else math.nan,
                                "service", values["maintenance_note"])

    def on_maintenance_call(self, kind: str, response):
        """std_srvs/Trigger maintenance/<axis>/<kind>: the event applied (success, the value entered and the
        model's values after it), or refused with the reason (a repeat: 'already applied at <time>')."""
        event = self.maintenance_event(kind, self.node.maintenance_values())
        if isinstance(event, str):
            response.success, response.message = False, event
            return response
        earlier = self.model.repeat_of(event)
        if earlier is not None:         # the same call again (the node's own stamp when the axis stood still)
            response.success = False
            response.message = (f"already applied at {stamp_text(earlier.t_ns)}: {event_text(earlier)}, straightness "
                                f"entered {_um(earlier.straightness_m)}; nothing applied "
                                f"(maintenance_repeat_window_s {self.model.params.maintenance_repeat_window_s:g} s)")
            return response
        reason = self.model.schedule(event)
        if reason is not None:
            response.success, response.message = False, reason
            return response
        self.node.publish_event(event)
        report = self.model.report()
        response.success = True
        response.message = (f"{event_text(event)} at {stamp_text(event.t_ns)}: straightness entered "
                            f"{_um(event.straightness_m)}, model {report['straightness_um']:.2f} um, "
                            f"measured {report['straightness_measured_um']:.2f} um, K {report['wear_coefficient']:.4g}")
        self.node.get_logger().info(f"maintenance: {response.message}")
        return response

    def on_event(self, event: MaintenanceEvent) -> None:
        """An event from the maintenance/events topic (a bag, an HMI, this node's own)."""
        self.node.process_inputs()
        self.rejections.log(self.model.schedule(event))

    # --- outputs ---------------------------------------------------------------------------------
    def publish_outputs(self, values: dict) -> None:
        if math.isfinite(values["straightness_um"]):
            self.pred_pub.publish(Float64(data=values["straightness_um"] * 1e-6))
        if not math.isnan(values["remaining_life_h"]):
            self.life_pub.publish(Float64(data=values["remaining_life_h"] * 3600.0))

    def states(self, machine_id: str) -> dict[str, dict]:
        """{state key: state} of every guide of the axis, the axis's maintenance log and its loaded model."""
        keys = self.model.state_keys(machine_id)
        states = {keys[name]: self.model.guide_state(name) for name in self.model.guides}
        states[self.maintenance_key(machine_id)] = self.model.maintenance_state()
        if self.loaded_model is not None:       # {}: a dropped or refused record, overwritten (configured model)
            states[self.loaded_model_key(machine_id)] = self.loaded_model
        return states

    def maintenance_key(self, machine_id: str) -> str:
        return f"{machine_id}/{self.name}/maintenance"

    def loaded_model_key(self, machine_id: str) -> str:
        return f"{machine_id}/{self.name}/loaded_model"

    def resume(self, store, machine_id: str) -> list[tuple]:
        """Restore every guide saved in ``store``; the (key, guide model) pairs resumed."""
        resumed = []
        for name, key in self.model.state_keys(machine_id).items():
            saved = store.load(key)
            if saved is not None:
                self.model.restore_guide(name, saved)
                resumed.append((key, self.model.guide(name)))
        return resumed
