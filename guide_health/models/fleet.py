"""Fleet board: the latest health status of every machine's monitors and a one-status summary.

Pure Python (no ROS): fed with diagnostic statuses (name, hardware_id = machine_id, level, message,
key values as strings), it answers which machines are healthy, which are not, which went silent, and
which has the least remaining life. `fleet_monitor` is the ROS adapter.
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

from guide_health.models.levels import LEVEL_NAMES, Level
from guide_health.models.wear.planning import LIMIT_KEYS

# severity order for "worst": STALE (no data) ranks between WARN and ERROR
_SEVERITY = {Level.OK: 0, Level.WARN: 1, Level.STALE: 2, Level.ERROR: 3}
SUMMARY_KEYS = ("machines", "statuses", "ok", "warn", "error", "stale", "worst_machine", "worst_status",
                "min_remaining_life_h", "min_remaining_life_machine", "max_life_used_fraction",
                "max_life_used_machine", "max_end_stress_ratio", "max_end_stress_machine", "ignored_statuses",
                "invalid_values", "forgotten_statuses")
#: the status values the fleet keeps, with their labels: the board's CHECKED_VALUES and the history's trend
#: columns (io/outputs/fleet_history.py); every other key of a status but FLEET_DATE_KEYS is skipped unread
FLEET_VALUES = (("remaining_life_h", "remaining precision life [h]"), ("straightness_um", "straightness [um]"),
                ("life_used_fraction", "fatigue life used [-]"), ("end_stress_ratio", "end-stress ratio [-]"))
FLEET_VALUE_KEYS = tuple(key for key, _ in FLEET_VALUES)
#: the limit date texts the fleet history keeps for `fleet plan` (ISO-8601 UTC, '' = never)
FLEET_DATE_KEYS = LIMIT_KEYS
#: summary values a status may carry, and the smallest valid value of each (NaN = not known yet: skipped)
CHECKED_VALUES = {"remaining_life_h": 0.0, "life_used_fraction": 0.0, "end_stress_ratio": 0.0}
#: why a status was ignored (FleetBoard.ignored counts them)
UNKNOWN_LEVEL, BOARD_FULL, MALFORMED = "unknown level", "board full", "malformed message"


def _number(text) -> float:
    try:
        return float(text)
    except (TypeError, ValueError):
        return math.nan


@dataclass
class MachineStatus:
    name: str
    hardware_id: str
    level: Level
    message: str
    values: dict = field(default_factory=dict)
    received_s: float = 0.0


def invalid_value(key: str, text) -> bool:
    """True when `text` of a CHECKED_VALUES key is no number or below the key's minimum (e.g. a remaining life
    of -5 h, 'banana'); NaN is "not known yet" (every monitor publishes it until it knows), not invalid."""
    value = _number(text)
    if math.isnan(value):
        return str(text).strip().lower() not in ("nan", "-nan", "")
    return not value >= CHECKED_VALUES[key]


class FleetBoard:
    """Latest status per (hardware_id, name); silent ones turn STALE after `stale_after_s` and are forgotten
    after `forget_after_s` (a retired machine, a renamed node: the board does not grow forever). At most
    `max_statuses` statuses; statuses of an unknown level (and beyond the maximum) are ignored, invalid
    summary values dropped, each counted (`ignored`, `invalid_values`, `forgotten`); `last_problem` says
    what the last update ignored or dropped ('' if nothing), for the node's log line."""

    def __init__(self, stale_after_s: float = 10.0, ignore_prefix: str = "", forget_after_s: float = math.inf,
                 max_statuses: int = 10**7):
        if not stale_after_s > 0:
            raise ValueError("stale_after_s must be > 0")
        if not forget_after_s > stale_after_s:
            raise ValueError("forget_after_s must be above stale_after_s")
        self.stale_after_s = float(stale_after_s)
        self.forget_after_s = float(forget_after_s)
        self.max_statuses = int(max_statuses)
        self.ignore_prefix = ignore_prefix      # the fleet monitor's own statuses
        self.statuses: dict[tuple[str, str], MachineStatus] = {}
        self.ignored: Counter = Counter()       # reason -> statuses ignored
        self.invalid_values = 0                 # summary values dropped
        self.forgotten = 0                      # statuses dropped after forget_after_s of silence
        self.last_problem = ""

    def update(self, name: str, hardware_id: str, level: int, message: str, values: dict,
               received_s: float) -> bool:
        """Record a status; False (ignored) for the board's own statuses, an unknown level or a new status on
        a full board. Invalid CHECKED_VALUES are dropped from the values and counted."""
        self.last_problem = ""
        if self.ignore_prefix and name.startswith(self.ignore_prefix):
            return False
        key = (hardware_id, name)
        reason = (UNKNOWN_LEVEL if level not in LEVEL_NAMES
                  else BOARD_FULL if key not in self.statuses and len(self.statuses) >= self.max_statuses else "")
        if reason:
            self.ignored[reason] += 1
            self.last_problem = f"ignored {hardware_id} '{name}': {reason} ({level!r})"[:200]
            return False
        values = dict(values)
        bad = sorted(k for k in CHECKED_VALUES if k in values and invalid_value(k, values[k]))
        for k in bad:
            self.last_problem = f"dropped {hardware_id} '{name}' {k} = {values.pop(k)!r} (invalid)"[:200]
        self.invalid_values += len(bad)
        self.statuses[key] = MachineStatus(name, hardware_id, Level(level), message, values, float(received_s))
        return True

    def reject_message(self, why: str) -> None:
        """A message whose statuses could not be read at all: counted among the ignored (as one)."""
        self.ignored[MALFORMED] += 1
        self.last_problem = f"ignored a {MALFORMED}: {why}"[:200]

    def forget_silent(self, now_s: float) -> int:
        """Drop the statuses silent for more than forget_after_s; returns how many."""
        old = [key for key, status in self.statuses.items() if now_s - status.received_s > self.forget_after_s]
        for key in old:
            del self.statuses[key]
        self.forgotten += len(old)
        return len(old)

    def effective_level(self, status: MachineStatus, now_s: float) -> Level:
        return Level.STALE if now_s - status.received_s > self.stale_after_s else status.level

    def summary(self, now_s: float) -> dict:
        """Counts per level, the worst status, the extreme values (silent statuses forgotten first)."""
        self.forget_silent(now_s)
        counts = {level: 0 for level in Level}
        worst, worst_level = None, None
        life = (math.inf, "")
        used = (-math.inf, "")
        end_ratio = (-math.inf, "")
        for status in self.statuses.values():
            level = self.effective_level(status, now_s)
            counts[level] += 1
            if worst_level is None or _SEVERITY[level] > _SEVERITY[worst_level]:
                worst, worst_level = status, level
            v = status.values
            h = _number(v.get("remaining_life_h"))
            if math.isfinite(h) and h < life[0]:
                life = (h, status.hardware_id)
            u = _number(v.get("life_used_fraction"))
            if math.isfinite(u) and u > used[0]:
                used = (u, status.hardware_id)
            r = _number(v.get("end_stress_ratio"))
            if math.isfinite(r) and r > end_ratio[0]:
                end_ratio = (r, status.hardware_id)
        machines = sorted({hw for hw, _ in self.statuses})
        result = {
            "machines": len(machines),
            "statuses": len(self.statuses),
            "ok": counts[Level.OK], "warn": counts[Level.WARN], "error": counts[Level.ERROR],
            "stale": counts[Level.STALE],
            "worst_machine": worst.hardware_id if worst else "",
            "worst_status": worst.name if worst else "",
            "min_remaining_life_h": life[0] if life[1] else math.nan,
            "min_remaining_life_machine": life[1],
            "max_life_used_fraction": used[0] if used[1] else math.nan,
            "max_life_used_machine": used[1],
            "max_end_stress_ratio": end_ratio[0] if end_ratio[1] else math.nan,
            "max_end_stress_machine": end_ratio[1],
            "ignored_statuses": sum(self.ignored.values()),
            "invalid_values": self.invalid_values,
            "forgotten_statuses": self.forgotten,
        }
        if worst is None:
            result["level"], result["message"] = Level.STALE, "no machine has reported yet"
        else:
            level = worst_level
            bad = counts[Level.WARN] + counts[Level.ERROR] + counts[Level.STALE]
            text = (f"{len(machines)} machines, {len(self.statuses)} statuses: {counts[Level.OK]} OK, "
                    f"{counts[Level.WARN]} WARN, {counts[Level.ERROR]} ERROR, {counts[Level.STALE]} STALE")
            if bad:
                text += f"; worst {worst.hardware_id} '{worst.name}' ({LEVEL_NAMES[level]}: {worst.message})"
            # the fleet status is ERROR/WARN with its worst member; silent machines make it WARN
            result["level"] = (Level.ERROR if level == Level.ERROR
                               else Level.WARN if level in (Level.WARN, Level.STALE) else Level.OK)
            result["message"] = text
        return result


# --- fleet prior: the population of a machine type's wear coefficient (empirical Bayes) ----------------

@dataclass(frozen=True)
class PopulationFit:
    """Random-effects fit of per-machine estimates y_i with standard errors s_i:
    y_i ~ N(mu, tau^2 + s_i^2) (the normal-normal hierarchical model), mu and tau by REML."""

    mean: float                  # mu, the population mean
    tau: float                   # tau, the population sd (between machines)
    mean_std_error: float        # sd of mu given tau: (sum w_i)^-1/2, w_i = 1 / (tau^2 + s_i^2)
    machines: int

    @property
    def predictive_sd(self) -> float:
        """sd of a new machine's value: sqrt(tau^2 + se(mu)^2) (population spread and the error of mu)."""
        return math.sqrt(self.tau ** 2 + self.mean_std_error ** 2)


def _reml_objective(tau: float, y, s2) -> tuple[float, float, float]:
    """(-log REML likelihood, mu, se(mu)) of the random-effects model at tau (Viechtbauer 2005, Eq. 7):
    -l_R = 1/2 [sum log v_i + log sum w_i + sum w_i (y_i - mu)^2], v_i = tau^2 + s_i^2, w_i = 1/v_i."""
    import numpy as np

    v = tau * tau + s2
    w = 1.0 / v
    mu = float(np.sum(w * y) / np.sum(w))
    nll = 0.5 * float(np.sum(np.log(v)) + math.log(np.sum(w)) + np.sum(w * (y - mu) ** 2))
    return nll, mu, 1.0 / math.sqrt(float(np.sum(w)))


def random_effects_fit(values, std_errors) -> PopulationFit:
    """REML fit of the population (mu, tau) from per-machine estimates and their standard errors
    (empirical Bayes: the hyper-parameters from the marginal likelihood of the machines' estimates).
    tau is bounded to [0, 10 x (range of y + largest s)]; at least 2 machines with finite s > 0."""
    import numpy as np
    from scipy.optimize import minimize_scalar

    y = np.asarray(values, dtype=float)
    s = np.asarray(std_errors, dtype=float)
    ok = np.isfinite(y) & np.isfinite(s) & (s > 0)
    y, s = y[ok], s[ok]
    if y.size < 2:
        raise ValueError(f"a population fit needs at least 2 machines with an estimate, got {int(y.size)}")
    s2 = s * s
    upper = 10.0 * (float(np.ptp(y)) + float(s.max()))
    best = minimize_scalar(lambda t: _reml_objective(t, y, s2)[0], bounds=(0.0, upper), method="bounded",
                           options={"xatol": 1e-6 * upper})
    tau = float(best.x)
    if _reml_objective(0.0, y, s2)[0] <= best.fun:       # the boundary tau = 0 (no spread beyond the errors)
        tau = 0.0
    _, mu, mu_se = _reml_objective(tau, y, s2)
    return PopulationFit(mean=mu, tau=tau, mean_std_error=mu_se, machines=int(y.size))


def likelihood_from_posterior(posterior_mean: float, posterior_sd: float, prior_mean: float,
                              prior_sd: float) -> tuple[float, float]:
    """The data-only estimate (mean, sd) behind a conjugate normal posterior: Gaussian division of the
    posterior by its prior, precision 1/sd^2 = 1/sd_post^2 - 1/sd_prior^2 and
    mean = (m_post/sd_post^2 - m_prior/sd_prior^2) sd^2 (WearCoefficientEstimator.posterior inverted:
    g'y/g'g and sigma/sqrt(g'g)). (nan, inf) when the posterior holds no information beyond the prior."""
    precision = 1.0 / posterior_sd ** 2 - 1.0 / prior_sd ** 2
    if not precision > 1e-12 / posterior_sd ** 2:
        return math.nan, math.inf
    mean = (posterior_mean / posterior_sd ** 2 - prior_mean / prior_sd ** 2) / precision
    return mean, 1.0 / math.sqrt(precision)


def wear_coefficient_prior(log_k_fit: PopulationFit) -> tuple[float, float]:
    """(K0, relative sd) of the wear_monitor's normal prior on K that matches the mean and sd of the new
    machine's lognormal predictive, log K ~ N(mu, v), v = tau^2 + se(mu)^2:
    K0 = exp(mu + v/2), sd/K0 = sqrt(exp(v) - 1) (lognormal moments)."""
    v = log_k_fit.predictive_sd ** 2
    return math.exp(log_k_fit.mean + 0.5 * v), math.sqrt(math.expm1(v))


def combine_estimates(values, std_errors) -> tuple[float, float]:
    """Inverse-variance mean and its sd of independent estimates of one quantity (several bags of one
    machine); (nan, inf) when none has a finite sd."""
    pairs = [(v, s) for v, s in zip(values, std_errors) if math.isfinite(v) and math.isfinite(s) and s > 0]
    if not pairs:
        return math.nan, math.inf
    w = [1.0 / (s * s) for _, s in pairs]
    return sum(wi * v for wi, (v, _) in zip(w, pairs)) / sum(w), 1.0 / math.sqrt(sum(w))
