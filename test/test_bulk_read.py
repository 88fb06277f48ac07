"""Bulk bag reading (issue 14): packed sqlite3 batches in rowid order, the order check and its fallback,
the packed CDR decoder, and the mcap chunk reader. Every result is compared with an independent path:
the per-message `ORDER BY timestamp` read (the previous reader), rosbags' own Reader, or the original run.
"""
from __future__ import annotations

import json
import sqlite3
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from guide_health.io.bag import cdr, sqlite3_storage, storage
from guide_health.io.bag import reader as bag_reader
from guide_health.io.bag import writer as bag_writer
from guide_health.io.bag.interfaces import JOINT_STATE, WRENCH_STAMPED
from guide_health.io.bag.sqlite3_storage import iter_sqlite_packed
from guide_health.runs import MachineRun

T0 = 1_700_000_000_123_456_789
ARRAYS = ("joint_t_ns", "joint_position_m", "joint_velocity_m_s", "load_t_ns", "load_n",
          "straightness_t_ns", "straightness_m", "temperature_t_ns", "temperature_c")


def make_run(n: int = 3000, seed: int = 5) -> MachineRun:
    """1 kHz joint states, 100 Hz load, 10 Hz temperature, a measurement every 0.5 s (seeded)."""
    rng = np.random.default_rng(seed)
    t = T0 + np.arange(n, dtype=np.int64) * 1_000_000
    pos = 0.2 * np.sin(np.arange(n) * 2e-3) + rng.normal(0, 1e-6, n)
    tl, ts, tt = t[::10] + 17, t[::500] + 3, t[::100]
    return MachineRun(joint_name="x", joint_t_ns=t, joint_position_m=pos, joint_velocity_m_s=np.gradient(pos, 1e-3),
                      load_t_ns=tl, load_n=1500.0 + rng.normal(0, 50, tl.size), straightness_t_ns=ts,
                      straightness_m=15e-6 + 1e-7 * np.arange(ts.size), temperature_t_ns=tt,
                      temperature_c=21.0 + 0.01 * np.arange(tt.size), metadata={"seed": seed})


def assert_runs_equal(got: MachineRun, want: MachineRun) -> None:
    for name in ARRAYS:
        a, b = getattr(got, name), getattr(want, name)
        assert a.dtype == b.dtype or (a.size == 0 and b.size == 0), name
        np.testing.assert_array_equal(a, b, err_msg=name)   # exact, bit for bit


def _db(bag: Path) -> Path:
    return next(bag.glob("*.db3"))


def _renumber(bag: Path, order_of_rows) -> None:
    """Rewrite the messages table so that the rows (taken in rowid order) get new rowids: row k becomes
    rowid 1 + position of k in `order_of_rows(n)` (the content and the timestamps are unchanged)."""
    con = sqlite3.connect(_db(bag))
    rows = con.execute("SELECT topic_id, timestamp, data FROM messages ORDER BY id").fetchall()
    perm = np.asarray(order_of_rows(len(rows)))
    con.execute("DELETE FROM messages")
    con.executemany("INSERT INTO messages (id, topic_id, timestamp, data) VALUES (?, ?, ?, ?)",
                    [(pos + 1, *rows[k]) for pos, k in enumerate(perm.tolist())])
    con.commit()
    con.close()


def _ordered_read(bag: Path, monkeypatch, **kw) -> MachineRun:
    """The previous reader: per-message rows ORDER BY timestamp (the packed path switched off)."""
    with monkeypatch.context() as m:
        m.setattr(sqlite3_storage.Sqlite3Storage, "iter_packed", lambda *a: None)
        return bag_reader.read_machine_bag(bag, **kw)


def _rosbags_read(bag: Path) -> MachineRun:
    """rosbags' Reader (open_storage(checked=True)) as the independent reference."""
    real = storage.open_storage
    try:
        storage.open_storage = lambda path, checked=False: real(path, checked=True)
        bag_reader.open_storage = storage.open_storage
        return bag_reader.read_machine_bag(bag)
    finally:
        storage.open_storage = real
        bag_reader.open_storage = real


def _uses_packed(bag: Path, chunk: int) -> bool:
    with storage.open_storage(bag) as st:
        return iter_sqlite_packed(st._db, bag, tuple(c.id for c in st.connections), chunk) is not None


def _read_watching_fallback(bag: Path, chunk: int, monkeypatch) -> tuple[MachineRun, list]:
    """read_machine_bag, and the rowids from which the bulk reader fell back to ORDER BY timestamp."""
    starts = []
    real = sqlite3_storage._RangeReader.ordered_from

    def spy(self, start, step):
        starts.append(start)
        return real(self, start, step)
    with monkeypatch.context() as m:
        m.setattr(sqlite3_storage._RangeReader, "ordered_from", spy)
        return bag_reader.read_machine_bag(bag, chunk_messages=chunk), starts


def test_packed_sqlite_read_equals_ordered_read(tmp_path, monkeypatch):
    run = make_run()
    bag = bag_writer.write_machine_bag(run, tmp_path / "bag", "sqlite3")
    for chunk in (1, 700, 200_000):
        got, fallback = _read_watching_fallback(bag, chunk, monkeypatch)
        assert_runs_equal(got, run)
        assert fallback == []
    try:                                        # without the read-ahead thread (fleet workers on full cores)
        sqlite3_storage.set_read_ahead(False)
        for chunk in (1, 700):
            assert_runs_equal(bag_reader.read_machine_bag(bag, chunk_messages=chunk), run)
    finally:
        sqlite3_storage.set_read_ahead(True)
    assert_runs_equal(bag_reader.read_machine_bag(bag, chunk_messages=700),
                      _ordered_read(bag, monkeypatch, chunk_messages=700))
    chunks = list(bag_reader.iter_machine_bag(bag, chunk_messages=700))
    assert [c.messages for c in chunks[:-1]] == [700] * (len(chunks) - 1)     # all topics read: full chunks


def _range_batches(db, where, args, flat, base_ns, step=700):
    lo, hi = db.execute("SELECT MIN(rowid), MAX(rowid) FROM messages").fetchone()
    return [sqlite3_storage._read_range(db, r, r + step, where, args, flat, base_ns) for r in range(lo, hi + 1, step)]


def test_range_query_forms_give_the_same_batches(tmp_path):
    """The flat range query (taken when the plan is a rowid range search) and log times read relative to a
    base give the batches of the ordered sub-query with absolute times, bit for bit; near the int64 limits
    no base is taken (a difference would overflow) and the times stay exact."""
    bag = bag_writer.write_machine_bag(make_run(), tmp_path / "bag", "sqlite3")
    with storage.open_storage(bag) as st:
        db, ids = st._db, [c.id for c in st.connections]
        where = f" AND topic_id IN ({','.join('?' * len(ids))})"
        assert sqlite3_storage._plan_in_rowid_order(db, where, ids)
        base = sqlite3_storage._time_base(db)
        assert base == db.execute("SELECT MIN(timestamp) FROM messages").fetchone()[0] > 0
        want = _range_batches(db, where, ids, False, 0)
        for flat, base_ns in ((True, 0), (True, base), (False, base)):
            for a, b in zip(_range_batches(db, where, ids, flat, base_ns), want, strict=True):
                for x, y in zip(a, b, strict=True):
                    assert x.dtype == y.dtype
                    np.testing.assert_array_equal(x, y)
    con = sqlite3.connect(tmp_path / "edge.db3")
    con.execute("CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER, timestamp INTEGER, data BLOB)")
    times = [-(2**63), -5, 0, 2**63 - 1]
    con.executemany("INSERT INTO messages VALUES (?, 1, ?, ?)", [(i + 1, t, bytes([i] * 3)) for i, t in
                                                                 enumerate(times)])
    con.commit()
    assert sqlite3_storage._time_base(con) == 0
    con.execute("DELETE FROM messages WHERE timestamp >= 0")
    assert sqlite3_storage._time_base(con) == -(2**63)
    for flat in (False, True):
        got = sqlite3_storage._read_range(con, 1, 10, "", [], flat, -(2**63))
        assert got.log_time_ns.tolist() == times[:2] and got.buf.tolist() == [0, 0, 0, 1, 1, 1]
    con.close()


def test_unwanted_topics_and_rows_of_no_topic(tmp_path, monkeypatch):
    """Every topic of the bag wanted: ranges are read without the topic filter and a row of no known topic
    (an orphan, topic id 99) is dropped; equal to the run and to the ORDER BY read. One topic wanted of
    several: the filter stays, and the batches hold exactly that topic's rows in time order."""
    run = make_run()
    bag = bag_writer.write_machine_bag(run, tmp_path / "orphan", "sqlite3")
    with sqlite3.connect(_db(bag)) as con:
        con.execute("INSERT INTO messages (topic_id, timestamp, data) VALUES "
                    "(99, (SELECT MAX(timestamp) FROM messages), x'00010000')")
        n_rows = con.execute("SELECT COUNT(*) FROM messages").fetchone()[0]
        first = con.execute("SELECT topic_id FROM messages ORDER BY rowid LIMIT 1").fetchone()[0]
        want = con.execute("SELECT timestamp, data FROM messages WHERE topic_id = ? ORDER BY timestamp, rowid",
                           (first,)).fetchall()
    for chunk in (700, n_rows):
        assert_runs_equal(bag_reader.read_machine_bag(bag, chunk_messages=chunk), run)
    assert_runs_equal(bag_reader.read_machine_bag(bag, chunk_messages=700),
                      _ordered_read(bag, monkeypatch, chunk_messages=700))
    with storage.open_storage(bag) as st:
        assert sqlite3_storage._every_topic(st._db, tuple(c.id for c in st.connections))
        assert not sqlite3_storage._every_topic(st._db, (first,))
        batches = [b for group in iter_sqlite_packed(st._db, bag, (first,), 700) for b in group]
    assert {int(i) for b in batches for i in b.connection_ids} == {first}
    assert [int(t) for b in batches for t in b.log_time_ns] == [t for t, _ in want]
    assert b"".join(b.buf.tobytes() for b in batches) == b"".join(d for _, d in want)


def test_rows_not_in_time_order_fall_back(tmp_path, monkeypatch):
    """Rows stored in reverse and in a seeded random order: the check of the first range fails and the
    reader gives the ORDER BY timestamp result (= the original run, = rosbags' Reader)."""
    run = make_run()
    for name, order in (("reverse", lambda n: np.arange(n)[::-1]),
                        ("shuffled", lambda n: np.random.default_rng(11).permutation(n))):
        bag = bag_writer.write_machine_bag(run, tmp_path / name, "sqlite3")
        _renumber(bag, order)
        got, fallback = _read_watching_fallback(bag, 700, monkeypatch)
        assert fallback == [1]
        assert_runs_equal(got, run)
        assert_runs_equal(got, _rosbags_read(bag))


def _swap_pairs(n):
    perm = np.arange(n)
    m = n - n % 2
    perm[0:m:2], perm[1:m:2] = perm[1:m:2].copy(), perm[0:m:2].copy()      # swap rows (0,1), (2,3)...
    return perm


def test_rows_out_of_order_inside_ranges_are_sorted(tmp_path, monkeypatch):
    """Neighbouring rows swapped (a disorder that stays inside each range of 1000 rowids): the ranges
    pass the check and are sorted inside; equal to the ORDER BY read and to the run. With ranges of 3
    rows the swapped pairs straddle ranges: fallback from the first range, still equal."""
    run = make_run()
    bag = bag_writer.write_machine_bag(run, tmp_path / "bag", "sqlite3")
    _renumber(bag, _swap_pairs)
    with sqlite3.connect(_db(bag)) as con:
        stamps = [t for (t,) in con.execute("SELECT timestamp FROM messages ORDER BY id")]
    assert sum(b < a for a, b in zip(stamps, stamps[1:])) > 100          # really out of order
    got, fallback = _read_watching_fallback(bag, 1000, monkeypatch)
    assert fallback == [] and _uses_packed(bag, 1000)
    assert_runs_equal(got, run)
    assert_runs_equal(got, _ordered_read(bag, monkeypatch, chunk_messages=1000))
    got, fallback = _read_watching_fallback(bag, 3, monkeypatch)
    assert fallback == [1]
    assert_runs_equal(got, run)


def test_late_disorder_falls_back_from_that_range(tmp_path, monkeypatch):
    """Rows 2000 and 2001 swapped (straddling the ranges [1001, 2001) and [2001, 3001)): the first range
    is handed on, the second fails its check and the rest comes from ORDER BY timestamp from rowid 1001;
    the result is the run. Without the timestamp index the whole order is checked before reading."""
    run = make_run()
    bag = bag_writer.write_machine_bag(run, tmp_path / "bag", "sqlite3")

    def swap_late(n):
        perm = np.arange(n)
        perm[[1999, 2000]] = perm[[2000, 1999]]
        return perm
    _renumber(bag, swap_late)
    for ahead in (True, False):                 # with and without the read-ahead thread
        monkeypatch.setattr(sqlite3_storage, "_READ_AHEAD", [ahead])
        got, fallback = _read_watching_fallback(bag, 1000, monkeypatch)
        assert fallback == [1001]
        assert_runs_equal(got, run)
    with sqlite3.connect(_db(bag)) as con:
        con.execute("DROP INDEX timestamp_idx")
    assert not _uses_packed(bag, 1000) and _uses_packed(bag, 5000)       # 2000/2001 inside [1, 5001)
    assert_runs_equal(bag_reader.read_machine_bag(bag, chunk_messages=1000), run)
    assert_runs_equal(bag_reader.read_machine_bag(bag, chunk_messages=5000), run)


def test_replay_report_identical_to_ordered_read(tmp_path, monkeypatch):
    """analyse_bag (replay) through the packed reader and through the per-message ORDER BY reader gives
    the same report, byte for byte once the timings are removed."""
    from guide_health.analysis.replay import analyse_bag
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    cfg = Path(__file__).resolve().parents[1] / "config" / "bench_000.yaml"
    params = wear_monitor_params(cfg)
    sim = dict(simulation_params(cfg), duration_h=1.0, joint_state_rate_hz=10.0, measurement_interval_h=0.2)
    bag = bag_writer.write_machine_bag(simulate_machine(params, sim, seed=4), tmp_path / "b", "sqlite3")

    def report():
        summary = analyse_bag(bag, params, chunk_messages=977)[1]
        return json.dumps(summary, sort_keys=True, default=str)
    fast = report()
    with monkeypatch.context() as m:
        m.setattr(sqlite3_storage.Sqlite3Storage, "iter_packed", lambda *a: None)
        slow = report()
    assert json.loads(fast)["messages"] == json.loads(slow)["messages"] > 30_000
    assert fast == slow


def test_decode_packed_equals_decode_chunk():
    """Messages of several lengths and layouts (one and two joints, big-endian, truncated, empty) packed
    into one buffer decode exactly as the list decoder decodes them (values, presence, counts)."""
    from guide_health.io.bag.typestore import header, message, typestore

    rng = np.random.default_rng(3)
    ts = typestore()
    raws = []
    for k in range(300):
        kind = int(rng.integers(5))
        names = ["x"] if kind == 0 else ["y", "x"]
        msg = message(JOINT_STATE, header=header(T0 + k, ""), name=names, position=rng.normal(size=len(names)),
                      velocity=rng.normal(size=len(names)), effort=np.zeros(0))
        raw = bytes(ts.serialize_cdr(msg, JOINT_STATE, little_endian=(kind != 2)))
        raws.append(raw[:20] if kind == 3 else b"" if kind == 4 and k % 7 == 0 else raw)
    joint = cdr.codec_for(JOINT_STATE, "x")
    buf = np.frombuffer(b"".join(raws), np.uint8)
    lengths = np.array([len(r) for r in raws], np.int64)
    offsets = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)
    for fast in (True, False):
        a = cdr.decode_chunk(raws, joint, fast)
        b = cdr.decode_packed(buf, offsets, lengths, joint, fast)
        for name in joint.names:
            np.testing.assert_array_equal(a.values[name], b.values[name])
            np.testing.assert_array_equal(a.present[name], b.present[name])
        np.testing.assert_array_equal(a.keep, b.keep)
        assert (a.missing, a.malformed, a.fast, a.fallback) == (b.missing, b.malformed, b.fast, b.fallback)
    assert a.keep.size > 100 and b.malformed > 0
    wrench = cdr.encode_wrench_stamped(T0 + np.arange(50), rng.normal(size=(50, 3)))
    c = cdr.decode_packed(np.frombuffer(b"".join(wrench), np.uint8), np.arange(50) * len(wrench[0]),
                          np.full(50, len(wrench[0])), cdr.codec_for(WRENCH_STAMPED))
    assert c.fast == 50 and c.values["nsec"].tolist() == ((T0 + np.arange(50)) % 1_000_000_000).tolist()


# ---------------------------------------------------------------------------------------------
# mcap: a minimal writer (mcap specification records) for chunks of each compression
# ---------------------------------------------------------------------------------------------

MCAP_MAGIC = b"\x89MCAP0\r\n"


def _record(op: int, body: bytes) -> bytes:
    return bytes([op]) + struct.pack("<Q", len(body)) + body


def _string(text: str) -> bytes:
    return struct.pack("<I", len(text.encode())) + text.encode()


def _compress(data: bytes, compression: str) -> bytes:
    if compression == "zstd":
        import zstandard
        return zstandard.ZstdCompressor().compress(data)
    if compression == "lz4":
        import lz4.frame
        return lz4.frame.compress(data)
    return data


def _schema_channel_records(mcap_file: Path) -> bytes:
    """The Schema (0x03) and Channel (0x04) records of an mcap file's summary, as raw bytes."""
    raw = mcap_file.read_bytes()
    pos = struct.unpack_from("<Q", raw, len(raw) - 37 + 9)[0]
    out = b""
    while raw[pos] != 0x02:
        length = struct.unpack_from("<Q", raw, pos + 1)[0]
        if raw[pos] in (0x03, 0x04):
            out += raw[pos:pos + 9 + length]
        pos += 9 + length
    return out


def write_mcap(path: Path, header_records: bytes, messages: list, compression: str, per_chunk: int,
               message_index: bool = True, summary: bool = True) -> Path:
    """An mcap file of `messages` [(channel id, log time, data)] in chunks of `per_chunk` (file order)."""
    out = bytearray(MCAP_MAGIC) + _record(0x01, _string("ros2") + _string("guide_health test"))
    out += header_records
    indexes = []
    for start in range(0, len(messages), per_chunk):
        group = messages[start:start + per_chunk]
        records, entries = bytearray(), {}
        for cid, t, data in group:
            entries.setdefault(cid, []).append((t, len(records)))
            records += _record(0x05, struct.pack("<HIQQ", cid, 0, t, t) + data)
        comp = _compress(bytes(records), compression)
        t_lo, t_hi = min(m[1] for m in group), max(m[1] for m in group)
        chunk_start = len(out)
        out += _record(0x06, struct.pack("<QQQI", t_lo, t_hi, len(records), zlib.crc32(records))
                       + _string(compression) + struct.pack("<Q", len(comp)) + comp)
        chunk_end = len(out)
        offsets = {}
        for cid, pairs in entries.items() if message_index else ():
            offsets[cid] = len(out)
            out += _record(0x07, struct.pack("<HI", cid, 16 * len(pairs))
                           + b"".join(struct.pack("<QQ", *p) for p in pairs))
        indexes.append(struct.pack("<QQQQ", t_lo, t_hi, chunk_start, chunk_end - chunk_start)
                       + struct.pack("<I", 10 * len(offsets))
                       + b"".join(struct.pack("<HQ", *o) for o in offsets.items())
                       + struct.pack("<Q", len(out) - chunk_end) + _string(compression)
                       + struct.pack("<QQ", len(comp), len(records)))
    out += _record(0x0F, struct.pack("<I", 0))                 # DataEnd
    summary_start = len(out) if summary else 0
    if summary:
        out += header_records + b"".join(_record(0x08, ci) for ci in indexes)
    out += _record(0x02, struct.pack("<QQI", summary_start, 0, 0)) + MCAP_MAGIC
    path.write_bytes(bytes(out))
    return path


@pytest.fixture(scope="module")
def mcap_source(tmp_path_factory):
    """A run, its mcap bag (bag_writer) and that file's channel records and messages (rosbags read)."""
    from rosbags.rosbag2 import Reader

    run = make_run(2000, seed=9)
    bag = bag_writer.write_machine_bag(run, tmp_path_factory.mktemp("mcap") / "bag", "mcap")
    mcap_file = next(bag.glob("*.mcap"))
    with Reader(mcap_file) as reader:                 # a bare file: connection id = channel id
        messages = [(c.id, t, bytes(raw)) for c, t, raw in reader.messages()]
    return run, bag, _schema_channel_records(mcap_file), messages


def _rosbags_mcap_read(path: Path, monkeypatch) -> MachineRun:
    """The bag read through the rosbags fallback (an independent mcap reader)."""
    with monkeypatch.context() as m:
        m.setattr(storage, "BACKENDS", {k: v for k, v in storage.BACKENDS.items() if k != "mcap"})
        return bag_reader.read_machine_bag(path)


def _mcap_packed(path: Path) -> bool:
    with storage.open_storage(path) as st:
        got = st.iter_packed(st.connections, 500)
        return got is not None


@pytest.mark.parametrize("compression", ["", "zstd", "lz4"])
def test_mcap_chunks_equal_rosbags(tmp_path, mcap_source, monkeypatch, compression):
    """Chunks of each compression read by the chunk reader: equal to rosbags' reader and to the run."""
    run, _, records, messages = mcap_source
    path = write_mcap(tmp_path / "c.mcap", records, messages, compression, per_chunk=333)
    assert _mcap_packed(path)
    got = bag_reader.read_machine_bag(path, chunk_messages=700)
    assert_runs_equal(got, run)
    assert_runs_equal(got, _rosbags_mcap_read(path, monkeypatch))


def test_mcap_bag_writer_bag_uses_chunk_reader(mcap_source, monkeypatch):
    run, bag, _, _ = mcap_source
    assert _mcap_packed(bag)
    assert_runs_equal(bag_reader.read_machine_bag(bag, chunk_messages=450), run)
    chunks = list(bag_reader.iter_machine_bag(bag, chunk_messages=450))
    assert [c.messages for c in chunks[:-1]] == [450] * (len(chunks) - 1)
    assert_runs_equal(bag_reader.read_machine_bag(bag), _rosbags_mcap_read(bag, monkeypatch))


def test_mcap_without_index_or_with_overlapping_chunks(tmp_path, mcap_source):
    """No summary, chunks without message indexes, chunks overlapping in time (one per topic, with and without
    message indexes): the chunk reader reads each whole, equal to the run, every message in log-time order
    across topics (what a streamed replay integrates)."""
    run, _, records, messages = mcap_source
    by_topic = sorted(messages, key=lambda m: m[0])                  # stable: each topic in time order
    for name, msgs, compression, kwargs in (("n", messages, "zstd", {"summary": False}),
                                            ("s", messages, "lz4", {"message_index": False}),
                                            ("o", by_topic, "", {}),
                                            ("on", by_topic, "zstd", {"message_index": False})):
        path = write_mcap(tmp_path / f"{name}.mcap", records, msgs, compression, 400, **kwargs)
        assert _mcap_packed(path), name
        assert_runs_equal(bag_reader.read_machine_bag(path, chunk_messages=300), run)
        with storage.open_storage(path) as st:
            times = [int(t) for group in st.iter_packed(st.connections, 300) for b in group for t in b.log_time_ns]
        assert times == sorted(m[1] for m in messages), name
