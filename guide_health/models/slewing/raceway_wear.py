"""Raceway wear of the two axial rows of a three-row roller slewing bearing and the tilting clearance it opens.

Archard's law on the raceway, local form: dh/dt = k p v_s, k = K / H [m^2/N] the dimensional wear coefficient
(K Archard's dimensionless coefficient, H the raceway hardness), p the contact pressure, v_s the sliding speed.

Sliding. A cylindrical roller on a flat thrust raceway rolls without slip only on the pitch circle: at the
distance y from its mid-length the raceway runs at (R_pw + y) / R_pw of the roller's surface speed, so the
contact slides at |y| / R_pw of the rolling speed (R_pw = D_pw / 2; the geometric slip of a cylindrical roller
on a thrust raceway, Harris & Kotzalas, Essential Concepts, Ch. on thrust cylindrical roller bearings). One
roller passing a raceway point at y removes

    dh(y) = k w(y) |y| / R_pw            (integral of p v_s dt across the contact = |y| / R_pw x integral p dx)

w(y) the line load along the roller: the seed-003 finite-roller distribution (Eqs. 2-10, end effect
included: the ends carry more load AND slide most). Averaged over the roller length l_e:

    h_mean = k Q chi(Q) / (4 R_pw),  chi(Q) = integral w(y)|y| dy / (Q l_e / 4)

chi = 1 for a uniform line load; the seed-003 distribution gives chi = 1.02-1.05 (tabulated over the roller
load, w normalised to carry Q: the seed's method balances the load only to ~1 %).

Passes. When one ring turns by d phi against the other the cage turns by d phi / 2 against each, so every point
of either raceway meets Z d phi / (4 pi) roller passes; over the circumference it meets the rollers of every
azimuth (the rotating ring) or of its own azimuth (the fixed ring), on average the row's mean roller. Mean depth
of one raceway: d h = Z d phi / (4 pi) x mean_j k Q_j chi(Q_j) / (4 R_pw); both raceways of a row:

    d c_row / d phi = k sum_j Q_j chi(Q_j) / (4 pi D_pw)          [m/rad]

Tilting clearance (the geometry of the map). The manufacturers' tilting test reverses a tilting moment and
reads the axial movement of one ring against the other near the raceway: the rigid ring, held at one azimuth
by the upper row's raceways and at the opposite one by the lower row's, moves by the axial play at the gauge.
The axial play of a three-row roller bearing is the gap the rollers of both axial rows leave between their
raceways, so every micrometre of mean depth worn on either raceway of either axial row adds a micrometre:

    c = c_0 + sum over the upper and the lower axial row of the mean depth of both raceways

ASSUMED: the depth is uniform over the circumference (the mean over the azimuth; a yaw or pitch bearing that
dwells at preferred positions wears unevenly, and the reading then depends on where the gauge stands) and
over the roller length (the ends wear first; the profile's shape is not followed). The radial row changes the
radial play, not the tilting clearance, and is left out.

The clearance per unit k, g = (c - c_0) / k [m per (m^2/N)], is what the guides' K estimator takes as
its "loss per unit K": the measured clearances update k with the same conjugate update and interval
(guide_health.models.wear.calibration.WearCoefficientEstimator), and the remaining life to the replacement
clearance is the guides' Eq. 12 life at the duty so far continued (guide_health.models.wear.planning).

Pure physics: numpy, SI units (m, N, rad, s); no ROS, no I/O.
"""
from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from guide_health.models.slewing.finite_roller import finite_roller_contact
from guide_health.models.wear.calibration import WearCoefficientEstimator
from guide_health.models.wear.life import LifeNow
from guide_health.models.wear.planning import LifeInputs, life_interval

#: the status keys of RacewayWear.report (slewing_monitor's status, replay's report)
RACEWAY_WEAR_KEYS = ("tilting_clearance_predicted_mm", "tilting_clearance_measured_mm",
                     "tilting_clearance_measurements", "tilting_clearance_limit_mm", "raceway_wear_coefficient_m2_n",
                     "raceway_wear_coefficient_low_m2_n", "raceway_wear_coefficient_high_m2_n",
                     "raceway_wear_remaining_life_h", "raceway_wear_remaining_life_low_h",
                     "raceway_wear_remaining_life_high_h")
#: roller loads [N] of the chi(Q) table (log-spaced; clamped outside, chi varies by ~1 % per decade)
_CHI_LOADS_N = np.logspace(1.0, 7.0, 13)
_CHI_POINTS = 4001


@functools.lru_cache(maxsize=16)
def sliding_weight_table(roller_length_m: float, roller_diameter_m: float, youngs_modulus_pa: float,
                         poisson: float) -> tuple[np.ndarray, np.ndarray]:
    """(ln Q, chi(Q)): chi = integral w(y)|y| dy / (Q l_e / 4) of the seed-003 line load w (normalised to Q)."""
    chi = []
    for load in _CHI_LOADS_N:
        contact = finite_roller_contact(float(load), roller_length_m, roller_diameter_m, youngs_modulus_pa, poisson,
                                        points=_CHI_POINTS)
        y, w = contact.y_m, contact.line_load_n_m
        carried = float(np.trapezoid(w, y))
        chi.append(float(np.trapezoid(w * np.abs(y), y)) / (carried * roller_length_m / 4.0))
    return np.log(_CHI_LOADS_N), np.asarray(chi)


def clearance_rate_per_k(roller_loads_n: np.ndarray, chi_table: tuple[np.ndarray, np.ndarray],
                         raceway_diameter_m: float) -> float:
    """d c / (k d phi) of one row: sum_j Q_j chi(Q_j) / (4 pi D_pw) [m per (m^2/N) per rad] (module doc)."""
    loads = np.asarray(roller_loads_n, dtype=float)
    loaded = loads[loads > 0.0]
    if loaded.size == 0:
        return 0.0
    chi = np.interp(np.log(loaded), *chi_table)
    return float(np.sum(loaded * chi)) / (4.0 * math.pi * raceway_diameter_m)


def clearance_rate_per_k_load_power(roller_loads_n: np.ndarray, chi_table: tuple[np.ndarray, np.ndarray],
                                    raceway_diameter_m: float, exponent: float, reference_load_n: float) -> np.ndarray:
    """d c / (k d phi) when a roller pass wears as Q^n rather than Q (a load-dependent wear exponent n; n = 1 is
    :func:`clearance_rate_per_k`): sum_j Q_j chi(Q_j) (Q_j / Q_ref)^(n - 1) / (4 pi D_pw), k keeping its meaning
    at the reference roller load Q_ref [N]. ``roller_loads_n``: one row of roller loads per load sample; returns
    one rate per row [m per (m^2/N) per rad]."""
    loads = np.atleast_2d(np.asarray(roller_loads_n, dtype=float))
    safe = np.where(loads > 0.0, loads, 1.0)
    chi = np.interp(np.log(safe), *chi_table)
    weight = np.where(loads > 0.0, loads * chi * (safe / reference_load_n) ** (exponent - 1.0), 0.0)
    return weight.sum(axis=1) / (4.0 * math.pi * raceway_diameter_m)


def axial_roller_loads_n(axial_load_n: float, tilting_moment_nm: float, roller_count: int,
                         raceway_diameter_m: float) -> np.ndarray:
    """The roller pair at each azimuth psi_j presses Q_j = |F_a / Z + (4 M_T / (Z D_pw)) cos psi_j| [N] on one
    axial row or the other (seed 003 Eq. 1): the loads of both axial rows at once."""
    z = int(roller_count)
    return np.abs(axial_load_n / z + (4.0 * abs(tilting_moment_nm) / (z * raceway_diameter_m)) * _azimuth_cosines(z))


@functools.lru_cache(maxsize=8)
def _azimuth_cosines(roller_count: int) -> np.ndarray:
    """cos psi_j of the Z roller azimuths psi_j = 2 pi j / Z (built once per Z: the live node calls this per load)."""
    cos = np.cos(2.0 * np.pi * np.arange(roller_count) / roller_count)
    cos.flags.writeable = False
    return cos


class RacewayWear:
    """Tilting clearance from the angle travelled under the load in force, k from measured clearances.

    ``on_loads(F_a, M_T)`` sets the wear rate; ``on_travel(d phi)`` adds the new ground the fatigue counter
    accepted (the same travel, so encoder noise wears nothing); ``on_measurement(t_ns, c)`` adds a measured
    tilting clearance [m] to the k estimator. ``report(elapsed_s)``: the status keys.
    """

    def __init__(self, roller_count: int, raceway_diameter_m: float, chi_table: tuple[np.ndarray, np.ndarray],
                 estimator: WearCoefficientEstimator, clearance_limit_m: float) -> None:
        self.roller_count = int(roller_count)
        self.raceway_diameter_m = float(raceway_diameter_m)
        self.chi_table = chi_table
        self.estimator = estimator
        self.clearance_limit_m = float(clearance_limit_m)
        self.rate_per_k_rad = 0.0         # d g / d phi at the load in force [m per (m^2/N) per rad]
        self.clearance_per_k = 0.0        # g: clearance growth per unit k so far

    def on_loads(self, axial_load_n: float, tilting_moment_nm: float) -> None:
        """The rate at F_a [N], M_T [N m] (finite: the monitor's input rule). Both axial rows at once: the roller
        pair at psi_j presses Q_j = |F_a / Z + (4 M_T / (Z D_pw)) cos psi_j| on one row or the other (seed 003
        Eq. 1, row_loads.axial_row_roller_load_distributions), so sum over both rows = sum_j Q_j chi(Q_j)."""
        loads = axial_roller_loads_n(axial_load_n, tilting_moment_nm, self.roller_count, self.raceway_diameter_m)
        self.rate_per_k_rad = clearance_rate_per_k(loads, self.chi_table, self.raceway_diameter_m)

    def on_travel(self, travel_rad: float) -> None:
        self.clearance_per_k += abs(travel_rad) * self.rate_per_k_rad

    def on_measurement(self, t_ns: int, clearance_m: float) -> str | None:
        """A measured tilting clearance [m]; returns the rejection reason or None."""
        if not (math.isfinite(clearance_m) and clearance_m > 0.0):
            return f"tilting clearance must be finite and > 0 m, got {clearance_m!r}"
        self.estimator.add(int(t_ns), float(clearance_m), self.clearance_per_k, 0.0)
        return None

    def life_interval_s(self, elapsed_s: float) -> tuple[float, float, float]:
        """(life, low, high) [s] to the replacement clearance at the duty so far continued (rate g / elapsed):
        the guides' Eq. 12 life and its 90 % interval from k's interval (planning.life_interval)."""
        k_low, k, k_high = self.estimator.interval90()
        rate = self.clearance_per_k / elapsed_s if elapsed_s > 0.0 else 0.0
        now = LifeNow(self.estimator.straightness_initial_m, self.clearance_limit_m, self.clearance_per_k, rate,
                      k, k_low, k_high)
        return life_interval(LifeInputs(now=now))

    def report(self, elapsed_s: float) -> dict[str, Any]:
        k_low, k, k_high = self.estimator.interval90()
        life, low, high = self.life_interval_s(elapsed_s)
        c0 = self.estimator.straightness_initial_m
        measured = self.estimator.measurement_m
        return {
            "tilting_clearance_predicted_mm": (c0 + k * self.clearance_per_k) * 1e3,
            "tilting_clearance_measured_mm": measured[-1] * 1e3 if measured else math.nan,
            "tilting_clearance_measurements": self.estimator.count,
            "tilting_clearance_limit_mm": self.clearance_limit_m * 1e3,
            "raceway_wear_coefficient_m2_n": k,
            "raceway_wear_coefficient_low_m2_n": k_low,
            "raceway_wear_coefficient_high_m2_n": k_high,
            "raceway_wear_remaining_life_h": life / 3600.0,
            "raceway_wear_remaining_life_low_h": low / 3600.0,
            "raceway_wear_remaining_life_high_h": high / 3600.0,
        }

    def state(self) -> dict[str, Any]:
        """g, the rate at the load in force and the measurements (the prior, noise and c_0 are parameters)."""
        est = self.estimator
        return {"rate_per_k_rad": self.rate_per_k_rad, "clearance_per_k": self.clearance_per_k,
                "measurements": {name: list(getattr(est, name)) for name in MEASUREMENT_FIELDS}}

    def restore(self, state: dict[str, Any]) -> None:
        """Continue from ``state`` (of :meth:`state`); ValueError (one line) when malformed, nothing changed."""
        check_wear_state(state)
        self.rate_per_k_rad = float(state["rate_per_k_rad"])
        self.clearance_per_k = float(state["clearance_per_k"])
        for name in MEASUREMENT_FIELDS:
            setattr(self.estimator, name, list(state["measurements"][name]))


#: the estimator's measurement lists (t_ns, clearance, g at the measurement, work: unused here)
MEASUREMENT_FIELDS = ("measurement_t_ns", "measurement_m", "measurement_loss_per_k_m", "measurement_work_nm")


def check_wear_state(state: Any) -> None:
    """ValueError (one line) unless ``state`` is a RacewayWear state: rates finite and >= 0, measurement lists
    of finite numbers and one length."""
    if not isinstance(state, dict):
        raise ValueError(f"raceway wear state must be a mapping, got {type(state).__name__}")
    for name in ("rate_per_k_rad", "clearance_per_k"):
        value = state.get(name)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value)
                                                                                  and value >= 0.0):
            raise ValueError(f"raceway wear {name} must be finite and >= 0, got {value!r}")
    lists = state.get("measurements")
    if not isinstance(lists, dict) or set(lists) != set(MEASUREMENT_FIELDS):
        raise ValueError("raceway wear measurements must hold " + ", ".join(MEASUREMENT_FIELDS))
    for name in MEASUREMENT_FIELDS:
        values = lists[name]
        if not isinstance(values, list) or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in values):
            raise ValueError(f"raceway wear {name} must be a list of finite numbers")
    if len({len(lists[name]) for name in MEASUREMENT_FIELDS}) != 1:
        raise ValueError("raceway wear measurement lists of unequal length")
