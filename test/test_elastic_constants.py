"""One elastic constant for every contact formula: the contact modulus E* (Johnson 1985 Eq. 4.22),
1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2, named ``effective_modulus_pa`` and defined once in
guide_health/models/contact/elastic.py. Formulas published with Hamrock's E' = 2 E* form 2 E* themselves.

These tests pin the convention (numbers) and that every call site of the rolling and the slewing models
uses it (a silent factor of 2 between E* and E' would change a pressure by 2^(1/2) or 2^(2/3)).
"""
from __future__ import annotations

import ast
import math
from pathlib import Path

import pytest

from guide_health.models.contact import hertz_line, hertz_point
from guide_health.models.contact.elastic import effective_modulus_pa
from guide_health.models.rolling import ball_contact, lubrication
from guide_health.models.slewing import finite_roller, monitor, numerical_roller
from guide_health.params import WEAR_MONITOR_DEFAULTS
from guide_health.params.typed import guide_params, slewing_monitor_params

PACKAGE = Path(__file__).resolve().parents[1] / "guide_health"


def test_steel_on_steel_contact_modulus():
    # seed 001 steels, E = 206 GPa, nu = 0.3: E* = 113.2 GPa (and Hamrock's E' = 226.4 GPa)
    assert effective_modulus_pa(206.0e9, 0.3) == pytest.approx(113.2e9, rel=5e-4)
    assert effective_modulus_pa(206.0e9, 0.3) == pytest.approx(206.0e9 / (2.0 * (1.0 - 0.3 ** 2)), rel=1e-15)
    # seed 003 Eq. 3 check: E* = E / (2 (1 - nu^2)) = 115.4 GPa for E = 210 GPa
    assert effective_modulus_pa(210.0e9, 0.3) == pytest.approx(115.4e9, rel=5e-4)
    assert effective_modulus_pa(210.0e9, 0.3) == pytest.approx(210.0e9 / (2.0 * (1.0 - 0.3 ** 2)), rel=1e-15)


def test_two_materials_follow_the_definition():
    e_star = effective_modulus_pa(206.0e9, 0.3, 70.0e9, 0.33)        # steel on aluminium
    assert 1.0 / e_star == pytest.approx((1 - 0.3 ** 2) / 206.0e9 + (1 - 0.33 ** 2) / 70.0e9, rel=1e-15)
    assert e_star == pytest.approx(effective_modulus_pa(70.0e9, 0.33, 206.0e9, 0.3), rel=1e-15)
    with pytest.raises(ValueError):
        effective_modulus_pa(0.0, 0.3)


def test_one_modulus_function_in_the_package():
    """No second (E' or E*) modulus function anywhere: the factor-of-2 trap cannot come back."""
    definitions = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and "modulus" in node.name:
                definitions.append((path.relative_to(PACKAGE).as_posix(), node.name))
    assert definitions == [("models/contact/elastic.py", "effective_modulus_pa")]


def rolling_params() -> dict:
    p = dict(WEAR_MONITOR_DEFAULTS)
    p.update(guide_type="rolling", ball_radius_m=3.9685e-3, groove_conformity=0.52, contact_angle_deg=50.0,
             balls_per_row=10, rows=4, preload_n=385.0, youngs_modulus_pa=206.0e9, poisson=0.3,
             roughness_rms_m=0.2e-6, oil_viscosity_pa_s=0.060, pressure_viscosity_pa_inv=2.0e-8)
    return p


def test_rolling_call_sites_use_e_star():
    guide = ball_contact.RollingGuideContact.from_params(guide_params(rolling_params()))
    e_star = effective_modulus_pa(206.0e9, 0.3)
    e_prime = 206.0e9 / (1.0 - 0.3 ** 2)                 # Hamrock's reduced modulus, written out here
    assert guide.effective_modulus_pa == e_star
    # Hertz: the circular limit a^3 = 3 P R / (4 E*) (Johnson Eq. 4.22/4.23)
    ball = hertz_point.hertz_point_contact(100.0, 5e-3, 5e-3, e_star)
    assert ball.semi_axis_x_m == pytest.approx((3 * 100.0 * 5e-3 / (4 * e_star)) ** (1 / 3), rel=1e-12)
    assert guide.hertz(385.0) == hertz_point.hertz_point_contact(385.0, guide.radius_x_m, guide.radius_y_m, e_star)
    # Hamrock-Dowson central film with U, G, W written with E' (their paper's form)
    contact = guide.hertz(385.0)
    u, r_x, k = 0.05, guide.radius_x_m, contact.ellipticity_k
    h_c = (2.69 * (0.060 * u / (e_prime * r_x)) ** 0.67 * (2.0e-8 * e_prime) ** 0.53
           * (385.0 / (e_prime * r_x ** 2)) ** -0.067 * (1 - 0.61 * math.exp(-0.73 * k)) * r_x)
    assert guide.film(385.0, 2 * u, contact)[0] == pytest.approx(h_c, rel=1e-12)
    # Greenwood-Tripp asperity pressure coefficient K_GT E'
    ebs = guide.asperity_density_per_m2 * guide.asperity_radius_m * guide.composite_rms_m
    k_gt = 16 * math.sqrt(2) / 15 * math.pi * ebs ** 2 * math.sqrt(guide.composite_rms_m / guide.asperity_radius_m)
    assert guide.gt_pressure_coefficient_pa == pytest.approx(k_gt * e_prime, rel=1e-12)
    assert lubrication.greenwood_tripp_pressure_coefficient(
        guide.composite_rms_m, guide.asperity_density_per_m2, guide.asperity_radius_m, e_star) == pytest.approx(
        k_gt * e_prime, rel=1e-12)


def test_slewing_call_sites_use_e_star():
    params = slewing_monitor_params(dict(youngs_modulus_pa=210.0e9, poisson=0.3, roller_end_radius_m=2e-3))
    e_star = effective_modulus_pa(210.0e9, 0.3)
    load, length, diameter = 103_400.0, params.roller_length_m, params.roller_diameter_m
    assert monitor.SlewingContactModel(params).effective_modulus_pa == e_star
    ideal = hertz_line.hertz_line_contact(load, length, diameter, 210.0e9, 0.3)
    assert ideal.effective_modulus_pa == e_star
    # p0 = sqrt(P' E* / (pi R)) (Johnson Eq. 4.45) and the (p0, b) helper of the numerical solver agree with it
    line_load, radius = load / length, diameter / 2
    assert ideal.p0_pa == pytest.approx(math.sqrt(line_load * e_star / (math.pi * radius)), rel=1e-12)
    p0, b = hertz_line.hertz_line_pressure_and_half_width(line_load, radius, e_star)
    assert (p0, b) == (pytest.approx(ideal.p0_pa, rel=1e-12), pytest.approx(ideal.half_width_m, rel=1e-12))
    assert finite_roller.finite_roller_contact(load, length, diameter, 210.0e9, 0.3).scalars.hertz == ideal
    report = numerical_roller.numerical_contact_report(params, load, nx=16, ny=32)
    assert report["p0_hertz_MPa"] == pytest.approx(ideal.p0_pa * 1e-6, rel=1e-12)
