"""Status tasks and their updater: every node's /diagnostics, in the spirit of diagnostic_updater.

A :class:`StatusTask` is one DiagnosticStatus a node publishes: a task name, a report function returning
``(level, message, values)``, the keys to publish and the inputs whose silence makes it STALE. The
:class:`StatusUpdater` of a node owns the input-arrival bookkeeping (``touch(input)`` from each
subscription callback), runs the tasks, applies the STALE rule once for all of them and publishes one
DiagnosticArray per ``update()``.

Conventions (diagnostic_updater's, INTERFACES.md), with names unique per machine and node so that an
aggregator or rqt_robot_monitor never merges two machines: ``name`` = "<machine_id>/<node name>: <task>"
(:func:`status_name`), ``hardware_id`` = machine_id, levels OK/WARN/ERROR/STALE
(guide_health.models.levels.Level), one human sentence as ``message``, numbers as KeyValues (plain decimal
via repr(float); 'nan' when unknown).

:class:`RejectionLog` is the rejected-input warning: at most once per reason and period, with the count
of the repeats it held back.
"""
from __future__ import annotations

import math
import numbers
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from guide_health.models.levels import Alarm, Level

STALE_PREFIX = "no data on {inputs} for {timeout:g} s; "
ALARM_KEYS = ("alarm_events", "alarm_latched")      # statuses of an updater with alarms
ACKNOWLEDGE_SERVICE = "~/acknowledge_alarms"          # std_srvs/Trigger


def status_name(machine_id: str, node_name: str, task: str) -> str:
    """"m1/wear_monitor: x precision": the machine first, so that one diagnostic_aggregator pattern takes
    every machine's statuses and keeps them apart, sorted by machine (config/diagnostic_aggregator.yaml)."""
    return f"{machine_id}/{node_name}: {task}"


class Report(NamedTuple):
    """What a task reports (after the STALE rule, when it comes from the updater)."""

    level: Level
    message: str
    values: dict


@dataclass(frozen=True)
class StatusTask:
    """One published status.

    task: the part after "<node name>: "; report: () -> (level, message, values);
    keys: published always, 'nan' when absent from values; optional_keys: published when present;
    stale_inputs: input names (as given to StatusUpdater.touch) whose silence for longer than the
    updater's input timeout makes the status STALE, with ``stale_prefix`` (formatted with ``inputs``, the
    silent ones joined by ', ', and ``timeout`` in s) put before the report's message.
    """

    task: str
    report: Callable[[], tuple]
    keys: tuple[str, ...]
    optional_keys: tuple[str, ...] = ()
    stale_inputs: tuple[str, ...] = ()
    stale_prefix: str = STALE_PREFIX


def format_value(value) -> str:
    """A KeyValue's text: true/false, integers as such, floats by repr (nan, inf, -inf), None as nan. numpy
    scalars as the Python number (numpy 2's repr would publish 'np.float64(...)')."""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        value = float(value)
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if value is None:
        return "nan"
    return str(value)


def make_status(name: str, hardware_id: str, report: Report, keys: Iterable[str],
                optional_keys: Iterable[str] = ()) -> DiagnosticStatus:
    status = DiagnosticStatus()
    status.level = bytes([Level(report.level)])
    status.name = name
    status.hardware_id = hardware_id
    status.message = report.message
    values = report.values
    status.values = ([KeyValue(key=k, value=format_value(values.get(k, math.nan))) for k in keys]
                     + [KeyValue(key=k, value=format_value(values[k])) for k in optional_keys if k in values])
    return status


class StatusUpdater:
    """Runs a node's status tasks and publishes them on /diagnostics.

    hardware_id: the machine_id; input_timeout_s: silence after which a task's stale_inputs make it
    STALE (None: the node has no such inputs). The publisher is ``self.publisher``; the node's timer
    calls :meth:`update`.
    """

    def __init__(self, node, hardware_id: str, input_timeout_s: float | None = None, alarms: bool = False):
        self.node = node
        self.hardware_id = hardware_id
        self.input_timeout_s = input_timeout_s
        self.tasks: list[StatusTask] = []
        self.last_arrival: dict[str, float | None] = {}
        self.publisher = node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        # alarms (guide_health.models.levels.Alarm): hysteresis with the report's 'level_clear', ERROR latched
        # until a call of the node's ~/acknowledge_alarms service (std_srvs/Trigger)
        self.alarms: dict[str, Alarm] | None = {} if alarms else None
        if alarms:
            from std_srvs.srv import Trigger

            node.create_service(Trigger, ACKNOWLEDGE_SERVICE, self._acknowledge)

    def add(self, task: StatusTask) -> None:
        if task.stale_inputs and self.input_timeout_s is None:
            raise ValueError(f"task {task.task!r} has stale inputs but the updater has no input timeout")
        self.tasks.append(task)
        if self.alarms is not None:
            self.alarms[task.task] = Alarm()
        for name in task.stale_inputs:
            self.last_arrival.setdefault(name, None)

    def touch(self, input_name: str, now: float | None = None) -> None:
        """A message arrived on `input_name` (valid or not: the input is alive) now, or at ``now``
        (time.monotonic() of its arrival)."""
        self.last_arrival[input_name] = time.monotonic() if now is None else now

    def silent_inputs(self, names: Iterable[str], now: float) -> list[str]:
        timeout = self.input_timeout_s
        return [n for n in names if (t := self.last_arrival.get(n)) is None or now - t > timeout]

    def run(self, task: StatusTask, now: float) -> Report:
        """The task's report with the STALE rule applied."""
        level, message, values = task.report()
        alarm = self.alarms.get(task.task) if self.alarms is not None else None
        if alarm is not None:
            values = {**values, **alarm.values()}
        silent = self.silent_inputs(task.stale_inputs, now)
        if silent:
            prefix = task.stale_prefix.format(inputs=", ".join(silent), timeout=self.input_timeout_s)
            return Report(Level.STALE, prefix + message, values)
        if alarm is not None:
            level, message = alarm.update(Level(level), Level(values.get("level_clear", level)), message)
            values.update(alarm.values())
        return Report(Level(level), message, values)

    def _acknowledge(self, request, response):
        """~/acknowledge_alarms: clear every latched ERROR; the response names what was latched."""
        held = {task: alarm.acknowledge() for task, alarm in self.alarms.items()}
        held = {task: n for task, n in held.items() if n}
        response.success = True
        response.message = ("acknowledged " + ", ".join(f"{task} ({n} ERROR events)" for task, n in held.items())
                            if held else "no latched alarm")
        return response

    def update(self) -> dict[str, Report]:
        """Run every task, publish one DiagnosticArray; the reports by task name."""
        now = time.monotonic()
        reports = {task.task: self.run(task, now) for task in self.tasks}
        node_name = self.node.get_name()
        extra = ALARM_KEYS if self.alarms is not None else ()
        statuses = [make_status(status_name(self.hardware_id, node_name, task.task), self.hardware_id,
                                reports[task.task], task.keys + extra, task.optional_keys) for task in self.tasks]
        array = DiagnosticArray()
        array.header.stamp = self.node.get_clock().now().to_msg()
        array.status = statuses
        self.publisher.publish(array)
        return reports


class RejectionLog:
    """Warn "<prefix><reason>" at most once per `period_s` per reason, with " (+N more since last report)"
    for the N repeats held back in between (README: "logs it at most once per 5 s with a count of
    repeats"). rclpy's ``throttle_duration_sec`` throttles per call site, not per reason, and drops the
    repeats without counting them, so it cannot keep that promise."""

    def __init__(self, logger, period_s: float = 5.0, prefix: str = "rejected input: "):
        self.logger = logger
        self.period_s = float(period_s)
        self.prefix = prefix
        self.last_logged: dict[str, float] = {}
        self.suppressed: dict[str, int] = {}

    def log(self, reason: str | None) -> None:
        if reason is None:
            return
        now = time.monotonic()
        last = self.last_logged.get(reason)
        if last is None or now - last >= self.period_s:
            more = self.suppressed.pop(reason, 0)
            suffix = f" (+{more} more since last report)" if more else ""
            self.logger.warning(f"{self.prefix}{reason}{suffix}")
            self.last_logged[reason] = now
        else:
            self.suppressed[reason] = self.suppressed.get(reason, 0) + 1

    def log_all(self, reasons: Iterable[str | None]) -> None:
        for reason in reasons:
            self.log(reason)
