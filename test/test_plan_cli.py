"""`guide-health plan`: a simulated machine's bag replayed with its parameters, its limit date at the observed
utilisation equal to `guide-health replay`'s, and the scenarios' dates by hand (a shift pattern's weekly
hours, Archard's 1 / load); the CSV, JSON and PNG written; bad scenarios one line, exit 2."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from guide_health.cli.app import main

CONFIG = Path(__file__).resolve().parents[1] / "config" / "bench_000.yaml"
S = 10**9


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    """1 h of the seed-000 bench (no effects: K and the duty set the life), 10 Hz, a measurement every 0.2 h."""
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    root = tmp_path_factory.mktemp("plan")
    sim = dict(simulation_params(CONFIG), duration_h=1.0, joint_state_rate_hz=10.0, measurement_interval_h=0.2,
               wear_coefficient_factor=1.5)
    write_machine_bag(simulate_machine(wear_monitor_params(CONFIG), sim, seed=4), root / "bag")
    return root / "bag"


def run_cli(capsys, argv):
    code = main([*argv, "--json"])
    out = capsys.readouterr()
    return code, json.loads(out.out) if code == 0 else out.err


def test_plan_equals_replay_and_the_scenarios_by_hand(bag, tmp_path, capsys):
    _, replay = run_cli(capsys, ["replay", str(bag), "--params", str(CONFIG), "--out", str(tmp_path / "r")])
    scenarios = tmp_path / "scenarios.yaml"
    scenarios.write_text("scenarios:\n  - name: two shifts\n    shift: 16x5\n  - name: lighter jobs\n"
                         "    load: 0.8\n    stroke: 1.0\n")
    code, plan = run_cli(capsys, ["plan", str(bag), "--params", str(CONFIG), "--scenario", "one shift: shift=8x5",
                                  "--scenario", "load=0.8", "--scenarios", str(scenarios),
                                  "--out", str(tmp_path / "p")])
    assert code == 0
    rows = {r["scenario"]: r for r in plan["rows"]}
    assert list(rows) == ["as observed", "one shift", "load=0.8", "two shifts", "lighter jobs"]
    base = rows["as observed"]
    for key in ("", "_low", "_high"):                      # the replay's (the live status's) numbers exactly
        assert base[f"life_h{key}"] == replay[f"remaining_life_h{key}"]
        assert base[f"limit_date_utc{key}"] == replay[f"limit_date_utc{key}"]
    life_h, now = replay["remaining_life_h"], base["now_t_ns"]
    for name, weekly_h in (("one shift", 40.0), ("two shifts", 80.0)):
        weeks = life_h / weekly_h
        assert rows[name]["life_h"] == life_h
        assert abs(rows[name]["limit_t_ns"] - (now + weeks * 7 * 86400 * S)) <= 1e-9 * weeks * 7 * 86400 * S
    for name in ("load=0.8", "lighter jobs"):               # Archard: the rate ~ W, no load_exponent named
        assert rows[name]["life_h"] == pytest.approx(life_h / 0.8, rel=1e-9)
    with open(plan["files"]["csv"]) as handle:
        table = list(csv.DictReader(handle))
    assert [r["scenario"] for r in table] == list(rows) and table[1]["limit_date_utc"] == rows["one shift"][
        "limit_date_utc"]
    assert json.loads(Path(plan["files"]["json"]).read_text())["rows"][0]["life_h"] == life_h
    from matplotlib.image import imread
    assert Path(plan["files"]["png"]).name == "plan_bench_000.png" and imread(plan["files"]["png"]).shape[0] > 300


@pytest.mark.parametrize("argv, message", [
    (["--scenario", "load=-1"], "scenario load=-1: must be a finite number > 0"),
    (["--scenario", "relube=2w"], "relube needs the lubrication_interval effect"),
    (["--scenario", "regrind=2001-01-01"], "not after the data's present"),
])
def test_bad_scenarios_are_one_line_errors(bag, tmp_path, capsys, argv, message):
    code, err = run_cli(capsys, ["plan", str(bag), "--params", str(CONFIG), "--no-plot", "--out",
                                 str(tmp_path / "p"), *argv])
    assert code == 2 and message in err and err.count("\n") == 1
