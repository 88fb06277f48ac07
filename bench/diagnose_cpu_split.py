"""CPU time of each part of `diagnose`'s pipeline, in one process tree (a proxy for the quiet machine when
the host is loaded: wall time then depends on the other processes, CPU time much less).

    .venv/bin/python bench/diagnose_cpu_split.py [BAG] [--params FILE]

Prints the CPU seconds of: the parent's start-up and parameters; the child that reads and decodes the bag;
the parent's imports and duty-cell accumulation (which run beside the child); the fit in the parent and in
the 2 pool workers; the report with matplotlib's import (diagnose imports and draws in the reader child
after the read, beside the fit). On an idle 2-core machine the wall time is about start-up + the longer of
child and parent + half the pool workers' CPU + the report.
"""
from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main() -> int:
    c0 = time.process_time()
    t0 = time.perf_counter()
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("bag", nargs="?", default="/tmp/guide_health_bench/diagnose_20h_50hz_running_in_2.5")
    ap.add_argument("--params", default=str(ROOT / "config" / "bench_000.yaml"))
    args = ap.parse_args()
    from guide_health.analysis.discrepancy.duty_process import start_duty_cells
    from guide_health.params import wear_monitor_params

    params = wear_monitor_params([args.params])
    c1 = time.process_time()
    pending = start_duty_cells(args.bag, params, background=True)      # the child only reads (no plot)
    from guide_health.analysis.discrepancy.report import preload_plotting, write_report
    from guide_health.analysis.discrepancy.workflow import diagnose_cells

    cells, _ = pending.result()
    pending.close()                                                      # waited for: its CPU is counted
    child = children_cpu()
    c2 = time.process_time()
    result = diagnose_cells(cells, params, workers=2)
    c3 = time.process_time()
    pool = children_cpu() - child
    preload_plotting()
    write_report(result, Path(args.bag + ".cpu_split"))
    c4 = time.process_time()
    print(f"CPU s: parent start-up + parameters {c1 - c0:.2f} (plus the interpreter), child read {child:.2f}, "
          f"parent imports + accumulation {c2 - c1:.2f}, fit {c3 - c2:.2f} in the parent + {pool:.2f} in the pool "
          f"workers, report {c4 - c3:.2f}; wall {time.perf_counter() - t0:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
