"""README/docs promises checked against hand computations (no ROS here; the node and command-line
promises are in test_readme_promises_e2e.py).

* remaining life after a change of duty: the duty W v is averaged over ``duty_window_s`` (docs/interfaces.md),
  remaining life = (A_max - A0 - K g) / (K dg/dt) (seed 000 Eq. 12 from the present state), every number
  computed here from the motion schedule written in the test;
* WARN/ERROR levels: life below ``life_warn_h`` -> WARN, below ``life_error_h`` -> ERROR, straightness above
  ``straightness_warn_fraction`` of the limit -> WARN, at the limit -> ERROR (docs/physics.md, interfaces.md);
* "straightness before any motion" is rejected and counted in ``rejected_samples``, live and offline alike.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from guide_health.models.levels import Level
from guide_health.models.wear.input_rules import STRAIGHTNESS_WITHOUT_TIME_BASE, rejected_key
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.params import wear_monitor_params
from guide_health.params.typed import wear_axis_params
from guide_health.runs import MachineRun

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "config" / "bench_000.yaml"
T0_S = 1_700_000_000                  # a multiple of the 10 s duty bucket (600 s window / 60 buckets)
NS = 1_000_000_000
DT_S, STEP_M = 0.1, 0.005             # 10 Hz joint samples moving 5 mm each: 0.05 m/s, no dwell
SPEED = STEP_M / DT_S
# bench_000.yaml (seed 000 section 2.2): b = 40 mm, H = 199 MPa, K = 4.42e-6, A0 = 15 um, A_max = 100 um
B_M, H_PA, K, A0_M, AMAX_M = 0.040, 199.0e6, 4.42e-6, 15.0e-6, 100.0e-6
L_MIN, L_MAX = 0.100, 0.300           # strokes of the schedule below
W1_N, W2_N = 6000.0, 3000.0           # duty before and after the change
T_CHANGE_S = 1800.0
WINDOW_S = 600.0


def schedule(n_samples: int) -> MachineRun:
    """0 -> 0.3 -> 0 -> 0.1 -> 0 m repeated at 0.05 m/s, joint stamps T0 + 0.05 + 0.1 i; load messages
    every second, 6000 N before T_CHANGE_S and 3000 N from it."""
    steps = np.tile(np.r_[np.ones(60), -np.ones(60), np.ones(20), -np.ones(20)], n_samples // 160 + 1)
    x = np.r_[0.0, np.cumsum(steps)][:n_samples] * STEP_M
    t_ns = T0_S * NS + 50_000_000 + np.arange(n_samples, dtype=np.int64) * 100_000_000
    load_t_s = np.arange(0, int(n_samples * DT_S) + 1)
    load = np.where(load_t_s < T_CHANGE_S, W1_N, W2_N)
    return MachineRun(joint_name="x", joint_t_ns=t_ns, joint_position_m=x,
                      load_t_ns=(T0_S + load_t_s).astype(np.int64) * NS, load_n=load)


def params(**over) -> dict:
    p = wear_monitor_params(BENCH)
    p.update(duty_window_s=WINDOW_S, straightness_model="eq7", life_warn_h=20.0, life_error_h=5.0)
    p.update(over)
    return p


def live_monitor(run: MachineRun, p: dict) -> PrecisionMonitor:
    """Sample by sample, loads first at equal stamps (the live node's order with the stamp-aligned feed)."""
    m = PrecisionMonitor(wear_axis_params(p))
    li = 0
    for t, x in zip(run.joint_t_ns.tolist(), run.joint_position_m.tolist()):
        while li < run.load_t_ns.size and run.load_t_ns[li] <= t:
            m.on_load(int(run.load_t_ns[li]), float(run.load_n[li]))
            li += 1
        m.on_joint(t, x)
    return m


def hand_life_h(work_nm: float, duty_w: float) -> float:
    """Eq. 7/10/12 by hand: g = 2 W s / (H b (l_min + l_max)) per unit K, dg/dt the same with the duty."""
    per_k = 2.0 / (H_PA * B_M * (L_MIN + L_MAX))
    return (AMAX_M - A0_M - K * per_k * work_nm) / (K * per_k * duty_w) / 3600.0


@pytest.mark.parametrize("path", ["live", "offline"])
def test_remaining_life_after_a_change_of_duty_follows_the_duty_window(path):
    """Catches: no window (whole-history mean 250 W instead of 150 W after the change), a window one bucket
    too long or short (+-2.3 % at mid-transition), the window applied to sliding distance instead of W v,
    a remaining life from total rather than current duty."""
    # (a) mid-transition: 300 s after the change, the 590 s window holds 290 s at 6000 N, 300 s at 3000 N
    # (b) 900 s after the change: the window holds only the new duty, W v = 3000 N x 0.05 m/s = 150 W
    for after_s, duty_hand_w in ((300.0, (W1_N * 290 + W2_N * 300) * SPEED / 590.0),
                                 (900.0, W2_N * SPEED)):
        n = int(round((T_CHANGE_S + after_s) / DT_S)) + 1         # last stamp T0 + T_CHANGE + after + 0.05
        run = schedule(n)
        m = live_monitor(run, params()) if path == "live" else PrecisionMonitor(wear_axis_params(params()))
        if path == "offline":
            m.process_run(run)
        r = m.report()
        assert (r["stroke_min_m"], r["stroke_max_m"]) == pytest.approx((L_MIN, L_MAX), abs=1e-9)
        assert r["sliding_distance_m"] == pytest.approx((n - 1) * STEP_M, rel=1e-9)
        assert r["duty_load_speed_w"] == pytest.approx(duty_hand_w, rel=1e-3)
        work_hand = (W1_N * T_CHANGE_S + W2_N * after_s) * SPEED   # sum of W ds since the start
        assert r["straightness_um"] == pytest.approx(
            1e6 * (A0_M + K * 2 * work_hand / (H_PA * B_M * (L_MIN + L_MAX))), rel=1e-4)
        assert r["remaining_life_h"] == pytest.approx(hand_life_h(work_hand, duty_hand_w), rel=1e-3)
        # without the window (whole-history mean duty) the life would differ by far more than the tolerance
        whole = (work_hand / ((n - 1) * DT_S))
        assert abs(hand_life_h(work_hand, whole) / r["remaining_life_h"] - 1) > 0.05


def _levels(p_over: dict) -> tuple[int, str]:
    run = schedule(3001)                        # 300 s at 6000 N: g known by hand
    m = PrecisionMonitor(wear_axis_params(params(**p_over)))
    m.process_run(run)
    r = m.report()
    return r["level"], r["message"], r


def test_warn_and_error_levels_from_the_life_and_straightness_thresholds():
    """Thresholds set around the hand-computed remaining life (and straightness): OK, WARN, ERROR each occur.
    Catches: swapped warn/error comparisons, '>' for '<', the warn fraction applied to the life, a missing
    ERROR at the limit."""
    work = W1_N * 300.0 * SPEED
    life_h = hand_life_h(work, W1_N * SPEED)            # about 1620 h at 300 W
    a_um = 1e6 * (A0_M + K * 2 * work / (H_PA * B_M * (L_MIN + L_MAX)))
    level, _, r = _levels({"life_warn_h": 0.5 * life_h, "life_error_h": 0.25 * life_h})
    assert r["remaining_life_h"] == pytest.approx(life_h, rel=2e-3)
    assert level == Level.OK
    level, msg, _ = _levels({"life_warn_h": 2.0 * life_h, "life_error_h": 0.5 * life_h})
    assert level == Level.WARN and "remaining precision life" in msg
    level, msg, _ = _levels({"life_warn_h": 4.0 * life_h, "life_error_h": 2.0 * life_h})
    assert level == Level.ERROR and "remaining precision life" in msg
    # straightness thresholds (life thresholds out of the way)
    quiet = {"life_warn_h": 1e-3 * life_h, "life_error_h": 0.0}
    level, _, _ = _levels(dict(quiet, straightness_limit_m=a_um * 1e-6 / 0.7, straightness_warn_fraction=0.8))
    assert level == Level.OK
    level, _, _ = _levels(dict(quiet, straightness_limit_m=a_um * 1e-6 / 0.9, straightness_warn_fraction=0.8))
    assert level == Level.WARN
    level, msg, _ = _levels(dict(quiet, straightness_limit_m=a_um * 1e-6 * 0.99, straightness_warn_fraction=0.8))
    assert level == Level.ERROR and "exceeds the limit" in msg


@pytest.mark.parametrize("path", ["live", "offline"])
def test_straightness_before_any_motion_is_rejected_and_counted(path):
    """interfaces.md, bad input: "straightness before any motion". The measurement stamped before the
    first joint sample is rejected (not applied with zero wear), counted under its reason and in
    rejected_samples, live and offline alike; the later ones still apply."""
    run = schedule(2001)
    run.straightness_t_ns = np.array([run.joint_t_ns[0] - NS, run.joint_t_ns[1000], run.joint_t_ns[2000]])
    run.straightness_m = np.array([15.0e-6, 15.5e-6, 16.0e-6])
    if path == "offline":
        m = PrecisionMonitor(wear_axis_params(params()))
        m.process_run(run)
    else:
        m = PrecisionMonitor(wear_axis_params(params()))
        assert m.on_straightness(int(run.straightness_t_ns[0]), 15.0e-6) == STRAIGHTNESS_WITHOUT_TIME_BASE
        for t_ns, x in zip(run.joint_t_ns.tolist(), run.joint_position_m.tolist()):
            if t_ns == run.joint_t_ns[0]:
                m.on_load(int(run.load_t_ns[0]), W1_N)
            m.on_joint(t_ns, x)
            if t_ns in (run.straightness_t_ns[1], run.straightness_t_ns[2]):
                m.on_straightness(t_ns, float(run.straightness_m[run.straightness_t_ns.tolist().index(t_ns)]))
    r = m.report()
    assert r["measurements"] == 2
    assert r["rejected_samples"] == 1
    assert r[rejected_key(STRAIGHTNESS_WITHOUT_TIME_BASE)] == 1
    assert r["straightness_measured_um"] == pytest.approx(16.0)
    assert not math.isnan(r["straightness_um"])
