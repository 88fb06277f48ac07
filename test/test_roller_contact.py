"""Roller/raceway contact of three-row roller slewing bearings (seed 003) and `guide-health contact slewing`.

Published numbers are copied here (the project never reads shared/ at run time): seed 003 Sec. 4 and
Table 1 (FENG, QI, TONG, China Mech. Eng. 28(4) 2017), and Johnson, Contact Mechanics (1985) Sec. 4.2/7.2.
"""
from __future__ import annotations

import json
import math
import sys
import timeit

import numpy as np
import pytest
from scipy import integrate

from guide_health import cli
from guide_health.errors import InputError
from guide_health.models.contact import elastic, hertz_line
from guide_health.models.slewing import finite_roller, mcewen, monitor, row_loads
from guide_health.params import SLEWING_MONITOR_DEFAULTS, validate_slewing_params
from guide_health.params.typed import slewing_monitor_params

# --- seed 003 Sec. 4 example and Table 1 (MPa) ---------------------------------------------------
E_PA, NU, D_M, L_M, Q_N, FRICTION = 210.0e9, 0.3, 0.032, 0.0313, 103_400.0, 0.1
TABLE1 = {"ideal": (2754.0, 1127.0), "center": (2675.0, 1095.0), "end": (3245.0, 1328.0)}  # (p0, von Mises)
TABLE1_FE = {"center": (2595.0, 1027.0), "end": (3151.0, 1305.0)}
FIG7_VON_MISES = (0.53, 0.70)     # value / p0, depth / a (roller end, x = 0)
FIG8_MAX_SHEAR = (0.301, 0.78)
# --- DESIGN.md intermediate values of the seed's method -----------------------------------------
DELTA_CENTRE_MM, LINE_LOAD_CENTRE_N_MM, END_RATIO = 0.0894, 3115.0, 1.213
# --- Johnson 1985 Sec. 4.2 (plane strain, nu = 0.3, frictionless, x = 0) ------------------------
JOHNSON_TAU1 = (0.300, 0.786)
JOHNSON_VON_MISES = (0.557, 0.70)


def seed_values(**overrides) -> dict:
    p = dict(SLEWING_MONITOR_DEFAULTS)
    p.update(youngs_modulus_pa=E_PA, poisson=NU, roller_diameter_m=D_M, roller_length_m=L_M, friction=FRICTION)
    p.update(overrides)
    return p


def seed_params(**overrides):
    """The seed 003 example as the models take it: the frozen, validated SlewingMonitorParams."""
    return slewing_monitor_params(seed_values(**overrides))


def rel(a, b):
    return abs(a / b - 1.0)


# =================================================================================================
# Hertz and the finite-roller method (Eqs. 2-10)
# =================================================================================================
def test_effective_modulus_equal_steels():
    assert rel(elastic.effective_modulus_pa(E_PA, NU), 115.4e9) < 5e-4
    # general two-material form reduces to E/(2(1-nu^2)) and is symmetric
    assert elastic.effective_modulus_pa(E_PA, NU, E_PA, NU) == pytest.approx(E_PA / (2 * (1 - NU ** 2)), rel=1e-12)
    assert elastic.effective_modulus_pa(200e9, 0.3, 70e9, 0.33) == pytest.approx(
        elastic.effective_modulus_pa(70e9, 0.33, 200e9, 0.3), rel=1e-12)


def test_ideal_hertz_reproduces_seed_2754():
    h = hertz_line.hertz_line_contact(Q_N, L_M, D_M, E_PA, NU)
    assert rel(h.half_width_m, 0.764e-3) < 2e-3
    assert rel(h.p0_pa * 1e-6, TABLE1["ideal"][0]) < 0.01
    # Eq. 9 integrates to the line load (load balance across the contact)
    total, _ = integrate.quad(lambda x: float(hertz_line.pressure_across_contact_pa(np.array(x), h.line_load_n_m,
                                                                            h.half_width_m)),
                              -h.half_width_m, h.half_width_m)
    assert rel(total, h.line_load_n_m) < 1e-8
    # p0 = E* a / (2R) (Hertz closed form)
    assert rel(h.p0_pa, h.effective_modulus_pa * h.half_width_m / (2 * h.effective_radius_m)) < 1e-12


def test_raceway_curvature_changes_contact_as_expected():
    flat = hertz_line.hertz_line_contact(Q_N, L_M, D_M, E_PA, NU)
    concave = hertz_line.hertz_line_contact(Q_N, L_M, D_M, E_PA, NU, raceway_radius_m=-1.0)    # outer ring, R = 1 m
    convex = hertz_line.hertz_line_contact(Q_N, L_M, D_M, E_PA, NU, raceway_radius_m=1.0)      # inner ring
    assert convex.p0_pa > flat.p0_pa > concave.p0_pa
    # 1/R = 2/d -+ 1/R_race; p0 ~ sqrt(1/R)
    assert rel(concave.p0_pa / flat.p0_pa, math.sqrt((2 / D_M - 1.0) / (2 / D_M))) < 1e-12
    assert rel(hertz_line.hertz_line_contact(Q_N, L_M, D_M, E_PA, NU, raceway_radius_m=1e12).p0_pa, flat.p0_pa) < 1e-9


def test_finite_roller_reproduces_seed_centre_and_end():
    c = finite_roller.finite_roller_contact(Q_N, L_M, D_M, E_PA, NU)
    s = c.scalars
    assert rel(s.centre_approach_m * 1e3, DELTA_CENTRE_MM) < 2e-3
    assert rel(s.centre_line_load_n_m * 1e-3, LINE_LOAD_CENTRE_N_MM) < 3e-3
    assert rel(s.p0_centre_pa * 1e-6, TABLE1["center"][0]) < 0.01
    assert rel(s.p0_end_pa * 1e-6, TABLE1["end"][0]) < 0.01
    assert rel(s.end_stress_ratio, END_RATIO) < 1e-3
    # the seed says its analytic pressures are within 3.1 % of its FE model; ours must be too (4 %)
    assert rel(s.p0_centre_pa * 1e-6, TABLE1_FE["center"][0]) < 0.04
    assert rel(s.p0_end_pa * 1e-6, TABLE1_FE["end"][0]) < 0.04
    # profile: symmetric, minimum at the centre, maximum (the Eq. 5 value) at the ends
    assert np.allclose(c.p0_pa, c.p0_pa[::-1], rtol=1e-12)
    assert c.p0_pa.min() == pytest.approx(s.p0_centre_pa, rel=1e-12)
    assert c.p0_pa.max() == pytest.approx(s.p0_end_pa, rel=1e-12)
    assert np.all(np.diff(c.p0_pa[c.y_m >= 0]) >= -1e-6)


def test_end_ratio_closed_form_and_load_dependence():
    half = L_M / 2
    for load in (2e4, Q_N, 3e5):
        h = hertz_line.hertz_line_contact(load, L_M, D_M, E_PA, NU)
        s = finite_roller.finite_roller_contact(load, L_M, D_M, E_PA, NU).scalars
        assert finite_roller.end_to_centre_pressure_ratio(load, half, h.half_width_m) == pytest.approx(
            s.end_stress_ratio, rel=1e-12)
    # independent of E (E* and k1 cancel)
    h = hertz_line.hertz_line_contact(Q_N, L_M, D_M, 70e9, NU)
    assert finite_roller.finite_roller_contact(Q_N, L_M, D_M, 70e9, NU).scalars.end_stress_ratio == pytest.approx(
        finite_roller.end_to_centre_pressure_ratio(Q_N, half, h.half_width_m), rel=1e-12)
    r_lo = finite_roller.finite_roller_contact(5e4, L_M, D_M, E_PA, NU).scalars.end_stress_ratio
    r_hi = finite_roller.finite_roller_contact(2e5, L_M, D_M, E_PA, NU).scalars.end_stress_ratio
    assert r_lo > r_hi and r_lo - r_hi < 0.01    # weakly load dependent (ln(l/a))


def test_palmgren_eq7_inverts_eq6():
    # Eq. 6: delta = 4.05e-5 P^0.925 / l_e^0.85 (mm, N); Eq. 7 with P1 = P / l_e must invert it
    for load in (1e4, Q_N, 4e5):
        delta_mm = 4.05e-5 * load ** 0.925 / (L_M * 1e3) ** 0.85
        p1 = finite_roller.line_load_from_approach_n_m(delta_mm * 1e-3, L_M)
        # Eq. 7 prints 2.47e4 for 1/4.05e-5 = 24691: agreement to that rounding
        assert rel(p1 * L_M, load) < 1e-3


def test_load_balance_of_the_seed_method():
    """Eqs. 2/4/5 (Johnson) and Eqs. 6/7 (Palmgren) are separate models: they balance Q to within 1 %."""
    c = finite_roller.finite_roller_contact(Q_N, L_M, D_M, E_PA, NU, points=20001)
    assert abs(c.load_balance_ratio - 1.0) < 0.01
    trapezoid = np.trapezoid(c.line_load_n_m, c.y_m) / Q_N
    assert trapezoid == pytest.approx(c.load_balance_ratio, abs=2e-3)


# =================================================================================================
# Eq. 1 and the radial row
# =================================================================================================
def test_eq1_rows_and_equilibrium():
    n, d0 = 170, 2.0
    fa, mt = 2.0e6, 7.8e6
    rows = row_loads.axial_row_roller_loads(fa, mt, n, d0)
    assert rows.main_row_max_n == pytest.approx(4 * mt / (n * d0) + fa / n)
    assert rows.opposite_row_max_n == pytest.approx(4 * mt / (n * d0) - fa / n)
    # rebuild the linear distribution F_a/n + Q_m cos(psi) from the two maxima: it carries F_a and M_T
    q_m = 0.5 * (rows.main_row_max_n + rows.opposite_row_max_n)
    q_a = 0.5 * (rows.main_row_max_n - rows.opposite_row_max_n)
    psi = 2 * np.pi * np.arange(n) / n
    q = q_a + q_m * np.cos(psi)
    assert q.sum() == pytest.approx(fa, rel=1e-9)
    assert np.sum(q * np.cos(psi) * d0 / 2) == pytest.approx(mt, rel=1e-9)
    assert rows.main_row_partly_unloaded and not rows.opposite_row_unloaded


def test_eq1_unloaded_rows_are_flagged():
    axial_only = row_loads.axial_row_roller_loads(1.0e6, 0.0, 170, 2.0)
    assert axial_only.opposite_row_unloaded and axial_only.opposite_row_max_n == 0.0
    assert not axial_only.main_row_unloaded and not axial_only.main_row_partly_unloaded
    lifting = row_loads.axial_row_roller_loads(-1.0e6, 1.0e5, 170, 2.0)        # F_a pulls the rings apart
    assert lifting.main_row_unloaded and lifting.main_row_max_n == 0.0
    assert lifting.max_n == pytest.approx(1.0e6 / 170 + 4 * 1.0e5 / (170 * 2.0))
    assert (row_loads.axial_row_roller_loads(1.0e6, -3.0e6, 170, 2.0)
            == row_loads.axial_row_roller_loads(1.0e6, 3.0e6, 170, 2.0))


def test_radial_row_stribeck_factor_from_integral():
    # zero clearance, line contact: J_r = 1/(2 pi) int cos^(1.1) psi cos psi dpsi over |psi| < pi/2
    j_r, _ = integrate.quad(lambda p: math.cos(p) ** 2.1, -math.pi / 2, math.pi / 2)
    j_r /= 2 * math.pi
    assert rel(1.0 / j_r, row_loads.RADIAL_ROW_LINE_CONTACT_FACTOR) < 2e-3
    assert row_loads.radial_row_roller_load_max_n(1.0e5, 100) == pytest.approx(4.08e3)


# =================================================================================================
# McEwen field (Eqs. 11-24)
# =================================================================================================
def flamant_field(x, z, friction):
    """Independent check: superpose Flamant line loads (Johnson Eqs. 2.15/2.16) over the contact, a = p0 = 1."""
    def integrand(s, k):
        dx = x - s
        r4 = (dx * dx + z * z) ** 2
        w = math.sqrt(max(1 - s * s, 0.0))
        normal = (dx * dx * z, z ** 3, dx * z * z)
        tangential = (dx ** 3, dx * z * z, dx * dx * z)
        return -2 / math.pi * w * (normal[k] + friction * tangential[k]) / r4
    return [integrate.quad(integrand, -1, 1, args=(k,), limit=400, epsabs=1e-12)[0] for k in range(3)]


@pytest.mark.parametrize("x, z", [(0.3, 0.5), (-0.7, 0.3), (1.5, 0.4), (-1.2, 1.0), (0.0, 0.786), (0.9, 0.05)])
@pytest.mark.parametrize("friction", [0.0, 0.1, -0.3])
def test_mcewen_matches_flamant_superposition(x, z, friction):
    sx, sz, txz, _ = mcewen.mcewen_normalised_field(np.array(x), np.array(z), friction, NU)
    ref = flamant_field(x, z, friction)
    assert np.allclose([sx, sz, txz], ref, atol=2e-6)


def test_mcewen_surface_boundary_conditions_and_axis_closed_form():
    f = 0.2
    x = np.linspace(-3, 3, 601)
    sx, sz, txz, _ = mcewen.mcewen_normalised_field(x, np.zeros_like(x), f, NU)
    p = np.sqrt(np.clip(1 - x * x, 0, None))
    assert np.allclose(sz, -p, atol=1e-12)                  # normal traction = pressure
    assert np.allclose(txz, -f * p, atol=1e-12)             # shear traction f p in +x (outward normal -z)
    inside = np.abs(x) < 1
    assert np.allclose(sx[inside], -p[inside] - 2 * f * x[inside], atol=1e-12)
    zeta = np.linspace(0, 4, 81)
    sx, sz, txz, sy = mcewen.mcewen_normalised_field(np.zeros_like(zeta), zeta, 0.0, NU)
    root = np.sqrt(1 + zeta ** 2)
    assert np.allclose(sz, -1 / root, atol=1e-12)
    assert np.allclose(sx, -((1 + 2 * zeta ** 2) / root - 2 * zeta), atol=1e-12)
    assert np.allclose(txz, 0, atol=1e-12)
    assert np.allclose(sy, NU * (sx + sz), atol=1e-15)


def test_mcewen_symmetry_and_no_nan_at_contact_edges():
    x = np.linspace(-2, 2, 81)          # includes x = +-1, z = 0 (the edges)
    z = np.linspace(0, 2, 41)
    xx, zz = np.meshgrid(x, z)
    sx, sz, txz, _ = mcewen.mcewen_normalised_field(xx, zz, 0.0, NU)
    assert np.all(np.isfinite(sx)) and np.all(np.isfinite(txz))
    assert np.allclose(sx, sx[:, ::-1], atol=1e-12) and np.allclose(sz, sz[:, ::-1], atol=1e-12)
    assert np.allclose(txz, -txz[:, ::-1], atol=1e-12)
    # friction reversed = mirror image (tau_xz changes sign under the mirror)
    a = mcewen.mcewen_normalised_field(xx, zz, 0.1, NU)
    b = mcewen.mcewen_normalised_field(-xx, zz, -0.1, NU)
    assert np.allclose(a[0], b[0], atol=1e-12) and np.allclose(a[1], b[1], atol=1e-12)
    assert np.allclose(a[2], -b[2], atol=1e-12)


def test_mcewen_scaling_with_a_and_p0():
    a, p0 = 0.9e-3, 3.2e9
    field = mcewen.mcewen_stress_field(np.array([0.3 * a]), np.array([0.6 * a]), a, p0, 0.1, NU)
    sx, sz, txz, sy = mcewen.mcewen_normalised_field(np.array([0.3]), np.array([0.6]), 0.1, NU)
    assert field.sigma_x[0] == pytest.approx(p0 * sx[0]) and field.tau_xz[0] == pytest.approx(p0 * txz[0])
    s1, s2 = field.sigma_1[0], field.sigma_2[0]
    assert s1 + s2 == pytest.approx(field.sigma_x[0] + field.sigma_z[0])
    assert field.max_shear[0] == pytest.approx(0.5 * (s1 - s2))
    assert field.von_mises[0] == pytest.approx(math.sqrt(0.5 * ((s1 - s2) ** 2 + (s2 - field.sigma_y[0]) ** 2
                                                                + (field.sigma_y[0] - s1) ** 2)))


def test_von_mises_at_surface_centre_frictionless_is_1_minus_2nu():
    for nu in (0.25, 0.3, 0.35):
        f = mcewen.mcewen_stress_field(np.zeros(1), np.zeros(1), 1e-3, 1.0, 0.0, nu)
        assert f.von_mises[0] == pytest.approx(1 - 2 * nu, abs=1e-12)


def test_mcewen_maxima_frictionless_johnson():
    tau = mcewen.field_maximum("max_shear", 0.0, NU, on_axis=True)
    vm = mcewen.field_maximum("von_mises", 0.0, NU, on_axis=True)
    assert tau.value_over_p0 == pytest.approx(JOHNSON_TAU1[0], abs=1e-3)
    assert tau.z_over_a == pytest.approx(JOHNSON_TAU1[1], abs=2e-3)
    assert vm.value_over_p0 == pytest.approx(JOHNSON_VON_MISES[0], abs=1.5e-3)
    assert vm.z_over_a == pytest.approx(JOHNSON_VON_MISES[1], abs=0.01)
    # frictionless: the global maximum lies on the axis
    glob = mcewen.field_maximum("von_mises", 0.0, NU)
    assert glob.value_over_p0 == pytest.approx(vm.value_over_p0, rel=1e-6)
    assert abs(glob.x_over_a) < 1e-4


def test_mcewen_maxima_with_friction_reproduce_seed_fig8_shear():
    tau = mcewen.field_maximum("max_shear", FRICTION, NU, on_axis=True)
    assert tau.value_over_p0 == pytest.approx(FIG8_MAX_SHEAR[0], abs=1e-3)
    assert tau.z_over_a == pytest.approx(FIG8_MAX_SHEAR[1], abs=0.01)
    vm_axis = mcewen.field_maximum("von_mises", FRICTION, NU, on_axis=True)
    assert vm_axis.z_over_a == pytest.approx(FIG7_VON_MISES[1], abs=0.01)     # depth agrees with Fig. 7
    # friction moves the maxima off the axis and raises them
    glob = mcewen.field_maximum("max_shear", FRICTION, NU)
    assert glob.value_over_p0 > tau.value_over_p0 and glob.x_over_a > 0.1


def test_field_maximum_refinement_beats_a_fine_brute_force_grid():
    xx, zz = np.meshgrid(np.linspace(-1.5, 1.5, 1201), np.linspace(0, 3, 1201))
    sx, sz, txz, sy = mcewen.mcewen_normalised_field(xx, zz, FRICTION, NU)
    vm = np.sqrt(0.5 * ((sx - sy) ** 2 + (sy - sz) ** 2 + (sz - sx) ** 2) + 3 * txz ** 2)
    best = mcewen.field_maximum("von_mises", FRICTION, NU)
    j = np.unravel_index(np.argmax(vm), vm.shape)
    assert best.value_over_p0 >= vm[j] - 1e-12
    assert best.value_over_p0 - vm[j] < 1e-4
    assert abs(best.x_over_a - xx[j]) < 0.01 and abs(best.z_over_a - zz[j]) < 0.01


def printed_seed_field(x, z, f, nu):
    """Eqs. 20-22 with the signs exactly as printed in seed 003 (m >= 0, n with the sign of x)."""
    m, n = mcewen._mcewen_mn(x, z)
    r = m * m + n * n
    t1, t2, t3 = (z * z + n * n) / r, (m * m - z * z) / r, (z * z - m * m) / r
    sx = -(m * (1 + t1) - 2 * z) - f * (n * (2 - t3) - 2 * x)
    sz = -m * (1 - t1) - f * n * t2
    txz = n * t2 + f * (m * (1 + t1) - 2 * z)
    sy = nu * (sx + sz)
    return np.sqrt(0.5 * ((sx - sy) ** 2 + (sy - sz) ** 2 + (sz - sx) ** 2) + 3 * txz ** 2)


def test_printed_signs_agree_on_axis_but_not_off_axis():
    z = np.linspace(0.01, 2, 200)
    ours = mcewen._normalised_quantity("von_mises", np.zeros_like(z), z, FRICTION, NU)
    assert np.allclose(printed_seed_field(np.zeros_like(z), z, FRICTION, NU), ours, atol=1e-12)
    xx, zz = np.meshgrid(np.linspace(-1.5, 1.5, 601), np.linspace(0.005, 2, 401))
    printed_max = printed_seed_field(xx, zz, FRICTION, NU).max()
    ours_max = mcewen.field_maximum("von_mises", FRICTION, NU).value_over_p0
    assert printed_max > ours_max + 0.02      # 0.591 vs 0.565: the printed set is not a physical field


# =================================================================================================
# Finding: the seed's von Mises 0.409 p0 (Table 1) and 0.53 p0 (Fig. 7)
# =================================================================================================
def test_table1_von_mises_is_a_surface_value():
    ratios = [vm / p0 for p0, vm in TABLE1.values()]
    assert max(ratios) - min(ratios) < 3e-4          # one fixed point of the normalised field
    c = mcewen.seed003_von_mises_candidates(FRICTION, NU)
    table_ratio = float(np.mean(ratios))
    assert c["surface_centre_frictionless"] == pytest.approx(1 - 2 * NU)
    assert c["surface_centre_with_friction"] == pytest.approx(math.sqrt((1 - 2 * NU) ** 2 + 3 * FRICTION ** 2))
    # only the surface centre with half the friction shear reproduces 0.409 at nu = 0.3, f = 0.1
    assert abs(c["surface_centre_half_friction_shear"] - table_ratio) < 3e-4
    for name in ("surface_centre_frictionless", "surface_centre_with_friction", "surface_centre_plane_stress",
                 "von_mises_max_on_axis", "sqrt3_max_shear_on_axis"):
        assert abs(c[name] - table_ratio) > 0.009, name
    # and it is far below the subsurface maximum, so Table 1's von Mises is not the maximum
    assert c["von_mises_max_on_axis"] / table_ratio > 1.3


def test_fig7_von_mises_053_not_reproduced_at_07a():
    c = mcewen.seed003_von_mises_candidates(FRICTION, NU)
    assert c["von_mises_max_on_axis_depth_over_a"] == pytest.approx(FIG7_VON_MISES[1], abs=0.01)
    assert c["von_mises_max_on_axis"] / FIG7_VON_MISES[0] - 1 > 0.04       # 0.559 vs 0.53
    assert c["von_mises_on_axis_at_depth_0p7a"] / FIG7_VON_MISES[0] - 1 > 0.04


# =================================================================================================
# Report, cached model and levels
# =================================================================================================
REPORT_KEYS = ("roller_load_max_n", "p_max_MPa", "p_max_position_mm", "p0_hertz_MPa", "p0_center_MPa",
               "p0_end_MPa", "end_stress_ratio", "von_mises_max_MPa", "von_mises_depth_mm", "shear_max_MPa",
               "shear_depth_mm", "allowable_MPa", "level", "message")


def test_report_seed_example():
    r = monitor.slewing_contact_report(seed_params(), None)
    assert set(REPORT_KEYS) <= set(r)
    assert r["roller_load_max_n"] == Q_N
    assert rel(r["p0_hertz_MPa"], TABLE1["ideal"][0]) < 0.01
    assert rel(r["p0_center_MPa"], TABLE1["center"][0]) < 0.01
    assert rel(r["p0_end_MPa"], TABLE1["end"][0]) < 0.01
    assert r["p_max_MPa"] == r["p0_end_MPa"] and r["p_max_position_mm"] == pytest.approx(L_M / 2 * 1e3)
    vm = mcewen.field_maximum("von_mises", FRICTION, NU)
    assert r["von_mises_max_MPa"] == pytest.approx(vm.value_over_p0 * r["p0_end_MPa"], rel=1e-9)
    assert r["von_mises_depth_mm"] == pytest.approx(vm.z_over_a * r["half_width_end_mm"], rel=1e-9)
    assert 0.5 < r["shear_depth_mm"] < 0.8 and 0.30 < r["shear_max_MPa"] / r["p_max_MPa"] < 0.31
    assert r["allowable_MPa"] == pytest.approx(4000.0)
    assert r["level"] == 1                           # 3246 MPa > 0.8 x 4000 MPa


@pytest.mark.parametrize("allowable, level", [(3.0e9, 2), (4.0e9, 1), (4.2e9, 0)])
def test_levels(allowable, level):
    r = monitor.slewing_contact_report(seed_params(allowable_contact_stress_pa=allowable), Q_N)
    assert r["level"] == level
    p = r["p_max_MPa"] * 1e6
    assert monitor.contact_level(p, p * 0.999, 0.8) == 2 and monitor.contact_level(p, p * 1.001, 0.8) == 1
    assert monitor.contact_level(p, p / 0.79, 0.8) == 0


def test_cached_model_equals_direct():
    params = seed_params()
    model = monitor.SlewingContactModel(params)
    for load in (1.0e3, Q_N, 3.0e5):
        direct, cached = monitor.slewing_contact_report(params, load), model.report_for_roller_load(load)
        for key in REPORT_KEYS:
            if isinstance(direct[key], float):
                assert cached[key] == pytest.approx(direct[key], rel=1e-6, abs=1e-9), key
            else:
                assert cached[key] == direct[key], key
    for loads in ((2.0e6, 5.0e4, 7.8e6), (1.0e6, 1.0e6, 0.0), (-5.0e5, 0.0, 1.0e6)):
        direct = monitor.slewing_contact_report_from_loads(params, *loads)
        cached = model.report_for_loads(*loads)
        assert cached["worst_row"] == direct["worst_row"]
        assert cached["roller_load_max_n"] == pytest.approx(direct["roller_load_max_n"])
        assert cached["p_max_MPa"] == pytest.approx(direct["p_max_MPa"], rel=1e-9)


def test_loads_report_picks_the_worst_roller():
    r = monitor.SlewingContactModel(seed_params()).report_for_loads(1.0e6, 1.0e6, 0.0)
    assert r["worst_row"] == "radial" and r["roller_load_max_n"] == pytest.approx(4.08e6 / 170)
    assert r["opposite_row_unloaded"]
    z = monitor.SlewingContactModel(seed_params()).report_for_loads(0.0, 0.0, 0.0)
    assert z["roller_load_max_n"] == 0.0 and z["p_max_MPa"] == 0.0 and z["level"] == 0


def test_cached_model_is_much_faster_than_direct():
    params = seed_params()
    model = monitor.SlewingContactModel(params)
    cached = min(timeit.repeat(lambda: model.report_for_loads(2.0e6, 5.0e4, 7.8e6), number=200, repeat=3)) / 200
    direct = min(timeit.repeat(lambda: monitor.slewing_contact_report_from_loads(params, 2.0e6, 5.0e4, 7.8e6),
                               number=2, repeat=2)) / 2
    assert cached < direct / 50
    assert cached < 1e-3                               # well inside a 200 Hz period


def test_bad_loads_and_params_raise():
    with pytest.raises(ValueError):
        monitor.SlewingContactModel(seed_params()).report_for_roller_load(float("nan"))
    with pytest.raises(ValueError):
        monitor.slewing_contact_report(seed_params(), -1.0)
    for bad in ({"poisson": 0.5}, {"roller_count": 0}, {"roller_count": 400}, {"stress_model": "fem"},
                {"warn_fraction": 1.5}, {"roller_count": 170.0}):
        with pytest.raises(InputError):
            validate_slewing_params(seed_values(**bad))


def test_numerical_model_unavailable_is_a_value_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "guide_health.models.slewing.numerical_roller", None)
    with pytest.raises(ValueError, match="not available"):
        monitor.slewing_contact_report(seed_params(stress_model="numerical"), Q_N)


# =================================================================================================
# CLI
# =================================================================================================
PARAMS_YAML = """\
slewing_monitor:
  ros__parameters:
    bearing: "131.32.2000.00Z"
    roller_count: 170
    raceway_diameter_m: 2.0
    roller_diameter_m: 0.032
    roller_length_m: 0.0313
    youngs_modulus_pa: 210.0e9
    poisson: 0.3
    friction: 0.1
"""


@pytest.fixture
def params_file(tmp_path):
    path = tmp_path / "slewing.yaml"
    path.write_text(PARAMS_YAML)
    return path


def test_cli_json_keys_and_values(params_file, capsys):
    assert cli.main(["contact", "slewing", "--params", str(params_file), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(REPORT_KEYS) <= set(out)
    assert out["roller_load_max_n"] == Q_N
    assert rel(out["p0_end_MPa"], TABLE1["end"][0]) < 0.01


def test_cli_load_options(params_file, capsys):
    assert cli.main(["contact", "slewing", "--params", str(params_file), "--json", "--load-n", "50000"]) == 0
    assert json.loads(capsys.readouterr().out)["roller_load_max_n"] == 50000.0
    assert cli.main(["contact", "slewing", "--params", str(params_file), "--json",
                     "--axial-n", "2e6", "--moment-nm", "7.8e6"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["roller_load_max_n"] == pytest.approx(4 * 7.8e6 / (170 * 2.0) + 2e6 / 170)


def test_cli_plot(params_file, tmp_path, capsys):
    png = tmp_path / "slewing.png"
    assert cli.main(["contact", "slewing", "--params", str(params_file), "--json", "--plot", str(png)]) == 0
    capsys.readouterr()
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("text, extra", [
    (PARAMS_YAML.replace("poisson: 0.3", "poisson: 0.7"), []),
    (PARAMS_YAML.replace("roller_count: 170", "roller_count: many"), []),
    (PARAMS_YAML, ["--load-n", "-3"]),
    (PARAMS_YAML, ["--load-n", "nan"]),
    ("slewing_monitor: [1, 2\n", []),
])
def test_cli_bad_input_exits_2_with_one_line(tmp_path, capsys, text, extra):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    assert cli.main(["contact", "slewing", "--params", str(path), "--json", *extra]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert len(captured.err.strip().splitlines()) == 1 and "error" in captured.err


def test_shipped_config_matches_seed(capsys):
    from pathlib import Path
    config = Path(__file__).resolve().parents[1] / "config" / "slewing_131.32.2000.00Z.yaml"
    assert cli.main(["contact", "slewing", "--params", str(config), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert rel(out["p0_hertz_MPa"], TABLE1["ideal"][0]) < 0.01 and out["bearing"] == "131.32.2000.00Z"
