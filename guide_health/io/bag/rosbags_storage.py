"""The fallback back end: any bag rosbags reads (split or compressed bags, a bare .db3 file, any bag opened
checked), through rosbags.rosbag2.Reader. Packed reading is not supported (`iter_packed` -> NOT_SUPPORTED)."""
from __future__ import annotations

import operator
from collections.abc import Collection, Iterator
from pathlib import Path

from ...errors import InputError
from .metadata import one_line
from .protocol import NOT_SUPPORTED, READ_ERRORS, BagConnection, PackedBatch, RawBatch, raw_batches


class RosbagsStorage:
    """Any bag rosbags reads, through rosbags.rosbag2.Reader (see protocol.BagStorage)."""

    def __init__(self, path: Path):
        from rosbags.rosbag2 import Reader

        self.path = Path(path)
        if not self.path.exists():
            raise InputError(f"bag not found: {self.path}")
        try:
            reader = Reader(self.path)
            reader.open()
        except READ_ERRORS as exc:
            raise InputError(f"not a readable rosbag2 bag: {self.path}: {one_line(exc)}") from None
        self._reader = reader
        self._rosbags_connection = {c.id: c for c in reader.connections}
        self.connections = [BagConnection(c.id, c.topic, c.msgtype, int(c.msgcount))
                            for c in reader.connections]
        self.message_count = int(reader.message_count)
        self.start_ns = int(reader.start_time)
        self.end_ns = int(reader.end_time)

    @classmethod
    def open(cls, path: Path, checked: bool = False) -> RosbagsStorage:
        """The storage of the bag at `path` (rosbags' open always reads every storage file's index, so a
        checked open is the same)."""
        return cls(path)

    def iter_batches(self, connections: Collection[BagConnection], chunk_messages: int,
                     start_ns: int | None = None) -> Iterator[RawBatch]:
        wanted = [self._rosbags_connection[c.id] for c in connections]
        if not wanted:                   # rosbags reads every topic when given no connections
            return iter(())
        rows = self._reader.messages(connections=wanted, start=start_ns)
        return raw_batches(rows, chunk_messages, self.path, operator.attrgetter("id"))

    def iter_packed(self, connections: Collection[BagConnection],
                    chunk_messages: int) -> Iterator[list[PackedBatch]] | None:
        """NOT_SUPPORTED: rosbags yields one record per message."""
        return NOT_SUPPORTED

    def close(self) -> None:
        try:
            self._reader.close()
        except Exception:  # noqa: BLE001 - closing a broken reader must not hide the real error
            pass

    def __enter__(self) -> RosbagsStorage:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
