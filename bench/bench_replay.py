"""Offline replay throughput and memory against the read limit of the same bag (issue 6.1, issue 17).

    .venv/bin/python bench/bench_replay.py [--sizes 1e6 3e6 10e6] [--storage sqlite3|mcap] [--workdir DIR]

For each size N it writes (once, cached in --workdir) a bench bag of N JointState messages at 1 kHz,
N/10 WrenchStamped at 100 Hz and straightness every 0.05 h, then measures in the same run, every figure
over every message of the bag:
  limit    the read limit (bench/read_limit.py): stdlib sqlite3 `SELECT data FROM messages`, or a minimal
           mcap chunk scan; nothing decoded (replay cannot be faster than this);
  rosbags  rosbags Reader.messages() over the whole bag, opening included (for reference);
  deser    the naive decoder: rosbags Reader (opening included) + deserialize_cdr on every message;
  replay   `guide-health replay BAG --no-plot --json` in a fresh process: wall time from process start
           to exit (imports, read, decode, model, report) and its peak RSS (wait4 ru_maxrss).
It prints messages/s of each and the ratios replay/limit and replay/deser, and the replay's time per
message across sizes (linear cost: the same us/msg at every size).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from read_limit import read_limit  # noqa: E402

PARAMS = ROOT / "config" / "bench_000.yaml"


def make_bag(n_joint: int, storage: str, workdir: Path) -> Path:
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    bag = workdir / f"replay_{n_joint}_{storage}"
    if bag.exists():
        return bag
    params = wear_monitor_params(PARAMS)
    rate_hz = 1000.0
    sim = dict(simulation_params(PARAMS), duration_h=n_joint / rate_hz / 3600.0, joint_state_rate_hz=rate_hz,
               load_rate_hz=rate_hz / 10, measurement_interval_h=0.05)
    t0 = time.perf_counter()
    run = simulate_machine(params, sim, seed=1)
    write_machine_bag(run, bag, storage=storage)
    print(f"  wrote {run.messages:,} messages to {bag} in {time.perf_counter() - t0:.1f} s", flush=True)
    return bag


def raw_read_rate(bag: Path) -> tuple[int, float]:
    from rosbags.rosbag2 import Reader

    t0 = time.perf_counter()
    n = 0
    with Reader(bag) as reader:
        for _ in reader.messages():
            n += 1
    return n, time.perf_counter() - t0


def deserialize_rate(bag: Path) -> tuple[int, float]:
    """(messages, msg/s) of the naive decoder over the whole bag: rosbags Reader (its opening included)
    and deserialize_cdr on every message. Counted over the same messages as the replay, so the ratio
    does not grow with the bag (a sample after a whole-bag opening scan did: 6.9 -> 13.6 -> 32.5)."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    n = 0
    t0 = time.perf_counter()
    with Reader(bag) as reader:
        for conn, _, raw in reader.messages():
            store.deserialize_cdr(raw, conn.msgtype)
            n += 1
    return n, n / (time.perf_counter() - t0)


def replay(bag: Path, workdir: Path) -> tuple[dict, float, float]:
    """(report, wall s, peak RSS MiB) of `guide-health replay` in a fresh process."""
    out = workdir / (bag.name + ".report")
    cmd = [sys.executable, "-m", "guide_health.cli", "replay", str(bag), "--params", str(PARAMS),
           "--out", str(out), "--no-plot", "--json"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, cwd=ROOT)
    stdout = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"replay failed with exit code {proc.returncode}")
    return json.loads(stdout), wall, usage.ru_maxrss / 1024.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=float, nargs="+", default=[1e6, 3e6], help="JointState messages per bag")
    ap.add_argument("--storage", choices=("sqlite3", "mcap"), default="sqlite3")
    ap.add_argument("--workdir", default="/tmp/guide_health_bench", help="where bags are cached")
    args = ap.parse_args()
    workdir = Path(args.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    rows = []
    for size in args.sizes:
        n_joint = int(size)
        print(f"bag with {n_joint:,} JointState ({args.storage}):", flush=True)
        # written by a child process: a bench process grown by the simulation would inflate the replay's
        # peak RSS (a forked child reports its parent's pages as its own ru_maxrss until exec)
        subprocess.run([sys.executable, "-c", f"import sys; sys.path.insert(0, {str(ROOT / 'bench')!r}); "
                        f"from bench_replay import make_bag; from pathlib import Path; "
                        f"make_bag({n_joint}, {args.storage!r}, Path({str(workdir)!r}))"], check=True, cwd=ROOT)
        bag = make_bag(n_joint, args.storage, workdir)          # cached: returns the path
        n_lim, t_lim, what = read_limit(bag)
        n_raw, t_raw = raw_read_rate(bag)
        n_deser, deser = deserialize_rate(bag)
        report, wall, rss = replay(bag, workdir)
        assert report["messages"] == n_lim == n_raw == n_deser, (report["messages"], n_lim, n_raw, n_deser)
        inner = report["read_s"] + report["model_s"]
        lim = n_lim / t_lim
        rows.append((n_lim, lim, deser, n_lim / wall, n_lim / inner, wall, rss))
        print(f"  read limit              {lim:12,.0f} msg/s   ({t_lim:.2f} s; {what})")
        print(f"  rosbags Reader          {n_raw / t_raw:12,.0f} msg/s   ({t_raw:.2f} s)")
        print(f"  rosbags + deserialize   {deser:12,.0f} msg/s   (every message)")
        print(f"  replay end to end       {n_lim / wall:12,.0f} msg/s   ({wall:.2f} s wall, "
              f"read {report['read_s']:.2f} s + model {report['model_s']:.2f} s, peak RSS {rss:.0f} MiB)")
        print(f"  ratio replay/limit      {n_lim / wall / lim:12.2f}   (without process start-up "
              f"{n_lim / inner / lim:.2f})")
        print(f"  ratio replay/deser      {n_lim / wall / deser:12.2f}", flush=True)
    print("\nsize [msg]  limit [msg/s]   replay [msg/s]   replay/limit   replay/deser   replay us/msg   peak RSS [MiB]")
    for n, lim, deser, rep, _, wall, rss in rows:
        print(f"{n:>10,}   {lim:12,.0f}   {rep:14,.0f}   {rep / lim:12.2f}   {rep / deser:12.2f}   "
              f"{wall / n * 1e6:13.2f}   {rss:14.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
