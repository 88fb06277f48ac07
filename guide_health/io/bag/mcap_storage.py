"""The mcap back end: topics, counts and `iter_batches` through rosbags (as the fallback), and `iter_packed`
for a single uncompressed-container mcap file read chunk by chunk into packed batches, instead of a Python
record per message (NOT_SUPPORTED for a split or compressed bag: then iter_batches).

The summary section (footer -> summary start) gives the channels and one ChunkIndex per chunk (mcap
specification, https://mcap.dev/spec: Chunk 0x06, MessageIndex 0x07, ChunkIndex 0x08, Channel 0x04, Schema
0x03). A chunk is decompressed whole ('' / zstd / lz4, the compressions rosbags reads, with the same
libraries), and the offsets of its messages come from its MessageIndex records, read with numpy (16-byte
(log_time, offset) entries); a chunk without message indexes is scanned record by record. Each message
record (opcode 0x05: channel u16, sequence u32, log_time u64, publish_time u64, data) is checked against its
index entry (opcode, channel, log time, length inside the chunk) and its data are handed on in place.

Order: rosbags sorts each chunk's messages by log time (stable, i.e. file order for ties) and merges chunks
by (log time, chunk offset). Chunks in file order whose time ranges do not overlap (each ends no later than
the next begins) give that order when each chunk is sorted by (log time, offset), which is done here;
`iter_mcap_packed` returns NOT_SUPPORTED otherwise, and for files without a summary/chunk index, so that the
caller reads through rosbags.
"""
from __future__ import annotations

import struct
import sys
import zlib
from collections.abc import Collection, Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...errors import InputError
from .metadata import bag_yaml, one_line
from .protocol import NOT_SUPPORTED, BagConnection, PackedBatch
from .rosbags_storage import RosbagsStorage

MAGIC = b"\x89MCAP0\r\n"
_FOOTER = 37                        # opcode, length, summary start, summary offset start, crc, magic
_U16, _U32, _U64 = struct.Struct("<H"), struct.Struct("<I"), struct.Struct("<Q")


class ChunkIndex(NamedTuple):
    """One ChunkIndex record (0x08) of the summary."""

    start_ns: int
    end_ns: int
    offset: int                     # of the chunk record in the file
    length: int                     # of the chunk record
    index_offsets: dict             # channel id -> file offset of its MessageIndex record
    index_length: int               # bytes of the message index records after the chunk
    compression: str


def _string(buf: bytes, pos: int) -> tuple[str, int]:
    n = _U32.unpack_from(buf, pos)[0]
    return bytes(buf[pos + 4:pos + 4 + n]).decode(), pos + 4 + n


def read_summary(f) -> tuple[dict, list[ChunkIndex]] | None:
    """({channel id: (topic, schema name)}, chunk indexes in file order) of an open mcap file, or None
    when it has no summary or no chunk index."""
    f.seek(0, 2)
    size = f.tell()
    if size < 8 + _FOOTER:
        return None
    f.seek(size - _FOOTER)
    footer = f.read(_FOOTER)
    if footer[-8:] != MAGIC or footer[0] != 0x02:
        raise ValueError("invalid mcap footer")
    start = _U64.unpack_from(footer, 9)[0]
    if not start:
        return None
    if not 8 <= start <= size - _FOOTER:
        raise ValueError("invalid mcap summary offset")
    f.seek(start)
    summary = f.read(size - _FOOTER - start)
    schemas, channels, chunks = {}, {}, []
    pos = 0
    while pos + 9 <= len(summary):
        op, length = summary[pos], _U64.unpack_from(summary, pos + 1)[0]
        body = pos + 9
        if op == 0x03:
            schemas[_U16.unpack_from(summary, body)[0]] = _string(summary, body + 2)[0]
        elif op == 0x04:
            cid, sid = _U16.unpack_from(summary, body)[0], _U16.unpack_from(summary, body + 2)[0]
            channels[cid] = (_string(summary, body + 4)[0], sid)
        elif op == 0x08:
            chunks.append(_chunk_index(summary, body))
        pos = body + length
    if not chunks:
        return None
    named = {cid: (topic, schemas.get(sid, "")) for cid, (topic, sid) in channels.items()}
    return named, sorted(chunks, key=lambda c: c.offset)


def _chunk_index(buf: bytes, pos: int) -> ChunkIndex:
    start_ns, end_ns, offset, length = struct.unpack_from("<QQQQ", buf, pos)
    n = _U32.unpack_from(buf, pos + 32)[0]
    pairs = struct.iter_unpack("<HQ", buf[pos + 36:pos + 36 + n])
    index_length = _U64.unpack_from(buf, pos + 36 + n)[0]
    compression = _string(buf, pos + 44 + n)[0]
    return ChunkIndex(start_ns, end_ns, offset, length, dict(pairs), index_length, compression)


def _decompress(data, compression: str, size: int) -> bytes:
    if compression == "":
        return bytes(data)
    if compression == "zstd":
        if sys.version_info >= (3, 14):  # pragma: no cover
            from compression import zstd
        else:
            from backports import zstd
        return zstd.decompress(data)
    if compression == "lz4":
        from lz4.frame import decompress
        return decompress(data)
    raise ValueError(f"unsupported chunk compression {compression!r}")


def _chunk_records(f, ci: ChunkIndex) -> np.ndarray:
    """The decompressed records of a chunk as uint8 (size and CRC checked)."""
    f.seek(ci.offset)
    rec = f.read(ci.length)
    if len(rec) != ci.length or rec[0] != 0x06:
        raise ValueError("chunk index points at no chunk")
    uncompressed, crc = _U64.unpack_from(rec, 25)[0], _U32.unpack_from(rec, 33)[0]
    compression, pos = _string(rec, 37)
    n = _U64.unpack_from(rec, pos)[0]
    raw = _decompress(memoryview(rec)[pos + 8:pos + 8 + n], compression, uncompressed)
    if len(raw) != uncompressed or (crc and zlib.crc32(raw) != crc):
        raise ValueError("chunk size or checksum mismatch")
    return np.frombuffer(raw, np.uint8)


def _indexed_messages(f, ci: ChunkIndex, wanted: set) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(channel, log time, record offset) of the wanted channels' messages, from the MessageIndex records."""
    base = ci.offset + ci.length
    f.seek(base)
    region = f.read(ci.index_length)
    parts = []
    for cid, off in ci.index_offsets.items():
        if cid not in wanted:
            continue
        rel = off - base
        if region[rel] != 0x07 or _U16.unpack_from(region, rel + 9)[0] != cid:
            raise ValueError("bad message index record")
        count = _U32.unpack_from(region, rel + 11)[0] // 16
        entries = np.frombuffer(region, "<u8", count=2 * count, offset=rel + 15).reshape(count, 2)
        parts.append((np.full(count, cid, np.int64), entries[:, 0].astype(np.int64), entries[:, 1].astype(np.int64)))
    if not parts:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64)
    return tuple(np.concatenate(col) for col in zip(*parts))


def _scanned_messages(records: np.ndarray, wanted: set) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The same by walking the chunk's records one by one (a chunk without message indexes)."""
    raw = records.tobytes()
    got = []
    pos = 0
    while pos + 9 <= len(raw):
        length = _U64.unpack_from(raw, pos + 1)[0]
        if raw[pos] == 0x05:
            cid = _U16.unpack_from(raw, pos + 9)[0]
            if cid in wanted:
                got.append((cid, _U64.unpack_from(raw, pos + 15)[0], pos))
        pos += 9 + length
    cols = np.array(got, np.int64).reshape(-1, 3)
    return cols[:, 0], cols[:, 1], cols[:, 2]


def _u64_at(records: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    return np.lib.stride_tricks.sliding_window_view(records, 8)[offsets].copy().view("<u8").reshape(-1)


def _chunk_batch(records: np.ndarray, channel: np.ndarray, log_ns: np.ndarray, rec_off: np.ndarray,
                 conn_of: dict) -> PackedBatch:
    """The chunk's wanted messages in (log time, offset) order; ValueError if a record disagrees with its
    index entry."""
    order = np.lexsort((rec_off, log_ns))
    channel, log_ns, rec_off = channel[order], log_ns[order], rec_off[order]
    size = records.size
    if rec_off.size and (rec_off.min() < 0 or rec_off.max() + 31 > size):
        raise ValueError("message index offset outside its chunk")
    length = _u64_at(records, rec_off + 1).astype(np.int64)
    head = np.lib.stride_tricks.sliding_window_view(records, 1)[rec_off, 0]
    chan = np.lib.stride_tricks.sliding_window_view(records, 2)[rec_off + 9].copy().view("<u2").reshape(-1)
    stamp = _u64_at(records, rec_off + 15).astype(np.int64)
    if ((head != 0x05) | (chan != channel) | (stamp != log_ns) | (length < 22)
            | (rec_off + 9 + length > size)).any():
        raise ValueError("message record does not match its index")
    ids = np.array([conn_of.get(c, -1) for c in range(int(channel.max()) + 1)] if channel.size else [], np.int64)
    return PackedBatch(ids[channel] if channel.size else channel, log_ns, records, rec_off + 31, length - 22)


def _take(batch: PackedBatch, lo: int, hi: int) -> PackedBatch:
    return PackedBatch(batch.connection_ids[lo:hi], batch.log_time_ns[lo:hi], batch.buf, batch.offsets[lo:hi],
                       batch.lengths[lo:hi])


def iter_mcap_packed(path: Path, connections, chunk_messages: int) -> Iterator[list[PackedBatch]] | None:
    """Groups of packed batches (one per chunk or part of a chunk: no copy) of exactly `chunk_messages`
    messages together (the last group may have fewer) of `connections`
    (BagConnection, matched to channels by topic and type) in log-time order; NOT_SUPPORTED when the file has no
    chunk index, its chunks overlap in time or a channel matches several connections. Read errors raise
    InputError (after the batches read before them)."""
    try:
        f = open(path, "rb")   # noqa: SIM115 - closed by the generator (or below)
        summary = read_summary(f)
    except (OSError, ValueError, struct.error, IndexError) as exc:
        raise InputError(f"corrupt bag {path}: {one_line(exc)}") from None
    if summary is None:
        f.close()
        return NOT_SUPPORTED
    channels, chunks = summary
    conn_of = {}
    for cid, (topic, msgtype) in channels.items():
        match = [c.id for c in connections if c.topic == topic and c.msgtype == msgtype]
        if len(match) > 1:
            f.close()
            return NOT_SUPPORTED
        conn_of[cid] = match[0] if match else -1
    if any(b.start_ns < a.end_ns for a, b in zip(chunks, chunks[1:])):
        f.close()
        return NOT_SUPPORTED
    wanted = {cid for cid, conn in conn_of.items() if conn >= 0}
    table = {cid: conn_of.get(cid, -1) for cid in range(max(channels, default=0) + 1)}
    return _iter_chunks(f, path, chunks, wanted, table, max(1, int(chunk_messages)))


def _iter_chunks(f, path, chunks, wanted: set, conn_of: dict, step: int) -> Iterator[list[PackedBatch]]:
    pending: list[PackedBatch] = []
    count = 0
    with f:
        for ci in chunks:
            if not wanted.intersection(ci.index_offsets) and ci.index_offsets:
                continue
            try:
                records = _chunk_records(f, ci)
                cols = (_indexed_messages(f, ci, wanted) if ci.index_offsets
                        else _scanned_messages(records, wanted))
                batch = _chunk_batch(records, *cols, conn_of)
            except (OSError, ValueError, struct.error, IndexError, RuntimeError) as exc:
                raise InputError(f"corrupt bag {path}: {one_line(exc)}") from None
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


class McapStorage(RosbagsStorage):
    """An mcap bag (directory or bare .mcap file): rosbags for topics, counts and iter_batches (see
    protocol.BagStorage), the chunk reader above for iter_packed."""

    @classmethod
    def open(cls, path: Path, checked: bool = False) -> McapStorage:
        """The storage of the mcap bag at `path` (rosbags reads every chunk index on open: always checked)."""
        return cls(path)

    def iter_packed(self, connections: Collection[BagConnection],
                    chunk_messages: int) -> Iterator[list[PackedBatch]] | None:
        """Packed batches of a single uncompressed-container mcap file read chunk by chunk
        (iter_mcap_packed); NOT_SUPPORTED for a split or compressed bag (then iter_batches through rosbags)."""
        file = self.path
        if self.path.is_dir():
            info = bag_yaml(self.path)
            files = info.get("relative_file_paths") or []
            if (info.get("storage_identifier") != "mcap" or len(files) != 1 or info.get("compression_format")
                    or info.get("compression_mode") not in (None, "", "none", "NONE")):
                return NOT_SUPPORTED
            file = self.path / files[0]
        if file.suffix != ".mcap" or not connections:
            return NOT_SUPPORTED
        return iter_mcap_packed(file, list(connections), chunk_messages)
