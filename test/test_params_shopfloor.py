"""Parameters files on a real installation: what rcl applies is what the CLI applies, in any namespace.

Truth: rcl itself. A probe node (rclpy, ``automatically_declare_parameters_from_overrides``) started in a
subprocess with a file reports what rcl made of every section and scalar; the loader
(guide_health/params/rcl_yaml.py) must give the same (name matching, file order, type and value of each
spelling). The real nodes started under ``-r __ns:=/m1`` with each shipped config report the file's
machine_id on /diagnostics, and the CLI and a real wear_monitor accept or refuse the same spellings with
the same line.
"""
import json
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from guide_health.cli.app import main as cli_main
from guide_health.errors import InputError
from guide_health.nodes.session import PLAYER_WAIT_TIMEOUT_S
from guide_health.params import WEAR_MONITOR_SCHEMA, wear_monitor_params
from guide_health.params.ros_args import check_ros_args

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config"

PROBE = '''
import json, math, sys
import rclpy
from rclpy.node import Node
try:
    rclpy.init(args=sys.argv)
except Exception as exc:
    print(json.dumps({"error": str(exc).splitlines()[0]})); sys.exit(3)
node = Node("wear_monitor", automatically_declare_parameters_from_overrides=True)
def plain(v):
    v = v.tolist() if hasattr(v, "tolist") else v
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    return repr(v) if isinstance(v, float) and not math.isfinite(v) else v
print(json.dumps({"fqn": node.get_fully_qualified_name(),
                  **{n: [type(p.value).__name__, plain(p.value)] for n, p in node._parameters.items()}}))
'''


def probe(tmp_path: Path, env: dict, *ros_args: str) -> dict:
    """What rcl gives a node ``wear_monitor`` started with ``--ros-args *ros_args``."""
    script = tmp_path / "probe.py"
    script.write_text(PROBE)
    proc = subprocess.run([sys.executable, str(script), "--ros-args", *ros_args], capture_output=True, text=True,
                          env=env, timeout=PLAYER_WAIT_TIMEOUT_S)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def plain(value):
    if isinstance(value, list):
        return [plain(v) for v in value]
    return repr(value) if isinstance(value, float) and not math.isfinite(value) else value


# --- names: which sections apply to which node, in which order ------------------------------------------

SECTION_NAMES = ["/**", "/**/wear_monitor", "wear_monitor", "/wear_monitor", "/m1/wear_monitor", "/*/wear_monitor",
                 "/m1/*", "/**/*", "/*", "/a/**/wear_monitor", "/**/m1/wear_monitor", "/m2/wear_monitor"]


@pytest.mark.ros
def test_section_names_apply_as_rcl_applies_them(tmp_path, ros_test_env):
    """Every section sets its own parameter p<i>: the parameters rcl gives the node in each namespace are
    exactly those of the sections ``applies`` accepts (the CLI's loader keeps sections by ``applies``)."""
    from guide_health.params.rcl_yaml import applies

    env = ros_test_env()
    text = "".join(f"{name}:\n  ros__parameters:\n    p{i}: {i}\n" for i, name in enumerate(SECTION_NAMES))
    path = tmp_path / "names.yaml"
    path.write_text(text)
    for namespace in ("/", "/m1", "/a/m1", "/a/b"):
        got = probe(tmp_path, env, "-r", f"__ns:={namespace}", "--params-file", str(path))
        fqn = got["fqn"]
        by_rcl = {int(k[1:]) for k in got if k.startswith("p")}
        by_loader = {i for i, name in enumerate(SECTION_NAMES) if applies(name, fqn)}
        assert by_loader == by_rcl, (fqn, sorted(by_loader), sorted(by_rcl))
        assert len(by_rcl) >= 3                  # /**, /**/wear_monitor, /**/* at least: the test can fail


@pytest.mark.ros
def test_later_sections_override_as_in_rcl(tmp_path, ros_test_env):
    """rcl applies sections in file order (a later ``/**`` beats an earlier ``/**/wear_monitor``), nested
    keys join into one name; the node's own loader merges the same way."""
    env = ros_test_env()
    path = tmp_path / "order.yaml"
    path.write_text("/**/wear_monitor:\n  ros__parameters:\n    life_warn_h: 40.0\n    life_error_h: 4.0\n"
                    "/**:\n  ros__parameters:\n    life_warn_h: 30.0\n"
                    "/m1:\n  wear_monitor:\n    ros__parameters:\n      life_error_h: 3.0\n")
    got = probe(tmp_path, env, "-r", "__ns:=/m1", "--params-file", str(path))
    assert (got["life_warn_h"][1], got["life_error_h"][1]) == (30.0, 3.0)
    params = check_ros_args(WEAR_MONITOR_SCHEMA, ["wm", "--ros-args", "-r", "__ns:=/m1", "--params-file", str(path)])
    assert (params["life_warn_h"], params["life_error_h"]) == (30.0, 3.0)
    assert wear_monitor_params(path)["life_error_h"] == 4.0      # the CLI reads as the node in '/'


# --- scalars: one reading on both sides ------------------------------------------------------------------

SPELLINGS = ["1_000", "1:00:00", "0b101", "0x1F", "017", "0o17", "08", "1e3", "1.0e3", "1E3", ".5", "1.", "+1", "-0",
             "yes", "Yes", "on", "OFF", "y", "n", "tRue", "~", "null", "'quoted'", '"1"', "!!str 1", "!!float 1",
             "inf", "-inf", ".inf", "-.inf", "Infinity", "nan", ".nan", ".NaN", "1e400", "1e-310", "2.3e-308",
             "99999999999999999999", "9223372036854775807", "0x1p3", "0xFFFFFFFFFFFFFFFF", "2020-01-01", "12:30",
             "[1, 2]", "[0x10, 017]", "[yes, no]", "[1e3, .5]", "[inf, nan]", "['a', b]", "|-\n      12"]
REFUSED = ["", "[1, 2.0]", "[1, a]", "[true, 1]", "*anchor"]


@pytest.mark.ros
def test_every_spelling_reads_as_rcl_reads_it(tmp_path, ros_test_env):
    """51 spellings in one file: type and value from the loader == from rcl (a node in a subprocess)."""
    from guide_health.params.rcl_yaml import read_params_file

    env = ros_test_env()
    path = tmp_path / "spellings.yaml"
    path.write_text("wear_monitor:\n  ros__parameters:\n"
                    + "".join(f"    v{i:02d}: {text}\n" for i, text in enumerate(SPELLINGS)))
    by_rcl = probe(tmp_path, env, "--params-file", str(path))
    by_loader = read_params_file(path)["wear_monitor"]["ros__parameters"]
    types = {"bool": bool, "int": int, "float": float, "str": str, "list": list}
    for i, text in enumerate(SPELLINGS):
        kind, value = by_rcl[f"v{i:02d}"]
        mine = by_loader[f"v{i:02d}"]
        assert type(mine) is types[kind] and plain(mine) == value, (text, mine, kind, value)
    # spot checks written out (the YAML 1.1 reading of PyYAML differs on each)
    assert [by_loader[f"v{SPELLINGS.index(t):02d}"] for t in ("1_000", "0b101", "1e3", "~", "017")] == \
        ["1_000", "0b101", 1000.0, "~", 15]


@pytest.mark.ros
@pytest.mark.parametrize("text", REFUSED)
def test_what_rcl_refuses_the_loader_refuses(tmp_path, ros_test_env, text):
    from guide_health.params.rcl_yaml import read_params_file

    env = ros_test_env()
    path = tmp_path / "bad.yaml"
    path.write_text("wear_monitor:\n  ros__parameters:\n    a: &anchor 1\n" + f"    v: {text}\n")
    assert "error" in probe(tmp_path, env, "--params-file", str(path))
    with pytest.raises(InputError, match="line 4"):
        read_params_file(path)


def _write_config(tmp_path: Path, name: str, body: str) -> Path:
    path = tmp_path / f"{name}.yaml"
    path.write_text("/**/wear_monitor:\n  ros__parameters:\n    state_file: none\n    life_error_h: 0.1\n" + body)
    return path


# (parameter, spelling): machine_id is a string parameter, life_warn_h a float one
NODE_SPELLINGS = [("machine_id", "1_000"), ("machine_id", "1:00:00"), ("machine_id", "0b101"), ("machine_id", "~"),
                  ("machine_id", "0x1F"), ("machine_id", "yes"), ("life_warn_h", "1e3"), ("life_warn_h", ".5"),
                  ("life_warn_h", "017"), ("life_warn_h", "1_000"), ("life_warn_h", "inf"),
                  ("life_warn_h", ".nan"), ("life_warn_h", "on"), ("life_warn_h", "0x1F")]


def _cli_verdict(tmp_path: Path, path: Path, capsys) -> tuple[int, str]:
    """(0, '') when ``guide-health replay`` accepts the parameters (it reads them before the bag: a missing
    bag is then its only complaint), else (2, its error line without the program name)."""
    code = cli_main(["replay", str(tmp_path / "no_bag"), "--params", str(path)])
    line = capsys.readouterr().err.strip().splitlines()[-1].split("error: ", 1)[-1]
    assert code == 2
    return (0, "") if line.startswith("bag not found") else (2, line)


def _node_verdicts(paths: list[Path], env: dict, tmp_path: Path, batch: int = 7) -> list[tuple[bool, int, str]]:
    """(started, exit code, log) of a real wear_monitor per file, ``batch`` processes at a time, each in its
    own namespace /s<i>: started = it logged its start-up line and was still running."""
    verdicts = []
    for first in range(0, len(paths), batch):
        procs = []
        for i, path in enumerate(paths[first:first + batch], first):
            log = tmp_path / f"node{i}.log"
            with open(log, "w") as out:
                procs.append((log, subprocess.Popen(
                    [sys.executable, "-m", "guide_health.nodes.wear_monitor", "--ros-args", "-r", f"__ns:=/s{i}",
                     "--params-file", str(path)], env=env, stdout=out, stderr=subprocess.STDOUT)))
        end = time.monotonic() + 300                 # an upper bound: seven start-ups on a loaded machine
        while time.monotonic() < end and any(p.poll() is None and "start: " not in log.read_text()
                                             for log, p in procs):
            time.sleep(0.2)
        for log, proc in procs:
            started = proc.poll() is None and "start: " in log.read_text()
            proc.terminate()
            proc.wait(30)
            verdicts.append((started, proc.returncode, log.read_text()))
    return verdicts


@pytest.mark.ros
def test_cli_and_node_accept_or_refuse_the_same_spellings(tmp_path, ros_test_env, capsys):
    """14 spellings: a real wear_monitor (in a namespace) and ``guide-health replay`` both start (the same
    machine_id) or both exit 2 with the same line. PyYAML's YAML 1.1 reading (1_000 = 1000, 1:00:00 = 3600,
    0b101 = 5, ~ = None) made the CLI refuse 4 machine_ids the node accepts."""
    env = ros_test_env()
    paths = [_write_config(tmp_path, f"s{i}", f"    {name}: {text}\n") for i, (name, text) in enumerate(NODE_SPELLINGS)]
    cli = [_cli_verdict(tmp_path, path, capsys) for path in paths]
    nodes = _node_verdicts(paths, env, tmp_path)
    for i, ((name, text), (code, line), (started, returncode, log)) in enumerate(zip(NODE_SPELLINGS, cli, nodes)):
        assert started == (code == 0), (name, text, code, line, log)
        if started:
            machine = wear_monitor_params(paths[i])["machine_id"]
            assert f"start: machine_id {machine}, node /s{i}/wear_monitor" in log, log
        else:
            assert returncode == 2 and f"wear_monitor: error: {line}" in log, (line, log)
    assert [code for code, _ in cli] == [0, 0, 0, 0, 2, 2, 0, 0, 0, 0, 2, 2, 2, 0]   # what rcl's typing gives


# --- shipped configs under a namespace ------------------------------------------------------------------

SHIPPED = [("wear_monitor", "bench_000.yaml"), ("wear_monitor", "machine_jobs.yaml"),
           ("wear_monitor", "machine_xyz.yaml"), ("wear_monitor", "nsk_lh45.yaml"),
           ("slewing_monitor", "slewing_131.32.2000.00Z.yaml"), ("vibration_monitor", "life_test_seed004.yaml")]


@pytest.mark.ros
@pytest.mark.parametrize("node,config", SHIPPED, ids=[c for _, c in SHIPPED])
def test_each_shipped_config_reaches_the_node_under_a_namespace(tmp_path, ros_test_env, node, config):
    """The node started with ``-r __ns:=/m1 --params-file config/...`` publishes the file's machine_id as
    hardware_id (not the default 'machine') and logs one start-up line naming it all."""
    from guide_health.nodes.session import DiagnosticsCollector, stop_node

    env = ros_test_env()
    doc = yaml.safe_load((CONFIG / config).read_text())
    machine = next(v["ros__parameters"]["machine_id"] for k, v in doc.items() if k.split("/")[-1] == node)
    assert machine != "machine"
    collector = DiagnosticsCollector(f"collector_{node}")
    log = tmp_path / "node.log"
    with open(log, "w") as out:
        proc = subprocess.Popen([sys.executable, "-m", f"guide_health.nodes.{node}", "--ros-args", "-r", "__ns:=/m1",
                                 "--params-file", str(CONFIG / config)], env=env, stdout=out, stderr=subprocess.STDOUT)
    try:
        end, seen = time.monotonic() + PLAYER_WAIT_TIMEOUT_S, None
        while time.monotonic() < end and seen is None and proc.poll() is None:
            seen = next((s for s in list(collector.latest.values()) if s["hardware_id"] == machine), None)
            time.sleep(0.1)
        assert seen is not None, log.read_text()
    finally:
        stop_node(proc)
        collector.close()
    start = [line for line in log.read_text().splitlines() if "start: " in line]
    assert len(start) == 1, log.read_text()
    assert f"machine_id {machine}, node /m1/{node}" in start[0]
    assert f"{CONFIG / config} [/**/{node}]" in start[0]
    if node == "wear_monitor":
        assert "axes " in start[0] and f"{machine}/wear_monitor.db (new)" in start[0]


def _start_line(cmd: list[str], env: dict, log: Path, timeout: float = PLAYER_WAIT_TIMEOUT_S) -> str:
    """The node's ``start:`` line ('' when it logs none within ``timeout``); the node is stopped (SIGINT)."""
    with open(log, "w") as out:
        proc = subprocess.Popen(cmd, env=env, stdout=out, stderr=subprocess.STDOUT)
    end = time.monotonic() + timeout
    while time.monotonic() < end and proc.poll() is None and "start: " not in log.read_text():
        time.sleep(0.1)
    proc.send_signal(2)
    try:
        proc.wait(30)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    return next((line for line in log.read_text().splitlines() if "start: " in line), "")


@pytest.mark.ros
def test_start_up_line_says_resumed_and_fleet_monitor_has_one(tmp_path, ros_test_env):
    env = ros_test_env()
    cmd = [sys.executable, "-m", "guide_health.nodes.wear_monitor", "--ros-args", "-r", "__ns:=/m1",
           "--params-file", str(CONFIG / "machine_xyz.yaml")]
    lines = [_start_line(cmd, env, tmp_path / f"wear{i}.log") for i in range(2)]
    assert "axes x, y, z" in lines[0] and lines[0].strip().endswith("wear_monitor.db (new)"), lines
    assert lines[1].strip().endswith("wear_monitor.db (resumed)"), lines
    history = tmp_path / "fleet.db"
    line = _start_line([sys.executable, "-m", "guide_health.nodes.fleet_monitor", "--ros-args", "-r", "__ns:=/plant",
                        "-p", f"history_file:={history}"], env, tmp_path / "fleet.log")
    assert "start: machine_id fleet, node /plant/fleet_monitor, axes none, params -p history_file:=" in line, line
    assert f"history {history}" in line


def test_a_file_without_a_section_for_the_node_exits_2_naming_it_all(tmp_path):
    """``wear_monitor:`` is ``/wear_monitor`` for rcl: under /m1 the node would run on defaults; it exits 2
    with one line naming the file, its sections and the node's full name."""
    path = tmp_path / "root_only.yaml"
    path.write_text("wear_monitor:\n  ros__parameters:\n    machine_id: m1\n/m2/wear_monitor:\n  ros__parameters:\n"
                    "    machine_id: m2\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-m", "guide_health.nodes.wear_monitor", "--ros-args", "-r", "__ns:=/m1",
                           "--params-file", str(path)], capture_output=True, text=True, timeout=60, env=env)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert str(path) in lines[0] and "/m1/wear_monitor" in lines[0]
    assert "'/wear_monitor'" in lines[0] and "'/m2/wear_monitor'" in lines[0] and "/**/wear_monitor" in lines[0]
    assert wear_monitor_params(path)["machine_id"] == "m1"     # the CLI reads it as the node in '/'


# --- --help -----------------------------------------------------------------------------------------------

@pytest.mark.parametrize("node", ["wear_monitor", "slewing_monitor", "vibration_monitor", "fleet_monitor"])
def test_node_help_prints_usage_without_starting_ros(tmp_path, node):
    home = tmp_path / "home"
    home.mkdir()
    env = dict(os.environ, PYTHONPATH=str(ROOT), HOME=str(home), ROS_HOME=str(home / ".ros"))
    script = Path(sys.executable).with_name(node)
    for flag in ("--help", "-h"):
        t0 = time.monotonic()
        proc = subprocess.run([str(script), flag], capture_output=True, text=True, timeout=20, env=env, cwd=home)
        elapsed = time.monotonic() - t0
        assert proc.returncode == 0 and elapsed < 2.0, (elapsed, proc.stderr)
        assert proc.stdout.startswith(f"usage: {node}") and "docs/interfaces.md" in proc.stdout
        assert "subscribes:" in proc.stdout and "publishes:" in proc.stdout
    proc = subprocess.run([sys.executable, "-m", f"guide_health.nodes.{node}", "--help"], capture_output=True,
                          text=True, timeout=30, env=env, cwd=home)
    assert proc.returncode == 0 and proc.stdout.startswith(f"usage: {node}"), proc.stderr
    assert list(home.rglob("*")) == []                       # no state database, no log directory


# --- the documented command lines and the launch files ------------------------------------------------------

NODE_SCRIPTS = ("wear_monitor", "slewing_monitor", "vibration_monitor", "fleet_monitor")


def documented_node_commands() -> list[tuple[str, str, list[str]]]:
    """(doc, node, argv) of every command line in README.md, docs/machine.md, docs/fleet.md, docs/ros.md
    that starts a node with shipped files (``ros2 run guide_health NODE ...`` or the console script)."""
    import shlex

    found = []
    for doc in ("README.md", "docs/machine.md", "docs/fleet.md", "docs/ros.md"):
        for line in (ROOT / doc).read_text().splitlines():
            words = shlex.split(line.split(" #")[0].strip(" `")) if "--ros-args" in line else []
            words = words[3:] if words[:2] == ["ros2", "run"] else words
            if words and words[0] in NODE_SCRIPTS:
                argv = [w.replace("install/guide_health/share/guide_health/", "") for w in words]
                files = [argv[i + 1] for i, w in enumerate(argv) if w == "--params-file"]
                if all((ROOT / f).is_file() for f in files):
                    found.append((doc, argv[0], argv))
    return found


def test_documented_node_commands_apply_their_files_in_their_namespace(monkeypatch):
    """Each documented node command line, checked as the node checks its arguments (full name from its
    -r __ns): every --params-file has a section for the node there, so none runs on defaults."""
    from guide_health.params import SCHEMAS
    from guide_health.params.ros_args import read_ros_args

    monkeypatch.chdir(ROOT)
    commands = documented_node_commands()
    assert sum("__ns:=" in " ".join(argv) for _, _, argv in commands) >= 4, commands
    for doc, node, argv in commands:
        result = read_ros_args(SCHEMAS[node], argv)
        files = [argv[i + 1] for i, w in enumerate(argv) if w == "--params-file"]
        assert sorted({path for path, _ in result.applied}) == sorted(set(files)), (doc, argv, result.applied)


def readme_node_command_lines() -> list[tuple[str, list[str]]]:
    """(label, argv as run) of every README line that starts a node: the console-script lines with a shipped
    file (``ros2 run guide_health`` dropped, as without ros2cli), and each ``systemctl ... guide-health-X@M``
    line as the unit's ExecStart expanded for its first instance (test_systemd_unit.expand_exec) with
    config/systemd/machine.env.example, its PARAMS_FILE a shipped config (the /etc file exists only there)."""
    import shlex

    from test_systemd_unit import ENV_EXAMPLE, environment_file, expand_exec, unit_settings

    found = [(f"README: {' '.join(argv)}", argv) for doc, _, argv in documented_node_commands() if doc == "README.md"]
    for line in (ROOT / "README.md").read_text().splitlines():
        words = shlex.split(line.split(" #")[0]) if "systemctl" in line else []
        units = [w for w in words if re.fullmatch(r"guide-health-[a-z]+@[A-Za-z0-9_]+", w)]
        if units:
            template, instance = units[0].split("@")
            unit = CONFIG / "systemd" / f"{template}@.service"
            env = dict(environment_file(ENV_EXAMPLE.read_text()), MACHINE_NAMESPACE=f"/{instance}",
                       PARAMS_FILE=str(CONFIG / "bench_000.yaml"))
            argv = expand_exec(unit_settings(unit.read_text())["Service.ExecStart"][0], instance, env)
            venv = env["GUIDE_HEALTH_VENV"]
            found.append((f"README: {line.strip()}", [argv[1].replace(venv, str(Path(sys.executable).parent.parent)),
                                                      *argv[2:]]))
    return found


@pytest.mark.ros
def test_readme_node_command_lines_run_as_written_under_a_namespace(tmp_path, ros_test_env, monkeypatch):
    """Each README line that starts a node, run as written (a line without a namespace also under
    ``-r __ns:=/readme``), on the test's own domain: the node publishes its params file's machine_id and
    logs a start-up line with its full name in that namespace."""
    from guide_health.nodes.session import DiagnosticsCollector

    env = ros_test_env()
    monkeypatch.chdir(ROOT)
    commands = readme_node_command_lines()
    assert sum("systemctl" in label for label, _ in commands) == 1 and len(commands) >= 3, commands
    runs = []
    for label, argv in commands:
        runs.append((label, argv))
        if "__ns:=" not in " ".join(argv):
            runs.append((label + " (under /readme)", [*argv, "-r", "__ns:=/readme"]))
    collector = DiagnosticsCollector("collector_readme")
    try:
        for i, (label, argv) in enumerate(runs):
            files = [argv[k + 1] for k, w in enumerate(argv) if w == "--params-file"]
            doc = yaml.safe_load(Path(files[-1]).read_text())
            machine = next(v["ros__parameters"]["machine_id"] for k, v in doc.items() if k.endswith("wear_monitor"))
            namespace = next((w.split(":=")[1] for w in argv if w.startswith("__ns:=")), "")
            script = str(Path(sys.executable).with_name(Path(argv[0]).name))
            collector.latest.clear()
            log = tmp_path / f"run{i}.log"
            with open(log, "w") as out:
                proc = subprocess.Popen([script, *argv[1:]], env=dict(env, ROS_HOME=str(tmp_path / f"home{i}")),
                                        stdout=out, stderr=subprocess.STDOUT)
            try:
                end, seen = time.monotonic() + PLAYER_WAIT_TIMEOUT_S, False
                while time.monotonic() < end and not seen and proc.poll() is None:
                    seen = any(s["hardware_id"] == machine for s in list(collector.latest.values()))
                    time.sleep(0.1)
                assert seen, (label, log.read_text())
            finally:
                proc.send_signal(2)
                proc.wait(30)
            start = [line for line in log.read_text().splitlines() if "start: " in line]
            assert len(start) == 1 and f"machine_id {machine}, node {namespace}/wear_monitor," in start[0], \
                (label, log.read_text())
    finally:
        collector.close()


@pytest.mark.parametrize("launch", ["machine.launch.py", "fleet.launch.py"])
def test_launch_default_files_apply_in_the_launch_namespace(launch):
    """The launch files pass their params file to rcl as it is, in the machine's namespace: its section
    must apply there (launch_ros is not on PyPI: the file is checked as the node would check it)."""
    import re

    from guide_health.params import SCHEMAS
    from guide_health.params.ros_args import read_ros_args

    defaults = re.findall(r'os\.path\.join\(share, "config", "([^"]+)"\)', (ROOT / "launch" / launch).read_text())
    assert defaults
    for name in defaults:
        argv = ["wear_monitor", "--ros-args", "-r", "__ns:=/m1", "--params-file", str(CONFIG / name)]
        assert read_ros_args(SCHEMAS["wear_monitor"], argv).applied == [(str(CONFIG / name), "/**/wear_monitor")]
