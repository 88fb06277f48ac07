"""A fleet of hundreds on one fleet_monitor: its CPU and memory, the history's growth per day and its
retention, and the trend page of a 30-day history.

    .venv/bin/python bench/bench_fleet_monitor.py [--machines 200] [--axes 3] [--publishers 4] [--seconds 120]
                                                  [--trend-days 30] [--skip-live] [--skip-trend] [--workdir DIR]

Live (an isolated ROS domain, nodes/session.isolated_ros_env): `fleet_monitor` (default parameters:
history_period_s 60, retention 365 d) and --publishers processes that publish, at 1 Hz, one DiagnosticArray
per machine with one "<axis> precision" status per axis (the keys and value texts of a wear_monitor status);
the machines are spread over the publishers and over the second. Measured over --seconds after every machine
is on the board, in the same run:
  fleet_monitor CPU [% of one core] (/proc/<pid>/stat), its RSS (VmRSS) at start and end, the fleet status
  (machines, statuses, STALE), the history's rows and bytes written -> growth per day, the time from the
  publishers' start until the board held every machine (discovery + first second), and as the same-run
  baseline the publishers' own CPU (they build and serialise the same messages fleet_monitor takes apart).
In-process: the board's own memory (tracemalloc of a FleetBoard filled with the same statuses).
Trend: a history of --trend-days days of the same fleet written directly into SQLite (one row per status
every --trend-period s, default 60: fleet_monitor's default history_period_s, 26 M rows for 30 days of 600
statuses, cached in --workdir), `guide-health fleet trend DB --days 30` in a fresh process: wall time (target
< 30 s; the page reads the hourly rows above 500 000 rows); then the retention: the node's hourly prune of
one hour of rows, on a copy (time, rows deleted). The machine's load average is printed at each step. No
timed assertion.
"""
from __future__ import annotations

import argparse
import json
import os
import sqlite3
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_live_node import cpu_seconds  # noqa: E402

FLEET_STATUS = "fleet/fleet_monitor: fleet"
AXES = "xyzab"

PUBLISHER = r'''
import sys, time
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
sys.path.insert(0, sys.argv[5])
from bench_fleet_monitor import status_values
index, count, machines, axes = (int(a) for a in sys.argv[1:5])
seconds = float(sys.argv[6])
rclpy.init()
node = rclpy.create_node(f"fleet_publisher_{index}")
pub = node.create_publisher(DiagnosticArray, "/diagnostics", 100)
mine = [m for m in range(machines) if m % count == index]
arrays = []
for m in mine:
    msg = DiagnosticArray()
    for a in "xyzab"[:axes]:
        values = status_values(m, a)
        msg.status.append(DiagnosticStatus(level=b"\x00", name=f"m{m:03d}/wear_monitor: {a} precision",
                                           message="precision life 812 h", hardware_id=f"m{m:03d}",
                                           values=[KeyValue(key=k, value=v) for k, v in values.items()]))
    arrays.append(msg)
while pub.get_subscription_count() < 1:
    time.sleep(0.05)
print("start", flush=True)
start = time.monotonic()
k = 0
try:
    while time.monotonic() - start < seconds:
        for i, msg in enumerate(arrays):
            due = start + k + (i + index / count) / max(len(arrays), 1)
            delay = due - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            msg.header.stamp = node.get_clock().now().to_msg()
            pub.publish(msg)
        k += 1
except Exception:          # stopped by the bench (SIGTERM invalidates the context)
    pass
'''


def status_values(machine: int, axis: str) -> dict[str, str]:
    """The key/value texts of one wear_monitor precision status (the keys the node publishes)."""
    from guide_health.nodes.axis_channel import EXTRA_PRECISION_KEYS, PRECISION_KEYS

    values = {k: f"{0.1 * (i + 1) + machine * 1e-3:.6g}" for i, k in enumerate(PRECISION_KEYS + EXTRA_PRECISION_KEYS)}
    values.update(remaining_life_h=f"{800.0 - machine:.1f}", straightness_um=f"{6.0 + machine * 0.01:.2f}",
                  guide="front", last_maintenance="")
    # the limit dates as the node publishes them (ISO-8601 UTC dates), so the page's plan reads real dates
    for key, month in zip(("limit_date_utc_low", "limit_date_utc", "limit_date_utc_high"), range(machine, machine + 3)):
        values[key] = f"{2027 + month // 12}-{1 + month % 12:02d}-{1 + machine % 28:02d}"
    return values


def filled_board_bytes(machines: int, axes: int) -> tuple[int, int]:
    """(bytes, statuses) tracemalloc counts for a FleetBoard holding every machine's statuses."""
    from guide_health.models.fleet import FleetBoard

    values = {(m, a): status_values(m, a) for m in range(machines) for a in AXES[:axes]}
    tracemalloc.start()
    base = tracemalloc.get_traced_memory()[0]
    board = FleetBoard(stale_after_s=10.0, forget_after_s=86400.0)
    for (m, a), v in values.items():
        board.update(f"m{m:03d}/wear_monitor: {a} precision", f"m{m:03d}", 0, "precision life 812 h", v, 0.0)
    used = tracemalloc.get_traced_memory()[0] - base
    tracemalloc.stop()
    return used, len(board.statuses)


def rss_mib(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def history_rows(db: Path) -> int:
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        return con.execute("SELECT COUNT(*) FROM fleet_history").fetchone()[0]
    finally:
        con.close()


def bytes_per_row(db: Path) -> tuple[float, int]:
    """(file bytes per row, rows) of a history once its WAL is checkpointed into the file."""
    con = sqlite3.connect(db)
    try:
        con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        rows = con.execute("SELECT COUNT(*) FROM fleet_history").fetchone()[0]
    finally:
        con.close()
    return db.stat().st_size / max(rows, 1), rows


BARE = r'''
import sys, time
import rclpy
from rclpy.experimental import EventsExecutor
from diagnostic_msgs.msg import DiagnosticArray
rclpy.init()
node = rclpy.create_node("bench_fleet_bare")
count = [0]
def on_raw(raw):
    count[0] += 1
node.create_subscription(DiagnosticArray, "/diagnostics", on_raw, 100, raw=True)
executor = EventsExecutor()
executor.add_node(node)
print("start", flush=True)
try:
    while rclpy.ok():
        executor.spin_once(timeout_sec=0.1)
except Exception:          # stopped by the bench
    pass
'''


def start_bare(env) -> subprocess.Popen:
    """The floor: a bare rclpy process with fleet_monitor's subscription (raw, depth 100, the events executor's
    spin_once loop) whose callback only counts."""
    proc = subprocess.Popen([sys.executable, "-c", BARE], env=env, stdout=subprocess.PIPE, text=True, cwd=ROOT)
    while not proc.stdout.readline().startswith("start"):
        pass
    return proc


def start_publishers(args, env) -> list[subprocess.Popen]:
    procs = [subprocess.Popen([sys.executable, "-c", PUBLISHER, str(i), str(args.publishers), str(args.machines),
                               str(args.axes), str(ROOT / "bench"), str(args.seconds + 60.0)],
                              env=env, stdout=subprocess.PIPE, text=True, cwd=ROOT)
             for i in range(args.publishers)]
    for p in procs:
        while not p.stdout.readline().startswith("start"):
            pass
    return procs


def stop_all(procs) -> None:
    for p in procs:
        if p.poll() is None:
            p.terminate()
    for p in procs:
        try:
            p.wait(timeout=20)
        except subprocess.TimeoutExpired:
            p.kill()


def live(args, workdir: Path) -> None:
    from guide_health.nodes.session import (
        DiagnosticsCollector,
        clean_fastdds_shm,
        isolated_ros_env,
        start_node,
        stop_node,
    )

    env = isolated_ros_env()
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    db = workdir / "live_history.db"
    for p in workdir.glob("live_history.db*"):
        p.unlink()
    statuses = args.machines * args.axes
    print(f"live: {args.machines} machines x {args.axes} axes = {statuses} statuses at 1 Hz from "
          f"{args.publishers} publisher processes, domain {env['ROS_DOMAIN_ID']} (load {os.getloadavg()[0]:.1f})",
          flush=True)
    collector = DiagnosticsCollector("bench_fleet_collector")
    node = start_node("guide_health.nodes.fleet_monitor", None,
                      {"machine_id": "fleet", "history_file": str(db), "max_statuses": 10000}, env,
                      workdir / "fleet_monitor.log")
    pubs = []
    bare = start_bare(env) if args.floor else None
    try:
        if collector.wait_for(FLEET_STATUS, timeout=60) is None:
            raise SystemExit(f"no fleet status: {(workdir / 'fleet_monitor.log').read_text()[-800:]}")
        rss0 = rss_mib(node.pid)
        t_start = time.monotonic()
        pubs = start_publishers(args, env)
        full = collector.wait_for(FLEET_STATUS, lambda s: float(s["values"]["statuses"]) >= statuses, timeout=120)
        t_full = time.monotonic() - t_start
        if full is None:
            raise SystemExit(f"the board never held {statuses} statuses: {collector.get(FLEET_STATUS)}")
        rows0 = history_rows(db)
        cpu0, t0 = cpu_seconds(node.pid), time.monotonic()
        pub_cpu0 = sum(cpu_seconds(p.pid) for p in pubs)
        bare0 = cpu_seconds(bare.pid) if bare else 0.0
        time.sleep(args.seconds)
        cpu1, t1 = cpu_seconds(node.pid), time.monotonic()
        bare1 = cpu_seconds(bare.pid) if bare else 0.0
        pub_cpu1 = sum(cpu_seconds(p.pid) for p in pubs)
        rows1 = history_rows(db)
        status = collector.get(FLEET_STATUS)
        rss1 = rss_mib(node.pid)
    finally:
        stop_all(pubs + ([bare] if bare else []))
        stop_node(node)
        collector.close()
        clean_fastdds_shm()
    per_row, rows = bytes_per_row(db)
    v = status["values"]
    window = t1 - t0
    per_day = 86400.0 / window
    print(f"  board full {t_full:.1f} s after the publishers started (discovery + the first second)")
    print(f"  fleet status: {v['machines']} machines, {v['statuses']} statuses, {v['stale']} STALE, "
          f"{v['ignored_statuses']} ignored")
    print(f"  fleet_monitor CPU {100.0 * (cpu1 - cpu0) / window:.1f} % of one core over {window:.0f} s "
          f"({1e6 * (cpu1 - cpu0) / (window * statuses):.0f} us per status; target < 10 %); publishers "
          f"{100.0 * (pub_cpu1 - pub_cpu0) / window:.1f} % together")
    if bare:
        print(f"  floor: a bare raw subscriber of the same topic {100.0 * (bare1 - bare0) / window:.1f} % of one "
              f"core; fleet_monitor / floor {(cpu1 - cpu0) / max(bare1 - bare0, 1e-9):.2f}")
    print(f"  fleet_monitor RSS {rss0:.0f} MiB before the fleet, {rss1:.0f} MiB with it")
    print(f"  history: {rows1 - rows0:,} rows in {window:.0f} s -> {(rows1 - rows0) * per_day / 1e6:.2f} M rows/day "
          f"(history_period_s 60: {statuses * 1440 / 1e6:.2f} M expected); {per_row:.0f} bytes per row in the "
          f"file ({rows:,} rows) -> {(rows1 - rows0) * per_day * per_row / 1e9:.2f} GB/day, "
          f"{(rows1 - rows0) * per_day * per_row * 365 / 1e12:.2f} TB at the default retention of 365 d", flush=True)


def write_history(db: Path, machines: int, axes: int, days: float, period_s: float,
                  t_end: float | None = None) -> int:
    """A fleet history of ``days``: one row per status every period_s, the remaining life falling 0.5-1.5 h per
    h (the level WARN below 200 h, ERROR below 100 h), generated inside SQLite (a recursive CTE of the time
    steps crossed with the statuses), so 26 M rows (30 days x 600 statuses at 60 s) take minutes."""
    from guide_health.io.outputs.fleet_history import HISTORY_SCHEMA, ROLL_UP, VALUE_COLUMNS, history_row

    con = sqlite3.connect(db)
    con.executescript(HISTORY_SCHEMA)
    t_end = time.time() if t_end is None else t_end
    steps = int(days * 86400.0 / period_s)
    con.execute(f"CREATE TEMP TABLE s (m, hardware_id, name, {', '.join(VALUE_COLUMNS)})")
    for m in range(machines):
        for a in AXES[:axes]:
            row = history_row(0.0, f"m{m:03d}", f"wear_monitor: {a} precision", 0, "", status_values(m, a))
            con.execute(f"INSERT INTO s VALUES ({', '.join('?' * (3 + len(VALUE_COLUMNS)))})", (m, *row[1:3], *row[5:]))
    # the level from the unrounded life, the column to 0.1 h as the node's text has it
    life = "(800.0 - s.m - k.k * :period / 3600.0 * (0.5 + s.m * 1.0 / :machines))"
    values = ", ".join(f"ROUND({life}, 1)" if c == "remaining_life_h" else f"s.{c}" for c in VALUE_COLUMNS)
    con.execute(f"""WITH RECURSIVE k(k) AS (SELECT 0 UNION ALL SELECT k + 1 FROM k WHERE k + 1 < :steps)
                    INSERT INTO fleet_history SELECT :t_end - (:steps - k.k) * :period, s.hardware_id, s.name,
                        CASE WHEN {life} > 200 THEN 0 WHEN {life} > 100 THEN 1 ELSE 2 END, '', {values}
                    FROM k CROSS JOIN s ORDER BY k.k, s.rowid""",
                {"period": period_s, "machines": machines, "steps": steps, "t_end": t_end})
    con.execute(ROLL_UP, (0,))          # the hourly rows, as fleet_monitor keeps them at each commit
    con.commit()
    n = con.execute("SELECT COUNT(*) FROM fleet_history").fetchone()[0]
    con.close()
    return n


def trend(args, workdir: Path) -> None:
    from guide_health.io.outputs.fleet_history import FleetHistory

    db = workdir / f"history_{args.machines}x{args.axes}_{args.trend_days:g}d_{args.trend_period:g}s.db"
    if not db.exists():
        t0 = time.perf_counter()
        part = db.with_suffix(".part")
        part.unlink(missing_ok=True)
        rows = write_history(part, args.machines, args.axes, args.trend_days, args.trend_period)
        part.rename(db)
        print(f"trend: wrote {rows:,} rows ({db.stat().st_size / 1e6:.0f} MB) in {time.perf_counter() - t0:.0f} s")
    cmd = [sys.executable, "-m", "guide_health.cli", "fleet", "trend", str(db), "--days", str(args.trend_days),
           "--out", str(workdir / "trend"), "--json"]
    print(f"trend page of {args.trend_days:g} days x {args.machines} machines, a row per status every "
          f"{args.trend_period:g} s (load {os.getloadavg()[0]:.1f}):",
          flush=True)
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=ROOT)
    out, err = proc.communicate()
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        print(f"  fleet trend failed ({proc.returncode}): {err.decode()[-400:]}")
        return
    result = json.loads(out)
    print(f"  {result['machines']} machines, {result['rows']:,} rows read {result.get('resolution', 'rows')}: "
          f"{wall:.1f} s wall (target < 30 s), page {Path(result['files']['html']).stat().st_size / 1e6:.1f} MB",
          flush=True)
    # the node's steady state: an hourly prune deletes the hour of rows that just passed the retention
    copy = workdir / "retention.db"
    subprocess.run(["cp", str(db), str(copy)], check=True)
    newest = sqlite3.connect(copy).execute("SELECT MAX(t_last) FROM fleet_history_hourly").fetchone()[0]
    history = FleetHistory(str(copy), 60.0, retention_days=args.trend_days - 1.0 / 24.0)
    t0 = time.perf_counter()
    deleted = history.prune(newest)
    dt = time.perf_counter() - t0
    history.close()
    print(f"  retention: the hourly prune (retention {args.trend_days:g} d - 1 h) deleted {deleted:,} rows in "
          f"{dt:.2f} s")
    copy.unlink()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--machines", type=int, default=200)
    ap.add_argument("--axes", type=int, default=3, choices=range(1, 6))
    ap.add_argument("--publishers", type=int, default=4)
    ap.add_argument("--seconds", type=float, default=120.0)
    ap.add_argument("--trend-days", type=float, default=30.0)
    ap.add_argument("--trend-period", type=float, default=60.0,
                    help="seconds between a status's rows in the generated history (fleet_monitor's "
                         "history_period_s; at 60 s, 30 days of 600 statuses are 26 M rows, 4.2 GB)")
    ap.add_argument("--skip-live", action="store_true")
    ap.add_argument("--floor", action="store_true",
                    help="also run a bare raw subscriber of /diagnostics beside the node (the floor's CPU)")
    ap.add_argument("--skip-trend", action="store_true")
    ap.add_argument("--workdir", type=Path, default=Path(tempfile.gettempdir()) / "guide_health_fleet_bench")
    args = ap.parse_args()
    args.workdir.mkdir(parents=True, exist_ok=True)
    print(f"load average at start: {os.getloadavg()[0]:.1f} (on {os.cpu_count()} cores)", flush=True)
    used, n = filled_board_bytes(args.machines, args.axes)
    print(f"board memory: {used / 1e6:.2f} MB for {n} statuses ({used / n / 1e3:.1f} kB per status; tracemalloc)")
    if not args.skip_live:
        live(args, args.workdir)
    if not args.skip_trend:
        trend(args, args.workdir)
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
