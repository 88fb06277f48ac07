"""Offline reading against the storage limit (issue 14): replay and diagnose against a plain sqlite3 loop.

    .venv/bin/python bench/bench_read_limit.py [--sizes 3e6] [--hours 20] [--rate 50] [--skip-diagnose]
                                               [--workdir DIR]

For each size N (JointState messages; bags written once by bench_replay.make_bag, cached in --workdir: N
JointState at 1 kHz, N/10 WrenchStamped, straightness every 0.05 h), measured in the same run:
  loop        stdlib sqlite3 `SELECT data FROM messages` over the .db3, one Python row per message
              (the storage limit of a Python reader; the baseline);
  read        in-process iter_machine_bag of the sqlite3 bag: bulk (rowid ranges, packed batches) and
              the previous per-message `ORDER BY timestamp` read; of the mcap bag: packed and per-message
              (bytes) batches;
  replay      `guide-health replay BAG --no-plot --json` in a fresh process (wall from process start to
              exit), sqlite3 and mcap bags of the same messages.
Printed ratios: replay rate / loop rate (target >= 0.5) and mcap replay / sqlite3 replay time (<= 1.5).
Then diagnose on the `bench_diagnose.py` bag (--hours at --rate Hz, running_in hidden): its wall time
against the loop over the same .db3 (target <= 2.5x). No timed assertion: the machine is shared.
"""
from __future__ import annotations

import argparse
import json
import os
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_replay import make_bag, replay  # noqa: E402

PARAMS = ROOT / "config" / "bench_000.yaml"


def loop_time(bag: Path) -> tuple[int, float]:
    """(messages, seconds) of the stdlib loop over the bag's .db3."""
    db = next(bag.glob("*.db3"))
    t0 = time.perf_counter()
    con = sqlite3.connect(db)
    n = 0
    for (_data,) in con.execute("SELECT data FROM messages"):
        n += 1
    con.close()
    return n, time.perf_counter() - t0


def read_time(bag: Path, *, bulk: bool) -> tuple[int, float]:
    """(messages, seconds) of iter_machine_bag in this process; bulk=False: the per-message path."""
    from guide_health.io.bag.mcap_storage import McapStorage
    from guide_health.io.bag.reader import iter_machine_bag
    from guide_health.io.bag.sqlite3_storage import Sqlite3Storage

    saved = (Sqlite3Storage.iter_packed, McapStorage.iter_packed)
    if not bulk:
        Sqlite3Storage.iter_packed = McapStorage.iter_packed = lambda *a: None
    try:
        t0 = time.perf_counter()
        n = sum(run.messages for run in iter_machine_bag(bag))
        return n, time.perf_counter() - t0
    finally:
        Sqlite3Storage.iter_packed, McapStorage.iter_packed = saved


def write_cached(n_joint: int, storage_id: str, workdir: Path) -> Path:
    """The bench bag, written by a child process (bench_replay's reason: a clean peak RSS)."""
    subprocess.run([sys.executable, "-c", f"import sys; sys.path.insert(0, {str(ROOT / 'bench')!r}); "
                    f"from bench_replay import make_bag; from pathlib import Path; "
                    f"make_bag({n_joint}, {storage_id!r}, Path({str(workdir)!r}))"], check=True, cwd=ROOT)
    return make_bag(n_joint, storage_id, workdir)


def bench_size(n_joint: int, workdir: Path) -> None:
    sq, mc = write_cached(n_joint, "sqlite3", workdir), write_cached(n_joint, "mcap", workdir)
    n, t_loop = loop_time(sq)
    print(f"bag of {n:,} messages ({n_joint:,} JointState):")
    print(f"  stdlib SELECT data loop     {t_loop:7.2f} s   {n / t_loop:12,.0f} msg/s   <- baseline")
    for label, bag, bulk in (("sqlite3 read, bulk", sq, True), ("sqlite3 read, per message", sq, False),
                             ("mcap read, chunks", mc, True), ("mcap read, per message", mc, False)):
        got, t = read_time(bag, bulk=bulk)
        assert got == n, (label, got, n)
        print(f"  {label:27s} {t:7.2f} s   {n / t:12,.0f} msg/s   ({t / t_loop:.2f}x the loop)")
    rep_sq, wall_sq, rss_sq = replay(sq, workdir)
    rep_mc, wall_mc, rss_mc = replay(mc, workdir)
    assert rep_sq["messages"] == rep_mc["messages"] == n
    same = {k: rep_sq[k] for k in ("straightness_um", "sliding_distance_m")} == \
        {k: rep_mc[k] for k in ("straightness_um", "sliding_distance_m")}
    print(f"  replay sqlite3, end to end  {wall_sq:7.2f} s   {n / wall_sq:12,.0f} msg/s   (read {rep_sq['read_s']:.2f}"
          f" s + model {rep_sq['model_s']:.2f} s; peak RSS {rss_sq:.0f} MiB)")
    print(f"  replay mcap, end to end     {wall_mc:7.2f} s   {n / wall_mc:12,.0f} msg/s   (read {rep_mc['read_s']:.2f}"
          f" s + model {rep_mc['model_s']:.2f} s; peak RSS {rss_mc:.0f} MiB; same numbers: {same})")
    print(f"  ratio replay rate / loop rate      {t_loop / wall_sq:6.2f}   (target >= 0.5)")
    print(f"  ratio mcap / sqlite3 replay time   {wall_mc / wall_sq:6.2f}   (target <= 1.5)", flush=True)


def bench_diagnose(hours: float, rate: float, workdir: Path) -> None:
    effect = "running_in=2.5"
    bag = workdir / f"diagnose_{hours:g}h_{rate:g}hz_{effect.replace('=', '_')}"   # bench_diagnose.py's bag
    if not bag.exists():
        subprocess.run([sys.executable, "-m", "guide_health.cli", "simulate", "--params", str(PARAMS), "--out",
                        str(bag), "--hours", str(hours), "--rate", str(rate), "--seed", "1", "--effect", effect],
                       check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
    n, t_loop = loop_time(bag)
    cmd = [sys.executable, "-m", "guide_health.cli", "diagnose", str(bag), "--params", str(PARAMS),
           "--out", str(workdir / (bag.name + ".diagnose")), "--json"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, cwd=ROOT)
    stdout = proc.stdout.read()
    _, status, _ = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit("diagnose failed")
    res = json.loads(stdout)
    print(f"diagnose bag {bag.name}: {n:,} messages")
    print(f"  stdlib SELECT data loop     {t_loop:7.2f} s   <- baseline")
    print(f"  diagnose, wall              {wall:7.2f} s   (read -> duty cells {res['read_s']:.2f} s, fit "
          f"{res['fit_s']:.2f} s, report {res['report_s']:.2f} s)")
    print(f"  ratio diagnose / loop time  {wall / t_loop:6.2f}   (target <= 2.5)", flush=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=float, nargs="+", default=[3e6], help="JointState messages per bag")
    ap.add_argument("--hours", type=float, default=20.0, help="diagnose bag duration [h]")
    ap.add_argument("--rate", type=float, default=50.0, help="diagnose bag JointState rate [Hz]")
    ap.add_argument("--skip-diagnose", action="store_true")
    ap.add_argument("--workdir", default="/tmp/guide_health_bench", help="where bags are cached")
    args = ap.parse_args()
    workdir = Path(args.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    print(f"load average at start: {os.getloadavg()[0]:.1f} (2 cores shared)")
    for size in args.sizes:
        bench_size(int(size), workdir)
    if not args.skip_diagnose:
        bench_diagnose(args.hours, args.rate, workdir)
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
