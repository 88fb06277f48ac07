"""Several bags of one machine read as one recording: a month of shifts, each its own bag (and each bag
possibly split into several storage files, which the storage back ends read as one).

`resolve_bags(paths)` takes bags and directories of bags, orders them by the log time of their first
message (not by name), refuses overlapping bags, drops bags without messages and lists the gaps between the
others. A BagSet is read through `ChainedStorage`, the bags as one storage: one model object streams across
them as the live node streams across a restart, and the batches run on across the bags' boundaries in the
windows one bag of the same messages is read in (sqlite3: `chunk_messages` rows of every topic), so the result
is that bag's to the last bit, not only to rounding. `events` gathers the maintenance events of every bag; the
progress callback sees one count across all files.
"""
from __future__ import annotations

import datetime
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import InputError
from .maintenance import read_events
from .metadata import metadata_message_counts, read_run_metadata
from .protocol import NOT_SUPPORTED, BagConnection, PackedBatch, RawBatch
from .reader import iter_machine_bag
from .storage import SUFFIX_STORAGE, open_storage


@dataclass(frozen=True)
class BagSpan:
    """One bag: its path, log times of its first and last message [ns] and its message count."""

    path: Path
    start_ns: int
    end_ns: int             # log time of the last message + 1
    messages: int


def utc_text(t_ns: int) -> str:
    """ISO 8601 UTC time of a stamp [ns], to the millisecond."""
    return datetime.datetime.fromtimestamp(t_ns * 1e-9, datetime.UTC).isoformat(timespec="milliseconds")


def is_bag(path: Path) -> bool:
    """A rosbag2 directory (metadata.yaml) or a bare storage file (.db3, .mcap)."""
    return (path.is_dir() and (path / "metadata.yaml").is_file()) or (path.is_file() and path.suffix in SUFFIX_STORAGE)


def _bag_paths(path: Path) -> list[Path]:
    """The bag at ``path``, or the bags directly inside the directory ``path``."""
    if is_bag(path) or not path.is_dir():
        return [path]          # a missing or unreadable path: the reader's own error names it
    inside = sorted(p for p in path.iterdir() if is_bag(p))
    if not inside:
        raise InputError(f"{path} is neither a bag nor a directory of bags (no metadata.yaml, .db3 or .mcap in it)")
    return inside


def _span(path: Path) -> BagSpan:
    with open_storage(path) as storage:
        return BagSpan(path, int(storage.start_ns), int(storage.end_ns), int(storage.message_count))


@dataclass(frozen=True)
class BagSet:
    """Bags of one machine in time order (``resolve_bags``)."""

    spans: tuple[BagSpan, ...]

    @property
    def paths(self) -> list[Path]:
        return [s.path for s in self.spans]

    def gaps(self) -> list[dict]:
        """Every interval between one bag's last message and the next bag's first: start, end [UTC and ns],
        duration [s]."""
        out = []
        for a, b in zip(self.spans, self.spans[1:]):
            end_a = a.end_ns - 1
            out.append({"after": str(a.path), "before": str(b.path), "start_utc": utc_text(end_a),
                        "end_utc": utc_text(b.start_ns), "start_ns": end_a, "end_ns": b.start_ns,
                        "duration_s": (b.start_ns - end_a) * 1e-9})
        return out

    def report(self) -> dict:
        """The report keys of a multi-bag run: ``bags`` (path, first and last message, messages) and ``gaps``."""
        return {"bags": [{"path": str(s.path), "start_utc": utc_text(s.start_ns), "end_utc": utc_text(s.end_ns - 1),
                          "messages": s.messages} for s in self.spans],
                "gaps": self.gaps()}

    def events(self, namespace: str | None = None) -> list:
        """The maintenance events of every bag, in stamp order."""
        return sorted((e for path in self.paths for e in read_events(path, namespace)), key=lambda e: e.t_ns)

    def open_storage(self) -> ChainedStorage:
        """The bags as one storage (io.bag.reader reads a BagSet through it)."""
        return ChainedStorage([open_storage(p) for p in self.paths], self)

    def run_metadata(self) -> dict:
        """The run metadata of the first bag that has any."""
        return next((m for m in map(read_run_metadata, self.paths) if m), {})

    def metadata_message_counts(self) -> dict[str, int]:
        """{topic: message count} summed over the bags' metadata.yaml (a bag without counts adds none)."""
        total: dict[str, int] = {}
        for path in self.paths:
            for topic, n in metadata_message_counts(path).items():
                total[topic] = total.get(topic, 0) + n
        return total

    def __str__(self) -> str:
        return f"{self.paths[0]} .. {self.paths[-1]} ({len(self.spans)} bags)"

    def iter_chunks(self, **kwargs) -> Iterator:
        """The MachineRun chunks of every bag in time order (``iter_machine_bag``'s arguments)."""
        return iter_machine_bag(self, **kwargs)


class ChainedStorage:
    """Several storages, one after the other in log time, as one (protocol.BagStorage): a topic's
    connections of every bag become one connection, and batches run on across the bags' boundaries, so a
    reader sees the batches it would see in one bag of the same messages."""

    def __init__(self, storages: list, bag_set: BagSet | Path):
        self.storages = storages
        self.path = bag_set             # a BagSet, or the directory of one bag split into several files
        self.connections: list[BagConnection] = []
        self._id_maps: list[dict[int, int]] = []      # per storage: its connection id -> the chained id
        by_key: dict[tuple[str, str], int] = {}
        counts: dict[int, int] = {}
        for storage in storages:
            ids = {}
            for c in storage.connections:
                ids[c.id] = by_key.setdefault((c.topic, c.msgtype), len(by_key))
                counts[ids[c.id]] = counts.get(ids[c.id], 0) + c.msgcount
            self._id_maps.append(ids)
        self.connections = [BagConnection(i, topic, msgtype, counts[i]) for (topic, msgtype), i in by_key.items()]
        self.message_count = sum(c.msgcount for c in self.connections)

    @property
    def start_ns(self) -> int:
        return min(s.start_ns for s in self.storages)

    @property
    def end_ns(self) -> int:
        return max(s.end_ns for s in self.storages)

    def _local(self, k: int, connections) -> tuple[list[BagConnection], np.ndarray]:
        """Storage k's connections of the chained ``connections``, and its id -> chained id lookup."""
        wanted = {c.id for c in connections}
        local = [c for c in self.storages[k].connections if self._id_maps[k][c.id] in wanted]
        ids = self._id_maps[k]
        lookup = np.full(max(ids, default=-1) + 1, -1, np.int64)
        for own, chained in ids.items():
            lookup[own] = chained
        return local, lookup

    def iter_batches(self, connections, chunk_messages: int, start_ns: int | None = None) -> Iterator[RawBatch]:
        def rows():
            for k, storage in enumerate(self.storages):
                local, lookup = self._local(k, connections)
                for b in storage.iter_batches(local, chunk_messages, start_ns):
                    yield RawBatch(lookup[np.asarray(b.connection_ids, np.int64)], tuple(b.log_time_ns),
                                   tuple(b.data))
        return _rebatch_raw(rows(), chunk_messages)

    def iter_packed(self, connections, chunk_messages: int):
        """Packed groups of the rows of ``connections`` in windows of ``chunk_messages`` rows of every topic,
        running on across the bags: the windows a single sqlite3 bag of the same rows is read in (rowid ranges
        of that many rows, empty ones skipped). NOT_SUPPORTED unless every bag reads packed."""
        parts = []
        for k, storage in enumerate(self.storages):
            groups = storage.iter_packed(storage.connections, chunk_messages) if storage.connections else iter(())
            if groups is NOT_SUPPORTED:
                return NOT_SUPPORTED
            parts.append((groups, self._local(k, self.connections)[1]))
        return _regroup_packed(parts, chunk_messages, np.asarray(sorted({c.id for c in connections}), np.int64))

    def close(self) -> None:
        for storage in self.storages:
            storage.close()

    def __enter__(self) -> ChainedStorage:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _rebatch_raw(batches, size: int) -> Iterator[RawBatch]:
    """RawBatches of ``size`` messages (the last may be shorter) from batches of any sizes."""
    ids: list = []
    times: list = []
    data: list = []
    for b in batches:
        ids.append(b.connection_ids)
        times.extend(b.log_time_ns)
        data.extend(b.data)
        while len(data) >= size:
            all_ids = np.concatenate(ids)
            yield RawBatch(all_ids[:size], tuple(times[:size]), tuple(data[:size]))
            ids, times, data = [all_ids[size:]], times[size:], data[size:]
    if data:
        yield RawBatch(np.concatenate(ids), tuple(times), tuple(data))


def _slice_packed(b: PackedBatch, lo: int, hi: int) -> PackedBatch:
    """Messages lo..hi of a packed batch (the offsets index the same buffer)."""
    return PackedBatch(b.connection_ids[lo:hi], b.log_time_ns[lo:hi], b.buf, b.offsets[lo:hi], b.lengths[lo:hi])


def _wanted_rows(group: list[PackedBatch], wanted: np.ndarray) -> list[PackedBatch]:
    """The group's rows of the ``wanted`` ids (batches left empty dropped)."""
    out = []
    for b in group:
        keep = np.flatnonzero(np.isin(b.connection_ids, wanted))
        if keep.size:
            out.append(b if keep.size == b.lengths.size else PackedBatch(
                b.connection_ids[keep], b.log_time_ns[keep], b.buf, b.offsets[keep], b.lengths[keep]))
    return out


def _regroup_packed(parts, size: int, wanted: np.ndarray) -> Iterator[list[PackedBatch]]:
    """Windows of ``size`` rows (every topic) from every storage's packed groups in turn, ids mapped to the
    chained ids, each window's rows of ``wanted`` as one group (a window without any: none)."""
    group: list[PackedBatch] = []
    held = 0
    for groups, lookup in parts:
        for batches in groups:
            for b in batches:
                b = b._replace(connection_ids=lookup[b.connection_ids])
                start = 0
                while start < b.lengths.size:
                    take = min(size - held, b.lengths.size - start)
                    group.append(b if take == b.lengths.size else _slice_packed(b, start, start + take))
                    held += take
                    start += take
                    if held == size:
                        if out := _wanted_rows(group, wanted):
                            yield out
                        group, held = [], 0
    if group and (out := _wanted_rows(group, wanted)):
        yield out


def resolve_bags(paths) -> BagSet | Path:
    """The bags named by ``paths`` (bags or directories of bags): one bag as its Path (read as before), several
    as a BagSet ordered by their first message. InputError (one line) when two bags overlap in time."""
    found = [p for path in paths for p in _bag_paths(Path(path))]
    if len(found) == 1:
        return found[0]
    if len(set(found)) != len(found):
        twice = next(p for p in found if found.count(p) > 1)
        raise InputError(f"bag {twice} is given twice")
    spans = sorted((_span(p) for p in found), key=lambda s: (s.start_ns, s.end_ns))
    spans = [s for s in spans if s.messages]
    for a, b in zip(spans, spans[1:]):
        if b.start_ns < a.end_ns:
            raise InputError(f"bags overlap: {a.path} ({utc_text(a.start_ns)} .. {utc_text(a.end_ns - 1)}) and "
                             f"{b.path} (from {utc_text(b.start_ns)}); give bags of one machine that follow "
                             "each other")
    if not spans:
        raise InputError(f"no messages in the bags {', '.join(str(p) for p in found)}")
    return BagSet(tuple(spans))


def source_events(source, namespace: str | None = None) -> list:
    """The maintenance events of a bag (Path) or a BagSet."""
    return source.events(namespace) if isinstance(source, BagSet) else read_events(source, namespace)


def iter_source_chunks(source, **kwargs) -> Iterator:
    """The MachineRun chunks of a bag (Path) or a BagSet (``iter_machine_bag``'s arguments)."""
    if isinstance(source, BagSet):
        return source.iter_chunks(**kwargs)
    return iter_machine_bag(source, **kwargs)
