"""Live wear_monitor against a bare rclpy subscriber (issue 14): CPU per message and loss.

    .venv/bin/python bench/bench_live_limit.py [--seconds 10] [--rate-hz 5000] [--loss-rate-hz 8000]

bench_live_node's feeder publishes JointState + WrenchStamped at --rate-hz each (reliable keep_all,
pre-encoded CDR) into, one after the other in the same run:
  bare         a subscriber process with the node's QoS and executor (EventsExecutor, raw subscriptions)
               whose callbacks only count (the floor of any rclpy node);
  wear_monitor the node (events executor: fixed-offset decoding, samples copied into the batched feed).
Printed: node CPU per received message [us] of each (from /proc/<pid>/stat over the feeding window) and
their ratio (target <= 1.2), then the samples the node lost at --loss-rate-hz joint + load (target 0).
No timed assertion: the machine is shared.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_live_node import FEEDER, cpu_seconds, trial  # noqa: E402

BARE = r'''
import os, sys, time
import rclpy
from rclpy.experimental import EventsExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from geometry_msgs.msg import WrenchStamped
from sensor_msgs.msg import JointState
expected, deadline = int(sys.argv[1]), time.monotonic() + float(sys.argv[2])
rclpy.init()
node = rclpy.create_node("bare_subscriber")
qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE)
counts = [0, 0]
def on_joint(raw): counts[0] += 1
def on_load(raw): counts[1] += 1
def check():
    if (counts[0] >= expected and counts[1] >= expected) or time.monotonic() > deadline:
        print(f"count {counts[0]} {counts[1]}", flush=True)
        os._exit(0)
node.create_subscription(JointState, "/joint_states", on_joint, qos, raw=True)
node.create_subscription(WrenchStamped, "/guide/load", on_load, qos, raw=True)
node.create_timer(0.2, check)
executor = EventsExecutor()
executor.add_node(node)
executor.spin()
'''


def bare_trial(seconds: float, rate: float, env: dict) -> dict:
    n = int(seconds * rate)
    sub = subprocess.Popen([sys.executable, "-c", BARE, str(n), str(seconds + 60.0)], env=env,
                           stdout=subprocess.PIPE, text=True, cwd=ROOT)
    time.sleep(1.0)
    feeder = subprocess.Popen([sys.executable, "-c", FEEDER, str(seconds), str(rate)], env=env,
                              stdout=subprocess.PIPE, text=True, cwd=ROOT)
    assert feeder.stdout.readline().strip() == "start"
    cpu0, t0 = cpu_seconds(sub.pid), time.monotonic()
    sent = int(feeder.stdout.readline().split()[1])
    cpu1, t1 = cpu_seconds(sub.pid), time.monotonic()
    feeder.wait(timeout=60)
    got = sub.stdout.readline().split()
    sub.wait(timeout=60)
    return {"sent": sent, "joint": int(got[1]), "load": int(got[2]), "cpu_s": cpu1 - cpu0, "feed_s": t1 - t0}


def main() -> int:
    from guide_health.nodes.session import clean_fastdds_shm, isolated_ros_env

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--rate-hz", type=float, default=5000.0)
    ap.add_argument("--loss-rate-hz", type=float, default=8000.0)
    args = ap.parse_args()
    env = isolated_ros_env()
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    print(f"load average at start: {os.getloadavg()[0]:.1f} (2 cores shared)", flush=True)
    bare = bare_trial(args.seconds, args.rate_hz, env)
    clean_fastdds_shm()
    node = trial("events", args.seconds, args.rate_hz, env)
    clean_fastdds_shm()
    bare_us = bare["cpu_s"] / (bare["joint"] + bare["load"]) * 1e6
    node_us = node["cpu_pct"] / 100.0 * node["feed_s"] / (node["joint"] + max(node["load"], 0)) * 1e6
    print(f"bare subscriber  sent {bare['sent']:,} + {bare['sent']:,} in {bare['feed_s']:.1f} s, received "
          f"{bare['joint']:,} + {bare['load']:,}; CPU {bare_us:.1f} us/msg")
    print(f"wear_monitor     sent {node['sent']:,} + {node['sent']:,} in {node['feed_s']:.1f} s, accepted "
          f"{node['joint']:,} + {node['load']:,}; CPU {node_us:.1f} us/msg (callback {node['callback_us']:.1f} us, "
          f"model {node['model_us']:.1f} us)")
    print(f"ratio node / bare CPU per message  {node_us / bare_us:.2f}   (target <= 1.2)", flush=True)
    loss = trial("events", args.seconds, args.loss_rate_hz, env)
    clean_fastdds_shm()
    print(f"loss at {args.loss_rate_hz:g} Hz joint + load, reliable: sent {loss['sent']:,} + {loss['sent']:,} in "
          f"{loss['feed_s']:.1f} s; lost {loss['sent'] - loss['joint']} + {loss['sent'] - loss['load']} "
          f"(target 0); node CPU {loss['cpu_pct']:.0f} % of one core")
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
