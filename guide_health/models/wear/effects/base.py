"""What an effect of the registry declares: its parameters, its rows in the model file's covariance, its values
for ``simulate --effect`` and its words for the report (plain data), and the interface through which every other
module reaches its physics (the methods of :class:`Effect`; an effect's module overrides those of its kind)."""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np


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
    note: str = ""      # ``simulate --help``'s words on the simulation parameters that go with it


@dataclass(frozen=True)
class LiveRequirement:
    """What a live effect needs of one of its parameters: ``condition`` "> 0" or "!= 0" (else the effect would
    do nothing, or divide by zero), ``note`` said after it."""

    parameter: str
    condition: str
    note: str = ""

    def holds(self, value: float) -> bool:
        return value > 0 if self.condition == "> 0" else value != 0.0


#: an effect's size is significant (and detectable, analysis/discrepancy/resolution.py) when it is at least this many
#: standard errors from its no-effect value (3: a 0.3 % two-sided false-detection rate)
SIGNIFICANT_SD = 3.0


@dataclass(frozen=True)
class ConsistencyRecord:
    """What an effect's own consistency check (:meth:`Effect.own_consistency_check`) sees of a record: the number
    of recorded relubrications (None: none), the fit span from the first measurement [s], the final fit's values,
    and ``refit_beside(forms)``: the final model refitted on the same fit span with the check forms ``forms``
    (analysis/discrepancy/consistency.py: e.g. "gauge_drift_in_time", "gauge_offset") freed beside the named
    effects, as (values, standard errors)."""

    relubrications: int | None
    fit_span_s: float
    values: dict[str, float]
    refit_beside: Callable[[tuple[str, ...]], tuple[dict[str, float], dict[str, float]]]


def size_beside_check(claim: str, size: float, sd: float, beside: str) -> dict[str, Any]:
    """The check that an effect's size stays significant with the forms ``beside`` freed next to it (its signature
    is not theirs): passed when |size| >= ``SIGNIFICANT_SD`` sd (``claim``: what the size is, e.g. "n - 1")."""
    z = abs(size) / sd if sd > 0 else math.inf
    passed = bool(z >= SIGNIFICANT_SD)
    return {"passed": passed, "size": float(size), "std_error": float(sd), "sd_from_none": float(z),
            "reason": (f"{claim} = {size:+.3g} ± {sd:.2g} with {beside} freed beside it ({z:.1f} sd from none"
                       + ("" if passed else f", below {SIGNIFICANT_SD:g}: the record does not show {claim} apart from "
                                            f"{beside}") + ")")}


#: the token of ``Effect.consistency_alternatives`` for the registry's step in the wear coefficient (RATE_STEP)
RATE_STEP_FORM = "rate_step"
#: the token for the registry's decay of K with sliding distance (SLIDING_DECAY), fitted in each of its decay laws
SLIDING_DECAY_FORM = "sliding_decay"


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
    #: its fields of the one parameter type (parameters.EffectParameters): (name, no-effect value, meaning);
    #: None: the default of its wear_monitor parameter of that name
    fields: tuple[tuple[str, Any, str], ...] = ()
    #: its ``guide_health_simulation`` parameters (params/simulation.py; the simulator's truth beyond the value)
    simulation: tuple[EffectParameter, ...] = ()
    #: the alternative forms the consistency check fits in its place (analysis/discrepancy/consistency.py: forms
    #: whose signature in a record can look like it; ``RATE_STEP_FORM``: the registry's step in K;
    #: ``SLIDING_DECAY_FORM``: the registry's decay with sliding distance); None: no check
    #: of its own beyond the selection
    consistency_alternatives: tuple[str, ...] | None = None
    #: the measurement that tells it from the registry's step in K (the consistency report's words)
    consistency_separation: str = ""
    #: its names in the bag metadata's ``effect_parameters`` (the simulator's hidden truth): a stored format, the
    #: names and order bags have recorded (registry.RECORDED_EFFECT_PARAMETERS)
    recorded: tuple[str, ...] = ()
    #: its fitted parameters that do not enter the work multiplier (straightness and measurement terms: a fit
    #: step of them reuses the effective-work sums, analysis/discrepancy/model.py)
    outside_the_sums: tuple[str, ...] = ()
    #: values derived from its fitted ones that the model file's parameter text lists after them
    file_derived: tuple[str, ...] = ()

    def simulation_fields(self, sim: dict[str, Any], run: dict[str, Any]) -> dict[str, Any]:
        """Its EffectParameters fields of the simulator's hidden truth beyond the ``--effect`` value, from its
        ``guide_health_simulation`` parameters ``sim`` and the run's facts ``run`` (sim/machine.py:
        ``relubrication_t_s`` [s from the start], ``work_weighted_position_m`` [m])."""
        return {}

    def truth_duty_factor(self, e: Any, t_a_s: np.ndarray, t_b_s: np.ndarray, x_a_m: np.ndarray,
                          x_b_m: np.ndarray) -> np.ndarray | None:
        """A duty effect's exact multiplier of the simulator's moves from t_a to t_b [s from the start] and x_a
        to x_b [m] (``e``: the EffectParameters of the hidden truth); None: 1 (no effect)."""
        return None

    def fit_duty_factor(self, values: dict[str, float], problem: Any) -> np.ndarray | None:
        """A duty effect's multiplier of the discrepancy fit's duty cells (``values``: the fit's parameters,
        ``problem``: analysis/discrepancy/model.py WearProblem); None: 1 (not fitted)."""
        return None

    def file_values(self, problem: Any, values: dict[str, float], t0_s: float) -> dict[str, Any]:
        """The model file's values of the effect named live that come from the record (absolute times
        [s since the stamps' epoch; ``t0_s`` the record's start], references); ``values``: the fit's."""
        return {}

    def file_jacobian(self, problem: Any, file_values: dict[str, Any]) -> tuple[tuple[str, str, float], ...]:
        """(covariance row, fitted parameter, d row / d parameter) of the model file's rows that are linear
        functions of fitted parameters other than their own (``file_values``: the file's values)."""
        return ()

    def fit_references(self, cells: Any) -> dict[str, float]:
        """EffectParameters fields the fit takes from the record instead of fitting them (duty cells with
        ``load_n`` [N], ``work_nm`` [N m], ...): field name -> value."""
        return {}

    def record_references(self, problem: Any) -> dict[str, Any]:
        """The references of its parameters the fit takes from the record (the model file writes them and the
        report lists them: wear_monitor parameter name -> value)."""
        return {}

    def plausible_strong_size(self, c: FitContext) -> tuple[dict[str, float], str, float] | None:
        """(its parameters at the strong end of its documented range on a record ``c``, what the size is, the
        size) for the detectable-size test (analysis/discrepancy/resolution.py; docs/discrepancy.md). None:
        none documented."""
        return None

    def own_consistency_check(self, record: ConsistencyRecord) -> dict[str, Any]:
        """The check of its own physics against a record (:class:`ConsistencyRecord`): {"passed": bool,
        "reason": words, ...}; {"passed": True} without one."""
        return {"passed": True}

    def live_values(self, p: dict[str, Any], named: bool) -> dict[str, Any]:
        """Its EffectParameters fields from the values of its own wear_monitor parameters ``p`` (``named``: the
        ``effects`` parameter names it); a field of a parameter it owns takes the parameter's value when named
        (else its no-effect value), the others (references, intervals) always."""
        return {}

    @property
    def rate_row(self) -> str:
        """The name of its covariance row whose multiplier sets the present wear rate ('' without one)."""
        return next((r.name for r in self.covariance_rows if r.rate), "")

    @property
    def row_names(self) -> tuple[str, ...]:
        """The names of its covariance rows, in its order."""
        return tuple(r.name for r in self.covariance_rows)

    def rate_factor(self, e: Any, speed_m_s: np.ndarray, load_n: np.ndarray,
                    retract: np.ndarray) -> np.ndarray | None:
        """A material effect's wear-rate factor of segments with the given speed [m/s], load [N] and direction
        (``e``: the EffectParameters); None: the factor is 1 (no effect)."""
        return None

    def live_rate_gradients(self, e: Any, seg: LiveSegments) -> dict[str, np.ndarray]:
        """A material effect's d(effective work)/d(parameter) of live segments, by covariance row name."""
        return {}

    def live_duty_factor(self, e: Any, t_s: np.ndarray, x_m: np.ndarray,
                         last_relubrication_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A duty effect's live (m, dm/d(its rate parameter)) at segment mid-times t [s since the stamps' epoch]
        and mid-positions x [m] (``last_relubrication_s``: the recorded relubrications' time base)."""
        raise NotImplementedError(f"{self.id} is not a duty effect")

    def scenario_load_exponent(self, e: Any) -> float | None:
        """The exponent n of the load in the wear rate, W^n, that a planning scenario's load scale is raised to
        (``e``: the EffectParameters); None: the effect leaves Archard's linear load (seed 000 Eq. 3)."""
        return None

    def scenario_rate_factor(self, e: Any, scales: Any, v_s: float) -> float | None:
        """A material effect's multiplier under a planning scenario's duty over the present's (``scales``:
        load_scale, speed_scale, stroke_scale; ``v_s``: the duty window's mean sliding speed [m/s]); None: 1."""
        return None

    def scenario_dln(self, e: Any, scales: Any, v_s: float, dln: float) -> float:
        """d ln(rate) / d(its rate parameter) under a planning scenario's duty, from the present window's
        ``dln`` (the life's gradient by its covariance row)."""
        return dln


@dataclass(frozen=True)
class LiveSegments:
    """Sliding segments of the live integration (models/wear/effect_wear.py) as a material effect's gradient
    takes them: load W [N] (at least 1e-12), speed [m/s], retract (bool), plain work W ds [N m], effective work
    without running-in [N m] and the product of the duty factors m_duty [-]."""

    load_n: np.ndarray
    speed_m_s: np.ndarray
    retract: np.ndarray
    work_nm: np.ndarray
    effective_work_nm: np.ndarray
    duty: np.ndarray


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


def work_weighted_geomean(values: np.ndarray, work: np.ndarray, mask: np.ndarray | None = None) -> float:
    """exp(sum w ln x / sum w) over the cells in ``mask`` (0 when they carry no work)."""
    if mask is not None:
        values, work = values[mask], work[mask]
    total = work.sum()
    return float(np.exp((work * np.log(values)).sum() / total)) if total > 0 else 0.0
