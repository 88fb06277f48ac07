"""The records of an mcap file (specification https://mcap.dev/spec), read without relying on its indexes.

`scan_file` walks every top-level record from the magic to the footer (or the end of the file): Header 0x01,
Footer 0x02, Schema 0x03, Channel 0x04, Message 0x05 (unchunked), Chunk 0x06, MessageIndex 0x07, Statistics
0x0B; everything else is stepped over by its length. Every Chunk becomes a `Segment`, and so does every run of
consecutive unchunked Message records, so that a file is read whole whatever its writer left out: no summary,
no chunk index, no message index, no statistics, no chunking. A chunk's message indexes, where written, are
the MessageIndex records right after it; they only locate messages faster (16-byte (log_time, offset)
entries read with numpy), and each entry is checked against the record it points at. A chunk without them is
walked record by record (`scan_records`), which also finds the Schema and Channel records that writers put
inside chunks.

Records are little-endian; a string is a u32 length and UTF-8 bytes. A chunk is decompressed whole ('' /
zstd / lz4), its size and CRC-32 checked.
"""
from __future__ import annotations

import struct
import sys
import zlib
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

MAGIC = b"\x89MCAP0\r\n"
OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK, OP_MESSAGE_INDEX, OP_STATISTICS = (
    0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x0B)
MESSAGE_HEAD = 22                   # channel u16, sequence u32, log_time u64, publish_time u64
_U16, _U32, _U64 = struct.Struct("<H"), struct.Struct("<I"), struct.Struct("<Q")
_CHUNK_HEAD = struct.Struct("<QQQI")  # message start, message end, uncompressed size, uncompressed CRC
_STATISTICS = struct.Struct("<QHIIIIQQ")
#: compressions of a chunk that this reader decompresses (the ones rosbag2 writes)
COMPRESSIONS = ("", "zstd", "lz4")


class Segment(NamedTuple):
    """Message records read as one: a Chunk record, or a run of consecutive unchunked Message records."""

    file: int                       # index of the storage file in the bag
    offset: int                     # of the chunk record / of the first message record in the file
    length: int                     # of the chunk record / of the region up to the end of the last message
    start_ns: int                   # log time of the first message
    end_ns: int                     # log time of the last message (inclusive, as a chunk header states it)
    compression: str | None         # the chunk's compression; None: unchunked records
    index: dict                     # channel id -> file offset of its MessageIndex record ({}: none)


@dataclass
class FileLayout:
    """What the top-level records of one mcap file say."""

    schemas: dict = field(default_factory=dict)        # schema id -> schema name (message type)
    channels: dict = field(default_factory=dict)       # channel id -> (topic, schema id)
    segments: list = field(default_factory=list)       # Segment, in file order
    counts: dict | None = None      # Statistics: channel id -> message count (None: no Statistics record)
    time_range: tuple | None = None  # Statistics: (first, last) log time [ns]

    def add_definition(self, op: int, buf, body: int) -> None:
        """Record a Schema or Channel record whose body starts at `body` in `buf`."""
        if op == OP_SCHEMA:
            self.schemas[_U16.unpack_from(buf, body)[0]] = _string(buf, body + 2)[0]
        else:
            cid, sid = _U16.unpack_from(buf, body)[0], _U16.unpack_from(buf, body + 2)[0]
            self.channels[cid] = (_string(buf, body + 4)[0], sid)

    def channel_type(self, cid: int) -> tuple[str, str]:
        """(topic, message type) of a channel; ValueError for a channel no Channel record defines."""
        if cid not in self.channels:
            raise ValueError(f"message on channel {cid}, which no channel record defines")
        topic, sid = self.channels[cid]
        return topic, self.schemas.get(sid, "")


def _string(buf, pos: int) -> tuple[str, int]:
    n = _U32.unpack_from(buf, pos)[0]
    if pos + 4 + n > len(buf):
        raise ValueError("string runs past its record")
    return bytes(buf[pos + 4:pos + 4 + n]).decode(), pos + 4 + n


def _statistics(layout: FileLayout, buf, body: int) -> None:
    """Statistics (0x0B): counts, time range and channel_message_counts (u32 bytes of (u16, u64) pairs)."""
    fields = _STATISTICS.unpack_from(buf, body)
    n = _U32.unpack_from(buf, body + _STATISTICS.size)[0]
    start = body + _STATISTICS.size + 4
    layout.counts = dict(struct.iter_unpack("<HQ", bytes(buf[start:start + n])))
    layout.time_range = (fields[6], fields[7]) if fields[0] else None


def scan_file(buf, file: int = 0) -> FileLayout:
    """The layout of the mcap file in `buf` (bytes or mmap): every top-level record, in file order.
    ValueError for a file that is not mcap or whose records run past its end (a truncated file)."""
    size = len(buf)
    if size < len(MAGIC) or buf[:len(MAGIC)] != MAGIC:
        raise ValueError("not an mcap file (no magic)")
    layout = FileLayout()
    run: list | None = None                 # the open run of unchunked messages: [offset, end, t_min, t_max]
    pos = len(MAGIC)
    while pos < size:
        if pos + 9 > size:
            raise ValueError(f"truncated record at byte {pos}")
        op, length = buf[pos], _U64.unpack_from(buf, pos + 1)[0]
        body, end = pos + 9, pos + 9 + length
        if end > size:
            raise ValueError(f"record at byte {pos} runs past the end of the file (truncated)")
        if op == OP_MESSAGE:
            if length < MESSAGE_HEAD:
                raise ValueError(f"message record at byte {pos} shorter than its header")
            t = _U64.unpack_from(buf, body + 6)[0]
            run = [pos, end, t, t] if run is None else [run[0], end, min(run[2], t), max(run[3], t)]
        elif op in (OP_SCHEMA, OP_CHANNEL):
            layout.add_definition(op, buf, body)
        else:
            if run is not None:
                layout.segments.append(Segment(file, run[0], run[1] - run[0], run[2], run[3], None, {}))
                run = None
            if op == OP_CHUNK:
                start_ns, end_ns = _CHUNK_HEAD.unpack_from(buf, body)[:2]
                compression = _string(buf, body + _CHUNK_HEAD.size)[0]
                layout.segments.append(Segment(file, pos, end - pos, start_ns, end_ns, compression, {}))
            elif op == OP_MESSAGE_INDEX and layout.segments and layout.segments[-1].compression is not None:
                layout.segments[-1].index[_U16.unpack_from(buf, body)[0]] = pos
            elif op == OP_STATISTICS:
                _statistics(layout, buf, body)
            elif op == OP_FOOTER:
                break
        pos = end
    if run is not None:
        layout.segments.append(Segment(file, run[0], run[1] - run[0], run[2], run[3], None, {}))
    return layout


def _decompress(data, compression: str) -> bytes:
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
    raise ValueError(f"chunk compression {compression!r} is not readable (readable: none, zstd, lz4)")


def segment_records(buf, seg: Segment) -> np.ndarray:
    """The records of a segment as uint8: a chunk decompressed (size and CRC checked), unchunked records
    copied out of the file."""
    if seg.compression is None:
        return np.frombuffer(buf, np.uint8, count=seg.length, offset=seg.offset).copy()
    body = seg.offset + 9
    uncompressed, crc = _CHUNK_HEAD.unpack_from(buf, body)[2:]
    pos = _string(buf, body + _CHUNK_HEAD.size)[1]
    n = _U64.unpack_from(buf, pos)[0]
    if pos + 8 + n > seg.offset + seg.length:
        raise ValueError(f"chunk at byte {seg.offset}: compressed data run past the chunk record")
    raw = _decompress(memoryview(buf)[pos + 8:pos + 8 + n], seg.compression)
    if len(raw) != uncompressed or (crc and zlib.crc32(raw) != crc):
        raise ValueError(f"chunk at byte {seg.offset}: size or checksum mismatch")
    return np.frombuffer(raw, np.uint8)


def scan_records(records: np.ndarray, wanted, layout: FileLayout | None = None) -> tuple:
    """(channel, log time, record offset) int64 columns of the Message records among `records` whose channel
    is in `wanted` (None: every channel), walking the records one by one; Schema and Channel records found
    on the way are added to `layout` (when given)."""
    raw = records.tobytes()
    size = len(raw)
    got = []
    pos = 0
    while pos < size:
        if pos + 9 > size:
            raise ValueError("truncated record inside a chunk")
        op, length = raw[pos], _U64.unpack_from(raw, pos + 1)[0]
        if pos + 9 + length > size:
            raise ValueError("record runs past the end of its chunk")
        if op == OP_MESSAGE:
            if length < MESSAGE_HEAD:
                raise ValueError("message record shorter than its header")
            cid = _U16.unpack_from(raw, pos + 9)[0]
            if wanted is None or cid in wanted:
                got.append((cid, _U64.unpack_from(raw, pos + 15)[0], pos))
        elif op in (OP_SCHEMA, OP_CHANNEL) and layout is not None:
            layout.add_definition(op, raw, pos + 9)
        pos += 9 + length
    cols = np.array(got, np.int64).reshape(-1, 3)
    return cols[:, 0], cols[:, 1], cols[:, 2]


def indexed_messages(buf, seg: Segment, wanted) -> tuple:
    """The same columns from the chunk's MessageIndex records (channel u16, u32 bytes of (log time u64,
    offset u64) entries) for the wanted channels."""
    parts = []
    for cid, off in seg.index.items():
        if cid not in wanted:
            continue
        if buf[off] != OP_MESSAGE_INDEX or _U16.unpack_from(buf, off + 9)[0] != cid:
            raise ValueError(f"bad message index record at byte {off}")
        count = _U32.unpack_from(buf, off + 11)[0] // 16
        if off + 15 + 16 * count > len(buf):
            raise ValueError(f"message index record at byte {off} runs past the end of the file")
        entries = np.frombuffer(buf, "<u8", count=2 * count, offset=off + 15).reshape(count, 2).astype(np.int64)
        parts.append((np.full(count, cid, np.int64), entries[:, 0], entries[:, 1]))
    if not parts:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64)
    return tuple(np.concatenate(col) for col in zip(*parts))


def segment_messages(buf, seg: Segment, records: np.ndarray, wanted) -> tuple:
    """(channel, log time, record offset in `records`) of the wanted channels' messages of a segment: from
    its message indexes where the chunk has them, else by walking its records."""
    if seg.index:
        return indexed_messages(buf, seg, wanted)
    return scan_records(records, wanted)


def _u64_at(records: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    return np.lib.stride_tricks.sliding_window_view(records, 8)[offsets].copy().view("<u8").reshape(-1)


def check_messages(records: np.ndarray, channel: np.ndarray, log_ns: np.ndarray,
                   rec_off: np.ndarray) -> np.ndarray:
    """The data lengths of the message records at `rec_off`; ValueError where a record is not the Message
    of that channel and log time (an index entry that points elsewhere) or runs past `records`."""
    size = records.size
    if rec_off.size == 0:
        return np.zeros(0, np.int64)
    if rec_off.min() < 0 or rec_off.max() + 9 + MESSAGE_HEAD > size:
        raise ValueError("message index offset outside its chunk")
    length = _u64_at(records, rec_off + 1).astype(np.int64)
    head = records[rec_off]
    chan = np.lib.stride_tricks.sliding_window_view(records, 2)[rec_off + 9].copy().view("<u2").reshape(-1)
    stamp = _u64_at(records, rec_off + 15).astype(np.int64)
    if ((head != OP_MESSAGE) | (chan != channel) | (stamp != log_ns) | (length < MESSAGE_HEAD)
            | (rec_off + 9 + length > size)).any():
        raise ValueError("message record does not match its index")
    return length - MESSAGE_HEAD
