"""A sqlite3 bag split into several storage files (``ros2 bag record --max-bag-size``: one metadata.yaml,
N .db3 files) read on the sqlite3 fast path: each file is a `Sqlite3Storage`, and the files are chained in
the order metadata.yaml lists them (chained_storage.ChainedStorage: a topic's ids of every file become one
connection, and the batches run on across the files in the windows one file of the same rows is read in, so
the result is the unsplit bag's to the last bit).

The chain is used only when it is the log-time order: every file's first message no earlier than the
previous file's last (rosbag2 writes the files one after the other). Files that overlap in time, a file
without its ``files[].message_count`` in metadata.yaml or one that does not open are NOT_SUPPORTED: the
rosbags fallback merges such files by time. The per-topic counts are metadata.yaml's totals (the files have
none of their own); the reader checks the rows it read against them as for one file.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

from ...errors import InputError
from .chained_storage import ChainedStorage
from .protocol import NOT_SUPPORTED, BagConnection


def _file_counts(info: dict, files: list) -> list[int] | None:
    """files[].message_count of each storage file (by name), or None when one is missing."""
    by_name = {}
    for entry in info.get("files") or []:
        try:
            by_name[Path(str(entry["path"])).name] = int(entry["message_count"])
        except (KeyError, TypeError, ValueError):
            return None
    counts = [by_name.get(Path(str(name)).name) for name in files]
    return None if any(n is None for n in counts) else counts


def open_split(storage_class, path: Path, info: dict, files: list, topic_counts: dict):
    """The split bag at ``path`` as one chained storage of ``storage_class`` (Sqlite3Storage) files, or
    NOT_SUPPORTED (see the module text)."""
    import apsw

    file_counts = _file_counts(info, files)
    if file_counts is None:
        return NOT_SUPPORTED
    storages = []
    try:
        for name, count in zip(files, file_counts):
            db_path = path / name
            if not db_path.is_file():
                return NOT_SUPPORTED
            db = apsw.Connection(str(db_path), flags=apsw.SQLITE_OPEN_READONLY)
            storages.append(storage_class(db_path, db, [
                BagConnection(int(tid), topic, msgtype, 0)
                for tid, topic, msgtype in db.execute("SELECT id, name, type FROM topics ORDER BY id")]))
            storages[-1].message_count = count
        if not _in_time_order(storages):
            raise LookupError("storage files overlap in time")
    except (apsw.Error, LookupError, InputError):      # the fallback reads it, or says what is wrong
        for storage in storages:
            storage.close()
        return NOT_SUPPORTED
    chained = ChainedStorage(storages, path)
    if any(c.topic not in topic_counts for c in chained.connections):
        chained.close()
        return NOT_SUPPORTED
    chained.connections = [dataclasses.replace(c, msgcount=topic_counts[c.topic]) for c in chained.connections]
    chained.message_count = sum(c.msgcount for c in chained.connections)
    return chained


def _in_time_order(storages) -> bool:
    """Every non-empty file starts no earlier than the previous non-empty one's last message."""
    last_ns = None
    for storage in storages:
        if not storage.message_count:
            continue
        if last_ns is not None and storage.start_ns < last_ns:
            return False
        last_ns = storage.end_ns - 1
    return True
