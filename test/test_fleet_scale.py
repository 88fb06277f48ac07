"""A fleet of hundreds, small scale: fleet_monitor's board (models/fleet.FleetBoard) and history
(io/outputs/fleet_history.FleetHistory) fed 200 synthetic machines x 3 axes, one status per axis every
second, for 60 s of simulated time, the way FleetMonitorNode._on_diagnostics_raw and publish_diagnostics call
them. Asserted: the bounds, not the time. The board holds one entry per live status; the history writes one
row per status per history period (plus every level change) and keeps in memory only the statuses of one
period; rows past the retention go at the prune; the machines that fell silent leave the board.

Truth: closed forms written here. With statuses sent at t = 0, 1, ..., T s and history_period_s P, a status
whose level never changes is recorded at t = 0, P, 2P, ..., so floor(T / P) + 1 rows; a status whose level
flips every second, at every second: T + 1 rows."""
from __future__ import annotations

import sqlite3
import tracemalloc

from guide_health.io.outputs.fleet_history import FleetHistory
from guide_health.models.fleet import FleetBoard
from guide_health.models.levels import OK, WARN

MACHINES, AXES, SECONDS, PERIOD_S, RETENTION_S = 200, ("x", "y", "z"), 60, 10.0, 30.0
T0_UNIX_S = 1_800_000_000.0
STATUSES = MACHINES * len(AXES)


def values(m: int) -> dict[str, str]:
    """A wear_monitor precision status's values (30 keys)."""
    v = {f"key_{i:02d}": f"{i * 0.1 + m * 1e-3:.6g}" for i in range(28)}
    v.update(remaining_life_h=f"{800.0 - m:.4f}", straightness_um=f"{6.0 + m * 0.01:.2f}")
    return v


VALUES = [values(m) for m in range(MACHINES)]


def feed(board: FleetBoard, history: FleetHistory, second: int, silent_from: int | None = None) -> None:
    """One second of the fleet: every machine's statuses (machines 100.. silent from ``silent_from``);
    m000's x status flips OK <-> WARN every second; then the node's periodic commit."""
    wall = T0_UNIX_S + second
    for m in range(MACHINES):
        if silent_from is not None and m >= 100 and second >= silent_from:
            continue
        for a in AXES:
            level = (WARN if second % 2 else OK) if (m == 0 and a == "x") else OK
            name = f"m{m:03d}/wear_monitor: {a} precision"
            if board.update(name, f"m{m:03d}", level, "", VALUES[m], float(second)):
                history.record(wall, f"m{m:03d}", name, level, "", VALUES[m])
    history.commit(wall)


def rows_per_status(db) -> dict[tuple[str, str], int]:
    return {(hw, name): n for hw, name, n in
            db.execute("SELECT hardware_id, name, COUNT(*) FROM fleet_history GROUP BY hardware_id, name")}


def test_board_and_history_stay_bounded_under_200_machines_for_60_s(tmp_path):
    board = FleetBoard(stale_after_s=5.0, forget_after_s=20.0, max_statuses=10_000)
    history = FleetHistory(str(tmp_path / "h.db"), PERIOD_S, retention_days=RETENTION_S / 86400.0)
    sizes = []
    for second in range(SECONDS + 1):
        if second == SECONDS - 3:
            tracemalloc.start()                                 # the last 3 s traced (it slows every allocation)
        feed(board, history, second)
        assert len(board.statuses) == STATUSES                 # one entry per status, never more
        assert len(history._last) <= STATUSES and not history._pending
        if second >= SECONDS - 3:
            sizes.append(tracemalloc.get_traced_memory()[0])
    tracemalloc.stop()
    # the heap does not grow with the seconds: 2 s more of 600 statuses a second add less than 64 kB, a
    # tenth of what one second's statuses would take if they were kept (600 copies of 30 values, ~1 MB)
    assert sizes[-1] - sizes[0] < 64_000, sizes
    s = board.summary(float(SECONDS))
    assert (s["machines"], s["statuses"], s["stale"], s["ignored_statuses"]) == (MACHINES, STATUSES, 0, 0)
    rows = rows_per_status(history.db)
    flipping = ("m000", "m000/wear_monitor: x precision")
    assert rows.pop(flipping) == SECONDS + 1                   # every level change is a row
    assert len(rows) == STATUSES - 1 and set(rows.values()) == {SECONDS // int(PERIOD_S) + 1}
    # retention 30 s at t = 60 s: the rows at t < 30 s go (steady statuses: t = 0, 10, 20; flipping: 0..29)
    deleted = history.prune(T0_UNIX_S + SECONDS)
    assert deleted == (STATUSES - 1) * 3 + 30
    assert len(history._last) == STATUSES                      # the period that started at t = 60 s runs
    history.prune(T0_UNIX_S + SECONDS + PERIOD_S)             # ... and is over: nothing kept in memory
    assert history._last == {} and history._last_level == {}
    history.close()
    con = sqlite3.connect(tmp_path / "h.db")
    oldest = T0_UNIX_S + SECONDS + PERIOD_S - RETENTION_S     # the second prune's cut: rows at 40 s and later
    assert con.execute("SELECT MIN(t_unix_s) FROM fleet_history").fetchone()[0] == oldest
    con.close()


def test_silent_machines_leave_the_board_so_it_holds_only_the_live_fleet(tmp_path):
    board = FleetBoard(stale_after_s=5.0, forget_after_s=20.0)
    history = FleetHistory(str(tmp_path / "h.db"), PERIOD_S)
    for second in range(SECONDS + 1):
        feed(board, history, second, silent_from=30)          # machines 100..199 stop at 30 s
        silent_s = second - 29                                  # their last statuses came at 29 s
        if 5 < silent_s <= 20:                                  # silent > 5 s: STALE, still on the board
            assert board.summary(float(second))["stale"] == STATUSES // 2
        if silent_s > 20:                                       # silent > 20 s: gone
            s = board.summary(float(second))
            assert (s["machines"], s["statuses"], s["stale"]) == (100, STATUSES // 2, 0)
    assert board.forgotten == STATUSES // 2
    history.close()
