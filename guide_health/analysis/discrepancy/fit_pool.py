"""The candidate fits of a forward-selection round in several processes (diagnose on a multi-core machine).

Every candidate of a round is fitted from the same current model, independently of the others, so a
round is a map. :class:`FitPool` forks worker processes that hold the :class:`WearProblem` (copied by the
fork, not pickled) and runs ``problem.fit(effects, warm)`` there: the same code on the same data, so the
same fits bit for bit (tested), only the FitResults travel back. The heaviest fits (most multi-start
points) are handed out first. ``workers`` <= 1, or no ``fork`` start method: None, the caller fits in turn.
"""
from __future__ import annotations

import math

_PROBLEM = None          # the WearProblem of the pool being created (inherited by the forked workers)


def _fit_job(job):
    index, effects, warm = job
    return index, _PROBLEM.fit(effects, warm=warm)


class FitPool:
    """A context manager giving ``fit_all(jobs)`` for :func:`selection.forward_selection`."""

    def __init__(self, problem, workers: int):
        self.problem, self.workers, self.pool = problem, int(workers), None

    def __enter__(self) -> FitPool | None:
        import multiprocessing

        if self.workers <= 1 or "fork" not in multiprocessing.get_all_start_methods():
            return None
        global _PROBLEM
        _PROBLEM = self.problem
        try:
            self.pool = multiprocessing.get_context("fork").Pool(self.workers)
        finally:
            _PROBLEM = None
        return self

    def __exit__(self, *exc) -> None:
        if self.pool is not None:
            self.pool.terminate()
            self.pool.join()

    def _cost(self, effects) -> int:
        """Multi-start points of the fit of `effects` (its last effect's starts; the others start warm)."""
        return math.prod(max(1, len(s.starts)) for s in self.problem.specs[effects[-1]]) if effects else 1

    def fit_all(self, jobs: list) -> list:
        """[problem.fit(effects, warm=warm) for effects, warm in jobs], computed by the workers."""
        order = sorted(range(len(jobs)), key=lambda i: -self._cost(jobs[i][0]))
        out = [None] * len(jobs)
        for index, fit in self.pool.imap_unordered(_fit_job, [(i, *jobs[i]) for i in order]):
            out[index] = fit
        return out
