"""Samples missing by stamp gaps, live == offline: a bag with joint and load samples removed, played into
the wear_monitor, gives the status keys the offline replay computes, and both equal the samples removed."""
import dataclasses
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rclpy")

from guide_health.analysis.replay import analyse  # noqa: E402
from guide_health.io.bag.reader import read_machine_bag  # noqa: E402
from guide_health.io.bag.writer import write_machine_bag  # noqa: E402
from guide_health.nodes.session import (  # noqa: E402
    bag_counts,
    clean_fastdds_shm,
    settled_status_after_bag,
)
from guide_health.params import simulation_params, wear_monitor_params  # noqa: E402
from guide_health.sim.machine import simulate_machine  # noqa: E402

pytestmark = pytest.mark.ros
ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "config" / "bench_000.yaml"
STATUS = "bench_000/wear_monitor: x precision"
JOINT_HOLES = [(50, 1), (1000, 3), (2500, 10), (4000, 20), (5990, 3)]      # 37 samples in 5 places
LOAD_HOLES = [(100, 2), (400, 1)]                                         # 3 loads (1 Hz: 3 s and 2 s gaps)


@pytest.fixture
def ros_env(ros_test_env):
    env = ros_test_env()
    yield env
    clean_fastdds_shm()


def keep(n: int, holes) -> np.ndarray:
    mask = np.ones(n, dtype=bool)
    for start, length in holes:
        mask[start:start + length] = False
    return mask


def bag_with_holes(tmp_path: Path):
    """10 min at 10 Hz joint / 1 Hz load (bench_000), with JOINT_HOLES and LOAD_HOLES removed."""
    params = wear_monitor_params(BENCH)
    sim = dict(simulation_params(BENCH), duration_h=1 / 6, joint_state_rate_hz=10.0, load_rate_hz=1.0,
               measurement_interval_h=0.05)
    run = simulate_machine(params, sim, seed=11)
    j, ld = keep(run.joint_t_ns.size, JOINT_HOLES), keep(run.load_t_ns.size, LOAD_HOLES)
    vel = run.joint_velocity_m_s
    run = dataclasses.replace(run, joint_t_ns=run.joint_t_ns[j], joint_position_m=run.joint_position_m[j],
                              joint_velocity_m_s=vel[j] if vel.size else vel, load_t_ns=run.load_t_ns[ld],
                              load_n=run.load_n[ld])
    bag = tmp_path / "holes"
    write_machine_bag(run, bag, storage="sqlite3")
    return params, bag


def test_live_missing_estimate_equals_offline_and_the_samples_removed(tmp_path, ros_env):
    params, bag = bag_with_holes(tmp_path)
    offline = analyse(read_machine_bag(bag, joint="x"), params)[1]
    assert (offline["joint_samples_missing_estimate"], offline["load_samples_missing_estimate"]) == (37, 3)
    assert offline["samples_missing_estimate"] == 40
    assert "40 samples missing (stamp gaps: joint_states 37, load 3)" in offline["message"]
    live = settled_status_after_bag("guide_health.nodes.wear_monitor", BENCH,
                                    {"state_file": "none", "diagnostics_period_s": 0.25}, ros_env, bag, STATUS,
                                    tmp_path / "node.log", collector_name="test_gaps_collector",
                                    counts=bag_counts(offline))
    values = live["values"]
    assert int(values["samples"]) == offline["samples"], "messages were lost on the way"
    for key in ("samples_missing_estimate", "joint_samples_missing_estimate", "load_samples_missing_estimate"):
        assert int(values[key]) == offline[key], key
    assert float(values["joint_period_estimate_us"]) == offline["joint_period_estimate_us"] == 100_000.0
    assert int(values["messages_lost"]) == 0          # DDS saw no loss: the samples were never published
    assert "40 samples missing (stamp gaps: joint_states 37, load 3)" in live["message"]
