"""Basic dynamic load rating C of a linear ball guide from its geometry (Lundberg-Palmgren, the theory ISO 14728-1
rates linear bearings by), so that a catalogue C can be checked.

Seed 004 (Sec. 1.1) quotes ISO 14728-1 Sec. 5.1.3 for the rating of a linear ball guide from Z_t (balls in the
effective contact length), D_w (ball diameter), r_g (groove radius), i (rows), l_t (effective raceway length) and
alpha (contact angle), with b_m = 1.3 and lambda = 0.9 "both maximum values; makers choose smaller ones" (a 0.7-0.9
spread of lambda alone is 20 %). The formula itself is lost in the seed's text, so it is DERIVED here from the
same theory, with ISO 281's constant:

* A ring raceway (Harris, Rolling Bearing Analysis, Lundberg-Palmgren with ISO 281's A = 98.1 N/mm^1.8), in the
  limit of a straight raceway (gamma = D_w cos(alpha)/d_m -> 0, curvature factors (1 -+ gamma) -> 1):
  Q_c = 98.1 lambda (2f/(2f - 1))^0.41 (D_w/d_m)^0.3 D_w^1.8 Z^(-1/3) for 10^6 revolutions, Z/2 ball passes per
  raceway point per revolution, raceway length pi d_m.
* Lundberg-Palmgren at equal contact stress: the number of passes at 90 % survival scales as (raceway length)^(-1/e),
  e = 10/9 (point contact), and as Q^-3.
* The carriage raceway of a guide (length l_t, Z_t balls in it) sees Z_t/l_t ball passes per unit ball travel and
  the balls travel half the carriage travel, so over a carriage travel L: N = (L/2) Z_t/l_t. Putting the two
  together (Z and d_m cancel):  Q_c,lin = 98.1 lambda (2f/(2f - 1))^0.41 D_w^2.1 (1e6 pi^0.9 l_t^0.1/(Z_t L))^(1/3)
  [N, mm], for one raceway; the ball's two contacts (rail and carriage, same conformity) in series by
  Lundberg-Palmgren's L^-e sum: x 2^(-0.3).
* Carriage C (load through the carriage centre, downward, four-row LH type, seed 001 geometry): the two upper rows
  carry it at alpha from the horizontal, C = b_m x 2 Z_t Q_c,ball sin(alpha); b_m = 1.3 (ISO's material and
  manufacturing factor for contemporary bearing steel). The rail raceway (each point over-rolled only while the
  carriage passes) is not the limit and is left out.

Worked example (the seed 001 NSK LH45 geometry, D_w = 7.937 mm, f = 0.52, Z_t = 10, l_t = Z_t D_w, alpha = 50 deg,
L = 50 km): C = 86.5 kN, against the ~80 kN of config/nsk_lh45.yaml's catalogue-like figure; with lambda = 0.7
instead of 0.9: 67.3 kN. A derivation, not a transcription of the standard: treat a few % as its accuracy and the
lambda band (0.7-0.9) as the real uncertainty, as the seed does.

Pure physics: SI at the boundary (m, N, km for the rating distance).
"""
from __future__ import annotations

import math

ISO281_CONSTANT_N_PER_MM18 = 98.1   # Lundberg-Palmgren's A in ISO 281 units (N, mm)
B_M = 1.3                           # ISO 14728-1 b_m as seed 004 quotes it
LAMBDA_REDUCTION = 0.9              # ISO 14728-1 lambda as seed 004 quotes it (0.7-0.9 in practice)
LP_EXPONENT_E = 10.0 / 9.0          # Lundberg-Palmgren Weibull slope e for point contact
_MM_PER_KM = 1.0e6


def raceway_ball_capacity_n(ball_diameter_m: float, groove_conformity: float, balls_in_row: int,
                            raceway_length_m: float, rating_distance_km: float,
                            lam: float = LAMBDA_REDUCTION) -> float:
    """Q_c [N]: the ball load one straight raceway carries for ``rating_distance_km`` of carriage travel at 90 %
    survival (Lundberg-Palmgren, module doc): 98.1 lambda (2f/(2f-1))^0.41 D^2.1 (1e6 pi^0.9 l^0.1/(Z L))^(1/3)."""
    d_mm = 1e3 * float(ball_diameter_m)
    l_mm = 1e3 * float(raceway_length_m)
    travel_mm = _MM_PER_KM * float(rating_distance_km)
    for name, value in (("ball diameter", d_mm), ("raceway length", l_mm), ("rating distance", travel_mm),
                        ("lambda", lam)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    if not groove_conformity > 0.5:
        raise ValueError(f"groove conformity must be > 0.5, got {groove_conformity!r}")
    if int(balls_in_row) < 1:
        raise ValueError(f"balls in a row must be >= 1, got {balls_in_row!r}")
    f = float(groove_conformity)
    conformity_term = (2.0 * f / (2.0 * f - 1.0)) ** 0.41
    cycles = 1e6 * math.pi ** (1.0 / LP_EXPONENT_E) * l_mm ** (1.0 - 1.0 / LP_EXPONENT_E) / (int(balls_in_row)
                                                                                            * travel_mm)
    return ISO281_CONSTANT_N_PER_MM18 * lam * conformity_term * d_mm ** 2.1 * cycles ** (1.0 / 3.0)


def ball_guide_dynamic_rating_n(ball_diameter_m: float, groove_conformity: float, contact_angle_deg: float,
                                balls_per_row: int, rating_distance_km: float = 50.0,
                                raceway_length_m: float | None = None, b_m: float = B_M,
                                lam: float = LAMBDA_REDUCTION) -> float:
    """Basic dynamic load rating C [N] of a four-row (LH-type) ball carriage for a downward load from its geometry
    (module doc): b_m 2 Z_t Q_c 2^-0.3 sin(alpha); ``raceway_length_m`` default Z_t D_w (balls touching)."""
    if not 0.0 < contact_angle_deg < 90.0:
        raise ValueError(f"contact angle must be in (0, 90) deg, got {contact_angle_deg!r}")
    length = balls_per_row * ball_diameter_m if raceway_length_m is None else raceway_length_m
    q_c = raceway_ball_capacity_n(ball_diameter_m, groove_conformity, balls_per_row, length, rating_distance_km,
                                  lam)
    q_ball = q_c * 2.0 ** (-1.0 / (3.0 * LP_EXPONENT_E))      # rail and carriage contacts in series
    return b_m * 2.0 * balls_per_row * q_ball * math.sin(math.radians(contact_angle_deg))
