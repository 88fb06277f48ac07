"""Worker processes for the independent hidden-effect cases of test_discrepancy*.py.

A spawned worker is a new interpreter that imports numpy, scipy and the discrepancy workflow again (about 3 CPU s,
two per pool). ``case_pool`` forks its workers from a fork server that imported them once. The server has a single
thread, so forking it is safe under pytest-xdist's threads (a plain fork of the test process is not). Each case
seeds its own generators: the start method changes no result. The server outlives the pool (idle) and serves the
next pool of the same process; it ends with the process.
"""
from __future__ import annotations

import contextlib
import multiprocessing as mp

#: what every case imports (the server imports it once; a worker imports only its test module on top)
PRELOAD = ["numpy", "scipy.optimize", "scipy.stats", "scipy.integrate", "guide_health.params",
           "guide_health.sim.machine", "guide_health.analysis.discrepancy.duty",
           "guide_health.analysis.discrepancy.workflow", "guide_health.io.bag.writer"]


@contextlib.contextmanager
def case_pool(processes: int = 2):
    """A multiprocessing Pool of ``processes`` workers forked from a preloaded fork server."""
    context = mp.get_context("forkserver")
    context.set_forkserver_preload(PRELOAD)
    with context.Pool(processes) as pool:
        yield pool
