"""Rules that one closed-form test alone guarded, or none: each checked here against a truth written in this
file, never computed with the function under test.

* the alarm's clearing test on the "above" side (models/levels.py ``exceeds``): a WARN raised at a threshold
  holds while the value stays inside the clear band [threshold (1 - margin), threshold], at function level
  and through the wear_monitor (straightness) and slewing_monitor (p_max) nodes;
* a parameters file section belongs to the node of exactly that name (params/loader.py): ``wear_monitor`` and
  ``wear_monitor_spare`` in one file, in both orders, offline and through the node's own --ros-args check;
* Walther / ASTM D341 (models/rolling/oil.py): the D341 line is straight in (log10 T, log10 log10(nu + 0.7)),
  checked on three temperatures of arbitrary oils (hypothesis), and the density line;
* the ball-guide defect frequencies (models/rolling/vibration.py): rolling without slip solved here as a
  2 x 2 linear system, the raceway passes and the ball-spall strikes counted as events over a long run,
  and a tone at the counted frequency named by the spectrum test;
* the fleet prior's REML (models/fleet.py): the restricted likelihood maximised here as the likelihood of the
  n - 1 error contrasts (Harville 1974) with scipy, and by Viechtbauer's (2005) fixed-point iteration.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from guide_health.models.levels import OK, WARN, exceeds, hysteresis_level

# --- alarm hysteresis on the "above" side ---------------------------------------------------------------
MARGIN = 0.05           # the schema's default alarm_clear_margin


def test_exceeds_holds_inside_the_clear_band_and_clears_below_it():
    """threshold 80 um, margin 5 %: the clearing test's threshold is 76 um (80 x 0.95)."""
    threshold = 80.0
    assert exceeds(80.5, threshold) and not exceeds(80.0, threshold) and exceeds(80.0, threshold, inclusive=True)
    assert exceeds(78.0, threshold, MARGIN)          # 78 > 76: inside the band, still "above" for clearing
    assert exceeds(76.1, threshold, MARGIN)
    assert not exceeds(75.9, threshold, MARGIN)      # below the band: clears
    assert not exceeds(78.0, threshold)              # without a margin 78 is below 80
    assert exceeds(76.0, threshold, MARGIN, inclusive=True) and not exceeds(76.0, threshold, MARGIN)


def straightness_levels(values_um, threshold_um, margin):
    """A straightness WARN's hysteresis level over a sequence of values (the precision monitor's rule)."""
    current, out = None, []
    for a in values_um:
        level_set = WARN if exceeds(a, threshold_um) else OK
        level_clear = WARN if exceeds(a, threshold_um, margin) else OK
        current = hysteresis_level(current, level_set, level_clear)
        out.append(current)
    return out


def test_a_straightness_warn_holds_inside_the_clear_band():
    values = [79.0, 80.5, 79.0, 77.0, 76.2, 75.0, 79.5, 80.1]
    assert straightness_levels(values, 80.0, MARGIN) == [OK, WARN, WARN, WARN, WARN, OK, OK, WARN]
    assert straightness_levels(values, 80.0, 0.0) == [OK, WARN, OK, OK, OK, OK, OK, WARN]


def test_slewing_contact_level_clearing_threshold_is_below_the_warn_threshold():
    from guide_health.models.slewing.monitor import contact_level

    allowable, fraction = 4000e6, 0.8                # WARN above 3200 MPa, ERROR above 4000 MPa
    assert contact_level(3250e6, allowable, fraction) == WARN
    assert contact_level(3150e6, allowable, fraction) == OK
    assert contact_level(3150e6, allowable, fraction, MARGIN) == WARN      # 3150 > 3200 x 0.95 = 3040
    assert contact_level(3000e6, allowable, fraction, MARGIN) == OK
    assert contact_level(3900e6, allowable, fraction, MARGIN).name == "ERROR"   # 3900 > 4000 x 0.95


# --- parameters: a section belongs to the node of exactly its name ------------------------------------
K_MAIN, K_SPARE = 4.0e-6, 9.0e-6


def two_node_file(tmp_path, spare_first: bool, prefix: str = ""):
    sections = [(f"{prefix}wear_monitor", K_MAIN), (f"{prefix}wear_monitor_spare", K_SPARE)]
    if spare_first:
        sections.reverse()
    path = tmp_path / f"two_{int(spare_first)}_{len(prefix)}.yaml"
    path.write_text(yaml.safe_dump({name: {"ros__parameters": {"wear_coefficient": k}} for name, k in sections},
                                   sort_keys=False))
    return path


@pytest.mark.parametrize("prefix", ["", "/**/", "/m1/"])
@pytest.mark.parametrize("spare_first", [False, True])
def test_a_node_reads_only_the_section_of_its_own_name(tmp_path, spare_first, prefix):
    """Sections named for the root namespace, for any namespace (``/**/``) and for ``/m1`` (read by the
    nodes of that namespace only, as rcl applies them)."""
    from guide_health.params import WEAR_MONITOR_SCHEMA
    from guide_health.params.loader import load_node_params, machine_axes_params, wear_monitor_params

    path = two_node_file(tmp_path, spare_first, prefix)
    ns = "/m1/" if prefix == "/m1/" else "/"
    defaults = WEAR_MONITOR_SCHEMA.defaults()
    if ns == "/":
        assert wear_monitor_params(path)["wear_coefficient"] == K_MAIN
        assert machine_axes_params(path)["x"]["wear_coefficient"] == K_MAIN
    spare = load_node_params(path, "wear_monitor_spare", defaults, fqn=ns + "wear_monitor_spare")
    assert spare["wear_coefficient"] == K_SPARE
    main = load_node_params(path, "wear_monitor", defaults, fqn=ns + "wear_monitor")
    assert main["wear_coefficient"] == K_MAIN


@pytest.mark.parametrize("spare_first", [False, True])
def test_the_nodes_ros_args_check_reads_only_its_own_section(tmp_path, spare_first):
    """The node's --ros-args check (what the wear_monitor runs before rcl) on the same file, and with the
    node renamed to the spare (``-r __node:=wear_monitor_spare``)."""
    from guide_health.params import WEAR_MONITOR_SCHEMA
    from guide_health.params.ros_args import check_ros_args

    path = str(two_node_file(tmp_path, spare_first))
    assert check_ros_args(WEAR_MONITOR_SCHEMA, ["--ros-args", "--params-file", path])["wear_coefficient"] == K_MAIN
    spare = check_ros_args(WEAR_MONITOR_SCHEMA, ["--ros-args", "-r", "__node:=wear_monitor_spare",
                                                 "--params-file", path])
    assert spare["wear_coefficient"] == K_SPARE


# --- Walther / ASTM D341 -------------------------------------------------------------------------------
def d341_coordinates(nu_mm2_s: float, t_c: float) -> tuple[float, float]:
    """The ASTM D341 chart's coordinates: (log10 T [K], log10 log10(nu + 0.7) [nu in mm^2/s])."""
    return math.log10(t_c + 273.15), math.log10(math.log10(nu_mm2_s + 0.7))


@settings(max_examples=200, deadline=None, derandomize=True)
@given(nu40=st.floats(10.0, 1000.0), ratio=st.floats(3.0, 12.0), t_c=st.floats(-10.0, 150.0))
def test_walther_viscosity_lies_on_the_d341_line_through_the_catalogue_points(nu40, ratio, t_c):
    """Any oil (nu_40 / nu_100 between 3 and 12, as mineral and synthetic oils are), any temperature: the
    point (T, nu(T)) lies on the straight line of the D341 chart through (40 degC, nu_40) and (100 degC,
    nu_100) (slope from the two points, written here), and nu falls with temperature."""
    from guide_health.models.rolling.oil import WaltherOil

    nu100 = nu40 / ratio
    oil = WaltherOil.from_catalogue(nu40, nu100, 870.0)
    x1, y1 = d341_coordinates(nu40, 40.0)
    x2, y2 = d341_coordinates(nu100, 100.0)
    x, y = d341_coordinates(oil.kinematic_viscosity_mm2_s(t_c), t_c)
    assert y == pytest.approx(y1 + (y2 - y1) * (x - x1) / (x2 - x1), abs=1e-11)
    assert oil.kinematic_viscosity_mm2_s(t_c + 1.0) < oil.kinematic_viscosity_mm2_s(t_c)


def test_walther_oil_density_and_dynamic_viscosity():
    """rho(T) = rho_15 (1 - 6.4e-4 (T - 15 degC)) (mineral oil); eta = nu rho. At 15 degC rho = rho_15; at
    75 degC 880 x (1 - 0.0384) = 846.2 kg/m^3. eta at 40 degC of a 65.4 cSt oil: 65.4e-6 x 880 x 0.984."""
    from guide_health.models.rolling.oil import WaltherOil

    oil = WaltherOil.from_catalogue(65.4, 8.83, 880.0)
    assert oil.density_kg_m3(15.0) == pytest.approx(880.0, rel=1e-12)
    assert oil.density_kg_m3(75.0) == pytest.approx(846.208, rel=1e-9)
    assert oil.dynamic_viscosity_pa_s(40.0) == pytest.approx(65.4e-6 * 880.0 * (1 - 6.4e-4 * 25.0), rel=1e-9)


# --- ball-guide defect frequencies from kinematics -------------------------------------------------------
BALL_D_M, PITCH_M, LOOP_M = 6.35e-3, 6.6e-3, 0.25


def rolling_without_slip(speed_m_s: float, rolling_radius_m: float) -> tuple[float, float]:
    """(ball centre speed u [m/s], ball spin omega [rad/s]) of a ball between a fixed rail and a carriage
    moving at v: the rail contact point at rest, u - omega r = 0, the carriage contact at v, u + omega r = v."""
    u, omega = np.linalg.solve(np.array([[1.0, -rolling_radius_m], [1.0, rolling_radius_m]]),
                               np.array([0.0, speed_m_s]))
    return float(u), float(omega)


def counted_frequencies(speed_m_s: float, contact_angle_rad: float, duration_s: float) -> dict[str, float]:
    """Events per second over ``duration_s``: balls (one per pitch) passing a point of the rail and of the
    carriage, and the strikes of a spall on a ball on either raceway (contact points opposite each other
    on the ball's rolling circle)."""
    r_roll = 0.5 * BALL_D_M * math.cos(contact_angle_rad)
    u, omega = rolling_without_slip(speed_m_s, r_roll)
    x0 = 0.37 * PITCH_M                     # a rail point between two balls at t = 0
    reach = int(abs(speed_m_s) * duration_s / PITCH_M) + 10     # balls that can reach x0 from either side
    ball_positions = np.arange(-reach, reach + 1) * PITCH_M
    rail_passes = np.count_nonzero((ball_positions < x0) & (ball_positions + u * duration_s >= x0))
    relative = u - speed_m_s                # the balls seen from the carriage
    carriage_passes = np.count_nonzero((ball_positions > x0) & (ball_positions + relative * duration_s <= x0))
    phase0 = 0.3                            # spall angle on the rolling circle at t = 0
    turns = (phase0 + omega * duration_s) / (2 * math.pi)
    strikes = sum(math.floor(turns - c) - math.floor(phase0 / (2 * math.pi) - c) for c in (0.0, 0.5))
    return {"raceway_hz": rail_passes / duration_s, "carriage_raceway_hz": carriage_passes / duration_s,
            "ball_defect_hz": strikes / duration_s}


@pytest.mark.parametrize("speed_m_s, angle_deg", [(1.0, 0.0), (1.0, 45.0), (0.35, 45.0), (2.0, 30.0)])
def test_defect_frequencies_equal_the_counted_events(speed_m_s, angle_deg):
    from guide_health.models.rolling import vibration as vib

    counted = counted_frequencies(speed_m_s, math.radians(angle_deg), duration_s=100.0)
    f = vib.defect_frequencies(vib.GuideKinematics(BALL_D_M, PITCH_M, LOOP_M, math.radians(angle_deg)), speed_m_s)
    # counts over 100 s: +-1 event in thousands
    assert f["raceway_hz"] == pytest.approx(counted["raceway_hz"], rel=2e-3)
    assert f["raceway_hz"] == pytest.approx(counted["carriage_raceway_hz"], rel=2e-3)
    assert f["ball_defect_hz"] == pytest.approx(counted["ball_defect_hz"], rel=2e-3)
    assert f["ball_defect_hz"] == pytest.approx(2 * f["ball_spin_hz"], rel=1e-12)


@pytest.mark.parametrize("defect", ["raceway", "ball_defect"])
def test_a_tone_at_the_counted_frequency_is_named(defect):
    """Impulses at the counted event rate (a spall struck once per event), in noise: the spectrum test names
    the defect from the monitor's frequencies. A frequency twice or half the kinematic one names nothing
    or the other defect."""
    from guide_health.models.rolling import vibration as vib

    fs, n, speed = 25600.0, 32768, 1.0
    kin = vib.GuideKinematics(BALL_D_M, PITCH_M, LOOP_M)
    rate_hz = counted_frequencies(speed, kin.contact_angle_rad, duration_s=100.0)[defect + "_hz"]
    t = np.arange(n) / fs
    rng = np.random.default_rng(4)
    phase = (t * rate_hz) % 1.0
    pulses = np.exp(-0.5 * (np.minimum(phase, 1.0 - phase) / (0.02)) ** 2)   # one short pulse per event
    x = 0.5 * rng.standard_normal(n) + 2.0 * (pulses - pulses.mean())
    freq, psd = vib.welch_psd(x, fs, segment=n)
    assert vib.name_tone(freq, psd, vib.defect_frequencies(kin, speed)) == defect


# --- the fleet prior's REML --------------------------------------------------------------------------------
def reml_by_contrasts(y, s) -> tuple[float, float]:
    """(tau, mu): the restricted likelihood as the likelihood of the n - 1 error contrasts z = K'y, K an
    orthonormal basis of the complement of the mean (Harville 1974), z ~ N(0, K' diag(tau^2 + s^2) K),
    maximised over tau with scipy on a grid then a bounded search; mu the GLS mean at that tau."""
    from scipy.linalg import null_space
    from scipy.optimize import minimize_scalar
    from scipy.stats import multivariate_normal

    y, s = np.asarray(y, float), np.asarray(s, float)
    contrasts = null_space(np.ones((1, y.size)))
    z = contrasts.T @ y

    def minus_loglik(tau):
        cov = contrasts.T @ np.diag(tau * tau + s * s) @ contrasts
        return -multivariate_normal(np.zeros(z.size), cov).logpdf(z)

    grid = np.linspace(0.0, 5.0 * (np.ptp(y) + s.max()), 401)
    i = int(np.argmin([minus_loglik(t) for t in grid]))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    best = minimize_scalar(minus_loglik, bounds=(lo, hi), method="bounded", options={"xatol": 1e-9})
    # the boundary wins a tie within rounding: at tau ~ 1e-8 the likelihood equals tau = 0's to an ulp, and which
    # side rounds lower depends on the BLAS (a tie was read as an interior maximum with numpy 2.4)
    tau = 0.0 if minus_loglik(0.0) <= best.fun + 1e-12 * abs(best.fun) else float(best.x)
    w = 1.0 / (tau * tau + s * s)
    return tau, float(np.sum(w * y) / np.sum(w))


def reml_by_fixed_point(y, s, iterations=2000) -> float:
    """tau by the REML estimating equation (Viechtbauer 2005, Eq. 10), iterated to its fixed point:
    tau^2 = sum w^2 ((y - mu)^2 - s^2) / sum w^2 + 1 / sum w, truncated at 0."""
    y, s = np.asarray(y, float), np.asarray(s, float)
    tau2 = float(np.var(y))
    for _ in range(iterations):
        w = 1.0 / (tau2 + s * s)
        mu = np.sum(w * y) / np.sum(w)
        tau2 = max(0.0, float(np.sum(w * w * ((y - mu) ** 2 - s * s)) / np.sum(w * w) + 1.0 / np.sum(w)))
    return math.sqrt(tau2)


@pytest.mark.parametrize("seed", range(4))
def test_random_effects_fit_maximises_the_restricted_likelihood(seed):
    """Unequal standard errors (no closed form): the package's tau and mu equal the contrasts' maximum and
    the estimating equation's root. ML instead of REML (no log sum w term) gives a tau ~ sqrt((n-1)/n)
    smaller: 7 % at n = 8, far outside the 1e-3 here."""
    from guide_health.models.fleet import random_effects_fit

    rng = np.random.default_rng(seed)
    s = rng.uniform(0.05, 0.3, 8)
    y = -12.0 + rng.normal(0.0, 0.3, 8) + rng.normal(0.0, s)
    tau, mu = reml_by_contrasts(y, s)
    assert tau > 0.05                                   # an interior maximum for these draws
    fit = random_effects_fit(y, s)
    assert fit.tau == pytest.approx(tau, rel=1e-3)
    assert fit.tau == pytest.approx(reml_by_fixed_point(y, s), rel=1e-3)
    assert fit.mean == pytest.approx(mu, abs=1e-4)
    w = 1.0 / (tau * tau + s * s)
    assert fit.mean_std_error == pytest.approx(1.0 / math.sqrt(np.sum(w)), rel=1e-3)


def test_random_effects_fit_at_the_boundary():
    """Estimates closer together than their errors: the restricted likelihood is largest at tau = 0."""
    from guide_health.models.fleet import random_effects_fit

    y, s = [0.10, 0.12, 0.05, 0.08], [0.2, 0.3, 0.25, 0.4]
    assert reml_by_contrasts(y, s)[0] == 0.0 and reml_by_fixed_point(y, s) == 0.0
    fit = random_effects_fit(y, s)
    w = 1.0 / np.square(s)
    assert fit.tau == 0.0 and fit.mean == pytest.approx(float(np.sum(w * np.array(y)) / np.sum(w)), rel=1e-12)


# --- node level: WARN held inside the clear band ---------------------------------------------------------
rclpy = pytest.importorskip("rclpy")
from geometry_msgs.msg import WrenchStamped  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402


def test_wear_monitor_straightness_warn_holds_inside_the_clear_band(ros_context, tmp_path):
    """The straightness stays put (no input between periods); the WARN threshold
    (straightness_warn_fraction x limit, a dynamic parameter) moves: 1 % below the value -> WARN; 2 % above
    it (the value inside the 5 % clear band) -> still WARN; 10 % above -> OK."""
    from test_wear_monitor_node import feed_cycle, make_node

    node = make_node(ros_context, tmp_path, input_timeout_s=600.0, life_warn_h=1e-6, life_error_h=0.0)
    try:
        feed_cycle(node, 1_700_000_001.0)
        node.publish_diagnostics()
        status = node.published[-1].status[0]
        values = {kv.key: kv.value for kv in status.values}
        a_um, limit_um = float(values["straightness_um"]), float(values["straightness_limit_um"])
        assert status.level == bytes([OK]) and a_um < 0.8 * limit_um, status.message
        levels = []
        for threshold_over_value in (1 / 1.01, 1 / 0.98, 1 / 0.90, 1 / 0.98):
            fraction = a_um * threshold_over_value / limit_um
            assert all(r.successful for r in node.set_parameters([Parameter("straightness_warn_fraction",
                                                                             value=fraction)]))
            node.publish_diagnostics()
            levels.append(node.published[-1].status[0].level[0])
            assert float({kv.key: kv.value for kv in node.published[-1].status[0].values}["straightness_um"]) == a_um
        assert levels == [WARN, WARN, OK, OK]
    finally:
        node.close()
        node.destroy_node()


def test_slewing_monitor_p_max_warn_holds_inside_the_clear_band(ros_context):
    """Axial loads chosen (with the node's own contact model) so that p_max is 1.01, 0.98, 0.90 and 0.98 of
    the WARN threshold (0.8 x 4000 MPa): WARN, WARN (inside the 5 % clear band), OK, OK."""
    from scipy.optimize import brentq

    from guide_health.nodes.slewing_monitor import SlewingMonitorNode

    node = SlewingMonitorNode(context=ros_context, parameter_overrides=[Parameter("input_timeout_s", value=600.0)])
    published = []
    node.diag_pub.publish = published.append
    try:
        model = node.core.model
        threshold_mpa = model.warn_fraction * model.allowable_pa * 1e-6
        assert threshold_mpa == pytest.approx(3200.0)

        def p_max_mpa(axial_n):
            return model.report_for_loads(axial_n, 0.0, 0.0)["p_max_MPa"]

        levels = []
        for ratio in (1.01, 0.98, 0.90, 0.98):
            axial_n = brentq(lambda f, r=ratio: p_max_mpa(f) - r * threshold_mpa, 1e5, 2e8, xtol=1.0)
            wrench = WrenchStamped()
            wrench.wrench.force.z = float(axial_n)
            node._on_load(wrench)
            node.publish_diagnostics()
            status = published[-1].status[0]
            p_max = float({kv.key: kv.value for kv in status.values}["p_max_MPa"])
            assert p_max == pytest.approx(ratio * threshold_mpa, rel=1e-4)
            levels.append(status.level[0])
        assert levels == [WARN, WARN, OK, OK]
    finally:
        node.destroy_node()
