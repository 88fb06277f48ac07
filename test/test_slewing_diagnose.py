"""`diagnose` of a slewing bag names the missing raceway-wear effect hidden in the tilting clearances.

The runs are written here, not by the package's simulator: a yaw-like duty (a rotation every few hours) with a
seasonal tilting moment, blocks of small pitch-like oscillations, and a clearance truth summed here motion by
motion from the roller loads of seed 003 Eq. 1 (Q_j = |F_a / Z + 4 M_T cos psi_j / (Z D_pw)|) with a plain
power law Q^n and no chi(Q) weighting (the package's model weights each roller by chi = 1.02-1.05 and starts
from the monitor's own stroke cutting), so the fitter meets a form it does not share."""
from __future__ import annotations

import math

import numpy as np
import pytest

from guide_health.params import SCHEMAS
from guide_health.runs import SlewingLoadRun

YEAR_S = 365.0 * 86400.0
START_NS = 1_700_000_000_000_000_000
Z, D_PW = 170, 2.0                           # the seed-003 bearing (config/slewing_131.32.2000.00Z.yaml's defaults)
C0, NOISE_M = 0.3e-3, 4e-6
SMALL_AMPLITUDE_RAD = math.radians(0.5)      # below theta_crit = 360 deg / 170 = 2.12 deg
PARAMS = SCHEMAS["slewing_monitor"].defaults() | {"tilting_clearance_noise_m": NOISE_M,
                                                  "tilting_clearance_initial_m": C0}


def roller_wear_weight(axial_n: float, moment_nm: float, n: float) -> float:
    """sum_j Q_j^n over the roller pairs of both axial rows (seed 003 Eq. 1), written here."""
    psi = 2.0 * np.pi * np.arange(Z) / Z
    q = np.abs(axial_n / Z + 4.0 * moment_nm * np.cos(psi) / (Z * D_PW))
    return float(np.sum(q ** n))


def make_run(seed: int, n: float = 1.0, small_factor: float = 1.0, offset_m: float = 0.0, readings: int = 24,
             small_blocks: bool = True, constant_mix: bool = False) -> SlewingLoadRun:
    """Two years: a rotation of U(0.2, 1.0) rad every ~12 h; with ``small_blocks`` 20 swings of +-0.5 deg after
    every rotation in the second year's first half (``constant_mix``: after every rotation all along). The
    tilting moment follows the seasons, M_T = 1.5 MN m (1 + 0.8 sin(2 pi t / year)) x lognormal(0.2). Truth:
    c = c_0 + offset + k sum travel x weight (x small_factor in the swings), k scaled for ~0.3 mm in 2 years."""
    rng = np.random.default_rng(seed)
    t, angle = 0.0, 0.0
    load_t, axial, moment, axis_t, axis_angle, wear = [], [], [], [0.0], [0.0], [(0.0, 0.0)]
    total = 0.0
    while t < 2 * YEAR_S:
        t += rng.exponential(12 * 3600.0)
        fa = 6.0e5 * (1.0 + 0.05 * rng.standard_normal())
        mt = 1.5e6 * (1.0 + 0.8 * math.sin(2 * math.pi * t / YEAR_S)) * math.exp(0.2 * rng.standard_normal() - 0.02)
        weight = roller_wear_weight(fa, mt, n)
        load_t.append(t)
        axial.append(fa)
        moment.append(mt)
        rotation = rng.uniform(0.2, 1.0) * rng.choice((-1.0, 1.0))
        for u in (0.5, 1.0):                          # 0.01 rad/s
            axis_t.append(t + u * abs(rotation) / 0.01)
            axis_angle.append(angle + u * rotation)
        angle += rotation
        t += abs(rotation) / 0.01
        total += abs(rotation) * weight
        wear.append((t, total))
        in_block = YEAR_S <= t < 1.5 * YEAR_S
        if small_blocks and (in_block or constant_mix):
            for k in range(20):                        # swings of +-A about the new position, 2 s each
                target = angle + (SMALL_AMPLITUDE_RAD if k % 2 == 0 else -SMALL_AMPLITUDE_RAD)
                swing = abs(target - axis_angle[-1])
                t += 2.0
                axis_t.append(t)
                axis_angle.append(target)
                total += swing * weight * small_factor
            wear.append((t, total))
    times = np.linspace(0, 2 * YEAR_S, readings + 2)[1:-1]
    wear_t, wear_sum = np.array(wear).T
    k_scale = 0.3e-3 / total
    ends = np.searchsorted(wear_t, times, side="right") - 1
    # a reading at standstill: after the motion in progress
    times = np.maximum(times, wear_t[ends] + 1.0)
    truth = C0 + offset_m + k_scale * wear_sum[ends]
    clearance = truth + NOISE_M * rng.standard_normal(readings)
    ns = lambda s: START_NS + np.round(np.asarray(s) * 1e9).astype(np.int64)   # noqa: E731
    return SlewingLoadRun(t_ns=ns(load_t), axial_n=np.array(axial), radial_n=0.02 * np.array(axial),
                          moment_nm=np.array(moment), metadata={}, axis_t_ns=ns(axis_t),
                          axis_angle_rad=np.array(axis_angle), clearance_t_ns=ns(times), clearance_m=clearance)


@pytest.fixture(scope="module")
def diagnose():
    from guide_health.analysis.slewing_diagnose import diagnose_slewing

    return lambda run: diagnose_slewing(run, PARAMS)


def test_clean_run_names_nothing_and_fits_k(diagnose):
    """No hidden effect: nothing named, no unexplained structure, the rms residual near the reading noise."""
    result = diagnose(make_run(1))
    assert result["named_effects"] == [] and not result["unexplained_structure"]["present"]
    assert result["final"]["rms_residual_um"] == pytest.approx(NOISE_M * 1e6, rel=0.4)
    assert 0.05 < result["travel_below_critical_share"] < 0.6
    assert result["critical_amplitude_deg"] == pytest.approx(360.0 / Z, rel=1e-12)


def test_hidden_load_exponent_is_named_with_its_value(diagnose):
    """Wear as Q^1.8 under a seasonal moment: `wear_load_exponent` named alone, n within 3 sd and 0.25 of 1.8
    (chi(Q)'s 1 %/decade is the only difference of form), the baseline's misfit gone."""
    result = diagnose(make_run(2, n=1.8, small_blocks=False))
    assert result["named_effects"] == ["wear_load_exponent"], result["named_effects"]
    e = result["effects"]["wear_load_exponent"]
    assert abs(e["value"] - 1.8) < max(3 * e["sd"], 0.05) and abs(e["value"] - 1.8) < 0.25
    assert result["baseline"]["rss_um2"] > 2 * result["final"]["rss_um2"]      # 1175 -> 340 um^2 (seed 2)
    assert result["final"]["rms_residual_um"] < 1.5 * NOISE_M * 1e6
    assert not result["unexplained_structure"]["present"]


def test_hidden_small_oscillation_wear_is_named_with_its_factor(diagnose):
    """Swings below theta_crit wearing 4x per radian, in half a year only: `small_oscillation_wear` named, a
    within 3 sd of 4."""
    result = diagnose(make_run(3, small_factor=4.0))
    assert result["named_effects"] == ["small_oscillation_wear"], result["named_effects"]
    e = result["effects"]["small_oscillation_wear"]
    assert abs(e["value"] - 4.0) < 3 * e["sd"] and e["sd"] < 1.0


def test_hidden_offset_is_named(diagnose):
    """A bearing that started 40 um wider than configured: `clearance_offset` named, 40 um within 3 sd."""
    result = diagnose(make_run(4, offset_m=40e-6))
    assert result["named_effects"] == ["clearance_offset"], result["named_effects"]
    e = result["effects"]["clearance_offset"]
    assert abs(e["value"] - 40e-6) < 3 * e["sd"] and e["sd"] < 5e-6


def test_small_oscillations_in_a_constant_mix_are_not_separable(diagnose):
    """The same 4x factor, but the swings follow every rotation all along: their travel is a fixed share of
    the whole, so a is not separable from k. Nothing is named; k absorbs the factor and the data fit."""
    result = diagnose(make_run(5, small_factor=4.0, constant_mix=True))
    assert "small_oscillation_wear" not in result["named_effects"]
    assert not result["unexplained_structure"]["present"]


def test_unexplained_structure_is_flagged(diagnose):
    """A clearance that jumps by 60 um half way (a raceway damage, outside the candidates): the residuals stay
    far above the reading noise and the report says so."""
    run = make_run(6, small_blocks=False)
    run.clearance_m[run.clearance_m.size // 2:] += 60e-6
    result = diagnose(run)
    assert result["unexplained_structure"]["present"]
    assert "structure remains unexplained" in result["unexplained_structure"]["message"]


def test_too_few_readings_is_one_line(diagnose):
    with pytest.raises(ValueError, match="at least 4"):
        diagnose(make_run(7, readings=3))


def test_cli_diagnose_of_a_slewing_bag(tmp_path, capsys):
    """`guide-health diagnose BAG --params slewing.yaml`: a slewing bag goes to the slewing workflow; report.json
    and report.md are written and the text names the effect."""
    import json

    from guide_health.cli.app import main
    from guide_health.io.bag.writer import write_slewing_bag

    bag = write_slewing_bag(make_run(2, n=1.8, small_blocks=False), tmp_path / "yaw")
    params = tmp_path / "slewing.yaml"
    params.write_text(f"slewing_monitor:\n  ros__parameters:\n    tilting_clearance_noise_m: {NOISE_M}\n"
                      f"    tilting_clearance_initial_m: {C0}\n")
    assert main(["diagnose", str(bag), "--params", str(params), "--out", str(tmp_path / "d")]) == 0
    out = capsys.readouterr().out
    report = json.loads((tmp_path / "d" / "report.json").read_text())
    assert report["kind"] == "slewing" and report["named_effects"] == ["wear_load_exponent"]
    assert "named: wear_load_exponent" in out and (tmp_path / "d" / "report.md").exists()


def test_an_effect_within_3_sd_of_no_effect_is_not_named_and_the_model_drops_it(diagnose):
    """The 3-sd rule on its own: a selection that put `clearance_offset` in (BIC alone) while its delta lies
    within 3 sd of 0 ends as not separable, and the final model is refitted without it."""
    from guide_health.analysis.discrepancy.selection import SelectionResult
    from guide_health.analysis.slewing_diagnose import SlewingProblem, _result, watch_record
    from guide_health.models.slewing.raceway_wear import sliding_weight_table
    from guide_health.params.typed import slewing_monitor_params

    p = slewing_monitor_params(PARAMS)
    record, replay = watch_record(make_run(1), PARAMS)
    problem = SlewingProblem(record, sliding_weight_table(p.roller_length_m, p.roller_diameter_m,
                                                          p.youngs_modulus_pa, p.poisson),
                             p.raceway_diameter_m, p.tilting_clearance_initial_m)
    base, offset = problem.fit(()), problem.fit(("clearance_offset",))
    assert abs(offset.values["delta_m"]) < 3 * offset.sd["delta_m"]            # 0.6 +- 1.5 um (seed 1)
    selection = SelectionResult(named=["clearance_offset"], baseline=base, final=offset,
                                rounds=[[{"effect": "clearance_offset", "fit": offset, "delta_bic": -11.0}]])
    result = _result(problem, selection, p, replay, 10.0)
    assert result["named_effects"] == [] and result["not_separable"] == ["clearance_offset"]
    assert result["final"]["effects"] == [] and result["final"]["values"]["k"] == base.values["k"]


def test_a_small_oscillation_column_equal_to_the_rest_has_infinite_sd():
    """Every increment alternately in a small and a large stroke at one load (lengths equal to 1e-7): g_small
    = g_large at every reading to 2e-5, so k and a cannot be told apart: the sd are infinite (the columns
    merge), never a number from a near-singular inverse."""
    from guide_health.analysis.slewing_diagnose import SlewingProblem, SlewingRecord
    from guide_health.models.slewing.raceway_wear import axial_roller_loads_n

    n = 200
    record = SlewingRecord(dphi_rad=0.1 * (1.0 + 1e-7 * np.arange(n)), load_index=np.zeros(n, dtype=np.int64),
                           small=np.arange(n) % 2 == 0,
                           roller_loads_n=axial_roller_loads_n(6e5, 1.5e6, Z, D_PW)[None, :],
                           reading_t_ns=np.arange(10), reading_m=C0 + 1e-5 * np.arange(1, 11),
                           reading_travel=np.arange(20, 201, 20), critical_rad=0.037)
    chi = (np.log([10.0, 1e7]), np.array([1.0, 1.0]))
    fit = SlewingProblem(record, chi, D_PW, C0).fit(("small_oscillation_wear",))
    assert math.isinf(fit.sd["a"]) and math.isinf(fit.sd["k"])


def test_a_directory_of_machine_bags_is_a_bag_set_not_a_slewing_bag(tmp_path, capsys):
    """The slewing check comes after the bags are resolved: a directory of two machine bags reaches the bag set's
    own rules (here: they overlap, one line), not 'not a readable rosbag2 bag' from reading the directory as one."""
    from pathlib import Path

    from guide_health.cli.app import main

    bench = str(Path(__file__).resolve().parents[1] / "config" / "bench_000.yaml")
    for name, seed in (("a", "1"), ("b", "2")):
        assert main(["simulate", "--params", bench, "--out", str(tmp_path / "set" / name), "--hours", "0.02",
                     "--seed", seed]) == 0
    capsys.readouterr()
    assert main(["diagnose", str(tmp_path / "set"), "--params", bench, "--out", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err
    assert "bags overlap" in err and "not a readable rosbag2 bag" not in err
