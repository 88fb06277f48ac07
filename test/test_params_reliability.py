"""What real typos and hostile files produce never hangs, never takes the last value silently, never prints a
traceback: parameters files (size, aliases, duplicate keys, near-miss section names, long values) for the CLI
and the node's own check alike, and the CLI's --out and simulate's size budget.

Truth: the one-line rule (docs/interfaces.md "Parameters", docs/cli.md), rcl's own refusal of aliases
(test_params_shopfloor.py), the file's lines written in the test, and simulate's estimate computed in the
test from duration x rates x BYTES_PER_MESSAGE.
"""
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from guide_health.cli.app import main as cli_main
from guide_health.errors import InputError
from guide_health.params import WEAR_MONITOR_SCHEMA, wear_monitor_params
from guide_health.params.ros_args import check_ros_args

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "config" / "bench_000.yaml"
SECTION = "/**/wear_monitor:\n  ros__parameters:\n"
MAX_PARAMS_FILE_BYTES = 1 << 20          # docs/interfaces.md: a parameters file above 1 MiB is refused


def _cli_line(capsys, argv: list[str]) -> str:
    """The one stderr line of a refused CLI call (exit 2)."""
    assert cli_main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in lines[0], lines
    return lines[0]


def _node_error(path: Path) -> str:
    with pytest.raises(InputError) as err:
        check_ros_args(WEAR_MONITOR_SCHEMA, ["wear_monitor", "--ros-args", "--params-file", str(path)])
    assert "\n" not in str(err.value)
    return str(err.value)


def test_a_file_above_the_size_limit_is_refused_before_parsing(tmp_path, capsys):
    path = tmp_path / "big.yaml"
    path.write_text(SECTION + "    joint: x\n" + ("#" * 79 + "\n") * (MAX_PARAMS_FILE_BYTES // 80 + 1))
    assert path.stat().st_size > MAX_PARAMS_FILE_BYTES
    t0 = time.monotonic()
    line = _cli_line(capsys, ["replay", str(tmp_path / "no_bag"), "--params", str(path)])
    assert time.monotonic() - t0 < 2.0
    assert str(path) in line and f"limit of {MAX_PARAMS_FILE_BYTES} bytes" in line
    assert "limit of" in _node_error(path)
    path.write_text(SECTION + "    joint: x\n" + "#\n" * (MAX_PARAMS_FILE_BYTES // 2 - 100))   # just below
    assert wear_monitor_params(path)["joint"] == "x"


def test_an_alias_bomb_is_refused_at_once_in_one_short_line(tmp_path):
    """Nine levels of ten aliases: 1e9 leaves if expanded. rcl refuses any alias; so do the CLI (in a
    subprocess with a timeout: the old reader expanded it and formatted the value) and the node's check."""
    levels = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    levels += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 10)]
    path = tmp_path / "bomb.yaml"
    path.write_text("bombs:\n" + "".join(f"  {line}\n" for line in levels) + SECTION + "    machine_id: *a9\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    t0 = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "guide_health.cli", "replay", str(tmp_path / "no_bag"), "--params",
                           str(path)], capture_output=True, text=True, timeout=60, env=env)
    assert proc.returncode == 2 and time.monotonic() - t0 < 30
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and len(lines[0]) < 400 and "aliases" in lines[0] and "line 3" in lines[0], lines
    assert "Will not support aliasing" in _node_error(path)


def test_a_duplicated_key_is_refused_naming_the_key_and_both_lines(tmp_path, capsys):
    path = tmp_path / "dup.yaml"
    path.write_text(SECTION + "    life_warn_h: 50.0\n    joint: x\n    life_warn_h: 60.0\n")
    line = _cli_line(capsys, ["replay", str(tmp_path / "no_bag"), "--params", str(path)])
    assert "duplicate key 'life_warn_h' (lines 3 and 5" in line and str(path) in line, line
    assert "duplicate key 'life_warn_h' (lines 3 and 5" in _node_error(path)
    path.write_text(SECTION + "    joint: x\n" + SECTION + "    joint: y\n")      # a section twice
    assert "duplicate key '/**/wear_monitor' (lines 1 and 4" in _node_error(path)


def test_a_near_miss_section_name_is_warned_about_by_cli_and_node(tmp_path, caplog):
    """``wear_monitr:`` beside ``/**/wear_monitor:`` applies to no node (rcl ignores it): one warning line
    naming it and the node it is close to, from the CLI (a process: on stderr) and from the node's check."""
    text = SECTION + "    joint: x\nwear_monitr:\n  ros__parameters:\n    wear_coefficient: 1.0e-5\n"
    cli_file, node_file = tmp_path / "cli.yaml", tmp_path / "node.yaml"
    cli_file.write_text(text)
    node_file.write_text(text)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-m", "guide_health.cli", "replay", str(tmp_path / "no_bag"), "--params",
                           str(cli_file)], capture_output=True, text=True, timeout=60, env=env)
    warned = [line for line in proc.stderr.splitlines() if "warning" in line]
    assert proc.returncode == 2 and len(warned) == 1, proc.stderr
    assert str(cli_file) in warned[0] and "section '/wear_monitr'" in warned[0] and "'wear_monitor'" in warned[0]
    assert wear_monitor_params(cli_file)["wear_coefficient"] == 4.42e-6       # the default: not applied
    caplog.clear()
    check_ros_args(WEAR_MONITOR_SCHEMA, ["wear_monitor", "--ros-args", "--params-file", str(node_file)])
    messages = [r.getMessage() for r in caplog.records]
    assert messages == [warned[0].replace(str(cli_file), str(node_file))], messages
    far = tmp_path / "far.yaml"
    far.write_text(text.replace("wear_monitr:", "other_tool:"))
    caplog.clear()
    wear_monitor_params(far)
    assert caplog.records == []                           # distance > 2: another tool's section, no warning


@pytest.mark.parametrize("value", ["[" + ", ".join(f"name_{i}" for i in range(3000)) + "]", "'" + "a" * 20000 + "'"])
def test_error_messages_show_at_most_80_characters_of_a_value(tmp_path, capsys, value):
    path = tmp_path / "long.yaml"
    path.write_text(SECTION + f"    life_warn_h: {value}\n")
    for line in (_cli_line(capsys, ["replay", str(tmp_path / "no_bag"), "--params", str(path)]), _node_error(path)):
        assert "life_warn_h" in line and "characters)" in line and len(line) < 200 + len(str(path)), line
    from guide_health.params.rcl_yaml import MAX_PARAMS_FILE_BYTES as LIMIT
    from guide_health.params.rcl_yaml import VALUE_CHARS

    assert (VALUE_CHARS, LIMIT) == (80, MAX_PARAMS_FILE_BYTES)


def test_a_long_minus_p_value_is_clipped_too():
    with pytest.raises(InputError) as err:
        check_ros_args(WEAR_MONITOR_SCHEMA, ["wm", "--ros-args", "-p", "life_warn_h:=" + "9x" * 5000])
    assert "life_warn_h" in str(err.value) and len(str(err.value)) < 400, str(err.value)


def test_minus_p_values_are_typed_as_rcl_types_them(tmp_path):
    params = check_ros_args(WEAR_MONITOR_SCHEMA, ["wm", "--ros-args", "-p", "machine_id:=1_000", "-p",
                                                  "life_warn_h:=1e3", "-p", "life_error_h:=0x1F"])
    assert (params["machine_id"], params["life_warn_h"], params["life_error_h"]) == ("1_000", 1000.0, 31.0)


# --- CLI: --out and simulate's budget --------------------------------------------------------------------

@pytest.fixture(scope="module")
def tiny_bag(tmp_path_factory):
    bag = tmp_path_factory.mktemp("bags") / "tiny"
    assert cli_main(["simulate", "--params", str(BENCH), "--hours", "0.002", "--out", str(bag)]) == 0
    return bag


COMMANDS = {
    "replay": lambda bag, out: ["replay", str(bag), "--params", str(BENCH), "--out", out],
    "diagnose": lambda bag, out: ["diagnose", str(bag), "--params", str(BENCH), "--out", out],
    "fleet replay": lambda bag, out: ["fleet", "replay", str(bag.parent), "--params", str(BENCH), "--out", out],
    "fleet trend": lambda bag, out: ["fleet", "trend", str(bag), "--out", out],
    "fleet prior": lambda bag, out: ["fleet", "prior", str(bag.parent), "--out", out],
    "life test": lambda bag, out: ["life", "test", str(bag), "--out", out],
    "simulate": lambda bag, out: ["simulate", "--params", str(BENCH), "--hours", "0.001", "--out", out],
}


@pytest.mark.parametrize("command", list(COMMANDS))
def test_an_out_that_is_a_file_or_under_a_file_is_one_line(tmp_path, capsys, tiny_bag, command):
    existing = tmp_path / "existing_file"
    existing.write_text("keep me")
    for out, words in ((existing / "sub", "is a file, not a directory"), (existing, "exists and is not a directory")):
        if command == "fleet prior" and out == existing:
            continue                                           # --out names a file there: overwriting is its job
        line = _cli_line(capsys, COMMANDS[command](tiny_bag, str(out)))
        assert words in line and str(out) in line, line
    assert existing.read_text() == "keep me"


def test_the_default_report_folder_being_a_file_is_one_line(tmp_path, capsys, tiny_bag):
    bag = tmp_path / "bag"
    bag.symlink_to(tiny_bag, target_is_directory=True)
    (tmp_path / "bag.report").write_text("not a folder")
    assert "bag.report exists and is not a directory" in _cli_line(capsys, ["replay", str(bag), "--params", str(BENCH)])


@pytest.mark.parametrize("args,words", [
    (["--hours", "inf"], "--hours must be a finite number > 0, got inf"),
    (["--hours", "nan"], "--hours must be a finite number > 0, got nan"),
    (["--rate", "inf"], "--rate must be a finite number > 0, got inf"),
    (["--hours", "1e300"], "above --max-bag-gb 4"),
    (["--hours", "100000"], "2.16e+10 messages, about 2.38e+03 GB, above --max-bag-gb 4"),
    (["--hours", "100000", "--max-bag-gb", "1e12"], "GB free on"),
    (["--hours", "1", "--max-bag-gb", "0.001"], "above --max-bag-gb 0.001"),
    (["--kind", "slewing", "--hours", "1e9"], "above --max-bag-gb 4"),
])
def test_simulate_refuses_what_it_cannot_write_before_allocating(tmp_path, capsys, args, words):
    """The bench's 50 Hz joint_states + 10 Hz load + 2 measurements/h: 100000 h x 60.0006 /s x 110 bytes
    = 2.38e12 bytes; refused in about a second instead of allocating it."""
    out = tmp_path / "bag"
    t0 = time.monotonic()
    line = _cli_line(capsys, ["simulate", "--params", str(BENCH), *args, "--out", str(out)])
    assert words in line and time.monotonic() - t0 < 10 and not out.exists(), line


def test_simulate_within_the_budget_writes_the_bag(tmp_path):
    """0.002 h x 60 /s x 110 bytes = 48 kB, under a 1 MB budget: written."""
    out = tmp_path / "bag"
    assert cli_main(["simulate", "--params", str(BENCH), "--hours", "0.002", "--max-bag-gb", "0.001", "--out",
                     str(out)]) == 0
    assert out.is_dir()
