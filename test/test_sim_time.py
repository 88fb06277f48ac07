"""Issue 16, sim time: bag_player --clock publishes /clock with the bag's log time, and a wear_monitor started
with use_sim_time:=true runs its diagnostics timer on it: no status before the clock starts, statuses
stamped in bag time (2023, not today's wall time) during the play, and the same numbers as offline replay."""
import time
from pathlib import Path

import pytest

pytest.importorskip("rclpy")

from guide_health.analysis.replay import analyse  # noqa: E402
from guide_health.io.bag.reader import read_machine_bag  # noqa: E402
from guide_health.io.bag.writer import write_machine_bag  # noqa: E402
from guide_health.nodes.bag_player import ClockPublisher, build_parser  # noqa: E402
from guide_health.nodes.session import (  # noqa: E402
    DiagnosticsCollector,
    clean_fastdds_shm,
    play_bag,
    start_node,
    stop_node,
)
from guide_health.params import simulation_params, wear_monitor_params  # noqa: E402
from guide_health.sim.machine import simulate_machine  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "config" / "bench_000.yaml"
STATUS = "simtime_m1/wear_monitor: x precision"


def test_clock_option_and_tick_period():
    assert build_parser().parse_args(["b"]).clock is None
    assert build_parser().parse_args(["b", "--clock"]).clock == 100.0
    assert build_parser().parse_args(["b", "--clock", "10"]).clock == 10.0

    class FakeNode:
        def create_publisher(self, msg_type, topic, qos):
            self.topic, self.sent = topic, []
            return type("P", (), {"publish": lambda _, m: self.sent.append(m.clock.sec * 10**9 + m.clock.nanosec)})()

    node = FakeNode()
    clock = ClockPublisher(node, 10.0)                  # every 0.1 s of bag time
    for t_ns in (5 * 10**9, 5 * 10**9 + 50_000_000, 5 * 10**9 + 100_000_000, 5 * 10**9 + 150_000_000):
        clock.tick(t_ns)
    clock.finish()                                       # the last log time at the end
    assert node.topic == "/clock"
    assert node.sent == [5_000_000_000, 5_100_000_000, 5_150_000_000]


#: the test's own /clock after the bag: one tick per TICK_WALL_S of wall time, each one status period of bag time on
PERIOD_S = 1.0
TICK_WALL_S = 0.25


def run_clock_on(collector, from_ns, done, timeout_s=300.0):
    """After the bag: the node has its data queued but stamps a status only when /clock passes a period, so
    run the clock on, one period of bag time per tick at a fixed wall-time cadence, until ``done(status)``
    (at most ``timeout_s``: a loaded machine may take minutes to drain the queue the player filled; the wait
    ends as soon as a status is done). The ticks start once the node's /clock subscription has matched this
    publisher (a best-effort tick sent before is lost). (the done status or None, the ticks sent)."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rosgraph_msgs.msg import Clock

    publisher = collector.node.create_publisher(Clock, "/clock", QoSProfile(depth=1,
                                                reliability=ReliabilityPolicy.BEST_EFFORT))
    assert wait_until(lambda: publisher.get_subscription_count() >= 1, 120.0), "no /clock subscriber matched"
    end = time.monotonic() + timeout_s
    ticks = 0
    while time.monotonic() < end:
        status = collector.wait_for(STATUS, done, timeout=TICK_WALL_S)
        if status is not None:
            return status, ticks
        ticks += 1
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = divmod(from_ns + int(ticks * PERIOD_S * 1e9), 10**9)
        publisher.publish(msg)
    return None, ticks


def wait_until(condition, timeout_s: float) -> bool:
    """Poll ``condition`` (a graph query) until it holds; False after ``timeout_s``."""
    end = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > end:
            return False
        time.sleep(0.05)
    return True


@pytest.fixture
def ros_env(ros_test_env):
    env = ros_test_env()            # the test's own domain, UDP only (conftest)
    yield env
    clean_fastdds_shm()


@pytest.mark.ros
def test_node_with_use_sim_time_runs_on_the_bag_clock(tmp_path, ros_env):
    params = wear_monitor_params(BENCH)
    sim = dict(simulation_params(BENCH), duration_h=0.1, joint_state_rate_hz=10.0, load_rate_hz=1.0,
               measurement_interval_h=0.25)
    run = simulate_machine(params, sim, seed=11)
    bag = tmp_path / "bag"
    write_machine_bag(run, bag)
    offline = analyse(read_machine_bag(bag, joint="x"), params)[1]
    stamps_ns = [int(t[0]) for t in (run.joint_t_ns, run.load_t_ns, run.straightness_t_ns) if len(t)]
    bag_start_ns = min(stamps_ns)
    bag_end_ns = max(int(t[-1]) for t in (run.joint_t_ns, run.load_t_ns, run.straightness_t_ns) if len(t))

    collector = DiagnosticsCollector("sim_time_collector")
    node = start_node("guide_health.nodes.wear_monitor", BENCH,
                      {"state_file": "''", "machine_id": "simtime_m1", "diagnostics_period_s": PERIOD_S,
                       "use_sim_time": "true",
                       "input_timeout_s": 60.0}, ros_env, log_path=tmp_path / "node.log")
    try:
        # the node is up once its /diagnostics publisher is in the graph (not after a fixed delay)
        assert wait_until(lambda: collector.node.count_publishers("/diagnostics") >= 1, 120.0), \
            (tmp_path / "node.log").read_text()
        time.sleep(2.5 * PERIOD_S)               # > two periods of wall time: a wall-time timer would have fired
        assert collector.get(STATUS) is None, "a status before /clock started"
        played = play_bag(bag, ros_env, ["--wait-subscribers", "1", "--max-rate", "0", "--clock", "10"])
        assert played.returncode == 0, played.stderr
        live, ticks = run_clock_on(collector, bag_end_ns,
                                   lambda s: float(s["values"]["samples"]) >= offline["samples"])
    finally:
        stop_node(node)
        collector.close()
    assert live is not None, (tmp_path / "node.log").read_text()
    stamps = [status["stamp_ns"] for status in collector.history[STATUS]]
    # the player published /clock up to the bag's end; this test ran it on by ``ticks`` periods of bag time
    last_ns = bag_end_ns + int(ticks * PERIOD_S * 1e9)
    assert all(bag_start_ns <= t <= last_ns for t in stamps), (stamps[:3], bag_start_ns, ticks)
    # one status per period of bag time (360 s of bag + the ticks), whatever the wall time took
    assert 10 <= len(stamps) <= (last_ns - bag_start_ns) / (PERIOD_S * 1e9) + 1, (len(stamps), ticks)
    assert float(live["values"]["samples"]) == offline["samples"]
    assert float(live["values"]["sliding_distance_m"]) == pytest.approx(offline["sliding_distance_m"], rel=1e-9)
