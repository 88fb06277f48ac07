"""Ball/groove contact of the NSK LH45 rolling guide (seed 001): Hertz, load distribution, film, regime, CLI.

Reference numbers are copied from seed 001 (Wang et al., J. Vibration and Shock 39(9) 2020) so that the
tests never read shared files at run time.
"""
from __future__ import annotations

import json
import math
import timeit
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from guide_health import cli
from guide_health.models.contact import hertz_point
from guide_health.models.rolling import ball_contact as bc
from guide_health.models.rolling import carriage, lubrication
from guide_health.params import WEAR_MONITOR_DEFAULTS
from guide_health.params.typed import guide_params

REPO = Path(__file__).resolve().parents[1]
CONFIG = REPO / "config" / "nsk_lh45.yaml"

# --- seed 001 geometry and results ---
BALL_RADIUS_M = 3.9685e-3
CONFORMITY = 0.52
CONTACT_ANGLE_DEG = 50.0
BALLS_PER_ROW = 10
E_PA = 206.0e9
NU = 0.3
SIGMA_M = 0.2e-6
# Table 1 (no external load: contact load = preload): preload [N], mean film [nm], p_Hertz [GPa], a [mm]
TABLE1 = [(385.0, 294.3, 1.680, 0.116), (635.0, 181.5, 1.984, 0.137),
          (1042.0, 167.6, 2.340, 0.162), (1450.0, 157.2, 2.613, 0.180)]
# Fig. 10 (385 N): conformity, mean film [nm], lambda
CONFORMITY_ROWS = [(0.515, 294.3, 1.18), (0.6, 232.0, 0.925), (0.8, 203.0, 0.82)]
# Fig. 8/9 (385 N, Gf 0.52, RMS 0.2 um): regime speeds [m/s]
BOUNDARY_BELOW_M_S = 0.0005         # Fig. 8 text: boundary below 0.0005 m/s (Fig. 9's 0.005 contradicts 73.76 %)
AREA_RATIO_AT_1MM_S = 0.7376        # Fig. 8 text: contact-area ratio 73.76 % at 0.001 m/s
CONTACT_NEAR_ZERO_AT_M_S = 1.0      # contact-area ratio 0.05 %
LAMBDA_BELOW_0P4_FOR_SPEED_BELOW = 0.1
LAMBDA_NEAR_1_AT_M_S = 0.5
SPEED_FACTOR = 3.0                  # tolerance on regime boundaries (brief)

# seed 000's 68# oil (65.4 / 8.83 cSt at 40 / 100 degC, rho_15 880 kg/m^3) at 21 degC by ASTM D341, computed by
# hand: log10 log10(nu + 0.7) line through (313.15 K, 65.4) and (373.15 K, 8.83) -> 186.07 cSt x 876.6 kg/m^3
SEED001_OIL_PA_S = 0.16311
E_PRIME = E_PA / (1.0 - NU ** 2)      # Hamrock's reduced modulus E' (the published formulas below)
E_STAR = E_PRIME / 2                  # contact modulus E* = E'/2, the models' elastic constant


def seed_values(**overrides) -> dict:
    p = dict(WEAR_MONITOR_DEFAULTS)
    p.update(guide_type="rolling", ball_radius_m=BALL_RADIUS_M, groove_conformity=CONFORMITY,
             contact_angle_deg=CONTACT_ANGLE_DEG, balls_per_row=BALLS_PER_ROW, rows=4, preload_n=385.0,
             youngs_modulus_pa=E_PA, poisson=NU, roughness_rms_m=SIGMA_M,
             oil_viscosity_pa_s=SEED001_OIL_PA_S, pressure_viscosity_pa_inv=2.0e-8)
    p.update(overrides)
    return p


def seed_params(**overrides):
    """The seed 001 NSK LH45 guide as the models take it (GuideParams)."""
    return guide_params(seed_values(**overrides))


def radii(conformity: float = CONFORMITY) -> tuple[float, float]:
    return bc.groove_contact_radii(BALL_RADIUS_M, conformity)


def crossing_speed(func, target: float, lo: float = 1e-5, hi: float = 30.0) -> float:
    """Carriage speed at which func(speed) crosses target (log-bracketed brentq)."""
    return 10.0 ** brentq(lambda lv: func(10.0 ** lv) - target, math.log10(lo), math.log10(hi), xtol=1e-10)


# ------------------------------------------------------------------------------------------------ Hertz

def test_groove_radii():
    r_x, r_y = radii()
    assert r_x == pytest.approx(3.9685e-3, rel=1e-12)
    assert r_y == pytest.approx(103.18e-3, rel=2e-4)     # 1/(1/r - 1/(2 f r))


@pytest.mark.parametrize("load_n, _film, p_gpa, a_mm", TABLE1)
def test_table1_hertz_within_half_percent(load_n, _film, p_gpa, a_mm):
    r_x, r_y = radii()
    c = hertz_point.hertz_point_contact(load_n, r_x, r_y, E_STAR)
    assert c.p_max_pa / 1e9 == pytest.approx(p_gpa, rel=5e-3)
    assert c.semi_axis_x_m * 1e3 == pytest.approx(a_mm, rel=5e-3)      # rolling direction = minor axis
    assert c.semi_axis_y_m > 5 * c.semi_axis_x_m


def test_circular_limit_is_closed_form_hertz():
    radius, load, e_star = 5e-3, 1000.0, E_PRIME / 2
    c = hertz_point.hertz_point_contact(load, radius, radius, E_STAR)
    a = (3 * load * radius / (4 * e_star)) ** (1 / 3)
    assert c.semi_axis_x_m == pytest.approx(a, rel=1e-12)
    assert c.semi_axis_y_m == pytest.approx(a, rel=1e-12)
    assert c.p_max_pa == pytest.approx(3 * load / (2 * math.pi * a * a), rel=1e-12)
    assert c.approach_m == pytest.approx(a * a / radius, rel=1e-12)
    # the elliptic-integral branch (and its near-circular series) converges to the same closed form (kappa -> 1)
    for excess in (1e-9, 1e-6, 2e-5, 1e-3):
        near = hertz_point.hertz_point_contact(load, radius, radius * (1 + excess), E_STAR)
        assert near.axis_ratio - 1.0 == pytest.approx(2.0 * excess / 3.0, rel=2 * excess + 1e-6)
        for got, want in ((near.semi_axis_x_m, a), (near.semi_axis_y_m, a), (near.p_max_pa, c.p_max_pa),
                          (near.approach_m, c.approach_m)):
            assert got == pytest.approx(want, rel=excess)


@pytest.mark.parametrize("ratio", [1.5, 4.0, 10.0, 26.0])
def test_exact_hertz_against_hamrock_brewe(ratio):
    """Hamrock-Brewe (1983) curve fits, independent of the elliptic-integral solver, agree within ~3 %.

    (Their k fit drifts to -5 % by R_y/R_x = 80, so the check stops at the guide's 26.)"""
    r_x = 4e-3
    r_y = ratio * r_x
    load = 500.0
    c = hertz_point.hertz_point_contact(load, r_x, r_y, E_STAR)
    k_hb = 1.0339 * ratio ** 0.636
    e_hb = 1.0003 + 0.5968 / ratio
    f_hb = 1.5277 + 0.6023 * math.log(ratio)
    r_eq = 1 / (1 / r_x + 1 / r_y)
    b_hb = (6 * e_hb * k_hb ** 2 * load * r_eq / (math.pi * E_PRIME)) ** (1 / 3)   # across (y)
    a_hb = (6 * e_hb * load * r_eq / (math.pi * k_hb * E_PRIME)) ** (1 / 3)        # along x
    delta_hb = f_hb * ((9 / (2 * e_hb * r_eq)) * (load / (math.pi * k_hb * E_PRIME)) ** 2) ** (1 / 3)
    assert c.ellipticity_k == pytest.approx(k_hb, rel=0.03)
    assert c.elliptic_e == pytest.approx(e_hb, rel=0.01)
    assert c.semi_axis_x_m == pytest.approx(a_hb, rel=0.02)
    assert c.semi_axis_y_m == pytest.approx(b_hb, rel=0.02)
    assert c.approach_m == pytest.approx(delta_hb, rel=0.03)
    # swapping the radii swaps the axes
    swapped = hertz_point.hertz_point_contact(load, r_y, r_x, E_STAR)
    assert swapped.semi_axis_x_m == pytest.approx(c.semi_axis_y_m, rel=1e-12)
    assert swapped.semi_axis_y_m == pytest.approx(c.semi_axis_x_m, rel=1e-12)


def test_hertz_load_scaling():
    r_x, r_y = radii()
    c1 = hertz_point.hertz_point_contact(385.0, r_x, r_y, E_STAR)
    c8 = hertz_point.hertz_point_contact(8 * 385.0, r_x, r_y, E_STAR)
    assert c8.semi_axis_x_m / c1.semi_axis_x_m == pytest.approx(2.0, rel=1e-10)
    assert c8.p_max_pa / c1.p_max_pa == pytest.approx(2.0, rel=1e-10)
    assert c8.approach_m / c1.approach_m == pytest.approx(4.0, rel=1e-10)
    assert c8.axis_ratio == pytest.approx(c1.axis_ratio, rel=1e-12)


# --------------------------------------------------------------------------------- load distribution

def stiffness() -> float:
    return carriage.ball_stiffness_n_per_m15(*radii(), E_STAR)


def test_ball_stiffness_is_two_hertz_contacts_in_series():
    k_b = stiffness()
    c = hertz_point.hertz_point_contact(385.0, *radii(), E_STAR)
    assert k_b * (2 * c.approach_m) ** 1.5 == pytest.approx(385.0, rel=1e-10)


@pytest.mark.parametrize("preload", [385.0, 635.0, 1042.0, 1450.0])
@pytest.mark.parametrize("load", [-20000.0, -3000.0, 0.0, 500.0, 5000.0, 16000.0, 40000.0])
def test_load_distribution_equilibrium(preload, load):
    d = carriage.carriage_load_distribution(load, preload, CONTACT_ANGLE_DEG, BALLS_PER_ROW, stiffness())
    sin_a = math.sin(math.radians(CONTACT_ANGLE_DEG))
    vertical = sum(f * s for f, s in zip(d.row_ball_loads_n, (1, 1, -1, -1))) * BALLS_PER_ROW * sin_a
    assert vertical == pytest.approx(load, abs=1e-6 * max(1.0, abs(load)))
    assert min(d.row_ball_loads_n) >= 0.0                      # no tension
    if load == 0.0:
        assert d.upper_ball_load_n == pytest.approx(preload, rel=1e-12)
        assert d.lower_ball_load_n == pytest.approx(preload, rel=1e-12)
    lift_off = 2 ** 2.5 * BALLS_PER_ROW * sin_a * preload      # lower rows unload (x = 1)
    if load > lift_off:
        assert d.lower_ball_load_n == 0.0
        assert d.upper_ball_load_n == pytest.approx(load / (2 * BALLS_PER_ROW * sin_a), rel=1e-9)
    if load < -lift_off:
        assert d.upper_ball_load_n == 0.0
    q = abs(load) / (2 * BALLS_PER_ROW * sin_a * preload)
    assert d.max_ball_load_n == pytest.approx(preload * carriage.upper_ball_load_ratio(q), rel=1e-9)


def test_fig4_working_load_rises_with_load_and_preload():
    loads = np.linspace(0.0, 30000.0, 61)
    preloads = [385.0, 635.0, 1042.0, 1450.0]
    k_b = stiffness()
    fu = np.array([[carriage.carriage_load_distribution(f, p, CONTACT_ANGLE_DEG, BALLS_PER_ROW, k_b).upper_ball_load_n
                    for f in loads] for p in preloads])
    assert np.all(np.diff(fu, axis=1) > 0)                     # F_u rises with F
    assert np.all(np.diff(fu, axis=0) >= -1e-9)                # never falls with preload
    # lower rows lift off (F_L = 0) at y sin a = Delta_0, where F_u = K_b (2 Delta_0)^1.5 = 2^1.5 F_0 and
    # F = 2 n sin a 2^1.5 F_0 = 16.68 kN at 385 N; found here from the model itself by bisection on F_L
    first_lift_off = 2 ** 2.5 * BALLS_PER_ROW * math.sin(math.radians(CONTACT_ANGLE_DEG)) * preloads[0]
    model_lift_off = brentq(lambda f: carriage.carriage_load_distribution(
        f, preloads[0], CONTACT_ANGLE_DEG, BALLS_PER_ROW, k_b).lower_ball_load_n - 1e-6 * preloads[0], 1.0, 40e3)
    assert model_lift_off == pytest.approx(first_lift_off, rel=1e-3)
    below = loads < first_lift_off
    assert np.all(np.diff(fu[:, below], axis=0) > 0)           # strictly, while all rows are loaded


# ------------------------------------------------------------------------------------- film and lambda

def test_greenwood_tripp_integrals():
    for t in (-3.0, -0.5, 0.0, 0.7, 2.5):
        assert lubrication.greenwood_tripp_integral(2.0, t) == pytest.approx(lubrication.greenwood_tripp_f2(t),
                                                                             rel=1e-8)
        assert lubrication.greenwood_tripp_integral(0.0, t) == pytest.approx(0.5 * math.erfc(t / math.sqrt(2)),
                                                                             rel=1e-8)
    # at t = 0 the integral has the closed form F_n(0) = 2^((n-1)/2) Gamma((n+1)/2) / sqrt(2 pi);
    # F_5/2(0) = 0.6166 is the Greenwood-Tripp value the contact load uses
    for n in (0.0, 1.0, 1.5, 2.0, 2.5):
        closed = 2 ** ((n - 1) / 2) * math.gamma((n + 1) / 2) / math.sqrt(2 * math.pi)
        assert lubrication.greenwood_tripp_integral(n, 0.0) == pytest.approx(closed, rel=1e-8), n
    assert 2 ** 0.75 * math.gamma(1.75) / math.sqrt(2 * math.pi) == pytest.approx(0.6166, abs=5e-5)


def test_entrainment_speed_is_half_the_carriage_speed():
    assert lubrication.entrainment_speed(0.4) == pytest.approx(0.2)
    assert lubrication.entrainment_speed(-0.4) == pytest.approx(0.2)
    r = bc.rolling_contact_report(seed_params(), None, 0.4)
    assert r["entrainment_speed_m_s"] == pytest.approx(0.2)


def test_film_speed_exponents():
    p = seed_params()
    r1 = bc.rolling_contact_report(p, None, 0.1)
    r2 = bc.rolling_contact_report(p, None, 1.0)
    assert r2["film_central_nm"] / r1["film_central_nm"] == pytest.approx(10 ** 0.67, rel=1e-9)
    assert r2["film_min_nm"] / r1["film_min_nm"] == pytest.approx(10 ** 0.68, rel=1e-9)


def independent_hamrock_dowson_nm(load_n: float, carriage_speed_m_s: float) -> tuple[float, float]:
    """Hamrock & Dowson (1977) central and minimum film [nm] of the seed's ball/groove contact, from the raw
    geometry: R_x = ball radius (straight groove along the rolling direction), 1/R_y = 1/R_ball - 1/R_groove
    (R_groove = Gf D), k from Hamrock-Brewe k = 1.0339 (R_y/R_x)^0.636, E' = E/(1 - nu^2) (equal materials),
    u = v/2; seed 000's 68# oil at 21 degC (0.16311 Pa s, 2.0e-8 1/Pa, docs/physics.md)."""
    r_x = BALL_RADIUS_M
    r_y = 1.0 / (1.0 / BALL_RADIUS_M - 1.0 / (CONFORMITY * 2 * BALL_RADIUS_M))
    k = 1.0339 * (r_y / r_x) ** 0.636
    u_dim = SEED001_OIL_PA_S * (carriage_speed_m_s / 2) / (E_PRIME * r_x)
    g_dim = 2.0e-8 * E_PRIME
    w_dim = load_n / (E_PRIME * r_x ** 2)
    h_c = 2.69 * u_dim ** 0.67 * g_dim ** 0.53 * w_dim ** -0.067 * (1 - 0.61 * math.exp(-0.73 * k)) * r_x
    h_min = 3.63 * u_dim ** 0.68 * g_dim ** 0.49 * w_dim ** -0.073 * (1 - math.exp(-0.68 * k)) * r_x
    return h_c * 1e9, h_min * 1e9


@pytest.mark.parametrize("speed", [0.005, 0.1, 0.5, 1.0])
@pytest.mark.parametrize("load_n", [385.0, 1450.0])
def test_absolute_film_and_lambda_against_an_independent_hamrock_dowson(speed, load_n):
    """Absolute film and lambda (central film / 0.2 um) vs the formula written here. Catches a factor of 2
    in E' or u (-> 37 % / 59 %), an exponent off by 0.01 (U ~ 1e-11: -> 25 %), a wrong R_x/R_y."""
    r = bc.rolling_contact_report(seed_params(), load_n, speed)
    h_c, h_min = independent_hamrock_dowson_nm(r["contact_load_n"], speed)
    assert r["contact_load_n"] == pytest.approx(load_n, rel=1e-9)        # no external load given: the preload
    assert r["film_central_nm"] == pytest.approx(h_c, rel=0.005)     # Hamrock-Brewe k: (1 - e^(-0.7 k)) ~ 0.997
    assert r["film_min_nm"] == pytest.approx(h_min, rel=0.005)
    assert r["lambda"] == pytest.approx(h_c * 1e-9 / SIGMA_M, rel=0.005)


def test_table1_film_needs_a_faster_smooth_film():
    """Seed 001 Table 1's mean film (294.3 nm at 385 N, rough-surface numerical model, speed not printed)
    is reached by the smooth central film at v = 0.88 m/s with seed 000's 68# oil at 21 degC (with VG68 at
    40 degC, 0.060 Pa s, it needed 2.4 m/s: v scales as 1/eta_0; Fig. 9 puts Table 1 near 0.9-1 m/s); the seed's
    fall with preload (294.3 -> 157.2 nm, -47 %) is far stronger than the EHL W^-0.067 (-8.5 %)."""
    v = crossing_speed(lambda s: independent_hamrock_dowson_nm(385.0, s)[0], TABLE1[0][1])
    model_v = crossing_speed(lambda s: bc.rolling_contact_report(seed_params(), 385.0, s)["film_central_nm"],
                             TABLE1[0][1])
    assert model_v == pytest.approx(v, rel=0.01)
    assert v == pytest.approx(2.4 * 0.060 / SEED001_OIL_PA_S, rel=0.02)
    assert v == pytest.approx(0.88, rel=0.02)
    assert TABLE1[-1][1] / TABLE1[0][1] == pytest.approx(0.534, abs=1e-3)
    assert (1450 / 385) ** -0.067 == pytest.approx(0.915, abs=1e-3)


@pytest.mark.parametrize("speed", [0.01, 0.5, 2.0])
def test_film_falls_with_load_like_table1(speed):
    p = seed_params()
    reports = [bc.rolling_contact_report(p, row[0], speed) for row in TABLE1]
    central = [r["film_central_nm"] for r in reports]
    minimum = [r["film_min_nm"] for r in reports]
    seed = [row[1] for row in TABLE1]
    assert all(np.diff(central) < 0) and all(np.diff(minimum) < 0) and all(np.diff(seed) < 0)
    # EHL load exponent -0.067: the fall is weak (the seed's rough-surface film falls 47 %)
    assert central[-1] / central[0] == pytest.approx((1450 / 385) ** -0.067, rel=1e-9)


@pytest.mark.parametrize("speed", [0.01, 0.5, 2.0])
def test_film_falls_with_conformity_like_fig10(speed):
    films = [bc.rolling_contact_report(seed_params(groove_conformity=f), None, speed) for f, _, _ in CONFORMITY_ROWS]
    central = [r["film_central_nm"] for r in films]
    minimum = [r["film_min_nm"] for r in films]
    lam = [r["lambda"] for r in films]
    seed_film = [row[1] for row in CONFORMITY_ROWS]
    seed_lambda = [row[2] for row in CONFORMITY_ROWS]
    for series in (central, minimum, lam, seed_film, seed_lambda):
        assert all(np.diff(series) < 0)
    # same direction as the seed; magnitude (0.515 -> 0.8): seed -31 %, Hamrock-Dowson h_min -27 %, h_c -15 %
    assert 0.6 < minimum[-1] / minimum[0] < 0.85
    assert 0.8 < central[-1] / central[0] < 0.95


def speed_functions(params=None):
    guide = bc.RollingGuideContact.from_params(params or seed_params())
    contact = guide.hertz(guide.preload_per_ball_n)

    def lam(v):
        return guide.film(contact.load_n, v, contact)[0] / guide.composite_rms_m

    def area_ratio(v):
        return guide.mixed(guide.film(contact.load_n, v, contact)[0], contact).asperity_load_share

    return lam, area_ratio


def test_contact_area_ratio_at_1_mm_s_matches_fig8_and_cannot_reach_80_percent():
    """Seed Fig. 8: A_c = 73.76 % at 0.001 m/s (calibrated by asperity_density_per_m2). JGP-GT's share is a
    one-parameter family: with that point matched it tends to 76.2 % at v -> 0 and never reaches the seed's
    80 % (issue 11 item 5, shown numerically: 74.7 % at 0.0005 m/s)."""
    _, area_ratio = speed_functions()
    assert area_ratio(0.001) == pytest.approx(AREA_RATIO_AT_1MM_S, abs=0.002)
    assert area_ratio(BOUNDARY_BELOW_M_S) == pytest.approx(0.7466, abs=0.002)
    assert area_ratio(1e-7) == pytest.approx(0.762, abs=0.002) and area_ratio(1e-7) < 0.8


def test_contact_area_ratio_falls_to_about_zero_near_1_m_s():
    """Seed: A_c falls to ~0 (0.05 %) at 1 m/s. JGP-GT is broader: '~0' taken as < 5 % within a factor 3."""
    _, area_ratio = speed_functions()
    speeds = np.logspace(-3, math.log10(3.0), 25)
    ratios = np.array([area_ratio(v) for v in speeds])
    assert np.all(np.diff(ratios) < 0)
    v5 = crossing_speed(area_ratio, 0.05, lo=0.01, hi=30.0)
    assert CONTACT_NEAR_ZERO_AT_M_S / SPEED_FACTOR <= v5 <= CONTACT_NEAR_ZERO_AT_M_S * SPEED_FACTOR


def test_lambda_below_0p4_below_0p1_m_s_and_near_1_at_0p5_m_s():
    lam, _ = speed_functions()
    assert all(lam(v) < 0.4 for v in np.logspace(-3, math.log10(LAMBDA_BELOW_0P4_FOR_SPEED_BELOW), 20))
    v1 = crossing_speed(lam, 1.0)
    assert LAMBDA_NEAR_1_AT_M_S / SPEED_FACTOR <= v1 <= LAMBDA_NEAR_1_AT_M_S * SPEED_FACTOR


def test_regimes_vs_speed():
    p = seed_params()
    regimes = {v: bc.rolling_contact_report(p, None, v)["regime"]
               for v in (0.0, 0.0001, 0.00045, 0.00055, 0.001, 0.1, 0.5, 1.0, 20.0)}
    assert regimes[0.0] == regimes[0.0001] == regimes[0.00045] == "boundary"
    assert regimes[0.00055] == regimes[0.001] == regimes[0.1] == regimes[0.5] == regimes[1.0] == "mixed"  # seed
    assert regimes[20.0] == "full_film"
    lam, _ = speed_functions()
    v_boundary = crossing_speed(lam, lubrication.LAMBDA_BOUNDARY, lo=1e-6, hi=1.0)
    assert v_boundary == pytest.approx(BOUNDARY_BELOW_M_S, rel=0.05)     # Fig. 8: boundary below 0.0005 m/s


# -------------------------------------------------------------------------------------- live estimator

def test_live_estimator_matches_direct_model_and_is_cheap():
    p = seed_params()
    est = bc.LubricationRegimeEstimator(p)
    guide = bc.RollingGuideContact.from_params(p)
    for speed, carriage_load in [(0.003, 0.0), (0.05, 2500.0), (0.4, 9000.0), (1.2, -4000.0), (0.2, 30000.0)]:
        s = est.sample(speed, carriage_load)
        ball = guide.load_distribution(carriage_load).max_ball_load_n
        direct = bc.rolling_contact_report(p, ball, speed)
        assert s.ball_load_n == pytest.approx(ball, rel=1e-4)
        assert s.lambda_ratio == pytest.approx(direct["lambda"], rel=1e-4)
        assert s.regime == direct["regime"]
        assert s.asperity_load_share == pytest.approx(direct["asperity_load_share"], abs=5e-3)
    assert est.sample(0.0, 100.0).regime == "boundary"
    with pytest.raises(ValueError):
        est.sample(float("nan"), 0.0)
    n = 2000
    per_sample = min(timeit.repeat(lambda: est.sample(0.1, 6000.0), number=n, repeat=3)) / n
    per_report = min(timeit.repeat(lambda: bc.rolling_contact_report(p, 597.7, 0.1), number=5, repeat=3)) / 5
    assert per_sample * 20 < per_report


# ------------------------------------------------------------------------------------------------- CLI

JSON_KEYS = ("p_max_MPa", "semi_axis_a_mm", "semi_axis_b_mm", "film_central_nm", "film_min_nm", "lambda", "regime",
             "contact_area_ratio", "asperity_load_share", "contact_load_n", "approach_um", "entrainment_speed_m_s")


def test_cli_json_keys(capsys):
    assert cli.main(["contact", "rolling", "--params", str(CONFIG), "--speed", "0.5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in JSON_KEYS:
        assert key in out
    assert out["regime"] in ("boundary", "mixed", "full_film")
    assert out["contact_load_n"] == pytest.approx(385.0)
    assert out["p_max_MPa"] == pytest.approx(1680.0, rel=5e-3)
    assert out["semi_axis_a_mm"] == pytest.approx(0.116, rel=5e-3)
    assert out["entrainment_speed_m_s"] == pytest.approx(0.25)
    assert cli.main(["contact", "rolling", "--params", str(CONFIG), "--load-n", "1450", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["p_max_MPa"] == pytest.approx(2613.0, rel=5e-3)


def test_cli_plot(tmp_path, capsys):
    png = tmp_path / "rolling.png"
    assert cli.main(["contact", "rolling", "--params", str(CONFIG), "--plot", str(png)]) == 0
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize("temperature", [None, 40.0])
def test_cli_plot_shows_the_viscosity_it_computed_with(tmp_path, capsys, monkeypatch, temperature):
    """The catalogue oil's Walther viscosity at the oil temperature (not the unused oil_viscosity_pa_s
    0.06) in the title, and the plotted film is the report's film at that viscosity."""
    from guide_health.analysis import report_plots

    figures = []
    monkeypatch.setattr(report_plots, "_save_figure", lambda plt, fig, path: figures.append(fig))
    extra = [] if temperature is None else ["--temperature-c", str(temperature)]
    assert cli.main(["contact", "rolling", "--params", str(CONFIG), "--plot", str(tmp_path / "r.png"), "--json",
                     *extra]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["oil_temperature_c"] == (21.0 if temperature is None else temperature)
    assert out["oil_viscosity_pa_s"] > 0.1 if temperature is None else out["oil_viscosity_pa_s"] < 0.06
    title = figures[0]._suptitle.get_text()
    assert f"eta0 {out['oil_viscosity_pa_s']:.3g} Pa s at {out['oil_temperature_c']:.1f} degC" in title
    assert "0.06 " not in title
    line = figures[0].axes[0].get_lines()[0]                  # central film [nm] against carriage speed
    speed, film_nm = line.get_xdata()[40], line.get_ydata()[40]
    assert cli.main(["contact", "rolling", "--params", str(CONFIG), "--speed", repr(float(speed)), "--json",
                     *extra]) == 0
    assert film_nm == pytest.approx(json.loads(capsys.readouterr().out)["film_central_nm"], rel=1e-12)


@pytest.mark.parametrize("extra, yaml_body", [
    (["--load-n", "-5"], None),
    (["--load-n", "nan"], None),
    (["--speed", "inf"], None),
    ([], "wear_monitor:\n  ros__parameters:\n    guide_type: rolling\n    groove_conformity: 0.45\n"),
    ([], "wear_monitor:\n  ros__parameters:\n    guide_type: rolling\n    rows: 6\n"),
    ([], "wear_monitor:\n  ros__parameters:\n    guide_type: rolling\n    roughness_rms_m: 0.0\n"),
])
def test_cli_bad_input_exits_2(tmp_path, capsys, extra, yaml_body):
    path = CONFIG
    if yaml_body is not None:
        path = tmp_path / "bad.yaml"
        path.write_text(yaml_body)
    assert cli.main(["contact", "rolling", "--params", str(path), "--json", *extra]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert len(captured.err.strip().splitlines()) == 1
