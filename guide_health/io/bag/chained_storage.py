"""Several storages read one after the other in log time as one storage (protocol.BagStorage): the bags of
a BagSet (bag_set.py) and the files of one split sqlite3 bag (sqlite3_split.py). A topic's connections of
every storage become one connection, and the packed batches run on across the storages' boundaries in the
windows one storage of the same rows is read in, so a reader's result is that of one bag to the last bit.
"""
from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from .protocol import NOT_SUPPORTED, BagConnection, PackedBatch, RawBatch


class ChainedStorage:
    """Several storages, one after the other in log time, as one (protocol.BagStorage): a topic's
    connections of every bag become one connection, and batches run on across the bags' boundaries, so a
    reader sees the batches it would see in one bag of the same messages."""

    def __init__(self, storages: list, bag_set):
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
