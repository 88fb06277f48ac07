"""Issue 10 item 4: a parameter typo, a misspelt section, a missing node section, a malformed file or a value
outside its range never goes unnoticed: the CLI and the node alike exit 2 with one line naming the file, the
node and the key (never a traceback, never the defaults used silently)."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

from guide_health.cli.app import main as cli_main
from guide_health.errors import InputError
from guide_health.params import WEAR_MONITOR_DEFAULTS, validate_wear_params, wear_monitor_params
from guide_health.params.ros_args import check_ros_args, parse_ros_args
from guide_health.params.wear_monitor import MAX_PROFILE_BINS, WEAR_MONITOR_SCHEMA

ROOT = Path(__file__).resolve().parents[1]
SECTION = "wear_monitor:\n  ros__parameters:\n"

# (file text, the words the one-line error must contain)
BAD_FILES = {
    "typo": (SECTION + "    straightnes_limit_m: 1.0e-4\n",
             ["unknown parameter 'straightnes_limit_m'", "did you mean 'straightness_limit_m'", "wear_monitor"]),
    "misspelt_ros__parameters": ("wear_monitor:\n  ros__parameter:\n    joint: x\n",
                                 ["'ros__parameter'", "did you mean 'ros__parameters'"]),
    "missing_node_section": ("wear_monitr:\n  ros__parameters:\n    joint: x\n",
                             ["no section for node 'wear_monitor'", "wear_monitr"]),
    "malformed_yaml": (SECTION + "    life_factors: [1.0,\n", ["not valid YAML"]),
    "negative_checkpoint": (SECTION + "    checkpoint_period_s: -1\n", ["checkpoint_period_s", "[0.1, 86400]"]),
    "zero_checkpoint": (SECTION + "    checkpoint_period_s: 0\n", ["checkpoint_period_s"]),
    "huge_wear_coefficient": (SECTION + "    wear_coefficient: 1.0e300\n", ["wear_coefficient"]),
    "tiny_profile_bin": (SECTION + "    profile_bin_m: 1.0e-9\n", ["profile_bin_m"]),
    "inverted_life_thresholds": (SECTION + "    life_warn_h: 5.0\n    life_error_h: 50.0\n",
                                 ["life_error_h", "below life_warn_h"]),
    "warn_fraction_1.5": (SECTION + "    straightness_warn_fraction: 1.5\n", ["straightness_warn_fraction"]),
    "warn_fraction_1": (SECTION + "    straightness_warn_fraction: 1.0\n", ["straightness_warn_fraction"]),
    "warn_fraction_negative": (SECTION + "    straightness_warn_fraction: -1.0\n", ["straightness_warn_fraction"]),
    "a0_above_limit": (SECTION + "    straightness_initial_m: 2.0e-4\n    straightness_limit_m: 1.0e-4\n",
                       ["straightness_initial_m", "below straightness_limit_m"]),
    "tiny_duty_window": (SECTION + "    duty_window_s: 1.0e-9\n", ["duty_window_s"]),
    "negative_input_timeout": (SECTION + "    input_timeout_s: -1\n", ["input_timeout_s"]),
}


def _write(tmp_path, name, text) -> Path:
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("name", list(BAD_FILES))
def test_cli_refuses_a_bad_parameters_file_in_one_line(tmp_path, capsys, name):
    text, words = BAD_FILES[name]
    path = _write(tmp_path, name, text)
    assert cli_main(["replay", str(tmp_path / "no_bag"), "--params", str(path)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert str(path) in err and all(w in err for w in words), err


@pytest.mark.parametrize("name", list(BAD_FILES))
def test_node_precheck_refuses_the_same_files(tmp_path, name):
    text, words = BAD_FILES[name]
    path = _write(tmp_path, name, text)
    with pytest.raises(InputError) as err:
        check_ros_args(WEAR_MONITOR_SCHEMA, ["wear_monitor", "--ros-args", "--params-file", str(path)])
    message = str(err.value)
    assert "\n" not in message and str(path) in message and all(w in message for w in words), message


@pytest.mark.parametrize("name", ["typo", "malformed_yaml", "misspelt_ros__parameters", "negative_checkpoint"])
def test_node_process_exits_2_with_one_line(tmp_path, name):
    text, words = BAD_FILES[name]
    path = _write(tmp_path, name, text)
    env = dict(os.environ, PYTHONPATH=str(ROOT), ROS_HOME=str(tmp_path))
    proc = subprocess.run([sys.executable, "-m", "guide_health.nodes.wear_monitor", "--ros-args",
                           "--params-file", str(path)], capture_output=True, text=True, timeout=60, env=env)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("wear_monitor: error: ") and str(path) in lines[0], proc.stderr


def test_rcl_parse_error_of_a_file_pyyaml_accepts_is_one_line(tmp_path):
    """A file rcl's parser refuses (a mixed-type list in another tool's section) ends in one line: the
    loader reads files as rcl does (params/rcl_yaml.py) and gives rcl's reason before rcl is reached."""
    path = _write(tmp_path, "rcl", "other_tool:\n  ros__parameters:\n    mixed: [1.0, \"a\"]\n" + SECTION
                  + "    state_file: ''\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT), ROS_HOME=str(tmp_path))
    proc = subprocess.run([sys.executable, "-m", "guide_health.nodes.wear_monitor", "--ros-args",
                           "--params-file", str(path)], capture_output=True, text=True, timeout=60, env=env)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "Traceback" not in proc.stderr and "Sequence should be of same type" in proc.stderr
    assert cli_main(["replay", str(tmp_path / "no_bag"), "--params", str(path)]) == 2


def test_ros_args_parsing_follows_rcl_order_and_remapping(tmp_path):
    a = _write(tmp_path, "a", SECTION + "    life_warn_h: 40.0\n    life_error_h: 4.0\n")
    b = _write(tmp_path, "b", "/**:\n  ros__parameters:\n    life_warn_h: 30.0\n")
    argv = ["prog", "--ros-args", "-r", "__node:=wm_x", "--params-file", str(a), "--", "--ros-args",
            "--params-file", str(b), "-p", "life_error_h:=2.0", "-p", "other:foo:=1"]
    name, files, overrides = parse_ros_args(argv, "wear_monitor")
    assert (name, files) == ("wm_x", [str(a), str(b)])
    # the file has no section for the remapped name 'wm_x'
    with pytest.raises(InputError, match="no section for node 'wm_x'"):
        check_ros_args(WEAR_MONITOR_SCHEMA, argv)
    argv = ["prog", "--ros-args", "--params-file", str(a), "--params-file", str(b), "-p", "life_error_h:=2.0"]
    params = check_ros_args(WEAR_MONITOR_SCHEMA, argv)
    assert (params["life_warn_h"], params["life_error_h"]) == (30.0, 2.0)   # later file, then -p win


def test_wildcard_section_keys_are_checked_against_every_schema(tmp_path):
    ok = _write(tmp_path, "ok", "/**:\n  ros__parameters:\n    use_sim_time: true\n    stale_after_s: 5.0\n"
                + SECTION + "    joint: 'y'\n")      # quoted: rcl (and the loader) read a bare y as true
    assert wear_monitor_params(ok)["joint"] == "y"
    bad = _write(tmp_path, "bad", "/**:\n  ros__parameters:\n    stale_afer_s: 5.0\n" + SECTION + "    joint: x\n")
    with pytest.raises(InputError, match=r"section '/\*\*': unknown parameter 'stale_afer_s'"):
        wear_monitor_params(bad)


def test_other_tools_sections_stay_allowed(tmp_path):
    path = _write(tmp_path, "p", "some_other_node:\n  ros__parameter:\n    anything: 1\n" + SECTION
                  + "    joint: z\n")
    assert wear_monitor_params(path)["joint"] == "z"


def test_profile_memory_is_bounded_at_the_bin_limit():
    ok = dict(WEAR_MONITOR_DEFAULTS, rail_length_m=1.0, profile_bin_m=1.0 / MAX_PROFILE_BINS)
    validate_wear_params(ok)
    with pytest.raises(InputError, match="bins: at most 1e\\+06"):
        validate_wear_params(dict(ok, rail_length_m=2.0))


def test_dynamic_set_is_checked_like_the_file():
    from guide_health.params.ros import _check_set

    values = dict(WEAR_MONITOR_DEFAULTS)
    param = type("P", (), {"name": "life_error_h", "value": 900.0})   # above life_warn_h 500
    result = _check_set(WEAR_MONITOR_SCHEMA, values, [param])
    assert not result.successful and "below life_warn_h" in result.reason and values["life_error_h"] == 100.0
    param = type("P", (), {"name": "life_error_h", "value": 50})
    assert _check_set(WEAR_MONITOR_SCHEMA, values, [param]).successful and values["life_error_h"] == 50.0
