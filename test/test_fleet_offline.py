"""`guide-health fleet replay|diagnose`: many bags on Dask (a LocalCluster of worker processes, or a
scheduler given by address) give each bag the single-bag command's result; a bad bag is a named row
and the run's exit status says partial (3)."""
import json
from pathlib import Path

import pytest

from guide_health.analysis.fleet import same_result
from guide_health.cli.app import main
from guide_health.cli.fleet import PARTIAL_EXIT_STATUS

CONFIG = Path(__file__).resolve().parents[1] / "config" / "bench_000.yaml"
FACTORS = (1.0, 1.8, 0.6)          # truth K / configured K of the three machines


@pytest.fixture(scope="module")
def fleet_bags(tmp_path_factory):
    """Three tiny machine bags (1 h, 10 Hz joint states, a measurement every 0.2 h), namespaces /m0../m2
    (bag2's run metadata names its machine press7), and a broken bag (unparsable metadata.yaml)."""
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    root = tmp_path_factory.mktemp("fleet")
    params = wear_monitor_params(CONFIG)
    for i, factor in enumerate(FACTORS):
        sim = dict(simulation_params(CONFIG), duration_h=1.0, joint_state_rate_hz=10.0,
                   measurement_interval_h=0.2, wear_coefficient_factor=factor)
        run = simulate_machine(params, sim, seed=i)
        if i == 2:
            run.metadata["machine_id"] = "press7"           # the run metadata names the machine
        write_machine_bag(run, root / "bags" / f"bag{i}", namespace=f"/m{i}")
    broken = root / "broken"
    broken.mkdir()
    (broken / "metadata.yaml").write_text("rosbag2_bagfile_information: [\n")
    (broken / "broken.db3").write_bytes(b"not a database")
    return root


@pytest.fixture(scope="module")
def scheduler():
    """The address of a Dask scheduler with one worker process, shared by the tests that hand bags to a
    scheduler (a cluster's start-up costs each worker an interpreter and the package's imports)."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        yield cluster.scheduler_address


def run_cli(capsys, argv):
    code = main([*argv, "--json"])
    return code, json.loads(capsys.readouterr().out)


def single_replays(capsys, root, tmp_path):
    return [run_cli(capsys, ["replay", str(root / "bags" / f"bag{i}"), "--params", str(CONFIG),
                             "--out", str(tmp_path / f"single{i}")])[1] for i in range(len(FACTORS))]


def test_fleet_replay_on_local_worker_processes_equals_single_replays(fleet_bags, tmp_path, capsys):
    singles = single_replays(capsys, fleet_bags, tmp_path)
    code, fleet = run_cli(capsys, ["fleet", "replay", str(fleet_bags / "bags"), "--params", str(CONFIG),
                                   "--workers", "2", "--out", str(tmp_path / "fleet")])
    assert code == 0 and fleet["engine"] == "LocalCluster(2 processes)"
    assert (fleet["bags"], fleet["ok"], fleet["failed"]) == (3, 3, 0)
    # the machine: run metadata machine_id (press7), else the topic namespace (m0, m1)
    assert [e["machine"] for e in fleet["results"]] == ["m0", "m1", "press7"]
    for single, entry in zip(singles, fleet["results"]):
        assert entry["ok"] and same_result(single, entry["result"])
        assert entry["result"]["remaining_life_h"] == single["remaining_life_h"]      # bit for bit
        # the per-bag report directory holds what the single command writes
        report = json.loads((tmp_path / "fleet" / "bags" / Path(entry["bag"]).name / "report.json").read_text())
        assert same_result(report, single)
    # the K estimates are ordered as the machines' true K (FACTORS x the configured K, the simulation's truth)
    ks = [e["result"]["wear_coefficient"] for e in fleet["results"]]
    assert ks[2] < ks[0] < ks[1]
    ranked = [r["machine"] for r in sorted(fleet["rows"], key=lambda r: r["remaining_life_h"])]
    assert ranked[0] == "m1" and ranked[-1] == "press7"       # the highest K wears out first
    csv_lines = (tmp_path / "fleet" / "fleet.csv").read_text().splitlines()
    assert len(csv_lines) == 4 and csv_lines[0].startswith("machine,machine_type,bag,status,level_name")
    md = (tmp_path / "fleet" / "fleet.md").read_text()
    assert md.count("| ok |") == 3
    from matplotlib.image import imread
    assert imread(fleet["files"]["png"]).shape[0] > 100


def test_fleet_replay_on_a_scheduler_address_equals_serial(fleet_bags, scheduler, tmp_path, capsys):
    _, serial = run_cli(capsys, ["fleet", "replay", str(fleet_bags / "bags"), "--params", str(CONFIG),
                                 "--workers", "0", "--no-plot", "--out", str(tmp_path / "serial")])
    assert serial["engine"] == "serial"
    code, remote = run_cli(capsys, ["fleet", "replay", str(fleet_bags / "bags"), "--params", str(CONFIG),
                                    "--scheduler", scheduler, "--no-plot", "--out", str(tmp_path / "remote")])
    assert code == 0 and remote["engine"] == scheduler
    assert all(same_result(a["result"], b["result"]) for a, b in zip(serial["results"], remote["results"]))


def test_a_bad_bag_is_named_and_the_others_complete(fleet_bags, scheduler, tmp_path, capsys):
    """On a worker process (the shared scheduler's): the bad bags' one-line errors travel back."""
    code, fleet = run_cli(capsys, ["fleet", "replay", str(fleet_bags / "bags" / "bag0"), str(fleet_bags / "broken"),
                                   str(fleet_bags / "bags" / "bag2"), str(fleet_bags / "missing"),
                                   "--params", str(CONFIG), "--scheduler", scheduler, "--no-plot",
                                   "--out", str(tmp_path / "partial")])
    assert code == PARTIAL_EXIT_STATUS == 3
    assert (fleet["ok"], fleet["failed"]) == (2, 2)
    assert [e["ok"] for e in fleet["results"]] == [True, False, True, False]
    failed = {Path(b["bag"]).name: b["error"] for b in fleet["failed_bags"]}
    assert set(failed) == {"broken", "missing"}
    assert "broken" in failed["broken"] and "\n" not in failed["broken"] and "Traceback" not in failed["broken"]
    assert "missing" in failed["missing"]
    rows = {r["machine"]: r for r in fleet["rows"]}
    # a bag that cannot be opened is named by its directory
    assert rows["broken"]["status"] == "error" and rows["m0"]["status"] == "ok" and rows["press7"]["status"] == "ok"
    assert "broken" in (tmp_path / "partial" / "fleet.md").read_text()


def test_fleet_diagnose_equals_single_diagnose(fleet_bags, tmp_path, capsys):
    bag = fleet_bags / "bags" / "bag1"
    _, single = run_cli(capsys, ["diagnose", str(bag), "--params", str(CONFIG), "--no-plot",
                                 "--out", str(tmp_path / "single")])
    code, fleet = run_cli(capsys, ["fleet", "diagnose", str(bag), "--params", str(CONFIG), "--workers", "0",
                                   "--no-plot", "--out", str(tmp_path / "fleet")])
    assert code == 0 and same_result(single, fleet["results"][0]["result"])
    assert fleet["rows"][0]["wear_coefficient"] == single["final"]["wear_coefficient"]


def test_fleet_bad_input_is_one_line(tmp_path, capsys):
    assert main(["fleet", "replay", str(tmp_path), "--params", str(CONFIG)]) == 2     # no bags in it
    assert "neither a bag nor a directory of bags" in capsys.readouterr().err
    assert main(["fleet", "replay", str(tmp_path), "--params", str(CONFIG), "--workers", "-1"]) == 2
    bag = tmp_path / "b"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("")
    assert main(["fleet", "replay", str(bag), "--params", str(CONFIG), "--scheduler", "nonsense://x",
                 "--out", str(tmp_path / "o")]) == 2
    assert "cannot reach the Dask scheduler at nonsense://x: ValueError: unknown address scheme" \
        in capsys.readouterr().err


def test_dask_malloc_trim_is_undone_only_in_dask_workers():
    """Dask's nanny sets MALLOC_TRIM_THRESHOLD_ (slow numpy allocation); run_bag resets the thresholds there."""
    import os
    import subprocess
    import sys

    code = "from guide_health.analysis.fleet import undo_dask_malloc_trim as u; print(u())"
    env = {k: v for k, v in os.environ.items() if k != "MALLOC_TRIM_THRESHOLD_"}
    plain = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    worker = subprocess.run([sys.executable, "-c", code], env={**env, "MALLOC_TRIM_THRESHOLD_": "65536"},
                            capture_output=True, text=True, check=True)
    assert (plain.stdout.strip(), worker.stdout.strip()) == ("False", "True" if sys.platform == "linux" else "False")


def test_read_ahead_is_switched_off_only_where_the_workers_fill_the_cores():
    """share_cores: a host whose worker threads fill its cores gets no read-ahead thread, a host with cores
    left over keeps it (a fake client: two hosts, 2 threads on 2 cores and 1 thread on 4 cores)."""
    from guide_health.analysis import fleet
    from guide_health.io.bag import sqlite3_storage

    class Client:
        calls: list = []

        def scheduler_info(self):
            return {"workers": {"a1": {"host": "a", "nthreads": 1}, "a2": {"host": "a", "nthreads": 1},
                                "b1": {"host": "b", "nthreads": 1}}}

        def run(self, func, *args, workers=None):
            if func is fleet.usable_cores:
                return {"a1": 2, "a2": 2, "b1": 4}
            self.calls.append((func, args, sorted(workers)))
            return {}

    client = Client()
    assert fleet.share_cores(client) == {"a1": False, "a2": False, "b1": True}
    assert sorted(client.calls, key=str) == sorted([(sqlite3_storage.set_read_ahead, (True,), ["b1"]),
                                                    (sqlite3_storage.set_read_ahead, (False,), ["a1", "a2"])], key=str)
