"""The plan's picture of one machine: per guide, straightness against the calendar from now to the limit under
each scenario, its line (to the limit date) and 90 % band (the lines to the band's dates), the limit and
A0. A straight line per surface: the plan is a date, the curve between now and then only shows which
scenario gets there first. matplotlib (Agg) is imported on use."""
from __future__ import annotations

import math
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from guide_health.io.outputs.files import save_figure


def _date(t_ns: float) -> datetime:
    return datetime.fromtimestamp(t_ns * 1e-9, tz=UTC)


def _path(row: dict[str, Any], end_ns: float) -> tuple[list, list]:
    """(dates, straightness um) from now to ``end_ns`` (a limit date), through a regrind when it comes first."""
    now, a_now, limit = row["now_t_ns"], row["straightness_um"], row["straightness_limit_um"]
    regrind = row.get("regrind_utc") and not row.get("regrind_late")
    if not regrind:
        return [_date(now), _date(end_ns)], [a_now, limit]
    d = datetime.fromisoformat(row["regrind_utc"].replace("Z", "+00:00")).timestamp() * 1e9
    if end_ns <= d:
        return [_date(now), _date(end_ns)], [a_now, limit]
    at_d = a_now + (limit - a_now) * (d - now) / (row["present_limit_t_ns"] - now)
    a0 = row["straightness_initial_um"]
    return [_date(now), _date(d), _date(d), _date(end_ns)], [a_now, at_d, a0, limit]


def plot_plan(path: Path, machine: str, rows: list[dict[str, Any]]) -> Path:
    """One PNG: a panel per guide (axis/guide), a colour per scenario: its line to the limit date, its band
    shaded between the (dashed) lines to the band's low and high dates."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.dates as mdates
    import matplotlib.pyplot as plt

    panels = list(dict.fromkeys((r["axis"], r["guide"]) for r in rows))
    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 3.6 * len(panels)), squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, (axis, guide) in zip(axes[:, 0], panels):
        mine = [r for r in rows if (r["axis"], r["guide"]) == (axis, guide)]
        finite = [r["limit_t_ns"] for r in mine if math.isfinite(r["limit_t_ns"])]
        right = max(finite) if finite else mine[0]["now_t_ns"] + 3.15e16
        right = mine[0]["now_t_ns"] + 1.3 * (right - mine[0]["now_t_ns"])
        for i, r in enumerate(mine):
            c = colours[i % len(colours)]
            if not math.isfinite(r["limit_t_ns"]):
                ax.plot([], [], color=c, label=f"{r['scenario']}: no limit")
                continue
            x, y = _path(r, r["limit_t_ns"])
            ax.plot(x, y, color=c, lw=2, label=f"{r['scenario']}: {r['limit_date_utc'][:10]}")
            lo = _path(r, r["limit_t_ns_low"])
            hi = _path(r, r["limit_t_ns_high"] if math.isfinite(r["limit_t_ns_high"]) else 10.0 * right)
            ax.plot(*lo, color=c, lw=0.8, ls="--")
            ax.plot(*hi, color=c, lw=0.8, ls="--")
            ax.fill(mdates.date2num(lo[0] + hi[0][::-1]), lo[1] + hi[1][::-1], color=c, alpha=0.10, lw=0)
        ax.axhline(mine[0]["straightness_limit_um"], color="black", lw=1.5, label="limit")
        ax.axhline(mine[0]["straightness_initial_um"], color="grey", lw=0.8, ls=":", label="A0")
        ax.set_xlim(_date(mine[0]["now_t_ns"]), _date(right))
        ax.set_ylabel("straightness [um]")
        ax.set_title(f"{machine} axis {axis} (guide {guide}): forecast to the limit, 90 % band dashed", fontsize=9)
        ax.legend(fontsize=7, loc="lower right")
        ax.grid(alpha=0.3)
    fig.autofmt_xdate()
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
    return path
