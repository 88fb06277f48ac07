"""The replay PNGs of a multi-axis machine (report_plots.plot_straightness_report), read from the figure
objects: each titled with its axis and the report's life in plain hours, the history panel at the bag's
time scale (not squeezed by the forecast), the forecast panel from now, the limit dates inside the frame."""
import json
import math
from pathlib import Path

import pytest

from guide_health.analysis import report_plots
from guide_health.analysis.report_plots import hours_text, life_text

ROOT = Path(__file__).resolve().parents[1]
XYZ = ROOT / "config" / "machine_xyz.yaml"
HOURS = 2.0


def test_life_numbers_are_plain_hours():
    assert life_text(1980.0, 1090.0, 11000.0) == "1980 h (90 %: 1090-11000 h)"
    assert life_text(1976.4, 1091.2, 10987.0) == "1980 h (90 %: 1090-11000 h)"      # 3 significant digits
    assert life_text(23.44, 9.87, math.inf) == "23.4 h (90 %: over 9.87 h)"
    assert (hours_text(1.88e6), hours_text(0.5234), hours_text(math.inf)) == ("1880000", "0.523", "never")


@pytest.fixture(scope="module")
def xyz_figures(tmp_path_factory):
    """Replay of a 2 h config/machine_xyz.yaml bag (a measurement every 0.25 h per axis), its figures
    caught where they would be written."""
    from guide_health.cli.app import main
    from guide_health.io.bag.writer import write_machine_axes_bag
    from guide_health.params import machine_axes_params, simulation_params
    from guide_health.params.machine import simulation_axes
    from guide_health.sim.machine import simulate_axes

    tmp = tmp_path_factory.mktemp("xyz")
    axes = machine_axes_params(XYZ)
    sim = dict(simulation_params(XYZ), duration_h=HOURS, joint_state_rate_hz=10.0, load_rate_hz=1.0,
               measurement_interval_h=0.25)
    write_machine_axes_bag(simulate_axes(axes, simulation_axes(sim, list(axes)), seed=5), axes, tmp / "bag",
                           metadata={"seed": 5})
    figures = {}
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(report_plots, "_save_figure", lambda plt, fig, path: figures.setdefault(Path(path).name, fig))
        assert main(["replay", str(tmp / "bag"), "--params", str(XYZ), "--out", str(tmp / "out")]) == 0
    return json.loads((tmp / "out" / "report.json").read_text()), figures


@pytest.mark.parametrize("axis", ["x", "y", "z"])
def test_multi_axis_png_title_panels_and_dates(xyz_figures, axis):
    report, figures = xyz_figures
    r = report["axes"][axis]
    fig = figures[f"straightness_{axis}.png"]
    title = fig._suptitle.get_text()
    assert title == (f"axis {axis} (guide {r['guide']}): remaining precision life "
                     f"{life_text(r['remaining_life_h'], r['remaining_life_h_low'], r['remaining_life_h_high'])}")
    assert "e+" not in title and "[" not in title
    history, forecast, _ = fig.axes
    measured_t = history.get_lines()[0].get_xdata()
    assert len(measured_t) == r["measurements"] == 8
    lo, hi = history.get_xlim()                        # the bag's own scale: 0 .. ~2 h, all measurements in
    assert lo == 0.0 and max(measured_t) < hi < 1.1 * HOURS
    assert r["remaining_life_h"] > 100 * HOURS         # the forecast reaches far beyond the history ...
    f_lo, f_hi = forecast.get_xlim()                   # ... on its own panel: from now to <= 3x the life
    assert f_lo == pytest.approx(HOURS, abs=0.05)
    assert f_lo + r["remaining_life_h"] < f_hi <= f_lo + 3.0 * r["remaining_life_h"] + 1e-6
    point = [line for line in forecast.get_lines() if line.get_label().startswith("forecast")][0]
    x, y = point.get_xdata(), point.get_ydata()
    inside = (x >= f_lo) & (x <= f_hi)
    assert inside.sum() >= 50                          # the forecast drawn finely on the span shown
    reach = x[inside][y[inside] >= r["straightness_limit_um"] - 1e-9].min()
    assert reach - f_lo == pytest.approx(r["remaining_life_h"], rel=0.05)   # reaches the limit at the life
    fig.canvas.draw()
    dates = [t for t in forecast.texts if t.get_text().startswith("limit reached")]
    assert len(dates) == 1 and "UTC" in dates[0].get_text()
    box, frame = dates[0].get_window_extent(), forecast.get_window_extent()
    assert frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0 and box.y1 <= frame.y1
