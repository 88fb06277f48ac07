"""What an effect of the registry declares (plain data, no physics): its parameters, its rows in the model
file's covariance, its values for ``simulate --effect`` and its words for the report."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class EffectParameter:
    """A wear_monitor parameter an effect owns: name, default (the no-effect value, or the reference the
    effect is measured from), unit, allowed range (params/schema.py's range syntax), meaning, choices."""

    name: str
    default: float | str
    unit: str
    range_text: str
    meaning: str
    choices: tuple = ()


@dataclass(frozen=True)
class CovarianceRow:
    """A row of the model file's effect_covariance. ``row``: its place in the file (a file format: every
    model file written so far has it there); ``since``: the generation of model files that added it
    (older files hold only the rows of earlier generations, as the matrix's leading block); ``rate``: the
    parameter's multiplier sets the present wear rate (the live duty buckets carry d(work)/d(it))."""

    name: str
    row: int
    since: int
    rate: bool = False


@dataclass(frozen=True)
class SimulateValue:
    """What ``guide-health simulate --effect ID=VALUE`` sets: the parameter, its unit, its no-effect value and
    (when it differs from the wear_monitor parameter's, or there is none) its allowed range, and the
    EffectParameters field it sets when that is named otherwise."""

    name: str
    unit: str
    no_effect: float
    range_text: str = ""
    field: str = ""


@dataclass(frozen=True)
class LiveRequirement:
    """What a live effect needs of one of its parameters: ``condition`` "> 0" or "!= 0" (else the effect would
    do nothing, or divide by zero), ``note`` said after it."""

    parameter: str
    condition: str
    note: str = ""

    def holds(self, value: float) -> bool:
        return value > 0 if self.condition == "> 0" else value != 0.0


@dataclass(frozen=True)
class Effect:
    """One entry of the registry (models/wear/effects/registry.py).

    ``duty``: a multiplier of the work by when and where it is done (the second group of candidates);
    ``live``: the live model integrates it (else diagnose names it but the model file leaves it out, or folds
    its fitted value into a row of its own: ``fitted_aliases``); ``material``: a property of the material pair
    and lubricant, pooled by the fleet prior; ``parameters``: the wear_monitor parameters it owns;
    ``fitted_to_file``: the fitted values the model file carries under the same name; ``fitted_aliases``:
    {fitted name: covariance row} when the names differ; ``covariance_rows``: its rows in the model file;
    ``requires``: what the live effect needs of its parameters; ``term``: its formula (the docs table);
    ``meaning`` and ``separating_duty``: the report's words (what it is; the duty that tells it apart);
    ``needs_temperature`` / ``needs_given_a0``: when it can be a candidate; ``reported_extra``: derived values
    the report lists with its fitted ones. Its
    module also holds ``fit_parameters`` (the discrepancy fit's bounds and starts for a record)."""

    id: str
    term: str
    meaning: str
    separating_duty: str
    simulate: SimulateValue
    duty: bool = False
    live: bool = True
    material: bool = False
    parameters: tuple[EffectParameter, ...] = ()
    fitted_to_file: tuple[str, ...] = ()
    fitted_aliases: tuple[tuple[str, str], ...] = ()
    covariance_rows: tuple[CovarianceRow, ...] = ()
    requires: LiveRequirement | None = None
    needs_temperature: bool = False          # a candidate only with a temperature record
    needs_given_a0: bool = False             # a candidate only when the parameters give A0 (else A0 is fitted)
    reported_extra: tuple[str, ...] = ()     # values the report adds to its fitted parameters


@dataclass(frozen=True)
class FitParameter:
    """One parameter the discrepancy fit frees: physical name and unit, bounds, log-scaled or not, start values."""

    name: str
    unit: str
    lower: float
    upper: float
    log: bool = False
    starts: tuple = ()


@dataclass(frozen=True)
class FitContext:
    """What an effect's fit bounds and starts depend on (analysis/discrepancy/model.py WearProblem): the
    record's sliding distance [m], the feed speed [m/s], the end of the fit span [s from the start], the
    largest distance of the work from x_ref [m], the longest time without relubrication [s] (None: no
    recorded relubrications) and whether A0 is fitted."""

    total_distance_m: float
    feed_speed_m_s: float
    fit_end_s: float
    position_spread_m: float
    relubrication_gap_s: float | None
    a0_free: bool
