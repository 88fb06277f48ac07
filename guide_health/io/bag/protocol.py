"""The one protocol every bag storage back end implements (cf. rosbags' storage reader protocol), and the
row containers that leave a back end.

Rows leave a back end as `RawBatch` columns (connection ids, log times, raw CDR bytes), not as one Python
object per message: a replay reads millions of messages, and a named record per message costs 0.25 s per
million (measured with `storage.iter_raw_messages`, which makes them for a player). Bulk reading gives
`PackedBatch`es instead: one byte buffer per batch. Every read error becomes InputError with a one-line
text.

A capability a back end (or a particular bag) lacks is answered with `NOT_SUPPORTED`, never by a missing
method: every back end has every method of `BagStorage`.
"""
from __future__ import annotations

from collections.abc import Collection, Iterator
from dataclasses import dataclass
from itertools import islice
from pathlib import Path
from typing import Final, NamedTuple, Protocol

import numpy as np

from ...errors import InputError
from .metadata import one_line

#: what a back end returns for a capability it does not have (for this bag): the caller takes the path every
#: back end has (`iter_packed` -> NOT_SUPPORTED: read `iter_batches`)
NOT_SUPPORTED: Final = None

#: exceptions that mean "this is not a good bag" when raised by a back end while opening or reading.
#: rosbags raises ReaderError, but a damaged file also surfaces as apsw/sqlite, struct, zstd, lz4,
#: OverflowError, UnicodeError, KeyError... from deep inside; only reader code runs in these try blocks.
READ_ERRORS = (Exception,)
EMPTY_START_NS = 2**63 - 1          # start / end of a bag without messages (as rosbags reports them)


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


class PackedBatch(NamedTuple):
    """Consecutive messages in log-time order, their bytes packed in one buffer."""

    connection_ids: np.ndarray      # int64 storage connection id of each message
    log_time_ns: np.ndarray         # int64 log time of each message [ns]
    buf: np.ndarray                 # uint8: every message's bytes, one after the other
    offsets: np.ndarray             # int64 start of each message in buf
    lengths: np.ndarray             # int64 length of each message [bytes]


class BagStorage(Protocol):
    """What the bag reader and the player need of a storage back end: topics, counts, and the raw rows in
    log-time order."""

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

    def iter_packed(self, connections: Collection[BagConnection],
                    chunk_messages: int) -> Iterator[list[PackedBatch]] | None:
        """Groups of packed batches of `connections` in log-time order, `chunk_messages` messages a group
        (no Python object per message); NOT_SUPPORTED when this back end cannot read this bag that way
        (then read `iter_batches`). Read errors raise InputError."""

    def close(self) -> None:
        """Release the files; the storage is unusable afterwards."""

    def __enter__(self) -> BagStorage: ...

    def __exit__(self, *exc) -> None: ...


def raw_batches(rows: Iterator[tuple], chunk_messages: int, path: Path, conn_id=None) -> Iterator[RawBatch]:
    """RawBatch columns of `chunk_messages` rows (connection, log time, bytes) at a time; conn_id maps a
    row's connection to its id (None: it is the id). On a read error the rows read before it are
    yielded first, then InputError is raised."""
    chunk_messages = max(1, int(chunk_messages))
    while True:
        got: list = []
        error = None
        try:
            got.extend(islice(rows, chunk_messages))      # in C; keeps the rows read before an error
        except READ_ERRORS as exc:
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
