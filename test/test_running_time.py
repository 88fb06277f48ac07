"""Running hours and calendar dates (models/wear/running_time.py): an idle machine keeps its last running
duty, its remaining life in running hours stays as it was, and the calendar date of the limit moves by the
idle time's effect on the utilisation, computed here by hand."""
from __future__ import annotations

import math
from datetime import UTC, datetime

import numpy as np
import pytest

from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.models.wear.running_time import RunningClock
from guide_health.params import WEAR_MONITOR_DEFAULTS
from guide_health.params.typed import wear_axis_params
from guide_health.runs import MachineRun

T0 = 1_700_000_000 * 10**9
S = 10**9
IDLE_AFTER_S = 300.0


def _utc(t_ns: float) -> str:
    return datetime.fromtimestamp(t_ns / 1e9, tz=UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def _triangle(t_ns: np.ndarray) -> np.ndarray:
    """0.05 m/s strokes between 0 and 0.2 m (period 8 s): every 0.1 s sample moves by 5 mm."""
    phase = ((t_ns - T0) / S) % 8.0
    return np.where(phase < 4.0, 0.05 * phase, 0.4 - 0.05 * phase)


def _run(t_ns: np.ndarray, x: np.ndarray, load_n: float = 2000.0) -> MachineRun:
    return MachineRun(joint_t_ns=t_ns, joint_position_m=x, joint_velocity_m_s=np.zeros(0),
                      load_t_ns=np.array([T0 - 1], np.int64), load_n=np.array([load_n]))


def _monitor(**over) -> PrecisionMonitor:
    return PrecisionMonitor(wear_axis_params(dict(WEAR_MONITOR_DEFAULTS, **{
        "idle_after_s": IDLE_AFTER_S, "rail_start_m": -0.1, "rail_length_m": 0.5, **over})))


def test_clock_sample_by_sample_equals_arrays():
    """The live decisions (advance) and the offline ones (advance_many over any chunks) are the same."""
    rng = np.random.default_rng(1)
    steps = rng.choice([S // 10, 50 * S, 400 * S, 4000 * S], size=3000, p=[0.9, 0.05, 0.03, 0.02])
    t = T0 + np.cumsum(steps)
    moving = rng.random(t.size) < 0.6
    one = RunningClock(IDLE_AFTER_S, utilisation_window_days=1.0)      # the run spans 3.3 days
    taus = [one.advance(int(ti), bool(m)) for ti, m in zip(t, moving)]
    many = RunningClock(IDLE_AFTER_S, utilisation_window_days=1.0)
    cuts = [0, 1, 5, 999, 1000, 2500, t.size]
    tau, counted = zip(*(many.advance_many(t[a:b], moving[a:b]) for a, b in zip(cuts, cuts[1:])))
    tau, counted = np.concatenate(tau), np.concatenate(counted)
    assert [x is not None for x in taus] == counted.tolist()
    assert [x for x in taus if x is not None] == tau[counted].tolist()
    assert one.state() == many.state() and len(one.idle_pause_end_ns) > 10
    # tau never runs backwards and stops for every idle pause: tau_end = t_end - sum of the pauses; the
    # pauses kept are those that ended within the last day, the others forgotten
    assert np.all(np.diff(tau[counted]) >= 0)
    every = RunningClock(IDLE_AFTER_S, utilisation_window_days=366.0)
    every.advance_many(t, moving)
    assert every.idle_ns == one.idle_ns == sum(e - s for s, e in zip(every.idle_pause_start_ns,
                                                                      every.idle_pause_end_ns))
    last_end = every.idle_pause_end_ns[-1]
    kept = [(s, e) for s, e in zip(every.idle_pause_start_ns, every.idle_pause_end_ns) if e > last_end - 86400 * S]
    assert list(zip(one.idle_pause_start_ns, one.idle_pause_end_ns)) == kept
    assert len(kept) < len(every.idle_pause_end_ns) and t[-1] - t[0] > 3 * 86400 * S


def test_idle_gap_of_ten_hours_keeps_the_life_and_moves_the_date_by_the_utilisation():
    """2 h of strokes, then 10 h standing still (joint_states at 1 Hz, the controller on): the remaining
    life in running hours stays exactly its value at the last motion, finite; the utilisation is the
    running share u = 1 - (10 h - idle_after_s) / 12 h (the first idle_after_s of a pause count as
    running); the limit's date moves from t_last_motion + L to t_end + L / u."""
    t_run = T0 + np.arange(0, 2 * 3600 * 10) * (S // 10)
    monitor = _monitor()
    monitor.process_run(_run(t_run, _triangle(t_run)))
    before = monitor.report()
    life = before["remaining_life_h"]
    assert math.isfinite(life) and life > 0 and before["utilisation"] == 1.0
    assert before["limit_date_utc"] == _utc(t_run[-1] + life * 3600 * S)
    assert "idle_since_utc" not in before

    t_idle = t_run[-1] + np.arange(1, 10 * 3600 + 1) * S
    monitor.process_run(_run(t_idle, np.full(t_idle.size, _triangle(t_run[-1:])[0])))
    after = monitor.report()
    assert after["remaining_life_h"] == life                  # exactly: the duty of the last running hour
    assert after["duty_load_speed_w"] == before["duty_load_speed_w"]
    t_end, t_motion = int(t_idle[-1]), int(t_run[-1])
    u = 1.0 - (t_end - (t_motion + IDLE_AFTER_S * S)) / (t_end - T0)
    assert after["utilisation"] == pytest.approx(u, rel=1e-12)
    assert after["utilisation"] == pytest.approx((2 * 3600 + 300 - 0.1) / (12 * 3600 - 0.1), rel=1e-12)
    assert after["limit_date_utc"] == _utc(t_end + life / u * 3600 * S)
    assert after["limit_date_utc_low"] == _utc(t_end + after["remaining_life_h_low"] / u * 3600 * S)
    assert after["idle_since_utc"] == _utc(t_motion)
    # the same samples in one batch (the vectorised path keeps the buckets the idle axis reports from)
    whole = _monitor()
    t_all = np.concatenate((t_run, t_idle))
    whole.process_run(_run(t_all, np.concatenate((_triangle(t_run), np.full(t_idle.size, _triangle(t_run[-1:])[0])))))
    assert whole.report()["remaining_life_h"] == pytest.approx(life, rel=1e-12)


def test_no_samples_for_ten_hours_then_running_again():
    """The machine (and its recorder) off for 10 h: the pause is idle, not running. In running hours the gap is
    invisible: 2 h + gap + 1 h ends with the life of 3 h without a gap (the duty window holds running time
    only), and the utilisation is 1 - 10 h / 13 h. (stamp_horizon_s above the gap: the gate takes the
    stamps after it as the same time base.)"""
    t1 = T0 + np.arange(0, 2 * 3600 * 10) * (S // 10)
    t2 = t1[-1] + 10 * 3600 * S + np.arange(1, 3600 * 10 + 1) * (S // 10)
    monitor = _monitor(stamp_horizon_s=86400.0)
    monitor.process_run(_run(t1, _triangle(t1)))
    before = monitor.report()["remaining_life_h"]
    monitor.process_run(_run(t2, _triangle(t2)))
    report = monitor.report()
    t3 = T0 + np.arange(0, 3 * 3600 * 10) * (S // 10)
    continuous = _monitor(stamp_horizon_s=86400.0)
    continuous.process_run(_run(t3, _triangle(t3)))
    assert report["remaining_life_h"] == pytest.approx(continuous.report()["remaining_life_h"], rel=1e-9)
    assert report["remaining_life_h"] == pytest.approx(before - 1.0, rel=1e-3)   # one running hour used
    pause = (t2[0] - t1[-1]) / S
    assert report["utilisation"] == pytest.approx(1.0 - pause / ((t2[-1] - T0) / S), rel=1e-12)
    assert "idle_since_utc" not in report
    # without the running clock (a pause never idle) the hour after the gap would be the whole duty window
    calendar = _monitor(idle_after_s=86400.0, stamp_horizon_s=86400.0)
    calendar.process_run(_run(t1, _triangle(t1)))
    calendar.process_run(_run(t2[:50], _triangle(t2[:50])))
    assert calendar.report()["remaining_life_h"] > 3 * before
