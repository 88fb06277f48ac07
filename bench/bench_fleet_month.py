"""A month of a fleet on Dask: `guide-health fleet replay --scheduler` over 20 machines' months on a cluster of
2 worker processes started as a user starts them, against the same command without Dask, in the same run.

    .venv/bin/python bench/bench_fleet_month.py [--machines 20] [--messages 5e5] [--files 5] [--take 1]
                                                [--workdir DIR]

Each machine's month (cached in --workdir) is one rosbag2 bag split into --files storage files by log time
(one metadata.yaml over several .db3, as `ros2 bag record --max-bag-duration` leaves a long recording),
cut from a bench run of about --messages messages (bench_fleet.make_bags: JointState at 1 kHz, load at
100 Hz, straightness every 0.05 h, K factors 0.8 .. 1.56 over the machines, namespace /mNN). A real month is
~100 M messages a machine; --messages scales it down (the rates are per message; say which was run).
Measured in the same run, each a fresh `guide-health fleet replay DIR --params P --no-plot --json` process:
  serial    --workers 0: every machine through the single-bag command one after another in one process
            (the baseline; its results are the single runs the cluster's must equal);
  cluster   --scheduler tcp://127.0.0.1:PORT of a cluster started before by the console scripts of the venv,
            `dask scheduler --host 127.0.0.1 --port 0 --scheduler-file F` and two `dask worker
            --scheduler-file F --nworkers 1 --nthreads 1` processes (left running: a plant's cluster is up
            before the job; their start is timed apart).
Also one machine through `guide-health replay` alone (a user's single run): equal to its fleet entries.
Printed: wall time and messages/s of each, the speed-up cluster / serial, the CPU of the workers and of the
command, equality of every machine's result (analysis/fleet.same_result: all but timings and paths), the load.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_live_node import cpu_seconds  # noqa: E402
from bench_month import cut_bag, time_edges  # noqa: E402

PARAMS = ROOT / "config" / "bench_000.yaml"
VENV_BIN = Path(sys.executable).parent


def build_fleet(machines: int, messages: float, files: int, workdir: Path, take: float = 1.0) -> Path:
    """The fleet directory: one split bag (``files`` storage files) per machine, cached; ``take`` < 1: only
    the first fraction of each bench run's time span (a smaller month from the same cached runs)."""
    fleet = workdir / (f"fleet_month_{int(messages)}_{machines}x{files}" + (f"_take{take:g}" if take < 1 else ""))
    bags = [fleet / f"m{i:02d}" for i in range(machines)]
    if all(b.exists() for b in bags):
        return fleet
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", f"import sys; sys.path.insert(0, {str(ROOT / 'bench')!r}); "
                    f"from bench_fleet import make_bags; from pathlib import Path; "
                    f"make_bags({machines}, {messages!r}, Path({str(workdir)!r}))"], check=True, cwd=ROOT)
    fleet.mkdir(parents=True, exist_ok=True)
    for i, bag in enumerate(bags):
        if not bag.exists():
            src = workdir / f"fleet_{int(messages)}_{i:02d}"
            edges = time_edges(src, 1)
            end = edges[0] + int((edges[1] - edges[0]) * take)
            cut_bag(src, [edges[0] + (end - edges[0]) * k // files for k in range(files)] + [end], bag)
    print(f"  built {machines} machine months of {files} files under {fleet} in {time.perf_counter() - t0:.0f} s",
          flush=True)
    return fleet


def fleet_replay(fleet: Path, out: Path, extra: list[str]) -> tuple[dict, float, float]:
    """(JSON result, wall s, CPU s of the command's process and its children) of one fleet replay."""
    cmd = [sys.executable, "-m", "guide_health.cli", "fleet", "replay", str(fleet), "--params", str(PARAMS),
           "--out", str(out), "--no-plot", "--json", *extra]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, cwd=ROOT)
    stdout = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"fleet replay {extra} failed: exit {os.waitstatus_to_exitcode(status)}")
    return json.loads(stdout), wall, usage.ru_utime + usage.ru_stime


def start_cluster(tmp: Path, env: dict) -> tuple[str, list[subprocess.Popen], float]:
    """`dask scheduler` + 2 `dask worker` processes (the venv's console scripts): (address, processes, start s)."""
    sched_file = tmp / "scheduler.json"
    logs = open(tmp / "cluster.log", "w")
    t0 = time.perf_counter()
    procs = [subprocess.Popen([str(VENV_BIN / "dask"), "scheduler", "--host", "127.0.0.1", "--port", "0",
                               "--dashboard-address", "127.0.0.1:0", "--scheduler-file", str(sched_file)],
                              env=env, stdout=logs, stderr=subprocess.STDOUT, cwd=ROOT)]
    while not sched_file.exists():
        time.sleep(0.1)
    time.sleep(0.5)
    address = json.loads(sched_file.read_text())["address"]
    for k in range(2):
        procs.append(subprocess.Popen([str(VENV_BIN / "dask"), "worker", "--scheduler-file", str(sched_file),
                                       "--nworkers", "1", "--nthreads", "1", "--no-dashboard",
                                       "--name", f"bench-worker-{k}"],
                                      env=env, stdout=logs, stderr=subprocess.STDOUT, cwd=ROOT))
    from distributed import Client

    with Client(address, timeout=60) as client:
        client.wait_for_workers(2, timeout=120)
    return address, procs, time.perf_counter() - t0


def tree_cpu(pid: int) -> float:
    """CPU seconds of a process and of its live descendants (a dask worker's nanny runs the worker)."""
    total = cpu_seconds(pid)
    for child in Path(f"/proc/{pid}/task").glob("*/children"):
        for kid in child.read_text().split():
            try:
                total += tree_cpu(int(kid))
            except (FileNotFoundError, ProcessLookupError):
                pass
    return total


def compare(a: dict, b: dict) -> tuple[int, int]:
    """(machines with equal results, machines) of two fleet results, entries matched by bag."""
    from guide_health.analysis.fleet import same_result

    by_bag = {Path(e["bag"]).name: e for e in b["results"]}
    same = sum(same_result(e["result"], by_bag[Path(e["bag"]).name]["result"]) for e in a["results"])
    return same, len(a["results"])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--machines", type=int, default=20)
    ap.add_argument("--messages", type=float, default=5e5, help="messages of one machine's month")
    ap.add_argument("--files", type=int, default=5, help="storage files of one machine's month")
    ap.add_argument("--take", type=float, default=1.0,
                    help="use the first fraction of each machine's cached run (scales the month down)")
    ap.add_argument("--workdir", type=Path, default=Path(tempfile.gettempdir()) / "guide_health_bench")
    args = ap.parse_args()
    args.workdir.mkdir(parents=True, exist_ok=True)
    print(f"load average at start: {os.getloadavg()[0]:.1f} (on {os.cpu_count()} cores)", flush=True)
    fleet = build_fleet(args.machines, args.messages, args.files, args.workdir, args.take)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        address, procs, start_s = start_cluster(tmp, env)
        try:
            print(f"cluster {address} (dask scheduler + 2 dask worker processes) up in {start_s:.1f} s", flush=True)
            serial, wall_s, cpu_s = fleet_replay(fleet, tmp / "serial", ["--workers", "0"])
            w0 = sum(tree_cpu(p.pid) for p in procs)
            dask, wall_d, cpu_d = fleet_replay(fleet, tmp / "dask", ["--scheduler", address])
            workers_cpu = sum(tree_cpu(p.pid) for p in procs) - w0
        finally:
            for p in procs[::-1]:
                p.terminate()
            for p in procs:
                try:
                    p.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    p.kill()
        one = serial["results"][0]
        single = subprocess.run([sys.executable, "-m", "guide_health.cli", "replay", one["bag"], "--params",
                                 str(PARAMS), "--out", str(tmp / "single"), "--no-plot", "--json"],
                                capture_output=True, text=True, cwd=ROOT)
    from guide_health.analysis.fleet import same_result

    n = sum(e["result"]["messages"] for e in serial["results"] if e["ok"])
    same, total = compare(dask, serial)
    single_same = single.returncode == 0 and same_result(json.loads(single.stdout), one["result"])
    print(f"{args.machines} machines x a month of {args.messages * args.take:,.0f} messages in {args.files} files = "
          f"{n:,} messages (load {os.getloadavg()[0]:.1f}):")
    print(f"  serial  (--workers 0)   {wall_s:7.1f} s  {n / wall_s:10,.0f} msg/s  CPU {cpu_s:.1f} s   <- baseline")
    print(f"  cluster (--scheduler)   {wall_d:7.1f} s  {n / wall_d:10,.0f} msg/s  CPU: workers {workers_cpu:.1f} s, "
          f"command {cpu_d:.1f} s")
    print(f"  speed-up cluster / serial  {wall_s / wall_d:5.2f}x  (ceiling on 2 cores: 2.0x over a one-core serial "
          f"run; the serial run used {cpu_s / wall_s:.2f} cores)")
    print(f"  ok: serial {serial['ok']}/{serial['bags']}, cluster {dask['ok']}/{dask['bags']}; equal results "
          f"{same}/{total}; `guide-health replay {Path(one['bag']).name}` alone equal: {single_same}")
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
