"""Property test (issue 10, state): an arbitrarily corrupted state row is either refused with one InputError
line naming the file and what to do, or loaded exactly (the restored monitor's state equals the row, and its
report works); never another exception, never half-loaded. Mutations: a field removed, replaced by any JSON
value (huge integers, NaN/inf, strings, lists, mappings, null), a list lengthened or shortened, a field added,
and the raw JSON text cut or overwritten."""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from guide_health.errors import InputError
from guide_health.io.state_store import StateStore, _encode, resume_monitor
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.models.wear.state_schema import state_fingerprint
from guide_health.params import WEAR_MONITOR_DEFAULTS

hypothesis = pytest.importorskip("hypothesis")
st = hypothesis.strategies
from test_input_rules import PARAMS as RULE_PARAMS  # noqa: E402 - arbitrary runs near the input limits
from test_input_rules import bad_runs  # noqa: E402

from guide_health.params import wear_monitor_params  # noqa: E402
from guide_health.params.typed import wear_axis_params  # noqa: E402

ROLLING_PARAMS = dict(wear_monitor_params(Path(__file__).resolve().parents[1] / "config" / "nsk_lh45.yaml"),
                      joint="x")

PARAMS = dict(WEAR_MONITOR_DEFAULTS, machine_id="m1", joint="x")


def fingerprint(params: dict) -> dict:
    """The saved state's fingerprint of a wear_monitor parameter dict (models/wear/state_schema.py)."""
    return state_fingerprint(params["machine_id"], wear_axis_params(params))


#: every live effect of a model file (docs/model_file.md), the duty and thermal ones included
EFFECTS = {"effects": "running_in,retract_asymmetry,load_exponent,load_along_rail,wear_rate_change,"
                      "lubrication_interval,thermal_drift,stroke_distribution", "stroke_distribution_weight": 0.4,
           "running_in_ratio": 1.5, "running_in_distance_m": 50.0, "retract_wear_factor": 0.6, "load_exponent": 1.3,
           "load_gradient_per_m": 2.0, "load_reference_position_m": 0.2, "wear_rate_change_factor": 1.7,
           "wear_rate_change_stamp_s": 1_700_000_020.0, "lubrication_wear_growth": 1e-3,
           "thermal_drift_m_per_k": 1e-6, "thermal_reference_c": 21.0,
           "effect_covariance": [1e-4 if i % 14 == 0 else 0.0 for i in range(169)]}
EFFECT_PARAMS = dict(PARAMS, **EFFECTS)
EFFECT_RULE_PARAMS = dict(RULE_PARAMS, **EFFECTS)
KEY = "m1/x/precision"
#: restore() takes these from the parameters, not from the state (a user may re-tune them)
FROM_PARAMS = ("prior_wear_coefficient", "prior_rel_sd", "noise_sd_m", "straightness_initial_m")


def populated_state(params: dict = PARAMS) -> dict:
    """A monitor after 40 s of 100 Hz strokes, 2 kN, 4 straightness measurements (fixed inputs); with the
    effects also guide temperatures and a relubrication (its time base)."""
    from guide_health.models.wear.maintenance import relubricate

    monitor = PrecisionMonitor(wear_axis_params(params))
    t0 = 1_700_000_000 * 10**9
    for i in range(4000):
        t = t0 + i * 10**7
        monitor.on_load(t, 2000.0)
        monitor.on_joint(t, 0.2 + 0.1 * math.sin(i / 50), 0.0)
        if i % 100 == 0:
            monitor.on_temperature(t, 20.0 + i * 1e-3)
        if i == 2500 and monitor.effect_wear is not None:
            relubricate(monitor, t)
        if i % 1000 == 999:
            monitor.on_straightness(t, 15.2e-6 + i * 1e-10)
    return monitor.state()


BASE = populated_state()
EFFECT_BASE = populated_state(EFFECT_PARAMS)


def _paths(value, prefix=()):
    """Every path (tuple of keys/indices) into the state, containers included."""
    yield prefix
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(value, list):
        for i, v in enumerate(value[:3]):
            yield from _paths(v, prefix + (i,))


PATHS = [p for p in _paths(BASE) if p]
EFFECT_PATHS = [p for p in _paths(EFFECT_BASE) if p]
json_leaf = st.one_of(st.none(), st.booleans(), st.integers(min_value=-(2**70), max_value=2**70),
                      st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=8),
                      st.sampled_from([0, -1, 1e308, -0.0, 2**63, 2**63 - 1, "nan", "1e-5"]))
json_value = st.recursive(json_leaf, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                             st.dictionaries(st.text(max_size=5), inner, max_size=3)),
                          max_leaves=8)


def _parent(state, path):
    node = state
    for part in path[:-1]:
        node = node[part]
    return node


@st.composite
def corrupted_rows(draw, base: dict = BASE, paths: list = PATHS) -> str:
    state = json.loads(json.dumps(_encode(base)))
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(paths))
        try:
            parent = _parent(state, path)
            current = parent[path[-1]]
        except (KeyError, IndexError, TypeError):
            continue
        kind = draw(st.sampled_from(["replace", "delete", "grow", "shrink", "add"]))
        if kind == "replace":
            parent[path[-1]] = draw(json_value)
        elif kind == "delete":
            del parent[path[-1]]
        elif kind == "grow" and isinstance(current, list):
            current.append(draw(json_value) if draw(st.booleans()) else (current[-1] if current else 0.0))
        elif kind == "shrink" and isinstance(current, list) and current:
            current.pop()
        elif kind == "add" and isinstance(current, dict):
            current[draw(st.text(max_size=6))] = draw(json_value)
    text = json.dumps(state)
    raw = draw(st.sampled_from(["as is", "cut", "overwrite"]))
    if raw == "cut":
        text = text[:draw(st.integers(0, len(text)))]
    elif raw == "overwrite":
        at = draw(st.integers(0, len(text)))
        text = text[:at] + draw(st.text(max_size=4)) + text[at + 4:]
    return text


def _comparable(state: dict) -> str:
    """The state as JSON without what restore takes from the parameters; effect lists of the length before
    stop 11 zero-padded and missing added fields at their defaults, as restore does (STATE_LIST_LENGTHS,
    ADDED_FIELDS); a JSON number by its value (a row's 12494052982552 is restored as the float
    12494052982552.0: the same number)."""
    from guide_health.models.wear.effect_wear import STATE_LIST_LENGTHS
    from guide_health.models.wear.state_schema import ADDED_FIELDS

    state = json.loads(json.dumps(_encode(state)))
    for name in FROM_PARAMS:
        state["estimator"].pop(name, None)
    integrator = state.get("integrator")
    if isinstance(integrator, dict):    # the running clock of a row without it: running since its first sample
        for name, default in (("idle_ns", 0), ("idle_pause_start_ns", []), ("idle_pause_end_ns", []),
                              ("last_motion_t_ns", integrator.get("last_t_ns")),
                              ("last_counted_t_ns", integrator.get("last_t_ns"))):
            integrator.setdefault(name, default)
    effects = state.get("effects")
    if isinstance(effects, dict):
        for name in ("measurement_pass_work_n", "measurement_temperature_offset_k"):   # not kept: NaN each
            effects.setdefault(name, _encode([math.nan] * len(effects.get("measurement_gradients", []))))
        for name, default in ADDED_FIELDS.items():
            effects.setdefault(name, default)

        def pad(values, name):
            return list(values) + [0.0] * (STATE_LIST_LENGTHS[name][0] - len(values))
        effects["work_gradient"] = pad(effects["work_gradient"], "work_gradient")
        effects["buckets"] = [pad(r, "buckets") for r in effects["buckets"]]
        effects["measurement_gradients"] = [pad(r, "measurement_gradients")
                                            for r in effects.get("measurement_gradients", [])]
    return json.dumps(_integral_floats_as_int(state), sort_keys=True)


def _integral_floats_as_int(value):
    if isinstance(value, dict):
        return {k: _integral_floats_as_int(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_integral_floats_as_int(v) for v in value]
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    store = StateStore(tmp_path_factory.mktemp("prop") / "state.db")
    store.save({KEY: BASE}, fingerprint(PARAMS))
    yield store
    store.close()


def test_the_uncorrupted_row_loads_exactly(store):
    monitor = PrecisionMonitor(wear_axis_params(PARAMS))
    assert resume_monitor(store, KEY, fingerprint(PARAMS), monitor)
    assert _comparable(monitor.state()) == _comparable(BASE)
    assert monitor.estimator.count == 4 and monitor.integrator.samples == 4000


@pytest.fixture(scope="module")
def effect_store(tmp_path_factory):
    store = StateStore(tmp_path_factory.mktemp("prop_effects") / "state.db")
    store.save({KEY: EFFECT_BASE}, fingerprint(EFFECT_PARAMS))
    yield store
    store.close()


def test_the_uncorrupted_effects_row_loads_exactly(effect_store):
    monitor = PrecisionMonitor(wear_axis_params(EFFECT_PARAMS))
    assert resume_monitor(effect_store, KEY, fingerprint(EFFECT_PARAMS), monitor)
    assert _comparable(monitor.state()) == _comparable(EFFECT_BASE)
    assert monitor.estimator.count == 4 and len(EFFECT_BASE["temperatures"]["reading_t_ns"]) == 40
    assert EFFECT_BASE["effects"]["last_relubrication_t_ns"] is not None


def test_an_effects_row_without_temperature_offsets_rebuilds_them_from_its_readings(effect_store):
    """A row saved before T - T_ref was kept per measurement: restore rebuilds the offsets from the row's
    temperature readings (finite, one per measurement), and the rest loads exactly."""
    row = json.loads(json.dumps(_encode(EFFECT_BASE)))
    saved = row["effects"].pop("measurement_temperature_offset_k")
    check_refused_with_one_line_or_loaded_exactly(effect_store, EFFECT_PARAMS, json.dumps(row))
    monitor = PrecisionMonitor(wear_axis_params(EFFECT_PARAMS))
    assert resume_monitor(effect_store, KEY, fingerprint(EFFECT_PARAMS), monitor)
    assert monitor.state()["effects"]["measurement_temperature_offset_k"] == pytest.approx(saved, abs=1e-9)


@hypothesis.settings(max_examples=200, deadline=None, derandomize=True,
                     suppress_health_check=[hypothesis.HealthCheck.function_scoped_fixture])
@hypothesis.given(corrupted_rows(EFFECT_BASE, EFFECT_PATHS))
def test_a_corrupted_effects_row_is_refused_with_one_line_or_loaded_exactly(effect_store, text):
    """The same property for a monitor with every live effect (effect sums and gradients, the relubrication
    time base, the temperature readings)."""
    check_refused_with_one_line_or_loaded_exactly(effect_store, EFFECT_PARAMS, text)


@hypothesis.settings(max_examples=400, deadline=None, derandomize=True,
                     suppress_health_check=[hypothesis.HealthCheck.function_scoped_fixture])
@hypothesis.given(corrupted_rows())
def test_a_corrupted_row_is_refused_with_one_line_or_loaded_exactly(store, text):
    check_refused_with_one_line_or_loaded_exactly(store, PARAMS, text)


def check_refused_with_one_line_or_loaded_exactly(store, params: dict, text: str) -> None:
    """``text`` as the saved row of KEY: refused with one InputError line naming the file and what to do, or
    loaded exactly (the monitor's state is the row) with a working report."""
    store._db.execute("UPDATE monitor_state SET state_json = ? WHERE key = ?", (text, KEY))
    monitor = PrecisionMonitor(wear_axis_params(params))
    try:
        resumed = resume_monitor(store, KEY, fingerprint(params), monitor)
    except InputError as exc:
        message = str(exc)
        assert "\n" not in message and str(store.path) in message and "move the file away" in message, message
        return
    assert resumed
    saved = json.loads(text)            # it loaded: the row was valid JSON and is now the monitor's state
    state = monitor.state()
    effects = saved.get("effects")
    if isinstance(effects, dict) and "pass_work_n" not in effects:
        # a row without the pass work: restore estimates it and its bucket column from the mean stroke
        # (GuideWear.restore, effect_wear.estimate_pass_work); everything else loads exactly
        assert state["effects"]["pass_work_n"] >= 0.0
        effects["pass_work_n"], effects["buckets"] = state["effects"]["pass_work_n"], state["effects"]["buckets"]
    if isinstance(effects, dict) and "measurement_temperature_offset_k" not in effects:
        # a row without T - T_ref per measurement: restore rebuilds them from the temperature readings where it
        # holds them (GuideWear.restore, effect_wear.rebuild_temperature_offsets), NaN otherwise
        rebuilt = state["effects"]["measurement_temperature_offset_k"]
        assert len(rebuilt) == len(state["effects"]["measurement_gradients"])
        effects["measurement_temperature_offset_k"] = rebuilt
    if "fit_watch" not in saved:
        # a row without the model-fit test (saved before it existed): restore starts a new test
        assert state["fit_watch"]["innovations"] == 0 and state["fit_watch"]["model_fit"] == "ok"
        saved["fit_watch"] = state["fit_watch"]
    assert _comparable(state) == _comparable(_decode_like_store(saved))
    report = monitor.report()
    assert set(report) >= {"level", "message", "straightness_um"}


def _decode_like_store(value):
    from guide_health.io.state_store import _decode

    return _decode(value)


@pytest.fixture(scope="module")
def round_trip_store(tmp_path_factory):
    """One state file for every example of the round trip: each save replaces KEY's row and fingerprint (an
    upsert in one transaction), so each example restores what it saved (opening a database per example was
    most of an example's time)."""
    store = StateStore(tmp_path_factory.mktemp("round_trip") / "state.db")
    yield store
    store.close()


@hypothesis.settings(max_examples=100, deadline=None,
                     suppress_health_check=[hypothesis.HealthCheck.too_slow, hypothesis.HealthCheck.data_too_large])
@pytest.mark.parametrize("params", [RULE_PARAMS, ROLLING_PARAMS, EFFECT_RULE_PARAMS],
                         ids=["sliding", "rolling", "effects"])
@hypothesis.given(run=bad_runs(), temperatures=st.lists(st.tuples(st.integers(-10**9, 10**11),
                                                                  st.floats(allow_nan=True, allow_infinity=True)),
                                                        max_size=6))
def test_every_state_a_monitor_reaches_is_accepted_and_round_trips(round_trip_store, params, run, temperatures):
    """The other side: whatever inputs a monitor saw (test_input_rules' arbitrary runs: any floats, stamps
    back and forth, jumps, straightness before any stroke; with the effects also any temperature readings),
    the state it saves is accepted by the schema and restores to the same state (a legal state refused would
    stop a restarted node), and its report works."""
    from guide_health.models.wear.maintenance import relubricate

    monitor = PrecisionMonitor(wear_axis_params(params))
    for dt, value in temperatures if params is EFFECT_RULE_PARAMS else ():     # the node checks a rolling
        monitor.on_temperature(1_700_000_000_000_000_000 + dt, value)           # guide's oil temperature first
    if monitor.effect_wear is not None and run.joint_t_ns.size:
        relubricate(monitor, int(run.joint_t_ns[0]))
    monitor.process_run(run)
    monitor.report()
    round_trip_store.save({KEY: monitor.state()}, fingerprint(params))
    again = PrecisionMonitor(wear_axis_params(params))
    assert resume_monitor(round_trip_store, KEY, fingerprint(params), again)
    assert _comparable(again.state()) == _comparable(monitor.state())
