"""bag_player -> subscriber in another process: delivered messages/s and losses (issue 6.3).

    .venv/bin/python bench/bench_bag_player.py [--messages 200000] [--workdir DIR]

A counting subscriber process (rclpy EventsExecutor, raw subscriptions, reliable) listens on the bag's
topics; bag_player plays a bench bag to it in three configurations measured in the same run:
  burst      --max-rate 0 --depth 1000: no pacing, a keep_last(1000) reliable publisher matching the
             keep_last(1000) subscriber (the baseline: what a naive player with the subscriber's own QoS
             does; the subscriber drops what it cannot take in time). Before issue 17 the publisher had
             depth 100, a tenth of the subscriber's: a misconfigured baseline that lost more than needed
  paced      the default token bucket (DEFAULT_MAX_RATE msg/s) into a keep_last(1000) subscriber
  flow       --max-rate 0 into a reliable keep_all subscriber: the writer waits for the reader
             (back-pressure), so nothing is lost at any speed
For each: messages sent, received, lost, and the delivered rate (received / time from the first to the
last message at the subscriber). Target: 'flow' delivers without loss at >= 20 k msg/s.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SUBSCRIBER = r'''
import json, sys, time
import rclpy
from rclpy.experimental import EventsExecutor
from rclpy.qos import QoSProfile, HistoryPolicy, ReliabilityPolicy
from sensor_msgs.msg import JointState
from geometry_msgs.msg import WrenchStamped
from std_msgs.msg import Float64
keep_all = sys.argv[1] == "keep_all"
idle_s = float(sys.argv[2])
rclpy.init()
node = rclpy.create_node("bench_counter")
qos = (QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE) if keep_all
       else QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE))
count = {"n": 0, "first": None, "last": None}
def cb(_raw):
    now = time.monotonic()
    if count["first"] is None:
        count["first"] = now
    count["last"] = now
    count["n"] += 1
for typ, topic in ((JointState, "/joint_states"), (WrenchStamped, "/guide/load"), (Float64, "/guide/straightness")):
    node.create_subscription(typ, topic, cb, qos, raw=True)
ex = EventsExecutor()
ex.add_node(node)
print("ready", flush=True)
start = time.monotonic()
while True:
    ex.spin_once(timeout_sec=0.2)
    last = count["last"] or start
    if time.monotonic() - last > idle_s and (count["n"] or time.monotonic() - start > 60):
        break
span = (count["last"] - count["first"]) if count["n"] > 1 else float("nan")
print(json.dumps({"received": count["n"], "span_s": span}), flush=True)
'''


def make_bag(n_joint: int, workdir: Path) -> Path:
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    bag = workdir / f"player_{n_joint}"
    if not bag.exists():
        params_file = ROOT / "config" / "bench_000.yaml"
        sim = dict(simulation_params(params_file), duration_h=n_joint / 1000.0 / 3600.0,
                   joint_state_rate_hz=1000.0, load_rate_hz=100.0, measurement_interval_h=0.01)
        write_machine_bag(simulate_machine(wear_monitor_params(params_file), sim, seed=3), bag)
    return bag


def trial(bag: Path, env: dict, sub_qos: str, player_args: list[str]) -> dict:
    sub = subprocess.Popen([sys.executable, "-c", SUBSCRIBER, sub_qos, "10.0"], env=env,
                           stdout=subprocess.PIPE, text=True)
    assert sub.stdout.readline().strip() == "ready"
    t0 = time.monotonic()
    player = subprocess.run([sys.executable, "-m", "guide_health.nodes.bag_player", str(bag),
                             "--wait-subscribers", "1", "--ack-timeout", "10"] + player_args,
                            env=env, capture_output=True, text=True, cwd=ROOT)
    wall = time.monotonic() - t0
    result = json.loads(sub.stdout.readline())
    sub.wait(timeout=30)
    result["player_exit"] = player.returncode
    result["player_summary"] = player.stderr.strip().splitlines()[-1] if player.stderr.strip() else ""
    result["player_wall_s"] = wall
    return result


def main() -> int:
    from guide_health.io.bag.info import bag_info
    from guide_health.nodes.session import clean_fastdds_shm, isolated_ros_env

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--messages", type=float, default=2e5, help="JointState messages in the bench bag")
    ap.add_argument("--workdir", default="/tmp/guide_health_bench")
    args = ap.parse_args()
    workdir = Path(args.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    bag = make_bag(int(args.messages), workdir)
    sent = bag_info(bag)["messages"]
    env = isolated_ros_env()
    configs = [
        ("burst", "keep_last", ["--max-rate", "0", "--depth", "1000"]),
        ("paced", "keep_last", []),
        ("flow", "keep_all", ["--max-rate", "0"]),
    ]
    print(f"bag {bag}: {sent:,} messages")
    print(f"{'config':8s} {'sent':>9s} {'received':>9s} {'lost':>8s} {'delivered msg/s':>16s}")
    for name, qos, extra in configs:
        r = trial(bag, env, qos, extra)
        clean_fastdds_shm()
        rate = r["received"] / r["span_s"] if r["span_s"] == r["span_s"] and r["span_s"] > 0 else float("nan")
        print(f"{name:8s} {sent:9,d} {r['received']:9,d} {sent - r['received']:8,d} {rate:16,.0f}"
              f"   [{r['player_summary']}]", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
