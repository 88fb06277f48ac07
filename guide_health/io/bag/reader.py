"""Read machine and slewing runs out of rosbag2 bags into numpy (MachineRun, SlewingLoadRun).

One pass over the bag in log-time order, in batches of `chunk_messages` messages from the storage back
end (`storage.open_storage`: packed batches where the back end supports them, else raw batches); each
topic's raw CDR of a batch is decoded with numpy (`cdr.decode_chunk`, `cdr.decode_packed`).
Times are int64 nanoseconds: header stamps for JointState, WrenchStamped and Temperature, the bag's log
time for Float64 (it has no header).
"""
from __future__ import annotations

import gc
import operator
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ...errors import InputError
from ...runs import MachineRun, SlewingLoadRun
from .cdr import WRENCH_NAMES, DecodedChunk, codec_for, decode_chunk, decode_packed
from .interfaces import FLOAT64, JOINT_STATE, MACHINE_TOPICS, NS_PER_S, SLEWING_TOPICS, topic_name
from .message_judge import MessageJudge
from .metadata import check_no_missing_messages, count_mismatch_text, count_mismatches, read_run_metadata
from .protocol import NOT_SUPPORTED, BagConnection, BagStorage, PackedBatch, RawBatch
from .storage import iter_raw_messages, open_storage
from .typestore import typestore

if TYPE_CHECKING:
    from ..outputs.progress import ProgressFn

_COUNT_KEYS = ("missing", "malformed", "fast", "fallback")


class TopicArrays(NamedTuple):
    """The decoded messages of one topic (a batch or the whole bag)."""

    values: dict        # name -> array over the kept messages (+ "log_t_ns" for a header-less topic)
    present: dict       # name -> bool array: the value was in the message (NaN where not)
    counts: dict        # kept, missing, malformed, fast, fallback -> number of messages
    rejections: tuple = ()  # ((index, reason), ...): messages not kept, after `index` kept ones (judged topics)


class TopicBatch(NamedTuple):
    """What one pass (or one batch of it) over the bag gives: the namespace and every read topic."""

    namespace: str
    topics: dict        # absolute topic -> TopicArrays


def detect_namespace(topics: dict, suffix: str, msgtype: str) -> str:
    """The namespace of the unique topic `<ns>/<suffix>` of type `msgtype` in {topic: type}."""
    found = sorted(t for t, ty in topics.items()
                   if (t == "/" + suffix or t.endswith("/" + suffix)) and ty == msgtype)
    if not found:
        raise InputError(f"no {suffix} topic of type {msgtype} in the bag")
    if len(found) > 1:
        raise InputError(f"several {suffix} topics in the bag ({', '.join(found)}): choose a namespace")
    return found[0][:-len("/" + suffix)]


# ---------------------------------------------------------------------------------------------
# one pass over the bag
# ---------------------------------------------------------------------------------------------

def _empty_values(names) -> dict:
    return {k: np.zeros(0, np.int64 if k in ("sec", "nsec") else np.float64) for k in names}


def _empty_topic(names, log=False) -> TopicArrays:
    values = _empty_values(names)
    if log:
        values["log_t_ns"] = np.zeros(0, np.int64)
    present = {k: np.zeros(0, bool) for k in names}
    return TopicArrays(values, present, dict.fromkeys(_COUNT_KEYS + ("kept",), 0))


class _TopicAccumulator:
    """Raw messages of one topic for the current chunk, then per-chunk arrays (bounded memory). ``judge``:
    every message not kept gets its rejection reason (:class:`MessageJudge`), and a message with an invalid
    header stamp is not kept."""

    def __init__(self, msgtype: str, joint: str, fast: bool, log_time: bool, judge: bool = False):
        self.codec = codec_for(msgtype, joint)
        self.names = self.codec.names
        self.fast = fast
        self.judge = MessageJudge(msgtype, joint) if judge else None
        self.raws: list = []
        self.log_times: list | None = [] if log_time else None
        self.parts: list[DecodedChunk] = []
        self.log_parts: list[np.ndarray] = []
        self.rejections: list = []        # (index into the kept messages since the last take, reason)
        self.kept = 0                     # kept messages since the last take

    def _judged(self, dec: DecodedChunk, raw_of) -> DecodedChunk:
        if self.judge is not None:
            dec, rejected = self.judge.judge(dec, raw_of)
            self.rejections.extend((self.kept + i, reason) for i, reason in rejected)
        self.kept += int(dec.keep.size)
        return dec

    def flush(self) -> None:
        if not self.raws:
            return
        dec = self._judged(decode_chunk(self.raws, self.codec, self.fast), self.raws.__getitem__)
        self.parts.append(dec)
        if self.log_times is not None:
            self.log_parts.append(np.asarray(self.log_times, dtype=np.int64)[dec.keep])
            self.log_times.clear()
        self.raws.clear()

    def add_packed(self, batch: PackedBatch, idx: np.ndarray | None) -> None:
        """Decode the messages `idx` of a packed batch (None: all) straight into a part."""
        self.flush()
        offsets, lengths, times = batch.offsets, batch.lengths, batch.log_time_ns
        if idx is not None:
            offsets, lengths, times = offsets[idx], lengths[idx], times[idx]
        dec = decode_packed(batch.buf, offsets, lengths, self.codec, self.fast)
        dec = self._judged(dec, lambda i: batch.buf[offsets[i]:offsets[i] + lengths[i]].tobytes())
        self.parts.append(dec)
        if self.log_times is not None:
            self.log_parts.append(times[dec.keep])

    def take(self) -> TopicArrays:
        """The decoded arrays so far, then forget them (streaming: memory bounded by one batch)."""
        out = self.result()
        self.parts.clear()
        self.log_parts.clear()
        self.rejections.clear()
        self.kept = 0
        return out

    def result(self) -> TopicArrays:
        self.flush()
        values = ({k: np.concatenate([p.values[k] for p in self.parts]) for k in self.names} if self.parts
                  else _empty_values(self.names))
        present = {k: np.concatenate([p.present[k] for p in self.parts]) if self.parts
                   else np.zeros(0, bool) for k in self.names}
        counts = {key: sum(getattr(p, key) for p in self.parts) for key in _COUNT_KEYS}
        counts["kept"] = sum(p.keep.size for p in self.parts)
        if self.log_times is not None:
            values["log_t_ns"] = (np.concatenate(self.log_parts) if self.log_parts
                                  else np.zeros(0, np.int64))
        return TopicArrays(values, present, counts, tuple(self.rejections))


def _stamps(values: dict) -> np.ndarray:
    return values["sec"].astype(np.int64) * NS_PER_S + values["nsec"].astype(np.int64)


@contextmanager
def _gc_paused():
    """Pause the cyclic garbage collector while millions of short-lived tuples are made: a batch of
    (connection, time, bytes) tuples is acyclic, yet each generation-0 collection walks it (measured:
    read time 3.5 s -> 2.5 s for 1.1 M messages). Reference counting still frees everything."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


def _split_batch(batch: RawBatch, acc_of: dict) -> None:
    """Hand each topic's accumulator its raw bytes (and log times) from a batch, with C-level
    numpy/itemgetter rather than a Python statement per message."""
    ids, b_times, b_raws = batch.connection_ids, batch.log_time_ns, batch.data
    got = len(b_raws)
    for cid in np.unique(ids).tolist():
        acc = acc_of[cid]
        idx = np.flatnonzero(ids == cid)
        if idx.size == got:
            acc.raws.extend(b_raws)
            if acc.log_times is not None:
                acc.log_times.extend(b_times)
            continue
        pick = operator.itemgetter(*idx.tolist())
        picked = pick(b_raws)
        acc.raws.extend(picked if idx.size > 1 else (picked,))
        if acc.log_times is not None:
            times = pick(b_times)
            acc.log_times.extend(times if idx.size > 1 else (times,))


def id_counts(ids: np.ndarray) -> tuple[list[int], list[int]]:
    """The distinct ids of a batch (ascending) and how often each occurs: a bincount for the small
    non-negative storage ids (np.unique sorts or hashes the whole batch: 3x the time)."""
    if not ids.size:
        return [], []
    lo, hi = int(ids.min()), int(ids.max())
    if lo < 0 or hi - lo > 1 << 16:
        uniq, counts = np.unique(ids, return_counts=True)
        return uniq.tolist(), counts.tolist()
    counts = np.bincount(ids - lo if lo else ids, minlength=1)
    nz = np.flatnonzero(counts)
    return (nz + lo).tolist(), counts[nz].tolist()


def _split_packed(batch: PackedBatch, acc_of: dict, cids: list[int] | None = None) -> None:
    """Decode each topic's messages of a packed batch (connection by connection, as _split_batch);
    `cids`: the batch's distinct connection ids when known (id_counts)."""
    ids = batch.connection_ids
    for cid in (id_counts(ids)[0] if cids is None else cids):
        idx = None if len(cids or ()) == 1 else np.flatnonzero(ids == cid)
        acc_of[cid].add_packed(batch, None if idx is None or idx.size == ids.size else idx)


def _topic_accumulators(storage: BagStorage, wanted: dict, namespace: str, suffix_for_ns: str, joint: str,
                        fast: bool) -> tuple[dict[str, _TopicAccumulator], list[BagConnection]]:
    """An accumulator per topic of `wanted` ({relative topic: type}) in the bag, and their connections.
    InputError if a topic has another type or the `suffix_for_ns` topic is not in the bag."""
    accs: dict[str, _TopicAccumulator] = {}
    conns: list[BagConnection] = []
    for rel, msgtype in wanted.items():
        topic = topic_name(namespace, rel)
        here = [c for c in storage.connections if c.topic == topic]
        if not here:
            continue
        bad = sorted({c.msgtype for c in here if c.msgtype != msgtype})
        if bad:
            raise InputError(f"bag {storage.path}: topic {topic} has type {bad[0]}, expected {msgtype}")
        accs[topic] = _TopicAccumulator(msgtype, joint, fast, log_time=(msgtype == FLOAT64),
                                        judge=suffix_for_ns == "joint_states")
        conns.extend(here)
    if topic_name(namespace, suffix_for_ns) not in accs:
        types = {c.topic: c.msgtype for c in storage.connections}
        raise InputError(f"bag {storage.path} has no topic {topic_name(namespace, suffix_for_ns)} "
                         f"(topics: {', '.join(sorted(types)) or 'none'})")
    return accs, conns


def _check_counts(storage: BagStorage, conns: list[BagConnection], rows: dict, stats: dict | None) -> None:
    """Rows read per topic against metadata.yaml's counts: fewer rows than counted is an InputError
    (check_no_missing_messages); more is a one-line warning and, with `stats`,
    stats["bag_count_mismatch"] = {topic: {metadata, rows}} (the stored rows are used)."""
    by_topic: dict[str, int] = {}
    for c in conns:
        by_topic[c.topic] = by_topic.get(c.topic, 0) + rows.get(c.id, 0)
    mismatches = count_mismatches(storage.path, by_topic)
    check_no_missing_messages(storage.path, mismatches)
    if mismatches:
        warnings.warn(count_mismatch_text(storage.path, mismatches), stacklevel=4)
        if stats is not None:
            stats["bag_count_mismatch"] = mismatches


def _iter_topic_batches(path, wanted: dict, namespace: str | None, suffix_for_ns: str, joint: str,
                        progress: ProgressFn | None, chunk_messages: int, fast: bool,
                        stream: bool, stats: dict | None = None) -> Iterator[TopicBatch]:
    """One pass over the bag in batches of `chunk_messages` (log-time order).

    stream=False: yields once, the TopicBatch of the whole bag; stream=True: yields one for every batch
    (arrays of the batch only), so memory stays bounded. At the end the rows read are checked against
    metadata.yaml's counts (_check_counts).
    """
    chunk_messages = max(1, int(chunk_messages))
    opener = getattr(path, "open_storage", None)          # a bag_set.BagSet: several bags as one storage
    with (opener() if opener else open_storage(path)) as storage:
        if namespace is None:
            types = {c.topic: c.msgtype for c in storage.connections}
            namespace = detect_namespace(types, suffix_for_ns, wanted[suffix_for_ns])
        accs, conns = _topic_accumulators(storage, wanted, namespace, suffix_for_ns, joint, fast)
        total = int(sum(c.msgcount for c in conns))
        acc_of = {c.id: accs[c.topic] for c in conns}
        packed = storage.iter_packed(conns, chunk_messages)
        batches = storage.iter_batches(conns, chunk_messages) if packed is NOT_SUPPORTED else iter(())
        if progress is not None:
            progress(0, total)
        done = 0
        rows: dict[int, int] = {}
        for group in packed or ():                  # bulk path: no Python object per message
            for batch in group:
                cids, counts = id_counts(batch.connection_ids)
                for cid, n in zip(cids, counts):
                    rows[cid] = rows.get(cid, 0) + n
                _split_packed(batch, acc_of, cids)
                done += int(batch.lengths.size)
            del group, batch
            if progress is not None:
                progress(done, max(total, done))
            if stream:
                yield TopicBatch(namespace, {topic: acc.take() for topic, acc in accs.items()})
        while True:
            with _gc_paused():
                batch = next(batches, None)     # read errors raise InputError; decoding is outside
                if batch is None:
                    break
                for cid, n in zip(*id_counts(np.asarray(batch.connection_ids))):
                    rows[cid] = rows.get(cid, 0) + n
                _split_batch(batch, acc_of)
                done += len(batch.data)
                del batch
                for acc in accs.values():
                    acc.flush()
            if progress is not None:
                progress(done, max(total, done))
            if stream:
                yield TopicBatch(namespace, {topic: acc.take() for topic, acc in accs.items()})
        if total == 0 and progress is not None:
            progress(0, 0)
        _check_counts(storage, conns, rows, stats)
        if not stream:
            yield TopicBatch(namespace, {topic: acc.result() for topic, acc in accs.items()})
        elif done == 0:                       # an empty bag still yields one (empty) batch
            yield TopicBatch(namespace, {topic: acc.take() for topic, acc in accs.items()})


def _read_topics(path, wanted: dict, namespace: str | None, suffix_for_ns: str, joint: str,
                 progress: ProgressFn | None, chunk_messages: int, fast: bool,
                 stats: dict | None = None) -> TopicBatch:
    """Read the topics `wanted` ({relative topic: type}) in one pass."""
    return next(_iter_topic_batches(path, wanted, namespace, suffix_for_ns, joint, progress, chunk_messages,
                                    fast, stream=False, stats=stats))


# ---------------------------------------------------------------------------------------------
# machine and slewing runs
# ---------------------------------------------------------------------------------------------

def read_machine_bag(path, joint: str = "x", namespace: str | None = None,
                     progress: ProgressFn | None = None, chunk_messages: int = 200_000,
                     *, fast: bool = True, stats: dict | None = None, topics: dict | None = None) -> MachineRun:
    """Read a machine bag into a MachineRun (header stamps; log time for straightness).

    namespace None: the namespace of the bag's unique `.../joint_states` topic.
    JointState messages without `joint` (or without its position) are skipped and counted;
    velocity is 0 where a message has none (an absent velocity counts as finite, as live), and empty when no
    message has one.
    progress(done_messages, total_messages) is called after every chunk.
    fast=False decodes every message with rosbags deserialize_cdr (the reference path).
    stats, when given, receives per-topic counts: kept, missing, malformed, fast, fallback.
    Raises InputError for a missing, corrupt or unsuitable bag. See iter_machine_bag for bounded memory.
    topics: {role: relative topic} for an axis of a machine, e.g. {"guide/load": "x/guide/load"}.
    """
    path = Path(path)
    topics = dict(topics or {})
    wanted = {topics.get(rel, rel): msgtype for rel, msgtype in MACHINE_TOPICS.items()}
    read = _read_topics(path, wanted, namespace, "joint_states", joint, progress, chunk_messages, fast, stats)
    run, counts = _machine_run(read, joint, read_run_metadata(path), topics)
    _report_counts(path, joint, read.namespace, counts, stats)
    return run


def iter_machine_bag(path, joint: str = "x", namespace: str | None = None,
                     progress: ProgressFn | None = None, chunk_messages: int = 200_000,
                     *, fast: bool = True, stats: dict | None = None,
                     topics: dict | None = None) -> Iterator[MachineRun]:
    """A machine bag as consecutive MachineRun chunks of about `chunk_messages` messages each, in
    log-time order (every chunk carries the run metadata); memory stays bounded by one chunk.
    Feeding them one after another to PrecisionMonitor.process_run gives the result of the whole run.
    Same arguments and errors as read_machine_bag; stats are filled once the iteration ends.
    topics: {role: relative topic} for an axis of a machine, e.g. {"guide/load": "x/guide/load"}."""
    path = path if hasattr(path, "open_storage") else Path(path)
    metadata = path.run_metadata() if hasattr(path, "open_storage") else read_run_metadata(path)
    total: dict = {}
    namespace_seen = namespace
    topics = dict(topics or {})
    wanted = {topics.get(rel, rel): msgtype for rel, msgtype in MACHINE_TOPICS.items()}
    for read in _iter_topic_batches(path, wanted, namespace, "joint_states", joint,
                                    progress, chunk_messages, fast, stream=True, stats=stats):
        namespace_seen = read.namespace
        run, counts = _machine_run(read, joint, metadata, topics)
        for topic, c in counts.items():
            acc = total.setdefault(topic, dict.fromkeys(c, 0))
            for key, value in c.items():
                acc[key] += value
        yield run
    _report_counts(path, joint, namespace_seen, total, stats)


_MACHINE_EMPTY = {
    "joint_states": ("sec", "nsec", "position", "velocity"),
    "guide/load": ("sec", "nsec", "fz"),
    "guide/straightness": ("data",),
    "guide/temperature": ("sec", "nsec", "temperature"),
}


def _machine_run(read: TopicBatch, joint: str, metadata: dict,
                 topics: dict | None = None) -> tuple[MachineRun, dict]:
    topics = topics or {}
    got = {rel: read.topics.get(topic_name(read.namespace, topics.get(rel, rel)),
                                _empty_topic(names, log=(rel == "guide/straightness")))
           for rel, names in _MACHINE_EMPTY.items()}
    js = got["joint_states"]
    ld_v = got["guide/load"].values
    st_v = got["guide/straightness"].values
    tp_v = got["guide/temperature"].values
    # a message without velocity among messages with one: an absent velocity counts as 0 (finite), as live
    present = js.present["velocity"]
    velocity = np.where(present, js.values["velocity"], 0.0) if present.any() else np.zeros(0)
    run = MachineRun(
        joint_name=joint,
        joint_t_ns=_stamps(js.values), joint_position_m=js.values["position"], joint_velocity_m_s=velocity,
        load_t_ns=_stamps(ld_v), load_n=ld_v["fz"],
        straightness_t_ns=st_v["log_t_ns"], straightness_m=st_v["data"],
        temperature_t_ns=_stamps(tp_v), temperature_c=tp_v["temperature"],
        metadata=metadata,
        rejected_messages=tuple((rel, i, reason) for rel, v in got.items() for i, reason in v.rejections),
    )
    return run, {rel: v.counts for rel, v in got.items()}


def joint_names_in_bag(path, namespace) -> list[str]:
    """The joint names of the first joint_states message of the bag ([] when it has none or is unreadable)."""
    try:
        with open_storage(path) as storage:
            conns = [c for c in storage.connections if c.topic == topic_name(namespace, "joint_states")]
            for message in iter_raw_messages(storage, conns, chunk_messages=1):
                return list(typestore().deserialize_cdr(message.data, conns[0].msgtype).name)
    except Exception:  # noqa: BLE001 - only a hint for an error message
        return []
    return []


def _report_counts(path, joint: str, namespace, counts: dict, stats: dict | None) -> None:
    """Counts into `stats`; skipped messages as a warning; InputError (one line naming the joint and the
    joints present) when joint_states messages exist and none carries `joint`."""
    if stats is not None:
        stats.update({"namespace": namespace, **counts})
    if not counts:
        return
    missing = counts["joint_states"]["missing"]
    if missing and not counts["joint_states"]["kept"]:
        present = joint_names_in_bag(path, namespace)
        raise InputError(f"bag {path}: no joint_states message has joint {joint!r} (joints present: "
                         f"{', '.join(present) or 'none'}); set the params file's joint to one of them")
    dropped = missing + sum(c["malformed"] for c in counts.values())
    if dropped:
        warnings.warn(f"bag {path}: skipped {missing} joint_states without joint {joint!r} "
                      f"and {dropped - missing} malformed messages", stacklevel=3)


def read_slewing_bag(path, namespace: str | None = None, progress: ProgressFn | None = None,
                     chunk_messages: int = 200_000, *, fast: bool = True, stats: dict | None = None,
                     axis_topic: str = "slewing/joint_states", axis_joint: str = "slew",
                     clearance_topic: str = "slewing/tilting_clearance") -> SlewingLoadRun:
    """Read `<ns>/slewing/load` into a SlewingLoadRun (axial = force.z, radial = hypot(force.x, force.y),
    moment = hypot(torque.x, torque.y)) and the angle of joint `axis_joint` on `<ns>/<axis_topic>` (when
    recorded; messages without the joint are skipped and counted) and the measured tilting clearances of
    `<ns>/<clearance_topic>` (Float64 [m], log time); namespace None = auto-detected. Raises InputError on a bad
    bag."""
    path = Path(path)
    wanted = {**SLEWING_TOPICS, axis_topic: JOINT_STATE, clearance_topic: FLOAT64}
    read = _read_topics(path, wanted, namespace, "slewing/load", axis_joint, progress, chunk_messages, fast,
                        stats)
    axis = read.topics.get(topic_name(read.namespace, axis_topic), _empty_topic(("sec", "nsec", "position")))
    clearance = read.topics.get(topic_name(read.namespace, clearance_topic), _empty_topic(("data",), log=True))
    if stats is not None:
        stats[axis_topic] = axis.counts
        stats[clearance_topic] = clearance.counts
    load = read.topics.get(topic_name(read.namespace, "slewing/load"),
                           _empty_topic(("sec", "nsec") + WRENCH_NAMES))
    values, counts = load.values, load.counts
    if stats is not None:
        stats.update({"namespace": read.namespace, "slewing/load": counts})
    if counts["malformed"]:
        warnings.warn(f"bag {path}: skipped {counts['malformed']} malformed slewing/load messages",
                      stacklevel=2)
    return SlewingLoadRun(
        t_ns=_stamps(values), axial_n=values["fz"],
        radial_n=np.hypot(values["fx"], values["fy"]), moment_nm=np.hypot(values["tx"], values["ty"]),
        metadata=read_run_metadata(path), axis_t_ns=_stamps(axis.values), axis_angle_rad=axis.values["position"],
        clearance_t_ns=clearance.values["log_t_ns"], clearance_m=clearance.values["data"],
    )
