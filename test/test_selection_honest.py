"""Backward pass and near-ties of the forward selection (analysis/discrepancy/selection.py) on a table of
fits whose BIC values are given (numbers chosen by hand, the rules checked against them)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from guide_health.analysis.discrepancy.selection import TIE_MARGIN, forward_selection
from guide_health.analysis.discrepancy.workflow import SEPARATING_DUTY, _tie


@dataclass
class Fake:
    bic: float
    heldout_rmse_um: float = math.nan
    n_heldout: int = 0


def table_fit(table):
    def fit(effects, warm=None):
        return Fake(table[frozenset(effects)])
    return fit


def test_backward_pass_drops_an_effect_made_redundant():
    """Forward: A (-40) first, then B (-55 with A; C would give -52), then C (-70). With B and C in, A is
    redundant: B + C alone is -69, only 1 above, so the backward pass drops A (cost 1 < 10)."""
    table = {frozenset(): 0.0, frozenset("A"): -40.0, frozenset("B"): -30.0, frozenset("C"): -30.0,
             frozenset("AB"): -55.0, frozenset("AC"): -52.0, frozenset("ABC"): -70.0, frozenset("BC"): -69.0}
    sel = forward_selection(table_fit(table), ["A", "B", "C"], bic_threshold=10.0)
    assert sel.dropped == [{"effect": "A", "delta_bic": 1.0}] and sel.named == ["B", "C"]
    assert sel.final.bic == -69.0 and sel.ties == []


def test_near_ties_are_reported():
    """A (-40) and C (-39) both earn their place in round 1 within BIC 2: a near-tie; B (-35) is not."""
    table = {frozenset(): 0.0, frozenset("A"): -40.0, frozenset("B"): -35.0, frozenset("C"): -39.0,
             frozenset("AB"): -41.0, frozenset("AC"): -41.0}
    sel = forward_selection(table_fit(table), ["A", "B", "C"], bic_threshold=10.0)
    assert sel.named == ["A"]
    assert sel.ties == [{"round": 1, "selected": "A", "tied": ["C"], "bic_margin": TIE_MARGIN}]


def test_near_tie_message_names_the_separating_duty():
    msg = _tie({"round": 1, "selected": "load_exponent", "tied": ["speed_dependent_wear"], "bic_margin": 2.0})
    assert msg["message"].startswith("the data cannot tell load_exponent from speed_dependent_wear")
    assert SEPARATING_DUTY["load_exponent"] in msg["message"]
    assert SEPARATING_DUTY["speed_dependent_wear"] in msg["message"]


# --- the residual checks after the fit (analysis/discrepancy/analysis.py) -----------------------------------

class LineProblem:
    """A straight-line 'wear model' y = a + b t over 40 measurements, the last 10 held out."""

    def __init__(self, y_m):
        self.t_s = np.arange(40) * 600.0
        self.y_m = np.asarray(y_m, dtype=float)
        self.heldout_mask = np.arange(40) >= 30

    def predict_m(self, values):
        return values["a"] + values["b"] * self.t_s


class LineFit:
    def __init__(self, values, cov, rss_um2, n_fit=30, n_params=2):
        self.values, self.rss_um2, self.n_fit, self.n_params = values, rss_um2, n_fit, n_params
        self.extra = {"covariance": {"names": ["a", "b"], "matrix": np.asarray(cov)}}


def test_forecast_check_is_generalised_least_squares_on_bias_and_drift():
    """Independent computation: whiten the forecast error with the Cholesky factor of S = s^2 I + J C J'
    (J = [1, t] exactly for a line), regress on the whitened [1, t - mean]: F = explained SS / 2."""
    from scipy import stats

    from guide_health.analysis.discrepancy.analysis import forecast_check

    rng = np.random.default_rng(4)
    values = {"a": 15e-6, "b": 1e-9}
    cov = np.array([[0.04e-12, 0.0], [0.0, 1e-26]])
    s2 = (0.3e-6) ** 2
    prob = LineProblem(15e-6 + 1e-9 * np.arange(40) * 600.0 + rng.normal(0, 0.3e-6, 40))
    prob.y_m[30:] += np.linspace(0.0, 1.2e-6, 10)                      # the forecast drifts away
    got = forecast_check(prob, LineFit(values, cov, rss_um2=s2 * 1e12 * 28))
    t = prob.t_s[30:]
    jac = np.column_stack((np.ones(10), t))
    sigma = s2 * np.eye(10) + jac @ cov @ jac.T
    chol = np.linalg.cholesky(sigma)
    e = prob.y_m[30:] - (values["a"] + values["b"] * t)
    xw = np.linalg.solve(chol, np.column_stack((np.ones(10), (t - t.mean()) / 3600.0)))
    ew = np.linalg.solve(chol, e)
    beta = np.linalg.lstsq(xw, ew, rcond=None)[0]
    f = float(np.sum((xw @ beta) ** 2)) / 2.0
    assert got["f"] == pytest.approx(f, rel=1e-6)
    assert got["p_value"] == pytest.approx(stats.f.sf(f, 2, 28), rel=1e-6)
    assert got["systematic"] and got["drift_um_per_h"] == pytest.approx(beta[1] * 1e6, rel=1e-6)
    # a held-out span that is only noisier (3x, no bias, no drift) is no structure here
    calm = LineProblem(15e-6 + 1e-9 * np.arange(40) * 600.0)
    calm.y_m[30:] += np.tile([0.9e-6, -0.9e-6], 5)
    assert not forecast_check(calm, LineFit(values, cov, rss_um2=s2 * 1e12 * 28))["systematic"]


def test_binned_work_f_test_is_calibrated_and_sees_a_sine_along_the_rail():
    """Cells of 4 positions x 40 intervals with random work: a residual of pure noise gives F-test p-values
    with the F distribution's size (p < 0.05 in 5 % of 400 seeded draws, within the binomial 3 sigma); a
    residual that follows the cumulative work at one position (any shape: here only the second bin) is found."""
    from types import SimpleNamespace

    from guide_health.analysis.discrepancy.analysis import binned_work_tests

    rng = np.random.default_rng(11)
    n, positions = 40, np.array([0.02, 0.07, 0.12, 0.17])
    interval = np.repeat(np.arange(n), positions.size)
    work = rng.uniform(0.5, 1.5, interval.size) * 1e4
    cells = SimpleNamespace(interval=interval, work_nm=work, speed_m_s=rng.uniform(0.01, 0.1, interval.size),
                            load_n=rng.uniform(1e3, 1e4, interval.size), pass_length_m=np.full(interval.size, 0.2),
                            position_m=np.tile(positions, n))
    problem = SimpleNamespace(cells=cells, y_m=np.zeros(n), retract=np.zeros(interval.size, bool))
    mask = np.ones(n, bool)

    def p_of(residual_um, condition="position_m"):
        rows = binned_work_tests(problem, residual_um, mask)
        return next(r["p_value"] for r in rows if r["condition"] == condition)

    small = sum(p_of(rng.normal(0, 1, n)) < 0.05 for _ in range(400))
    assert abs(small - 20) <= 3 * math.sqrt(400 * 0.05 * 0.95)
    in_bin = np.cumsum(np.bincount(interval, weights=work * (cells.position_m == 0.07), minlength=n))
    # 3 noise sd over the record, in the second bin only (measured p = 3e-5; a plain trend would be absorbed
    # by the constant-and-bins fit only if the bins' work did not vary between intervals)
    assert p_of(in_bin / in_bin[-1] * 3.0 + rng.normal(0, 1, n)) < 1e-3


def test_spearman_equals_scipy_stats_with_ties_and_constant_input():
    """analysis.spearman (scipy.special, so that diagnose does not import scipy.stats) against
    scipy.stats.spearmanr: rho and p to 1e-12 on 200 seeded samples with and without ties; a constant input
    gives NaN as scipy's does."""
    from scipy import stats

    from guide_health.analysis.discrepancy.analysis import spearman

    rng = np.random.default_rng(11)
    for i in range(200):
        n = int(rng.integers(6, 400))
        x = rng.normal(size=n)
        y = 0.2 * x + rng.normal(size=n)
        if i % 3 == 0:
            x = np.round(x, 1)
        if i % 4 == 0:
            y = np.round(y)
        rho, p = spearman(x, y)
        ref = stats.spearmanr(x, y)
        assert rho == pytest.approx(ref[0], abs=1e-12)
        assert p == pytest.approx(ref[1], rel=1e-10, abs=1e-300)
    assert all(np.isnan(spearman(np.ones(8), np.arange(8.0))))
