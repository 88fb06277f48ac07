"""The sqlite3 back end: an uncompressed sqlite3 bag whose metadata.yaml gives every topic's message count,
read straight through apsw (rosbags' own sqlite binding); a bag split into several files is read file after
file (sqlite3_split.py); any other sqlite3 bag is NOT_SUPPORTED here (`Sqlite3Storage.open`) and goes to the
rosbags fallback.

Why: rosbags' Reader.open() counts the messages of every topic with a full scan (0.64 s of a 1.5 s read of
1.1 M messages), and its reader yields each row as one Python generator step; here the counts come from
metadata.yaml and the rows from the apsw cursor in C with islice. Measured on 1.1 M messages: 0.7 s for the
rows against 1.4 s through the generator (1.0 s with the stdlib sqlite3 module).

Bulk reading (`iter_packed`, `iter_sqlite_packed`): one byte buffer per batch instead of a Python object per
message. rosbag2 appends rows as messages arrive, so the rowid order is nearly always the log-time order,
and a scan in rowid order avoids walking the timestamp index (1.7x the scan). That is checked, not assumed:
the rowids are cut into ranges of `chunk_messages` and one query per range gives its MIN/MAX(timestamp) (a
covering scan without the blobs, about 0.07 us per row); the rowid order is used only if every range ends no
later than the next one begins. A range whose rows are not in order inside it is sorted by (timestamp, rowid)
in numpy, which then gives exactly what `ORDER BY timestamp` gives through the timestamp index (ties in rowid
order). Otherwise the caller falls back to `ORDER BY timestamp`.

Each range is read with one row per query: `group_concat` of the blobs cast back to BLOB (sqlite copies
the bytes of a blob into the text of a UTF-8 database unchanged) plus the lengths, topic ids and
timestamps as comma-separated text parsed by numpy. The total length is checked against the lengths; a
range that cannot be read this way (too large a string, another text encoding) is read row by row.
"""
from __future__ import annotations

from collections.abc import Collection, Iterator
from concurrent.futures import ThreadPoolExecutor
from itertools import islice
from pathlib import Path

import numpy as np

from ...errors import InputError
from .metadata import bag_yaml, one_line
from .protocol import (
    EMPTY_START_NS,
    NOT_SUPPORTED,
    READ_ERRORS,
    BagConnection,
    PackedBatch,
    RawBatch,
    raw_batches,
)
from .sqlite3_split import open_split

#: first and last rowid / log time of the messages table: one index search each. (MIN and MAX in one SELECT
#: scan the whole timestamp index: 22-25 ms for 0.5 M rows, against 0.02 ms.)
ROWID_SPAN = "SELECT (SELECT MIN(rowid) FROM messages), (SELECT MAX(rowid) FROM messages)"
TIME_SPAN = "SELECT (SELECT MIN(timestamp) FROM messages), (SELECT MAX(timestamp) FROM messages)"


def pack_rows(conn_ids, log_times, raws) -> PackedBatch:
    """A PackedBatch from per-message columns (ids, times, bytes), for the fallbacks."""
    lengths = np.fromiter(map(len, raws), np.int64, count=len(raws))
    return PackedBatch(np.asarray(conn_ids, np.int64).reshape(-1), np.asarray(log_times, np.int64).reshape(-1),
                       np.frombuffer(b"".join(raws), np.uint8), _starts(lengths), lengths)


def _starts(lengths: np.ndarray) -> np.ndarray:
    offsets = np.zeros(lengths.size, np.int64)
    np.cumsum(lengths[:-1], out=offsets[1:])
    return offsets


def _ints(text) -> np.ndarray:
    return np.fromstring(text, dtype=np.int64, sep=",") if text else np.zeros(0, np.int64)


def time_sorted(batch: PackedBatch) -> PackedBatch:
    """The batch in (log time, position) order: itself when already sorted."""
    t = batch.log_time_ns
    if t.size < 2 or (t[1:] >= t[:-1]).all():
        return batch
    order = np.argsort(t, kind="stable")
    return PackedBatch(batch.connection_ids[order], t[order], batch.buf, batch.offsets[order],
                       batch.lengths[order])


def _range_ranges(db, step: int) -> list[tuple[int, int]] | None:
    """Rowid ranges [lo, hi) of `step` rowids whose log times do not overlap (each ends no later than
    the next begins); None if they do (then the rowid order is not the log-time order)."""
    lo, hi = db.execute(ROWID_SPAN).fetchone()
    if lo is None:
        return []
    ranges = []
    last_max = None
    sql = "SELECT MIN(timestamp), MAX(timestamp) FROM messages WHERE rowid >= ? AND rowid < ?"
    for start in range(int(lo), int(hi) + 1, step):
        t_min, t_max = db.execute(sql, (start, start + step)).fetchone()
        if t_min is None:
            continue
        if last_max is not None and t_min < last_max:
            return None
        last_max = t_max
        ranges.append((start, start + step))
    return ranges


#: the aggregates of a range: blobs, lengths, topic ids and log times ({time}: relative to a base, shorter
#: text to write and parse)
_COLUMNS = ("CAST(group_concat(data, '') AS BLOB), group_concat(length(data)), group_concat(topic_id), "
            "group_concat({time})")
_RANGE = "FROM messages WHERE rowid >= ? AND rowid < ?"
#: the aggregates straight over the rowid range search (the rows are stepped in rowid order: checked on the
#: query plan, _plan_in_rowid_order), else over a sub-query ordered by rowid (materialised: 15 % slower)
_RANGE_SQL = (f"SELECT {_COLUMNS} {_RANGE}{{where}}",
              f"SELECT {_COLUMNS} FROM (SELECT data, topic_id, timestamp {_RANGE}{{where}} ORDER BY rowid)")


def _range_sql(flat: bool, where: str, base_ns: int) -> str:
    """The range query; with a base its first parameter is the base (an int64 bound, never a literal)."""
    return _RANGE_SQL[0 if flat else 1].format(where=where, time="timestamp - ?" if base_ns else "timestamp")


def _plan_in_rowid_order(db, where: str, args: list) -> bool:
    """Whether sqlite runs the flat range query as one search of the rowid (integer primary key) range, so
    that its aggregates see the rows in rowid order (an ungrouped aggregate is stepped in loop order)."""
    try:
        plan = db.execute("EXPLAIN QUERY PLAN " + _range_sql(True, where, 0), [0, 1, *args]).fetchall()
    except Exception:  # noqa: BLE001 - no plan: take the ordered sub-query
        return False
    details = [str(row[-1]) for row in plan]
    return (len(details) == 1 and details[0].startswith("SEARCH messages USING INTEGER PRIMARY KEY")
            and "rowid>" in details[0] and "rowid<" in details[0])


def _time_base(db) -> int:
    """The smallest log time when every log time minus it fits int64 (integer times); else 0 (none)."""
    lo, hi = db.execute(TIME_SPAN).fetchone()
    if isinstance(lo, int) and isinstance(hi, int) and hi - lo < 2**63:
        return lo
    return 0


def _read_range(db, start: int, stop: int, where: str, args: list, flat: bool = False,
                base_ns: int = 0) -> PackedBatch:
    """The wanted rows of rowids [start, stop) in rowid order, packed (`flat`: the query plan is a rowid range
    search, _plan_in_rowid_order; `base_ns`: log times are read relative to it, _time_base)."""
    import apsw

    try:
        first = [base_ns] if base_ns else []
        blob, lengths, ids, times = db.execute(_range_sql(flat, where, base_ns),
                                               [*first, start, stop, *args]).fetchone()
    except apsw.TooBigError:            # more than SQLITE_MAX_LENGTH bytes: read this range row by row
        blob = None
    else:
        lengths = _ints(lengths)
        blob = b"" if blob is None and not lengths.size else blob
        if isinstance(blob, bytes) and int(lengths.sum()) == len(blob):
            times = _ints(times)
            if base_ns:
                times += base_ns
            return PackedBatch(_ints(ids), times, np.frombuffer(blob, np.uint8), _starts(lengths), lengths)
    rows = db.execute(f"SELECT topic_id, timestamp, data FROM messages WHERE rowid >= ? AND rowid < ?{where} "
                      "ORDER BY rowid", [start, stop, *args]).fetchall()
    return pack_rows(*zip(*rows)) if rows else pack_rows((), (), ())


def _has_time_index(db) -> bool:
    """Whether an index of `messages` starts with the timestamp column (rosbag2's timestamp_idx)."""
    for row in db.execute("PRAGMA index_list(messages)").fetchall():
        cols = db.execute(f"PRAGMA index_info(\"{row[1]}\")").fetchall()
        if cols and cols[0][2] == "timestamp":
            return True
    return False


def iter_sqlite_packed(db, path, topic_ids: tuple, chunk_messages: int) -> Iterator[list[PackedBatch]] | None:
    """Packed batches (each alone in a list, as the mcap reader gives groups of them) of the rows of
    `topic_ids` in log-time order, `chunk_messages` rowids at a time; NOT_SUPPORTED if the rows are not stored in
    log-time order (known before reading) or the database is not UTF-8 (the caller then reads with ORDER
    BY timestamp). Read errors raise InputError.

    With a timestamp index the order is checked range by range while reading (see _RangeReader): before
    range k is handed on, no wanted row after it may be earlier than the latest time so far; an index range
    scan over the times of that range. When a check fails, the rest is read with ORDER BY timestamp (what
    was handed on is the start of that order). Without the index, all ranges are checked first."""
    step = max(1, int(chunk_messages))
    try:
        if db.execute("PRAGMA encoding").fetchone()[0] != "UTF-8":
            return NOT_SUPPORTED
        if _has_time_index(db):
            lo, hi = db.execute(ROWID_SPAN).fetchone()
            ranges = [] if lo is None else [(r, r + step) for r in range(int(lo), int(hi) + 1, step)]
            checked = False
        else:
            ranges, checked = _range_ranges(db, step), True
    except Exception as exc:  # noqa: BLE001 - a damaged database: one-line error
        raise InputError(f"corrupt bag {path}: {one_line(exc)}") from None
    if ranges is None:
        return NOT_SUPPORTED
    where = f" AND topic_id IN ({','.join('?' * len(topic_ids))})"
    try:
        every = _every_topic(db, topic_ids)
        flat = _plan_in_rowid_order(db, "" if every else where, [] if every else list(topic_ids))
        base_ns = _time_base(db)
    except Exception as exc:  # noqa: BLE001 - a damaged database: one-line error
        raise InputError(f"corrupt bag {path}: {one_line(exc)}") from None
    reader = _RangeReader(db, path, where, list(topic_ids), checked, flat, base_ns, unfiltered=every)
    return _iter_ranges(reader, ranges, step)


def _every_topic(db, topic_ids) -> bool:
    """Whether the wanted topics are all the topics of the bag: the ranges are then read without the
    per-row topic filter (12 ms per 0.5 M rows), and rows of no known topic are dropped in numpy."""
    return {int(row[0]) for row in db.execute("SELECT id FROM topics").fetchall()} == {int(t) for t in topic_ids}


def _only(batch: PackedBatch, topic_ids: np.ndarray) -> PackedBatch:
    """The batch's rows of `topic_ids` (itself when all are)."""
    ok = np.isin(batch.connection_ids, topic_ids)
    if ok.all():
        return batch
    k = np.flatnonzero(ok)
    return PackedBatch(batch.connection_ids[k], batch.log_time_ns[k], batch.buf, batch.offsets[k], batch.lengths[k])


class _RangeReader:
    """Reads rowid ranges in order (in one worker thread), checking the log-time order as it goes."""

    def __init__(self, db, path, where: str, args: list, checked: bool, flat: bool = False, base_ns: int = 0,
                 unfiltered: bool = False):
        self.db, self.path, self.where, self.args = db, path, where, args
        self.checked = checked
        self.flat, self.base_ns = flat, base_ns         # see _read_range
        # every topic wanted: ranges read without the topic filter, rows of unknown topics dropped (_only)
        self.unfiltered = np.asarray(sorted(args), np.int64) if unfiltered else None
        self.latest_ns: int | None = None      # max log time of the wanted rows read so far

    def read(self, bounds: tuple[int, int]) -> PackedBatch | None:
        """The range's wanted rows sorted by (time, rowid); None if a later row is earlier than them."""
        try:
            if self.unfiltered is None:
                batch = _read_range(self.db, bounds[0], bounds[1], self.where, self.args, self.flat, self.base_ns)
            else:
                batch = _only(_read_range(self.db, bounds[0], bounds[1], "", [], self.flat, self.base_ns),
                              self.unfiltered)
            batch = time_sorted(batch)
            if self.checked or not batch.lengths.size:
                return batch
            low = -(2**63) if self.latest_ns is None else self.latest_ns
            high = max(low, int(batch.log_time_ns[-1]))
            sql = f"SELECT 1 FROM messages WHERE timestamp >= ? AND timestamp < ? AND rowid >= ?{self.where} LIMIT 1"
            if self.db.execute(sql, [low, high, bounds[1], *self.args]).fetchone() is not None:
                return None
            self.latest_ns = high
            return batch
        except Exception as exc:  # noqa: BLE001 - a damaged database: one-line error
            raise InputError(f"corrupt bag {self.path}: {one_line(exc)}") from None

    def ordered_from(self, start: int, step: int) -> Iterator[list[PackedBatch]]:
        """The wanted rows from rowid `start` on with ORDER BY timestamp, packed `step` at a time."""
        try:
            rows = self.db.execute(f"SELECT topic_id, timestamp, data FROM messages WHERE rowid >= ?{self.where} "
                                   "ORDER BY timestamp", [start, *self.args])
            while got := list(islice(rows, step)):
                yield [pack_rows(*zip(*got))]
        except Exception as exc:  # noqa: BLE001 - a damaged database: one-line error
            raise InputError(f"corrupt bag {self.path}: {one_line(exc)}") from None


#: read the next rowid range in a thread while this one is decoded (set_read_ahead)
_READ_AHEAD = [True]


def set_read_ahead(on: bool) -> None:
    """Whether bulk sqlite3 reads query the next range in a thread while the caller decodes this one. On by
    default (one bag on a multi-core machine: the query overlaps the decoding). A fleet worker switches it off
    when every core already runs a bag: the thread then only adds switching (same results either way)."""
    _READ_AHEAD[0] = bool(on)


def _iter_ranges(reader: _RangeReader, ranges, step: int) -> Iterator[list[PackedBatch]]:
    """Read the ranges one ahead in a worker thread (apsw releases the GIL while sqlite works, so the
    query of the next range runs while the caller decodes this one); at most two ranges in memory.
    Without read-ahead (set_read_ahead), one range after the other in this thread."""
    if not _READ_AHEAD[0]:
        yield from _iter_ranges_inline(reader, ranges, step)
        return
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="bag-read") as pool:
        ahead = pool.submit(reader.read, ranges[0]) if ranges else None
        for k in range(len(ranges)):
            batch = ahead.result()
            if batch is None:                   # out of order from here on
                ahead = None
                yield from reader.ordered_from(ranges[k][0], step)
                return
            ahead = pool.submit(reader.read, ranges[k + 1]) if k + 1 < len(ranges) else None
            if batch.lengths.size:
                yield [batch]
            del batch


def _iter_ranges_inline(reader: _RangeReader, ranges, step: int) -> Iterator[list[PackedBatch]]:
    for lo, hi in ranges:
        batch = reader.read((lo, hi))
        if batch is None:                       # out of order from here on
            yield from reader.ordered_from(lo, step)
            return
        if batch.lengths.size:
            yield [batch]
        del batch


class Sqlite3Storage:
    """A single-file, uncompressed sqlite3 bag read straight through apsw (see protocol.BagStorage)."""

    def __init__(self, path: Path, db, connections: list[BagConnection]):
        self.path = path
        self._db = db
        self.connections = connections
        self.message_count = sum(c.msgcount for c in connections)
        self._time_range: tuple[int, int] | None = None

    @classmethod
    def open(cls, path: Path, checked: bool = False) -> Sqlite3Storage | None:
        """The storage if `path` is such a bag whose metadata.yaml counts every topic; NOT_SUPPORTED for any
        other bag and for a checked open (the rosbags fallback reads those, and reports what is wrong with a
        broken bag)."""
        if checked:
            return NOT_SUPPORTED
        try:
            import apsw
        except ImportError:  # pragma: no cover - rosbags depends on it
            return NOT_SUPPORTED
        info = bag_yaml(path) if path.is_dir() else {}
        files = info.get("relative_file_paths") or []
        if info.get("storage_identifier") != "sqlite3" or not files or info.get("compression_format"):
            return NOT_SUPPORTED
        counts = {}
        for entry in info.get("topics_with_message_count") or []:
            try:
                counts[entry["topic_metadata"]["name"]] = int(entry["message_count"])
            except (KeyError, TypeError, ValueError):
                return NOT_SUPPORTED
        if len(files) > 1:                  # split by rosbag2: the files chained (sqlite3_split.py)
            return open_split(cls, path, info, files, counts)
        db_path = path / files[0]
        if not db_path.is_file():
            return NOT_SUPPORTED
        try:
            db = apsw.Connection(str(db_path), flags=apsw.SQLITE_OPEN_READONLY)
            rows = db.execute("SELECT id, name, type FROM topics ORDER BY id")
            connections = [BagConnection(int(tid), name, msgtype, counts.get(name, -1))
                           for tid, name, msgtype in rows]
        except apsw.Error:
            return NOT_SUPPORTED
        if any(c.msgcount < 0 for c in connections):
            db.close()
            return NOT_SUPPORTED
        return cls(path, db, connections)

    def _log_time_range(self) -> tuple[int, int]:
        if self._time_range is None:
            try:
                first, last = self._db.execute(TIME_SPAN).fetchone()  # two index searches, not a scan
            except READ_ERRORS as exc:
                raise InputError(f"corrupt bag {self.path}: {one_line(exc)}") from None
            self._time_range = ((int(first), int(last) + 1) if self.message_count and first is not None
                                else (EMPTY_START_NS, 0))
        return self._time_range

    @property
    def start_ns(self) -> int:
        return self._log_time_range()[0]

    @property
    def end_ns(self) -> int:
        return self._log_time_range()[1]

    def iter_batches(self, connections: Collection[BagConnection], chunk_messages: int,
                     start_ns: int | None = None) -> Iterator[RawBatch]:
        ids = tuple(c.id for c in connections)
        if not ids:
            return iter(())
        sql = f"SELECT topic_id, timestamp, data FROM messages WHERE topic_id IN ({','.join('?' * len(ids))})"
        args = list(ids)
        if start_ns is not None:
            sql += " AND timestamp >= ?"
            args.append(int(start_ns))
        try:            # log-time order, as rosbags orders them
            rows = self._db.execute(sql + " ORDER BY timestamp", args)
        except READ_ERRORS as exc:
            raise InputError(f"corrupt bag {self.path}: {one_line(exc)}") from None
        return raw_batches(rows, chunk_messages, self.path)

    def iter_packed(self, connections: Collection[BagConnection],
                    chunk_messages: int) -> Iterator[list[PackedBatch]] | None:
        """Packed batches in log-time order read in rowid order (iter_sqlite_packed); NOT_SUPPORTED when the
        rows are not stored in log-time order (then iter_batches, ORDER BY timestamp)."""
        ids = tuple(c.id for c in connections)
        packed = iter_sqlite_packed(self._db, self.path, ids, chunk_messages) if ids else NOT_SUPPORTED
        return packed if packed is NOT_SUPPORTED else self._released_after(packed)

    def _released_after(self, groups: Iterator[list[PackedBatch]]) -> Iterator[list[PackedBatch]]:
        """The groups, then the connection's page cache freed: a storage read to its end holds no pages, so
        a chain of many bags (chained_storage.ChainedStorage, a month of splits) holds one bag's cache, not one each."""
        yield from groups
        self._db.execute("PRAGMA shrink_memory")

    def close(self) -> None:
        self._db.close()

    def __enter__(self) -> Sqlite3Storage:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
