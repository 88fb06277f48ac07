"""The discrepancy fit's fast paths give the numbers of the plain computation, bit for bit.

- WearProblem.fit_span(): the fit's residuals over the fit span's cells only equal predict_m()[fit_mask];
- the effective-work sums reused between evaluations that differ only outside the multiplier (K, A0, w,
  delta, c_T, b) equal those of a fresh problem, and a change of a multiplier parameter is not served stale;
- the rolling regime model's asperity-share table, built once per guide, equals a fresh build.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from guide_health.analysis.discrepancy.duty import PER_CELL_FIELDS, DutyCellAccumulator, duty_cells_from_runs
from guide_health.analysis.discrepancy.model import WearProblem
from guide_health.params import simulation_params, wear_monitor_params
from guide_health.sim.machine import simulate_machine

JOBS = Path(__file__).resolve().parents[1] / "config" / "machine_jobs.yaml"

EVERY_EFFECT = dict(running_in_ratio=2.0, running_in_distance_m=400.0, retract_wear_factor=0.3, lift_speed_m_s=0.05,
                    load_exponent=1.5, stroke_distribution_weight=0.7, thermal_drift_m_per_k=1e-6,
                    initial_offset_m=3e-6, thermal_offset_m=1e-6, wear_rate_change_time_s=2e4,
                    wear_rate_change_factor=2.0, lubrication_interval_s=7000.0, lubrication_wear_growth=0.3,
                    load_gradient_per_m=0.5)


def problem_of(resets: bool) -> WearProblem:
    params = wear_monitor_params(JOBS)
    sim = simulation_params(JOBS)
    sim.update(duration_h=6.0, joint_state_rate_hz=5.0, load_rate_hz=5.0, straightness_noise_m=3e-7)
    run = simulate_machine(params, sim, seed=4, effects={"running_in": 2.0})
    if not resets:
        return WearProblem(duty_cells_from_runs(run, params["slider_length_m"]), params)
    t = np.asarray(run.joint_t_ns)
    acc = DutyCellAccumulator(params["slider_length_m"], resets_ns=[int(t[t.size // 3]), int(t[2 * t.size // 3])],
                              reset_straightness_m=[2e-6, np.nan])
    acc.add(run)
    return WearProblem(acc.finish(), params)


@pytest.fixture(scope="module", params=[False, True], ids=["one_surface", "two_wear_resets"])
def problem(request):
    return problem_of(request.param)


def value_sets(problem: WearProblem) -> list[dict]:
    k0 = problem.k0
    a0 = {"straightness_initial_m": 1e-6} if problem.a0_free else {}
    return [{"wear_coefficient": k0, **a0},
            {"wear_coefficient": 1.3 * k0, **a0},                                  # K only: the sums reused
            {"wear_coefficient": k0, "running_in_ratio": 2.0, "running_in_distance_m": 300.0, **a0},
            {"wear_coefficient": k0, "running_in_ratio": 2.0, "running_in_distance_m": 300.000001, **a0},
            {"wear_coefficient": 0.9 * k0, **EVERY_EFFECT, **a0},
            {"wear_coefficient": 0.9 * k0, **EVERY_EFFECT, "initial_offset_m": -2e-6, **a0},
            {"wear_coefficient": 0.9 * k0, **EVERY_EFFECT, "load_gradient_per_m": -0.5, **a0}]


def test_fit_span_predicts_the_fit_measurements_bit_for_bit(problem):
    span = problem.fit_span()
    n_fit = int(problem.fit_mask.sum())
    assert span.y_m.size == n_fit < problem.y_m.size
    assert span.cells.cells < problem.cells.cells          # the held-out measurements' cells are left out
    assert all(getattr(span.cells, f) is None or getattr(span.cells, f).size == span.cells.cells
               for f in PER_CELL_FIELDS)
    for values in value_sets(problem):
        full = problem.predict_m(values)
        assert np.array_equal(span.predict_m(values), full[problem.fit_mask])
        assert np.ptp(full) > 1e-7                          # the prediction is not a constant


def test_reused_sums_equal_a_fresh_evaluation(problem):
    """Each value set evaluated after the previous one (the sums kept when only K, A0 or an added term
    changed) equals the same set on a problem that evaluates nothing else."""
    sets = value_sets(problem)
    previous = None
    span = problem.fit_span()
    for values in sets:
        after_others = span.predict_m(values)
        fresh = problem.fit_span().predict_m(values)       # a new span has no sums yet
        assert np.array_equal(after_others, fresh)
        if previous is not None:
            assert not np.array_equal(after_others, previous)   # every set moves the prediction
        previous = after_others


def test_rolling_share_table_built_once_equals_a_fresh_build():
    from guide_health.models.rolling import ball_contact
    from guide_health.models.rolling.lubrication import greenwood_tripp_f52_table
    from guide_health.models.wear.precision import PrecisionMonitor
    from guide_health.params.typed import wear_axis_params

    params = wear_monitor_params(Path(__file__).resolve().parents[1] / "config" / "nsk_lh45.yaml")
    first = PrecisionMonitor(wear_axis_params(params)).rolling.regime_model
    second = PrecisionMonitor(wear_axis_params(params)).rolling.regime_model
    assert greenwood_tripp_f52_table() is greenwood_tripp_f52_table()
    axes = (tuple(first._log_lambda_axis), tuple(first._log_load_axis))
    fresh = ball_contact._asperity_share_table.__wrapped__(first.guide, *axes)
    assert first._share == second._share == [list(row) for row in fresh]
    assert first._share is not second._share                # each monitor holds its own rows
    assert 0.0 < np.min(fresh) < np.max(fresh) <= 1.0
