"""The effect registry (models/wear/effects/registry.py) is the one list of effects: every entry appears in each
place derived from it (candidates, simulate's values, live ids, wear_monitor parameters, model-file keys,
covariance rows, saved-state lengths, the older model files' sizes, the report's words, the docs table), and
no module outside the effects package lists effect ids or covariance rows by hand."""
import ast
import math
from pathlib import Path

import numpy as np
import pytest

from guide_health.models.wear.effects import registry
from guide_health.models.wear.effects.parameters import EffectParameters

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "guide_health"
IDS = [e.id for e in registry.EFFECTS]
#: literals that name several covariance rows outside the effects package, and why they may: the bag metadata's
#: record of the simulator's truth is a stored format (its names and order are what bags hold)
ALLOWED_ROW_LISTS: set = set()


def test_ids_are_unique_and_each_has_its_module():
    assert len(set(IDS)) == len(IDS) == len(registry.MODULES)
    for module, effect in zip(registry.MODULES, registry.EFFECTS):
        assert module.__name__.rsplit(".", 1)[-1] == effect.id
        assert effect.term and effect.meaning and effect.separating_duty


def test_candidates_and_simulate_values_are_every_entry():
    from guide_health.analysis.discrepancy.model import _effect_specs  # noqa: F401  (the fit's view)
    from guide_health.sim.machine import EFFECTS as SIMULATED

    assert list(registry.CANDIDATE_IDS) == [e.id for e in registry.EFFECTS if not e.duty] + [
        e.id for e in registry.EFFECTS if e.duty]
    assert sorted(registry.CANDIDATE_IDS) == sorted(IDS) == sorted(SIMULATED)
    assert sorted(registry.EFFECT_VALUE) == sorted(IDS) == sorted(registry.FIT_PARAMETERS)


def test_the_report_words_are_the_registry_s():
    from guide_health.analysis.discrepancy.workflow import EFFECT_MEANING, SEPARATING_DUTY

    assert EFFECT_MEANING == {e.id: e.meaning for e in registry.EFFECTS}
    assert SEPARATING_DUTY == {e.id: e.separating_duty for e in registry.EFFECTS}


def test_every_live_parameter_is_a_wear_monitor_parameter_with_the_registry_s_range():
    from guide_health.params.wear_monitor import WEAR_MONITOR_SCHEMA

    for effect in registry.EFFECTS:
        for p in effect.parameters:
            param = WEAR_MONITOR_SCHEMA[p.name]
            assert (param.default, param.unit, param.range_text or "", param.description) == (
                p.default, p.unit, " | ".join(p.choices) if p.choices else p.range_text, p.meaning), p.name
        for name in effect.fitted_to_file:           # the model file's keys load as wear_monitor parameters
            assert name in WEAR_MONITOR_SCHEMA.by_name, (effect.id, name)
        if effect.requires is not None:
            assert effect.requires.parameter in {p.name for p in effect.parameters}
    # running_in_distance_m: declared once (its module), the schema's and the parameter type's default from it
    assert WEAR_MONITOR_SCHEMA["running_in_distance_m"].default == EffectParameters().running_in_distance_m == 100.0


def test_model_file_keys_and_live_ids_are_derived():
    from guide_health.analysis.discrepancy import model_file

    assert model_file.EFFECT_PARAMETERS == {e.id: e.fitted_to_file for e in registry.EFFECTS
                                            if e.live and e.fitted_to_file}
    assert model_file.MATERIAL_EFFECTS == tuple(e.id for e in registry.EFFECTS if e.material)
    assert set(registry.LIVE_EFFECT_IDS) | {"initial_offset"} == set(IDS)
    assert model_file.not_live_effects(IDS) == []    # initial_offset is folded into A0, the rest are live


def test_covariance_rows_sizes_and_state_lengths_are_derived():
    from guide_health.models.wear.effect_wear import STATE_LIST_LENGTHS
    from guide_health.params.schema import LIST_UPGRADES

    names = registry.COVARIANCE_NAMES
    owned = [r.name for e in registry.EFFECTS for r in e.covariance_rows]
    assert sorted(owned + ["wear_coefficient", "straightness_initial_m"]) == sorted(names)
    assert len(set(names)) == len(names) == 13
    # every live effect has a row (its own or, through fitted_aliases, another's)
    for e in registry.EFFECTS:
        assert e.covariance_rows or any(row in names for _, row in e.fitted_aliases), e.id
    # the model files that exist: 6 x 6, 9 x 9, 10 x 10, 12 x 12, 13 x 13 (today)
    assert registry.COVARIANCE_SIZES == (6, 9, 10, 12, 13)
    assert LIST_UPGRADES["effect_covariance"][0] == (36, 81, 100, 144)
    # the saved live state: phi and bucket rows of each generation (the padding history, derived)
    assert STATE_LIST_LENGTHS["work_gradient"] == STATE_LIST_LENGTHS["measurement_gradients"] == (12, 11, 9, 8, 5)
    assert STATE_LIST_LENGTHS["buckets"] == (11, 10, 7)
    assert tuple(registry.PHI_NAMES[i] for i in registry.RATE_PHI) == registry.RATE_NAMES
    assert registry.BUCKET_SUMS[registry.RATE_SUMS] == tuple(f"d_{n}" for n in registry.RATE_NAMES)


def test_phi_is_the_parameter_type_s_fields_in_row_order():
    e = EffectParameters(running_in_ratio=2.0, retract_wear_factor=0.5, lift_speed_m_s=0.3, load_exponent=1.4,
                         load_gradient_per_m=0.2, wear_rate_change_factor=1.5, lubrication_wear_growth=0.01,
                         stroke_distribution_weight=0.4, thermal_drift_m_per_k=1e-6)
    phi = dict(zip(registry.PHI_NAMES, e.phi()))
    for name, value in phi.items():
        assert value == getattr(e, name, 0.0), name
    assert EffectParameters().phi()[registry.PHI_INDEX["lift_speed_m_s"]] == 0.0     # v_lift inf: no effect


def test_the_live_integration_fills_every_rate_row_by_name():
    """EffectWear's gradient and bucket sums: one column per rate row of the registry, each non-zero when its
    effect acts (a name missing from the live integration would leave its column zero)."""
    from guide_health.models.wear.effect_wear import EffectWear

    e = EffectParameters(effects=tuple(registry.LIVE_EFFECT_IDS), running_in_ratio=1.0, retract_wear_factor=0.5,
                         lift_speed_m_s=0.05, load_exponent=1.3, load_gradient_per_m=0.5, wear_rate_change_factor=2.0,
                         wear_rate_change_time_s=1.0, lubrication_wear_growth=1e-3, stroke_distribution_weight=0.5,
                         slider_length_m=0.05)
    ew = EffectWear(e, duty_bucket_s=10.0, duty_buckets=6)
    t = np.arange(0, 41) * 1_000_000_000
    x = 0.2 * np.abs(((np.arange(41) % 8) - 4) / 4.0)
    ew.add_segments(t[:-1], t[1:], x[:-1], x[1:], np.full(40, 1500.0), np.cumsum(np.abs(np.diff(x))) - np.abs(
        np.diff(x)))
    for name in ("running_in_ratio", "running_in_distance_m") + registry.RATE_NAMES:
        assert ew.work_gradient[registry.PHI_INDEX[name]] != 0.0, name
    sums = ew.window_sums(int(t[-1]))
    for name in registry.BUCKET_SUMS:
        assert sums[registry.SUM_INDEX[name]] != 0.0, name


@pytest.mark.parametrize("doc", ["docs/discrepancy.md", "docs/model_file.md"])
def test_the_docs_carry_the_registry_s_table(doc):
    assert registry.docs_table() in (ROOT / doc).read_text(), f"paste registry.docs_table() into {doc}"


def _hand_lists(tree: ast.AST):
    """(line, assigned name, effect ids, covariance rows) of each literal naming >= 2 effect ids or >= 3 rows."""
    ids, rows = set(IDS), set(registry.COVARIANCE_NAMES) - {"wear_coefficient", "straightness_initial_m"}
    targets = {}
    for node in ast.walk(tree):
        if isinstance(node, (ast.Assign, ast.AnnAssign)):
            for target in (node.targets if isinstance(node, ast.Assign) else [node.target]):
                if isinstance(target, ast.Name):
                    targets[id(node.value)] = target.id
    for node in ast.walk(tree):
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            elts = node.elts
        elif isinstance(node, ast.Dict):
            elts = [k for k in node.keys if k is not None]
        else:
            continue
        words = {e.value for e in elts if isinstance(e, ast.Constant) and isinstance(e.value, str)}
        if len(words & ids) >= 2 or len(words & rows) >= 3:
            yield node.lineno, targets.get(id(node), ""), sorted(words & ids), sorted(words & rows)


def test_no_module_outside_the_registry_lists_effects_by_hand():
    """A tuple, list, set or dict of effect ids (two or more) or covariance rows (three or more) outside
    models/wear/effects/ is a list the registry should derive. EffectWear's named live terms are checked by
    test_the_live_integration_fills_every_rate_row_by_name instead."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        if rel.startswith("models/wear/effects/"):
            continue
        for line, name, ids, rows in _hand_lists(ast.parse(path.read_text())):
            if (rel, name) in ALLOWED_ROW_LISTS or (rel == "models/wear/effect_wear.py" and not ids[1:]):
                continue
            found.append(f"{rel}:{line} {name} {ids or ''} {rows or ''}")
    assert not found, "\n".join(found)


def test_the_hand_list_check_can_fail():
    tree = ast.parse('X = ("running_in", "thermal_drift")\nY = {"running_in_ratio": 1, "load_exponent": 2, '
                     '"lift_speed_m_s": 3}\n')
    assert [n for _, n, _, _ in _hand_lists(tree)] == ["X", "Y"]


def test_simulate_values_set_the_parameter_type_s_fields():
    """Every --effect value lands on a field of EffectParameters (lubrication_interval's b on
    lubrication_wear_growth), the no-effect value leaving the baseline's."""
    for effect in registry.EFFECTS:
        value = effect.simulate
        e = EffectParameters.from_values({effect.id: 0.5})
        field = registry.simulate_field(value.name)
        assert getattr(e, field) == 0.5, effect.id
        base = getattr(EffectParameters(), field)
        assert base == value.no_effect or (math.isinf(value.no_effect) and math.isinf(base)), effect.id


@pytest.mark.parametrize("relubrication_gap_s", [None, 7200.0])
def test_each_candidate_s_plausible_size_sets_its_own_fitted_parameters(relubrication_gap_s):
    """The detectable-size test (analysis/discrepancy/resolution.py) adds each candidate at the plausible size its
    module gives: values of parameters its fit frees on that record (a term's offset may stay free), and a
    positive size."""
    from guide_health.models.wear.effects.base import FitContext

    c = FitContext(total_distance_m=2000.0, feed_speed_m_s=0.05, fit_end_s=20 * 3600.0, position_spread_m=0.3,
                   relubrication_gap_s=relubrication_gap_s, a0_free=False)
    for e in registry.EFFECTS:
        values, size_name, size = e.plausible_strong_size(c)
        assert values and set(values) <= {p.name for p in registry.FIT_PARAMETERS[e.id](c)}, e.id
        assert size_name and size > 0, e.id


def test_consistency_forms_and_the_since_changes_are_the_registry_s():
    """Every alternative form an effect names is a form the consistency check fits; --since's two changes are
    the roles' ids and the reported factor is the rate step's rate row."""
    from guide_health.analysis.discrepancy import consistency, since

    assert registry.CONSISTENCY_ALTERNATIVES
    for effect, forms in registry.CONSISTENCY_ALTERNATIVES.items():
        assert forms and set(forms) <= set(consistency.ALTERNATIVES), effect
        assert effect not in forms
    assert since.CHANGES[1:3] == (registry.INITIAL_TERM.id, registry.RATE_STEP.id)
    assert since.RATE_FACTOR in registry.COVARIANCE_NAMES
    assert registry.RATE_STEP.duty and registry.RATE_STEP.rate_row == since.RATE_FACTOR


def test_the_bag_metadata_names_are_the_stored_format():
    """The bag metadata's ``effect_parameters`` (the simulator's truth) is derived from the effects' ``recorded``
    names; bags have recorded these names in this order, so the derived tuple must stay exactly this."""
    from guide_health.sim.machine import recorded_effect_parameters

    assert registry.RECORDED_EFFECT_PARAMETERS == (
        "running_in_ratio", "running_in_distance_m", "retract_wear_factor", "lift_speed_m_s", "load_exponent",
        "load_reference_n", "stroke_distribution_weight", "thermal_drift_m_per_k", "initial_offset_m",
        "wear_rate_change_factor", "wear_rate_change_time_s", "lubrication_wear_growth_per_s", "load_gradient_per_m",
        "load_reference_position_m")
    recorded = recorded_effect_parameters(EffectParameters.from_values({"lubrication_interval": 2e-5}))
    assert recorded["lubrication_wear_growth_per_s"] == 2e-5 and "lift_speed_m_s" not in recorded   # inf: left out


def test_the_model_file_values_from_the_record_keep_their_order_and_closed_forms():
    """model.yaml's keys are a stored format: the values an effect takes from the record (Effect.file_values,
    record_references) come in the order files have written them, each its closed form: x_ref, t0 + t_c,
    T_ref = T_0 - b / c_T, and the recorded relubrications' growth b, interval 0, t0 + the last one and their
    mean gap; the gauge offset's covariance row is dc_T (T_ref - T_0) + db."""
    from types import SimpleNamespace

    from guide_health.analysis.discrepancy.model_file import model_parameters

    t0_s, c_t, b = 1.7e9, 2.0e-6, 1.0e-6
    problem = SimpleNamespace(a0_free=False, a0_m=10e-6, fit_references={"load_reference_n": 5000.0}, retract_sign=1,
                              cells=SimpleNamespace(t0_ns=int(t0_s * 1e9)), temperature_first_c=21.0,
                              position_ref_m=0.25, relubrication_t_s=np.array([3600.0, 10800.0, 14400.0]))
    values = {"wear_coefficient": 4e-6, "thermal_drift_m_per_k": c_t, "thermal_offset_m": b,
              "wear_rate_change_factor": 2.0, "wear_rate_change_time_s": 7200.0,
              "lubrication_wear_growth_per_s": 3e-5, "load_gradient_per_m": 0.5}
    names = ["wear_coefficient", "thermal_drift_m_per_k", "thermal_offset_m"]
    fit = SimpleNamespace(values=values,
                          extra={"covariance": {"names": names, "matrix": np.diag([1e-14, 1e-14, 4e-14])}})
    named = ["thermal_drift", "wear_rate_change", "lubrication_interval", "load_along_rail"]
    model = model_parameters(problem, fit, named)
    assert list(model) == [
        "wear_coefficient", "straightness_initial_m", "effects", "load_reference_n", "retract_direction",
        "thermal_drift_m_per_k", "wear_rate_change_factor", "load_gradient_per_m", "load_reference_position_m",
        "wear_rate_change_stamp_s", "thermal_reference_c", "lubrication_wear_growth", "lubrication_interval_s",
        "lubrication_reference_stamp_s", "lubrication_forecast_interval_s", "effect_covariance"]
    assert (model["load_reference_n"], model["retract_direction"]) == (5000.0, "+x")
    assert model["load_reference_position_m"] == 0.25 and model["wear_rate_change_stamp_s"] == t0_s + 7200.0
    assert model["thermal_reference_c"] == pytest.approx(21.0 - b / c_t, rel=1e-15)
    assert (model["lubrication_wear_growth"], model["lubrication_interval_s"]) == (3e-5, 0.0)
    assert model["lubrication_reference_stamp_s"] == t0_s + 14400.0
    assert model["lubrication_forecast_interval_s"] == pytest.approx(5400.0, rel=1e-15)
    n = len(registry.COVARIANCE_NAMES)
    cov = np.asarray(model["effect_covariance"]).reshape(n, n)
    e = registry.COVARIANCE_INDEX["thermal_gauge_offset_m"]
    assert cov[e, e] == pytest.approx((b / c_t) ** 2 * 1e-14 + 4e-14, rel=1e-12)      # (-b/c)^2 var c + var b


def test_straightness_without_a_stroke_range_is_nan_without_a_warning():
    """Eq. 7's mean stroke (l_min + l_max) / 2 is undefined before a stroke: the straightness is NaN (as the live
    monitor's), not a division by zero; with a range it is K / (H b) 2 G / (l_min + l_max) at w = 0."""
    import warnings

    from guide_health.models.wear.effects.stroke_distribution import straightness_wear_m

    g, p = np.array([0.0, 2.0e3]), np.array([0.0, 1.0e4])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for stroke_sum_m in (0.0, math.nan):
            assert np.isnan(straightness_wear_m(4e-6, 2e9, 0.01, g, p, stroke_sum_m, 0.5)).all()
    assert straightness_wear_m(4e-6, 2e9, 0.01, g, p, 0.4)[1] == pytest.approx(4e-6 / (2e9 * 0.01) * 2 * 2e3 / 0.4,
                                                                             rel=1e-15)
