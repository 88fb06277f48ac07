"""The wear model with any set of effects, evaluated over duty cells at the measurement times, and its
least-squares fit (scipy.optimize.least_squares) with parameter uncertainty.

Prediction of the measured straightness at measurement j (models/wear/effects/, seed 000 Eq. 7/10):

    y_j = A0 + delta + c_T (T_j - T_0)
          + K / (H b) [(1 - w) 2 G_j / (l_min + l_max) + w P_j],
    G_j = sum over cells before t_j of  work * m(cell),   P_j the same with the pass work,

with m the product of the wear-rate multipliers of the effects in the model. The baseline has K only
(and A0 when the parameters give A0 = 0): "a K that is merely off is a calibration, not a missing effect".
"""
from __future__ import annotations

import contextlib
import copy
import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from guide_health.analysis.discrepancy.duty import PER_CELL_FIELDS, DutyCells
from guide_health.models.wear.effect_life import symmetrised
from guide_health.models.wear.effects import (
    CANDIDATE_IDS,
    EffectParameters,
    effect_multiplier,
    measured_straightness_m,
)
from guide_health.models.wear.effects.base import FitContext, work_weighted_geomean
from guide_health.models.wear.effects.base import FitParameter as ParamSpec
from guide_health.models.wear.effects.registry import (
    BY_ID,
    FIT_DUTY_FACTORS,
    FIT_PARAMETERS,
    GAUGE_TEMPERATURE,
    OUTSIDE_THE_SUMS,
    PASS_WEIGHTING,
    RECORD_REFERENCE_EFFECTS,
    SLIDING_DECAY,
)
from guide_health.models.wear.form_average import RUNNING_IN_FORMS
from guide_health.models.wear.input_rules import reading_in_force_index

UM = 1e6
MICRO_UNITS = ("m", "m/K")       # fitted in um and um/K


def fit_context(problem: WearProblem) -> FitContext:
    """What the effects' fit bounds, starts and plausible sizes depend on, for this record."""
    return FitContext(
        total_distance_m=problem.cells.total_distance_m, feed_speed_m_s=problem.feed_speed_m_s,
        fit_end_s=float(problem.t_s[problem.fit_mask][-1]),
        position_spread_m=(float(np.max(np.abs(problem.cells.position_m - problem.position_ref_m)))
                           if problem.cells.cells else 0.0),
        relubrication_gap_s=problem.relubrication_gap_s if problem.relubrication_t_s is not None else None,
        a0_free=problem.a0_free)


def _effect_specs(problem: WearProblem) -> dict[str, list[ParamSpec]]:
    """Each candidate's fitted parameters (bounds and starts from the effect's module, for this record)."""
    context = fit_context(problem)
    return {effect: fit(context) for effect, fit in FIT_PARAMETERS.items()}


@contextlib.contextmanager
def in_decay_law(problem, law: str):
    """``problem`` (a WearProblem) with its sliding decay in ``law`` (models/wear/form_average.py
    RUNNING_IN_FORMS) inside the block, its fits and predictions among them; the library's law again after."""
    problem.running_in_form = law
    try:
        yield problem
    finally:
        problem.running_in_form = RUNNING_IN_FORMS[0]


@dataclass
class FitResult:
    """A fitted model: effects, parameter values and standard errors, scores."""

    effects: tuple[str, ...]
    values: dict[str, float]
    std_errors: dict[str, float]
    units: dict[str, str]
    predicted_m: np.ndarray             # at every measurement
    n_fit: int
    n_params: int
    rss_um2: float
    bic: float
    rmse_um: float
    max_rel_error: float
    heldout_rmse_um: float
    heldout_max_rel_error: float
    n_heldout: int = 0
    success: bool = True
    extra: dict = field(default_factory=dict)

    def parameter_table(self) -> dict[str, dict[str, Any]]:
        """{name: {value, std_error, unit}} of the fitted parameters."""
        return {k: {"value": v, "std_error": self.std_errors.get(k, math.nan), "unit": self.units.get(k, "")}
                for k, v in self.values.items()}

    def summary(self) -> dict[str, Any]:
        return {
            "effects": list(self.effects),
            "parameters": self.parameter_table(),
            "n_params": self.n_params, "bic": self.bic,
            "rmse_um": self.rmse_um, "max_rel_error": self.max_rel_error,
            "heldout_rmse_um": self.heldout_rmse_um, "heldout_max_rel_error": self.heldout_max_rel_error,
        }


def rel_errors(pred: np.ndarray, meas: np.ndarray) -> np.ndarray:
    return np.abs(pred - meas) / np.abs(meas)


#: the fewest straightness measurements the workflow fits (K, an effect's parameters, a held-out forecast)
MIN_MEASUREMENTS = 6
#: parameters of the prediction that do not enter the multiplier m (Eq. 7/10's factor and the terms added to it)
_OUTSIDE_THE_SUMS = frozenset({"wear_coefficient", "straightness_initial_m"}) | OUTSIDE_THE_SUMS
#: the EffectParameters fields a fit may hold (those taken from the record, WearProblem.fit_references, win)
_EFFECT_FIELDS = tuple(f.name for f in dataclasses.fields(EffectParameters))


class WearProblem:
    """Measurements, duty cells and wear parameters of one machine; fits models with any effect set."""

    def __init__(self, cells: DutyCells, params: dict[str, Any], heldout_fraction: float = 0.25,
                 relubrication_t_s: np.ndarray | None = None):
        if cells.measurement_m.size < MIN_MEASUREMENTS:
            raise ValueError(f"the discrepancy workflow needs at least {MIN_MEASUREMENTS} straightness measurements, "
                             f"the bag has {cells.measurement_m.size}")
        if cells.cells == 0:
            raise ValueError("the bag has no loaded axis motion (no wear to model)")
        self.cells = cells
        self.params = params
        self.k0 = float(params["wear_coefficient"])
        self.hardness_pa = float(params["hardness_pa"])
        self.width_m = float(params["contact_width_m"])
        self.a0_m = float(params["straightness_initial_m"])
        self.a0_free = not self.a0_m > 0
        # l_min + l_max: parameters, else the observed passes (as the live monitor does)
        if params["stroke_min_m"] > 0 and params["stroke_max_m"] > 0:
            self.stroke_sum_m = float(params["stroke_min_m"] + params["stroke_max_m"])
        else:
            strokes = cells.pass_lengths_m[cells.pass_lengths_m >= params["stroke_detect_min_m"]]
            if strokes.size == 0:
                raise ValueError("no strokes longer than stroke_detect_min_m in the bag")
            self.stroke_sum_m = float(strokes.min() + strokes.max())
        # measurement order and the fit / held-out split (the later measurements are held out)
        self.t_s = cells.measurement_t_s           # sorted by DutyCellAccumulator.finish
        self.y_m = cells.measurement_m
        n = self.y_m.size
        n_held = int(round(heldout_fraction * n))
        n_held = min(max(n_held, 0), n - 4)
        self.fit_mask = np.arange(n) < n - n_held
        self.heldout_mask = ~self.fit_mask
        # cells before each measurement
        self.cell_index = np.searchsorted(cells.interval, np.arange(n), side="right")
        # direction of the retract: the faster one (a rapid return); equal speeds: negative dx
        speeds = {sign: work_weighted_geomean(cells.speed_m_s, cells.work_nm, cells.direction == sign)
                  for sign in (1, -1)}
        self.retract_sign = 1 if speeds[1] > 1.05 * speeds[-1] else -1
        self.retract = cells.direction == self.retract_sign
        self.feed_speed_m_s = work_weighted_geomean(cells.speed_m_s, cells.work_nm, ~self.retract)
        if not self.feed_speed_m_s > 0:
            self.feed_speed_m_s = float(np.median(cells.speed_m_s))
        self.retract_speed_m_s = speeds[self.retract_sign]
        # effect parameters taken from the record instead of fitted (Effect.fit_references: e.g. a reference load)
        self.fit_references = {k: v for e in RECORD_REFERENCE_EFFECTS for k, v in e.fit_references(cells).items()}
        # temperature change at the measurements (relative to the first measurement)
        self.temperature_change_k = None
        self.temperature_first_c = math.nan
        if cells.temperature_c.size >= 2:
            tt = cells.temperature_t_s
            o = np.argsort(tt, kind="stable")
            # the reading in force at each measurement, as the live correction takes it (zero-order hold by
            # stamp); a measurement before the first reading takes the first (live rejects it)
            temp = cells.temperature_c[o][np.maximum(reading_in_force_index(tt[o], self.t_s), 0)]
            self.temperature_change_k = temp - temp[0]
            self.temperature_first_c = float(temp[0])     # T_0: the gauge term's reference is T_0 + dT_ref
        # each cell spans its measurement interval (for a change point inside it: uniform work assumed)
        edges = np.concatenate(([0.0], self.t_s, [max(cells.duration_s, float(self.t_s[-1]))]))
        k = np.clip(cells.interval, 0, n)
        self.cell_start_s, self.cell_end_s = edges[k], edges[k + 1]
        # recorded relubrications [s from t0] (maintenance events): the relubrication factor's time since the last
        relube = np.sort(np.asarray(relubrication_t_s if relubrication_t_s is not None else [], dtype=float))
        self.relubrication_t_s = relube if relube.size else None
        gaps = np.diff(np.concatenate(([0.0], relube, [max(cells.duration_s, 1.0)]))) if relube.size else [1.0]
        self.relubrication_gap_s = float(max(np.max(gaps), 1.0))     # the longest time without relubrication
        self.position_ref_m = float(np.sum(cells.work_nm * cells.position_m) / max(cells.work_nm.sum(), 1e-300))
        # wear resets (regrind, new rail): the wear of measurement i counts from the last reset before it
        self.measurement_epoch = (np.searchsorted(cells.reset_t_s, self.t_s, side="left")
                                  if cells.epoch is not None else None)
        self.specs = _effect_specs(self)
        self._work_cache: tuple | None = None     # (multiplier parameters, G_j, P_j) of the last prediction
        self.running_in_form = RUNNING_IN_FORMS[0]     # the sliding decay's law (the library's: in_decay_law)

    # --- candidates ---------------------------------------------------------------------------
    def available_effects(self) -> list[str]:
        """Effect ids that can be tried on this data: those that need a temperature record only with one, those
        that need a given A0 only when A0 is given (with A0 = 0 the baseline fits A0 itself)."""
        return [e for e in CANDIDATE_IDS
                if not (BY_ID[e].needs_temperature and self.temperature_change_k is None)
                and not (BY_ID[e].needs_given_a0 and self.a0_free)]

    # --- prediction ----------------------------------------------------------------------------
    def _param_list(self, effects: tuple[str, ...]) -> list[ParamSpec]:
        specs = [ParamSpec("wear_coefficient", "-", 0.0, math.inf)]     # starts from _k_start()
        if self.a0_free:
            specs.append(ParamSpec("straightness_initial_m", "m", -1e-3, 1e-3, False, (0.0,)))
        for e in effects:
            specs.extend(self.specs[e])
        return specs

    # Inside the fit, K is relative to the configured K0 and lengths are in um (um/K): one conversion
    # for bounds, starts, results and standard errors.
    def _to_internal(self, spec: ParamSpec, value: float) -> float:
        if spec.log:
            return math.log(value)
        if spec.name == "wear_coefficient":
            return value / self.k0
        return value / self._internal_factor(spec)

    def _internal_factor(self, spec: ParamSpec) -> float:
        """d(physical)/d(internal) of a linear parameter."""
        if spec.name == "wear_coefficient":
            return self.k0
        if spec.unit == "s":
            return 3600.0                        # times in hours inside the fit
        if spec.unit == "1/s":
            return 1.0 / 3600.0                  # rates per hour inside the fit
        return 1e-6 if spec.unit in MICRO_UNITS else 1.0

    def _physical(self, specs: list[ParamSpec], x: np.ndarray) -> dict[str, float]:
        """Internal vector -> physical values."""
        return {spec.name: math.exp(xi) if spec.log else float(xi) * self._internal_factor(spec)
                for spec, xi in zip(specs, x)}

    def predict_m(self, values: dict[str, float]) -> np.ndarray:
        """Measured straightness [m] at every measurement for physical parameter values."""
        c = self.cells
        # the fitted effect parameters; one not fitted keeps EffectParameters' no-effect value
        eff = EffectParameters(**{**{name: values[name] for name in _EFFECT_FIELDS if name in values},
                                  **self.fit_references})
        # the effective work depends on the multiplier's parameters (and the sliding decay's law) only: a
        # finite-difference step of K, A0 or a term outside the sums (most of a fit's evaluations) reuses the last sums
        key = (tuple(sorted(self.fit_references.items())), self.running_in_form,
               *sorted((k, v) for k, v in values.items() if k not in _OUTSIDE_THE_SUMS))
        if self._work_cache is None or self._work_cache[0] != key:
            ri = SLIDING_DECAY.cell_factor(eff, self.running_in_form, c.sliding_distance_m, c.sliding_distance_var_m2)
            m = effect_multiplier(eff, c.speed_m_s, c.load_n, self.retract, ri, self._duty_factors(values))
            self._work_cache = (key, self._work_since_reset(c.work_nm * m), self._work_since_reset(c.pass_work_n * m))
        g, p = self._work_cache[1:]
        wear = PASS_WEIGHTING.straightness_wear_m(values["wear_coefficient"], self.hardness_pa, self.width_m, g, p,
                                                  self.stroke_sum_m, eff)
        a0 = self.initial_straightness_m(values["straightness_initial_m"] if self.a0_free else self.a0_m)
        temp = self.temperature_change_k
        y = measured_straightness_m(wear, a0, temp, eff)
        # c_T (T - T_ref) = c_T (T - T_0) + b with b = -c_T dT_ref: fitted linear in b (no local minima)
        return y + values.get("thermal_offset_m", 0.0) if temp is not None else y

    def _work_since_reset(self, per_cell: np.ndarray) -> np.ndarray:
        """Sum of ``per_cell`` over the cells before each measurement, from its epoch's start (the last wear
        reset before it: Eq. 7's work on the new surface)."""
        if self.measurement_epoch is None:
            return np.concatenate(([0.0], np.cumsum(per_cell)))[self.cell_index]
        out = np.zeros(self.t_s.size)
        for e in np.unique(self.measurement_epoch):
            here = self.measurement_epoch == e
            out[here] = np.concatenate(([0.0], np.cumsum(np.where(self.cells.epoch == e, per_cell, 0.0))))[
                self.cell_index[here]]
        return out

    def initial_straightness_m(self, a0_m: float) -> np.ndarray | float:
        """The straightness of each measurement's surface when new: A0, after a wear reset the value entered
        with it (else A0, as the live monitor takes it)."""
        if self.measurement_epoch is None:
            return a0_m
        after = self.cells.reset_straightness_m
        return np.concatenate(([a0_m], np.where(np.isfinite(after), after, a0_m)))[self.measurement_epoch]

    def _duty_factors(self, values: dict[str, float]) -> np.ndarray | float:
        """The product of the duty effects' cell forms (Effect.fit_duty_factor, registry FIT_DUTY_FACTORS order)."""
        m = 1.0
        for effect in FIT_DUTY_FACTORS:
            f = effect.fit_duty_factor(values, self)
            if f is not None:
                m = m * f
        return m

    # --- fitting -------------------------------------------------------------------------------
    def fit_span(self) -> WearProblem:
        """This problem cut to the fit span: the measurements before the held-out ones and the cells their
        wear counts (both prefixes: the held-out measurements are the last, the cells are sorted by interval).
        Its predict_m equals predict_m(values)[fit_mask] bit for bit (prefix sums, factors cell by cell), at
        the cost of the fit span's cells only (a fit evaluates the model thousands of times)."""
        n_fit = int(self.fit_mask.sum())
        n_cells = int(self.cell_index[n_fit - 1])
        c = self.cells
        span = copy.copy(self)
        span._work_cache = None
        per_cell = {name: getattr(c, name)[:n_cells] for name in PER_CELL_FIELDS if getattr(c, name) is not None}
        span.cells = dataclasses.replace(c, **per_cell, measurement_t_s=c.measurement_t_s[:n_fit],
                                         measurement_m=c.measurement_m[:n_fit])
        for name in ("retract", "cell_start_s", "cell_end_s"):
            setattr(span, name, getattr(self, name)[:n_cells])
        for name in ("t_s", "y_m", "cell_index", "temperature_change_k", "measurement_epoch"):
            value = getattr(self, name)
            setattr(span, name, value[:n_fit] if value is not None else None)
        span.fit_mask, span.heldout_mask = self.fit_mask[:n_fit], self.heldout_mask[:n_fit]
        return span

    def fit(self, effects: tuple[str, ...] | list[str] = (), warm: FitResult | None = None) -> FitResult:
        """Least-squares fit on the fit span of the model with ``effects``; multi-start over the
        nonlinear parameters (parameters of ``warm``, a fit of a sub-model, start from its values);
        standard errors from the Jacobian at the optimum."""
        effects = tuple(effects)
        specs = self._param_list(effects)
        fit = self.fit_mask
        y_um = self.y_m[fit] * UM
        span = self.fit_span()

        def residual(x):
            return span.predict_m(self._physical(specs, x)) * UM - y_um

        lower = np.array([self._to_internal(s, s.lower) for s in specs])
        upper = np.array([self._to_internal(s, s.upper) for s in specs])
        k_start = self._k_start()
        starts = [[]]
        for s in specs:
            if warm is not None and s.name in warm.values:
                vals = [self._to_internal(s, warm.values[s.name])]
            elif s.name == "wear_coefficient":
                vals = [k_start]                        # already relative to K0
            else:
                vals = [self._to_internal(s, v) for v in s.starts]
            starts = [st + [v] for st in starts for v in vals]
        best = None
        for x0 in starts:
            x0 = np.clip(np.array(x0, dtype=float), lower + 1e-12 * np.abs(lower), upper)
            try:
                res = least_squares(residual, x0, bounds=(lower, upper), x_scale="jac", method="trf",
                                    max_nfev=200)
            except (ValueError, FloatingPointError):   # pragma: no cover (bad start)
                continue
            if best is None or res.cost < best.cost:
                best = res
        values = self._physical(specs, best.x)
        n = int(fit.sum())
        k = len(specs)
        rss = float(2.0 * best.cost)
        # standard errors: s^2 (J^T J)^-1 in internal coordinates, mapped to physical units
        dof = max(n - k, 1)
        s2 = rss / dof
        jtj = best.jac.T @ best.jac
        cov = symmetrised(s2 * np.linalg.pinv(jtj))       # pinv is symmetric only to rounding
        se = {}
        for i, spec in enumerate(specs):
            sd_int = math.sqrt(max(cov[i, i], 0.0))
            se[spec.name] = abs(values[spec.name]) * sd_int if spec.log else sd_int * self._internal_factor(spec)
        pred = self.predict_m(values)
        if "thermal_offset_m" in values:
            GAUGE_TEMPERATURE.fit_reference_offset(values, se, cov, specs)
        units = {s.name: s.unit for s in specs} | {"thermal_reference_offset_k": "K"}
        result = self._score(effects, values, se, units, pred, k, rss, bool(best.success))
        # covariance in physical units: d(physical)/d(internal) = value (log) or the linear factor
        scale = np.array([values[s.name] if s.log else self._internal_factor(s) for s in specs])
        result.extra["covariance"] = {"names": [s.name for s in specs], "matrix": cov * np.outer(scale, scale)}
        return result

    def _k_start(self) -> float:
        """K / K0 of the baseline by linear least squares through A0 (a good start for every model)."""
        a0 = self.initial_straightness_m(0.0 if self.a0_free else self.a0_m)
        base = self.predict_m({"wear_coefficient": self.k0, "straightness_initial_m": 0.0}) - a0
        y = self.y_m[self.fit_mask] - (a0[self.fit_mask] if isinstance(a0, np.ndarray) else a0)
        g = base[self.fit_mask]
        if self.a0_free:
            g = g - g.mean()
            y = y - y.mean()
        denom = float(g @ g)
        return max(float(g @ y) / denom, 1e-6) if denom > 0 else 1.0

    def _score(self, effects, values, se, units, pred, k, rss, success) -> FitResult:
        fit, held = self.fit_mask, self.heldout_mask
        n = int(fit.sum())
        err_um = (pred - self.y_m) * UM
        rel = rel_errors(pred, self.y_m)
        bic = n * math.log(max(rss, 1e-30) / n) + k * math.log(n)
        return FitResult(
            effects=effects, values=values, std_errors=se, units=units, predicted_m=pred,
            n_fit=n, n_params=k, rss_um2=rss, bic=bic,
            rmse_um=float(np.sqrt(np.mean(err_um[fit] ** 2))),
            max_rel_error=float(rel[fit].max()),
            heldout_rmse_um=float(np.sqrt(np.mean(err_um[held] ** 2))) if held.any() else math.nan,
            heldout_max_rel_error=float(rel[held].max()) if held.any() else math.nan,
            n_heldout=int(held.sum()), success=success,
        )
