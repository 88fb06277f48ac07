"""The parameter schema (guide_health.params): defaults inside their ranges, every config file valid, ROS
descriptors carrying description/unit/range/read_only, unknown-key suggestions and the Markdown table."""
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from guide_health.errors import InputError
from guide_health.params import (
    SCHEMAS,
    SLEWING_MONITOR_SCHEMA,
    WEAR_MONITOR_DEFAULTS,
    WEAR_MONITOR_SCHEMA,
    Param,
    check_unknown_keys,
    load_node_params,
    markdown_table,
    schema_for,
    simulation_params,
    validate_slewing_params,
    validate_wear_params,
    wear_monitor_params,
)

ROOT = Path(__file__).resolve().parents[1]
# every parameters file of guide_health's nodes (diagnostic_aggregator.yaml configures another package's node)
CONFIGS = sorted(p for p in (ROOT / "config").glob("*.yaml") if p.name != "diagnostic_aggregator.yaml")
ALL_PARAMS = [(s, p) for s in SCHEMAS.values() for p in s.params]


def test_every_loaded_section_has_a_schema():
    assert set(SCHEMAS) == {"wear_monitor", "slewing_monitor", "fleet_monitor", "vibration_monitor",
                            "guide_health_simulation", "guide_health_slewing_simulation",
                            "guide_health_life_test_simulation"}


@pytest.mark.parametrize("schema,param", ALL_PARAMS, ids=[f"{s.section}.{p.name}" for s, p in ALL_PARAMS])
def test_every_default_is_inside_its_declared_range_and_described(schema, param):
    assert param.accepts(param.default), (schema.section, param.name, param.default, param.range_text)
    assert param.description and "\n" not in param.description
    assert param.type_name in ("bool", "int", "float", "string", "string[]") or param.type_name.startswith("float[")
    if param.type_name in ("int", "float") or param.type_name.startswith("float["):
        assert param.unit, f"{param.name}: numbers carry a unit ('-' when dimensionless)"


@pytest.mark.parametrize("schema", SCHEMAS.values(), ids=list(SCHEMAS))
def test_defaults_pass_the_full_validation(schema):
    schema.validate(schema.defaults())


@pytest.mark.parametrize("path", CONFIGS, ids=lambda p: p.name)
def test_every_config_file_loads_and_validates(path):
    sections = {str(key).rstrip("/").split("/")[-1] for key in yaml.safe_load(path.read_text())}
    assert sections <= set(SCHEMAS), sections - set(SCHEMAS)
    for section in sections:
        schema = schema_for(section)
        values = load_node_params(path, section, schema.defaults())
        schema.check_unknown_keys([k for k in values if "." not in k])   # every name in the file is declared
        schema.validate(values)                     # (per-axis names: checked by the loader, params/machine.py)


def test_config_loaders_validate():
    assert wear_monitor_params(ROOT / "config" / "nsk_lh45.yaml")["guide_type"] == "rolling"
    assert simulation_params(ROOT / "config" / "machine_jobs.yaml")["job_hours"] == 3.0


def test_ball_contact_thresholds_match_the_schema_defaults():
    from guide_health.models.rolling import lubrication as bc

    assert WEAR_MONITOR_DEFAULTS["lambda_boundary"] == bc.LAMBDA_BOUNDARY
    assert WEAR_MONITOR_DEFAULTS["lambda_full_film"] == bc.LAMBDA_FULL_FILM


def test_long_standing_checks_keep_their_messages():
    with pytest.raises(InputError, match=r"^parameter hardness_pa must be > 0, got -1.0$"):
        validate_wear_params(dict(WEAR_MONITOR_DEFAULTS, hardness_pa=-1.0))
    with pytest.raises(InputError, match=r"^stroke_min_m/stroke_max_m: both 0"):
        validate_wear_params(dict(WEAR_MONITOR_DEFAULTS, stroke_min_m=0.1))
    with pytest.raises(InputError, match=r"^parameter poisson must be in \[0, 0.5\), got 0.5$"):
        validate_slewing_params(dict(SLEWING_MONITOR_SCHEMA.defaults(), poisson=0.5))


@pytest.mark.parametrize("name,value,expected", [
    ("hardness_pa", 1.0e5, "wear_monitor: parameter hardness_pa = 100000.0 must be in [1e6, 1e11] Pa"),
    ("wear_coefficient", 0.5, "wear_monitor: parameter wear_coefficient = 0.5 must be in [1e-12, 1e-1]"),
    ("life_factors", [1.0, 0.0, 1.0, 1.0], "wear_monitor: parameter life_factors = [1.0, 0.0, 1.0, 1.0] must "
                                           "be in (0, 10]"),
    ("rolling_element", "balls", "wear_monitor: parameter rolling_element = 'balls' must be one of ball | roller"),
])
def test_a_value_outside_a_declared_range_is_one_line_naming_node_key_value_range(name, value, expected):
    with pytest.raises(InputError) as err:
        validate_wear_params(dict(WEAR_MONITOR_DEFAULTS, **{name: value}))
    assert str(err.value) == expected


def test_interval_ends():
    p = Param("x", 0.5, "-", "(0, 1]", "x")
    assert not p.accepts(0.0) and p.accepts(1e-300) and p.accepts(1.0) and not p.accepts(1.0 + 1e-12)
    assert not p.accepts(float("nan")) and not p.accepts("0.5") and not p.accepts(True)
    with pytest.raises(ValueError):
        Param("y", 0.5, "-", "0 < y", "y")


def test_unknown_key_names_the_closest_known_key(tmp_path):
    with pytest.raises(InputError, match=r"unknown parameter 'hardnes_pa' for wear_monitor "
                                         r"\(did you mean 'hardness_pa'\?\)"):
        WEAR_MONITOR_SCHEMA.check_unknown_keys(["contact_width_m", "hardnes_pa"])
    with pytest.raises(InputError, match=r"'zzz' for n$"):
        check_unknown_keys("n", ["zzz"], ["alpha"])
    path = tmp_path / "p.yaml"
    path.write_text("wear_monitor:\n  ros__parameters:\n    wear_coeficient: 1.0e-5\n")
    assert load_node_params(path, "wear_monitor", WEAR_MONITOR_DEFAULTS,
                            strict=False)["wear_coeficient"] == 1.0e-5     # non-strict on request only
    with pytest.raises(InputError, match=r"p.yaml: unknown parameter 'wear_coeficient' for wear_monitor "
                                         r"\(did you mean 'wear_coefficient'\?\)"):
        load_node_params(path, "wear_monitor", WEAR_MONITOR_DEFAULTS)      # strict by default
    with pytest.raises(InputError, match="did you mean 'slewing_monitor'"):
        schema_for("slewing_monitr")


@pytest.mark.parametrize("schema", SCHEMAS.values(), ids=list(SCHEMAS))
def test_markdown_table_lists_every_parameter(schema):
    table = markdown_table(schema)
    rows = [line for line in table.splitlines() if line.startswith("| `")]
    assert [row.split("`")[1] for row in rows] == [p.name for p in schema.params]
    assert table.splitlines()[2] == "| name | type | default | unit | range | dynamic | description |"
    assert all(row.count(" | ") == 6 for row in rows)       # no unescaped '|' inside a cell


def test_importing_the_schema_needs_no_ros():
    code = "import sys, guide_health.params; assert not {'rclpy', 'rcl_interfaces'} & set(sys.modules)"
    subprocess.run([sys.executable, "-c", code], check=True, cwd=ROOT)


# --- ROS descriptors ------------------------------------------------------------------------------------
rcl_interfaces = pytest.importorskip("rcl_interfaces")


def test_descriptor_carries_description_unit_range_and_read_only():
    from guide_health.params import descriptor_for

    hardness = descriptor_for(WEAR_MONITOR_SCHEMA["hardness_pa"])
    assert hardness.description.endswith("[Pa]") and "softer" in hardness.description
    assert hardness.read_only and hardness.dynamic_typing
    fp = hardness.floating_point_range[0]
    assert (fp.from_value, fp.to_value, fp.step) == (1e6, 1e11, 0.0)
    assert hardness.additional_constraints == "in [1e6, 1e11] Pa" and not hardness.integer_range
    warn = descriptor_for(WEAR_MONITOR_SCHEMA["life_warn_h"])
    assert not warn.read_only and warn.floating_point_range[0].to_value == 1e7
    rollers = descriptor_for(SLEWING_MONITOR_SCHEMA["roller_count"])
    assert (rollers.integer_range[0].from_value, rollers.integer_range[0].to_value) == (1, 100000)
    guide = descriptor_for(WEAR_MONITOR_SCHEMA["guide_type"])
    assert guide.read_only and guide.additional_constraints == "one of: sliding, rolling"
    assert not guide.floating_point_range and not guide.integer_range


class FakeNode:
    """The part of rclpy.node.Node that declare_parameters uses (overrides as a --params-file sets them)."""

    def __init__(self, overrides):
        self.overrides, self.values, self.descriptors = overrides, {}, {}

    def declare_parameter(self, name, default, descriptor):
        assert descriptor.dynamic_typing and not descriptor.read_only
        self.values[name] = self.overrides.get(name, default)

    def get_parameter(self, name):
        return type("P", (), {"value": self.values[name]})

    def set_descriptor(self, name, descriptor):
        self.descriptors[name] = descriptor

    def add_on_set_parameters_callback(self, callback):
        self.on_set = callback


def test_declare_parameters_coerces_validates_then_describes():
    from guide_health.params import declare_parameters

    node = FakeNode({"hardness_pa": 200000000, "life_factors": (1.0, 1.0, 0.9, 1.2)})   # int for a float
    values = declare_parameters(node, WEAR_MONITOR_SCHEMA)
    assert values["hardness_pa"] == 2.0e8 and isinstance(values["hardness_pa"], float)
    assert values["life_factors"] == [1.0, 1.0, 0.9, 1.2]
    assert set(node.descriptors) == set(WEAR_MONITOR_DEFAULTS)
    assert node.descriptors["state_file"].read_only
    with pytest.raises(InputError, match="must be > 0"):
        declare_parameters(FakeNode({"diagnostics_period_s": 0.0}), WEAR_MONITOR_SCHEMA)


rclpy = pytest.importorskip("rclpy")


def test_descriptors_on_a_real_node(ros_context):
    from rclpy.parameter import Parameter

    from guide_health.params import FLEET_MONITOR_SCHEMA, declare_parameters

    node = rclpy.create_node("fleet_monitor", context=ros_context,
                             parameter_overrides=[Parameter("stale_after_s", value=20)])
    try:
        values = declare_parameters(node, FLEET_MONITOR_SCHEMA)
        assert values["stale_after_s"] == 20.0
        stale, history = node.describe_parameters(["stale_after_s", "history_file"])
        assert "[s]" in stale.description and not stale.read_only
        assert stale.floating_point_range[0].from_value == 0.0 and history.read_only
        refused = node.set_parameters([Parameter("history_file", value="/tmp/x.db")])[0]
        assert not refused.successful
        assert node.set_parameters([Parameter("stale_after_s", value=30.0)])[0].successful
    finally:
        node.destroy_node()
