"""``initial_offset`` (delta [m]): a measurement term. The initial straightness is A0 + delta, not the A0 of the
parameters. The live model has no term of its own: the model file folds delta into A0 (its covariance row is
A0's)."""
from __future__ import annotations

from guide_health.models.wear.effects.base import (
    Effect,
    FitContext,
    FitParameter,
    SimulateValue,
)


class InitialOffset(Effect):
    """A measurement term: the initial straightness is A0 + delta."""

    def plausible_strong_size(self, c):
        return {"initial_offset_m": 6e-6}, "delta [um]", 6.0

    def reading_offset_m(self, e) -> float:
        return e.initial_offset_m


EFFECT = InitialOffset(
    id="initial_offset",
    term="A0 is A0 + delta",
    meaning="initial offset: the initial straightness is not the A0 of the parameters",
    separating_duty="a straightness measurement before the first motion",
    simulate=SimulateValue("initial_offset_m", "m", 0.0, "[-1e-3, 1e-3]"),
    live=False,
    needs_given_a0=True,         # with A0 = 0 the baseline fits A0 itself
    fitted_aliases=(("initial_offset_m", "straightness_initial_m"),),     # the model file's A0 = A0 + delta
    fields=(("initial_offset_m", 0.0, "delta (offline; live folded into A0)"),),
    recorded=("initial_offset_m",),
    outside_the_sums=("initial_offset_m",),
)


def fit_parameters(c: FitContext) -> list[FitParameter]:
    """delta."""
    return [FitParameter("initial_offset_m", "m", -1e-3, 1e-3, False, (0.0,))]
