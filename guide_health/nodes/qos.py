"""Sensor QoS of the monitoring nodes, and the count of the sensor messages lost on the way.

The trade-off (docs/ros.md "QoS"): a RELIABLE, KEEP_ALL reader never loses a sample of a reliable writer:
when the node lags, its queue fills and the writer waits or queues (back-pressure), which is what a
lossless bag replay (``bag_player --max-rate 0``, the live == offline tests) needs. But a reliable reader
refuses a BEST_EFFORT writer (``SensorDataQoS``, the usual choice of drivers) as incompatible QoS. A
best-effort reader matches every writer and never slows a driver down; the price is loss when the node
lags (its KEEP_LAST queue is overwritten) or the network drops a datagram.

Parameter ``sensor_qos``:

- ``auto`` (default): per topic, RELIABLE KEEP_ALL until a best-effort publisher appears, then BEST_EFFORT
  KEEP_LAST(``sensor_queue_depth``) while one is there. The reliable subscription's incompatible-QoS
  event (DDS reports the refused writer) marks the topic, and a 1 s timer recreates its subscription: no
  graph query in the data path. The same timer looks at a best-effort topic's publishers (a graph query,
  outside the data path): when every one left is reliable (the best-effort driver gone, a reliable one
  there), the topic goes back to RELIABLE KEEP_ALL. Both kinds of sensors work out of the box, and reliable
  ones keep their back-pressure. A switch recreates the subscription: the few samples sent meanwhile are
  not received (the stamp-gap count, stream_gaps.py, sees them).
- ``reliable`` / ``best_effort``: one profile for every data topic.

Status keys ``messages_lost`` and ``best_effort_topics`` (how many data topics are subscribed best effort;
the node logs each switch). The loss is counted on best-effort subscriptions only (a reliable
KEEP_ALL one loses nothing):

- with message info (the ``single_threaded`` executor): the gaps in the writer's publication sequence
  numbers. A jump from n to n + k + 1 means k samples never reached the callback, whatever dropped them (a
  queue overwritten under KEEP_LAST, which DDS does not report, or a lost datagram). Message info carries no
  writer id, so it is counted only while the topic has one matched publisher (the subscription's matched
  event; a sensor driver); a number going
  backwards (a restarted driver) starts a new run, and what a writer sent before the first message received
  from it is not counted.
- without (the ``events`` executor: rclpy 7.1.6's EventsExecutor raises SystemError when a callback asks for
  message info): DDS's message_lost event, which Fast DDS raises for gaps it sees on the wire but not for
  an overwritten reader queue. ``executor: auto`` therefore spins the single-threaded executor when
  ``sensor_qos`` is ``best_effort``.
"""
from __future__ import annotations

from dataclasses import dataclass

SENSOR_QOS_CHOICES = ("auto", "reliable", "best_effort")
AUTO_CHECK_PERIOD_S = 1.0


def reader_profile(kind: str, depth: int):
    """The reader QoS of a data subscription: ``reliable`` (KEEP_ALL) or ``best_effort`` (KEEP_LAST depth)."""
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    if kind == "reliable":
        return QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE)
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(depth), reliability=ReliabilityPolicy.BEST_EFFORT)


def resolve_executor(executor: str, sensor_qos: str, use_sim_time: bool = False) -> str:
    """``events`` or ``single_threaded`` for the parameters ``executor`` and ``sensor_qos``; ``auto``: events
    (raw CDR, fastest) unless every sensor topic is best effort (``sensor_qos: best_effort``), where the exact
    loss count needs message info, or the node runs on ``/clock`` (``use_sim_time``): rclpy 7.1.6's
    EventsExecutor stopped taking messages then (three runs of test/test_sim_time.py: bag_player's data never
    acknowledged)."""
    if executor == "auto":
        slow = sensor_qos == "best_effort" or use_sim_time
        return "single_threaded" if slow else "events"
    return executor


class LossCounter:
    """Messages lost per topic: sequence-number gaps (``seen``) or DDS message_lost events (``reported``)."""

    def __init__(self):
        self.last_sequence: dict[str, int] = {}
        self.lost: dict[str, int] = {}
        self.single_writer: dict[str, bool] = {}

    def seen(self, topic: str, info) -> None:
        sequence = info.get("publication_sequence_number") if info else None
        if not sequence:
            return
        last = self.last_sequence.get(topic)
        if last is not None and sequence > last + 1 and self.single_writer.get(topic, False):
            self.lost[topic] = self.lost.get(topic, 0) + sequence - last - 1
        self.last_sequence[topic] = sequence

    def reported(self, topic: str, count: int) -> None:
        if count > 0:
            self.lost[topic] = self.lost.get(topic, 0) + int(count)

    @property
    def total(self) -> int:
        return sum(self.lost.values())

    def summary(self) -> str:
        """'' when nothing was lost, else '12 sensor messages lost (joint_states 10, guide/load 2)'."""
        if not self.total:
            return ""
        parts = ", ".join(f"{topic} {n}" for topic, n in self.lost.items() if n)
        return f"{self.total} sensor messages lost ({parts})"


@dataclass
class _Entry:
    msg_type: type
    topic: str
    callback: object
    raw: bool
    kind: str = ""
    subscription: object = None


class SensorSubscriptions:
    """The data subscriptions of a node under ``sensor_qos`` (module text). ``subscribe`` like
    ``create_subscription`` without the QoS; ``values()`` the status keys; ``message_suffix()`` the loss."""

    def __init__(self, node, mode: str, depth: int, with_info: bool):
        if mode not in SENSOR_QOS_CHOICES:
            raise ValueError(f"sensor_qos must be one of {', '.join(SENSOR_QOS_CHOICES)}, got {mode!r}")
        self.node, self.mode, self.depth, self.with_info = node, mode, int(depth), with_info
        self.entries: list[_Entry] = []
        self.losses = LossCounter()
        self.pending: set[str] = set()         # topics whose reliable subscription refused a best-effort writer
        node.create_timer(AUTO_CHECK_PERIOD_S, self.refresh)

    def subscribe(self, msg_type, topic: str, callback, raw: bool = False):
        entry = _Entry(msg_type, topic, callback, raw)
        self.entries.append(entry)
        self._create(entry, "best_effort" if self.mode == "best_effort" else "reliable")
        return entry.subscription

    def _create(self, entry: _Entry, kind: str) -> None:
        from rclpy.event_handler import SubscriptionEventCallbacks

        callback, topic, writers = entry.callback, entry.topic, self.losses.single_writer
        events = SubscriptionEventCallbacks(matched=lambda info: writers.__setitem__(topic, info.current_count == 1))
        if kind == "best_effort" and self.with_info:
            seen, inner = self.losses.seen, entry.callback
            callback = lambda msg, info: (seen(topic, info), inner(msg))  # noqa: E731
        elif kind == "best_effort":
            report = self.losses.reported
            events.message_lost = lambda event: report(topic, event.total_count_change)
        elif self.mode == "auto":
            events.incompatible_qos = lambda event: self.pending.add(topic)
        if entry.subscription is not None:
            self.node.destroy_subscription(entry.subscription)
        entry.subscription = self.node.create_subscription(
            entry.msg_type, topic, callback, reader_profile(kind, self.depth), raw=entry.raw, event_callbacks=events)
        entry.kind = kind

    def refresh(self) -> None:
        """``auto``: a topic whose reliable subscription refused a best-effort writer is subscribed best effort
        (outside the event callback, which belongs to the subscription being replaced); a best-effort topic
        whose publishers are all reliable again goes back to reliable."""
        for entry in self.entries:
            if entry.topic in self.pending and entry.kind == "reliable":
                self.node.get_logger().info(f"{entry.topic}: a best-effort publisher; best_effort subscription "
                                            f"(sensor_qos auto)")
                self._create(entry, "best_effort")
            elif self.mode == "auto" and entry.kind == "best_effort" and self._only_reliable_writers(entry.topic):
                self.node.get_logger().info(f"{entry.topic}: no best-effort publisher left; reliable subscription "
                                            f"(sensor_qos auto)")
                self._create(entry, "reliable")
        self.pending.clear()

    def _only_reliable_writers(self, topic: str) -> bool:
        """The topic has publishers and all of them are reliable (graph query)."""
        from rclpy.qos import ReliabilityPolicy

        writers = self.node.get_publishers_info_by_topic(topic)
        return bool(writers) and all(w.qos_profile.reliability == ReliabilityPolicy.RELIABLE for w in writers)

    def values(self) -> dict:
        return {"messages_lost": self.losses.total,
                "best_effort_topics": sum(e.kind == "best_effort" for e in self.entries)}

    def message_suffix(self) -> str:
        lost = self.losses.summary()
        return f"; {lost}" if lost else ""
