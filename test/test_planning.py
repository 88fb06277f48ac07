"""Maintenance planning (models/wear/planning.py): the limit date at the observed utilisation and under
scenarios, every scenario's life through the live status's own life function (one code path), checked
against the closed forms: Eq. 12 by hand for a known duty and K, Archard's 1/load (W^n with load_exponent),
a shift pattern's weekly hours, a regrind's fresh surface."""
from __future__ import annotations

import math
from datetime import UTC, datetime

import numpy as np
import pytest

from guide_health.models.wear.effects.registry import RATE_NAMES
from guide_health.models.wear.planning import (
    Scenario,
    Utilisation,
    calendar_band_s,
    duration_s,
    observed_utilisation,
    parse_scenario,
    plan_scenario,
    scenario_from_items,
    scenario_inputs,
)
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.models.wear.running_time import RunningClock
from guide_health.params import WEAR_MONITOR_DEFAULTS
from guide_health.params.typed import wear_axis_params
from guide_health.runs import MachineRun

T0 = 1_700_000_000 * 10**9
S = 10**9
LOAD_N, SPEED, STROKE = 2000.0, 0.05, 0.2


def _utc(t_ns: float) -> str:
    return datetime.fromtimestamp(t_ns / 1e9, tz=UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def _monitor(hours: float = 1.0, **over) -> PrecisionMonitor:
    """1 h of 0.05 m/s strokes between 0 and 0.2 m under 2000 N (period 8 s, samples every 0.1 s)."""
    t = T0 + np.arange(0, int(hours * 3600 * 10)) * (S // 10)
    phase = ((t - T0) / S) % 8.0
    x = np.where(phase < 4.0, SPEED * phase, 2 * STROKE - SPEED * phase)
    monitor = PrecisionMonitor(wear_axis_params(dict(WEAR_MONITOR_DEFAULTS, **{
        "rail_start_m": -0.1, "rail_length_m": 0.5, **over})))
    monitor.process_run(MachineRun(joint_t_ns=t, joint_position_m=x, joint_velocity_m_s=np.zeros(0),
                                   load_t_ns=np.array([T0 - 1], np.int64), load_n=np.array([LOAD_N])))
    return monitor


NO_CHANGE = Scenario()


def _plan(monitor, scenario=NO_CHANGE):
    clock = monitor.integrator.clock
    return plan_scenario(monitor.axis.life_inputs(monitor.name), observed_utilisation(clock), clock.last_t_ns,
                         scenario)


def test_no_change_scenario_is_the_live_status_exactly():
    """The no-change scenario's life, band and dates are the status's, to the bit (one code path)."""
    monitor = _monitor()
    report, plan = monitor.report(), _plan(monitor)
    for key in ("", "_low", "_high"):
        assert plan[f"life_h{key}"] == report[f"remaining_life_h{key}"]
        assert plan[f"limit_date_utc{key}"] == report[f"limit_date_utc{key}"]
    assert plan["utilisation"] == report["utilisation"] == 1.0 and math.isfinite(plan["life_h"])


def test_status_dates_carry_the_daily_utilisation_spread():
    """Five days running 24, 4, 12, 12 and 20 h, each to its end (1 Hz samples): the window's 4 whole days back
    from the latest sample vary; the status's limit_date_utc band is the plan's as observed (life band and
    utilisation spread on ln), wider than now + (low, high) / u alone."""
    day = 86400 * S
    t = np.concatenate([T0 + (i + 1) * day - np.arange(hours * 3600, 0, -1) * S
                        for i, hours in enumerate((24, 4, 12, 12, 20))])
    phase = ((t - T0) / S) % 8.0
    monitor = PrecisionMonitor(wear_axis_params(dict(WEAR_MONITOR_DEFAULTS, rail_start_m=-0.1, rail_length_m=0.5)))
    monitor.process_run(MachineRun(joint_t_ns=t, joint_position_m=np.where(phase < 4.0, SPEED * phase,
                                                                           2 * STROKE - SPEED * phase),
                                   joint_velocity_m_s=np.zeros(0), load_t_ns=np.array([T0 - 1], np.int64),
                                   load_n=np.array([200.0])))      # a light load: far from the limit
    report, plan = monitor.report(), _plan(monitor)
    assert report["remaining_life_h_low"] > 100
    assert plan["utilisation_days"] == 4 and plan["utilisation_cv_daily"] > 0.3
    for key in ("limit_date_utc", "limit_date_utc_low", "limit_date_utc_high"):
        assert report[key] == plan[key]
    now, u = monitor.integrator.clock.last_t_ns, report["utilisation"]
    assert plan["limit_t_ns_low"] < now + report["remaining_life_h_low"] / u * 3600 * S - 3600 * S
    assert plan["limit_t_ns_high"] > now + report["remaining_life_h_high"] / u * 3600 * S + 3600 * S
    assert report["limit_date_utc"] == _utc(now + report["remaining_life_h"] / u * 3600 * S)


def test_one_shift_date_is_the_running_life_over_the_weekly_hours_by_hand():
    """Known duty and K: Eq. 7/12 by hand, L = (A_max - A_now) / (K W v / H x 2 / (b (l_min + l_max))),
    A_now = A0 + K W s / H x 2 / (b (l_min + l_max)); at 8 h x 5 days the date is now + L / 40 h weeks."""
    monitor = _monitor()
    p, report = WEAR_MONITOR_DEFAULTS, monitor.report()
    assert report["stroke_min_m"] == report["stroke_max_m"] == pytest.approx(STROKE, rel=1e-9)
    per_work = 2.0 / (p["hardness_pa"] * p["contact_width_m"] * 2 * STROKE)       # A per unit K W s
    k = p["wear_coefficient"]
    a_now = p["straightness_initial_m"] + k * LOAD_N * report["sliding_distance_m"] * per_work
    # the duty window's W v: 100 W but for the window's edges cutting a stroke (2.8e-5 here)
    assert report["duty_load_speed_w"] == pytest.approx(LOAD_N * SPEED, rel=1e-4)
    life_h = (p["straightness_limit_m"] - a_now) / (k * report["duty_load_speed_w"] * per_work) / 3600.0
    shift = _plan(monitor, parse_scenario("one shift: shift=8x5"))
    assert shift["life_h"] == pytest.approx(life_h, rel=1e-6)
    assert shift["utilisation"] == 40.0 / 168.0
    now = monitor.integrator.clock.last_t_ns
    weeks = life_h / 40.0
    assert abs(shift["limit_t_ns"] - (now + weeks * 7 * 86400 * S)) < 1e-6 * weeks * 7 * 86400 * S
    assert shift["limit_date_utc_low"] == _utc(now + shift["life_h_low"] * 168 / 40 * 3600 * S)


@pytest.mark.parametrize("exponent", [None, 1.6])
def test_load_scale_changes_the_life_by_archard_or_the_fitted_exponent(exponent):
    """load 0.8: the life x 1 / 0.8 (Archard, no load_exponent named) or x 0.8^-n with load_exponent n (the
    future rate ~ W^n; the margin left is the same)."""
    over = {} if exponent is None else {"effects": "load_exponent", "load_exponent": exponent,
                                        "load_reference_n": LOAD_N}
    monitor = _monitor(**over)
    base, less = _plan(monitor), _plan(monitor, parse_scenario("load=0.8"))
    n = 1.0 if exponent is None else exponent
    assert less["life_h"] / base["life_h"] == pytest.approx(0.8 ** -n, rel=1e-9)
    assert base["life_h"] == monitor.report()["remaining_life_h"]


def test_scenario_moves_the_effects_rate_and_gradients_by_their_closed_forms():
    """load x0.8, speed x1.5 under load_exponent n and speed_dependent_wear v_lift (registry.SCENARIO_FACTORS):
    the rate per K x 0.8^n x 1.5 x share(1.5 v) / share(v), share = 1 / (1 + (v / v_lift)^1.4); d ln rate / dn
    gains ln 0.8; d ln rate / d v_lift = (1 - share) 1.4 / v_lift moves by (1 - share(1.5 v)) / (1 - share(v))."""
    n, lift = 1.3, 0.04
    monitor = _monitor(effects="load_exponent,speed_dependent_wear", load_exponent=n, load_reference_n=LOAD_N,
                       lift_speed_m_s=lift)
    inputs = monitor.axis.life_inputs(monitor.name)
    now = inputs.effect[3]
    moved = scenario_inputs(inputs, parse_scenario("load=0.8, speed=1.5")).effect[3]

    def share(v):
        return 1.0 / (1.0 + (v / lift) ** 1.4)

    v = now.v_s
    assert v == pytest.approx(SPEED, rel=1e-3)
    factor = 0.8 ** n * 1.5 * share(1.5 * v) / share(v)
    assert moved.rate_work_per_k / now.rate_work_per_k == pytest.approx(factor, rel=1e-12)
    assert moved.v_s == now.v_s * 1.5
    i_n, i_lift = RATE_NAMES.index("load_exponent"), RATE_NAMES.index("lift_speed_m_s")
    assert moved.dln_rate[i_n] - now.dln_rate[i_n] == pytest.approx(math.log(0.8), rel=1e-12)
    assert moved.dln_rate[i_lift] / now.dln_rate[i_lift] == pytest.approx(
        (1 - share(1.5 * v)) / (1 - share(v)), rel=1e-12)
    others = [i for i in range(len(RATE_NAMES)) if i not in (i_n, i_lift)]
    assert np.array_equal(np.asarray(moved.dln_rate)[others], np.asarray(now.dln_rate)[others])


def test_speed_and_stroke_scales_and_the_regrind():
    """speed x2 halves the running life (twice the sliding distance per running hour); strokes x2 doubles it
    (Eq. 7: A / V ~ 1 / (l_min + l_max)); a regrind at D gives D + the fresh surface's life (A = A0)."""
    monitor = _monitor()
    base = _plan(monitor)
    assert _plan(monitor, parse_scenario("speed=2"))["life_h"] == pytest.approx(base["life_h"] / 2, rel=1e-12)
    assert _plan(monitor, parse_scenario("stroke=2"))["life_h"] == pytest.approx(base["life_h"] * 2, rel=1e-12)
    p, now = WEAR_MONITOR_DEFAULTS, monitor.integrator.clock.last_t_ns
    regrind = now + 40 * 3600 * S               # before the limit (84 h at u = 1)
    assert base["life_h"] > 80
    plan = _plan(monitor, Scenario("regrind", regrind_t_ns=regrind))
    rate = (p["wear_coefficient"] * monitor.report()["duty_load_speed_w"] * 2.0
            / (p["hardness_pa"] * p["contact_width_m"] * 2 * STROKE))
    fresh_h = (p["straightness_limit_m"] - p["straightness_initial_m"]) / rate / 3600
    assert not plan["regrind_late"]
    assert abs(plan["limit_t_ns"] - (regrind + fresh_h * 3600 * S)) < 1e-6 * fresh_h * 3600 * S
    late = _plan(monitor, Scenario("late", regrind_t_ns=now + int(base["life_h"] * 2 * 3600) * S))
    assert late["regrind_late"] and late["limit_date_utc"] == base["limit_date_utc"]


def test_relubrication_interval_moves_the_life_through_the_effect():
    """relube under lubrication_interval (a = 1.4 per fitted interval T = 2 h): relubricating every 30 min
    keeps the multiplier low, the life longer than every 8 h; without the effect: a one-line error."""
    monitor = _monitor(hours=1.0, effects="lubrication_interval", lubrication_wear_growth=1.4,
                       lubrication_interval_s=7200.0)
    often = _plan(monitor, parse_scenario("relube=30min"))
    rarely = _plan(monitor, parse_scenario("relube=8h"))
    same = _plan(monitor, parse_scenario("relube=2h"))
    assert often["life_h"] > _plan(monitor)["life_h"] > rarely["life_h"]
    assert same["life_h"] == _plan(monitor)["life_h"]
    for other in ({}, {"effects": "load_exponent", "load_exponent": 1.2, "load_reference_n": LOAD_N}):
        with pytest.raises(ValueError, match="lubrication_interval"):
            _plan(_monitor(**other), parse_scenario("relube=30min"))


def test_daily_utilisation_spread_widens_the_date_band():
    """Days of 20 h, 4 h, 12 h, 12 h of running: cv of (20, 4, 12, 12) / 24 over n = 4 whole days, the band
    sd(ln u) = cv sqrt(1/n + 1/m) combined with the life's half-widths on ln (docs/planning.md)."""
    clock = RunningClock(idle_after_s=300.0, utilisation_window_days=7.0)
    day = 86400 * S
    start = T0
    t, moving = [], []
    for i, hours in enumerate((20, 4, 12, 12)):
        t.extend(start + i * day + np.arange(0, int(hours * 3600), 60) * S)
        moving.extend([True] * int(hours * 60))
    t.append(start + 4 * day)
    moving.append(True)
    clock.advance_many(np.array(t, np.int64), np.array(moving))
    u = observed_utilisation(clock)
    # each day runs from its first sample to its last (a minute before the hour count): the pause is idle
    # from the last counted sample (no samples in it)
    daily = (np.array([12, 12, 4, 20]) * 3600.0 - 60.0) / 86400.0
    assert u.days == 4
    assert u.cv_daily == pytest.approx(daily.std(ddof=1) / daily.mean(), rel=1e-12)
    life = (1000 * 3600.0, 800 * 3600.0, 1300 * 3600.0)
    mid, low, high = calendar_band_s(life, u)
    m = mid / 86400.0
    spread = 1.6448536269514722 * u.cv_daily * math.sqrt(1 / 4 + 1 / m)
    assert mid == life[0] / u.mean
    assert low == pytest.approx(mid * math.exp(-math.hypot(math.log(1000 / 800), spread)), rel=1e-12)
    assert high == pytest.approx(mid * math.exp(math.hypot(math.log(1300 / 1000), spread)), rel=1e-12)
    assert calendar_band_s(life, Utilisation(0.5)) == (2000 * 3600.0, 1600 * 3600.0, 2600 * 3600.0)


def test_scenario_grammar():
    s = parse_scenario("second shift: load=0.8, speed=1.2, stroke=0.5, relube=2w, shift=16x5, regrind=2027-03-01")
    assert s == Scenario("second shift", 0.8, 1.2, 0.5, 14 * 86400.0, 16.0, 5.0,
                         int(datetime(2027, 3, 1, tzinfo=UTC).timestamp()) * S)
    assert parse_scenario("load=0.8").name == "load=0.8"
    assert duration_s("250") == 250 * 3600.0 and duration_s("90min") == 5400.0
    assert scenario_from_items("y", {"load": 0.5}).load_scale == 0.5
    for bad, why in (("load=0", "> 0"), ("load=x", "not a number"), ("shift=25x5", "hours per day"),
                     ("colour=red", "unknown"), ("load", "not key=value"), ("regrind=tomorrow", "no date"),
                     ("relube=soon", "no duration")):
        with pytest.raises(ValueError, match=why):
            parse_scenario(bad)
