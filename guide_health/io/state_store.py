"""Crash-safe persistence of monitor state in an embedded SQLite file.

One row per monitor (key = e.g. "<machine_id>/<joint>/precision") holding the JSON state, written in one
transaction: a reader (or a restarted node) sees either the previous checkpoint or the new one, never a
mix. WAL journal + synchronous=FULL: a SIGKILL or power loss loses at most the work since the last commit.
"""
from __future__ import annotations

import json
import math
import sqlite3
import time
from pathlib import Path

SCHEMA = """
CREATE TABLE IF NOT EXISTS monitor_state (
    key TEXT PRIMARY KEY,
    saved_unix_s REAL NOT NULL,
    state_json TEXT NOT NULL
);
"""


def _encode(value):
    """JSON cannot hold NaN/inf portably: store them as strings."""
    if isinstance(value, float) and not math.isfinite(value):
        return {"__float__": repr(value)}
    if isinstance(value, dict):
        return {k: _encode(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_encode(v) for v in value]
    return value


def _decode(value):
    if isinstance(value, dict):
        if set(value) == {"__float__"}:
            return float(value["__float__"])
        return {k: _decode(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_decode(v) for v in value]
    return value


class StateStore:
    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._db = sqlite3.connect(str(self.path), isolation_level=None, timeout=10.0)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=FULL")
        self._db.executescript(SCHEMA)

    def load(self, key: str) -> dict | None:
        row = self._db.execute("SELECT state_json FROM monitor_state WHERE key = ?", (key,)).fetchone()
        return None if row is None else _decode(json.loads(row[0]))

    def save(self, states: dict[str, dict]) -> None:
        """Write several monitors' states in one atomic transaction."""
        now = time.time()
        rows = [(key, now, json.dumps(_encode(state), allow_nan=False)) for key, state in states.items()]
        self._db.execute("BEGIN IMMEDIATE")
        try:
            self._db.executemany(
                "INSERT INTO monitor_state (key, saved_unix_s, state_json) VALUES (?, ?, ?) "
                "ON CONFLICT(key) DO UPDATE SET saved_unix_s = excluded.saved_unix_s, "
                "state_json = excluded.state_json", rows)
        except BaseException:
            self._db.execute("ROLLBACK")
            raise
        self._db.execute("COMMIT")

    def close(self) -> None:
        self._db.close()
