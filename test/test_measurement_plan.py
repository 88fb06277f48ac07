"""How often to measure straightness (models/wear/measurement_plan.py): the function against a closed form,
and docs/sensors.md's table against the function."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from guide_health.models.wear.measurement_plan import life_interval_half_width, longest_measurement_interval_h
from guide_health.params import wear_monitor_params
from guide_health.params.machine import axes_params
from guide_health.params.typed import wear_axis_params

ROOT = Path(__file__).resolve().parents[1]
Z90 = 1.6448536269514722


@pytest.fixture(scope="module")
def x_axis():
    return wear_axis_params(axes_params(wear_monitor_params(ROOT / "config" / "machine_xyz.yaml"))["x"])


def test_without_measurements_the_interval_is_the_priors(x_axis):
    """No measurement before ``at``: K in k0 (1 -+ z90 r). At constant duty the remaining life after ``at``
    running hours is L(K) = k0 L0 / K - at (the wear so far, K g, scales with K too), so the long side is
    (L0 / (1 - z90 r) - at) / (L0 - at) - 1 (L0 = 2000 h, at = 500 h, r = 0.5: 6.175)."""
    r = x_axis.wear_coefficient_prior_rel_sd
    expected = (2000.0 / (1 - Z90 * r) - 500.0) / (2000.0 - 500.0) - 1
    assert life_interval_half_width(x_axis, 2000.0, 1000.0, 500.0) == pytest.approx(expected, rel=1e-9)


def test_more_measurements_narrow_the_interval(x_axis):
    widths = [life_interval_half_width(x_axis, 2000.0, n, 500.0) for n in (100, 50, 10, 1)]
    assert widths == sorted(widths, reverse=True) and widths[-1] < 0.05


def test_the_docs_table_is_the_functions(x_axis):
    text = (ROOT / "docs" / "sensors.md").read_text()
    rows = re.findall(r"^\| (\d+) h \| (\d+) h[^|]*\| (?:(\d+) h|not reachable \(0\)) \|$", text, re.M)
    assert len(rows) == 3
    for at, n20, n10 in rows:
        assert longest_measurement_interval_h(x_axis, 2000.0, float(at), 0.2) == int(n20)
        assert longest_measurement_interval_h(x_axis, 2000.0, float(at), 0.1) == int(n10 or 0)
