"""Slewing-bearing monitor core (no ROS): validation, worst roller per reporting period, levels, and the
offline analysis of a whole load history with the same object (`analyse_slewing_run`)."""
from __future__ import annotations

import math

import numpy as np

from guide_health.models.roller_contact import SlewingContactModel
from guide_health.params import validate_slewing_params


class SlewingMonitor:
    """ROS-free core of the node: worst case per publish period, input validation, levels."""

    def __init__(self, params: dict):
        validate_slewing_params(params)
        self.params = params
        self.model = SlewingContactModel(params)
        self.worst: dict | None = None
        self.last_report: dict | None = None
        self.loads_in_period = 0
        self.rejected = 0
        self.last_problem: str | None = None
        self.worst_sample: dict | None = None

    def on_loads(self, axial_n: float, radial_n: float, moment_nm: float) -> str | None:
        """One load sample; returns the rejection reason or None."""
        if not all(math.isfinite(v) for v in (axial_n, radial_n, moment_nm)):
            self.rejected += 1
            self.last_problem = "non-finite load"
            return "non-finite load (NaN/inf) ignored"
        report = self.model.report_for_loads(axial_n, radial_n, moment_nm)
        self.worst_sample = report              # the report of this sample (offline analysis reads it)
        self.loads_in_period += 1
        if self.worst is None or report["p_max_MPa"] > self.worst["p_max_MPa"]:
            self.worst = report
        return None

    def period_report(self) -> tuple[int, str, dict]:
        """Level, message and values for the period just ended (the worst roller since the last call)."""
        report = self.worst or self.last_report
        values = dict(report or {})
        values["loads_in_period"] = self.loads_in_period
        values["rejected_loads"] = self.rejected
        if report is None:
            level, message = 1, "no valid load received yet"
            if self.last_problem:
                message = f"no valid load received yet ({self.last_problem})"
        else:
            level, message = int(report["level"]), report["message"]
            if report.get("main_row_unloaded") and report.get("opposite_row_unloaded"):
                level, message = max(level, 1), "no axial roller is loaded: " + message
            elif report.get("main_row_partly_unloaded"):
                # normal for a three-row roller bearing under a crane's moment: the retaining row takes
                # it; reported, but not a warning by itself
                message = ("tilting moment lifts the main row's rollers off on the far side "
                           "(4 M_T / D0 > F_a, the retaining row takes the moment); " + message)
            if self.loads_in_period == 0 and self.rejected:
                level, message = max(level, 1), f"only invalid loads this period ({self.last_problem}); last valid: {message}"
        if report is not None and self.worst is not None:
            self.last_report = self.worst
        self.worst = None
        self.loads_in_period = 0
        return level, message, values



def analyse_slewing_run(run, params: dict, progress=None) -> tuple[SlewingMonitor, dict]:
    """Every load sample of a SlewingLoadRun through SlewingMonitor (the node's rules); returns the
    monitor and a report: the worst roller of the whole run (its loads and time), counts of samples per
    level, and `p_max_MPa` per sample for plots (key `series`)."""
    monitor = SlewingMonitor(params)
    n = int(np.asarray(run.t_ns).size)
    p_max = np.full(n, np.nan)
    levels = {0: 0, 1: 0, 2: 0}
    worst_i = -1
    worst = None
    for i, (fa, fr, mt) in enumerate(zip(np.asarray(run.axial_n, float).tolist(),
                                         np.asarray(run.radial_n, float).tolist(),
                                         np.asarray(run.moment_nm, float).tolist())):
        if monitor.on_loads(fa, fr, mt) is None:
            rep = monitor.worst_sample
            p_max[i] = rep["p_max_MPa"]
            levels[int(rep["level"])] += 1
            if worst is None or rep["p_max_MPa"] > worst["p_max_MPa"]:
                worst, worst_i = rep, i
        if progress is not None and (i % 20000 == 0 or i == n - 1):
            progress(i + 1, n)
    report = dict(worst or {})
    report.update(
        loads=n, rejected_loads=monitor.rejected,
        samples_ok=levels[0], samples_warn=levels[1], samples_error=levels[2],
        worst_t_s=(float(run.t_ns[worst_i] - run.t_ns[0]) * 1e-9) if worst_i >= 0 else math.nan,
        worst_axial_n=float(run.axial_n[worst_i]) if worst_i >= 0 else math.nan,
        worst_radial_n=float(run.radial_n[worst_i]) if worst_i >= 0 else math.nan,
        worst_moment_nm=float(run.moment_nm[worst_i]) if worst_i >= 0 else math.nan,
        duration_h=(float(run.t_ns[-1] - run.t_ns[0]) * 1e-9 / 3600.0) if n else 0.0,
        messages=n,
    )
    report["series"] = p_max
    return monitor, report
