"""Issue 16, unique aggregator-ready names: "<machine_id>/<node>: <task>" differs between machines and nodes,
and config/diagnostic_aggregator.yaml puts every shipped machine's statuses into exactly one analyzer
(GenericAnalyzer ``find_and_remove_prefix`` = startswith + remove_prefix, as diagnostic_aggregator applies it)."""
from pathlib import Path

import yaml

from guide_health.nodes.status import status_name

ROOT = Path(__file__).resolve().parents[1]
AGGREGATOR = ROOT / "config" / "diagnostic_aggregator.yaml"


def analyzers():
    params = yaml.safe_load(AGGREGATOR.read_text())["/**/analyzers"]["ros__parameters"]
    return params["path"], {k: v for k, v in params.items() if isinstance(v, dict)}


def aggregated_paths(name: str) -> list[str]:
    """The /diagnostics_agg names a status gets: one per matching GenericAnalyzer."""
    base, found = analyzers()
    paths = []
    for analyzer in found.values():
        assert analyzer["type"] == "diagnostic_aggregator/GenericAnalyzer"
        for prefix in analyzer["find_and_remove_prefix"]:
            if name.startswith(prefix):
                paths.append(f"/{base}/{analyzer['path']}/{name[len(prefix):]}")
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


def test_names_are_unique_per_machine_and_node():
    names = {status_name(m, node, "x precision")
             for m in ("m1", "m2") for node in ("wear_monitor", "wear_monitor_y")}
    assert len(names) == 4
    assert status_name("m1", "wear_monitor", "x precision") == "m1/wear_monitor: x precision"


def test_every_shipped_machine_and_the_fleet_fall_into_exactly_one_analyzer():
    machines = shipped_machine_ids() | {"m1", "m2", "fleet"}      # + launch/fleet.launch.py's default fleet
    assert {"bench_000", "nsk_lh45_bench", "slewing_131", "mill_x"} <= machines
    for machine in machines:
        node = "fleet_monitor" if machine == "fleet" else "wear_monitor"
        paths = aggregated_paths(status_name(machine, node, "x precision"))
        assert len(paths) == 1, (machine, paths)
        group = "Fleet" if machine == "fleet" else machine
        assert paths[0] == f"/Machines/{group}/{node}: x precision"
    # a machine whose id starts like another's is not swallowed by it: the prefix ends with '/'
    assert aggregated_paths("m10/wear_monitor: x precision") == []


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
