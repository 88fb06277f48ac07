"""Bag storage back ends behind one protocol: topics, counts, and the raw rows in log-time order.

`open_storage(path)` picks the back end; nothing else in guide_health looks at how a bag is stored.

- `SqliteDirectStorage`: a single-file, uncompressed sqlite3 bag whose metadata.yaml gives every
  topic's message count, read straight through apsw (rosbags' own sqlite binding).
- `RosbagsStorage`: everything else (mcap, split or compressed bags, a bare .db3 / .mcap file), and any
  bag opened with checked=True: rosbags.rosbag2.Reader.

The bag reader asks a back end for `iter_packed` first (issue 14): one byte buffer per batch instead of a
Python object per message (io.packed for sqlite3, io.mcap_chunks for a single mcap file); None means
"not here", and it reads `iter_batches`. The player keeps `iter_batches`.

Rows leave a back end as `RawBatch` columns (connection ids, log times, raw CDR bytes), not as one
Python object per message: a replay reads millions of messages, and a named record per message costs
0.25 s per million (measured with `iter_raw_messages`, which makes them for a player). Every read error
becomes InputError with a one-line text.
"""
from __future__ import annotations

import operator
from collections.abc import Collection, Iterator
from dataclasses import dataclass
from itertools import islice, repeat
from pathlib import Path
from typing import NamedTuple, Protocol

import numpy as np

from ..errors import InputError
from .bag_metadata import bag_yaml, check_bag_file_paths, one_line

#: exceptions that mean "this is not a good bag" when raised by a back end while opening or reading.
#: rosbags raises ReaderError, but a damaged file also surfaces as apsw/sqlite, struct, zstd, lz4,
#: OverflowError, UnicodeError, KeyError... from deep inside; only reader code runs in these try blocks.
_READ_ERRORS = (Exception,)
_EMPTY_START_NS = 2**63 - 1         # start / end of a bag without messages (as rosbags reports them)


@dataclass(frozen=True)
class BagConnection:
    """One topic of a bag (the fields of rosbags' Connection that guide_health uses)."""

    id: int             # back-end id, unique within an open storage; RawBatch.connection_ids refer to it
    topic: str
    msgtype: str
    msgcount: int


class RawBatch(NamedTuple):
    """Consecutive messages of a bag in log-time order, as three columns of equal length."""

    connection_ids: np.ndarray      # int64 BagConnection.id of each message
    log_time_ns: tuple              # int log (receive) time of each message [ns]
    data: tuple                     # raw CDR bytes of each message


class BagStorage(Protocol):
    """What the bag reader needs of a storage back end (cf. rosbags' storage reader protocol)."""

    path: Path
    connections: list[BagConnection]
    message_count: int

    @property
    def start_ns(self) -> int:
        """Log time of the first message [ns] (2**63 - 1 without messages)."""

    @property
    def end_ns(self) -> int:
        """Log time of the last message + 1 [ns] (0 without messages)."""

    def iter_batches(self, connections: Collection[BagConnection], chunk_messages: int,
                     start_ns: int | None = None) -> Iterator[RawBatch]:
        """The messages of `connections` from log time `start_ns` on (inclusive; None: all) in batches
        of `chunk_messages` (the last may be shorter). A read error first yields the rows read before
        it, then raises InputError."""

    def close(self) -> None:
        """Release the files; the storage is unusable afterwards."""

    def __enter__(self) -> BagStorage: ...

    def __exit__(self, *exc) -> None: ...


class RawMessage(NamedTuple):
    """One message of a bag, for a player."""

    connection: BagConnection
    log_time_ns: int
    data: bytes                     # raw CDR


def iter_raw_messages(storage: BagStorage, connections: Collection[BagConnection],
                      start_ns: int | None = None, chunk_messages: int = 1000) -> Iterator[RawMessage]:
    """The messages of `connections` one by one in log-time order, from log time `start_ns` on
    (inclusive; None: from the first message). A read error raises InputError after the messages read
    before it."""
    connection_of = {c.id: c for c in connections}.__getitem__
    as_message = repeat(RawMessage)
    for batch in storage.iter_batches(connections, chunk_messages, start_ns):
        rows = zip(map(connection_of, batch.connection_ids.tolist()), batch.log_time_ns, batch.data)
        yield from map(tuple.__new__, as_message, rows)      # RawMessage(*row), without a Python call


def open_storage(path, *, checked: bool = False) -> BagStorage:
    """Open the bag at `path` (directory, .db3 or .mcap) with the fastest back end that reads it.

    checked=True always uses rosbags, whose open reads every storage file's index (it counts a sqlite3
    database with a full scan), so that a damaged bag is refused before anything is reported or played.
    Raises InputError if the bag is missing or unreadable, or its metadata.yaml names a storage file
    outside the bag folder. Close it (or use it in a `with`).
    """
    path = Path(path)
    check_bag_file_paths(path)          # no storage file outside the bag folder
    if not checked:
        direct = SqliteDirectStorage.open(path)
        if direct is not None:
            return direct
    return RosbagsStorage(path)


def _batches(rows: Iterator[tuple], chunk_messages: int, path: Path, conn_id=None) -> Iterator[RawBatch]:
    """RawBatch columns of `chunk_messages` rows (connection, log time, bytes) at a time; conn_id maps a
    row's connection to its id (None: it is the id). On a read error the rows read before it are
    yielded first, then InputError is raised."""
    chunk_messages = max(1, int(chunk_messages))
    while True:
        got: list = []
        error = None
        try:
            got.extend(islice(rows, chunk_messages))      # in C; keeps the rows read before an error
        except _READ_ERRORS as exc:
            error = exc
        count = len(got)
        if count:
            conns, times, data = zip(*got)
            del got
            ids = np.fromiter(conns if conn_id is None else map(conn_id, conns), dtype=np.int64, count=count)
            yield RawBatch(ids, times, data)
        if error is not None:
            raise InputError(f"corrupt bag {path}: {one_line(error)}") from None
        if count < chunk_messages:
            return


class RosbagsStorage:
    """Any bag rosbags reads, through rosbags.rosbag2.Reader (see BagStorage)."""

    def __init__(self, path: Path):
        from rosbags.rosbag2 import Reader

        self.path = Path(path)
        if not self.path.exists():
            raise InputError(f"bag not found: {self.path}")
        try:
            reader = Reader(self.path)
            reader.open()
        except _READ_ERRORS as exc:
            raise InputError(f"not a readable rosbag2 bag: {self.path}: {one_line(exc)}") from None
        self._reader = reader
        self._rosbags_connection = {c.id: c for c in reader.connections}
        self.connections = [BagConnection(c.id, c.topic, c.msgtype, int(c.msgcount))
                            for c in reader.connections]
        self.message_count = int(reader.message_count)
        self.start_ns = int(reader.start_time)
        self.end_ns = int(reader.end_time)

    def iter_batches(self, connections: Collection[BagConnection], chunk_messages: int,
                     start_ns: int | None = None) -> Iterator[RawBatch]:
        wanted = [self._rosbags_connection[c.id] for c in connections]
        if not wanted:                   # rosbags reads every topic when given no connections
            return iter(())
        rows = self._reader.messages(connections=wanted, start=start_ns)
        return _batches(rows, chunk_messages, self.path, operator.attrgetter("id"))

    def iter_packed(self, connections: Collection[BagConnection], chunk_messages: int):
        """Packed batches of a single uncompressed-container mcap file read chunk by chunk
        (io.mcap_chunks), or None (then iter_batches through rosbags)."""
        from .mcap_chunks import iter_mcap_packed

        file = self.path
        if self.path.is_dir():
            info = bag_yaml(self.path)
            files = info.get("relative_file_paths") or []
            if (info.get("storage_identifier") != "mcap" or len(files) != 1 or info.get("compression_format")
                    or info.get("compression_mode") not in (None, "", "none", "NONE")):
                return None
            file = self.path / files[0]
        if file.suffix != ".mcap" or not connections:
            return None
        return iter_mcap_packed(file, list(connections), chunk_messages)

    def close(self) -> None:
        try:
            self._reader.close()
        except Exception:  # noqa: BLE001 - closing a broken reader must not hide the real error
            pass

    def __enter__(self) -> RosbagsStorage:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class SqliteDirectStorage:
    """A single-file, uncompressed sqlite3 bag read straight through apsw (see BagStorage).

    Why: rosbags' Reader.open() counts the messages of every topic with a full scan (0.64 s of a 1.5 s
    read of 1.1 M messages), and its reader yields each row as one Python generator step; here the
    counts come from metadata.yaml and the rows from the apsw cursor in C with islice. Measured on
    1.1 M messages: 0.7 s for the rows against 1.4 s through the generator (1.0 s with the stdlib
    sqlite3 module)."""

    def __init__(self, path: Path, db, connections: list[BagConnection]):
        self.path = path
        self._db = db
        self.connections = connections
        self.message_count = sum(c.msgcount for c in connections)
        self._time_range: tuple[int, int] | None = None

    @classmethod
    def open(cls, path: Path) -> SqliteDirectStorage | None:
        """The storage if `path` is such a bag whose metadata.yaml counts every topic; else None, and
        the caller reads with rosbags (which also reports what is wrong with a broken bag)."""
        try:
            import apsw
        except ImportError:  # pragma: no cover - rosbags depends on it
            return None
        info = bag_yaml(path) if path.is_dir() else {}
        files = info.get("relative_file_paths") or []
        if info.get("storage_identifier") != "sqlite3" or len(files) != 1 or info.get("compression_format"):
            return None
        counts = {}
        for entry in info.get("topics_with_message_count") or []:
            try:
                counts[entry["topic_metadata"]["name"]] = int(entry["message_count"])
            except (KeyError, TypeError, ValueError):
                return None
        db_path = path / files[0]
        if not db_path.is_file():
            return None
        try:
            db = apsw.Connection(str(db_path), flags=apsw.SQLITE_OPEN_READONLY)
            rows = db.execute("SELECT id, name, type FROM topics ORDER BY id")
            connections = [BagConnection(int(tid), name, msgtype, counts.get(name, -1))
                           for tid, name, msgtype in rows]
        except apsw.Error:
            return None
        if any(c.msgcount < 0 for c in connections):
            db.close()
            return None
        return cls(path, db, connections)

    def _log_time_range(self) -> tuple[int, int]:
        if self._time_range is None:
            try:
                from .packed import TIME_SPAN  # two index searches, not a scan of the index

                first, last = self._db.execute(TIME_SPAN).fetchone()
            except _READ_ERRORS as exc:
                raise InputError(f"corrupt bag {self.path}: {one_line(exc)}") from None
            self._time_range = ((int(first), int(last) + 1) if self.message_count and first is not None
                                else (_EMPTY_START_NS, 0))
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
        except _READ_ERRORS as exc:
            raise InputError(f"corrupt bag {self.path}: {one_line(exc)}") from None
        return _batches(rows, chunk_messages, self.path)

    def iter_packed(self, connections: Collection[BagConnection], chunk_messages: int):
        """Packed batches in log-time order read in rowid order (io.packed), or None when the rows are
        not stored in log-time order (then iter_batches, ORDER BY timestamp)."""
        from .packed import iter_sqlite_packed

        ids = tuple(c.id for c in connections)
        return iter_sqlite_packed(self._db, self.path, ids, chunk_messages) if ids else None

    def close(self) -> None:
        self._db.close()

    def __enter__(self) -> SqliteDirectStorage:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
