"""Offline replay throughput and memory against the raw rosbags read rate of the same bag (issue 6.1).

    .venv/bin/python bench/bench_replay.py [--sizes 1e6 3e6 10e6] [--storage sqlite3|mcap] [--workdir DIR]

For each size N it writes (once, cached in --workdir) a bench bag of N JointState messages at 1 kHz,
N/10 WrenchStamped at 100 Hz and straightness every 0.05 h, then measures in the same run:
  raw      rosbags Reader.messages() over the whole bag, nothing done with the bytes (the read limit);
  deser    rosbags deserialize_cdr on every message of a 200 k-message sample (the naive decoder);
  replay   `guide-health replay BAG --no-plot --json` in a fresh process: wall time from process start
           to exit (imports, read, decode, model, report) and its peak RSS (wait4 ru_maxrss).
It prints messages/s of each and the ratios replay/raw (target >= 0.5) and replay/deser (target >= 3),
and the replay's time per message across sizes (linear cost: the same us/msg at every size).
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

PARAMS = ROOT / "config" / "bench_000.yaml"


def make_bag(n_joint: int, storage: str, workdir: Path) -> Path:
    from guide_health.io.bag_writer import write_machine_bag
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


def deserialize_rate(bag: Path, sample: int = 200_000) -> float:
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    from rosbags.rosbag2 import Reader

    n = 0
    t0 = time.perf_counter()
    with Reader(bag) as reader:
        for conn, _, raw in reader.messages():
            store.deserialize_cdr(raw, conn.msgtype)
            n += 1
            if n >= sample:
                break
    return n / (time.perf_counter() - t0)


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
        n_raw, t_raw = raw_read_rate(bag)
        deser = deserialize_rate(bag)
        report, wall, rss = replay(bag, workdir)
        assert report["messages"] == n_raw, (report["messages"], n_raw)
        inner = report["read_s"] + report["model_s"]
        rows.append((n_raw, n_raw / t_raw, deser, n_raw / wall, n_raw / inner, wall, rss))
        print(f"  raw rosbags read        {n_raw / t_raw:12,.0f} msg/s   ({t_raw:.2f} s)")
        print(f"  deserialize_cdr loop    {deser:12,.0f} msg/s")
        print(f"  replay end to end       {n_raw / wall:12,.0f} msg/s   ({wall:.2f} s wall, "
              f"read {report['read_s']:.2f} s + model {report['model_s']:.2f} s, peak RSS {rss:.0f} MiB)")
        print(f"  ratio replay/raw        {n_raw / wall / (n_raw / t_raw):12.2f}   (target >= 0.5; "
              f"without process start-up {n_raw / inner / (n_raw / t_raw):.2f})")
        print(f"  ratio replay/deser      {n_raw / wall / deser:12.2f}   (target >= 3)", flush=True)
    print("\nsize [msg]    raw [msg/s]   replay [msg/s]   replay us/msg   peak RSS [MiB]")
    for n, raw, _, rep, _, wall, rss in rows:
        print(f"{n:>10,}   {raw:12,.0f}   {rep:14,.0f}   {wall / n * 1e6:13.2f}   {rss:14.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
