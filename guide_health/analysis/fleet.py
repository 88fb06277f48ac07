"""Fleet replay/diagnose: many bags through the single-bag commands on Dask, and the combined table.

Each bag goes through the very command a user runs on one bag (``guide-health replay`` /
``guide-health diagnose``), given by the caller as a callable ``run_one(bag, params_files, out, options) ->
result`` (cli/fleet.py: the command parsed with its own options), in a Dask worker process, writing its
report directory ``OUT/bags/<name>/`` as that command would. The engine is either a local cluster of
worker processes (``LocalCluster(processes=True)``, started and stopped here: no server to run) or an
existing Dask distributed scheduler given by address (``tcp://host:port``); ``workers=0`` runs the bags one
after another in this process (no Dask; for debugging and the benchmark's serial baseline).

The machine of a bag (docs/fleet.md): ``machine_id`` of the bag's run metadata if it has one, else the
namespace of its topics (``/m1/joint_states`` -> ``m1``), else the bag directory's name.

A bag that fails (bad bag, bad data) is a row with its one-line error; the others complete.
"""
from __future__ import annotations

import contextlib
import importlib.util
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from guide_health.errors import InputError
from guide_health.io.bag.info import bag_topic_types
from guide_health.io.bag.metadata import one_line, read_run_metadata
from guide_health.io.bag.sqlite3_storage import set_read_ahead

#: one bag through a single-bag command: run_one(bag, params files, report directory, options) -> its JSON-able
#: result; raises on failure (a module-level function or a partial of one: Dask pickles it by reference)
RunOneBag = Callable[[str, tuple[str, ...], str, tuple[str, ...]], dict[str, Any]]
#: modules the single-bag commands import when they run: imported before forking local workers
PRELOAD = {"replay": ("guide_health.io.bag.reader", "guide_health.io.outputs.progress"),
           "diagnose": ("guide_health.analysis.discrepancy.workflow", "guide_health.analysis.discrepancy.duty",
                        "guide_health.analysis.discrepancy.report", "guide_health.io.outputs.progress")}
#: Dask settings of the local cluster the command starts: its diagnostics (the stack profiler sampling every
#: 10 ms, the 20 ms event-loop tick, system and memory monitors at 0.5 / 0.1 s) serve a dashboard this
#: cluster does not have. Measured alternating on 16 bags of 0.5 M messages, 2 workers: 322-330 against
#: 357-396 ms CPU per bag in the workers and 11-13 against 24-44 ms in the command's process.
LOCAL_CLUSTER_CONFIG = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "500ms",
                        "distributed.admin.system-monitor.interval": "2s",
                        "distributed.admin.system-monitor.gil.enabled": False,
                        "distributed.worker.memory.monitor-interval": "1s"}
#: matplotlib's heavy part (0.34 s to import), preloaded when the bags' PNGs are drawn; without switching the
#: caller's backend (the commands choose Agg themselves)
PLOT_PRELOAD = ("matplotlib.figure", "matplotlib.backends.backend_agg")
#: keys of a per-bag result that are timings or paths (differ between runs of the same bag)
VOLATILE_KEYS = ("read_s", "model_s", "fit_s", "report_s", "total_s", "files")


def is_bag_dir(path: Path) -> bool:
    """A rosbag2 directory: it holds a metadata.yaml, a .db3 or a .mcap file."""
    return path.is_dir() and ((path / "metadata.yaml").exists() or any(path.glob("*.db3"))
                              or any(path.glob("*.mcap")))


def expand_bags(paths: list[str]) -> list[Path]:
    """The bags named: a bag directory itself, or a directory's bag sub-directories (sorted by name). A
    path that is neither is kept as a bag, so that its error is reported with the others."""
    bags: list[Path] = []
    for text in paths:
        path = Path(text)
        if path.is_dir() and not is_bag_dir(path):
            inner = sorted(p for p in path.iterdir() if is_bag_dir(p))
            if not inner:
                raise InputError(f"{path}: neither a bag nor a directory of bags")
            bags.extend(inner)
        else:
            bags.append(path)
    if not bags:
        raise InputError("no bags given")
    return bags


def report_names(bags: list[Path]) -> list[str]:
    """A unique report directory name per bag: its name, with ``-2``, ``-3`` ... for repeats."""
    seen: dict[str, int] = {}
    names = []
    for bag in bags:
        n = seen.get(bag.name, 0) + 1
        seen[bag.name] = n
        names.append(bag.name if n == 1 else f"{bag.name}-{n}")
    return names


def machine_of_bag(bag: Path) -> str:
    """The machine of a bag: run metadata ``machine_id``, else its topics' namespace, else its name."""
    try:
        machine = read_run_metadata(bag).get("machine_id")
        if machine:
            return str(machine)
        for topic in bag_topic_types(bag):
            parts = topic.strip("/").split("/")
            if parts[-1] in ("joint_states", "load") and len(parts) > 1 + (parts[-1] == "load"):
                return parts[0]
    except Exception:  # noqa: BLE001 - a bag we cannot open has its name; the command reports the error
        pass
    return bag.name


def error_line(exc: BaseException) -> str:
    """The one-line error of a failed bag (the CLI's wording for input and file errors)."""
    if isinstance(exc, InputError):
        return one_line(exc, 300)
    if isinstance(exc, OSError) and exc.strerror:
        return f"{exc.strerror}: {exc.filename}"
    return f"{type(exc).__name__}: {one_line(exc)}"


_MALLOC_TUNED: list[bool] = []
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3          # glibc mallopt parameters (malloc.h)


def undo_dask_malloc_trim() -> bool:
    """Dask's nanny starts worker processes with MALLOC_TRIM_THRESHOLD_=65536 (distributed.nanny.pre-spawn-
    environ; also ``dask worker``). That also switches off glibc's dynamic mmap threshold, so every numpy
    array above 128 KiB is mmapped and unmapped again: measured 1.6-2.0x slower per bag. Set the thresholds
    glibc's dynamic rule settles at (mmap 32 MiB, trim twice that). True when done (Linux, variable set)."""
    import ctypes
    import os
    import sys

    if "MALLOC_TRIM_THRESHOLD_" not in os.environ or not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL("libc.so.6")
        return bool(libc.mallopt(M_MMAP_THRESHOLD, 32 << 20)) and bool(libc.mallopt(M_TRIM_THRESHOLD, 64 << 20))
    except (OSError, AttributeError):
        return False


def run_bag(run_one: RunOneBag, bag: str, params, out: str, options: tuple[str, ...] = ()) -> dict[str, Any]:
    """One bag through the single-bag command `run_one` (the worker task): {bag, machine, ok, error, seconds,
    result}.

    ``params``: a params file or a list (merged in order).
    Never raises: a failure is ``ok: False`` with the one-line error."""
    if not _MALLOC_TUNED:                       # once per worker process
        _MALLOC_TUNED.append(undo_dask_malloc_trim())
    t0, cpu0 = time.perf_counter(), time.process_time()
    entry: dict[str, Any] = {"bag": bag, "machine": machine_of_bag(Path(bag)), "ok": False, "error": "",
                             "result": None}
    files = (params,) if isinstance(params, str) else tuple(params)   # several merge in order, as for one bag
    try:
        entry["result"] = run_one(bag, files, out, tuple(options))
        entry["ok"] = True
    except Exception as exc:  # noqa: BLE001 - one bag's failure is its row, never the fleet's
        entry["error"] = error_line(exc)
    entry["seconds"] = time.perf_counter() - t0
    entry["cpu_s"] = time.process_time() - cpu0            # every thread of the worker process meanwhile
    return entry


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity where the platform tells it)."""
    import os

    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def share_cores(client) -> dict[str, bool]:
    """Switch the bulk reader's read-ahead thread off in the workers of every host whose worker threads
    already fill its cores (worker threads >= cores, e.g. 2 local workers on 2 cores: measured 5-12 % less CPU
    per bag, bit-identical results); on where cores are left over. {worker: read-ahead}."""
    try:
        workers = client.scheduler_info()["workers"]
        cores = client.run(usable_cores)
    except Exception:  # noqa: BLE001 - an older or restricted cluster: leave the workers as they are
        return {}
    threads: dict[str, int] = {}
    for info in workers.values():
        threads[info["host"]] = threads.get(info["host"], 0) + int(info.get("nthreads", 1))
    ahead = {addr: threads[info["host"]] < (cores.get(addr) or 1) for addr, info in workers.items()}
    for flag in (True, False):
        chosen = [addr for addr, on in ahead.items() if on is flag]
        if chosen:
            client.run(set_read_ahead, flag, workers=chosen)
    return ahead


def require_dask() -> None:
    """InputError (one line naming the package) when Dask is not installed: it is a declared dependency
    (setup.py, package.xml), but a hand-made environment may lack it; ``--workers 0`` runs without it."""
    for module in ("dask", "distributed"):
        if importlib.util.find_spec(module) is None:
            raise InputError(f"fleet runs on Dask workers need the Python package {module!r}: "
                             f"pip install 'dask[distributed]' (or run in this process with --workers 0)")


@contextlib.contextmanager
def dask_client(workers: int, scheduler: str | None):
    """A distributed Client: on ``scheduler`` (an address), else on a LocalCluster of ``workers``
    single-threaded worker processes (closed on exit)."""
    import logging

    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError, ValueError) as exc:     # refused/timed out, or not an address
            raise InputError(f"cannot reach the Dask scheduler at {scheduler}: {error_line(exc)}") from None
        with client:
            yield client
        return
    with dask.config.set({**LOCAL_CLUSTER_CONFIG, "distributed.worker.multiprocessing-method": local_start_method()}), \
            LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                         silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        yield client


def local_start_method() -> str:
    """How local worker processes start: ``fork`` on Linux (measured: LocalCluster(2) starts in 0.85 s
    instead of 4.9 s with spawn, closes in 0.5 s instead of 2.5 s, and the workers inherit the imported
    analysis modules), unless DASK_DISTRIBUTED__WORKER__MULTIPROCESSING_METHOD chooses; else Dask's
    default (spawn)."""
    import os
    import sys

    import dask

    if "DASK_DISTRIBUTED__WORKER__MULTIPROCESSING_METHOD" in os.environ or not sys.platform.startswith("linux"):
        return dask.config.get("distributed.worker.multiprocessing-method")
    return "fork"


def run_fleet(command: str, run_one: RunOneBag, bags: list[Path], params, out: Path, options: tuple[str, ...] = (),
              workers: int = 2, scheduler: str | None = None, progress=None) -> list[dict[str, Any]]:
    """Every bag through ``run_one``, the single-bag command ``command`` (replay|diagnose: its PRELOAD),
    report directories ``out/bags/<name>``; the entries of :func:`run_bag` in the order of ``bags``.
    ``progress(done, total)`` after each bag. The caller has imported the command's module (forked local
    workers inherit the modules)."""
    params = tuple(str(Path(p).resolve()) for p in ([params] if isinstance(params, (str, Path)) else params))
    jobs = [(str(bag.resolve()), str((out / "bags" / name).resolve()))
            for bag, name in zip(bags, report_names(bags))]
    entries: list[dict[str, Any] | None] = [None] * len(jobs)
    if progress:
        progress(0, len(jobs))
    if workers == 0 and not scheduler:
        for i, (bag, bag_out) in enumerate(jobs):
            entries[i] = run_bag(run_one, bag, params, bag_out, options)
            if progress:
                progress(i + 1, len(jobs))
        return entries
    import importlib

    require_dask()
    from distributed import as_completed

    for module in PRELOAD[command] + (() if "--no-plot" in options else PLOT_PRELOAD):
        importlib.import_module(module)
    with dask_client(workers, scheduler) as client:
        share_cores(client)
        futures = {client.submit(run_bag, run_one, bag, params, bag_out, options, pure=False): i
                   for i, (bag, bag_out) in enumerate(jobs)}
        for done, future in enumerate(as_completed(futures), start=1):
            i = futures[future]
            try:
                entries[i] = future.result()
            except Exception as exc:  # noqa: BLE001 - a worker lost on this bag
                entries[i] = {"bag": jobs[i][0], "machine": Path(jobs[i][0]).name, "ok": False,
                              "error": f"worker failed: {error_line(exc)}", "result": None, "seconds": math.nan,
                              "cpu_s": math.nan}
            if progress:
                progress(done, len(jobs))
    return entries


def same_result(a: dict, b: dict) -> bool:
    """Two results of one bag agree, timings and file paths aside (NaN equals NaN)."""
    keys = (set(a) | set(b)) - set(VOLATILE_KEYS)
    return all(_same(a.get(k), b.get(k)) for k in keys)


def _same(x, y) -> bool:
    if isinstance(x, dict) and isinstance(y, dict):
        return same_result(x, y)
    if isinstance(x, list) and isinstance(y, list):
        return len(x) == len(y) and all(_same(u, v) for u, v in zip(x, y))
    if isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y):
        return True
    return x == y
