"""The effect registry: every wear effect of guide_health, one module each, and what is derived from them.

An effect's module (this package) holds its parameters, its wear-rate multiplier (or straightness term) and
gradient, its live form and the report's words (base.Effect and its subclass there); the rest of guide_health
reaches it through the roles below and the effect's methods, never by its name (test/test_effect_home.py).
Everything that lists effects is derived here, by name: the candidates of ``diagnose`` and the ``--effect`` values
of ``simulate`` (catalogue order below), the live effect ids, the wear_monitor parameters of the effects
(params/wear_monitor.py), the model file's keys and the rows of its effect_covariance (with the sizes older files
had), the lengths of the saved live state's lists, and the docs table (:func:`docs_table`).
test/test_effect_registry.py holds every derived place to the registry. docs/adding_an_effect.md: how to add one.
"""
from __future__ import annotations

import math

from guide_health.models.wear.effects import (
    initial_offset,
    load_along_rail,
    load_exponent,
    lubrication_interval,
    retract_asymmetry,
    running_in,
    speed_dependent_wear,
    stroke_distribution,
    thermal_drift,
    wear_rate_change,
)
from guide_health.models.wear.effects.base import (
    RATE_STEP_FORM,
    SLIDING_DECAY_FORM,
    CovarianceRow,
    Effect,
    EffectParameter,
)

#: the catalogue, in the order simulate and diagnose list (and diagnose tries) the effects: the wear-rate and
#: measurement terms first, then the duty effects
MODULES = (running_in, retract_asymmetry, speed_dependent_wear, load_exponent, stroke_distribution, thermal_drift,
           initial_offset, wear_rate_change, lubrication_interval, load_along_rail)
EFFECTS: tuple[Effect, ...] = tuple(m.EFFECT for m in MODULES)
BY_ID = {e.id: e for e in EFFECTS}
#: the roles the wear core reaches an effect by, never by its name (its methods: base.Effect and its module)
SLIDING_DECAY = running_in.EFFECT              # K(s) decays over the sliding distance of the present surface
PASS_WEIGHTING = stroke_distribution.EFFECT    # the weight of the pass work in the straightness
GAUGE_TEMPERATURE = thermal_drift.EFFECT       # the straightness gauge's temperature term
INITIAL_TERM = initial_offset.EFFECT           # the initial straightness's offset from the parameters' A0
RELUBRICATION = lubrication_interval.EFFECT    # the duty factor that follows the relubrications
RATE_STEP = wear_rate_change.EFFECT            # K steps by a factor at one time (diagnose --since's new wear rate)
#: the material factors of the wear rate, in the order their product is taken (the last bit depends on it)
MATERIAL_FACTORS = (speed_dependent_wear.EFFECT, load_exponent.EFFECT, retract_asymmetry.EFFECT)
#: the duty factors, in the order their product is taken
DUTY_FACTORS = (load_along_rail.EFFECT, wear_rate_change.EFFECT, lubrication_interval.EFFECT)
#: the factors a planning scenario's duty scales move (models/wear/planning.py), in the order they are applied
SCENARIO_FACTORS = (load_exponent.EFFECT, speed_dependent_wear.EFFECT)
#: the wear rate's power n of the load, W^n (seed 000 Table 2 tests it on pin-on-disc rows)
LOAD_POWER = load_exponent.EFFECT
#: the material factor that follows the instantaneous sliding speed (the simulator averages it along a double-S move)
SPEED_SHARE = speed_dependent_wear.EFFECT
#: the duty factors of the discrepancy fit's cells, in the order their product is taken (the last bit depends on it)
FIT_DUTY_FACTORS = (wear_rate_change.EFFECT, lubrication_interval.EFFECT, load_along_rail.EFFECT)
#: the effects whose model-file values come from the record (Effect.file_values, file_jacobian), in the order model
#: files have written them (a stored format)
FILE_VALUE_EFFECTS = (load_along_rail.EFFECT, wear_rate_change.EFFECT, thermal_drift.EFFECT,
                      lubrication_interval.EFFECT)
#: the effects whose references the fit takes from the record (Effect.record_references), in the model file's order
RECORD_REFERENCE_EFFECTS = (load_exponent.EFFECT, retract_asymmetry.EFFECT)
#: each effect's fitted parameters for a record (base.FitContext -> base.FitParameter list), catalogue order
FIT_PARAMETERS = {m.EFFECT.id: m.fit_parameters for m in MODULES}

EFFECT_IDS = tuple(e.id for e in EFFECTS if not e.duty)
#: duty effects: multipliers of the work by when and where it is done (the simulator hides them too, with a
#: recorded relubrication plan for lubrication_interval)
DUTY_EFFECT_IDS = tuple(e.id for e in EFFECTS if e.duty)
#: the discrepancy workflow's candidates
CANDIDATE_IDS = EFFECT_IDS + DUTY_EFFECT_IDS
#: the effects the live model integrates (initial_offset is folded into A0)
LIVE_EFFECT_IDS = tuple(e.id for e in EFFECTS if e.live)
#: effects of the material pair and lubricant, shared by machines of a type (the fleet prior pools them)
MATERIAL_EFFECTS = tuple(e.id for e in EFFECTS if e.material)
#: what `guide-health simulate --effect NAME=VALUE` sets, its unit, and the no-effect value
EFFECT_VALUE = {e.id: (e.simulate.name, e.simulate.unit, e.simulate.no_effect) for e in EFFECTS}
#: the allowed range of an --effect value that is not a wear_monitor parameter of the same name (those take
#: the wear_monitor schema's range), or whose hidden value must differ from the parameter's "no effect"
EFFECT_VALUE_RANGES = {e.simulate.name: e.simulate.range_text for e in EFFECTS if e.simulate.range_text}
#: the fitted parameters each live effect carries into the model file (same names as the wear_monitor's)
EFFECT_PARAMETERS = {e.id: e.fitted_to_file for e in EFFECTS if e.live and e.fitted_to_file}
#: a fitted parameter's row in the covariance when its name differs from the live one
COVARIANCE_ALIASES = {fitted: row for e in EFFECTS for fitted, row in e.fitted_aliases}
#: the wear_monitor parameters the effects own, in catalogue order
LIVE_PARAMETERS: tuple[EffectParameter, ...] = tuple(p for e in EFFECTS for p in e.parameters)
PARAMETER_OWNER = {p.name: e.id for e in EFFECTS for p in e.parameters}
#: the alternative forms each effect with a consistency check of its own is checked against (the step in K's id
#: for RATE_STEP_FORM, the decay with sliding distance's for SLIDING_DECAY_FORM), analysis/discrepancy/consistency.py
_FORM_TOKENS = {RATE_STEP_FORM: RATE_STEP.id, SLIDING_DECAY_FORM: SLIDING_DECAY.id}
CONSISTENCY_ALTERNATIVES = {e.id: tuple(_FORM_TOKENS.get(a, a) for a in e.consistency_alternatives)
                            for e in EFFECTS if e.consistency_alternatives is not None}

#: the rows of the baseline model: K first, A0 (when the fit freed it, or initial_offset's delta) last
BASELINE_ROWS = (CovarianceRow("wear_coefficient", 0, 1), CovarianceRow("straightness_initial_m", 12, 5))
COVARIANCE_ROWS: tuple[CovarianceRow, ...] = tuple(sorted(
    BASELINE_ROWS + tuple(r for e in EFFECTS for r in e.covariance_rows), key=lambda r: r.row))
if [r.row for r in COVARIANCE_ROWS] != list(range(len(COVARIANCE_ROWS))):      # pragma: no cover
    raise ValueError("the effects' covariance rows must number 0 .. n-1, each once")
#: the model file's effect_covariance rows (row-major, SI). ``lubrication_wear_growth`` is b [1/s] (recorded
#: relubrications) or a [-] (interval); ``thermal_gauge_offset_m`` the gauge's offset at T_ref;
#: ``straightness_initial_m`` A0 when the fit freed it
COVARIANCE_NAMES = tuple(r.name for r in COVARIANCE_ROWS)
COVARIANCE_INDEX = {name: i for i, name in enumerate(COVARIANCE_NAMES)}
#: the bag metadata's ``effect_parameters``: the simulator's hidden truth under the names and in the order bags have
#: recorded it (a stored format)
RECORDED_EFFECT_PARAMETERS = tuple(name for e in EFFECTS for name in e.recorded)
#: the fit's parameters that do not enter the work multiplier (with K and A0: Eq. 7/10's factor and the terms added)
OUTSIDE_THE_SUMS = frozenset(name for e in EFFECTS for name in e.outside_the_sums)
#: the effect parameters phi (every row but K) and their places in phi
PHI_NAMES = COVARIANCE_NAMES[1:]
PHI_INDEX = {name: i for i, name in enumerate(PHI_NAMES)}
_GENERATIONS = sorted({r.since for r in COVARIANCE_ROWS})
#: the number of rows of the model files of each generation, oldest first (the last is today's)
COVARIANCE_SIZES = tuple(sum(r.since <= g for r in COVARIANCE_ROWS) for g in _GENERATIONS)
#: the parameters whose multiplier sets the present rate (the live duty buckets carry d(work)/d(each)), in
#: row order, and their places in phi (a rate row added later sits after the others: rows are numbered by
#: generation)
RATE_NAMES = tuple(r.name for r in COVARIANCE_ROWS if r.rate)
RATE_PHI = [PHI_INDEX[name] for name in RATE_NAMES]
if [r.since for r in COVARIANCE_ROWS] != sorted(r.since for r in COVARIANCE_ROWS):    # pragma: no cover
    raise ValueError("the covariance rows must be numbered by generation (older files hold the leading block)")


def state_layouts(rows: tuple[CovarianceRow, ...]) -> tuple[dict[int, tuple[str, ...]], dict[int, tuple[str, ...]]]:
    """The names of a saved live state's lists in each generation of ``rows`` (the covariance rows), by their
    length: ({length: the work gradient's phi names}, {length: a duty bucket row's sums}). A bucket row holds the
    work, the effective work without running-in, the sliding distance, the effective work's derivative by each
    rate parameter (row order) and, from the pass weighting's generation on, its pass work sum
    W ds m / max(L, L_s). Restore maps a saved list to today's names by these (base.Effect: a term absent from an
    older state is at its no-effect value 0), so a new effect's row needs no state-file generation of its own."""
    pass_since = PASS_WEIGHTING.covariance_rows[0].since
    phi, sums = {}, {}
    for g in sorted({r.since for r in rows}):
        here = tuple(r for r in sorted(rows, key=lambda r: r.row) if r.since <= g)
        phi[len(here) - 1] = tuple(r.name for r in here[1:])
        row_sums = (("work_nm", "effective_work_nm", "distance_m") + tuple(f"d_{r.name}" for r in here if r.rate)
                    + (("pass_work_n",) if g >= pass_since else ()))
        sums[len(row_sums)] = row_sums
    return phi, sums


#: the saved lists' names by length, each generation (effect_wear.EffectWear.restore keys a saved list by them)
PHI_LAYOUTS, BUCKET_LAYOUTS = state_layouts(COVARIANCE_ROWS)
#: the sums of a live duty bucket (today's generation: state_layouts)
BUCKET_SUMS = BUCKET_LAYOUTS[max(BUCKET_LAYOUTS)]
SUM_INDEX = {name: i for i, name in enumerate(BUCKET_SUMS)}
RATE_SUMS = slice(SUM_INDEX[f"d_{RATE_NAMES[0]}"], SUM_INDEX[f"d_{RATE_NAMES[-1]}"] + 1)
#: lengths of a saved work gradient and bucket row (index then sums) for each generation, today's first
PHI_LENGTHS = tuple(sorted(PHI_LAYOUTS, reverse=True))
BUCKET_ROW_LENGTHS = tuple(sorted((1 + n for n in BUCKET_LAYOUTS), reverse=True))


_SIMULATE_FIELDS = {e.simulate.name: e.simulate.field for e in EFFECTS if e.simulate.field}


def simulate_field(value_name: str) -> str:
    """The EffectParameters field an ``--effect`` value sets (the value's name unless the effect says)."""
    return _SIMULATE_FIELDS.get(value_name, value_name)


def docs_table() -> str:
    """The markdown table of the effects (docs/discrepancy.md and docs/model_file.md carry it verbatim)."""
    rows = ["| effect | term | `simulate --effect` value | live: wear_monitor parameters | covariance rows |",
            "|---|---|---|---|---|"]
    for e in EFFECTS:
        value = e.simulate
        no_effect = "inf" if math.isinf(value.no_effect) else f"{value.no_effect:g}"
        params = ", ".join(f"`{p.name}`" for p in e.parameters) if e.live else "not live (folded into A0)"
        covariance = ", ".join(f"`{r.name}`" for r in e.covariance_rows) or "A0's"
        rows.append(f"| `{e.id}` | {e.term} | `{value.name}` [{value.unit}] (none: {no_effect}) | {params} | "
                    f"{covariance} |")
    return "\n".join(rows) + "\n"
