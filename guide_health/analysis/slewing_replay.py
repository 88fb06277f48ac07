"""Offline analysis of a slewing-bearing load history with the live node's core (``SlewingMonitor``)."""
from __future__ import annotations

import math

import numpy as np

from guide_health.models.levels import ERROR, OK, WARN
from guide_health.models.slewing.monitor import SlewingMonitor
from guide_health.params.typed import slewing_monitor_params


def analyse_slewing_run(run, params: dict, progress=None,
                        monitor: SlewingMonitor | None = None) -> tuple[SlewingMonitor, dict]:
    """Every load sample of a SlewingLoadRun through SlewingMonitor (the node's rules); returns the
    monitor and a report: the worst roller of the whole run (its loads and time), counts of samples per
    level, and `p_max_MPa` per sample for plots (key `series`). ``params``: the slewing_monitor section as
    loaded (a dict), made the typed, validated SlewingMonitorParams here as the node does; ``monitor``: one made
    from them by the caller (e.g. with its wear model watched), else a new one."""
    monitor = SlewingMonitor(slewing_monitor_params(params)) if monitor is None else monitor
    n = int(np.asarray(run.t_ns).size)
    axis_t = np.asarray(run.axis_t_ns, dtype=np.int64).tolist()
    axis_angle = np.asarray(run.axis_angle_rad, dtype=float).tolist()
    next_axis = 0
    # measured tilting clearances at their log times: after every sample stamped at or before them
    clearances = list(zip(np.asarray(run.clearance_t_ns, dtype=np.int64).tolist(),
                          np.asarray(run.clearance_m, dtype=float).tolist()))
    next_clearance = 0
    p_max = np.full(n, np.nan)
    levels = {OK: 0, WARN: 0, ERROR: 0}
    worst_i = -1
    worst = None
    for i, (fa, fr, mt, t) in enumerate(zip(np.asarray(run.axial_n, float).tolist(),
                                            np.asarray(run.radial_n, float).tolist(),
                                            np.asarray(run.moment_nm, float).tolist(),
                                            np.asarray(run.t_ns, dtype=np.int64).tolist())):
        while next_clearance < len(clearances) and clearances[next_clearance][0] < t:
            next_axis = _angles_until(monitor, axis_t, axis_angle, next_axis, clearances[next_clearance][0], True)
            monitor.on_tilting_clearance(clearances[next_clearance][1])
            next_clearance += 1
        next_axis = _angles_until(monitor, axis_t, axis_angle, next_axis, t, False)  # a load first at equal stamps
        if monitor.on_loads(fa, fr, mt, t_ns=t) is None:
            rep = monitor.worst_sample
            p_max[i] = rep["p_max_MPa"]
            levels[int(rep["level"])] += 1
            if worst is None or rep["p_max_MPa"] > worst["p_max_MPa"]:
                worst, worst_i = rep, i
        if progress is not None and (i % 20000 == 0 or i == n - 1):
            progress(i + 1, n)
    for stamp, clearance_m in clearances[next_clearance:]:
        next_axis = _angles_until(monitor, axis_t, axis_angle, next_axis, stamp, True)
        monitor.on_tilting_clearance(clearance_m)
    _angles_until(monitor, axis_t, axis_angle, next_axis, None, True)
    report = dict(worst or {})
    if axis_t:            # the rating life per row (docs/slewing.md), the keys of the live status
        fatigue_level, fatigue_message, fatigue_values = monitor.fatigue.report()
        report.update(fatigue_values, fatigue_level=int(fatigue_level), fatigue_message=fatigue_message,
                      rejected_axis_angles=monitor.rejected_angles)
        report.update(monitor.wear.report(monitor.elapsed_s()),
                      rejected_tilting_clearances=monitor.rejected_clearances)
    report.update(
        loads=n, rejected_loads=monitor.rejected, samples_missing_estimate=monitor.stamp_gaps.missing,
        load_period_estimate_us=monitor.stamp_gaps.period_ns * 1e-3,
        samples_ok=levels[OK], samples_warn=levels[WARN], samples_error=levels[ERROR],
        worst_t_s=(float(run.t_ns[worst_i] - run.t_ns[0]) * 1e-9) if worst_i >= 0 else math.nan,
        worst_axial_n=float(run.axial_n[worst_i]) if worst_i >= 0 else math.nan,
        worst_radial_n=float(run.radial_n[worst_i]) if worst_i >= 0 else math.nan,
        worst_moment_nm=float(run.moment_nm[worst_i]) if worst_i >= 0 else math.nan,
        duration_h=(float(run.t_ns[-1] - run.t_ns[0]) * 1e-9 / 3600.0) if n else 0.0,
        messages=n,
    )
    report["series"] = p_max
    return monitor, report


def _angles_until(monitor: SlewingMonitor, axis_t: list, axis_angle: list, start: int, t_ns: int | None,
                  inclusive: bool) -> int:
    """Feed the axis angles from ``start`` stamped before ``t_ns`` (at or before when ``inclusive``; None: all);
    returns the next index."""
    i = start
    while i < len(axis_t) and (t_ns is None or axis_t[i] < t_ns or (inclusive and axis_t[i] == t_ns)):
        monitor.on_axis_angle(axis_angle[i], axis_t[i])
        i += 1
    return i
