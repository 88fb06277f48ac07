"""Fleet replay on Dask against a serial run of the same bags (issue 13; not CI).

    .venv/bin/python bench/bench_fleet.py [--bags 16] [--messages 5e5] [--workdir DIR] [--plot]

Writes (once, cached in --workdir) --bags machine bags of about --messages messages each (JointState at
1 kHz, load at 100 Hz, straightness every 0.05 h; K factors 0.8 .. 1.4), then times `fleet replay` of all
of them (analysis/fleet.py run_fleet, per-bag PNG off unless --plot):
  serial      workers=0: one bag after another in this process (no Dask), after one warm-up bag;
  local 1/2   a LocalCluster of 1 / 2 worker processes, started and stopped inside the run (what a user
              of `guide-health fleet replay --workers N` waits for);
  pool 2      2 plain forked processes (concurrent.futures, no Dask): the parallel ceiling of the cores as
              loaded at the time, against which local 2 shows what Dask costs;
  startup     LocalCluster(2) + Client start and close alone (as fleet replay starts them: fork on Linux);
  address     the same bags on an already running LocalCluster(2) (Dask's default spawn start, like
              `dask worker` processes) reached by its scheduler address
              (`--scheduler tcp://...`; client connection included, cluster start not).
It prints each wall time and the time spent inside the bag tasks, the speed-ups over serial (target:
2 workers >= 1.7x), the Dask overhead per bag ((local 1 - startup - serial) / bags, and local 1's wall time
outside its bag tasks per bag, which other load on the cores disturbs less) and address mode against local
mode. The machine's load average is
printed before and after: other processes on the cores change every number.
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

PARAMS = ROOT / "config" / "bench_000.yaml"


def make_bags(n: int, messages: float, workdir: Path) -> list[Path]:
    from guide_health.io.bag_writer import write_machine_bag
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


def timed_fleet(bags, out: Path, options, **engine) -> tuple[float, list[dict]]:
    from guide_health.analysis.fleet import run_fleet

    t0 = time.perf_counter()
    entries = run_fleet("replay", bags, str(PARAMS), out, options, **engine)
    wall = time.perf_counter() - t0
    failed = [e for e in entries if not e["ok"]]
    if failed:
        raise SystemExit(f"bench: {len(failed)} bags failed: {failed[0]['error']}")
    return wall, entries


def timed_pool(bags, out: Path, options) -> tuple[float, list[dict]]:
    """The same bags on 2 plain forked processes (concurrent.futures, no Dask): what `xargs -P 2` gives."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from guide_health.analysis.fleet import report_names, run_bag

    t0 = time.perf_counter()
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork")) as pool:
        entries = list(pool.map(run_bag, ["replay"] * len(bags), [str(b) for b in bags], [str(PARAMS)] * len(bags),
                                [str(out / n) for n in report_names(bags)], [options] * len(bags)))
    return time.perf_counter() - t0, entries


def in_task(entries) -> str:
    """The time spent inside the bag tasks (run_bag), against which the wall time shows the overhead."""
    total = sum(e["seconds"] for e in entries)
    return f"[inside the bag tasks {total:.2f} s, {total / len(entries):.2f} s per bag]"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bags", type=int, default=16)
    parser.add_argument("--messages", type=float, default=5e5, help="messages per bag (about)")
    parser.add_argument("--workdir", default=str(Path(tempfile.gettempdir()) / "guide_health_bench_fleet"))
    parser.add_argument("--plot", action="store_true", help="per-bag PNG too (default: --no-plot)")
    args = parser.parse_args()
    from distributed import LocalCluster

    from guide_health.analysis.fleet import dask_client, local_start_method, run_bag

    workdir = Path(args.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    bags = make_bags(args.bags, args.messages, workdir)
    options = () if args.plot else ("--no-plot",)
    out = workdir / "out"
    print(f"load average before: {os.getloadavg()}  cpus: {os.cpu_count()}", flush=True)
    run_bag("replay", str(bags[0]), str(PARAMS), str(out / "warmup"), options)      # imports, caches
    serial, entries = timed_fleet(bags, out / "serial", options, workers=0)
    messages = sum(e["result"]["messages"] for e in entries)
    print(f"serial      {serial:6.2f} s  ({messages:,} messages, {messages / serial:,.0f} msg/s, "
          f"{serial / len(bags):.2f} s per bag) {in_task(entries)}", flush=True)
    local, inside = {}, {}
    for workers in (1, 2):
        local[workers], entries = timed_fleet(bags, out / f"local{workers}", options, workers=workers)
        inside[workers] = sum(e["seconds"] for e in entries)
        print(f"local {workers}     {local[workers]:6.2f} s  speed-up over serial {serial / local[workers]:.2f}x "
              f"{in_task(entries)}", flush=True)
    pool, entries = timed_pool(bags, out / "pool", options)
    print(f"pool 2      {pool:6.2f} s  speed-up over serial {serial / pool:.2f}x (2 forked processes, no Dask: "
          f"the ceiling on these cores now) {in_task(entries)}; local 2 / pool 2 = {local[2] / pool:.2f}",
          flush=True)
    t0 = time.perf_counter()
    with dask_client(2, None):
        pass
    startup = time.perf_counter() - t0
    print(f"startup     {startup:6.2f} s  (LocalCluster(2) + Client as fleet replay starts them "
          f"({local_start_method()}), start and close)", flush=True)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster:
        address, entries = timed_fleet(bags, out / "address", options, scheduler=cluster.scheduler_address)
    print(f"address     {address:6.2f} s  speed-up over serial {serial / address:.2f}x "
          f"(running 2-worker cluster at {cluster.scheduler_address}) {in_task(entries)}", flush=True)
    print(f"overhead    {(local[1] - startup - serial) / len(bags) * 1e3:6.0f} ms per bag "
          "((local 1 - startup - serial) / bags); outside the bag tasks with 1 worker: "
          f"{(local[1] - inside[1]) / len(bags) * 1e3:.0f} ms per bag (startup included)")
    print(f"address vs local 2: {address:.2f} s vs {local[2]:.2f} s (local 2 without its startup: "
          f"{local[2] - startup:.2f} s)")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
