"""Crash-safe persistence of monitor state in an embedded SQLite file.

One row per monitor (key = e.g. "<machine_id>/<joint>/precision") holding the JSON state, written in one
transaction: a reader (or a restarted node) sees either the previous checkpoint or the new one, never a
mix. WAL journal + synchronous=FULL: a SIGKILL or power loss loses at most the work since the last commit.

Safety:
* where: ``resolve_state_path`` turns the ``state_file`` parameter into a path: ``auto`` (the default) is
  ``$ROS_HOME/guide_health/<machine_id>/<node>.db`` (ROS_HOME defaults to ``~/.ros``), ``''`` or ``none``
  disables persistence, anything else is the path itself;
* one writer: an exclusive ``fcntl.flock`` on ``<state>.lock`` beside it; a second process on the same state
  file is refused with one line naming the holder's pid (the lock goes with the process, also on SIGKILL);
* whose: each row is saved with a fingerprint (machine, axis, guide type, geometry); ``load`` refuses a row
  saved under another one;
* every open/read/write failure (a directory, a garbage file, no permission, a disk full) is one
  InputError line naming the file and what to do; the file is created 0600 and never through a symlink.
"""
from __future__ import annotations

import fcntl
import json
import math
import os
import re
import sqlite3
import time
from pathlib import Path

from guide_health.errors import InputError
from guide_health.models.wear.state_schema import check_precision_state, fingerprint_mismatch

SCHEMA = """
CREATE TABLE IF NOT EXISTS monitor_state (
    key TEXT PRIMARY KEY,
    saved_unix_s REAL NOT NULL,
    state_json TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS monitor_fingerprint (
    key TEXT PRIMARY KEY,
    fingerprint_json TEXT NOT NULL
);
"""
DISABLED = ("", "none")
AUTO = "auto"
FILE_MODE = 0o600


def _safe_part(text: str) -> str:
    """A machine or node name as one path component (no '/', no '..')."""
    part = re.sub(r"[^A-Za-z0-9_.-]", "_", str(text).strip("/")) or "_"
    return "_" if set(part) == {"."} else part


def resolve_state_path(setting: str, machine_id: str, node_name: str) -> Path | None:
    """The state file of the ``state_file`` parameter: None when disabled ('' or 'none'); ``auto`` ->
    ``$ROS_HOME/guide_health/<machine_id>/<node_name>.db`` (ROS_HOME: ~/.ros); else the path (~ expanded)."""
    text = str(setting).strip()
    if text.lower() in DISABLED:
        return None
    if text.lower() == AUTO:
        ros_home = os.environ.get("ROS_HOME") or os.path.join(os.path.expanduser("~"), ".ros")
        return Path(ros_home) / "guide_health" / _safe_part(machine_id) / f"{_safe_part(node_name)}.db"
    return Path(os.path.expanduser(text))


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
            try:
                return float(value["__float__"])
            except (TypeError, ValueError):
                return value
        return {k: _decode(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_decode(v) for v in value]
    return value


def _reason(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    return " ".join(str(exc).split()) or type(exc).__name__


class StateStore:
    """The SQLite state file at ``path``, locked for this process until :meth:`close`."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._lock_fd: int | None = None
        self._db = None
        try:
            self._open()
        except BaseException:
            self.close()
            raise

    def _fail(self, what: str, todo: str) -> InputError:
        what = what if len(what) <= 240 else what[:237] + "..."
        return InputError(f"state file {self.path}: {what}; {todo}")

    def _open(self) -> None:
        if self.path.is_dir():
            raise self._fail("is a directory", "set state_file to a file path (or 'none')")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        except OSError as exc:
            raise self._fail(f"cannot create its folder ({_reason(exc)})", "set state_file to a writable path "
                             "(or 'none')") from None
        self._lock()
        try:           # create 0600, never through a symlink (O_NOFOLLOW refuses one at the path)
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, FILE_MODE)
            os.close(fd)
        except OSError as exc:
            what = "is a symbolic link" if self.path.is_symlink() else f"cannot be opened ({_reason(exc)})"
            raise self._fail(what, "set state_file to a writable regular file (or 'none')") from None
        try:
            self._db = sqlite3.connect(str(self.path), isolation_level=None, timeout=10.0)
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=FULL")
            self._db.executescript(SCHEMA)
            columns = [row[1] for row in self._db.execute("PRAGMA table_info(monitor_state)")]
        except sqlite3.Error as exc:
            raise self._fail(f"is not a usable guide_health state database ({_reason(exc)})",
                             "move it away to start afresh, or set another state_file") from None
        if columns != ["key", "saved_unix_s", "state_json"]:
            raise self._fail("has a monitor_state table of another layout",
                             "move it away to start afresh, or set another state_file")

    def _lock(self) -> None:
        lock_path = Path(f"{self.path}.lock")
        try:
            fd = os.open(lock_path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, FILE_MODE)
        except OSError as exc:
            raise self._fail(f"cannot create the lock file {lock_path} ({_reason(exc)})",
                             "set state_file to a writable path (or 'none')") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = os.read(fd, 32).decode(errors="replace").strip() or "?"
            os.close(fd)
            raise self._fail(f"is in use by another process (pid {holder}, lock {lock_path})",
                             "two monitors must not share a state file: stop the other one or set another "
                             "state_file") from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self._lock_fd = fd

    def saved_fingerprint(self, key: str) -> dict | None:
        """The fingerprint saved with ``key`` (None: no row, unreadable or not a JSON mapping: ``load`` says why)."""
        try:
            row = self._db.execute("SELECT fingerprint_json FROM monitor_fingerprint WHERE key = ?",
                                   (key,)).fetchone()
            saved = json.loads(row[0]) if row is not None else None
        except (sqlite3.Error, TypeError, ValueError, RecursionError):
            return None
        return saved if isinstance(saved, dict) else None

    def load(self, key: str, fingerprint: dict | None = None, check=None) -> dict | None:
        """The saved state of ``key`` (None if there is none), refused whole (InputError, one line naming the
        file and what to do) when it cannot be read, is not JSON, was saved under another ``fingerprint`` (a
        state of before fingerprints is accepted), or ``check(state)`` raises InputError/ValueError."""
        try:
            row = self._db.execute("SELECT state_json FROM monitor_state WHERE key = ?", (key,)).fetchone()
            saved_fp = self._db.execute("SELECT fingerprint_json FROM monitor_fingerprint WHERE key = ?",
                                        (key,)).fetchone()
        except sqlite3.Error as exc:
            raise self._fail(f"cannot be read ({_reason(exc)})", "move it away to start afresh") from None
        if row is None:
            self._check_machine(key, fingerprint)
            return None
        try:
            state = _decode(json.loads(row[0]))
            saved_fp = None if saved_fp is None else json.loads(saved_fp[0])
        except (TypeError, ValueError, RecursionError) as exc:
            raise self._fail(f"the saved state of '{key}' is not valid JSON ({_reason(exc)})",
                             "move the file away to start afresh") from None
        if fingerprint is not None and saved_fp is not None:
            if not isinstance(saved_fp, dict):
                raise self._fail(f"the fingerprint of '{key}' is not a mapping", "move the file away to start "
                                 "afresh")
            diff = fingerprint_mismatch(saved_fp, fingerprint)
            if diff:
                raise self._fail(f"the state of '{key}' was saved for another guide: {diff}",
                                 "restore those parameters, or move the file away to start afresh")
        if check is not None:
            try:
                check(state)
            except (InputError, ValueError, TypeError, RecursionError) as exc:
                raise self._fail(f"the saved state of '{key}' is refused ({_reason(exc)})",
                                 "move the file away to start afresh") from None
        return state

    def _check_machine(self, key: str, fingerprint: dict | None) -> None:
        """No row for ``key``: the file must not hold another machine's states (a copied or shared file)."""
        if not fingerprint or "machine_id" not in fingerprint:
            return
        try:
            rows = self._db.execute("SELECT key, fingerprint_json FROM monitor_fingerprint").fetchall()
        except sqlite3.Error as exc:
            raise self._fail(f"cannot be read ({_reason(exc)})", "move it away to start afresh") from None
        for other, text in rows:
            try:
                machine = json.loads(text).get("machine_id")
            except (AttributeError, TypeError, ValueError):
                machine = None
            if machine is not None and machine != fingerprint["machine_id"]:
                raise self._fail(f"holds the state '{other}' of machine_id {machine!r} (now "
                                 f"{fingerprint['machine_id']!r})", "set this machine's own state_file, or "
                                 "restore machine_id")

    def save(self, states: dict[str, dict], fingerprint: dict | None = None) -> None:
        """Write several monitors' states (and their fingerprint) in one atomic transaction."""
        now = time.time()
        rows = [(key, now, json.dumps(_encode(state), allow_nan=False)) for key, state in states.items()]
        try:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                self._db.executemany(
                    "INSERT INTO monitor_state (key, saved_unix_s, state_json) VALUES (?, ?, ?) "
                    "ON CONFLICT(key) DO UPDATE SET saved_unix_s = excluded.saved_unix_s, "
                    "state_json = excluded.state_json", rows)
                if fingerprint is not None:
                    self._db.executemany("INSERT OR REPLACE INTO monitor_fingerprint VALUES (?, ?)",
                                         [(key, json.dumps(fingerprint, sort_keys=True)) for key in states])
            except BaseException:
                self._db.execute("ROLLBACK")
                raise
            self._db.execute("COMMIT")
        except sqlite3.Error as exc:
            raise self._fail(f"cannot be written ({_reason(exc)})",
                             "free disk space or fix its permissions (the monitor keeps its state in memory and "
                             "retries at the next checkpoint)") from None

    def close(self) -> None:
        if self._db is not None:
            self._db.close()
            self._db = None
        if self._lock_fd is not None:
            os.close(self._lock_fd)          # releases the flock
            self._lock_fd = None


#: what a restore of a validated state may still raise (a bug, or a combination the schema cannot see)
_RESTORE_ERRORS = (LookupError, TypeError, ValueError, ArithmeticError, AttributeError, RecursionError)


def resume_monitor(store: StateStore, key: str, fingerprint: dict | None, monitor) -> bool:
    """Restore ``monitor`` (a PrecisionMonitor) from the state of ``key`` in ``store``: validated whole
    against the monitor's fresh state first (models/wear/state_schema.py), then restored and reported once,
    so that a state which would crash the first status is refused here. False when there is no saved state;
    InputError (one line naming the file and what to do) when it is refused."""
    template = monitor.state()
    saved = store.load(key, fingerprint, lambda state: check_precision_state(state, template))
    if saved is None:
        return False
    try:
        monitor.restore(saved)
        monitor.report()
    except _RESTORE_ERRORS as exc:
        raise store._fail(f"the saved state of '{key}' cannot be restored ({_reason(exc)})",
                          "move the file away to start afresh") from None
    return True


def _mapping(state) -> None:
    if not isinstance(state, dict):
        raise InputError(f"state must be a mapping, got {type(state).__name__}")


def resume_with(store: StateStore, key: str, fingerprint: dict | None, restore) -> bool:
    """``restore(saved)`` with the saved mapping of ``key`` (a state without a schema of its own, e.g. an
    axis's maintenance log); False when there is none; whatever ``restore`` raises on a malformed state
    becomes one InputError line naming the file."""
    saved = store.load(key, fingerprint, _mapping)
    if saved is None:
        return False
    try:
        restore(saved)
    except _RESTORE_ERRORS as exc:
        raise store._fail(f"the saved state of '{key}' cannot be restored ({_reason(exc)})",
                          "move the file away to start afresh") from None
    return True
