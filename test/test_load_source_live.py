"""load_source model live: bag_player -> wear_monitor (no load topic in the bag, the load from the masses
and the motion) -> /diagnostics equals the offline replay of the same bag, with the new keys."""
import dataclasses
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rclpy")

from guide_health.analysis.replay import analyse  # noqa: E402
from guide_health.io.bag.reader import read_machine_bag  # noqa: E402
from guide_health.io.bag.writer import write_machine_bag  # noqa: E402
from guide_health.nodes.session import bag_counts, clean_fastdds_shm, settled_status_after_bag  # noqa: E402
from guide_health.params import simulation_params, wear_monitor_params  # noqa: E402
from guide_health.sim.machine import simulate_machine  # noqa: E402

pytestmark = pytest.mark.ros
BENCH = Path(__file__).resolve().parents[1] / "config" / "bench_000.yaml"
STATUS = "bench_000/wear_monitor: x precision"
MODEL = {"load_source": "model", "moving_mass_kg": 500.0, "workpiece_mass_kg": 100.0, "axis_incline_deg": 15.0,
         "load_lever_ratio": 0.3, "acceleration_window_s": 0.2}


@pytest.fixture
def ros_env(ros_test_env):
    yield ros_test_env()
    clean_fastdds_shm()


def test_live_model_load_matches_offline_replay(tmp_path, ros_env):
    params = wear_monitor_params(BENCH)
    sim = dict(simulation_params(BENCH), duration_h=1.0, joint_state_rate_hz=10.0, measurement_interval_h=0.25)
    run = simulate_machine(params, sim, seed=11)
    run = dataclasses.replace(run, load_t_ns=np.zeros(0, np.int64), load_n=np.zeros(0))
    bag = write_machine_bag(run, tmp_path / "no_loads")
    offline = analyse(read_machine_bag(bag, joint="x"), dict(params, **MODEL))[1]
    assert offline["load_samples"] == 0 and offline["load_source"] == "model"
    live = settled_status_after_bag("guide_health.nodes.wear_monitor", BENCH,
                                    {"state_file": str(tmp_path / "state.db"), "diagnostics_period_s": 0.25, **MODEL},
                                    ros_env, bag, STATUS, tmp_path / "node.log", collector_name="load_model_collector",
                                    counts=bag_counts(offline))
    values = live["values"]
    assert values["load_source"] == "model"
    assert live["level"] != 3, "STALE: the node waited for a load topic"
    assert float(values["samples"]) == offline["samples"]
    for key in ("sliding_distance_m", "wear_coefficient", "straightness_um", "remaining_life_h", "utilisation"):
        assert float(values[key]) == pytest.approx(offline[key], rel=1e-9), key
    assert values["limit_date_utc"] == offline["limit_date_utc"] != ""
