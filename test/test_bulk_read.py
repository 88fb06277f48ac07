"""Bulk bag reading (issue 14): packed sqlite3 batches in rowid order, the order check and its fallback,
the packed CDR decoder, and the mcap chunk reader. Every result is compared with an independent path:
the per-message `ORDER BY timestamp` read (the previous reader), rosbags' own Reader, or the original run.
"""
from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import numpy as np

from guide_health.io import bag_reader, bag_writer, cdr, storage
from guide_health.io.interfaces import JOINT_STATE, WRENCH_STAMPED
from guide_health.io.packed import iter_sqlite_packed
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
        m.setattr(storage.SqliteDirectStorage, "iter_packed", lambda *a: None)
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


def test_packed_sqlite_read_equals_ordered_read(tmp_path, monkeypatch):
    run = make_run()
    bag = bag_writer.write_machine_bag(run, tmp_path / "bag", "sqlite3")
    assert _uses_packed(bag, 700)
    for chunk in (1, 700, 200_000):
        assert_runs_equal(bag_reader.read_machine_bag(bag, chunk_messages=chunk), run)
    assert_runs_equal(bag_reader.read_machine_bag(bag, chunk_messages=700),
                      _ordered_read(bag, monkeypatch, chunk_messages=700))
    chunks = list(bag_reader.iter_machine_bag(bag, chunk_messages=700))
    assert [c.messages for c in chunks[:-1]] == [700] * (len(chunks) - 1)     # all topics read: full chunks


def test_rows_not_in_time_order_fall_back(tmp_path, monkeypatch):
    """Rows stored in reverse and in a seeded random order: the order check refuses the rowid order and
    the reader gives the ORDER BY timestamp result (= the original run, = rosbags' Reader)."""
    run = make_run()
    for name, order in (("reverse", lambda n: np.arange(n)[::-1]),
                        ("shuffled", lambda n: np.random.default_rng(11).permutation(n))):
        bag = bag_writer.write_machine_bag(run, tmp_path / name, "sqlite3")
        _renumber(bag, order)
        assert not _uses_packed(bag, 700)
        got = bag_reader.read_machine_bag(bag, chunk_messages=700)
        assert_runs_equal(got, run)
        assert_runs_equal(got, _rosbags_read(bag))


def test_rows_out_of_order_inside_ranges_are_sorted(tmp_path, monkeypatch):
    """Neighbouring rows swapped (a disorder that stays inside each range of 1000 rowids): the rowid
    ranges still do not overlap in time, so the packed path is used and sorts each range; equal to the
    ORDER BY read and to the run. With ranges of 3 rows, swapped pairs straddle ranges: fallback."""
    run = make_run()
    bag = bag_writer.write_machine_bag(run, tmp_path / "bag", "sqlite3")

    def swap_pairs(n):
        perm = np.arange(n)
        m = n - n % 2
        perm[0:m:2], perm[1:m:2] = perm[1:m:2].copy(), perm[0:m:2].copy()      # swap rows (0,1), (2,3)...
        return perm
    _renumber(bag, swap_pairs)
    with sqlite3.connect(_db(bag)) as con:
        stamps = [t for (t,) in con.execute("SELECT timestamp FROM messages ORDER BY id")]
    assert sum(b < a for a, b in zip(stamps, stamps[1:])) > 100          # really out of order
    assert _uses_packed(bag, 1000) and not _uses_packed(bag, 3)
    assert_runs_equal(bag_reader.read_machine_bag(bag, chunk_messages=1000), run)
    assert_runs_equal(bag_reader.read_machine_bag(bag, chunk_messages=3), run)
    assert_runs_equal(bag_reader.read_machine_bag(bag, chunk_messages=1000),
                      _ordered_read(bag, monkeypatch, chunk_messages=1000))


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
        m.setattr(storage.SqliteDirectStorage, "iter_packed", lambda *a: None)
        slow = report()
    assert json.loads(fast)["messages"] == json.loads(slow)["messages"] > 30_000
    assert fast == slow


def test_decode_packed_equals_decode_chunk():
    """Messages of several lengths and layouts (one and two joints, big-endian, truncated, empty) packed
    into one buffer decode exactly as the list decoder decodes them (values, presence, counts)."""
    from guide_health.io.typestore import header, message, typestore

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
