"""The input rules (models/wear/input_rules.py) are one set of rules: the live feed, the offline monitor and
the duty cells of the discrepancy workflow accept the same samples, integrate each joint sample with the
same load and count the same rejections.

Live samples arrive in a time-consistent order: every accepted load stamped at or before an accepted joint
sample arrives before it, every later accepted load after it (the order a header-stamp merge gives; the
stamp-aligned feed exists for the other orders). Measurements arrive after the joint samples stamped at
or before them.
"""
from __future__ import annotations

import math
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from guide_health.analysis.discrepancy.duty import DutyCellAccumulator
from guide_health.models.wear.feed import StampAlignedFeed
from guide_health.models.wear.input_rules import (
    JOINT_TIME_BACKWARDS,
    LOAD_TIME_BACKWARDS,
    MEASUREMENT_ALREADY_APPLIED,
    NEGATIVE_STRAIGHTNESS,
    NON_FINITE_JOINT,
    NON_FINITE_LOAD,
    NON_FINITE_STRAIGHTNESS,
    STRAIGHTNESS_TIME_BACKWARDS,
    InputLimits,
    RejectionCounter,
    accept_joint_samples,
    accept_load_samples,
    accept_straightness_samples,
    check_joint_sample,
    check_load_sample,
    check_straightness_sample,
    load_at_joint_samples,
)
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.params import wear_monitor_params
from guide_health.params.typed import wear_axis_params
from guide_health.runs import MachineRun

ROOT = Path(__file__).resolve().parents[1]
PARAMS = wear_monitor_params(ROOT / "config" / "bench_000.yaml")
LIMITS = InputLimits.from_params(wear_axis_params(PARAMS))
T0_NS = 1_700_000_000_000_000_000
MS = 1_000_000
NAN, INF = math.nan, math.inf

# every kind of bad sample, stamps in ms from T0
JOINTS = [  # t, position [m], velocity [m/s]
    (0, 0.100, 0.0), (10, 0.101, 0.1),        # before the first load: distance counts, wear does not
    (20, 0.102, 0.1), (30, NAN, 0.1), (40, INF, 0.1), (50, 0.104, NAN),
    (60, 0.106, 0.1), (60, 0.107, 0.1),       # duplicate stamp
    (55, 0.108, 0.1),                         # backwards
    (70, 0.105, -0.1), (80, 0.103, -0.1), (90, -INF, -0.1), (100, 0.101, -0.1), (110, 0.103, 0.1),
    (120, 0.106, 0.1)]
LOADS = [  # t, force.z [N]
    (15, 1000.0), (25, -50.0),                # a reverse (lift-off) load: accepted
    (35, NAN), (45, 3000.0),
    (45, 3500.0),                             # duplicate stamp
    (40, 3200.0),                             # backwards
    (65, INF), (75, 2000.0),
    (105, -INF),                              # rejected: its stamp does not block the next load
    (95, 0.0), (115, 4000.0)]
STRAIGHTNESS = [  # t, straightness [m]
    (50, 16e-6), (50, 16.5e-6),                # the same stamp: the same measurement, applied once
    (40, 17e-6), (70, NAN), (80, -1e-6), (90, 18e-6), (120, 19e-6)]

EXPECTED_JOINT_MS = [0, 10, 20, 60, 70, 80, 100, 110, 120]
EXPECTED_LOAD_AT_JOINT = [NAN, NAN, 1000.0, 3000.0, 3000.0, 2000.0, 0.0, 0.0, 4000.0]
EXPECTED_REJECTED = {NON_FINITE_JOINT: 4, JOINT_TIME_BACKWARDS: 2, NON_FINITE_LOAD: 3,
                     LOAD_TIME_BACKWARDS: 2, NON_FINITE_STRAIGHTNESS: 1, NEGATIVE_STRAIGHTNESS: 1,
                     STRAIGHTNESS_TIME_BACKWARDS: 1, MEASUREMENT_ALREADY_APPLIED: 1}
EXPECTED_DISTANCE_M = 0.016                  # 1 + 1 + 4 + 1 + 2 + 2 + 2 + 3 mm
EXPECTED_WORK_NM = 32.0                      # 1000*1 + 3000*4 + 3000*1 + 2000*2 + 0 + 0 + 4000*3 mm


def machine_run(joints, loads, meas, velocity=True) -> MachineRun:
    def col(rows, i, dtype=float):
        return np.array([r[i] for r in rows], dtype=dtype)

    def stamps(rows):
        return T0_NS + col(rows, 0, np.int64) * MS if rows else np.zeros(0, np.int64)

    return MachineRun("x", stamps(joints), col(joints, 1), col(joints, 2) if velocity else np.zeros(0),
                      stamps(loads), col(loads, 1), stamps(meas), col(meas, 1))


def record_integration(monitor: PrecisionMonitor) -> list:
    """(t_ns, position, load) of every joint sample the monitor's integrator receives."""
    seen = []
    integrator = monitor.integrator
    advance, advance_many = integrator.advance, integrator.advance_many

    def one(t_ns, position_m, load_n):
        seen.append((int(t_ns), float(position_m), float(load_n)))
        advance(t_ns, position_m, load_n)

    def many(t_ns, position_m, load_n):
        seen.extend(zip(np.asarray(t_ns).tolist(), np.asarray(position_m, float).tolist(),
                        np.asarray(load_n, float).tolist()))
        advance_many(t_ns, position_m, load_n)

    integrator.advance, integrator.advance_many = one, many
    return seen


def arrival_order(run: MachineRun) -> list[tuple[str, int]]:
    """("j" | "l" | "s", index) in a time-consistent arrival order (module docstring), each topic in its
    array order; built with the scalar rules."""
    velocity = run.joint_velocity_m_s if run.joint_velocity_m_s.size else np.zeros(run.joint_t_ns.size)
    load_base, accepted_loads = None, []
    for i, (t, w) in enumerate(zip(run.load_t_ns.tolist(), run.load_n.tolist())):
        reason, load_base = check_load_sample(t, w, load_base, LIMITS)
        if reason is None:
            accepted_loads.append((t, i))
    meas_t = np.maximum.accumulate(run.straightness_t_ns).tolist() if run.straightness_t_ns.size else []
    events, li, mi, joint_base = [], 0, 0, None
    for j, (t, x, v) in enumerate(zip(run.joint_t_ns.tolist(), run.joint_position_m.tolist(), velocity.tolist())):
        reason, joint_base = check_joint_sample(t, x, v, joint_base, LIMITS)
        if reason is None:
            while mi < len(meas_t) and meas_t[mi] < t:
                events.append(("s", mi))
                mi += 1
            through = max([i for s, i in accepted_loads if s <= t], default=-1)
            while li <= through:
                events.append(("l", li))
                li += 1
        events.append(("j", j))
    events += [("s", i) for i in range(mi, len(meas_t))] + [("l", i) for i in range(li, run.load_t_ns.size)]
    return events


def live(run: MachineRun, window_s: float):
    """The live path: StampAlignedFeed sample by sample (arrival 1 ms apart), straightness as the node
    handles it (flush, then the monitor), all pending samples flushed at the end."""
    monitor = PrecisionMonitor(wear_axis_params(PARAMS))
    seen = record_integration(monitor)
    feed = StampAlignedFeed(monitor.axis, window_s)
    reasons = []
    velocity = run.joint_velocity_m_s if run.joint_velocity_m_s.size else np.zeros(run.joint_t_ns.size)
    for n, (kind, i) in enumerate(arrival_order(run)):
        now = n * 1e-3
        if kind == "j":
            reasons += feed.joint(int(run.joint_t_ns[i]), float(run.joint_position_m[i]), float(velocity[i]), now)
        elif kind == "l":
            reasons += feed.load(int(run.load_t_ns[i]), float(run.load_n[i]), now)
        else:
            reasons += feed.flush_all()
            reasons.append(monitor.on_straightness(int(run.straightness_t_ns[i]), float(run.straightness_m[i])))
    reasons += feed.flush_all()
    assert Counter(r for r in reasons if r) == Counter(monitor.rejected)   # every rejection reported once
    return monitor, seen


def batch(run: MachineRun):
    monitor = PrecisionMonitor(wear_axis_params(PARAMS))
    seen = record_integration(monitor)
    monitor.process_run(run)
    return monitor, seen


def chunks(run: MachineRun, pieces: int) -> list[MachineRun]:
    """The run cut into consecutive chunks along its arrival order (as a bag is read in log-time order)."""
    events = arrival_order(run)
    cuts = np.linspace(0, len(events), pieces + 1).astype(int)
    out = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        take = {k: [i for kind, i in events[a:b] if kind == k] for k in "jls"}
        j, l_, s = (np.array(take[k], dtype=np.int64) for k in "jls")
        out.append(MachineRun("x", run.joint_t_ns[j], run.joint_position_m[j],
                              run.joint_velocity_m_s[j] if run.joint_velocity_m_s.size else np.zeros(0),
                              run.load_t_ns[l_], run.load_n[l_], run.straightness_t_ns[s], run.straightness_m[s]))
    return out


def duty(runs: list[MachineRun]):
    acc = DutyCellAccumulator(PARAMS["slider_length_m"], limits=LIMITS)
    seen = []
    add_segments = acc._add_segments

    def record(t_ns, position_m, load_n):
        seen.extend(zip(t_ns.tolist(), position_m.tolist(), load_n.tolist()))
        add_segments(t_ns, position_m, load_n)

    acc._add_segments = record
    for run in runs:
        acc.add(run)
    return acc.finish(), seen


def same_samples(a: list, b: list) -> bool:
    """Same stamps, positions and loads (NaN == NaN)."""
    return len(a) == len(b) and all(
        ta == tb and xa == xb and (la == lb or (math.isnan(la) and math.isnan(lb)))
        for (ta, xa, la), (tb, xb, lb) in zip(a, b))


def close(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b)) or math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-300)


def check_paths_agree(run: MachineRun, pieces: int = 3):
    """live (window 0 and 0.5 s) == batch (whole and chunked) == duty cells (whole and chunked)."""
    ref, ref_seen = batch(run)
    est = ref.estimator
    chunked = PrecisionMonitor(wear_axis_params(PARAMS))
    chunked_seen = record_integration(chunked)
    for part in chunks(run, pieces):
        chunked.process_run(part)
    for monitor, seen in (live(run, 0.0), live(run, 0.5), (chunked, chunked_seen)):
        assert same_samples(seen, ref_seen)
        assert dict(monitor.rejected) == dict(ref.rejected)
        assert monitor.integrator.samples == ref.integrator.samples
        assert monitor.load_samples == ref.load_samples
        assert close(monitor.integrator.sliding_distance_m, ref.integrator.sliding_distance_m)
        assert close(monitor.integrator.archard_work_nm, ref.integrator.archard_work_nm)
        assert monitor.estimator.measurement_t_ns == est.measurement_t_ns
        assert monitor.estimator.measurement_m == est.measurement_m
        assert all(map(close, monitor.estimator.measurement_loss_per_k_m, est.measurement_loss_per_k_m))
    for runs in ([run], chunks(run, pieces)):
        cells, seen = duty(runs)
        assert same_samples(seen, ref_seen)
        assert cells.rejected_samples == dict(ref.rejected)
        assert close(cells.total_distance_m, ref.integrator.sliding_distance_m)
        assert close(float(cells.work_nm.sum()), ref.integrator.archard_work_nm)
        meas_t_s = (np.asarray(est.measurement_t_ns, dtype=np.int64) - cells.t0_ns) * 1e-9
        assert cells.measurement_t_s.tolist() == meas_t_s.tolist()
        assert cells.measurement_m.tolist() == est.measurement_m
    return ref, ref_seen


def test_every_path_accepts_the_same_samples_with_the_same_load():
    run = machine_run(JOINTS, LOADS, STRAIGHTNESS)
    monitor, seen = check_paths_agree(run)
    assert [(t - T0_NS) // MS for t, _, _ in seen] == EXPECTED_JOINT_MS
    assert same_samples([(t, x, w) for t, x, w in seen],
                        [(t, x, w) for (t, x, _), w in zip(seen, EXPECTED_LOAD_AT_JOINT)])
    assert dict(monitor.rejected) == EXPECTED_REJECTED
    assert monitor.integrator.sliding_distance_m == pytest.approx(EXPECTED_DISTANCE_M, rel=1e-12)
    assert monitor.integrator.archard_work_nm == pytest.approx(EXPECTED_WORK_NM, rel=1e-12)
    assert [(t - T0_NS) // MS for t in monitor.estimator.measurement_t_ns] == [50, 90, 120]
    assert monitor.load_samples == 6                 # the -50 N lift-off load counts
    cells, _ = duty([run])
    assert cells.segments == 7 and cells.rejected_segments == 1     # one segment before the first load
    assert cells.work_nm.sum() == pytest.approx(EXPECTED_WORK_NM, rel=1e-12)


def test_without_velocities_and_every_chunking():
    run = machine_run(JOINTS, LOADS, STRAIGHTNESS, velocity=False)
    for pieces in (1, 2, 5, 17):
        monitor, _ = check_paths_agree(run, pieces)
    assert monitor.rejected[NON_FINITE_JOINT] == 3            # no velocity: the NaN velocity is gone


def test_scalar_and_vectorised_rules_agree():
    t = np.array([5, 3, 5, 6, 6, 9, 2, 10, 10], dtype=np.int64)
    v = np.array([1.0, 2.0, NAN, 3.0, -1.0, INF, 4.0, 5.0, 0.0])
    for accept, check in ((accept_load_samples, check_load_sample),
                          (accept_straightness_samples, check_straightness_sample)):
        for last in (None, 4, 5):
            result = accept(t, v, last)
            counter, expected = RejectionCounter(), []
            for ti, vi in zip(t.tolist(), v.tolist()):
                reason = check(ti, vi, last)
                reason = reason[0] if isinstance(reason, tuple) else reason
                expected.append(reason is None)
                if reason is None:
                    last = ti
                else:
                    counter.reject(reason)
            assert result.accepted.tolist() == expected
            assert result.rejected == dict(counter)
    joints = accept_joint_samples(t, v, np.zeros(t.size), None)
    assert joints.accepted.tolist() == [True, False, False, True, False, False, False, True, False]
    assert joints.rejected == {NON_FINITE_JOINT: 2, JOINT_TIME_BACKWARDS: 4}
    # the latest load at or before each joint sample, a carried load before the chunk's first
    loads = load_at_joint_samples(np.array([1, 5, 7, 20]), np.array([5, 10]), np.array([100.0, 200.0]), 2, 50.0)
    assert np.isnan(loads[0]) and loads[1:].tolist() == [100.0, 100.0, 200.0]
    assert load_at_joint_samples(np.array([3, 4]), np.array([4]), np.array([9.0]), 2, 50.0).tolist() == [50.0, 9.0]


def test_rejection_counter():
    counter = RejectionCounter()
    assert counter.reject(NON_FINITE_LOAD) == NON_FINITE_LOAD
    counter.count(NON_FINITE_LOAD, 2)
    counter.count(NON_FINITE_LOAD, 0)
    assert counter == {NON_FINITE_LOAD: 3} and counter.total == 3


# --- property-based: arbitrary floats and stamps ---------------------------------------------------
hypothesis = pytest.importorskip("hypothesis")
st = hypothesis.strategies

any_float = st.floats(allow_nan=True, allow_infinity=True)
# values: mostly near the plausibility limits of bench_000 (rail -0.05..0.35 m + 0.1 m margin, load 1e6 N,
# straightness 10 x 100 um), sometimes any float
position = st.one_of(st.floats(-0.2, 0.5), st.sampled_from([-0.15, 0.45, -0.1500001, 0.4500001]), any_float)
load_value = st.one_of(st.floats(-10.0, 2e6), st.sampled_from([0.0, 1e6, 1e6 + 1.0, 1e308]), any_float)
straightness = st.one_of(st.floats(-1e-6, 2e-3), st.sampled_from([0.0, 1e-3, 1.0]), any_float)
# a stamp is mostly a small step from the previous one (duplicates, back and forth), sometimes a jump
# beyond the 1 h horizon (a pause or an outlier) or anywhere
HOUR_MS = 3600 * 1000
stamp_step = st.one_of(st.integers(-3, 5).map(lambda ms: ("step", ms)),
                       st.integers(HOUR_MS - 1, 3 * HOUR_MS).map(lambda ms: ("step", ms)),
                       st.integers(0, 2 ** 62).map(lambda t_ns: ("at", t_ns)))


@st.composite
def bad_runs(draw):
    def topic(values, size: int):
        rows = draw(st.lists(st.tuples(stamp_step, *values), max_size=size))
        t, stamps = T0_NS, []
        for (kind, value), *_ in rows:
            t = t + value * MS if kind == "step" else value
            stamps.append(t)
        columns = [np.array([r[i] for r in rows], dtype=float) for i in range(1, len(values) + 1)]
        return [np.array(stamps, dtype=np.int64)] + columns

    jt, jx, jv = topic((position, any_float), 40)
    lt, lw = topic((load_value,), 25)
    st_, sm = topic((straightness,), 8)
    return MachineRun("x", jt, jx, jv if draw(st.booleans()) else np.zeros(0), lt, lw, st_, sm)


@hypothesis.settings(max_examples=150, deadline=None,
                     suppress_health_check=[hypothesis.HealthCheck.too_slow, hypothesis.HealthCheck.data_too_large])
@hypothesis.given(bad_runs(), st.integers(1, 4))
def test_property_live_equals_batch_equals_duty(run, pieces):
    check_paths_agree(run, pieces)


@hypothesis.settings(max_examples=150, deadline=None,
                     suppress_health_check=[hypothesis.HealthCheck.too_slow, hypothesis.HealthCheck.data_too_large])
@hypothesis.given(bad_runs())
def test_property_a_rejected_sample_changes_no_state(run):
    """Sample by sample in arrival order: no exception, and every rejected sample leaves the saved state
    (and the report's numbers) exactly as they were; every accepted one is within the limits."""
    monitor = PrecisionMonitor(wear_axis_params(PARAMS))
    velocity = run.joint_velocity_m_s if run.joint_velocity_m_s.size else np.zeros(run.joint_t_ns.size)
    for kind, i in arrival_order(run):
        before = repr(monitor.state())
        if kind == "j":
            x = float(run.joint_position_m[i])
            reason = monitor.on_joint(int(run.joint_t_ns[i]), x, float(velocity[i]))
            assert reason is not None or LIMITS.position_min_m <= x <= LIMITS.position_max_m
        elif kind == "l":
            w = float(run.load_n[i])
            reason = monitor.on_load(int(run.load_t_ns[i]), w)
            assert reason is not None or abs(w) <= LIMITS.load_max_n
        else:
            a = float(run.straightness_m[i])
            reason = monitor.on_straightness(int(run.straightness_t_ns[i]), a)
            assert reason is not None or 0 <= a <= LIMITS.straightness_max_m
        if reason is not None:
            assert repr(monitor.state()) == before, reason
    report = monitor.report()
    assert report["rejected_samples"] == monitor.rejected.total
    assert all(math.isfinite(report[k]) or math.isnan(report[k]) or report[k] == math.inf
               for k in ("straightness_um", "remaining_life_h", "wear_coefficient"))


@hypothesis.settings(max_examples=200, deadline=None, derandomize=True)
@hypothesis.given(stamps=st.lists(st.integers(-50, 50), max_size=30),
                  at=st.lists(st.integers(-60, 60), min_size=1, max_size=20))
def test_the_reading_in_force_is_one_rule_for_a_stamp_and_for_an_array(stamps, at):
    """reading_in_force_index (thermal_drift's correction: live per measurement, diagnose vectorised): the
    scalar branch (bisect) and the array branch (searchsorted) agree, and the index is the last reading
    stamped at or before the stamp (-1 before the first; a reading stamped at the measurement counts)."""
    from guide_health.models.wear.input_rules import reading_in_force_index

    readings = sorted(stamps)
    vector = reading_in_force_index(readings, np.asarray(at))
    for a, i in zip(at, vector.tolist()):
        assert reading_in_force_index(readings, a) == i
        before = [j for j, s in enumerate(readings) if s <= a]
        assert i == (before[-1] if before else -1)
