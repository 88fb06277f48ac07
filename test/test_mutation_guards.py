"""Rules the first run of bench/mutation_check.py let through within the tests it runs per module (some
are guarded by slower end-to-end files it leaves out): each checked here against a truth written in this
file (a closed form, a quadrature, a published quantile, a hand count), never computed with the function under
test. Input rules (load cap of a rolling guide, the sample that takes a new time base), the ERROR event count,
params merge order and '/**' under the node's section, integer parameters, the K interval's quantile, the
remaining life with running-in and relubrication, the life interval's K term, rail replacement and
relubrication, a read from a log time, the mcap chunk reader, Hamrock-Dowson's minimum film, combining bags.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from guide_health.models.levels import OK
from guide_health.params.typed import wear_axis_params

K_MAIN, K_SPARE = 4.0e-6, 9.0e-6


# --- input rules: the plausible-load cap and a new time base ---------------------------------------------
def test_rolling_guide_load_cap_is_the_smaller_of_the_two_limits():
    """load_max = min(load_max_n, load_max_rating_multiple x carriages x C) for a rolling guide with a rating
    (3 x 2 x 10 kN = 60 kN); load_max_n alone for a sliding guide."""
    from guide_health.models.wear.input_rules import InputLimits
    from guide_health.params import WEAR_MONITOR_SCHEMA

    p = WEAR_MONITOR_SCHEMA.defaults() | {"guide_type": "rolling", "dynamic_load_rating_n": 1.0e4, "carriages": 2,
                                          "load_max_rating_multiple": 3.0}
    assert InputLimits.from_params(wear_axis_params(p | {"load_max_n": 1.0e6})).load_max_n == 6.0e4
    assert InputLimits.from_params(wear_axis_params(p | {"load_max_n": 5.0e4})).load_max_n == 5.0e4
    sliding = wear_axis_params(p | {"guide_type": "sliding", "load_max_n": 1.0e6})
    assert InputLimits.from_params(sliding).load_max_n == 1.0e6


@pytest.mark.parametrize("rebase_samples", [1, 2, 3])
def test_a_new_time_base_is_taken_at_the_rebase_samples_th_agreeing_jump(rebase_samples):
    """Horizon 1 s, last stamp 0; samples every 0.5 s from 100 s on: the first rebase_samples - 1 are held
    back as candidates (stamp jump), the rebase_samples-th is accepted, the rest follow it in time. The same
    with the scalar (live) and the vectorised (offline) rule."""
    from guide_health.models.wear import input_rules as ir

    ns = ir.NS_PER_S
    limits = ir.InputLimits(stamp_horizon_ns=ns, rebase_samples=rebase_samples)
    stamps = [100 * ns + k * ns // 2 for k in range(5)]
    expected = [ir.JOINT_STAMP_JUMP] * (rebase_samples - 1) + [None] * (6 - rebase_samples)
    base, reasons = ir.StampBase(0), []
    for t in stamps:
        reason, base = ir.check_joint_sample(t, 0.1, 0.0, base, limits)
        reasons.append(reason)
    assert reasons == expected and base.last_t_ns == stamps[-1]
    batch = ir.accept_joint_samples(np.array(stamps), np.full(5, 0.1), np.zeros(0), ir.StampBase(0), limits)
    assert batch.accepted.tolist() == [r is None for r in expected]


def test_an_error_lasting_several_periods_is_one_event():
    """Three periods in ERROR, then OK: one ERROR event (a rise to ERROR), latched, acknowledged as one."""
    from guide_health.models.levels import ERROR, Alarm

    alarm = Alarm()
    for _ in range(3):
        assert alarm.update(ERROR, ERROR, "overstress")[0] == ERROR
    assert alarm.update(OK, OK, "fine")[0] == ERROR                     # latched
    assert alarm.values() == {"alarm_events": 1, "alarm_latched": 1}
    assert alarm.acknowledge() == 1
    assert alarm.update(ERROR, ERROR, "again")[0] == ERROR and alarm.values()["alarm_events"] == 2


# --- parameters: merge order, '/**' under the node's own section, integer types ----------------------------
def params_file(tmp_path, name, sections):
    path = tmp_path / name
    path.write_text(yaml.safe_dump({key: {"ros__parameters": values} for key, values in sections.items()},
                                   sort_keys=False))
    return str(path)


def test_several_params_files_later_wins_offline_and_in_the_ros_args_check(tmp_path):
    from guide_health.params import WEAR_MONITOR_SCHEMA
    from guide_health.params.loader import wear_monitor_params
    from guide_health.params.ros_args import check_ros_args

    base = params_file(tmp_path, "base.yaml", {"wear_monitor": {"wear_coefficient": K_MAIN, "life_warn_h": 400.0}})
    over = params_file(tmp_path, "over.yaml", {"wear_monitor": {"wear_coefficient": K_SPARE}})
    merged = wear_monitor_params([base, over])
    assert (merged["wear_coefficient"], merged["life_warn_h"]) == (K_SPARE, 400.0)
    assert wear_monitor_params([over, base])["wear_coefficient"] == K_MAIN
    node = check_ros_args(WEAR_MONITOR_SCHEMA, ["--ros-args", "--params-file", base, "--params-file", over])
    assert node["wear_coefficient"] == K_SPARE


@pytest.mark.parametrize("wildcard_first", [True, False])
def test_sections_apply_in_file_order_the_later_wins(tmp_path, wildcard_first):
    """'/**' applies to every node; sections apply in file order and the later one wins, as rcl applies them
    (test_params_shopfloor.py compares this order with rcl itself)."""
    from guide_health.params.loader import wear_monitor_params

    sections = {"/**": {"wear_coefficient": 1.0e-6, "life_warn_h": 300.0}, "wear_monitor": {"wear_coefficient": K_MAIN}}
    if not wildcard_first:
        sections = dict(reversed(list(sections.items())))
    p = wear_monitor_params(params_file(tmp_path, "wild.yaml", sections))
    assert (p["wear_coefficient"], p["life_warn_h"]) == ((K_MAIN if wildcard_first else 1.0e-6), 300.0)


def test_true_is_not_an_integer_parameter(tmp_path):
    from guide_health.errors import InputError
    from guide_health.params.loader import wear_monitor_params
    from guide_health.params.schema import coerce_value

    assert coerce_value("carriages", 2, 1) == 2
    with pytest.raises(InputError, match="parameter carriages must be an integer, got True"):
        coerce_value("carriages", True, 1)
    with pytest.raises(InputError, match="carriages must be an integer"):
        wear_monitor_params(params_file(tmp_path, "bool.yaml", {"wear_monitor": {"carriages": True}}))


# --- the K interval's quantile -------------------------------------------------------------------------------
T95_DF2, T95_DF3 = 2.919985580355516, 2.353363434801823     # Student-t 0.95 quantiles (tables)
Z95 = 1.6448536269514722                                    # standard normal 0.95 quantile


def test_the_k_interval_is_90_percent():
    """Conjugate normal update by hand with 1 and 2 measurements (sigma = the configured noise): K +- 1.645 sd;
    from 3 on, sigma from the residuals: Student-t with n - 1 degrees of freedom (2.920, 2.353)."""
    from guide_health.models.wear.calibration import WearCoefficientEstimator

    k0, rel, noise, a0 = 4.42e-6, 0.5, 0.5e-6, 15e-6
    est = WearCoefficientEstimator(k0, rel, noise, a0)
    g, y = [], []
    for j, (g_j, rise) in enumerate([(2.0, 11e-6), (4.0, 19e-6), (6.0, 31e-6), (8.0, 40e-6)], 1):
        est.add(j, a0 + rise, g_j, 0.0)
        g.append(g_j)
        y.append(rise)
        low, k, high = est.interval90()
        if j <= 2:
            precision = 1.0 / (rel * k0) ** 2 + np.dot(g, g) / noise ** 2
            k_hand = (k0 / (rel * k0) ** 2 + np.dot(g, y) / noise ** 2) / precision
            assert k == pytest.approx(k_hand, rel=1e-12)
            assert (high - k, k - low) == pytest.approx((Z95 / math.sqrt(precision),) * 2, rel=1e-9)
        else:
            sd = est.posterior()[1]
            assert (high - k) / sd == pytest.approx({3: T95_DF2, 4: T95_DF3}[j], rel=1e-9)


# --- remaining life with running-in and a relubrication schedule: quadrature against the closed forms -----
def wear_time_by_quadrature(horizon_s, ratio, distance_m, s_now_m, speed_m_s, lubrication=None):
    """int_0^T m(u) (1 + r e^(-(s + v u)/s0)) du / m_w with the multiplier m(u) = max(1 + b tau(u), 0), tau the
    time since the last relubrication (tau_now + u until the first, due at interval - tau_now, then a sawtooth);
    without a schedule m = m_w = 1 and the running-in term alone (scipy quad, breakpoints at the
    relubrications). The running-in term is weighted by m(0), as the package's approximation states."""
    from scipy.integrate import quad

    def running_in(u):
        return ratio * math.exp(-(s_now_m + speed_m_s * u) / distance_m)

    if lubrication is None:
        return horizon_s + quad(running_in, 0.0, horizon_s, limit=200)[0]
    growth, tau_now, interval, window_mean = lubrication
    due = max(interval - tau_now, 0.0)

    def tau(u):
        return tau_now + u if u < due else (u - due) % interval

    starts = [due + k * interval for k in range(int(horizon_s / interval) + 2)]
    cap = -1.0 / growth if growth < 0 else math.inf                    # the multiplier reaches 0 at tau = cap
    kinks = [start + cap for start in starts] + ([cap - tau_now] if cap - tau_now < due else [])
    breaks = sorted(u for u in starts + kinks if 0.0 < u < horizon_s)
    edges = [0.0, *breaks, horizon_s]
    multiplier = sum(quad(lambda u: max(1.0 + growth * tau(u), 0.0), a, b)[0] for a, b in zip(edges, edges[1:]))
    m_now = max(1.0 + growth * tau_now, 0.0) if tau_now < interval else 1.0
    return (multiplier + m_now * quad(running_in, 0.0, horizon_s, limit=200)[0]) / window_mean


@pytest.mark.parametrize("lubrication", [None, (2e-5, 1.0e4, 3.6e4, 1.2), (2e-5, 5.0e4, 3.6e4, 1.1),
                                         (-3e-5, 1.0e4, 3.6e4, 0.9)])
def test_wear_time_and_remaining_life_equal_the_quadrature(lubrication):
    """Running-in ratio 2, s0 = 500 m, 120 m travelled, 0.05 m/s; with a relubrication every 10 h (due in
    7.2 h, overdue, and a multiplier falling with time, clipped at 0 after 9.3 h). Then the remaining life:
    the root of rate x E(T) = margin found here with brentq on the quadrature."""
    from scipy.optimize import brentq

    from guide_health.models.wear.effect_life import remaining_life_with_running_in_s, wear_time_s

    args = (2.0, 500.0, 120.0, 0.05)
    for horizon in (600.0, 2.0e4, 1.5e5):
        assert float(wear_time_s(horizon, *args, lubrication)) == pytest.approx(
            wear_time_by_quadrature(horizon, *args, lubrication), rel=1e-7)
    rate, margin = 1.0e-10, 8.0e-6
    truth = brentq(lambda t: rate * wear_time_by_quadrature(t, *args, lubrication) - margin, 1.0, 1e7, xtol=1e-3)
    assert remaining_life_with_running_in_s(margin, rate, *args, lubrication) == pytest.approx(truth, rel=1e-6)


def test_life_interval_with_only_k_uncertain_is_the_delta_method_on_k():
    """No effect named, no covariance: life = (A_max - A0 - K G l) / (K c) with G the work, l the straightness
    per unit K and work, c the rate per K; its 90 % interval is life x exp(+-1.645 |d ln life / d K| sd_K),
    d ln life / d K = -G l / (A_max - A0 - K G l) - 1 / K (written here)."""
    from guide_health.models.wear.effect_life import EffectLifeNow, life_interval_s
    from guide_health.models.wear.effects.parameters import EffectParameters
    from guide_health.models.wear.effects.registry import RATE_PHI

    e = EffectParameters(effects=())
    n_phi = e.phi().size
    k, k_sd, margin0, work, loss_work, rate_per_k = 4.0e-6, 0.4e-6, 85e-6, 2.0e6, 6.25e-7, 1.875e-4
    now = EffectLifeNow(margin0=margin0, work=work, loss_work=loss_work, loss_pass=0.0,
                        work_gradient=np.zeros(n_phi), dln_rate=np.zeros(len(RATE_PHI)),
                        rate_work_per_k=rate_per_k, s_now=100.0, v_s=0.05)
    centre = (margin0 - k * work * loss_work) / (k * rate_per_k)
    dln = -work * loss_work / (margin0 - k * work * loss_work) - 1.0 / k
    expected = (centre, centre * math.exp(-Z95 * abs(dln) * k_sd), centre * math.exp(Z95 * abs(dln) * k_sd))
    assert life_interval_s(k, k_sd, e, now, Z95) == pytest.approx(expected, rel=1e-3)


def test_life_interval_wider_than_a_float_is_zero_to_infinity_not_an_overflow():
    """The same closed form with sd_K so large that exp(1.645 |d ln life / d K| sd_K) exceeds the largest
    float (and its square too): the interval is (0, inf) around the unchanged centre."""
    from guide_health.models.wear.effect_life import EffectLifeNow, life_interval_s
    from guide_health.models.wear.effects.parameters import EffectParameters
    from guide_health.models.wear.effects.registry import RATE_PHI

    e = EffectParameters(effects=())
    n_phi = e.phi().size
    k, margin0, work, loss_work, rate_per_k = 4.0e-6, 85e-6, 2.0e6, 6.25e-7, 1.875e-4
    now = EffectLifeNow(margin0=margin0, work=work, loss_work=loss_work, loss_pass=0.0,
                        work_gradient=np.zeros(n_phi), dln_rate=np.zeros(len(RATE_PHI)),
                        rate_work_per_k=rate_per_k, s_now=100.0, v_s=0.05)
    centre = (margin0 - k * work * loss_work) / (k * rate_per_k)
    for k_sd in (1.0e3, 1.0e160):       # exp overflow; then the square of the term overflows too
        assert life_interval_s(k, k_sd, e, now, Z95) == (pytest.approx(centre, rel=1e-9), 0.0, math.inf)


# --- maintenance: what each event resets -----------------------------------------------------------------------
def test_rail_replacement_and_relubrication_on_every_guide_of_an_axis():
    """Two-guide rolling axis after 0.5 h: 'replace_rail' for every guide ('' = all) restarts each guide's
    straightness at the measured 12 um with no work since, its K prior the posterior at the event (relative
    sd = sd / K); 'relubricate' restarts the recent boundary share (no travel since: NaN or 0) and keeps
    the whole-history share."""
    from guide_health.models.wear.axis import AxisMonitor
    from guide_health.models.wear.maintenance import MaintenanceEvent, check_event
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    root = Path(__file__).resolve().parents[1] / "config"
    params = dict(wear_monitor_params(root / "nsk_lh45.yaml"), guides=["left", "right"],
                  guide_load_shares=[0.5, 0.5])
    sim = dict(simulation_params(root / "bench_000.yaml"), duration_h=0.5, joint_state_rate_hz=10.0,
               load_rate_hz=1.0)
    model = AxisMonitor(wear_axis_params(params))
    model.process_run(simulate_machine(params, sim, seed=2))
    event = MaintenanceEvent(model.last_t_ns, "replace_rail", "x", "", 12e-6)
    assert check_event(event, ("left", "right"), params["straightness_limit_m"]) is None
    posteriors = {n: g.estimator.posterior(g.measurement_losses_per_k_m()) for n, g in model.guides.items()}
    totals = {n: model.guide_report(n)["boundary_share_total"] for n in model.guides}
    assert all(g.integrator.archard_work_nm > 0 for g in model.guides.values())
    model.schedule(event)
    for name, guide in model.guides.items():
        k, k_sd, _ = posteriors[name]
        assert guide.integrator.archard_work_nm == 0.0
        assert model.guide_report(name)["straightness_um"] == pytest.approx(12.0, rel=1e-9)
        assert guide.estimator.prior_wear_coefficient == k
        assert guide.estimator.prior_rel_sd == pytest.approx(k_sd / k, rel=1e-12)
    model.schedule(MaintenanceEvent(model.last_t_ns, "relubricate", "x"))
    for name, guide in model.guides.items():
        assert guide.rolling.boundary_travel_m == 0.0 and guide.rolling.window_travel_m == 0.0
        assert model.guide_report(name)["boundary_share_total"] == totals[name]


# --- bag readers: a read from a start stamp includes the messages at that stamp ---------------------------------
def test_a_read_from_a_log_time_includes_the_messages_at_it(tmp_path):
    """A 3-minute bench bag (sqlite3): the messages from the log time of a message in the middle on are those
    whose log time is at or after it, in the direct sqlite back end and in rosbags' (checked) alike."""
    from guide_health.io.bag.storage import iter_raw_messages, open_storage
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    cfg = Path(__file__).resolve().parents[1] / "config" / "bench_000.yaml"
    params = wear_monitor_params(cfg)
    sim = dict(simulation_params(cfg), duration_h=0.05, joint_state_rate_hz=5.0, load_rate_hz=1.0)
    write_machine_bag(simulate_machine(params, sim, seed=3), tmp_path / "bag")
    for checked in (False, True):
        with open_storage(tmp_path / "bag", checked=checked) as storage:
            every = [(m.connection.topic, m.log_time_ns, bytes(m.data))
                     for m in iter_raw_messages(storage, storage.connections)]
            start = every[len(every) // 2][1]
            later = [(m.connection.topic, m.log_time_ns, bytes(m.data))
                     for m in iter_raw_messages(storage, storage.connections, start)]
        assert len(every) > 500
        assert later == [m for m in every if m[1] >= start] and later[0][1] == start


def test_mcap_chunk_reader_returns_every_message_whatever_the_batch_size(tmp_path):
    """The packed mcap path (chunk by chunk) and its raw rows against rosbags' reader on the same file: the same log
    times in the same order for batch sizes that leave remainders of every size (1 included: total - 1),
    and every group but the last holds exactly the batch size."""
    from guide_health.io.bag.storage import iter_raw_messages, open_storage
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    cfg = Path(__file__).resolve().parents[1] / "config" / "bench_000.yaml"
    params = wear_monitor_params(cfg)
    sim = dict(simulation_params(cfg), duration_h=0.05, joint_state_rate_hz=5.0, load_rate_hz=1.0)
    write_machine_bag(simulate_machine(params, sim, seed=3), tmp_path / "bag", storage="mcap")
    from rosbags.rosbag2 import Reader

    with Reader(tmp_path / "bag") as reader:
        truth = [t for _, t, _ in reader.messages()]
    with open_storage(tmp_path / "bag") as storage:
        assert [m.log_time_ns for m in iter_raw_messages(storage, storage.connections)] == truth
        for step in (1, 2, 3, 7, 64, len(truth) - 1, len(truth), 10**6):
            groups = list(storage.iter_packed(storage.connections, step))
            times = [int(t) for group in groups for batch in group for t in batch.log_time_ns]
            assert times == truth, step
            sizes = [sum(batch.lengths.size for batch in group) for group in groups]
            assert all(size == step for size in sizes[:-1]) and 0 < sizes[-1] <= step


# --- Hamrock-Dowson minimum film ---------------------------------------------------------------------------------
@pytest.mark.parametrize("ellipticity", [1.0, 3.25, 9.63])
def test_hamrock_dowson_minimum_film_written_out(ellipticity):
    """H_min = 3.63 U^0.68 G^0.49 W^-0.073 (1 - e^(-0.68 k)), h_min = H_min R_x, with E' = 2 E*
    (Hamrock & Dowson 1977): 385 N, u = 0.25 m/s, R_x = 3.3 mm, E* = 115 GPa, eta = 0.1631 Pa s, alpha = 2e-8."""
    from guide_health.models.rolling.lubrication import hamrock_dowson_film

    w, u, rx, e_star, eta, alpha = 385.0, 0.25, 3.3e-3, 115e9, 0.1631, 2.0e-8
    e_prime = 2.0 * e_star
    big_u, big_g, big_w = eta * u / (e_prime * rx), alpha * e_prime, w / (e_prime * rx ** 2)
    h_min = 3.63 * big_u ** 0.68 * big_g ** 0.49 * big_w ** -0.073 * (1.0 - math.exp(-0.68 * ellipticity)) * rx
    h_c = 2.69 * big_u ** 0.67 * big_g ** 0.53 * big_w ** -0.067 * (1.0 - 0.61 * math.exp(-0.73 * ellipticity)) * rx
    assert hamrock_dowson_film(w, u, rx, ellipticity, e_star, eta, alpha) == pytest.approx((h_c, h_min), rel=1e-12)


# --- fleet prior: combining the bags of one machine ----------------------------------------------------------------
def test_bags_of_one_machine_combine_by_inverse_variance():
    """Estimates 1 +- 1 and 3 +- 2: weights 1 and 1/4, mean (1 + 3/4) / (5/4) = 1.4, sd (5/4)^-1/2."""
    from guide_health.models.fleet import combine_estimates

    assert combine_estimates([1.0, 3.0], [1.0, 2.0]) == pytest.approx((1.4, 1.0 / math.sqrt(1.25)), rel=1e-12)
    assert combine_estimates([1.0, math.nan, 3.0], [1.0, 0.5, math.inf]) == pytest.approx((1.0, 1.0))
