"""Load distribution over the four ball rows of a linear rolling-guide carriage under preload and a vertical
load (seed 001 Eq. 1 / its ref. 11, Tian et al. 2016).

Pure physics: scipy only, SI units (m, N). Seed 001 (NSK LH45 guide; the reference: docs/physics.md#the-seeds).

Load distribution (what is solved)
----------------------------------
The seed's Eq. 1 (garbled in the text layer) is the per-contact Hertz law F = H delta^1.5 with the four rows at
contact angle alpha measured from the horizontal, vertical components F_i sin(alpha); rows 1, 2 (upper, load
F_u, the "working load") carry a downward (compressive) carriage load, rows 3, 4 (lower, F_L) carry lift-off.
The preload figures 385/635/1042/1450 N are PER BALL CONTACT: the seed says that without external load "the
preload is the force between the ball and the raceway" and Table 1's Hertz pressures follow from them as
single-contact loads (checked in :mod:`.ball_contact`). With a rigid carriage and rail, n balls per row sharing
equally, no moment, a vertical carriage displacement y (towards the rail) changes the normal approach of every
ball of the upper rows by +y sin(alpha) and of the lower rows by -y sin(alpha):

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
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from guide_health.models.contact.hertz_point import hertz_point_contact
from guide_health.models.lazy_scipy import brentq


def ball_stiffness_n_per_m15(radius_x_m: float, radius_y_m: float, effective_modulus_pa: float) -> float:
    """K_b in F = K_b Delta^1.5 [N/m^1.5] for one ball between carriage and rail grooves (seed 001 Eq. 1).

    Two identical Hertz contacts in series: Delta = 2 delta_contact, delta_contact = c F^(2/3) (exact Hertz).
    """
    reference = hertz_point_contact(1.0, radius_x_m, radius_y_m, effective_modulus_pa)  # delta at 1 N = c
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


def equivalent_fatigue_load_n(distribution: CarriageLoadDistribution,
                              reverse_load_rating_factor: float = 1.0) -> float:
    """Carriage load for the rating life of a preloaded 4-row carriage [N].

    The catalogue rating (C/P)^p assumes the load is shared by the loaded rows without preload, i.e. the most
    loaded ball carries P / (2 n sin alpha). Under preload the internal ball loads of the equilibrium above
    are higher (385 N per ball, 2 kN on the carriage: the upper balls carry 452 N, not 131 N), so the load
    that gives the most loaded ball its real load is

        P_fatigue = 2 n sin(alpha) x max(F_u, F_L)  /  f_dir

    f_dir = 1 for a downward load (force.z >= 0, upper rows), ``reverse_load_rating_factor`` = C_reverse / C
    for a reverse (lift-off) load carried by the lower rows. Without preload P_fatigue = |F| / f_dir; from
    F = 2^2.5 n sin(alpha) F_0 (16.7 kN for 385 N) on, the unloaded rows make it |F| / f_dir for every
    preload. This is the catalogues' preloaded-carriage correction (THK's approximation
    P_E = P_pr (1 + F / (2^1.5 P_pr))^1.5 with P_pr = 2 n sin(alpha) F_0 is the same at F = 0 and at the
    relief point), computed with the exact equilibrium.
    """
    if not (math.isfinite(reverse_load_rating_factor) and reverse_load_rating_factor > 0):
        raise ValueError(f"reverse_load_rating_factor must be > 0, got {reverse_load_rating_factor!r}")
    rows_pair = 2.0 * distribution.balls_per_row * math.sin(distribution.contact_angle_rad)
    p = rows_pair * distribution.max_ball_load_n
    return p if distribution.external_load_n >= 0 else p / reverse_load_rating_factor
