"""Slewing-bearing rating life and static safety per row (models/slewing/rating.py, fatigue.py) against closed
forms written here: ISO 281 roller capacity by hand for the seed 003 bearing (Z = 170, d = 32 mm,
l_e = 31.3 mm, D_pw = 2000 mm), Miner over revolutions, the oscillating-bearing counting below and above the
critical angle, ISO 76 static safety by hand, an overload naming its row."""
import math

import numpy as np
import pytest

from guide_health.models.levels import ERROR, OK
from guide_health.models.slewing.fatigue import SlewingFatigue, critical_amplitude_rad
from guide_health.models.slewing.rating import (
    hardness_factor,
    row_equivalent_loads,
    slewing_ratings,
)
from guide_health.models.slewing.row_loads import axial_row_roller_load_distributions, axial_row_roller_loads

Z, D_MM, L_MM, DPW_MM = 170, 32.0, 31.3, 2000.0
# ISO 281 Table 9 (thrust, alpha = 90 deg): f_c(0.01) = 105.4, f_c(0.02) = 122.9; D/D_pw = 0.016
FC_THRUST = 105.4 + (0.016 - 0.01) / 0.01 * (122.9 - 105.4)
# ISO 281 Table 7 (radial): f_c(0.01) = 52.1, f_c(0.02) = 60.8
FC_RADIAL = 52.1 + (0.016 - 0.01) / 0.01 * (60.8 - 52.1)
C_AXIAL = 1.0 * FC_THRUST * L_MM ** (7 / 9) * Z ** 0.75 * D_MM ** (29 / 27)      # ISO 281 Eq. (11), b_m = 1.0
C_RADIAL = 1.1 * FC_RADIAL * L_MM ** (7 / 9) * Z ** 0.75 * D_MM ** (29 / 27)     # ISO 281 Eq. (7), b_m = 1.1
C0_AXIAL = 220.0 * Z * L_MM * D_MM                                              # ISO 76, alpha = 90 deg
C0_RADIAL = 44.0 * (1 - D_MM / DPW_MM) * Z * L_MM * D_MM                          # ISO 76, radial roller
#: static hardness factor at 55 HRC: (HV_55 / HV_58)^2, HV = (223 HRC + 14500) / (100 - HRC) (Schlecht)
F0H_55 = ((223 * 55 + 14500) / 45 / ((223 * 58 + 14500) / 42)) ** 2


def ratings(hrc=58.0):
    return slewing_ratings(Z, Z, D_MM * 1e-3, L_MM * 1e-3, DPW_MM * 1e-3, hrc)


def rotate(fatigue, revolutions, steps_per_rev=720, t0=0.0, dt=1.0):
    n = int(revolutions * steps_per_rev)
    for k in range(n + 1):
        fatigue.on_angle(2 * math.pi * k / steps_per_rev, t0 + k * dt)


def test_capacities_equal_iso281_and_iso76_by_hand():
    r = ratings()
    assert C_AXIAL == pytest.approx(3.287e6, rel=1e-3)   # the docs/slewing.md worked example
    assert r.dynamic_n["upper_axial"] == pytest.approx(C_AXIAL, rel=1e-12)
    assert r.dynamic_n["lower_axial"] == pytest.approx(C_AXIAL, rel=1e-12)
    assert r.dynamic_n["radial"] == pytest.approx(C_RADIAL, rel=1e-12)
    assert r.static_n["upper_axial"] == pytest.approx(C0_AXIAL, rel=1e-12)
    assert r.static_n["radial"] == pytest.approx(C0_RADIAL, rel=1e-12)
    soft = ratings(55.0)                                  # (55/58)^3.6 on C; (HV_55 / HV_58)^2 on C0
    assert soft.dynamic_n["upper_axial"] == pytest.approx(C_AXIAL * (55 / 58) ** 3.6, rel=1e-12)
    assert (223 * 58 + 14500) / 42 == pytest.approx(653.19, abs=0.01)   # HV_58
    assert soft.static_n["radial"] == pytest.approx(C0_RADIAL * F0H_55, rel=1e-12)
    assert soft.static_n["upper_axial"] == pytest.approx(C0_AXIAL * 0.8291, rel=1e-4)    # (594.78/653.19)^2
    assert hardness_factor(62.0) == 1.0 and ratings(62.0).static_n["radial"] == pytest.approx(C0_RADIAL, rel=1e-12)


def test_constant_axial_load_over_n_revolutions_gives_n_over_l10():
    fatigue = SlewingFatigue(ratings())
    fatigue.on_loads(5.0e5, 0.0, 0.0)
    rotate(fatigue, 3)
    l10 = 1e6 * (C_AXIAL / 5.0e5) ** (10 / 3)             # ISO 281: million revolutions
    level, _, values = fatigue.report()
    assert values["fatigue_damage_upper_axial"] == pytest.approx(3 / l10, rel=1e-9)
    assert values["fatigue_damage_lower_axial"] == 0.0 and values["fatigue_damage_radial"] == 0.0
    assert values["fatigue_governing_row"] == "upper_axial" and level == OK
    elapsed_s = 3 * 720 * 1.0
    assert values["fatigue_remaining_life_upper_axial_h"] == pytest.approx(
        elapsed_s * (l10 / 3 - 1) / 3600, rel=1e-9)
    # the direction of rotation does not matter; a radial load alone loads the radial row with P = F_r
    back = SlewingFatigue(ratings())
    back.on_loads(0.0, 2.0e5, 0.0)
    for k in range(2 * 720 + 1):
        back.on_angle(-2 * math.pi * k / 720)
    assert back.row_damage()["radial"] == pytest.approx(2 / ((C_RADIAL / 2.0e5) ** (10 / 3) * 1e6), rel=1e-9)


def test_load_reversal_moves_the_damage_to_the_other_axial_row():
    fatigue = SlewingFatigue(ratings())
    fatigue.on_loads(5.0e5, 0.0, 0.0)
    rotate(fatigue, 1)
    fatigue.on_loads(-4.0e5, 0.0, 0.0)                    # reversal: the lower (retaining) row takes it
    for k in range(1, 2 * 720 + 1):
        fatigue.on_angle(2 * math.pi * (1 + k / 720))
    damage = fatigue.row_damage()
    assert damage["upper_axial"] == pytest.approx(1 / ((C_AXIAL / 5.0e5) ** (10 / 3) * 1e6), rel=1e-9)
    assert damage["lower_axial"] == pytest.approx(2 / ((C_AXIAL / 4.0e5) ** (10 / 3) * 1e6), rel=1e-9)


def test_tilting_moment_equivalent_load_is_the_life_mean_of_the_roller_loads():
    """P = Z (mean Q_j^(10/3))^(3/10) over the Z azimuths of seed 003 Eq. 1, written here independently."""
    fa, m = 3.0e5, 4.0e6
    psi = 2 * np.pi * np.arange(Z) / Z
    q = fa / Z + 4 * m / (Z * 2.0) * np.cos(psi)
    p_upper = Z * np.mean(np.clip(q, 0, None) ** (10 / 3)) ** 0.3
    p_lower = Z * np.mean(np.clip(-q, 0, None) ** (10 / 3)) ** 0.3
    loads = row_equivalent_loads(ratings(), fa, 0.0, m)
    assert loads.dynamic_n["upper_axial"] == pytest.approx(p_upper, rel=1e-12)
    assert loads.dynamic_n["lower_axial"] == pytest.approx(p_lower, rel=1e-12)
    assert p_lower > 0 and p_upper > fa                   # the moment lifts rollers off: the lower row works
    upper, lower = axial_row_roller_load_distributions(fa, m, Z, 2.0)
    rows = axial_row_roller_loads(fa, m, Z, 2.0)
    assert upper.max() == pytest.approx(rows.main_row_max_n) and lower.max() == pytest.approx(rows.opposite_row_max_n)


def oscillate(fatigue, amplitude_rad, cycles, per_half=200):
    """phi = A cos(pi k / per_half): starts at +A, `cycles` full cycles, ends at +A."""
    k = np.arange(2 * cycles * per_half + 1)
    for i, phi in enumerate(amplitude_rad * np.cos(np.pi * k / per_half)):
        fatigue.on_angle(float(phi), float(i))


def dg03_oscillating_rating_ratio(swing_deg, rollers):
    """C_osc / C of a roller bearing below the critical angle, NREL DG03 after Rumbarger & Jones 1968:
    (180 deg / phi)^(2/9) Z^0.028, phi the full swing in degrees."""
    return (180.0 / swing_deg) ** (2.0 / 9.0) * rollers ** 0.028


def test_oscillation_below_the_critical_angle_counts_the_dg03_oscillating_rating():
    """theta_crit = 360 deg / Z = 2.12 deg for the axial rows; a 1 deg amplitude (2 deg swing) cycle uses
    1 / L_osc, L_osc = (C_osc / P)^(10/3) 1e6 cycles with C_osc = C (180/2)^(2/9) 170^0.028."""
    fatigue = SlewingFatigue(ratings(), reversal_deadband_rad=1e-3)
    fatigue.on_loads(5.0e5, 0.0, 0.0)
    amp, cycles = math.radians(1.0), 7
    oscillate(fatigue, amp, cycles)
    fatigue.on_angle(amp - 2e-3, 1e6)                     # confirms the last reversal; 2e-3 rad open stroke
    l10 = (C_AXIAL / 5.0e5) ** (10 / 3) * 1e6
    l_osc = (C_AXIAL * dg03_oscillating_rating_ratio(2.0, Z) / 5.0e5) ** (10 / 3) * 1e6
    expected = cycles / l_osc + 2e-3 / (2 * math.pi * l10)
    assert fatigue.strokes == 2 * cycles and fatigue.small_strokes == 2 * cycles
    assert fatigue.row_damage()["upper_axial"] == pytest.approx(expected, rel=1e-6)
    # angle equivalence would count 4 A per cycle: L_osc / L10 = 90 against 45.26 here, half the damage
    assert l_osc / l10 == pytest.approx(45.265, rel=1e-4)
    assert expected > 1.95 * cycles * 4 * amp / (2 * math.pi * l10)


def test_small_oscillation_of_the_radial_row_takes_its_own_roller_count():
    """A radial row of 120 rollers (theta_crit = 360 / 120 = 3 deg; the model takes gamma = 0 for every row): a
    2 deg amplitude is below it for the radial row and above the axial rows' 2.12 deg."""
    r = slewing_ratings(Z, 120, D_MM * 1e-3, L_MM * 1e-3, DPW_MM * 1e-3, 58.0)
    fatigue = SlewingFatigue(r, reversal_deadband_rad=1e-3)
    fatigue.on_loads(0.0, 4.0e5, 0.0)
    amp, cycles = math.radians(2.0), 5
    oscillate(fatigue, amp, cycles)
    fatigue.on_angle(amp - 2e-3, 1e6)
    loads = row_equivalent_loads(r, 0.0, 4.0e5, 0.0)
    p_radial = loads.dynamic_n["radial"]
    l10 = (r.dynamic_n["radial"] / p_radial) ** (10 / 3) * 1e6
    l_osc = (r.dynamic_n["radial"] * dg03_oscillating_rating_ratio(4.0, 120) / p_radial) ** (10 / 3) * 1e6
    assert fatigue.row_damage()["radial"] == pytest.approx(cycles / l_osc + 2e-3 / (2 * math.pi * l10), rel=1e-6)


@pytest.mark.parametrize("amplitude_deg", [3.0, 10.0])
def test_oscillation_above_the_critical_angle_counts_the_angle_travelled(amplitude_deg):
    """theta_crit = 360 deg / 170 = 2.118 deg; 3 and 10 deg are above it: L_osc = L10 (90/theta) cycles, i.e.
    each cycle counts 4 theta of rotation."""
    assert critical_amplitude_rad(Z) == pytest.approx(math.radians(360.0 / 170), rel=1e-12)
    fatigue = SlewingFatigue(ratings())
    fatigue.on_loads(5.0e5, 0.0, 0.0)
    oscillate(fatigue, math.radians(amplitude_deg), 5)
    l10 = (C_AXIAL / 5.0e5) ** (10 / 3) * 1e6
    assert fatigue.strokes == 9 and fatigue.small_strokes == 0   # the last stroke is still open
    assert fatigue.row_damage()["upper_axial"] == pytest.approx(5 / (l10 * 90.0 / amplitude_deg), rel=1e-9)


def test_encoder_noise_at_standstill_makes_no_strokes():
    fatigue = SlewingFatigue(ratings(), reversal_deadband_rad=1e-3)
    fatigue.on_loads(5.0e5, 0.0, 0.0)
    rng = np.random.default_rng(3)
    for i, phi in enumerate(1.0 + rng.uniform(-4e-4, 4e-4, 2000)):    # peak to peak 0.8e-3 < deadband
        fatigue.on_angle(float(phi), float(i))
    assert fatigue.strokes == 0
    # only new ground counts: the damage is at most that of the noise band (8e-4 rad), not its 2000 steps
    l10 = (C_AXIAL / 5.0e5) ** (10 / 3) * 1e6
    assert fatigue.row_damage()["upper_axial"] <= 8e-4 / (2 * math.pi * l10)


def test_static_safety_factor_equals_iso76_by_hand():
    fa, fr, m = 5.0e5, 1.0e5, 2.0e6
    fatigue = SlewingFatigue(ratings())
    fatigue.on_loads(fa, fr, m)
    q_max = fa / Z + 4 * m / (Z * 2.0)                    # seed 003 Eq. 1, azimuth 0
    s0_axial = 220.0 * L_MM * D_MM / q_max                # C0a / (Z Q_max)
    s0_radial = C0_RADIAL / fr
    level, _, values = fatigue.report()
    assert values["static_safety_factor"] == pytest.approx(min(s0_axial, s0_radial), rel=1e-12)
    assert values["static_safety_row"] == ("upper_axial" if s0_axial < s0_radial else "radial")
    assert level == OK
    fatigue.on_loads(fa, fr, 0.2 * m)                     # a milder sample keeps the worst one
    assert fatigue.report()[2]["static_safety_factor"] == pytest.approx(min(s0_axial, s0_radial), rel=1e-12)


def test_overload_above_the_static_capacity_is_an_error_naming_the_row():
    fatigue = SlewingFatigue(ratings())
    fatigue.on_loads(5.0e5, 0.0, 0.0)
    assert fatigue.report()[0] == OK
    fatigue.on_loads(-1.2 * C0_AXIAL, 0.0, 0.0)          # lifting load 20 % above C0a: the retaining row
    level, message, values = fatigue.report()
    assert level == ERROR and "lower_axial" in message and "static overload" in message
    assert values["static_safety_factor"] == pytest.approx(1 / 1.2, rel=1e-12)
    radial = SlewingFatigue(ratings())
    radial.on_loads(1e5, 1.1 * C0_RADIAL, 0.0)
    level, message, _ = radial.report()
    assert level == ERROR and "radial row" in message


def test_limiting_load_curve_from_a_table():
    curve = ((0.0, 1.0e6, 2.0e6), (6.0e6, 5.0e6, 3.0e6))
    fatigue = SlewingFatigue(ratings(), limiting_curve=curve)
    fatigue.on_loads(1.5e6, 0.0, 2.0e6)                   # M_lim(1.5e6) = 4e6 -> safety 2
    assert fatigue.report()[2]["limiting_curve_safety"] == pytest.approx(2.0, rel=1e-12)
    fatigue.on_loads(1.5e6, 0.0, 5.0e6)                   # 4e6 / 5e6 = 0.8 < 1: ERROR
    level, message, values = fatigue.report()
    assert values["limiting_curve_safety"] == pytest.approx(0.8, rel=1e-12)
    assert level == ERROR and "limiting load curve" in message


def test_bad_input_is_a_one_line_value_error():
    fatigue = SlewingFatigue(ratings())
    with pytest.raises(ValueError, match="finite"):
        fatigue.on_angle(math.nan)
    with pytest.raises(ValueError, match="finite"):
        fatigue.on_loads(math.inf, 0.0, 0.0)
    with pytest.raises(ValueError, match="f_c table"):
        slewing_ratings(Z, Z, 0.032, 0.0313, 0.2)        # D/D_pw = 0.16 outside the tabulated range


def test_node_takes_the_axis_angle_and_publishes_damage_and_static_safety(ros_context):
    """The node in-process: one load, the axis turned 2 revolutions on `axis_topic` -> damage 2 / L10 of the
    upper row with the default 55 HRC reduction; a JointState without the joint is counted, not used."""
    from geometry_msgs.msg import WrenchStamped
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import JointState

    from guide_health.nodes.slewing_monitor import SlewingMonitorNode

    # fed in stamp order here: on arrival (no wait for a load stamped after the last angle)
    node = SlewingMonitorNode(context=ros_context,
                              parameter_overrides=[Parameter("input_align_window_s", value=0.0)])
    published = []
    node.diag_pub.publish = published.append
    try:
        msg = WrenchStamped()
        msg.wrench.force.z = 5.0e5
        node._on_load(msg)
        for k in range(2 * 36 + 1):
            js = JointState(name=["slew"], position=[2 * math.pi * k / 36])
            js.header.stamp.sec = k
            node._on_axis(js)
        node._on_axis(JointState(name=["other"], position=[0.0]))
        node.publish_diagnostics()
        values = {kv.key: kv.value for kv in published[-1].status[0].values}
        l10 = 1e6 * (C_AXIAL * (55 / 58) ** 3.6 / 5.0e5) ** (10 / 3)
        assert float(values["fatigue_damage_upper_axial"]) == pytest.approx(2 / l10, rel=1e-5)
        assert float(values["fatigue_damage_lower_axial"]) == 0.0
        assert values["fatigue_governing_row"] == "upper_axial"
        assert float(values["static_safety_factor"]) == pytest.approx(C0_AXIAL * F0H_55 / 5.0e5, rel=1e-5)
        assert float(values["rejected_axis_angles"]) == 1
        assert float(values["fatigue_remaining_life_upper_axial_h"]) == pytest.approx(72 * (l10 / 2 - 1) / 3600,
                                                                                      rel=1e-5)
    finally:
        node.destroy_node()


def test_offline_analysis_of_a_run_with_the_axis_angle_gives_the_live_keys():
    """analyse_slewing_run merges loads and axis angles by stamp: F_a = 500 kN until 50 s, then 300 kN;
    2 revolutions in 720 steps at 0.5 + 0.125 k s -> steps 1..395 at 500 kN, 396..720 at 300 kN (the load
    stamped 50 s is in force for the angle stamped 50 s), damage by hand (55 HRC default); equal to a live
    core fed the same samples in stamp order."""
    from guide_health.analysis.slewing_replay import analyse_slewing_run
    from guide_health.models.slewing.monitor import SlewingMonitor
    from guide_health.params import SLEWING_MONITOR_DEFAULTS
    from guide_health.params.typed import slewing_monitor_params
    from guide_health.runs import SlewingLoadRun

    t_load = np.arange(0, 101) * 1_000_000_000
    t_axis = np.arange(0, 721) * 125_000_000 + 500_000_000          # 0.5 s .. 90.5 s, 8 Hz
    angle = 2 * np.pi * np.arange(721) / 360                          # 2 revolutions
    axial = np.where(t_load < 50_000_000_000, 5.0e5, 3.0e5)
    run = SlewingLoadRun(t_ns=t_load, axial_n=axial, radial_n=np.zeros(101),
                         moment_nm=np.zeros(101), axis_t_ns=t_axis, axis_angle_rad=angle)
    _, report = analyse_slewing_run(run, dict(SLEWING_MONITOR_DEFAULTS))
    c = C_AXIAL * (55 / 58) ** 3.6
    expected = 395 / 360 / (1e6 * (c / 5.0e5) ** (10 / 3)) + 325 / 360 / (1e6 * (c / 3.0e5) ** (10 / 3))
    assert report["fatigue_damage_upper_axial"] == pytest.approx(expected, rel=1e-9)
    assert report["fatigue_governing_row"] == "upper_axial" and report["fatigue_level"] == OK
    live = SlewingMonitor(slewing_monitor_params(dict(SLEWING_MONITOR_DEFAULTS)))
    events = sorted([(int(t), 0, i) for i, t in enumerate(t_load)] + [(int(t), 1, j) for j, t in enumerate(t_axis)])
    for t, kind, i in events:
        if kind == 0:
            live.on_loads(float(axial[i]), 0.0, 0.0, t_ns=t)
        else:
            live.on_axis_angle(float(angle[i]), t)
    values = live.period_report()[2]
    for key in ("fatigue_damage_upper_axial", "fatigue_remaining_life_upper_axial_h", "static_safety_factor"):
        assert report[key] == values[key], key
    # a run without the axis keeps the contact report alone (no fatigue keys)
    _, plain = analyse_slewing_run(SlewingLoadRun(t_ns=t_load, axial_n=np.full(101, 5.0e5), radial_n=np.zeros(101),
                                                  moment_nm=np.zeros(101)), dict(SLEWING_MONITOR_DEFAULTS))
    assert "fatigue_damage_upper_axial" not in plain
