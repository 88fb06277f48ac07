"""PNG plots of the fleet trend: one machine's quantities over time, and the fleet overview. matplotlib's
object API on the Agg canvas (no pyplot: its import and figure manager were seconds of a page)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from guide_health.analysis.fleet_trend import TREND_KEYS, MachineTrend, iso
from guide_health.analysis.report_plots import _save_figure

LEVEL_COLOURS = {0: "#27ae60", 1: "#e69f00", 2: "#c0392b", 3: "#7f8c8d"}
OVERVIEW_LEGEND_MAX = 24        # machines named in the overview's legend (beyond: a legend no one reads)
#: time bins of a drawn series: at least the pixel columns of a panel (8 in x 110 dpi less the margins is
#: ~690 px), so a series drawn as the min and the max of each bin looks as the full series would
PLOT_BINS = 800


def min_max_per_bin(t, v, t_lo: float, t_hi: float, bins: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The points of a series (times ascending, values finite) to draw: per time bin of [t_lo, t_hi] its
    first minimum and first maximum, in time order, plus the series' first and last point. Every bin keeps
    the extremes of the full series, so no spike (an alarm) disappears from the figure, and a line of
    43 200 rows becomes at most 2 x bins + 2 points. ``bins`` None: PLOT_BINS; a series of at most
    2 x bins points, or bins 0, is returned whole."""
    t, v = np.asarray(t, dtype=float), np.asarray(v, dtype=float)
    bins = PLOT_BINS if bins is None else bins
    if bins <= 0 or t.size <= 2 * bins:
        return t, v
    span = t_hi - t_lo if t_hi > t_lo else 1.0
    b = np.clip(((t - t_lo) / span * bins).astype(np.int64), 0, bins - 1)
    order = np.lexsort((v, b))                      # by bin, then value (stable: the first of equal values)
    starts = np.flatnonzero(np.r_[True, b[order][1:] != b[order][:-1]])
    ends = np.r_[starts[1:], b.size] - 1
    last_max = np.lexsort((-np.arange(b.size), v, b))[ends]     # of equal maxima the first, too
    keep = np.unique(np.concatenate(([0, t.size - 1], order[starts], last_max)))
    return t[keep], v[keep]


def _hours(t_unix_s, t0: float) -> np.ndarray:
    return (np.asarray(t_unix_s, dtype=float) - t0) / 3600.0


def _fixed_margins(fig, left_in: float, bottom_in: float, top_in: float, hspace: float = 0.25,
                   wspace: float = 0.2) -> None:
    """Margins in inches instead of tight_layout, which measures every tick label and was half the time of a
    machine's figure; the labels here are short and of known font size, so fixed margins hold them."""
    width_in, height_in = fig.get_size_inches()
    fig.subplots_adjust(left=left_in / width_in, right=1.0 - 0.15 / width_in, bottom=bottom_in / height_in,
                        top=1.0 - top_in / height_in, hspace=hspace, wspace=wspace)


def _agg_figure(figsize: tuple[float, float]):
    """A figure on its own Agg canvas, outside pyplot (nothing to close)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    FigureCanvasAgg(fig)
    return fig


class MachineFigures:
    """The machine figures of one page: one figure per panel count, cleared of its data and drawn again for
    each machine. Its axes and their tick objects are made once: making them was a third of a machine's
    figure time; the drawing equals a new figure's (test_fleet_trend.py compares the pixels)."""

    def __init__(self) -> None:
        self._figures: dict[int, tuple] = {}

    def axes(self, panels: int) -> tuple:
        """(figure, column of axes) of ``panels`` panels, empty of data."""
        if panels not in self._figures:
            fig = _agg_figure((8, 1.9 * panels + 0.6))
            self._figures[panels] = (fig, fig.subplots(panels, 1, sharex=True, squeeze=False)[:, 0])
            return self._figures[panels]
        fig, axes = self._figures[panels]
        for ax in axes:
            for artist in [*ax.lines, *ax.collections]:
                artist.remove()
            if ax.get_legend() is not None:
                ax.get_legend().remove()
            ax.set_prop_cycle(None)                 # the colours of a new figure, from the first
            ax.relim()
            ax.autoscale(True)
        return fig, axes


def plot_machine_trend(path: Path, trend: MachineTrend, figures: MachineFigures | None = None) -> None:
    """A panel per quantity the machine reports (one line per status), then the level of each status;
    ``figures``: the page's figures to draw into (None: a figure of its own)."""
    keys = [(k, label) for k, label in TREND_KEYS if np.isfinite(trend.values[k]).any()]
    fig, axes = (figures or MachineFigures()).axes(len(keys) + 1)
    t0, t1 = trend.first_t(), float(trend.t_unix_s[-1])
    names = sorted(set(trend.status))
    for ax, (key, label) in zip(axes, keys):
        t_all, values, status = trend.points(key)
        for name in names:
            sel = (status == name) & np.isfinite(values)
            if sel.any():
                t, v = min_max_per_bin(t_all[sel], values[sel], t0, t1)
                ax.plot(_hours(t, t0), v, ".-", ms=3, label=name)
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
    ax = axes[-1]
    t_all, level, status = trend.points("level")
    for row, name in enumerate(names):
        sel = status == name
        t, levels = min_max_per_bin(t_all[sel], level[sel], t0, t1)
        ax.scatter(_hours(t, t0), np.full(levels.size, row), s=12,
                   c=[LEVEL_COLOURS.get(int(v), "#000") for v in levels])
    ax.set_yticks(range(len(names)))
    ax.set_yticklabels(names, fontsize=7)
    ax.set_ylim(-0.7, len(names) - 0.3)
    ax.set_xlabel(f"time [h] since {iso(t0)} UTC (level: green OK, orange WARN, red ERROR, "
                  "grey STALE)", fontsize=8)
    fig.suptitle(f"machine {trend.machine}", fontsize=10)
    _fixed_margins(fig, left_in=1.6, bottom_in=0.5, top_in=0.4)
    _save_figure(None, fig, path)


def plot_fleet_overview(path: Path, trends: dict[str, MachineTrend], rows: list[dict]) -> None:
    """Left: every machine's remaining life over time; right: the ranking by latest remaining life."""
    fig = _agg_figure((11, 1.8 + 0.3 * max(4, len(rows))))
    left, right = fig.subplots(1, 2, gridspec_kw={"width_ratios": [3, 2]})
    t0 = min(t.first_t() for t in trends.values())
    t1 = max(t.t_unix_s[-1] for t in trends.values())
    for m, trend in trends.items():
        t_all, values, _ = trend.points("remaining_life_h")
        sel = np.isfinite(values)
        if sel.any():
            t, v = min_max_per_bin(t_all[sel], values[sel], t0, t1)
            left.plot(_hours(t, t0), v, ".-", ms=3, label=m)
    left.set_xlabel(f"time [h] since {iso(t0)} UTC")
    left.set_ylabel("remaining precision life [h]")
    left.grid(alpha=0.3)
    if 0 < len(left.lines) <= OVERVIEW_LEGEND_MAX:        # more: the ranking beside names every machine
        left.legend(fontsize=7, loc="upper right")
    ranked = [r for r in rows if math.isfinite(r["remaining_life_h"])]
    y = np.arange(len(ranked))[::-1]
    colours = {"OK": "#27ae60", "WARN": "#e69f00", "ERROR": "#c0392b", "STALE": "#7f8c8d"}
    right.barh(y, [min(r["remaining_life_h"], 1e9) for r in ranked],
               color=[colours.get(r["level"], "#2e86c1") for r in ranked])
    right.set_yticks(y)
    right.set_yticklabels([r["machine"] for r in ranked], fontsize=8)
    right.set_xlabel("latest remaining life [h]")
    right.grid(axis="x", alpha=0.3)
    fig.suptitle(f"fleet: {len(trends)} machines", fontsize=10)
    _fixed_margins(fig, left_in=0.9, bottom_in=0.6, top_in=0.5, hspace=0.0, wspace=0.35)
    _save_figure(None, fig, path)
