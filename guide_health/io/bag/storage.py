"""Bag storage back ends in one table keyed by the storage identifier of metadata.yaml (`BACKENDS`), and the
rosbags fallback for any bag none of them reads; `open_storage(path)` picks one, and nothing else in
guide_health looks at how a bag is stored.

- ``sqlite3``: `Sqlite3Storage` (sqlite3_storage.py), an uncompressed sqlite3 bag whose metadata.yaml
  counts every topic, read straight through apsw, with bulk packed reading; a split bag's files chained in
  log-time order (sqlite3_split.py);
- ``mcap``: `McapStorage` (mcap_storage.py), every record of the bag's .mcap files walked without relying on
  their indexes (mcap_records.py), read whole or refused;
- the fallback `RosbagsStorage` (rosbags_storage.py): everything else (compressed sqlite3 bags, split ones
  whose files overlap in time, a bare .db3 file, a bag opened checked, mcap bags of compressed files),
  through rosbags.rosbag2.Reader.

Every back end implements the whole protocol (protocol.BagStorage); what one cannot do for a bag it answers
with protocol.NOT_SUPPORTED. The bag reader asks `iter_packed` first (one byte buffer per batch) and reads
`iter_batches` when that is not supported; the player reads `iter_batches` (`iter_raw_messages`).
"""
from __future__ import annotations

from collections.abc import Collection, Iterator
from itertools import repeat
from pathlib import Path
from typing import NamedTuple

from .mcap_storage import McapStorage
from .metadata import bag_yaml, check_bag_file_paths
from .protocol import NOT_SUPPORTED, BagConnection, BagStorage
from .rosbags_storage import RosbagsStorage
from .sqlite3_storage import Sqlite3Storage

#: storage identifier (metadata.yaml storage_identifier) -> back end; each has open(path, checked) that gives
#: its storage or NOT_SUPPORTED (then the fallback reads the bag)
BACKENDS = {"sqlite3": Sqlite3Storage, "mcap": McapStorage}
FALLBACK = RosbagsStorage
#: the storage identifier of a bare storage file (no metadata.yaml), by its suffix
SUFFIX_STORAGE = {".db3": "sqlite3", ".mcap": "mcap"}


def storage_identifier(path: Path) -> str | None:
    """metadata.yaml's storage_identifier of a bag directory, or the one of a bare storage file's suffix."""
    path = Path(path)
    if path.is_dir():
        return bag_yaml(path).get("storage_identifier")
    return SUFFIX_STORAGE.get(path.suffix)


def open_storage(path, *, checked: bool = False) -> BagStorage:
    """Open the bag at `path` (directory, .db3 or .mcap) with the back end of its storage identifier, or the
    rosbags fallback when that back end does not support this bag.

    checked=True: the bag is opened so that rosbags reads every storage file's index (it counts a sqlite3
    database with a full scan), so that a damaged bag is refused before anything is reported or played.
    Raises InputError if the bag is missing or unreadable, or its metadata.yaml names a storage file
    outside the bag folder. Close it (or use it in a `with`).
    """
    path = Path(path)
    check_bag_file_paths(path)          # no storage file outside the bag folder
    backend = BACKENDS.get(storage_identifier(path))
    if backend is not None:
        storage = backend.open(path, checked=checked)
        if storage is not NOT_SUPPORTED:
            return storage
    return FALLBACK.open(path, checked=checked)


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
