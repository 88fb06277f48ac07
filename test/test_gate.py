"""One input gate per axis (models/wear/gate.py) and the life functions of typed inputs (models/wear/life.py).

Truth: the rule written in the test (the load rule judges the first guide's share of the axis load, each
rule applied once per sample), Eq. 12 of seed 000 written out, the thresholds of the judgement."""
import math
from pathlib import Path

import pytest

from guide_health.models.levels import Level
from guide_health.models.wear.axis import AxisMonitor
from guide_health.models.wear.input_rules import LOAD_ABOVE_MAX, POSITION_OUT_OF_TRAVEL
from guide_health.models.wear.life import (
    LifeNow,
    PrecisionNow,
    RecentInputs,
    Thresholds,
    judge,
    remaining_life_interval_s,
)
from guide_health.params import machine_axes_params
from guide_health.params.typed import wear_axis_params

ROOT = Path(__file__).resolve().parents[1]
T0_NS = 1_700_000_000 * 10**9


def two_guides(shares=(0.6, 0.4)) -> AxisMonitor:
    p = dict(machine_axes_params(ROOT / "config" / "machine_xyz.yaml")["y"])
    p.update(guides=["front", "rear"], guide_load_shares=list(shares), load_max_n=10000.0)
    return AxisMonitor(wear_axis_params(p))


def test_a_sample_is_judged_once_per_axis_and_every_guide_carries_its_share():
    axis = two_guides()
    assert axis.on_load(T0_NS, 15000.0) is None                  # front share 9000 N <= 10000 N
    assert axis.on_load(T0_NS + 10**7, 20000.0) == LOAD_ABOVE_MAX  # front share 12000 N: rejected for the axis
    assert axis.on_joint(T0_NS + 2 * 10**7, 99.0) == POSITION_OUT_OF_TRAVEL
    assert axis.on_joint(T0_NS + 3 * 10**7, 0.1) is None
    assert axis.on_joint(T0_NS + 4 * 10**7, 0.2) is None
    assert dict(axis.rejected) == {LOAD_ABOVE_MAX: 1, POSITION_OUT_OF_TRAVEL: 1}
    assert axis.load_n == 15000.0 and axis.gate.load_samples == 1
    for name, share in (("front", 0.6), ("rear", 0.4)):
        report = axis.guide(name).report()
        assert report["rejected_samples"] == 2 and report["load_samples"] == 1 and report["samples"] == 2
        assert axis.guide(name).load_n == pytest.approx(15000.0 * share, rel=1e-15)
        # the work of the 0.1 m stroke with the guide's share of the accepted load (W ds)
        assert axis.guides[name].integrator.archard_work_nm == pytest.approx(15000.0 * share * 0.1, rel=1e-12)
    assert axis.gate.recent_rejected_share() == (0.5, "guide/load", LOAD_ABOVE_MAX)


def test_saved_guides_carry_their_share_and_restore_the_axis_load():
    axis = two_guides((0.5, 0.5))
    axis.on_load(T0_NS, 8000.0)
    axis.on_joint(T0_NS + 10**7, 0.1)
    states = {name: axis.guide_state(name) for name in axis.guides}
    assert [s["load_n"] for s in states.values()] == [4000.0, 4000.0]
    again = two_guides((0.5, 0.5))
    for name, state in states.items():
        again.restore_guide(name, state)
    assert (again.load_n, again.load_t_ns, again.gate.load_samples) == (8000.0, T0_NS, 1)
    assert again.gate.joint_base.last_t_ns == T0_NS + 10**7
    assert again.on_joint(T0_NS + 10**7, 0.2) is not None           # the time base came back: not in time


def test_remaining_life_and_its_interval_are_eq12_at_k_and_the_ends_of_its_interval():
    a0, a_max, g, rate = 10e-6, 50e-6, 2.0, 1e-3                      # [m], [m], [m per K], [m/s per K]
    now = LifeNow(a0, a_max, g, rate, 4e-6, 2e-6, 8e-6)
    life, low, high = remaining_life_interval_s(now)
    assert life == pytest.approx((a_max - a0 - 4e-6 * g) / (4e-6 * rate), rel=1e-12)
    assert low == pytest.approx((a_max - a0 - 8e-6 * g) / (8e-6 * rate), rel=1e-12)
    assert high == pytest.approx((a_max - a0 - 2e-6 * g) / (2e-6 * rate), rel=1e-12)
    assert remaining_life_interval_s(LifeNow(a0, a_max, g, rate, 4e-6, -1e-6, 8e-6))[2] == math.inf


def test_judgement_levels_and_the_clear_margin():
    th = Thresholds(straightness_warn_fraction=0.8, life_warn_h=500.0, life_error_h=100.0, rejected_share_warn=0.5,
                    alarm_clear_margin=0.1)
    quiet = RecentInputs(0.0, "", "", 0)
    assert judge(PrecisionNow(20.0, 50.0, 1000.0, 10, "x"), quiet, th)[0] == Level.OK
    assert judge(PrecisionNow(20.0, 50.0, 300.0, 10, "x"), quiet, th)[0] == Level.WARN
    level, text, clear = judge(PrecisionNow(20.0, 50.0, 90.0, 10, "x"), quiet, th)
    assert (level, clear) == (Level.ERROR, Level.ERROR) and "remaining precision life 90 h" in text
    # 105 h is above the error threshold, not above it moved by the 10 % margin: ERROR does not clear yet
    assert judge(PrecisionNow(20.0, 50.0, 105.0, 10, "x"), quiet, th)[::2] == (Level.WARN, Level.ERROR)
    assert judge(PrecisionNow(51.0, 50.0, 0.0, 10, "x"), quiet, th)[0] == Level.ERROR
    noisy = RecentInputs(0.75, "joint_states", "non-finite joint position/velocity", 100)
    level, text, _ = judge(PrecisionNow(20.0, 50.0, 1000.0, 10, "x"), noisy, th)
    assert level == Level.WARN and text.startswith("75% of the last 100 joint_states samples rejected")
    assert judge(PrecisionNow(math.nan, 50.0, math.nan, 0, "x"), quiet, th)[1].endswith("joint 'x' accepted")
