"""The mcap back end: an mcap bag (a directory of .mcap files, or a bare .mcap file) read whole or refused.

Every storage file is walked record by record (mcap_records.scan_file), so a file is read whatever indexes
its writer left out (summary, chunk index, message index, statistics, chunking). Topics and counts come from
the file's Statistics record where it has one that covers every channel (an open without decompressing), else
from a pass over every message (also for a checked open: then both must agree). A read delivers every message
of the wanted topics; when the file counts a different number than were read, the read ends with an
InputError naming the topic and both counts, never a silent partial result.

Order: segments (chunks, runs of unchunked messages) are taken in file order; consecutive segments whose log
time ranges overlap are read together, and the messages of each such group are sorted by (log time, position
in the file), the order of rosbags' merge (each chunk sorted by log time, stable; chunks merged by (log time,
chunk offset)). Groups that do not overlap follow one another in time, so the whole read is in log-time order.
A group holds its chunks in memory: segments that overlap one another are read at once.

Bags whose storage files are compressed as a whole or message by message (metadata.yaml compression_format)
are not read here: open() answers NOT_SUPPORTED and the rosbags fallback reads them.
"""
from __future__ import annotations

import mmap
from collections.abc import Collection, Iterator
from pathlib import Path

import numpy as np

from ...errors import InputError
from .mcap_records import (
    MESSAGE_HEAD,
    Segment,
    check_messages,
    scan_file,
    scan_records,
    segment_messages,
    segment_records,
)
from .metadata import bag_yaml, one_line
from .protocol import EMPTY_START_NS, NOT_SUPPORTED, READ_ERRORS, BagConnection, PackedBatch, RawBatch


def mcap_files(path: Path) -> list[Path] | None:
    """The storage files of an mcap bag in order (metadata.yaml's relative_file_paths, else the directory's
    *.mcap files by name); None for a bag whose files are compressed (the fallback reads those)."""
    if not path.is_dir():
        return [path]
    info = bag_yaml(path)
    if info.get("compression_format") or info.get("compression_mode") not in (None, "", "none", "NONE"):
        return None
    names = info.get("relative_file_paths") or sorted(p.name for p in path.glob("*.mcap"))
    return [path / str(name) for name in names]


def _open_buffer(file: Path):
    """The file's bytes, memory-mapped (bytes for an empty file)."""
    with open(file, "rb") as f:
        if f.seek(0, 2) == 0:
            return b""
        return mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)


class McapStorage:
    """An mcap bag read by its records (see the module text and protocol.BagStorage)."""

    def __init__(self, path: Path, files: list[Path], checked: bool = False):
        self.path = Path(path)
        self._bufs: list = []
        try:
            for file in files:
                if not file.is_file():
                    raise InputError(f"bag {self.path}: storage file {file.name} is missing")
                self._bufs.append(_open_buffer(file))
            self._layouts = [scan_file(buf, i) for i, buf in enumerate(self._bufs)]
            counts, time_range = self._counts(checked)
            self._connect(counts)
        except InputError:
            self.close()
            raise
        except READ_ERRORS as exc:
            self.close()
            raise InputError(f"not a readable mcap bag: {self.path}: {one_line(exc)}") from None
        self._file_counts = counts
        self.message_count = int(sum(counts.values()))
        self.start_ns, self.end_ns = ((int(time_range[0]), int(time_range[1]) + 1)
                                      if self.message_count and time_range else (EMPTY_START_NS, 0))

    @classmethod
    def open(cls, path: Path, checked: bool = False) -> McapStorage | None:
        """The storage of the mcap bag at `path`; NOT_SUPPORTED for a bag of compressed files. checked: count
        every message now (a damaged file is refused before anything is read)."""
        path = Path(path)
        if not path.exists():
            raise InputError(f"bag not found: {path}")
        files = mcap_files(path)
        if files is None:
            return NOT_SUPPORTED
        if not files:
            raise InputError(f"not a readable mcap bag: {path}: no .mcap file")
        return cls(path, files, checked)

    def _counts(self, checked: bool) -> tuple[dict, tuple | None]:
        """({(file, channel id): messages}, (first, last) log time) from the Statistics records when every file
        has one covering every channel it defines (and not `checked`), else by reading every message."""
        layouts = self._layouts
        if not checked and all(lay.counts is not None and set(lay.counts) <= set(lay.channels) for lay in layouts):
            counts = {(i, cid): n for i, lay in enumerate(layouts) for cid, n in lay.counts.items()}
            ranges = [lay.time_range for lay in layouts if lay.time_range]
            return counts, ((min(r[0] for r in ranges), max(r[1] for r in ranges)) if ranges else None)
        counts: dict = {}
        lo, hi = None, None
        for i, (layout, buf) in enumerate(zip(layouts, self._bufs)):
            for seg in layout.segments:
                channel, log_ns, _ = scan_records(segment_records(buf, seg), None, layout)
                for cid, n in zip(*np.unique(channel, return_counts=True)):
                    counts[(i, int(cid))] = counts.get((i, int(cid)), 0) + int(n)
                if log_ns.size:
                    lo = int(log_ns.min()) if lo is None else min(lo, int(log_ns.min()))
                    hi = int(log_ns.max()) if hi is None else max(hi, int(log_ns.max()))
            if layout.counts is not None:
                self._check_counts(i, layout.counts, {cid: n for (f, cid), n in counts.items() if f == i})
        return counts, (None if lo is None else (lo, hi))

    def _connect(self, counts: dict) -> None:
        """One BagConnection per (topic, type) over every file; self._conn_of[(file, channel)] = its id."""
        key_id: dict = {}
        self._conn_of: dict = {}
        totals: list[int] = []
        for i, layout in enumerate(self._layouts):
            for cid in sorted(set(layout.channels) | {c for (f, c) in counts if f == i}):
                key = layout.channel_type(cid)
                if key not in key_id:
                    key_id[key] = len(key_id)
                    totals.append(0)
                self._conn_of[(i, cid)] = key_id[key]
                totals[key_id[key]] += counts.get((i, cid), 0)
        self.connections = [BagConnection(k, topic, msgtype, totals[k]) for (topic, msgtype), k in key_id.items()]

    def _check_counts(self, file: int, stated: dict, read: dict) -> None:
        """InputError naming the topic when a file states another message count for a channel than was read."""
        for cid in sorted(set(stated) | set(read)):
            if stated.get(cid, 0) != read.get(cid, 0):
                topic = self._layouts[file].channels.get(cid, (f"channel {cid}",))[0]
                raise InputError(f"bag {self.path}: topic {topic}: the file holds {stated.get(cid, 0)} messages, "
                                 f"{read.get(cid, 0)} were read (its records disagree with its statistics or "
                                 "message indexes: a damaged or incompletely written file)")

    def iter_packed(self, connections: Collection[BagConnection],
                    chunk_messages: int, start_ns: int | None = None) -> Iterator[list[PackedBatch]]:
        """Groups of packed batches, exactly `chunk_messages` messages a group (the last may have fewer), of
        `connections` in log-time order from `start_ns` on (None: all). After the last group the messages read
        are checked against the counts: InputError (as for every read error) when they differ."""
        return self._packed_groups(connections, chunk_messages, start_ns)

    def iter_batches(self, connections: Collection[BagConnection], chunk_messages: int,
                     start_ns: int | None = None) -> Iterator[RawBatch]:
        """The same messages as RawBatch columns (one bytes object per message)."""
        for group in self._packed_groups(connections, chunk_messages, start_ns):
            ids = np.concatenate([b.connection_ids for b in group])
            times = tuple(np.concatenate([b.log_time_ns for b in group]).tolist())
            data = []
            for b in group:
                view = memoryview(b.buf)
                data.extend(view[o:o + n].tobytes() for o, n in zip(b.offsets.tolist(), b.lengths.tolist()))
            yield RawBatch(ids, times, tuple(data))

    def _packed_groups(self, connections: Collection[BagConnection], chunk_messages: int,
                       start_ns: int | None) -> Iterator[list[PackedBatch]]:
        ids = {c.id for c in connections}
        wanted = {key: conn for key, conn in self._conn_of.items() if conn in ids}
        return self._iter_groups(wanted, max(1, int(chunk_messages)), start_ns)

    def _clusters(self, wanted: dict, start_ns: int | None) -> Iterator[list[Segment]]:
        """The segments that may hold wanted messages in groups whose log time ranges are disjoint, in time
        order: segments by first log time, a segment joining the group while it begins no later than the
        group's last log time (so that a log time shared across segments is sorted in one group); each group
        in file order."""
        files_channels: dict = {}
        for f, cid in wanted:
            files_channels.setdefault(f, set()).add(cid)
        segments = [seg for layout in self._layouts for seg in layout.segments
                    if files_channels.get(seg.file) and (start_ns is None or seg.end_ns >= start_ns)
                    and not (seg.index and not files_channels[seg.file] & seg.index.keys())]
        group: list[Segment] = []
        group_end = None
        for seg in sorted(segments, key=lambda s: s.start_ns):        # stable: file order for equal starts
            if group and seg.start_ns <= group_end:
                group.append(seg)
                group_end = max(group_end, seg.end_ns)
                continue
            if group:
                yield sorted(group, key=lambda s: (s.file, s.offset))
            group, group_end = [seg], seg.end_ns
        if group:
            yield sorted(group, key=lambda s: (s.file, s.offset))

    def _cluster_batch(self, group: list[Segment], wanted: dict, start_ns: int | None,
                       rows: dict) -> PackedBatch:
        """The wanted messages of a group of segments in (log time, file position) order; `rows` counts
        them per (file, channel)."""
        bufs, cols, base = [], [], 0
        for seg in group:
            buf = self._bufs[seg.file]
            records = segment_records(buf, seg)
            chans = {cid for (f, cid) in wanted if f == seg.file}
            channel, log_ns, rec_off = segment_messages(buf, seg, records, chans)
            lengths = check_messages(records, channel, log_ns, rec_off)
            for cid, n in zip(*np.unique(channel, return_counts=True)):
                rows[(seg.file, int(cid))] = rows.get((seg.file, int(cid)), 0) + int(n)
            conn = np.array([wanted.get((seg.file, c), -1) for c in range(int(channel.max(initial=0)) + 1)],
                            np.int64)
            cols.append((conn[channel], log_ns, rec_off + base + 9 + MESSAGE_HEAD, lengths))
            bufs.append(records)
            base += records.size
        ids, log_ns, offsets, lengths = (np.concatenate(c) for c in zip(*cols))
        order = np.lexsort((offsets, log_ns))
        if start_ns is not None:
            order = order[log_ns[order] >= start_ns]
        buf = bufs[0] if len(bufs) == 1 else np.concatenate(bufs)
        return PackedBatch(ids[order], log_ns[order], buf, offsets[order], lengths[order])

    def _iter_groups(self, wanted: dict, step: int, start_ns: int | None) -> Iterator[list[PackedBatch]]:
        pending: list[PackedBatch] = []
        count = 0
        rows: dict = {}
        for group in self._clusters(wanted, start_ns):
            try:
                batch = self._cluster_batch(group, wanted, start_ns, rows)
            except READ_ERRORS as exc:
                raise InputError(f"corrupt bag {self.path}: {one_line(exc)}") from None
            done, n = 0, int(batch.lengths.size)
            while n - done >= step - count:          # complete a group of `step` messages
                pending.append(_take(batch, done, done + step - count))
                done += step - count
                yield pending
                pending, count = [], 0
            if done < n:
                pending.append(_take(batch, done, n))
                count += n - done
        if count:
            yield pending
        if start_ns is None:
            for f in sorted({f for f, _ in wanted}):
                stated = {c: n for (g, c), n in self._file_counts.items() if g == f and (g, c) in wanted}
                self._check_counts(f, stated, {c: n for (g, c), n in rows.items() if g == f})

    def close(self) -> None:
        for buf in self._bufs:
            if isinstance(buf, mmap.mmap):
                try:
                    buf.close()
                except BufferError:        # a batch still views it: released with the batch
                    pass
        self._bufs = []

    def __enter__(self) -> McapStorage:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _take(batch: PackedBatch, lo: int, hi: int) -> PackedBatch:
    return PackedBatch(batch.connection_ids[lo:hi], batch.log_time_ns[lo:hi], batch.buf, batch.offsets[lo:hi],
                       batch.lengths[lo:hi])
