"""The read limit of a rosbag2 bag for the offline benchmarks: the least work that touches every message.

* sqlite3 storage: the stdlib ``sqlite3`` module, ``SELECT data FROM messages`` over every ``.db3`` file of
  the bag, each row fetched (``fetchmany``) and counted, nothing decoded;
* mcap storage: a minimal record scan of every ``.mcap`` file (mmap): top-level records by opcode and
  length, each Chunk decompressed ('' / zstd / lz4) and its Message records counted, nothing decoded.

Both count every message of the bag, so a benchmark's ratio to this limit is over the same messages.
"""
from __future__ import annotations

import mmap
import sqlite3
import struct
import time
from pathlib import Path

MCAP_MAGIC = b"\x89MCAP0\r\n"
OP_FOOTER, OP_MESSAGE, OP_CHUNK, OP_DATA_END = 0x02, 0x05, 0x06, 0x0F


def sqlite3_read_limit(bag: Path) -> tuple[int, float]:
    """(messages, seconds) of ``SELECT data FROM messages`` over every .db3 file of the bag."""
    files = sorted(Path(bag).glob("*.db3"))
    t0 = time.perf_counter()
    n = 0
    for path in files:
        db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
        cur = db.execute("SELECT data FROM messages")
        while True:
            rows = cur.fetchmany(10_000)
            if not rows:
                break
            n += len(rows)
        db.close()
    return n, time.perf_counter() - t0


def _decompress(compression: str, data, size: int) -> bytes:
    if compression == "":
        return data
    if compression == "zstd":
        import zstandard

        return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    if compression == "lz4":
        import lz4.frame

        return lz4.frame.decompress(data)
    raise ValueError(f"unknown mcap chunk compression {compression!r}")


def _count_messages(buf, start: int, end: int) -> int:
    """Message records in buf[start:end] (a chunk's records or the top level)."""
    n = 0
    pos = start
    unpack = struct.unpack_from
    while pos + 9 <= end:
        op, length = unpack("<BQ", buf, pos)
        if op == OP_MESSAGE:
            n += 1
        pos += 9 + length
    return n


def mcap_chunk_scan(bag: Path) -> tuple[int, float]:
    """(messages, seconds) of a minimal record scan of every .mcap file, chunks decompressed."""
    files = sorted(Path(bag).glob("*.mcap"))
    t0 = time.perf_counter()
    n = 0
    for path in files:
        with open(path, "rb") as handle, mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ) as buf:
            if buf[:8] != MCAP_MAGIC:
                raise ValueError(f"{path}: not an mcap file")
            pos, end = 8, len(buf)
            while pos + 9 <= end:
                op, length = struct.unpack_from("<BQ", buf, pos)
                body = pos + 9
                if op == OP_CHUNK:
                    # start u64, end u64, uncompressed size u64, crc u32, compression str, records u64 + bytes
                    size = struct.unpack_from("<Q", buf, body + 16)[0]
                    clen = struct.unpack_from("<I", buf, body + 28)[0]
                    compression = bytes(buf[body + 32:body + 32 + clen]).decode()
                    rec = body + 32 + clen
                    rlen = struct.unpack_from("<Q", buf, rec)[0]
                    data = _decompress(compression, memoryview(buf)[rec + 8:rec + 8 + rlen], size)
                    n += _count_messages(data, 0, len(data))
                    if isinstance(data, memoryview):
                        data.release()
                elif op == OP_MESSAGE:
                    n += 1
                elif op in (OP_DATA_END, OP_FOOTER):
                    break
                pos = body + length
    return n, time.perf_counter() - t0


def storage_of(bag: Path) -> str:
    bag = Path(bag)
    if any(bag.glob("*.mcap")):
        return "mcap"
    if any(bag.glob("*.db3")):
        return "sqlite3"
    raise ValueError(f"{bag}: neither .db3 nor .mcap files")


def read_limit(bag: Path) -> tuple[int, float, str]:
    """(messages, seconds, what) of the bag's read limit (module docstring)."""
    if storage_of(bag) == "mcap":
        n, t = mcap_chunk_scan(bag)
        return n, t, "mcap chunk scan"
    n, t = sqlite3_read_limit(bag)
    return n, t, "stdlib sqlite3 SELECT data"
