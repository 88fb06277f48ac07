"""The typed parameter objects (guide_health/params/typed.py): generated from the schema, so field names,
order and defaults are the schema's exactly; frozen; built and validated in one place; a run-time change gives a
new object. Truth: the schema itself and hand-picked values written here."""
from __future__ import annotations

import dataclasses

import pytest

from guide_health.errors import InputError
from guide_health.params import SCHEMAS
from guide_health.params.machine import AXIS_PARAMS, MACHINE_WIDE
from guide_health.params.typed import (
    TYPED_CLASSES,
    AxisParams,
    GuideParams,
    WearAxisParams,
    as_dict,
    guide_params,
    slewing_monitor_params,
    typed_params,
    vibration_monitor_params,
    wear_axis_params,
    with_changes,
)


def _default(value):
    return tuple(value) if isinstance(value, list) else value


@pytest.mark.parametrize("section", sorted(SCHEMAS))
def test_every_schema_has_a_class_whose_fields_are_its_parameters_with_their_defaults(section):
    cls = TYPED_CLASSES[section]
    fields = dataclasses.fields(cls)
    assert [f.name for f in fields] == [p.name for p in SCHEMAS[section].params]
    assert [f.default for f in fields] == [_default(p.default) for p in SCHEMAS[section].params]
    obj = cls()
    assert as_dict(obj) == SCHEMAS[section].defaults()
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(obj, fields[0].name, fields[0].default)


def test_the_defaults_once_values_the_old_fallbacks_disagreed_with():
    # the schema's values: the old model fallbacks were 0.0 for all three and 0.0 for the wear alarm margin
    p = slewing_monitor_params()
    assert p.log_profile_coeff_m == pytest.approx(0.00035 * 0.032) and p.roller_end_radius_m == 1.0e-3
    assert p.crown_drop_m == 15.0e-6 and p.alarm_clear_margin == 0.05
    assert typed_params("wear_monitor").alarm_clear_margin == 0.05
    assert guide_params({}).oil_temperature_c == 40.0


def test_builders_validate_with_the_loaders_message():
    with pytest.raises(InputError, match="warn_fraction"):
        slewing_monitor_params({"warn_fraction": 1.5})
    with pytest.raises(InputError, match="persist_k must be <= persist_n"):
        vibration_monitor_params({"persist_k": 6, "persist_n": 5})
    loose = typed_params("vibration_monitor", {"load_fraction": 20.0}, validate=False)
    assert loose.load_fraction == 20.0      # read as it is where a command never validated the section


def test_guide_params_hold_the_per_axis_physics_and_lists_as_tuples():
    names = {f.name for f in dataclasses.fields(GuideParams)}
    assert not names & set(MACHINE_WIDE)
    wear = {p.name for p in SCHEMAS["wear_monitor"].params}
    assert names == wear - set(MACHINE_WIDE)
    g = guide_params({"life_factors": [1.0, 0.9, 1.0, 1.2], "carriages": 2, "axis": "x", "joint": "x"})
    assert g.life_factors == (1.0, 0.9, 1.0, 1.2) and g.carriages == 2
    a = AxisParams()
    assert [f.name for f in dataclasses.fields(a)][:len(AXIS_PARAMS)] == [p.name for p in AXIS_PARAMS]


def test_wear_axis_params_hold_a_guides_physics_and_the_axis_of_a_single_joint_section_or_an_axis_dict():
    names = [f.name for f in dataclasses.fields(WearAxisParams)]
    assert names == ([f.name for f in dataclasses.fields(GuideParams)] + [p.name for p in AXIS_PARAMS]
                     + ["axis", "output_prefix", "guide_load_shares", "maintenance_repeat_window_s"])
    single = wear_axis_params({**SCHEMAS["wear_monitor"].defaults(), "joint": "z", "wear_coefficient": 2e-6})
    assert (single.axis, single.joint, single.guides, single.guide_load_shares) == ("z", "z", ("guide",), (1.0,))
    assert single.wear_coefficient == 2e-6 and single.alarm_clear_margin == 0.05      # the schema's default
    two = wear_axis_params({"axis": "y", "joint": "y", "guides": ["front", "rear"]})
    assert two.guide_load_shares == (0.5, 0.5)
    shared = wear_axis_params({"axis": "y", "guides": ["front", "rear"], "guide_load_shares": [0.75, 0.25]})
    assert shared.guide_load_shares == (0.75, 0.25) and shared.joint == "x"      # the section's joint default
    with pytest.raises(dataclasses.FrozenInstanceError):
        single.wear_coefficient = 1.0


def test_with_changes_gives_a_new_object_with_only_its_own_names():
    p = slewing_monitor_params()
    q = with_changes(p, {"warn_fraction": 0.7, "life_warn_h": 3.0})     # life_warn_h: not a slewing parameter
    assert (p.warn_fraction, q.warn_fraction) == (0.8, 0.7)
    assert q is not p and dataclasses.replace(q, warn_fraction=0.8) == p
    assert with_changes(p, {"life_warn_h": 3.0}) is p
    g = with_changes(guide_params({}), {"life_factors": [1.0, 1.0, 1.0, 2.0]})
    assert g.life_factors == (1.0, 1.0, 1.0, 2.0)


#: (model modules, the names their parameter objects go by, the class they take): every field a model reads
#: must be one the generated class declares (the classes are built at run time, so no static checker sees them)
MODEL_READS = [
    (("models/slewing/monitor.py", "models/slewing/numerical_roller.py"), ("params", "resolved"), "slewing_monitor"),
    (("models/rolling/ball_contact.py", "models/rolling/rolling_guide.py"), ("params", "p"), "guide"),
    (("analysis/life_signs.py", "analysis/life_plots.py", "nodes/vibration_monitor.py"), ("p",),
     "vibration_monitor"),
    (("sim/slewing.py",), ("p",), "guide_health_slewing_simulation"),
    (("sim/life_test.py",), ("sim",), "guide_health_life_test_simulation"),
    (("sim/life_test.py",), ("bench",), "vibration_monitor"),
    (("nodes/fleet_monitor.py",), ("p",), "fleet_monitor"),
]


def _attribute_reads(source: str, names: tuple[str, ...]) -> set[str]:
    import ast

    return {node.attr for node in ast.walk(ast.parse(source))
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in names
            and isinstance(node.ctx, ast.Load)}


@pytest.mark.parametrize("modules,names,section", MODEL_READS, ids=[m[0][0] + ":" + m[2] for m in MODEL_READS])
def test_every_field_a_consumer_reads_is_declared(modules, names, section):
    from pathlib import Path

    package = Path(__file__).resolve().parents[1] / "guide_health"
    cls = GuideParams if section == "guide" else TYPED_CLASSES[section]
    declared = {f.name for f in dataclasses.fields(cls)}
    reads = set().union(*(_attribute_reads((package / m).read_text(), names) for m in modules))
    assert len(reads) >= 3, reads                       # the check looks at real reads
    assert reads <= declared, sorted(reads - declared)
