"""Bags with damaged messages for the rejection-ledger tests: a clean sqlite3 bag written with the project's
writer, then messages replaced in its db3 file (what a broken recorder or a bad disk leaves)."""
from __future__ import annotations

import sqlite3
import struct
from pathlib import Path

import numpy as np
import yaml

from guide_health.io.bag.interfaces import JOINT_STATE
from guide_health.io.bag.typestore import header, message, typestore
from guide_health.io.bag.writer import write_machine_bag
from guide_health.models.wear import input_rules as rules
from guide_health.params import simulation_params, wear_monitor_params
from guide_health.sim.machine import simulate_machine

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "config" / "bench_000.yaml"


def db_file(bag: Path) -> Path:
    return next(Path(bag).glob("*.db3"))


def topic_rows(bag: Path, topic: str) -> list[tuple[int, int, bytes]]:
    """(row id, log time, data) of a topic's messages in log-time order."""
    with sqlite3.connect(db_file(bag)) as db:
        return db.execute("SELECT m.id, m.timestamp, m.data FROM messages m JOIN topics t ON m.topic_id = t.id "
                          "WHERE t.name = ? ORDER BY m.timestamp, m.id", (topic,)).fetchall()


def replace_rows(bag: Path, data_of_row: dict[int, bytes]) -> None:
    with sqlite3.connect(db_file(bag)) as db:
        db.executemany("UPDATE messages SET data = ? WHERE id = ?", [(d, i) for i, d in data_of_row.items()])


def delete_rows(bag: Path, rows) -> None:
    """Delete messages and recount metadata.yaml (a count above the stored rows is a refused bag)."""
    with sqlite3.connect(db_file(bag)) as db:
        db.executemany("DELETE FROM messages WHERE id = ?", [(int(i),) for i in rows])
        counts = dict(db.execute("SELECT t.name, COUNT(m.id) FROM topics t LEFT JOIN messages m "
                                 "ON m.topic_id = t.id GROUP BY t.name").fetchall())
    path = Path(bag) / "metadata.yaml"
    info = yaml.safe_load(path.read_text())
    meta = info["rosbag2_bagfile_information"]
    for entry in meta["topics_with_message_count"]:
        entry["message_count"] = counts.get(entry["topic_metadata"]["name"], 0)
    meta["message_count"] = sum(counts.values())
    for f in meta.get("files", []):
        f["message_count"] = sum(counts.values())
    path.write_text(yaml.safe_dump(info, sort_keys=False))


def joint_state(t_ns: int, names, positions, velocities=()) -> bytes:
    msg = message(JOINT_STATE, header=header(t_ns), name=list(names), position=np.asarray(positions, float),
                  velocity=np.asarray(velocities, float), effort=np.zeros(0))
    return bytes(typestore().serialize_cdr(msg, JOINT_STATE))


def clean_bench_bag(tmp_path: Path, name: str = "clean", hours: float = 0.5, rate: float = 10.0, seed: int = 3):
    """(params, bag) of a bench_000 run: joint_states at ``rate`` Hz, loads at 1 Hz, a measurement per 0.1 h."""
    params = wear_monitor_params(BENCH)
    sim = dict(simulation_params(BENCH), duration_h=hours, joint_state_rate_hz=rate, load_rate_hz=1.0,
               measurement_interval_h=0.1)
    run = simulate_machine(params, sim, seed=seed)
    return params, write_machine_bag(run, tmp_path / name, storage="sqlite3")


#: every kind of damaged message, the topic it is on, and the reason the rules give it (the truth of the
#: tests, from input_rules' definitions)
KINDS = {
    "empty joint message": ("/joint_states", rules.MALFORMED_JOINT_STATES),
    "joint message 1 byte short": ("/joint_states", rules.MALFORMED_JOINT_STATES),
    "names [y, x], one position": ("/joint_states", rules.JOINT_POSITION_MISSING),
    "no names, no positions": ("/joint_states", rules.EMPTY_JOINT_STATES),
    "names [x], no positions": ("/joint_states", rules.EMPTY_JOINT_STATES),
    "only joint y": ("/joint_states", rules.joint_missing("x")),
    "nanosec 1.5e9": ("/joint_states", rules.INVALID_STAMP),
    "empty load message": ("/guide/load", rules.MALFORMED_LOAD),
    "load message 1 byte short": ("/guide/load", rules.MALFORMED_LOAD),
    "load frame_id longer than the message": ("/guide/load", rules.MALFORMED_LOAD),
    "load nanosec 1.5e9": ("/guide/load", rules.INVALID_STAMP),
    "straightness 1 byte short": ("/guide/straightness", rules.MALFORMED_STRAIGHTNESS),
}
#: the kinds bag_player must skip: not a CDR payload of their type (shorter than its fixed part: JointState 36
#: bytes, WrenchStamped 68, Float64 12; or not decodable)
PLAYER_SKIPS = ("empty joint message", "joint message 1 byte short", "empty load message", "load message 1 byte short",
                "load frame_id longer than the message", "straightness 1 byte short")


def damaged(kind: str, raw: bytes, t_ns: int) -> bytes:
    """The message ``raw`` (stamped ``t_ns``) damaged as ``kind``."""
    if kind.startswith("empty"):
        return b""
    if "1 byte short" in kind:
        return raw[:-1]
    if kind == "names [y, x], one position":
        return joint_state(t_ns, ["y", "x"], [0.1], [0.0])
    if kind == "no names, no positions":
        return joint_state(t_ns, [], [])
    if kind == "names [x], no positions":
        return joint_state(t_ns, ["x"], [])
    if kind == "only joint y":
        return joint_state(t_ns, ["y"], [0.1], [0.0])
    if "nanosec" in kind:
        return raw[:8] + struct.pack("<I", 1_500_000_000) + raw[12:]
    if kind == "load frame_id longer than the message":
        return raw[:12] + struct.pack("<I", 10_000) + raw[16:]
    raise ValueError(kind)


def bag_with_every_damage(tmp_path: Path, every: int = 97):
    """(params, bag, {kind: message index}) : the clean bench bag with each KINDS damage at a different
    message of its topic (message ``every * (k + 1)`` of the topic for the k-th kind of it)."""
    params, bag = clean_bench_bag(tmp_path, "damaged")
    rows = {topic: topic_rows(bag, topic) for topic in {t for t, _ in KINDS.values()}}
    used: dict[str, int] = {}
    edits, where = {}, {}
    for kind, (topic, _) in KINDS.items():
        used[topic] = used.get(topic, 0) + 1
        index = (every if topic != "/guide/straightness" else 1) * used[topic]
        row_id, t_ns, raw = rows[topic][index]
        edits[row_id] = damaged(kind, bytes(raw), t_ns)
        where[kind] = index
    replace_rows(bag, edits)
    return params, bag, where


def expected_counts() -> dict[str, int]:
    """{reason: count} of bag_with_every_damage."""
    counts: dict[str, int] = {}
    for _, reason in KINDS.values():
        counts[reason] = counts.get(reason, 0) + 1
    return counts
