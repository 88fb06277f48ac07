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

import tempfile  # noqa: E402

from bench_live_node import FEEDER, cpu_seconds  # noqa: E402

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
while rclpy.ok():                     # the node's loop (nodes/common.run_node)
    executor.spin_once(timeout_sec=0.1)
'''


def _line(proc, prefix: str) -> str:
    """The first stdout line starting with `prefix` (Fast DDS prints its transport errors there too)."""
    for line in proc.stdout:
        if line.startswith(prefix):
            return line
    raise SystemExit(f"no {prefix!r} line from {proc.args[:2]}")


def bare_trial(seconds: float, rate: float, env: dict) -> dict:
    n = int(seconds * rate)
    sub = subprocess.Popen([sys.executable, "-c", BARE, str(n), str(seconds + 60.0)], env=env,
                           stdout=subprocess.PIPE, text=True, cwd=ROOT)
    time.sleep(1.0)
    feeder = subprocess.Popen([sys.executable, "-c", FEEDER, str(seconds), str(rate)], env=env,
                              stdout=subprocess.PIPE, text=True, cwd=ROOT)
    _line(feeder, "start")
    cpu0, t0 = cpu_seconds(sub.pid), time.monotonic()
    sent = int(_line(feeder, "sent").split()[1])
    cpu1, t1 = cpu_seconds(sub.pid), time.monotonic()
    feeder.wait(timeout=60)
    got = _line(sub, "count").split()
    sub.wait(timeout=60)
    return {"sent": sent, "joint": int(got[1]), "load": int(got[2]), "cpu_s": cpu1 - cpu0, "feed_s": t1 - t0}


def trial(seconds: float, rate: float, env: dict) -> dict:
    """bench_live_node.trial for the events executor, reading the feeder's lines past Fast DDS noise."""
    from guide_health.nodes.session import DiagnosticsCollector, start_node, stop_node

    status_name = "wear_monitor: x precision"
    with tempfile.TemporaryDirectory() as tmp:
        collector = DiagnosticsCollector("bench_collector_limit")
        node = start_node("guide_health.nodes.wear_monitor", ROOT / "config" / "bench_000.yaml",
                          {"state_file": f"{tmp}/state.db", "executor": "events", "input_timeout_s": 30.0},
                          env, Path(tmp) / "node.log")
        try:
            assert collector.wait_for(status_name, timeout=30) is not None
            feeder = subprocess.Popen([sys.executable, "-c", FEEDER, str(seconds), str(rate)], env=env,
                                      stdout=subprocess.PIPE, text=True, cwd=ROOT)
            _line(feeder, "start")
            cpu0, t0 = cpu_seconds(node.pid), time.monotonic()
            sent = int(_line(feeder, "sent").split()[1])
            cpu1, t1 = cpu_seconds(node.pid), time.monotonic()
            feeder.wait(timeout=60)
            status = collector.wait_settled(status_name, "samples", settle_s=2.0, timeout=120)
        finally:
            stop_node(node)
            collector.close()
    v = status["values"]
    return {"sent": sent, "joint": int(float(v["samples"])), "load": int(float(v["load_samples"])),
            "cpu_pct": 100.0 * (cpu1 - cpu0) / (t1 - t0), "feed_s": t1 - t0,
            "callback_us": float(v.get("callback_time_us", "nan")), "model_us": float(v.get("model_time_us", "nan"))}


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
    node = trial(args.seconds, args.rate_hz, env)
    clean_fastdds_shm()
    bare_us = bare["cpu_s"] / (bare["joint"] + bare["load"]) * 1e6
    node_us = node["cpu_pct"] / 100.0 * node["feed_s"] / (node["joint"] + max(node["load"], 0)) * 1e6
    print(f"bare subscriber  sent {bare['sent']:,} + {bare['sent']:,} in {bare['feed_s']:.1f} s, received "
          f"{bare['joint']:,} + {bare['load']:,}; CPU {bare_us:.1f} us/msg")
    print(f"wear_monitor     sent {node['sent']:,} + {node['sent']:,} in {node['feed_s']:.1f} s, accepted "
          f"{node['joint']:,} + {node['load']:,}; CPU {node_us:.1f} us/msg (callback {node['callback_us']:.1f} us, "
          f"model {node['model_us']:.1f} us)")
    print(f"ratio node / bare CPU per message  {node_us / bare_us:.2f}   (target <= 1.2)", flush=True)
    loss = trial(args.seconds, args.loss_rate_hz, env)
    clean_fastdds_shm()
    print(f"loss at {args.loss_rate_hz:g} Hz joint + load, reliable: sent {loss['sent']:,} + {loss['sent']:,} in "
          f"{loss['feed_s']:.1f} s; lost {loss['sent'] - loss['joint']} + {loss['sent'] - loss['load']} "
          f"(target 0); node CPU {loss['cpu_pct']:.0f} % of one core")
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
