"""Fleet replay on Dask against a serial run of the same bags (issue 13; not CI).

    .venv/bin/python bench/bench_fleet.py [--bags 16] [--messages 5e5] [--workdir DIR] [--plot] [--no-address]
                                          [--chunk-messages N] [--commands]

Writes (once, cached in --workdir) --bags machine bags of about --messages messages each (JointState at
1 kHz, load at 100 Hz, straightness every 0.05 h; K factors 0.8 .. 1.4), reads every bag file once (so that
no mode pays the disk), then times `fleet replay` of all of them (analysis/fleet.py run_fleet, per-bag PNG
off unless --plot):
  serial      workers=0: one bag after another in this process (no Dask), after one warm-up bag; the bulk
              reader's read-ahead thread is on (the single-bag command as a user runs it);
  local 1/2   a LocalCluster of 1 / 2 worker processes, started and stopped inside the run (what a user
              of `guide-health fleet replay --workers N` waits for; analysis/fleet.py share_cores switches
              the read-ahead thread off where the workers fill the cores);
  pool 2      2 plain forked processes (concurrent.futures, no Dask) running the same per-bag code with the
              same read-ahead setting as local 2: the parallel ceiling of the cores as loaded at the time,
              against which local 2 shows what Dask costs;
  startup     LocalCluster(2) + Client start and close alone (as fleet replay starts them: fork on Linux);
  address     the same bags on an already running LocalCluster(2) (Dask's default spawn start and
              settings, like `dask worker` processes) reached by its scheduler address
              (`--scheduler tcp://...`; client connection included; the cluster is started and warmed up by
              a run of 2 bags before, as a plant's running cluster would be).
For each mode it prints the wall time, the time and the CPU time per bag inside the bag tasks (run_bag), and
the CPU time of the whole mode (this process + its worker processes, per bag): CPU time moves much less
than wall time when other processes load the cores. Speed-ups are over the faster of serial and local 1
(the in-process loop already reads in a thread while it integrates, so it bounds local 2 on 2 cores; the
issue-13 1.7x is over the single-bag command run one bag after another, timed by --commands); the Dask
overhead per bag is (local 1 - startup - serial) / bags and local 1's
wall time outside its bag tasks per bag. The load average is printed before and after: on a shared machine
only the same-run ratios mean anything, and the CPU columns say whether a slowdown was the cores' load
(wall up, CPU not) or the work itself (CPU up).
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
import tempfile
import time
from functools import partial
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

PARAMS = ROOT / "config" / "bench_000.yaml"


def make_bags(n: int, messages: float, workdir: Path) -> list[Path]:
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    params = wear_monitor_params(PARAMS)
    rate_hz = 1000.0
    duration_h = messages / (rate_hz * 1.1) / 3600.0
    bags = []
    for i in range(n):
        bag = workdir / f"fleet_{int(messages)}_{i:02d}"
        bags.append(bag)
        if bag.exists():
            continue
        sim = dict(simulation_params(PARAMS), duration_h=duration_h, joint_state_rate_hz=rate_hz,
                   load_rate_hz=rate_hz / 10, measurement_interval_h=0.05, wear_coefficient_factor=0.8 + 0.04 * i)
        t0 = time.perf_counter()
        run = simulate_machine(params, sim, seed=100 + i)
        write_machine_bag(run, bag, namespace=f"/m{i:02d}")
        print(f"  wrote {run.messages:,} messages to {bag} in {time.perf_counter() - t0:.1f} s", flush=True)
    return bags


def cpu_now() -> float:
    """CPU seconds of this process and of its finished (waited-for) child processes."""
    import resource

    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + kids.ru_utime + kids.ru_stime


class Mode:
    """Wall time, CPU time of the mode (process + children) and its bag entries."""

    def __init__(self, name: str):
        self.name, self.wall, self.cpu, self.entries = name, 0.0, 0.0, []

    def __enter__(self):
        self.t0, self.c0 = time.perf_counter(), cpu_now()
        return self

    def __exit__(self, *exc):
        self.wall, self.cpu = time.perf_counter() - self.t0, cpu_now() - self.c0

    def line(self, base: float | None, note: str = "") -> str:
        n = len(self.entries)
        inside = sum(e["seconds"] for e in self.entries) / n
        cpu_in = sum(e["cpu_s"] for e in self.entries) / n
        ratio = f"  {base / self.wall:5.2f}x" if base else "        "
        return (f"{self.name:<9} {self.wall:7.2f} s{ratio}  per bag: inside {inside:.3f} s, CPU inside {cpu_in:.3f} s, "
                f"CPU of the mode {self.cpu / n:.3f} s{note}")


def check(entries) -> list[dict]:
    failed = [e for e in entries if not e["ok"]]
    if failed:
        raise SystemExit(f"bench: {len(failed)} bags failed: {failed[0]['error']}")
    return entries


def run_pool(bags, out: Path, options, read_ahead: bool) -> list[dict]:
    """The same bags on 2 plain forked processes (concurrent.futures, no Dask): what `xargs -P 2` gives."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from guide_health.analysis.fleet import report_names, run_bag
    from guide_health.cli.fleet import run_single_bag
    from guide_health.io.bag.sqlite3_storage import set_read_ahead

    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork"), initializer=set_read_ahead,
                             initargs=(read_ahead,)) as pool:
        return list(pool.map(run_bag, [partial(run_single_bag, "replay")] * len(bags), [str(b) for b in bags],
                             [str(PARAMS)] * len(bags), [str(out / n) for n in report_names(bags)],
                             [options] * len(bags)))


def process_cpu() -> float:
    """CPU seconds of the calling process (run on the workers of a running cluster)."""
    return time.process_time()


def set_chunk_messages(n: int) -> None:
    """Messages per read/integration batch of the replay (analysis/replay.py analyse_bag's default, 200 000),
    in this process and in the processes forked from it (an experiment: other sizes change the last bits
    of the results, ~1e-13 relative, through the order of the sums)."""
    import guide_health.analysis.replay as replay

    defaults = list(replay.analyse_bag.__defaults__)
    defaults[-1] = int(n)
    replay.analyse_bag.__defaults__ = tuple(defaults)


def warm_page_cache(bags) -> int:
    """Read every file of the bags once (the serial run, first, would otherwise pay the disk)."""
    size = 0
    for bag in bags:
        for f in bag.iterdir():
            with open(f, "rb") as handle:
                while chunk := handle.read(1 << 24):
                    size += len(chunk)
    return size


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bags", type=int, default=16)
    parser.add_argument("--messages", type=float, default=5e5, help="messages per bag (about)")
    parser.add_argument("--workdir", default=str(Path(tempfile.gettempdir()) / "guide_health_bench_fleet"))
    parser.add_argument("--plot", action="store_true", help="per-bag PNG too (default: --no-plot)")
    parser.add_argument("--no-address", action="store_true", help="skip the scheduler-address mode")
    parser.add_argument("--commands", action="store_true",
                        help="also time the commands a user runs: `guide-health replay` per bag one after another "
                             "(a shell loop), the same with 2 at a time (xargs -P 2), and `guide-health fleet replay "
                             "--workers 2` (each a fresh process: imports included)")
    parser.add_argument("--chunk-messages", type=int, default=None,
                        help="messages per batch in every mode (experiment; default: the replay's 200 000)")
    args = parser.parse_args()
    if args.chunk_messages:
        set_chunk_messages(args.chunk_messages)
    from distributed import Client, LocalCluster

    from guide_health.analysis.fleet import dask_client, local_start_method, run_bag, run_fleet, share_cores
    from guide_health.cli.fleet import run_single_bag

    replay = partial(run_single_bag, "replay")

    workdir = Path(args.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    bags = make_bags(args.bags, args.messages, workdir)
    options = () if args.plot else ("--no-plot",)
    out = workdir / "out"
    print(f"{len(bags)} bags, {warm_page_cache(bags) / 2**20:.0f} MiB read into the page cache", flush=True)
    print(f"load average before: {os.getloadavg()}  cpus: {os.cpu_count()}", flush=True)
    run_bag(replay, str(bags[0]), str(PARAMS), str(out / "warmup"), options)      # imports, caches
    modes = {}
    with Mode("serial") as m:
        m.entries = check(run_fleet("replay", replay, bags, str(PARAMS), out / "serial", options, workers=0))
    modes["serial"] = m
    messages = sum(e["result"]["messages"] for e in m.entries)
    print(f"{messages:,} messages; serial {messages / m.wall:,.0f} msg/s", flush=True)
    print(m.line(None), flush=True)
    for workers in (1, 2):
        with Mode(f"local {workers}") as m:
            m.entries = check(run_fleet("replay", replay, bags, str(PARAMS), out / f"local{workers}", options,
                                        workers=workers))
        modes[workers] = m
        if workers == 1:
            base = min(modes["serial"].wall, m.wall)
            print(m.line(None), flush=True)
            print(f"baseline  {base:7.2f} s  (the faster of serial and local 1; speed-ups below are over it)")
    print(modes[2].line(base, "  (over the in-process loop; its ceiling below; issue 13's 1.7x is over the "
                              "single-bag command one bag after another: --commands)"), flush=True)
    t0 = time.perf_counter()
    with dask_client(2, None) as client:
        ahead = share_cores(client)
    startup = time.perf_counter() - t0
    with Mode("pool 2") as m:
        m.entries = check(run_pool(bags, out / "pool", options, all(ahead.values()) if ahead else True))
    modes["pool"] = m
    print(m.line(base, f"  (no Dask; local 2 / pool 2 = {modes[2].wall / m.wall:.2f})"), flush=True)
    print(f"startup   {startup:7.2f} s  (LocalCluster(2) + Client as fleet replay starts them "
          f"({local_start_method()}), start and close; read-ahead in the workers: {sorted(set(ahead.values()))})")
    if not args.no_address:
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                          silence_logs=logging.ERROR) as cluster:
            if args.chunk_messages:
                with Client(cluster) as client:
                    client.run(set_chunk_messages, args.chunk_messages)
            # a plant's cluster keeps running: its spawned workers import the analysis once, before the run
            check(run_fleet("replay", replay, bags[:2], str(PARAMS), out / "address_warmup", options,
                            scheduler=cluster.scheduler_address))
            with Client(cluster) as client:
                workers_cpu = sum(client.run(process_cpu).values())
                with Mode("address") as m:
                    m.entries = check(run_fleet("replay", replay, bags, str(PARAMS), out / "address", options,
                                                scheduler=cluster.scheduler_address))
                m.cpu += sum(client.run(process_cpu).values()) - workers_cpu     # the workers outlive the mode
        print(m.line(base, f"  (running 2-worker cluster at {cluster.scheduler_address}, Dask's default "
                           f"settings, warmed up by 2 bags; address / local 2 = {m.wall / modes[2].wall:.2f})"),
              flush=True)
    n, s, one = len(bags), modes["serial"], modes[1]
    print(f"overhead  {(one.wall - startup - s.wall) / n * 1e3:5.0f} ms per bag ((local 1 - startup - serial) / "
          f"bags); local 1 outside its bag tasks: {(one.wall - sum(e['seconds'] for e in one.entries)) / n * 1e3:.0f}"
          f" ms per bag (startup included); CPU of the mode per bag, local 1 - serial: "
          f"{(one.cpu - s.cpu) / n * 1e3:.0f} ms")
    two_in = sum(e["seconds"] for e in modes[2].entries) / sum(e["seconds"] for e in s.entries)
    two_cpu = sum(e["cpu_s"] for e in modes[2].entries) / sum(e["cpu_s"] for e in s.entries)
    print(f"a bag inside its task with two running (local 2) against serial: {two_in:.2f}x the time, "
          f"{two_cpu:.2f}x the CPU time")
    # the serial run reads the next rowid range in a thread while it decodes this one: it uses more than one
    # core, and two workers on two cores can at best give 2 x serial wall / (CPU time of the 2-worker mode)
    print(f"serial used {s.cpu / s.wall:.2f} cores; 2 cores' ceiling for local 2 with its CPU time: "
          f"{2 * base / modes[2].cpu:.2f}x over the baseline (meaningful on a quiet machine only: load stretches "
          "the serial wall)")
    if args.commands:
        time_commands(bags, out, options)
    print(f"load average after: {os.getloadavg()}")


def time_commands(bags, out: Path, options) -> None:
    """The user's commands, each a fresh process as typed in a shell: the issue's own measurement (8 bags
    one after another 10 s, `xargs -P 2` 5.5 s) made on these bags, against `fleet replay --workers 2`."""
    import subprocess
    from concurrent.futures import ThreadPoolExecutor

    exe = [str(Path(sys.executable).with_name("guide-health"))]

    def one(i_bag):
        i, bag = i_bag
        subprocess.run(exe + ["replay", str(bag), "--params", str(PARAMS), "--out", str(out / "cmd" / str(i)),
                              *options], check=True, capture_output=True)

    walls = {}
    for name, parallel in (("shell loop", 1), ("xargs -P 2", 2)):
        t0 = time.perf_counter()
        with ThreadPoolExecutor(parallel) as pool:
            list(pool.map(one, enumerate(bags)))
        walls[name] = time.perf_counter() - t0
    t0 = time.perf_counter()
    subprocess.run(exe + ["fleet", "replay", *map(str, bags), "--params", str(PARAMS), "--workers", "2",
                          "--out", str(out / "cmd_fleet"), *options], check=True, capture_output=True)
    walls["fleet --workers 2"] = time.perf_counter() - t0
    loop = walls["shell loop"]
    for name, wall in walls.items():
        print(f"{name:<18} {wall:7.2f} s  {loop / wall:5.2f}x the shell loop of `guide-health replay`"
              + ("  <- the issue's serial (one bag after another)" if name == "shell loop" else ""), flush=True)


if __name__ == "__main__":
    main()
