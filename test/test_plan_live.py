"""The live `plan` service (std_srvs/Trigger, scenario in the parameter plan_scenario) of a wear_monitor that
took a bag equals `guide-health plan` of the same bag: live == offline for the answer; a bad scenario is
refused with its one-line reason."""
import json
from pathlib import Path

import pytest

pytest.importorskip("rclpy")

from guide_health.cli.app import main  # noqa: E402
from guide_health.nodes.session import PLAYER_WAIT_TIMEOUT_S, bag_counts  # noqa: E402

pytestmark = pytest.mark.ros
BENCH = Path(__file__).resolve().parents[1] / "config" / "bench_000.yaml"
STATUS = "bench_000/wear_monitor: x precision"
SCENARIO = "lighter, one shift: load=0.8, shift=8x5"


def call_plan(env, scenario: str) -> tuple[bool, str]:
    """Set plan_scenario, call /plan (guide-health maintenance's rclpy client, in this test's domain)."""
    import os

    import rclpy

    from guide_health.cli.maintenance import _call

    old = dict(os.environ)
    os.environ.update(env)
    context = rclpy.Context()
    rclpy.init(args=[], context=context)
    try:
        return _call(context, "/wear_monitor", "/plan", {"plan_scenario": scenario}, PLAYER_WAIT_TIMEOUT_S)
    finally:
        rclpy.shutdown(context=context)
        os.environ.clear()
        os.environ.update(old)


def test_live_plan_service_equals_the_offline_plan(tmp_path, live_wear_node, capsys):
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    # 1 h at 2 Hz: the plan's rows are the model's numbers after the bag, the same function live and offline
    sim = dict(simulation_params(BENCH), duration_h=1.0, joint_state_rate_hz=2.0, load_rate_hz=1.0,
               measurement_interval_h=0.25)
    bag = tmp_path / "bag"
    write_machine_bag(simulate_machine(wear_monitor_params(BENCH), sim, seed=5), bag)
    assert main(["plan", str(bag), "--params", str(BENCH), "--scenario", SCENARIO, "--no-plot", "--json",
                 "--out", str(tmp_path / "plan")]) == 0
    offline = json.loads(capsys.readouterr().out)["rows"]
    assert main(["replay", str(bag), "--params", str(BENCH), "--no-plot", "--json", "--out", str(tmp_path / "r")]) == 0
    counts = bag_counts(json.loads(capsys.readouterr().out))
    live_wear_node.start(BENCH, {"state_file": "none", "diagnostics_period_s": 0.25}, STATUS)
    live_wear_node.play(bag)
    status = live_wear_node.wait_counts(STATUS, counts)
    assert all(float(status["values"][k]) == v for k, v in counts.items()), "messages were lost on the way"
    ok, answer = call_plan(live_wear_node.env, SCENARIO)
    bad_ok, reason = call_plan(live_wear_node.env, "load=0")
    assert ok, answer
    live = json.loads(answer)["rows"]
    assert [r["scenario"] for r in live] == [r["scenario"] for r in offline] == ["as observed", "lighter, one shift"]
    for a, b in zip(live, offline):
        assert a["now_t_ns"] == b["now_t_ns"] and a["utilisation"] == b["utilisation"]
        for key in ("life_h", "life_h_low", "life_h_high"):       # per sample live, vectorised offline: 1e-9
            assert a[key] == pytest.approx(b[key], rel=1e-9), key
        assert abs(a["limit_t_ns"] - b["limit_t_ns"]) <= 1e-9 * (b["limit_t_ns"] - b["now_t_ns"])
    assert not bad_ok and reason == "scenario load=0: must be a finite number > 0"
