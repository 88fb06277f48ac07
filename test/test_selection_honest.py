"""Backward pass and near-ties of the forward selection (analysis/discrepancy/selection.py) on a table of
fits whose BIC values are given (numbers chosen by hand, the rules checked against them)."""
from __future__ import annotations

import math
from dataclasses import dataclass

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
