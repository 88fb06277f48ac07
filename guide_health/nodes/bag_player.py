"""bag_player: publish a rosbag2 bag's messages on their topics, paced so that nothing is lost.

    bag_player BAG [--rate FACTOR | --max-rate MSGS_PER_S] [--topics T ...] [--remap-ns /m1]
                   [--wait-subscribers N] [--wait-timeout S] [--start-delay S] [--ack-timeout S]
                   [--start-after-ns T] [--clock [HZ]]

Every message is published as its raw CDR bytes (rclpy ``Publisher.publish(bytes)`` -> publish_raw,
no deserialisation) in log-time order, with the bag's message type. Pacing (`Pacer`, pure, no ROS):

- ``--rate F``: by log time / F (1 = real time, 100 = a hundred times faster); no rate cap unless
  ``--max-rate`` is given too.
- default: as fast as possible without loss = a token bucket at ``--max-rate`` (default
  DEFAULT_MAX_RATE msg/s, small bursts), which a cross-process SingleThreadedExecutor subscriber keeps
  up with. ``--max-rate 0`` removes the cap (bursts: subscribers will drop messages).

Data topics use reliable, volatile QoS with KEEP_ALL history (``--depth N`` for keep_last N). Measured
here: a reliable KEEP_LAST subscriber loses whatever its executor has not taken when its queue overflows,
whatever the publisher does, so the token bucket is what protects it; a reliable KEEP_ALL subscriber
pushes back on a KEEP_ALL publisher (publish blocks; when it gives up with "cannot publish data" the
player retries), so nothing is lost at any rate. A KEEP_ALL publisher costs a KEEP_LAST subscriber
nothing. ``--wait-subscribers N`` waits until every played topic has >= N subscribers (at most
``--wait-timeout`` s, then warns and plays anyway); after the last message the player waits until
reliable subscribers acknowledged everything (``Publisher.wait_for_all_acked``) before it exits.

Header-less messages (types in ``--barrier-types``, default std_msgs/msg/Float64 such as
guide/straightness) carry no time stamp, so a subscriber can only date them by their arrival among the
stamped messages. DDS keeps order per writer only, and a reliable writer may still hold thousands of
unacknowledged joint_states when the straightness writer sends: the measurement would overtake them.
Around each such message the player therefore waits until every other publisher's data has been
acknowledged (it is in the readers' queues), and after it until the message itself is (a sample lost to
a full transport buffer is resent only at the next heartbeat, seconds later, while joint_states flow on:
measured, measurements dated up to 3600 s of bag time late), which preserves the bag's order at the
subscriber's queue. ``--barrier-settle S`` waits S s more before the header-less message, for a subscriber
that dates it on arrival and must have taken the data before it (acknowledged = queued, not yet taken).

The same holds for any sparse topic (fewer than ``--barrier-sparse`` of the bag's messages, default
1 %), e.g. a guide load that changes once per job: a reliable sample refused by a full reader queue is
resent only at the next heartbeat, and the node would integrate the samples stamped after the load
change with the old load.

Simulated time: ``--clock [HZ]`` also publishes rosgraph_msgs/Clock on ``/clock`` (best effort, depth 1,
like ``ros2 bag play --clock``): the log time of the message about to be published, whenever it has
advanced by 1/HZ s of bag time (default 100 Hz) since the last clock message, and the last log time at
the end. Nodes started with ``use_sim_time:=true`` then run their timers (the diagnostics period) on bag
time, whatever the playback speed; the numbers never depend on it (they come from header stamps).

Topic names: as in the bag (absolute; ``--ros-args -r from:=to`` remaps them). ``--remap-ns /m1``
replaces the bag's machine namespace (the prefix of its `.../joint_states` or `.../slewing/load` topic,
'' if none) by /m1, so one bag can play as machine m1, m2, ... of a fleet. Exit 0 after the bag, 1 with one
line on a bad bag, 2 on bad arguments; a summary (messages, seconds, msg/s) goes to stderr.

A message that is not a CDR payload of its type (shorter than the type's fixed part, e.g. empty, or not
decodable, e.g. truncated; io/bag/payload.py) is skipped, never published, and counted per topic: a
subscriber would stop on it, or (DDS pads a payload to 4 bytes) take a truncated message for a valid one.
Exit EXIT_INCOMPLETE (3), with one line naming the topics and counts, when any message was skipped or a
topic's data was not acknowledged by the end.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from guide_health.errors import InputError
from guide_health.io.bag.payload import PayloadCheck
from guide_health.io.bag.storage import iter_raw_messages, open_storage

DEFAULT_MAX_RATE = 3000.0       # msg/s a cross-process SingleThreadedExecutor subscriber keeps up with
DEFAULT_BURST = 20              # messages a token-bucket burst may hold
DEFAULT_DEPTH = 0               # data topics: 0 = keep_all (back-pressure from keep_all subscribers)
# slewing first: a slewing bag's axis topic (`<ns>/slewing/joint_states`) also ends in joint_states
_MACHINE_SUFFIXES = ("slewing/load", "joint_states")
DEFAULT_BARRIER_TYPES = ("std_msgs/msg/Float64",)
DEFAULT_BARRIER_SPARSE = 0.01
DEFAULT_CLOCK_HZ = 100.0        # /clock messages per second of bag time (--clock)
EXIT_INCOMPLETE = 3             # a message skipped (not a payload of its type) or not acknowledged


# ---------------------------------------------------------------------------------------------
# pacing: pure, testable without ROS
# ---------------------------------------------------------------------------------------------

@dataclass
class Pacer:
    """When may each message go? Log-time pacing and/or a token bucket (GCRA), in seconds from start.

    rate: log-time speed factor (None: ignore log time); max_rate: msg/s cap (None or 0: none);
    burst: messages the bucket may release at once.
    """

    rate: float | None = None
    max_rate: float | None = None
    burst: int = 1

    def __post_init__(self) -> None:
        if self.rate is not None and not self.rate > 0:
            raise ValueError("rate must be > 0")
        if self.max_rate is not None and self.max_rate < 0:
            raise ValueError("max_rate must be >= 0")
        self.burst = max(1, int(self.burst))
        self._t0: int | None = None
        self._tat = 0.0          # theoretical arrival time of the next conforming message

    def due(self, log_time_ns: int) -> float:
        """Seconds after the start at which the message logged at `log_time_ns` may be published."""
        if self._t0 is None:
            self._t0 = int(log_time_ns)
        ideal = (int(log_time_ns) - self._t0) * 1e-9 / self.rate if self.rate else 0.0
        if not self.max_rate:
            return ideal
        interval = 1.0 / self.max_rate
        send = max(ideal, self._tat - (self.burst - 1) * interval)
        self._tat = max(self._tat, send) + interval
        return send


def compute_schedule(log_times_ns, rate: float | None = None, max_rate: float | None = None,
                     burst: int = 1) -> list[float]:
    """Publication times [s from start] of messages with these log times (in bag order)."""
    pacer = Pacer(rate, max_rate, burst)
    return [pacer.due(t) for t in log_times_ns]


# ---------------------------------------------------------------------------------------------
# topics
# ---------------------------------------------------------------------------------------------

def bag_namespace(topics) -> str:
    """The machine namespace of a bag: prefix of its unique `.../joint_states` (or slewing) topic."""
    for suffix in _MACHINE_SUFFIXES:
        found = sorted({t[:-len(suffix) - 1] for t in topics
                        if t == "/" + suffix or t.endswith("/" + suffix)})
        if len(found) == 1:
            return found[0]
    return ""


def output_topic(topic: str, bag_ns: str, remap_ns: str | None) -> str:
    """Name to publish `topic` under: the bag's name, or with its machine namespace `bag_ns`
    replaced by `remap_ns` (topics outside the machine namespace keep their names)."""
    if remap_ns is None or not topic.startswith(bag_ns + "/"):
        return topic
    rel = topic[len(bag_ns) + 1:]
    ns = remap_ns.strip("/")
    return f"/{ns}/{rel}" if ns else f"/{rel}"


def message_class(msgtype: str):
    """ROS message class for 'pkg/msg/Name'."""
    try:
        pkg, kind, name = msgtype.split("/")
        return getattr(importlib.import_module(f"{pkg}.{kind}"), name)
    except (ValueError, ImportError, AttributeError):
        raise InputError(f"message type {msgtype} is not available in this ROS 2 installation") from None


# ---------------------------------------------------------------------------------------------
# command line
# ---------------------------------------------------------------------------------------------

def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="bag_player", description=__doc__.split("\n\n")[0])
    p.add_argument("bag", help="rosbag2 bag (directory, .db3 or .mcap)")
    p.add_argument("--rate", type=float, default=None, metavar="FACTOR",
                   help="pace by log time / FACTOR (1 = real time); default: token bucket, see --max-rate")
    p.add_argument("--max-rate", type=float, default=None, metavar="MSGS_PER_S",
                   help=f"cap in msg/s (default {DEFAULT_MAX_RATE:g} without --rate; 0 = no cap)")
    p.add_argument("--burst", type=int, default=DEFAULT_BURST, help="token-bucket burst [messages]")
    p.add_argument("--topics", nargs="+", default=None, metavar="TOPIC",
                   help="play only these bag topics (names as in the bag)")
    p.add_argument("--remap-ns", default=None, metavar="NS",
                   help="publish the bag's machine topics under this absolute namespace, e.g. /m1")
    p.add_argument("--wait-subscribers", type=int, default=0, metavar="N",
                   help="wait until every played topic has >= N subscribers before starting")
    p.add_argument("--wait-timeout", type=float, default=30.0, metavar="S",
                   help="give up waiting for subscribers after S seconds (then play anyway)")
    p.add_argument("--start-after-ns", type=int, default=None, metavar="T",
                   help="play only messages logged after T [ns since epoch], e.g. to finish a bag after a "
                        "node restarted from a checkpoint taken at T")
    p.add_argument("--start-delay", type=float, default=0.0, metavar="S", help="sleep S seconds before playing")
    p.add_argument("--ack-timeout", type=float, default=30.0, metavar="S",
                   help="wait at most S seconds for reliable subscribers to acknowledge the data at the end")
    p.add_argument("--depth", type=int, default=DEFAULT_DEPTH,
                   help="keep_last depth of the data topics (0 = keep_all)")
    p.add_argument("--barrier-types", nargs="*", default=list(DEFAULT_BARRIER_TYPES), metavar="TYPE",
                   help="header-less message types published only after all earlier data is acknowledged "
                        "(keeps their order among stamped messages); none: no barriers")
    p.add_argument("--barrier-settle", type=float, default=0.0, metavar="S",
                   help="after a barrier's data is acknowledged (it is in the readers' queues, not yet taken by "
                        "their callbacks), wait S seconds more before the header-less message, so a node that "
                        "dates it on arrival has taken the data before it (default 0)")
    p.add_argument("--barrier-sparse", type=float, default=DEFAULT_BARRIER_SPARSE, metavar="FRACTION",
                   help="also treat topics with fewer than FRACTION of the bag's messages as barriers (a "
                        "rare load change delayed by a resend would otherwise reach the node after the "
                        "samples stamped after it); 0: off")
    p.add_argument("--deserialize", action="store_true",
                   help="deserialize each message into its ROS class before publishing (slower; for comparison)")
    p.add_argument("--clock", type=float, nargs="?", const=DEFAULT_CLOCK_HZ, default=None, metavar="HZ",
                   help=f"publish /clock (rosgraph_msgs/Clock) with the log time, at most HZ per s of bag time "
                        f"(default {DEFAULT_CLOCK_HZ:g}), for nodes with use_sim_time:=true")
    p.add_argument("--quiet", action="store_true", help="no summary on stderr")
    return p


def _log(msg: str) -> None:
    print(f"bag_player: {msg}", file=sys.stderr, flush=True)


def _sleep_until(deadline: float) -> None:
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            return
        time.sleep(left)


def _publish_blocked(publish, data, timeout_s: float) -> float:
    """Retry a publish that failed because the keep_all history is full; seconds spent blocked."""
    t0 = time.monotonic()
    pause = 0.001
    while True:
        try:
            publish(data)
            return time.monotonic() - t0
        except Exception as exc:  # noqa: BLE001 - rclpy raises RCLError("... cannot publish data ...")
            if "cannot publish" not in str(exc):
                raise
            if time.monotonic() - t0 > timeout_s:
                raise InputError(f"subscribers accepted no data for {timeout_s:g} s: {exc}") from None
            time.sleep(pause)
            pause = min(0.05, pause * 2)


def pacer_from_args(args) -> Pacer:
    """The pacing of --rate / --max-rate / --burst (default: the DEFAULT_MAX_RATE token bucket)."""
    if args.rate is not None and not args.rate > 0:
        raise InputError("--rate must be > 0")
    max_rate = args.max_rate if args.max_rate is not None else (None if args.rate else DEFAULT_MAX_RATE)
    if max_rate is not None and max_rate < 0:
        raise InputError("--max-rate must be >= 0")
    return Pacer(args.rate, max_rate or None, args.burst)


def select_connections(reader, bag, topics: list[str] | None) -> tuple[list, dict[str, str]]:
    """The bag connections to play (those of `topics` if given; none without messages) and each played
    topic's message type."""
    connections = list(reader.connections)
    if topics:
        unknown = sorted(set(topics) - {c.topic for c in connections})
        if unknown:
            raise InputError(f"topics not in the bag: {', '.join(unknown)}")
        connections = [c for c in connections if c.topic in set(topics)]
    connections = [c for c in connections if c.msgcount > 0]   # no publisher for empty topics
    if not connections:
        raise InputError(f"no messages to play in {bag}")
    types = {}
    for c in connections:
        if types.setdefault(c.topic, c.msgtype) != c.msgtype:
            raise InputError(f"topic {c.topic} has several types in the bag")
    return connections, types


def data_qos(depth: int):
    """Reliable, volatile; keep_last `depth`, or keep_all for depth 0 (publish blocks while reliable
    keep_all subscribers lag)."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    if depth > 0:
        return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                          reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
    return QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1,
                      reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)


def barrier_publishers(connections, pubs: dict, barrier_types, barrier_sparse: float) -> dict:
    """For each connection whose messages are barriers (a type in `barrier_types`, or a topic with fewer
    than `barrier_sparse` of the played messages): the other topics' publishers, whose data must be
    acknowledged before such a message goes."""
    barrier_types = set(barrier_types or ())
    total = int(sum(c.msgcount for c in connections))
    topic_count: dict[str, int] = {}
    for c in connections:
        topic_count[c.topic] = topic_count.get(c.topic, 0) + int(c.msgcount)
    sparse = {t for t, n in topic_count.items()
              if len(topic_count) > 1 and n < barrier_sparse * total}
    return {c.id: [p for topic, p in pubs.items() if topic != c.topic]
            for c in connections if c.msgtype in barrier_types or c.topic in sparse}


class ClockPublisher:
    """``--clock``: /clock = the log time, whenever it advanced by ``period_ns`` since the last one."""

    def __init__(self, node, hz: float):
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock

        if not hz > 0:
            raise InputError("--clock must be > 0 Hz")
        self._clock_type = Clock
        self.publisher = node.create_publisher(Clock, "/clock", QoSProfile(depth=1,
                                               reliability=ReliabilityPolicy.BEST_EFFORT))
        self.period_ns = int(round(1e9 / hz))
        self.last_ns: int | None = None
        self.latest_ns: int | None = None
        self.published = 0

    def tick(self, log_time_ns: int) -> None:
        self.latest_ns = int(log_time_ns)
        if self.last_ns is None or self.latest_ns - self.last_ns >= self.period_ns:
            self.publish(self.latest_ns)

    def publish(self, t_ns: int) -> None:
        msg = self._clock_type()
        msg.clock.sec, msg.clock.nanosec = divmod(int(t_ns), 1_000_000_000)
        self.publisher.publish(msg)
        self.last_ns = int(t_ns)
        self.published += 1

    def finish(self) -> None:
        if self.latest_ns is not None and self.latest_ns != self.last_ns:
            self.publish(self.latest_ns)


@dataclass
class Playback:
    """The publishing side of a play: publishers per topic and, per bag connection id, its publish
    function, message class and barrier publishers."""

    pubs: dict
    publish: dict
    msg_class: dict
    barrier_of: dict
    clock: ClockPublisher | None = None
    payload: dict = field(default_factory=dict)         # connection id -> its PayloadCheck (io/bag/payload.py)
    skipped: dict = field(default_factory=dict)         # topic -> messages not published (not a payload)


def create_playback(node, connections, classes: dict, args) -> Playback:
    """Publishers for the played topics (message class per bag topic in `classes`), named per --remap-ns."""
    bag_ns = bag_namespace(list(classes))
    qos = data_qos(args.depth)
    pubs = {topic: node.create_publisher(classes[topic], output_topic(topic, bag_ns, args.remap_ns), qos)
            for topic in classes}
    return Playback(pubs=pubs,
                    publish={c.id: pubs[c.topic].publish for c in connections},
                    msg_class={c.id: classes[c.topic] for c in connections},
                    barrier_of=barrier_publishers(connections, pubs, args.barrier_types, args.barrier_sparse),
                    clock=None if args.clock is None else ClockPublisher(node, args.clock),
                    payload={c.id: PayloadCheck(c.msgtype) for c in connections})


def wait_for_subscribers(pubs, count: int, timeout_s: float) -> None:
    """Until every publisher has >= `count` subscribers; after `timeout_s` warn and go on."""
    deadline = time.monotonic() + timeout_s
    while True:
        short = [p.topic_name for p in pubs if p.get_subscription_count() < count]
        if not short:
            return
        if time.monotonic() > deadline:
            _log(f"warning: fewer than {count} subscribers after {timeout_s:g} s on {', '.join(short)}; "
                 f"playing anyway")
            return
        time.sleep(0.01)


def _rcl_error_type() -> type:
    try:
        from rclpy._rclpy_pybind11 import RCLError
    except ImportError:  # pragma: no cover - other rclpy layouts
        return RuntimeError
    return RCLError


def publish_in_order(messages, playback: Playback, pacer: Pacer, args) -> tuple[int, float, float, float]:
    """Publish (connection, log time, raw CDR) in bag order when the pacer allows, behind barriers;
    (messages sent, s blocked by subscribers, monotonic start, s sending). A message that is not a CDR
    payload of its type is not published: counted per topic in ``playback.skipped``."""
    from rclpy.duration import Duration
    from rclpy.serialization import deserialize_message

    RCLError = _rcl_error_type()
    ack_wait = Duration(seconds=args.ack_timeout)
    publish, barrier_of, pubs = playback.publish, playback.barrier_of, playback.pubs
    sent = 0
    blocked = 0.0
    t_start = time.monotonic()
    due = pacer.due
    tick = playback.clock.tick if playback.clock is not None else lambda t: None
    payload, skipped = playback.payload, playback.skipped
    for conn, log_t, raw in messages:
        if not payload[conn.id](raw):
            skipped[conn.topic] = skipped.get(conn.topic, 0) + 1
            continue
        when = t_start + due(log_t)
        if when > time.monotonic():
            _sleep_until(when)
        tick(log_t)
        data = deserialize_message(raw, playback.msg_class[conn.id]) if args.deserialize else bytes(raw)
        others = barrier_of.get(conn.id)
        if others:
            for other in others:
                if not other.wait_for_all_acked(ack_wait):
                    _log(f"warning: {other.topic_name} not acknowledged within {args.ack_timeout:g} s "
                         f"before a {conn.topic} message; order may not be kept")
            if args.barrier_settle > 0:
                time.sleep(args.barrier_settle)
        try:
            publish[conn.id](data)
        except RCLError as exc:
            if "cannot publish" not in str(exc):
                raise
            # keep_all writer full: reliable keep_all subscribers lag. Back-pressure: retry.
            blocked += _publish_blocked(publish[conn.id], data, args.ack_timeout)
        if others is not None and not pubs[conn.topic].wait_for_all_acked(ack_wait):
            _log(f"warning: a {conn.topic} message was not acknowledged within {args.ack_timeout:g} s; "
                 f"later messages may overtake it")
        sent += 1
    return sent, blocked, t_start, time.monotonic() - t_start


def wait_all_acked(pubs, timeout_s: float) -> list[str]:
    """Wait (each at most `timeout_s`) until every publisher's data is acknowledged; the topics whose data
    was not."""
    from rclpy.duration import Duration

    return [p.topic_name for p in pubs if not p.wait_for_all_acked(Duration(seconds=timeout_s))]


def incomplete_play_line(skipped: dict[str, int], unacked: list[str]) -> str:
    """The one line of a play that did not deliver every message ('' when it did)."""
    parts = []
    if skipped:
        parts.append(f"skipped {sum(skipped.values())} messages that are not a CDR payload of their type ("
                     + ", ".join(f"{topic}: {n}" for topic, n in sorted(skipped.items())) + ")")
    if unacked:
        parts.append(f"not every message acknowledged on {', '.join(sorted(unacked))}")
    return "; ".join(parts)


def play(args, rclpy_args) -> int:
    import rclpy


    pacer = pacer_from_args(args)
    with open_storage(args.bag, checked=True) as reader:
        connections, types = select_connections(reader, args.bag, args.topics)
        classes = {topic: message_class(t) for topic, t in types.items()}
        total = int(sum(c.msgcount for c in connections))
        start_ns = None if args.start_after_ns is None else int(args.start_after_ns) + 1

        rclpy.init(args=rclpy_args)
        try:
            node = rclpy.create_node("bag_player")
            playback = create_playback(node, connections, classes, args)
            if args.wait_subscribers > 0:
                wait_for_subscribers(playback.pubs.values(), args.wait_subscribers, args.wait_timeout)
            if args.start_delay > 0:
                time.sleep(args.start_delay)
            messages = iter_raw_messages(reader, connections, start_ns)
            sent, blocked, t_start, t_sent = publish_in_order(messages, playback, pacer, args)
            if playback.clock is not None:
                playback.clock.finish()
            unacked = wait_all_acked(playback.pubs.values(), args.ack_timeout)
            t_total = time.monotonic() - t_start
            if not args.quiet:
                rate = sent / t_sent if t_sent > 0 else float("inf")
                _log(f"published {sent} of {total} messages on {len(playback.pubs)} topics in {t_sent:.2f} s "
                     f"({rate:,.0f} msg/s); all acknowledged: {'NO' if unacked else 'yes'} "
                     f"after {t_total:.2f} s" + (f"; blocked by subscribers {blocked:.2f} s" if blocked else ""))
            node.destroy_node()
        finally:
            if rclpy.ok():
                rclpy.shutdown()
    incomplete = incomplete_play_line(playback.skipped, unacked)
    if incomplete:
        _log(f"error: {incomplete}")
        return EXIT_INCOMPLETE
    return 0


FASTDDS_PROFILE = Path(__file__).resolve().parents[1] / "fastdds" / "bag_player.xml"


def use_fast_heartbeat_profile() -> None:
    """Fast DDS writers of this process heartbeat every 20 ms (guide_health/fastdds/bag_player.xml) unless
    the user set FASTRTPS_DEFAULT_PROFILES_FILE. Readers acknowledge on heartbeats, so every
    wait_for_all_acked (the barriers, the final flush) waits ~20 ms instead of up to the 3 s default:
    measured with bench/bench_bag_player.py, 110 003 messages to a keep_all subscriber in 3.2 s (34 k msg/s)
    instead of 19 s (5.8 k msg/s). Must run before the first DDS participant is created."""
    if "FASTRTPS_DEFAULT_PROFILES_FILE" not in os.environ and FASTDDS_PROFILE.is_file():
        os.environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(FASTDDS_PROFILE)


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        from rclpy.utilities import remove_ros_args
        user_args = remove_ros_args(args=["bag_player"] + argv)[1:]
    except ImportError:  # pragma: no cover - rclpy is needed to publish anyway
        user_args = argv
    args = build_parser().parse_args(user_args)
    if not 0.0 <= args.barrier_settle <= 3600.0:
        _log(f"error: --barrier-settle must be in [0, 3600] s, got {args.barrier_settle!r}")
        return 1
    use_fast_heartbeat_profile()
    try:
        return play(args, ["bag_player"] + argv)
    except InputError as exc:
        _log(f"error: {exc}")
        return 1
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
