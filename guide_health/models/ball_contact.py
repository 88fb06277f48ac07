"""Ball/groove contact of a four-row linear rolling guideway: Hertz, load distribution, EHL film, mixed lubrication.

Source: WANG Xiaopeng, ZHAO Xinze, XU Xiang, LI Xiang, HE Kongde, TIAN Hongliang, "Mixed lubrication of a linear
motion rolling guideway pair", Journal of Vibration and Shock 39(9), 2020, DOI 10.13465/j.cnki.jvs.2020.09.037
("seed 001" below; NSK LH45 guide, equation/table/figure numbers are the paper's).

Pure physics: numpy/scipy only, SI units at every public boundary (m, N, Pa, m/s), no ROS, no I/O.

Contents
--------
* Exact Hertz point contact (Johnson 1985, Sec. 4.2, Eqs. 4.36-4.41) with complete elliptic integrals
  (``scipy.special.ellipk/ellipe``, parameter m = e^2): the axis ratio is solved from the curvature ratio with
  ``scipy.optimize.brentq``; semi-axes, peak pressure and mutual approach follow in closed form.
* Groove geometry: ball radius r, straight groove (rail and carriage) of radius f D = 2 f r (seed 001 Eq. 2).
  Effective radii: R_x = r along the rolling direction (the groove is straight), 1/R_y = 1/r - 1/(2 f r)
  across it (R_y = 103.18 mm for r = 3.9685 mm, f = 0.52). The contact ellipse is long across the groove,
  so the rolling-direction semi-axis a is the MINOR one (seed Table 1 'a').
* Load distribution of a 4-row carriage with contact angle alpha under preload and a vertical load
  (seed 001 Eq. 1 / its ref. 11, Tian et al. 2016): ``carriage_load_distribution``.
* Hamrock-Dowson (1977) central and minimum film for the elliptical contact, entrainment speed from the
  carriage speed, lambda ratio, regime.
* Johnson-Greenwood-Poon (1972) load sharing with Greenwood-Tripp (1970) asperity contact: asperity load share,
  mean-plane separation and real (asperity) contact area vs speed.
* ``rolling_contact_report`` (INTERFACES.md ``contact rolling --json`` keys) and ``LubricationRegimeEstimator``
  (one-time set-up, then O(1) microseconds per joint-state sample for a live node).

Hertz check (seed 001 Table 1, E = 206 GPa, nu = 0.3 both bodies, contact load = preload): p_max = 1.6796 /
1.9844 / 2.3406 / 2.6132 GPa and a = 0.11598 / 0.13703 / 0.16163 / 0.18045 mm at 385 / 635 / 1042 / 1450 N
against the table's 1.680 / 1.984 / 2.340 / 2.613 GPa and 0.116 / 0.137 / 0.162 / 0.180 mm (all within 0.25 %).
Axis ratio b/a = 8.136, approach 6.01 um per contact at 385 N.

Load distribution (what is solved)
----------------------------------
The seed's Eq. 1 (garbled in the text layer) is the per-contact Hertz law F = H delta^1.5 with the four rows
at contact angle alpha measured from the horizontal, vertical components F_i sin(alpha); rows 1, 2 (upper,
load F_u, the "working load") carry a downward (compressive) carriage load, rows 3, 4 (lower, F_L) carry
lift-off. The preload figures 385/635/1042/1450 N are PER BALL CONTACT: the seed says that without external
load "the preload is the force between the ball and the raceway" and Table 1's Hertz pressures follow from
them as single-contact loads (checked above). With a rigid carriage and rail, n balls per row sharing equally,
no moment, a vertical carriage displacement y (towards the rail) changes the normal approach of every ball
of the upper rows by +y sin(alpha) and of the lower rows by -y sin(alpha):

    F_u = K_b (Delta_0 + y sin alpha)^1.5,   F_L = K_b max(Delta_0 - y sin alpha, 0)^1.5     (no tension)
    F   = 2 n sin(alpha) (F_u - F_L)                                       (vertical equilibrium)
    Delta_0 = (F_0 / K_b)^(2/3)                                            (preload approach)

solved for y with brentq (the left side is monotonic in y); lateral components cancel by symmetry.
K_b is the stiffness of one ball between the carriage groove and the rail groove: two identical Hertz
contacts in series, Delta = 2 delta_contact (delta_contact from the exact Hertz solution). With the
dimensionless x = y sin(alpha) / Delta_0 the ball loads F_u/F_0 = (1 + x)^1.5 are independent of K_b, so
Fig. 4's F_u(F) does not depend on the stiffness; K_b sets only the displacement. F_u rises with F and, at a
given F, with the preload until the lower rows unload (x >= 1, at F = 2^2.5 n sin(alpha) F_0 = 16.7 kN for
385 N), beyond which F_u = F / (2 n sin alpha) for every preload.

Film, kinematics, oil and roughness (assumptions)
-------------------------------------------------
* Kinematics: the rail is fixed, the carriage moves at v. In pure rolling the ball centre moves at v/2
  relative to the rail, and the carriage and rail contacts lie on one line through the ball centre, so
  both contact surfaces move through the contact at |v|/2 relative to the contact point:
  entrainment speed u = (u1 + u2)/2 = |v|/2 at both the ball/rail and the ball/carriage contact. The
  seed's 10 % slide-to-roll ratio changes u1 - u2, not u. (The seed's speed axis is the "slider speed";
  its film numbers look as if it fed that speed directly as the entrainment speed, see below.)
* Oil: ISO VG68 guideway oil at 40 degC inlet temperature, eta_0 = 0.060 Pa s (68 mm^2/s x 870 kg/m^3),
  pressure-viscosity alpha = 2.0e-8 1/Pa (``oil_viscosity_pa_s``, ``pressure_viscosity_pa_inv``: set eta_0
  for the actual guide temperature). Isothermal, Newtonian, fully flooded inlet (no starvation, no
  shear heating): an upper bound on the film of an oil-starved guide.
* Roughness: ``roughness_rms_m`` is the COMPOSITE RMS sigma = sqrt(Rq1^2 + Rq2^2) of ball and groove.
  The seed's "RMS = 0.2 um" is taken as composite: the seed defines lambda = mean film / RMS with no
  sqrt(2), and its lambda ~ 1 at 0.5 m/s needs h ~ 200 nm, which is already 2x the smooth film at that
  speed; a per-surface reading (sigma = 0.28 um) would push every regime boundary a further 1.7x in speed.
  (The seed's Fig. 10 pairs, 294.3 nm / 1.18, 232 nm / 0.925, 203 nm / 0.82, imply sigma = 0.25 um.)
* Hamrock & Dowson (1977): H_c = 2.69 U^0.67 G^0.53 W^-0.067 (1 - 0.61 e^(-0.73 k)),
  H_min = 3.63 U^0.68 G^0.49 W^-0.073 (1 - e^(-0.68 k)); U = eta_0 u/(E' R_x), G = alpha E',
  W = w/(E' R_x^2), E' = 2/((1-nu1^2)/E1 + (1-nu2^2)/E2), k = b/a (transverse/rolling semi-axis).
  For this guide at 385 N: h_c = 4.7 / 34.8 / 102 / 163 nm at v = 0.005 / 0.1 / 0.5 / 1 m/s
  (lambda = 0.023 / 0.17 / 0.51 / 0.81).  At v < 0.01 m/s U < 1e-12, below the range the fit was made
  for (a low-speed extrapolation of the u^0.67 law).
* lambda = h_c / sigma (central film, like the seed's mean film in 2/3 of the Hertz zone); ``lambda_min``
  = h_min / sigma is reported as well.

Regime thresholds
-----------------
boundary: lambda < 0.03;  mixed: 0.03 <= lambda < 3;  full_film: lambda >= 3 (``LAMBDA_BOUNDARY``,
``LAMBDA_FULL_FILM``). The classical stochastic rule (boundary below 1, full film above 3) would call the
whole speed range in which the seed finds mixed lubrication (0.005-1 m/s) "boundary". Deterministic mixed-EHL
(the seed's method family; Zhu & Wang, Proc. IMechE J 2012, doi:10.1177/1350650112461867) places the end of
boundary lubrication (contact area ratio ~> 80 %, the seed's criterion) at lambda ~ 0.01-0.05 and finds
little asperity contact above lambda ~ 0.6-1.2. 0.03 is inside that band and close to where the JGP asperity
load share below crosses 80 % at the seed's 385 N contact (lambda = 0.035, v = 0.009 m/s; lambda = 0.03 is
reached at v = 0.007 m/s; seed: 0.005 m/s). 3 is kept as the
conservative full-film bound: the Gaussian (Greenwood-Tripp) asperity share falls below 0.1 % only there.

Mixed lubrication: Johnson-Greenwood-Poon + Greenwood-Tripp
----------------------------------------------------------
The load w is shared, w = w/gamma_1 + w/gamma_2 (1/gamma_1 + 1/gamma_2 = 1): the fluid carries w/gamma_1 with
modulus E'/gamma_1, the asperities w/gamma_2 with E'/gamma_2 (both give the same Hertz area A_H = pi a b).
The fluid film is Hamrock-Dowson at (w/gamma_1, E'/gamma_1): h = h_c,smooth gamma_1^(0.67 - 0.53)
= h_c,smooth gamma_1^0.14 (the W exponent cancels). The asperity pressure (Greenwood & Tripp 1970) at
mean-plane separation h = t sigma is
    p_a = (16 sqrt(2)/15) pi (eta_s beta sigma)^2 sqrt(sigma/beta) E' F_5/2(t),
    F_n(t) = int_t^inf (s - t)^n phi(s) ds  (phi: standard normal density; scipy.integrate.quad),
and must equal the asperity share of the mean Hertz pressure, p_a = w/(gamma_2 A_H). One unknown (t) is
solved with brentq. Real (micro-)contact area: A_r/A_H = pi^2 (eta_s beta sigma)^2 F_2(t) (closed form).
Asperity parameters (``asperity_radius_m`` = 2 um, ``asperity_density_per_m2`` = 1.7e11 1/m^2, summit sigma =
composite sigma): eta_s beta sigma = 0.068, sigma/beta = 0.1, as for a finely ground surface measured at
sub-micron sampling (Nayak, isotropic Gaussian: eta beta sigma = sqrt(alpha_B)/(16 sqrt(3 pi)) = 0.068 at bandwidth
alpha_B = 11, and sigma/beta = 8 sqrt(alpha_B) Dq^2/(3 sqrt(pi)) = 0.1 at RMS slope Dq = 0.14). They are an
effective choice: the asperity share at vanishing speed tends to p_a(t=0)/p_mean = 0.86 at 385 N, so the
speed at which the share crosses 80 % is ill-conditioned (a ~4 % change of eta^2 sqrt(1/beta) moves it across
the whole factor-3 band around the seed's 0.005 m/s); treat that crossing as calibrated to the seed, not
predicted. The textbook Greenwood-Williamson range (eta beta sigma = 0.03-0.05, sigma/beta = 0.01) gives an
asperity share of only 5-15 % at any speed > 0 for this 1.1 GPa mean-pressure contact (never boundary).

``contact_area_ratio`` (the seed's A_c: share of the Hertz area in solid contact in a deterministic model,
which resolves roughness only down to its grid and lets it flatten elastically) has no direct Gaussian
counterpart: the Greenwood-Tripp real area of micro-contacts is a different, much smaller quantity (a few %,
reported as ``asperity_real_area_ratio``). It is estimated by the JGP asperity LOAD share (contact nodes in
a deterministic model carry about the local Hertz-like pressure, so area and load ratios fall together).
Known limits of JGP-GT against the seed: (1) its transition is broader: share 0.85 -> 0.16 from 0.001 to
1 m/s and ~2 % at 3 m/s, against the seed's 80 % -> 0.05 % from 0.005 to 1 m/s (Zhu & Wang attribute this
to the Gaussian model ignoring the elastic flattening of asperities inside the EHL zone); (2) at a fixed
speed the share FALLS with load, because the asperity pressure at a given separation does not depend on the
nominal pressure while the EHL film hardly does (W^-0.067): at 1450 N the share never exceeds ~55 %. The
lambda-based regime falls the right way with load.

Smooth-surface Hamrock-Dowson vs the seed's rough-surface numerical mixed-EHL
-----------------------------------------------------------------------------
* The seed does not state the speed of Table 1 / Fig. 10. Its own Fig. 9 (lambda -> 1, i.e. h ~ 200 nm,
  at 0.5 m/s, film ~ u^0.6-0.7) puts Table 1's 294.3 nm at ~0.9-1 m/s slider speed. Hamrock-Dowson reaches
  294.3 nm at 385 N only at u = 1.2 m/s entrainment, i.e. v = 2.4 m/s with u = v/2 (1.2 m/s if the seed fed
  the slider speed as the entrainment speed, which would also explain why its lambda(0.5 m/s) ~ 1 is 2x the
  smooth value 0.51).
* The seed's mean film h_a is the mean gap over 2/3 of the Hertz zone between ROUGH surfaces: below ~0.1 m/s
  it is held up by the roughness (it "changes little over three decades" with lambda < 0.4), whereas the
  smooth film keeps falling as u^0.67 (lambda_HD = 0.008 at 0.001 m/s). Above ~0.1 m/s both grow with speed.
* Load: the seed's film falls 38 % from 385 to 635 N (294.3 -> 181.5 nm) and 47 % to 1450 N; EHL theory
  gives W^-0.067: -3.3 % and -8.5 %. Only the direction is reproduced. (The 385 N row equals the seed's
  Gf = 0.515 row, 294.3 nm; Hamrock-Dowson also puts f = 0.515 and 0.52 within 0.1 % of each other.)
* Conformity 0.515 -> 0.6 -> 0.8 at 385 N: R_x and W do not change, only k = b/a (9.63 -> 3.25 -> 1.92), so
  Hamrock-Dowson gives h_c -5.6 % / -15.0 % and h_min -10.8 % / -27.0 % relative to 0.515, against the
  seed's mean film -21 % / -31 %. Direction reproduced; the minimum film comes close, the central film
  falls about half as much (the seed's film also feels the rise of p_max with f: 1.58 -> 2.35 -> 2.91 GPa).
  The JGP asperity share, by contrast, FALLS with f at a fixed speed (limit (2) above); the seed's A_c
  rises (1 % -> 1.5 % -> 3.7 %).
* The seed's lambda = h_a / RMS; its Fig. 10 lambdas imply RMS = 0.25 um, not the stated 0.2 um.
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import Any, Callable, NamedTuple

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq
from scipy.special import ellipe, ellipk

from guide_health.params import WEAR_MONITOR_DEFAULTS

# --- Hamrock & Dowson (1977) point-contact film fits (dimensionless exponents/coefficients) ---
HD_CENTRAL_COEFF = 2.69
HD_CENTRAL_U_EXP = 0.67
HD_CENTRAL_G_EXP = 0.53
HD_CENTRAL_W_EXP = -0.067
HD_MIN_COEFF = 3.63
HD_MIN_U_EXP = 0.68
HD_MIN_G_EXP = 0.49
HD_MIN_W_EXP = -0.073
# JGP: the fluid film at (w/gamma_1, E'/gamma_1) is h_smooth gamma_1^(0.67 - 0.53)
JGP_FILM_GAMMA_EXP = HD_CENTRAL_U_EXP - HD_CENTRAL_G_EXP

# --- regime thresholds on lambda = h_c / sigma (see module docstring) ---
LAMBDA_BOUNDARY = 0.03
LAMBDA_FULL_FILM = 3.0
REGIMES = ("boundary", "mixed", "full_film")

ROWS_SUPPORTED = 4
_SQRT_2PI = math.sqrt(2.0 * math.pi)
_isfinite = math.isfinite
_log10 = math.log10
_GT_PRESSURE_COEFF = 16.0 * math.sqrt(2.0) / 15.0 * math.pi


# ----------------------------------------------------------------------------------------------------------
# Geometry and Hertz
# ----------------------------------------------------------------------------------------------------------

def reduced_modulus(youngs_modulus_1_pa: float, poisson_1: float,
                    youngs_modulus_2_pa: float | None = None, poisson_2: float | None = None) -> float:
    """E' = 2 / ((1 - nu1^2)/E1 + (1 - nu2^2)/E2) [Pa] (Hamrock's reduced modulus; Johnson's E* = E'/2)."""
    e2 = youngs_modulus_1_pa if youngs_modulus_2_pa is None else youngs_modulus_2_pa
    n2 = poisson_1 if poisson_2 is None else poisson_2
    return 2.0 / ((1.0 - poisson_1 ** 2) / youngs_modulus_1_pa + (1.0 - n2 ** 2) / e2)


def groove_contact_radii(ball_radius_m: float, groove_conformity: float) -> tuple[float, float]:
    """Effective radii (R_x, R_y) [m] of a ball in a straight groove of radius f D (seed 001 Eq. 2).

    R_x (rolling direction) = r: the groove is straight along the rail. 1/R_y = 1/r - 1/(2 f r) across it.
    """
    if not ball_radius_m > 0:
        raise ValueError(f"ball radius must be > 0, got {ball_radius_m!r}")
    if not groove_conformity > 0.5:
        raise ValueError(f"groove conformity must be > 0.5 (groove radius larger than the ball), got {groove_conformity!r}")
    groove_radius_m = groove_conformity * 2.0 * ball_radius_m  # seed 001 Eq. 2: R2 = Gf D1 = 2 Gf R1
    return ball_radius_m, 1.0 / (1.0 / ball_radius_m - 1.0 / groove_radius_m)


def hertz_axis_ratio(radius_ratio: float) -> float:
    """Axis ratio kappa = major/minor semi-axis >= 1 of an elliptical Hertz contact [-].

    ``radius_ratio`` = R_large/R_small >= 1 of the effective radii. Solves (Johnson 1985 Eq. 4.39)
    R_large/R_small = (kappa^2 E(m) - K(m)) / (K(m) - E(m)),  m = e^2 = 1 - 1/kappa^2,
    with brentq; the right side rises monotonically from 1 at kappa = 1.
    """
    if not radius_ratio >= 1.0:
        raise ValueError(f"radius ratio must be >= 1, got {radius_ratio!r}")
    excess = radius_ratio - 1.0
    if excess < 1e-12:
        return 1.0
    if excess < 1e-5:
        # near-circular series: the right side is 1 + 3/2 (kappa - 1) + O((kappa - 1)^2); the elliptic-integral
        # difference K - E loses digits at m < 1e-5, the series error here is < 1e-10
        return 1.0 + 2.0 * excess / 3.0

    def residual(kappa: float) -> float:
        m = 1.0 - 1.0 / kappa ** 2
        k_m, e_m = ellipk(m), ellipe(m)
        return (kappa ** 2 * e_m - k_m) / (k_m - e_m) - radius_ratio

    return brentq(residual, 1.0 + 1e-9, radius_ratio + 1.0, xtol=1e-14, rtol=1e-13)


@dataclass(frozen=True)
class HertzPointContact:
    """Elliptical Hertz contact (Johnson 1985 Sec. 4.2). Semi-axes along the x (rolling) and y directions."""

    load_n: float
    semi_axis_x_m: float        # along x (rolling direction); the minor axis when R_x < R_y
    semi_axis_y_m: float        # along y (across the groove)
    p_max_pa: float             # peak pressure p0 = 3 P / (2 pi a b)
    approach_m: float           # mutual approach delta of distant points of the two bodies
    axis_ratio: float           # major/minor >= 1
    eccentricity_sq: float      # m = e^2 = 1 - (minor/major)^2
    elliptic_k: float           # K(m)
    elliptic_e: float           # E(m)

    @property
    def ellipticity_k(self) -> float:
        """Hamrock-Dowson k = semi-axis across / along the entrainment (x) direction [-]."""
        return self.semi_axis_y_m / self.semi_axis_x_m

    @property
    def area_m2(self) -> float:
        """Contact area pi a b [m^2]."""
        return math.pi * self.semi_axis_x_m * self.semi_axis_y_m

    @property
    def mean_pressure_pa(self) -> float:
        """Mean pressure P / (pi a b) = 2/3 p_max [Pa]."""
        return self.load_n / self.area_m2


def hertz_point_contact(load_n: float, radius_x_m: float, radius_y_m: float,
                        reduced_modulus_pa: float) -> HertzPointContact:
    """Exact Hertz solution for a gap x^2/(2 R_x) + y^2/(2 R_y) under load P (Johnson 1985 Eqs. 4.36-4.41).

    With E* = E'/2, the major semi-axis c (along the larger radius R_l), kappa = c/a_minor:
        c^3 = 3 P R_l (K - E) / (pi E* m),   p0 = 3 P / (2 pi a c),   delta = p0 a_minor K(m) / E*.
    Circular limit (R_x = R_y = R): a^3 = 3 P R / (4 E*), p0 = 3 P / (2 pi a^2), delta = a^2 / R.
    """
    if not load_n > 0:
        raise ValueError(f"contact load must be > 0, got {load_n!r}")
    if not (radius_x_m > 0 and radius_y_m > 0 and reduced_modulus_pa > 0):
        raise ValueError("radii and modulus must be > 0")
    e_star = 0.5 * reduced_modulus_pa
    r_large, r_small = max(radius_x_m, radius_y_m), min(radius_x_m, radius_y_m)
    kappa = hertz_axis_ratio(r_large / r_small)
    if kappa == 1.0:
        radius = r_large
        a = (3.0 * load_n * radius / (4.0 * e_star)) ** (1.0 / 3.0)
        p0 = 3.0 * load_n / (2.0 * math.pi * a * a)
        half_pi = 0.5 * math.pi
        return HertzPointContact(load_n, a, a, p0, a * a / radius, 1.0, 0.0, half_pi, half_pi)
    m = 1.0 - 1.0 / kappa ** 2
    k_m, e_m = float(ellipk(m)), float(ellipe(m))
    # (K - E)/m, by its series pi/4 (1 + 3m/8 + 15m^2/64) where the difference would lose digits
    k_minus_e_over_m = (0.25 * math.pi * (1.0 + 0.375 * m + 15.0 / 64.0 * m * m)) if m < 1e-4 else (k_m - e_m) / m
    major = (3.0 * load_n * r_large * k_minus_e_over_m / (math.pi * e_star)) ** (1.0 / 3.0)
    minor = major / kappa
    p0 = 3.0 * load_n / (2.0 * math.pi * major * minor)
    approach = p0 * minor * k_m / e_star
    if radius_x_m <= radius_y_m:       # contact elongated across x: x is the minor axis
        ax, ay = minor, major
    else:
        ax, ay = major, minor
    return HertzPointContact(load_n, ax, ay, p0, approach, kappa, m, k_m, e_m)


# ----------------------------------------------------------------------------------------------------------
# Load distribution over the four rows (seed 001 Eq. 1 / ref. 11)
# ----------------------------------------------------------------------------------------------------------

def ball_stiffness_n_per_m15(radius_x_m: float, radius_y_m: float, reduced_modulus_pa: float) -> float:
    """K_b in F = K_b Delta^1.5 [N/m^1.5] for one ball between carriage and rail grooves (seed 001 Eq. 1).

    Two identical Hertz contacts in series: Delta = 2 delta_contact, delta_contact = c F^(2/3) (exact Hertz).
    """
    reference = hertz_point_contact(1.0, radius_x_m, radius_y_m, reduced_modulus_pa)  # delta at 1 N = c
    return (2.0 * reference.approach_m) ** -1.5


@dataclass(frozen=True)
class CarriageLoadDistribution:
    """Ball loads of a 4-row carriage (rows 1, 2 upper; 3, 4 lower) under preload and a vertical load."""

    external_load_n: float            # F, vertical, > 0 presses the carriage onto the rail
    preload_per_ball_n: float         # F_0 (per ball contact)
    vertical_displacement_m: float    # y, carriage towards the rail
    upper_ball_load_n: float          # F_u ("working load", seed Fig. 4)
    lower_ball_load_n: float          # F_L
    contact_angle_rad: float
    balls_per_row: int

    @property
    def row_ball_loads_n(self) -> tuple[float, float, float, float]:
        """Load of one ball of each row 1..4 [N]."""
        return (self.upper_ball_load_n, self.upper_ball_load_n, self.lower_ball_load_n, self.lower_ball_load_n)

    @property
    def max_ball_load_n(self) -> float:
        """Highest ball load of any row [N]."""
        return max(self.upper_ball_load_n, self.lower_ball_load_n)

    @property
    def vertical_force_balance_n(self) -> float:
        """Sum of the vertical components of all ball loads on the carriage [N] (= F at equilibrium)."""
        s = math.sin(self.contact_angle_rad)
        return 2.0 * self.balls_per_row * s * (self.upper_ball_load_n - self.lower_ball_load_n)


def carriage_load_distribution(external_load_n: float, preload_per_ball_n: float, contact_angle_deg: float,
                               balls_per_row: int, ball_stiffness: float) -> CarriageLoadDistribution:
    """Solve the 4-row equilibrium (seed 001 Eq. 1; equations in the module docstring) for y with brentq.

    F_u = K_b (Delta_0 + y sin a)^1.5, F_L = K_b max(Delta_0 - y sin a, 0)^1.5, F = 2 n sin a (F_u - F_L).
    ``ball_stiffness`` K_b [N/m^1.5] from :func:`ball_stiffness_n_per_m15`. Unloaded rows carry 0 (no tension).
    """
    if not (math.isfinite(external_load_n) and math.isfinite(preload_per_ball_n)):
        raise ValueError("loads must be finite")
    if preload_per_ball_n < 0:
        raise ValueError(f"preload must be >= 0, got {preload_per_ball_n!r}")
    if not 0.0 < contact_angle_deg < 90.0:
        raise ValueError(f"contact angle must be in (0, 90) deg, got {contact_angle_deg!r}")
    if int(balls_per_row) != balls_per_row or balls_per_row < 1:
        raise ValueError(f"balls_per_row must be a positive integer, got {balls_per_row!r}")
    if not ball_stiffness > 0:
        raise ValueError("ball stiffness must be > 0")
    alpha = math.radians(contact_angle_deg)
    sin_a = math.sin(alpha)
    n = int(balls_per_row)
    delta0 = (preload_per_ball_n / ball_stiffness) ** (2.0 / 3.0)

    def upper(y: float) -> float:
        return ball_stiffness * max(delta0 + y * sin_a, 0.0) ** 1.5

    def lower(y: float) -> float:
        return ball_stiffness * max(delta0 - y * sin_a, 0.0) ** 1.5

    def residual(y: float) -> float:
        return 2.0 * n * sin_a * (upper(y) - lower(y)) - external_load_n

    if external_load_n == 0.0:
        y = 0.0
    else:
        y_bound = ((abs(external_load_n) / (2.0 * n * sin_a * ball_stiffness)) ** (2.0 / 3.0) + delta0) / sin_a
        y = brentq(residual, -y_bound, y_bound, xtol=1e-18, rtol=1e-13)
    return CarriageLoadDistribution(external_load_n, preload_per_ball_n, y, upper(y), lower(y), alpha, n)


def upper_ball_load_ratio(load_ratio: float) -> float:
    """F_u/F_0 vs q = F / (2 n sin(alpha) F_0) (dimensionless form of the 4-row equilibrium, q >= 0).

    q = (1 + x)^1.5 - max(1 - x, 0)^1.5 with F_u/F_0 = (1 + x)^1.5; for q >= 2^1.5 (lower rows unloaded)
    F_u/F_0 = q. Independent of the ball stiffness.
    """
    q = abs(load_ratio)
    if q >= 2.0 ** 1.5:
        return q
    x = brentq(lambda x: (1.0 + x) ** 1.5 - (1.0 - x) ** 1.5 - q, 0.0, 1.0, xtol=1e-15)
    return (1.0 + x) ** 1.5


# ----------------------------------------------------------------------------------------------------------
# Film thickness and lambda
# ----------------------------------------------------------------------------------------------------------

def entrainment_speed(carriage_speed_m_s: float) -> float:
    """u = (u1 + u2)/2 = |v|/2 [m/s] for the ball/rail and ball/carriage contacts in pure rolling (see module doc)."""
    return 0.5 * abs(carriage_speed_m_s)


def hamrock_dowson_film(load_n: float, entrainment_speed_m_s: float, radius_x_m: float, ellipticity_k: float,
                        reduced_modulus_pa: float, viscosity_pa_s: float,
                        pressure_viscosity_pa_inv: float) -> tuple[float, float]:
    """(central, minimum) film thickness [m] of a smooth elliptical EHL contact (Hamrock & Dowson 1977).

    H_c = 2.69 U^0.67 G^0.53 W^-0.067 (1 - 0.61 exp(-0.73 k)), H_min = 3.63 U^0.68 G^0.49 W^-0.073 (1 - exp(-0.68 k)),
    h = H R_x; U = eta_0 u / (E' R_x), G = alpha E', W = w / (E' R_x^2), k = b/a (entrainment along x).
    """
    if not load_n > 0:
        raise ValueError(f"contact load must be > 0, got {load_n!r}")
    if entrainment_speed_m_s < 0:
        raise ValueError("entrainment speed must be >= 0")
    if entrainment_speed_m_s == 0.0:
        return 0.0, 0.0
    u_dim = viscosity_pa_s * entrainment_speed_m_s / (reduced_modulus_pa * radius_x_m)
    g_dim = pressure_viscosity_pa_inv * reduced_modulus_pa
    w_dim = load_n / (reduced_modulus_pa * radius_x_m ** 2)
    h_central = (HD_CENTRAL_COEFF * u_dim ** HD_CENTRAL_U_EXP * g_dim ** HD_CENTRAL_G_EXP * w_dim ** HD_CENTRAL_W_EXP
                 * (1.0 - 0.61 * math.exp(-0.73 * ellipticity_k)))
    h_min = (HD_MIN_COEFF * u_dim ** HD_MIN_U_EXP * g_dim ** HD_MIN_G_EXP * w_dim ** HD_MIN_W_EXP
             * (1.0 - math.exp(-0.68 * ellipticity_k)))
    return h_central * radius_x_m, h_min * radius_x_m


def composite_roughness(rq_1_m: float, rq_2_m: float = 0.0) -> float:
    """sigma = sqrt(Rq1^2 + Rq2^2) [m]."""
    return math.hypot(rq_1_m, rq_2_m)


def lubrication_regime(lambda_ratio: float, lambda_boundary: float = LAMBDA_BOUNDARY,
                       lambda_full_film: float = LAMBDA_FULL_FILM) -> str:
    """'boundary' (lambda < lambda_boundary), 'full_film' (lambda >= lambda_full_film) or 'mixed'."""
    if lambda_ratio < lambda_boundary:
        return "boundary"
    if lambda_ratio >= lambda_full_film:
        return "full_film"
    return "mixed"


# ----------------------------------------------------------------------------------------------------------
# Greenwood-Tripp asperity contact and JGP load sharing
# ----------------------------------------------------------------------------------------------------------

def greenwood_tripp_integral(order: float, separation_ratio: float) -> float:
    """F_n(t) = int_t^inf (s - t)^n phi(s) ds (Greenwood & Tripp 1970), phi the standard normal density.

    scipy.integrate.quad over x = s - t in [0, inf), split at the density peak for t < 0.
    """
    t = separation_ratio

    def integrand(x: float) -> float:
        return x ** order * math.exp(-0.5 * (x + t) ** 2)

    if t < 0.0:
        peak = -t
        value = quad(integrand, 0.0, peak + 12.0, points=(peak,), limit=200)[0]
    else:
        value = quad(integrand, 0.0, math.inf, limit=200)[0]
    return value / _SQRT_2PI


def greenwood_tripp_f2(separation_ratio: float) -> float:
    """F_2(t) = (1 + t^2) Q(t) - t phi(t) (closed form), Q the upper normal tail."""
    t = separation_ratio
    upper_tail = 0.5 * math.erfc(t / math.sqrt(2.0))
    return (1.0 + t * t) * upper_tail - t * math.exp(-0.5 * t * t) / _SQRT_2PI


def greenwood_tripp_pressure_coefficient(composite_rms_m: float, asperity_density_per_m2: float,
                                         asperity_radius_m: float, reduced_modulus_pa: float) -> float:
    """K_GT E' [Pa] in p_a = K_GT E' F_5/2(h/sigma), K_GT = (16 sqrt 2 / 15) pi (eta beta sigma)^2 sqrt(sigma/beta)."""
    eta_beta_sigma = asperity_density_per_m2 * asperity_radius_m * composite_rms_m
    return (_GT_PRESSURE_COEFF * eta_beta_sigma ** 2 * math.sqrt(composite_rms_m / asperity_radius_m)
            * reduced_modulus_pa)


@dataclass(frozen=True)
class MixedLubrication:
    """JGP/GT load sharing result."""

    asperity_load_share: float        # 1/gamma_2 = W_asperity / W
    separation_m: float               # mean-plane separation h = film of the fluid part (may be < 0 at v = 0)
    asperity_real_area_ratio: float   # A_r / A_Hertz, GT micro-contact area


def jgp_greenwood_tripp(smooth_central_film_m: float, mean_contact_pressure_pa: float, composite_rms_m: float,
                        gt_pressure_coefficient_pa: float, asperity_density_per_m2: float, asperity_radius_m: float,
                        f52: Callable[[float], float] | None = None) -> MixedLubrication:
    """Johnson-Greenwood-Poon (1972) load sharing with Greenwood-Tripp asperities (equations: module docstring).

    Unknown t = h/sigma: s(t) = K_GT E' F_5/2(t) / p_mean (asperity share), and the fluid film at
    (w/gamma_1, E'/gamma_1) equals the separation: h_smooth (1 - s)^-0.14 = sigma t. brentq on t in (t_full, t_hi],
    t_full: s(t_full) = 1 (asperities alone). ``f52`` replaces :func:`greenwood_tripp_integral` (e.g. a table).
    """
    if f52 is None:
        def f52(t: float) -> float:
            return greenwood_tripp_integral(2.5, t)
    scale = gt_pressure_coefficient_pa / mean_contact_pressure_pa

    def share(t: float) -> float:
        return scale * f52(t)

    lo = -4.0
    while share(lo) < 1.0:
        lo -= 4.0
        if lo < -1e3:
            raise ValueError("asperity contact too compliant: no separation carries the load")
    t_full = brentq(lambda t: share(t) - 1.0, lo, 40.0, xtol=1e-12)
    eta_beta_sigma = asperity_density_per_m2 * asperity_radius_m * composite_rms_m
    area_coeff = math.pi ** 2 * eta_beta_sigma ** 2
    if smooth_central_film_m <= 0.0:
        return MixedLubrication(1.0, t_full * composite_rms_m, area_coeff * greenwood_tripp_f2(t_full))
    lam = smooth_central_film_m / composite_rms_m

    def film_mismatch(t: float) -> float:
        s = min(share(t), 1.0 - 1e-15)
        return lam * (1.0 - s) ** (-JGP_FILM_GAMMA_EXP) - t

    t_lo = t_full + 1e-12 * max(1.0, abs(t_full))
    if film_mismatch(t_lo) <= 0.0:
        # the root sits closer to t_full than double precision resolves (1 - s < 1e-15): asperities carry all
        return MixedLubrication(1.0, t_full * composite_rms_m, area_coeff * greenwood_tripp_f2(t_full))
    t_hi = max(t_full, lam) + 1.0
    while film_mismatch(t_hi) > 0.0:
        t_hi += 2.0
    t = brentq(film_mismatch, t_lo, t_hi, xtol=1e-12)
    return MixedLubrication(min(share(t), 1.0), t * composite_rms_m, area_coeff * greenwood_tripp_f2(t))


# ----------------------------------------------------------------------------------------------------------
# Parameters, report and the live estimator
# ----------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class RollingGuideContact:
    """Numbers of one ball/groove contact of a rolling guide, from wear_monitor parameters (SI)."""

    ball_radius_m: float
    groove_conformity: float
    contact_angle_deg: float
    balls_per_row: int
    rows: int
    preload_per_ball_n: float
    viscosity_pa_s: float
    pressure_viscosity_pa_inv: float
    composite_rms_m: float
    youngs_modulus_pa: float
    poisson: float
    asperity_radius_m: float
    asperity_density_per_m2: float
    carriages: int
    lambda_boundary: float
    lambda_full_film: float
    radius_x_m: float
    radius_y_m: float
    reduced_modulus_pa: float
    ball_stiffness: float

    @classmethod
    def from_params(cls, params: dict[str, Any]) -> "RollingGuideContact":
        """Validate and convert wear_monitor parameters; raises ValueError with a one-line reason."""
        def number(name: str, default: Any = None) -> float:
            value = params.get(name, default)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"parameter {name} must be a finite number, got {value!r}")
            return float(value)

        def positive(name: str, default: Any = None) -> float:
            value = number(name, default)
            if not value > 0:
                raise ValueError(f"parameter {name} must be > 0, got {value!r}")
            return value

        def integer(name: str, default: Any = None) -> int:
            value = params.get(name, default)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"parameter {name} must be a positive integer, got {value!r}")
            return value

        radius = positive("ball_radius_m")
        conformity = number("groove_conformity")
        if not conformity > 0.5:
            raise ValueError(f"parameter groove_conformity must be > 0.5, got {conformity!r}")
        angle = number("contact_angle_deg")
        if not 0.0 < angle < 90.0:
            raise ValueError(f"parameter contact_angle_deg must be in (0, 90), got {angle!r}")
        rows = integer("rows")
        if rows != ROWS_SUPPORTED:
            raise ValueError(f"parameter rows: only 4-row carriages are modelled, got {rows!r}")
        preload = number("preload_n")
        if preload < 0:
            raise ValueError(f"parameter preload_n must be >= 0, got {preload!r}")
        poisson = number("poisson")
        if not 0.0 <= poisson < 0.5:
            raise ValueError(f"parameter poisson must be in [0, 0.5), got {poisson!r}")
        youngs = positive("youngs_modulus_pa")
        e_prime = reduced_modulus(youngs, poisson)
        lam_b = positive("lambda_boundary", LAMBDA_BOUNDARY)
        lam_f = positive("lambda_full_film", LAMBDA_FULL_FILM)
        if not lam_f > lam_b:
            raise ValueError("lambda_full_film must be > lambda_boundary")
        r_x, r_y = groove_contact_radii(radius, conformity)
        return cls(
            ball_radius_m=radius, groove_conformity=conformity, contact_angle_deg=angle,
            balls_per_row=integer("balls_per_row"), rows=rows, preload_per_ball_n=preload,
            viscosity_pa_s=positive("oil_viscosity_pa_s"),
            pressure_viscosity_pa_inv=positive("pressure_viscosity_pa_inv"),
            composite_rms_m=positive("roughness_rms_m"), youngs_modulus_pa=youngs, poisson=poisson,
            asperity_radius_m=positive("asperity_radius_m", WEAR_MONITOR_DEFAULTS["asperity_radius_m"]),
            asperity_density_per_m2=positive("asperity_density_per_m2",
                                             WEAR_MONITOR_DEFAULTS["asperity_density_per_m2"]),
            carriages=integer("carriages", WEAR_MONITOR_DEFAULTS["carriages"]),
            lambda_boundary=lam_b, lambda_full_film=lam_f,
            radius_x_m=r_x, radius_y_m=r_y, reduced_modulus_pa=e_prime,
            ball_stiffness=ball_stiffness_n_per_m15(r_x, r_y, e_prime),
        )

    def hertz(self, load_n: float) -> HertzPointContact:
        """Hertz contact at a ball load [N]."""
        return hertz_point_contact(load_n, self.radius_x_m, self.radius_y_m, self.reduced_modulus_pa)

    def film(self, load_n: float, carriage_speed_m_s: float, contact: HertzPointContact | None = None
             ) -> tuple[float, float]:
        """Hamrock-Dowson (central, minimum) film [m] at a ball load and carriage speed."""
        contact = contact or self.hertz(load_n)
        return hamrock_dowson_film(load_n, entrainment_speed(carriage_speed_m_s), self.radius_x_m,
                                   contact.ellipticity_k, self.reduced_modulus_pa, self.viscosity_pa_s,
                                   self.pressure_viscosity_pa_inv)

    @property
    def gt_pressure_coefficient_pa(self) -> float:
        """K_GT E' [Pa] of the Greenwood-Tripp asperity pressure."""
        return greenwood_tripp_pressure_coefficient(self.composite_rms_m, self.asperity_density_per_m2,
                                                    self.asperity_radius_m, self.reduced_modulus_pa)

    def mixed(self, smooth_central_film_m: float, contact: HertzPointContact,
              f52: Callable[[float], float] | None = None) -> MixedLubrication:
        """JGP/GT load sharing for this contact."""
        return jgp_greenwood_tripp(smooth_central_film_m, contact.mean_pressure_pa, self.composite_rms_m,
                                   self.gt_pressure_coefficient_pa, self.asperity_density_per_m2,
                                   self.asperity_radius_m, f52)

    def load_distribution(self, carriage_load_n: float) -> CarriageLoadDistribution:
        """Ball loads under a vertical load on ONE carriage [N]."""
        return carriage_load_distribution(carriage_load_n, self.preload_per_ball_n, self.contact_angle_deg,
                                          self.balls_per_row, self.ball_stiffness)


def rolling_contact_report(params: dict[str, Any], load_n: float | None, speed_m_s: float) -> dict[str, Any]:
    """Contact, film, lambda and regime of one ball contact (INTERFACES.md ``contact rolling --json`` keys).

    ``load_n``: contact load per ball [N] (default: ``preload_n``); ``speed_m_s``: carriage speed [m/s]
    (its sign is irrelevant). Raises ValueError on bad numbers.
    """
    guide = RollingGuideContact.from_params(params)
    load = guide.preload_per_ball_n if load_n is None else float(load_n)
    if not (math.isfinite(load) and load > 0):
        raise ValueError(f"contact load per ball must be a finite number > 0, got {load!r}")
    speed = float(speed_m_s)
    if not math.isfinite(speed):
        raise ValueError(f"speed must be finite, got {speed!r}")
    contact = guide.hertz(load)
    h_central, h_min = guide.film(load, speed, contact)
    mixed = guide.mixed(h_central, contact)
    sigma = guide.composite_rms_m
    lam = h_central / sigma
    regime = lubrication_regime(lam, guide.lambda_boundary, guide.lambda_full_film)
    return {
        "p_max_MPa": contact.p_max_pa * 1e-6,
        "semi_axis_a_mm": contact.semi_axis_x_m * 1e3,
        "semi_axis_b_mm": contact.semi_axis_y_m * 1e3,
        "film_central_nm": h_central * 1e9,
        "film_min_nm": h_min * 1e9,
        "lambda": lam,
        "lambda_min": h_min / sigma,
        "regime": regime,
        "contact_area_ratio": mixed.asperity_load_share,
        "asperity_load_share": mixed.asperity_load_share,
        "asperity_real_area_ratio": mixed.asperity_real_area_ratio,
        "mean_plane_separation_nm": mixed.separation_m * 1e9,
        "contact_load_n": load,
        "approach_um": contact.approach_m * 1e6,
        "entrainment_speed_m_s": entrainment_speed(speed),
        "carriage_speed_m_s": abs(speed),
        "ellipticity_k": contact.ellipticity_k,
        "mean_pressure_MPa": contact.mean_pressure_pa * 1e-6,
        "composite_roughness_nm": sigma * 1e9,
        "radius_x_mm": guide.radius_x_m * 1e3,
        "radius_y_mm": guide.radius_y_m * 1e3,
        "lambda_boundary": guide.lambda_boundary,
        "lambda_full_film": guide.lambda_full_film,
        "message": (f"{regime} lubrication: lambda {lam:.3g}, central film {h_central * 1e9:.1f} nm, "
                    f"p_max {contact.p_max_pa * 1e-6:.0f} MPa at {load:.0f} N per ball"),
    }


def speed_sweep(params: dict[str, Any], load_n: float | None, speeds_m_s: np.ndarray) -> dict[str, np.ndarray]:
    """Film, lambda and JGP shares over carriage speeds [m/s] at one ball load (for plots and checks)."""
    guide = RollingGuideContact.from_params(params)
    load = guide.preload_per_ball_n if load_n is None else float(load_n)
    contact = guide.hertz(load)
    out = {k: np.empty(len(speeds_m_s)) for k in ("film_central_m", "film_min_m", "lambda", "asperity_load_share",
                                                  "asperity_real_area_ratio", "separation_m")}
    for i, v in enumerate(np.asarray(speeds_m_s, dtype=float)):
        hc, hm = guide.film(load, v, contact)
        mixed = guide.mixed(hc, contact)
        out["film_central_m"][i], out["film_min_m"][i] = hc, hm
        out["lambda"][i] = hc / guide.composite_rms_m
        out["asperity_load_share"][i] = mixed.asperity_load_share
        out["asperity_real_area_ratio"][i] = mixed.asperity_real_area_ratio
        out["separation_m"][i] = mixed.separation_m
    out["speed_m_s"] = np.asarray(speeds_m_s, dtype=float)
    return out


class RegimeSample(NamedTuple):
    """Per-sample output of :class:`LubricationRegimeEstimator` (a NamedTuple: cheap to build)."""

    lambda_ratio: float
    regime: str
    asperity_load_share: float
    ball_load_n: float


class LubricationRegimeEstimator:
    """O(1) lambda / regime / asperity share from (carriage speed, carriage vertical load) for a live node.

    Set-up (once, ~0.4 s): Hertz geometry (the ellipticity does not depend on load), the film constant
    C in h_c = C u^0.67 w^-0.067 (Hamrock-Dowson is a pure power law at fixed geometry), a table of the
    dimensionless 4-row equilibrium F_u/F_0 vs F/(2 n sin(alpha) F_0), and a table of the JGP asperity share
    over (log lambda, log ball load). Per sample: a few float operations, two bisections and one bilinear
    interpolation (microseconds). ``carriage_load_n`` is the vertical load on the guide (compressive > 0),
    shared equally by ``carriages``; the most loaded ball row sets lambda.
    """

    _LAMBDA_LOG_GRID = np.linspace(-3.5, 1.0, 46)
    _LOAD_LOG_SPAN = (0.5, 5.0)       # ball loads 3.2 N .. 100 kN on the share table

    def __init__(self, params: dict[str, Any]) -> None:
        guide = RollingGuideContact.from_params(params)
        self.guide = guide
        self._preload = guide.preload_per_ball_n
        self._sin_alpha = math.sin(math.radians(guide.contact_angle_deg))
        self._load_scale = 1.0 / (guide.carriages * 2.0 * guide.balls_per_row * self._sin_alpha)
        reference = guide.hertz(1.0)
        h_ref, _ = hamrock_dowson_film(1.0, 1.0, guide.radius_x_m, reference.ellipticity_k,
                                       guide.reduced_modulus_pa, guide.viscosity_pa_s,
                                       guide.pressure_viscosity_pa_inv)
        self._lambda_coeff = h_ref / guide.composite_rms_m       # lambda = coeff u^0.67 w^-0.067
        self._lambda_boundary = guide.lambda_boundary
        self._lambda_full_film = guide.lambda_full_film
        # dimensionless equilibrium table q -> F_u/F_0 for q < 2^1.5 (x in [0, 1])
        x = np.linspace(0.0, 1.0, 401)
        self._q_table = ((1.0 + x) ** 1.5 - (1.0 - x) ** 1.5).tolist()
        self._fu_table = ((1.0 + x) ** 1.5).tolist()
        self._q_unloaded = 2.0 ** 1.5
        # asperity share table over (log10 lambda, log10 ball load)
        f52 = _f52_interpolator()
        log_w = np.linspace(self._LOAD_LOG_SPAN[0], self._LOAD_LOG_SPAN[1], 19)
        share = np.empty((len(self._LAMBDA_LOG_GRID), len(log_w)))
        for j, lw in enumerate(log_w):
            contact = guide.hertz(10.0 ** lw)
            for i, ll in enumerate(self._LAMBDA_LOG_GRID):
                share[i, j] = guide.mixed(10.0 ** ll * guide.composite_rms_m, contact, f52).asperity_load_share
        self._log_lambda_axis = self._LAMBDA_LOG_GRID.tolist()
        self._log_load_axis = log_w.tolist()
        self._share = share.tolist()

    def ball_load(self, carriage_load_n: float) -> float:
        """Highest ball load [N] under a vertical carriage load [N] (table of the 4-row equilibrium)."""
        per_row_pair = abs(carriage_load_n) * self._load_scale       # |F| / (2 n sin a) per carriage
        if self._preload <= 0.0:
            return per_row_pair
        q = per_row_pair / self._preload
        if q >= self._q_unloaded:
            return per_row_pair
        table = self._q_table
        i = bisect.bisect_right(table, q) - 1
        f = (q - table[i]) / (table[i + 1] - table[i])
        return self._preload * (self._fu_table[i] + f * (self._fu_table[i + 1] - self._fu_table[i]))

    def sample(self, carriage_speed_m_s: float, carriage_load_n: float) -> RegimeSample:
        """lambda, regime, asperity share and ball load for one (speed [m/s], load [N]) sample."""
        if not (_isfinite(carriage_speed_m_s) and _isfinite(carriage_load_n)):
            raise ValueError("speed and load must be finite")
        w = self.ball_load(carriage_load_n)
        if w <= 0.0:
            return RegimeSample(math.inf, "full_film", 0.0, 0.0)
        u = 0.5 * abs(carriage_speed_m_s)
        if u == 0.0:
            return RegimeSample(0.0, "boundary", 1.0, w)
        lam = self._lambda_coeff * u ** 0.67 * w ** -0.067        # Hamrock-Dowson central-film exponents
        if lam < self._lambda_boundary:
            regime = "boundary"
        elif lam >= self._lambda_full_film:
            regime = "full_film"
        else:
            regime = "mixed"
        return RegimeSample(lam, regime, self._share_at(_log10(lam), _log10(w)), w)

    def _share_at(self, log_lambda: float, log_load: float) -> float:
        ax, ay, table = self._log_lambda_axis, self._log_load_axis, self._share
        if log_lambda >= ax[-1]:
            log_lambda = ax[-1]
        if log_lambda <= ax[0]:
            log_lambda = ax[0]
        log_load = min(max(log_load, ay[0]), ay[-1])
        i = min(bisect.bisect_right(ax, log_lambda) - 1, len(ax) - 2)
        j = min(bisect.bisect_right(ay, log_load) - 1, len(ay) - 2)
        fx = (log_lambda - ax[i]) / (ax[i + 1] - ax[i])
        fy = (log_load - ay[j]) / (ay[j + 1] - ay[j])
        r0, r1 = table[i], table[i + 1]
        return ((1 - fx) * ((1 - fy) * r0[j] + fy * r0[j + 1])
                + fx * ((1 - fy) * r1[j] + fy * r1[j + 1]))


def _f52_interpolator() -> Callable[[float], float]:
    """Fast F_5/2(t): log F on a 0.001-step grid over t in [-12, 12] (from a cubic spline through 1201 quad
    values), linear interpolation in pure Python (relative error < 1e-6); quad outside the grid."""
    from scipy.interpolate import CubicSpline

    t_lo, t_hi, step = -12.0, 12.0, 0.001
    knots = np.linspace(t_lo, t_hi, 1201)
    spline = CubicSpline(knots, np.log([greenwood_tripp_integral(2.5, t) for t in knots]))
    log_table = spline(np.linspace(t_lo, t_hi, int(round((t_hi - t_lo) / step)) + 1)).tolist()
    last = len(log_table) - 2
    exp = math.exp

    def f52(t: float) -> float:
        if not t_lo <= t <= t_hi:
            return greenwood_tripp_integral(2.5, t)
        position = (t - t_lo) / step
        i = min(int(position), last)
        frac = position - i
        return exp(log_table[i] + frac * (log_table[i + 1] - log_table[i]))

    return f52
