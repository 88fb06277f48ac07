"""Maintenance events on the wire and in bags: `<ns>/maintenance/events`, diagnostic_msgs/msg/DiagnosticArray.

Encoding (docs/machine.md): one DiagnosticArray per event; ``header.stamp`` = when the event happened in the
machine's time base (the stamps of joint_states); one DiagnosticStatus with ``level`` OK, ``name``
"maintenance: <axis>", ``message`` = the kind, ``hardware_id`` = machine_id and the KeyValues ``kind``,
``axis``, ``guide`` ('' = every guide of the axis), ``straightness_m`` (the straightness after a regrind or
rail replacement, or the manual reading; 'nan' = none), ``source`` and ``note`` (when one was entered). A
standard type, so any recorder, rqt or Foxglove shows it and ``ros2 bag record`` carries it.
"""
from __future__ import annotations

import math
from pathlib import Path

from guide_health.errors import InputError
from guide_health.models.wear.input_rules import MAINTENANCE_MALFORMED, MAINTENANCE_STRAIGHTNESS_NOT_A_NUMBER
from guide_health.models.wear.maintenance import MaintenanceEvent, clip

from .interfaces import topic_name
from .metadata import check_no_missing_messages, count_mismatches
from .storage import open_storage
from .typestore import header, message, typestore

MAINTENANCE_TOPIC = "maintenance/events"
DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"


def event_values(event: MaintenanceEvent) -> list[tuple[str, str]]:
    """The KeyValues of an event's DiagnosticStatus."""
    a = event.straightness_m
    values = [("kind", event.kind), ("axis", event.axis), ("guide", event.guide),
              ("straightness_m", "nan" if math.isnan(a) else repr(float(a))), ("source", event.source)]
    return values + [("note", event.note)] if event.note else values


class EventDecodeError(InputError):
    """A DiagnosticStatus on maintenance/events that is no event: ``reason`` is its input_rules reason."""

    def __init__(self, reason: str, details: str):
        super().__init__(f"{reason}: {details}")
        self.reason, self.details = reason, details


def event_from_status(t_ns: int, values: dict[str, str], message: str = "") -> MaintenanceEvent:
    """The event of one DiagnosticStatus (values: its KeyValues); EventDecodeError when it is not one."""
    if "axis" not in values:
        raise EventDecodeError(MAINTENANCE_MALFORMED, "no axis")
    text = values.get("straightness_m", "nan")
    try:
        straightness_m = float(text)
    except ValueError:
        raise EventDecodeError(MAINTENANCE_STRAIGHTNESS_NOT_A_NUMBER, f"straightness_m {clip(text)}") from None
    return MaintenanceEvent(int(t_ns), values.get("kind", message), values["axis"], values.get("guide", ""),
                            straightness_m, values.get("source", "") or "topic", values.get("note", ""))


def encode_events(events: list[MaintenanceEvent], machine_id: str) -> list[bytes]:
    """CDR bytes of one DiagnosticArray per event (rosbags; events are few)."""
    store = typestore()
    out = []
    for e in events:
        status = message("diagnostic_msgs/msg/DiagnosticStatus", level=b"\x00"[0], name=f"maintenance: {e.axis}",
                         message=e.kind, hardware_id=machine_id,
                         values=[message("diagnostic_msgs/msg/KeyValue", key=k, value=v) for k, v in event_values(e)])
        array = message(DIAGNOSTIC_ARRAY, header=header(e.t_ns), status=[status])
        out.append(bytes(store.serialize_cdr(array, DIAGNOSTIC_ARRAY)))
    return out


def read_events(bag: str | Path, namespace: str | None = None) -> list[MaintenanceEvent]:
    """Every maintenance event in a bag (its `<ns>/maintenance/events`), in stamp order; [] without."""
    store = typestore()
    events = []
    with open_storage(bag) as storage:
        wanted = [c for c in storage.connections if c.msgtype == DIAGNOSTIC_ARRAY
                  and (c.topic == topic_name(namespace, MAINTENANCE_TOPIC) if namespace is not None
                       else c.topic.endswith("/" + MAINTENANCE_TOPIC))]
        read: dict[str, int] = dict.fromkeys((c.topic for c in wanted), 0)
        topic_of = {c.id: c.topic for c in wanted}
        for batch in storage.iter_batches(wanted, 10_000):
            for cid in batch.connection_ids.tolist():
                read[topic_of[cid]] += 1
            for raw in batch.data:
                try:
                    msg = store.deserialize_cdr(bytes(raw), DIAGNOSTIC_ARRAY)
                except Exception:  # noqa: BLE001 - a malformed event is skipped, not a crash
                    continue
                t_ns = int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)
                for status in msg.status:
                    try:
                        events.append(event_from_status(t_ns, {kv.key: kv.value for kv in status.values},
                                                        status.message))
                    except InputError:
                        continue
    check_no_missing_messages(storage.path, count_mismatches(storage.path, read))
    return sorted(events, key=lambda e: e.t_ns)
