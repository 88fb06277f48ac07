"""Unique aggregator-ready names: "<machine_id>/<node>: <task>" differs between machines and nodes, and
config/diagnostic_aggregator.yaml puts every machine's statuses, any number of machines, into exactly one
analyzer by pattern.

The aggregator (ros/diagnostics, diagnostic_aggregator; not on PyPI) is emulated by its own rules, from
its source: GenericAnalyzer::match (src/generic_analyzer.cpp) accepts a name when a ``regex`` matches all
of it (std::regex_match), or it equals an ``expected`` entry, or starts with a ``startswith`` /
``find_and_remove_prefix`` entry, or contains a ``contains`` entry; the item's output name is the
analyzer's path + "/" + the name with every '/' written as ' ' (getOutputName, status_item.hpp), after
which removeLeadingNameChaff drops a ``find_and_remove_prefix`` entry (also '/' -> ' ') and the ': ' or
' ' that follow it. The analyzers' parameters are read as rcl gives them to the aggregator node
``analyzers`` (a probe node in a subprocess), so the regex tested is the string the aggregator compiles."""
import functools
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from guide_health.nodes.session import PLAYER_WAIT_TIMEOUT_S
from guide_health.nodes.status import status_name

ROOT = Path(__file__).resolve().parents[1]
AGGREGATOR = ROOT / "config" / "diagnostic_aggregator.yaml"
MONITOR_NODES = ("wear_monitor", "wear_monitor_y", "slewing_monitor", "vibration_monitor")
TASKS = ("x precision", "x fatigue", "y lubrication", "131.32.2000.00Z roller contact", "x vibration")


@functools.lru_cache(maxsize=1)
def file_params() -> dict:
    """The aggregator node's parameters as the file writes them, parsed once (read only: thousands of names
    are checked against them)."""
    return yaml.safe_load(AGGREGATOR.read_text())["/**/analyzers"]["ros__parameters"]


def analyzers(params: dict | None = None):
    """(base path, {name: analyzer parameters}) of the file's aggregator node (rcl's ``params`` when given)."""
    params = params or file_params()
    return params["path"], {k: v for k, v in params.items() if isinstance(v, dict)}


def output_name(item: str) -> str:
    return item.replace("/", " ")                               # getOutputName


def remove_leading_chaff(name: str, chaff: str) -> str:
    """removeLeadingNameChaff on "<path>/<output name>"."""
    head, tail = name[:name.rfind("/") + 1], name[name.rfind("/") + 1:]
    if chaff and tail.startswith(chaff):
        tail = tail[len(chaff):]
    tail = tail[1:] if tail.startswith(":") else tail
    return head + tail.lstrip(" ")


def matches(analyzer: dict, name: str) -> bool:
    """GenericAnalyzer::match."""
    assert analyzer["type"] == "diagnostic_aggregator/GenericAnalyzer"
    starts = analyzer.get("startswith", []) + analyzer.get("find_and_remove_prefix", [])
    return (any(re.fullmatch(r, name) for r in analyzer.get("regex", []))
            or name in analyzer.get("expected", [])
            or any(name.startswith(p) for p in starts)
            or any(c in name for c in analyzer.get("contains", [])))


def aggregated_paths(name: str, params: dict | None = None) -> list[str]:
    """The /diagnostics_agg names a status gets: one per matching GenericAnalyzer."""
    base, found = analyzers(params)
    paths = []
    for analyzer in found.values():
        if matches(analyzer, name):
            out = f"/{base}/{analyzer['path']}/{output_name(name)}"
            for chaff in analyzer.get("find_and_remove_prefix", []):
                out = remove_leading_chaff(out, output_name(chaff))
            paths.append(out)
    return paths


def shipped_machine_ids() -> set[str]:
    ids = set()
    for path in (ROOT / "config").glob("*.yaml"):
        for section in (yaml.safe_load(path.read_text()) or {}).values():
            if not isinstance(section, dict):
                continue
            machine = section.get("ros__parameters", {}).get("machine_id")
            if machine:
                ids.add(machine)
    return ids


def generated_machine_ids(n: int) -> list[str]:
    """n machine ids as plants name them: m1.., hall/cell codes, upper case, dashes and dots."""
    forms = ("m{i}", "vmc_{i:03d}", "Hall2-Cell{i}", "LINE.{i}.A", "{i}")
    return [forms[i % len(forms)].format(i=i) for i in range(1, n + 1)]


def test_names_are_unique_per_machine_and_node():
    names = {status_name(m, node, "x precision")
             for m in ("m1", "m2") for node in ("wear_monitor", "wear_monitor_y")}
    assert len(names) == 4
    assert status_name("m1", "wear_monitor", "x precision") == "m1/wear_monitor: x precision"


def test_emulated_rules_on_the_aggregators_own_cases():
    """The emulation against removeLeadingNameChaff's comment example and regex_match's whole-name rule."""
    assert remove_leading_chaff("/PREFIX/base_hokuyo_node: Connection Status", "base_hokuyo_node") == \
        "/PREFIX/Connection Status"
    assert matches({"type": "diagnostic_aggregator/GenericAnalyzer", "regex": ["ab"]}, "ab")
    assert not matches({"type": "diagnostic_aggregator/GenericAnalyzer", "regex": ["ab"]}, "abc")


def check_machines(params: dict | None, machines: list[str]) -> None:
    """Every monitor status of every machine in exactly one analyzer, Monitors, its name kept whole (no two
    machines merge); the fleet status in Fleet; another package's status in none (the aggregator's Other)."""
    seen = set()
    for machine in machines:
        for node in MONITOR_NODES:
            for task in TASKS:
                name = status_name(machine, node, task)
                paths = aggregated_paths(name, params)
                assert paths == [f"/Machines/Monitors/{machine} {node}: {task}"], (name, paths)
                seen.add(paths[0])
    assert len(seen) == len(machines) * len(MONITOR_NODES) * len(TASKS)
    assert aggregated_paths(status_name("fleet", "fleet_monitor", "fleet"), params) == \
        ["/Machines/Fleet/fleet_monitor: fleet"]
    for other in ("camera_driver: frame rate", "/arm/motor: temperature", "m1/camera_driver: fps"):
        assert aggregated_paths(other, params) == [], other


def test_any_number_of_machines_falls_into_one_analyzer_by_pattern():
    """No block per machine: 200 generated machines, the shipped ones and the fleet launch's defaults."""
    _, found = analyzers()
    assert set(found) == {"fleet", "monitors"}
    machines = generated_machine_ids(200) + sorted(shipped_machine_ids() | {"m1", "m2"})
    assert {"bench_000", "nsk_lh45_bench", "slewing_131", "mill_x", "vmc_xyz_01"} <= set(machines)
    check_machines(None, machines)


PROBE = """
import json, sys
import rclpy
from rclpy.node import Node
rclpy.init(args=sys.argv)
node = Node("analyzers", automatically_declare_parameters_from_overrides=True)
print(json.dumps({n: p.value if not hasattr(p.value, "tolist") else p.value.tolist()
                  for n, p in node._parameters.items() if n != "use_sim_time"}))
"""


@pytest.mark.ros
def test_the_file_as_rcl_gives_it_to_the_aggregator(tmp_path, ros_test_env):
    """The aggregator node ``analyzers`` in a namespace gets the analyzers (``/**/analyzers``) with the
    regex string as written; with it, 50 generated machines fall into Monitors."""
    env = ros_test_env()
    script = tmp_path / "probe.py"
    script.write_text(PROBE)
    proc = subprocess.run([sys.executable, str(script), "--ros-args", "-r", "__ns:=/plant", "--params-file",
                           str(AGGREGATOR)], capture_output=True, text=True, env=env, timeout=PLAYER_WAIT_TIMEOUT_S)
    flat = json.loads(proc.stdout.strip().splitlines()[-1])
    params: dict = {}
    for key, value in flat.items():                              # "monitors.regex" -> {"monitors": {"regex"}}
        *parents, leaf = key.split(".")
        node = params
        for p in parents:
            node = node.setdefault(p, {})
        node[leaf] = value
    assert params["monitors"]["regex"] == analyzers()[1]["monitors"]["regex"]
    check_machines(params, generated_machine_ids(50))


def test_format_value_publishes_numpy_scalars_as_python_numbers():
    """numpy 2's repr of np.float64 is 'np.float64(1.5)': a KeyValue must read '1.5' (found on the
    remaining life of a monitor with duty effects, stop 11)."""
    import numpy as np

    from guide_health.nodes.status import format_value

    assert format_value(np.float64(28.25)) == "28.25" == format_value(28.25)
    assert format_value(np.float32(0.5)) == "0.5"
    assert format_value(np.int64(7)) == "7" and format_value(np.True_) == "true" and format_value(False) == "false"
    assert format_value(np.float64("nan")) == "nan" and format_value(-np.inf) == "-inf" and format_value(None) == "nan"
    assert float(format_value(np.float64(1.0) / 3.0)) == 1.0 / 3.0
