"""`wear_monitor`: live precision monitor of a guideway or of a whole machine (thin rclpy adapter around
one AxisMonitor per axis, guide_health/models/wear/axis.py; the per-axis wiring is nodes/axis_channel.py).

Single joint (no ``axes`` parameter): subscribes `joint_states`, `guide/load`, `guide/straightness` (and
`guide/temperature`), publishes `/diagnostics`, `guide/straightness_predicted` and `guide/remaining_life`.
A machine (``axes: [x, y, z]``, docs/machine.md): one `joint_states` for all axes, and per axis
`<axis>/guide/load`, `<axis>/guide/straightness`, ... and the statuses `<axis> precision` (+ `<axis> fatigue`).
Time comes from header stamps, so a bag replayed at any rate gives the same numbers. State persists in
SQLite (`state_file`), one key per guide.

Executor (parameter `executor`; `auto`, the default, is `events` unless `sensor_qos` is `best_effort` or
the node runs on /clock, guide_health/nodes/qos.py): `events` spins rclpy's EventsExecutor with raw
subscriptions for joint_states and guide/load, whose callbacks only copy the message and its arrival time;
batches are decoded at fixed CDR offsets with numpy (guide_health.io.bag.cdr.RawBatchDecoder) instead of rclpy
deserialisation and integrated through the model's batch path (:meth:`WearMonitorNode.process_inputs`,
the same numbers as one by one); it handles messages in arrival order across topics, so a header-less
straightness message is dated by the joint samples published before it. `single_threaded` is rclpy's
SingleThreadedExecutor with deserialised messages (the reference; it
takes one message per subscription per wait, so under a backlog a straightness message overtakes queued joint
samples).
"""
from __future__ import annotations

import math
import sys
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from guide_health.analysis.plan_report import plan_axis
from guide_health.errors import InputError
from guide_health.io.bag.maintenance import MAINTENANCE_TOPIC, EventDecodeError, event_from_status, event_values
from guide_health.io.outputs.json_text import json_text
from guide_health.io.state_store import StateStore, resolve_state_path, resume_monitor, resume_with
from guide_health.models.wear.input_rules import INVALID_STAMP, MAINTENANCE_MALFORMED
from guide_health.models.wear.planning import parse_scenario
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.models.wear.state_schema import state_fingerprint
from guide_health.nodes.axis_channel import (  # noqa: F401 - the status keys are part of this module's API
    EXTRA_FATIGUE_KEYS,
    EXTRA_PRECISION_KEYS,
    FATIGUE_KEYS,
    PRECISION_KEYS,
    ROLLING_PRECISION_KEYS,
    TIMING_KEYS,
    AxisChannel,
    stamp_ns,
)
from guide_health.nodes.common import run_node
from guide_health.nodes.live_params import PeriodicTimers, apply_wear_changes
from guide_health.nodes.model_service import on_load_model, resume_loaded_model
from guide_health.nodes.qos import SensorSubscriptions, resolve_executor
from guide_health.nodes.status import StatusUpdater
from guide_health.params import WEAR_MONITOR_SCHEMA, declare_parameters
from guide_health.params.ros import declare_axis_parameters
from guide_health.params.wear_monitor import hardness_units_warning

# data QoS: parameter sensor_qos (guide_health/nodes/qos.py: reliable back-pressure vs best-effort loss)
# maintenance events are few and must not be lost: reliable; published transient local so that a recorder
# started later still gets the last ones, read volatile so that any publisher (a bag player) connects
EVENT_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)
EVENT_READ_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE)
INPUTS = ("joint_states", "guide/load")     # single joint: silent for input_timeout_s: every status STALE
# events executor: the raw joint/load callbacks copy; the messages are handled in batches of this many (and
# before a status, a straightness message, a temperature, a maintenance event, a checkpoint, a parameter change,
# shutdown), with the same result as one by one (StampAlignedFeed.process, test_live_batch.py)
INPUT_BATCH_MESSAGES = 2048


class WearMonitorNode(Node):
    def __init__(self, **kwargs):
        super().__init__("wear_monitor", **kwargs)
        params = declare_parameters(self, WEAR_MONITOR_SCHEMA, on_applied=self._apply_params)   # validated
        self.periodic = PeriodicTimers(self)
        self.params = params
        self.axes = declare_axis_parameters(self, params)         # {axis: params}, validated
        self.single = not params["axes"]
        self.startup_warnings = [w for w in {hardness_units_warning(p) for p in self.axes.values()} if w]
        for warning in self.startup_warnings:     # a real hardness in Pa with seed 000's K (units mix-up)
            self.get_logger().warning(warning)
        self.raw = resolve_executor(params["executor"], params["sensor_qos"],
                                    self.get_parameter("use_sim_time").value) == "events"
        # cost accounting since start: callback wall time per message and the model's part of it
        self._callback_s = 0.0
        self._model_s = 0.0
        self._callbacks = 0
        # raw joint_states messages copied by the callback, (raw, arrival monotonic s), handled in batches
        # (separate lists of untracked objects: no garbage-collector work per message, unlike tuples)
        self.joints: list = []
        self.joint_arrivals: list = []
        self.batch_messages = INPUT_BATCH_MESSAGES
        self.updater = StatusUpdater(self, params["machine_id"], params["input_timeout_s"], alarms=True)
        self.diag_pub = self.updater.publisher
        self.sensors = SensorSubscriptions(self, params["sensor_qos"], params["sensor_queue_depth"],
                                           with_info=not self.raw)
        self.channels = [AxisChannel(self, p, self.sensors, self.single) for p in self.axes.values()]
        self.by_axis = {channel.name: channel for channel in self.channels}
        first = self.channels[0]
        # the single-joint names of old (tests, tools): the first axis's model, feed and log
        self.joint, self.monitor, self.feed = first.joint, PrecisionMonitor(axis=first.model), first.feed
        self.rejections, self.precision_task = first.rejections, first.precision_task
        self.state_key = next(iter(first.model.state_keys(params["machine_id"]).values()))
        self.state_path = resolve_state_path(params["state_file"], params["machine_id"], self.get_name())
        self.store = StateStore(self.state_path) if self.state_path is not None else None
        self.model_records_refused = 0       # saved loaded-model records that did not read back
        if self.store is not None:
            try:
                self._resume()
            except BaseException:
                self.store.close()      # the lock goes at once (a test process builds the next node)
                raise
        for channel in self.channels:
            for task in channel.status_tasks(self._timing_values):
                self.updater.add(task)
        self.sensors.subscribe(JointState, "joint_states", self._on_joint_raw if self.raw else self._on_joint,
                               raw=self.raw)
        # maintenance events (docs/machine.md): published by the services, taken from any publisher or bag
        self.event_pub = self.create_publisher(DiagnosticArray, MAINTENANCE_TOPIC, EVENT_QOS)
        self.create_subscription(DiagnosticArray, MAINTENANCE_TOPIC, self._on_events, EVENT_READ_QOS)
        self.create_service(Trigger, "plan", self._on_plan)     # parameter plan_scenario: docs/planning.md
        # a model file loaded over the running model (nodes/model_service.py)
        self.create_service(Trigger, "~/load_model", lambda request, response: on_load_model(self, response))
        self.periodic.create("diagnostics_period_s", params["diagnostics_period_s"], self.publish_diagnostics)
        if self.store is not None:
            self.periodic.create("checkpoint_period_s", params["checkpoint_period_s"], self.checkpoint)

    def _apply_params(self, changed: dict) -> None:
        """An accepted ``ros2 param set`` (guide_health.nodes.live_params): every guide of every axis. (Declaring
        the per-axis parameters calls this too, before the axes exist, with nothing changed.)"""
        if not changed or not hasattr(self, "channels"):
            return
        self.process_inputs()
        apply_wear_changes(changed, [channel.model for channel in self.channels],
                           [channel.feed for channel in self.channels], self.updater,
                           self.periodic)

    def _resume(self) -> None:
        for channel in self.channels:
            fingerprint = state_fingerprint(self.params["machine_id"], channel.model_params)
            self._resume_loaded_model(channel, fingerprint)
            for name, key in channel.model.state_keys(self.params["machine_id"]).items():
                guide = channel.model.guide(name)
                if not resume_monitor(self.store, key, fingerprint, guide):     # validated whole, one line
                    continue
                self.get_logger().info(
                    f"resumed from {self.state_path} ({key}): {guide.integrator.sliding_distance_m:.1f} m slid, "
                    f"{guide.estimator.count} measurements")
            resume_with(self.store, channel.maintenance_key(self.params["machine_id"]), fingerprint,
                        channel.model.restore_maintenance)

    def _resume_loaded_model(self, channel, fingerprint: dict) -> None:
        """The model a file loaded live put on the axis, before its guides (nodes/model_service.py: the
        precedence); a record that does not read back: one line, counted, the configured model."""
        lines = []
        try:
            resume_with(self.store, channel.loaded_model_key(self.params["machine_id"]), fingerprint,
                        lambda record: lines.append(resume_loaded_model(channel, record)))
        except InputError as exc:
            self.model_records_refused += 1
            channel.loaded_model = {}       # the next checkpoint overwrites the refused record
            self.get_logger().warning(f"loaded-model record refused ({str(exc).splitlines()[0]}): axis "
                                      f"{channel.name} runs on the configured model")
            return
        for line in filter(None, lines):
            self.get_logger().info(f"axis {channel.name}: {line}")

    # --- inputs ----------------------------------------------------------------------------------
    def _on_joint_raw(self, raw: bytes) -> None:
        """The raw joint_states callback (events executor): a copy; every ``batch_messages`` messages (and
        before anything that reads or changes the model) :meth:`process_inputs` handles them."""
        self.joints.append(raw)
        self.joint_arrivals.append(time.monotonic())
        if len(self.joints) >= self.batch_messages:
            self.process_inputs()

    def process_inputs(self) -> None:
        """Handle the joint and load messages copied since the last batch, as their callbacks did one by one
        (each axis: AxisChannel.process; a message the batch decoder does not take goes the per-message way,
        deserialised, at its place)."""
        raws, arrivals = self.joints, self.joint_arrivals
        if not raws and not any(channel.loads for channel in self.channels):
            return
        t0 = time.perf_counter()
        self.joints, self.joint_arrivals = [], []
        count = len(raws) + sum(len(channel.loads) for channel in self.channels)
        bad = {}
        decoded = [channel.joint_batch.decode(raws) for channel in self.channels]
        if raws:
            self.updater.touch("joint_states", arrivals[-1])
            worse = np.zeros(len(raws), dtype=bool)
            for values, status in decoded:
                worse |= (status != 0) | (values["nsec"] >= 1_000_000_000)
            bad = {j: _deserialise(raws[j]) for j in np.flatnonzero(worse).tolist()}
        model_s = sum(channel.process(arrivals, d, bad) for channel, d in zip(self.channels, decoded))
        self._callback_s += time.perf_counter() - t0
        self._model_s += model_s
        self._callbacks += count

    def _on_joint(self, msg: JointState) -> None:
        self.process_inputs()             # (a node fed both ways: the copied messages came first)
        self.updater.touch("joint_states")
        for channel in self.channels:
            t1, t2 = channel.joint_message(msg)
            self.account(t1, t1, t2)   # deserialisation happened before the callback: not measurable here

    def _on_load_raw(self, raw: bytes) -> None:
        self.channels[0].on_load_raw(raw)

    def _on_load(self, msg) -> None:
        self.channels[0].on_load(msg)

    def _on_straightness(self, msg) -> None:
        self.channels[0].on_straightness(msg)

    def _on_events(self, msg: DiagnosticArray) -> None:
        """Events from maintenance/events: those of this node's axes applied; one that is no event or cannot
        be applied counted under its reason (``rejected: maintenance event <reason>``) and logged."""
        t_ns = stamp_ns(msg.header)
        for status in msg.status:
            values = {kv.key: kv.value for kv in status.values}
            channel = self.by_axis.get(values.get("axis", ""))
            if channel is None:
                continue          # another node's axis: not ours
            if t_ns is None:
                channel.rejections.log(channel.model.reject_event(MAINTENANCE_MALFORMED, INVALID_STAMP))
                continue
            try:
                event = event_from_status(t_ns, values, status.message)
            except EventDecodeError as exc:
                channel.rejections.log(channel.model.reject_event(exc.reason, exc.details))
                continue
            channel.on_event(event)

    def maintenance_values(self) -> dict:
        """The maintenance_* parameters for a service call, then cleared (each call states its own values)."""
        names = ("maintenance_guide", "maintenance_straightness_m", "maintenance_time_s", "maintenance_note")
        values = {name: self.get_parameter(name).value for name in names}
        self.set_parameters([Parameter(name, value=WEAR_MONITOR_SCHEMA[name].default) for name in names])
        return values

    def _on_plan(self, request, response):
        """std_srvs/Trigger `plan`: the limit date of every guide of every axis as observed and under the
        ``plan_scenario`` parameter's scenario, now (the inputs received so far integrated first); ``message``
        the JSON of `guide-health plan --json` ({machine, rows}); a bad scenario: success False, the reason."""
        self.process_inputs()
        machine = str(self.params["machine_id"])
        text = str(self.get_parameter("plan_scenario").value)
        try:
            scenarios = [parse_scenario(text)] if text.strip() else []
            rows = [row for channel in self.channels for row in plan_axis(machine, channel.model, scenarios)]
        except (ValueError, InputError) as exc:
            response.success, response.message = False, str(exc).splitlines()[0]
            return response
        response.success, response.message = True, json_text({"machine": machine, "rows": rows})
        return response

    def publish_event(self, event) -> None:
        msg = DiagnosticArray()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(event.t_ns), 1_000_000_000)
        status = DiagnosticStatus(level=DiagnosticStatus.OK, name=f"maintenance: {event.axis}", message=event.kind,
                                  hardware_id=self.params["machine_id"])
        status.values = [KeyValue(key=k, value=v) for k, v in event_values(event)]
        msg.status = [status]
        self.event_pub.publish(msg)
        self.checkpoint()           # the event is in the state database at once

    def account(self, t0: float, t1: float, t2: float) -> None:
        self._callback_s += time.perf_counter() - t0
        self._model_s += t2 - t1
        self._callbacks += 1

    # --- outputs ---------------------------------------------------------------------------------
    def _timing_values(self, report: dict) -> None:
        n = self._callbacks
        report["callback_time_us"] = self._callback_s / n * 1e6 if n else math.nan
        report["model_time_us"] = self._model_s / n * 1e6 if n else math.nan
        report.update(self.sensors.values())          # messages_lost, best_effort_topics (nodes/qos.py)
        report["model_records_refused"] = self.model_records_refused
        report["message"] += self.sensors.message_suffix()

    def publish_diagnostics(self) -> None:
        self.process_inputs()
        now = time.monotonic()
        for channel in self.channels:
            channel.rejections.log_all(channel.feed.flush_aged(now))
        reports = self.updater.update()
        for channel in self.channels:
            channel.publish_outputs(reports[channel.precision_task].values)

    def checkpoint(self) -> None:
        if self.store is None:
            return
        self.process_inputs()
        for channel in self.channels:    # one transaction per axis (each axis has its own fingerprint)
            try:
                self.store.save(channel.states(self.params["machine_id"]),
                                state_fingerprint(self.params["machine_id"], channel.model_params))
            except InputError as exc:       # disk full, permissions: logged, retried at the next checkpoint
                self.get_logger().error(str(exc), throttle_duration_sec=60.0)

    def close(self) -> None:
        self.process_inputs()
        for channel in self.channels:
            channel.rejections.log_all(channel.feed.flush_all())
        if self.store is not None:
            self.checkpoint()
            self.store.close()
            self.store = None


def _deserialise(raw: bytes) -> JointState | None:
    """The JointState of a raw message, None when it is not one (malformed)."""
    try:
        return deserialize_message(raw, JointState)
    except Exception:  # noqa: BLE001 - anything undecodable is malformed input
        return None


def main(argv: list[str] | None = None) -> int:
    return run_node("wear_monitor", WearMonitorNode, argv, events_executor=lambda node: node.raw)


if __name__ == "__main__":
    sys.exit(main())
