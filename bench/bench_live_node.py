"""Live wear_monitor at 1 kHz JointState + 1 kHz WrenchStamped from another process (issue 6.2).

    .venv/bin/python bench/bench_live_node.py [--seconds 60] [--rate-hz 1000]

A feeder process publishes JointState (joint x, a 0.05 m/s zigzag) and WrenchStamped (6000 N) at
--rate-hz each, reliable keep_all, pre-encoded CDR, paced on the wall clock, for --seconds. The node
under test runs in its own process; measured in the same run for each executor:
  events           rclpy.experimental.EventsExecutor + raw subscriptions + numpy CDR decode (the default)
  single_threaded  rclpy SingleThreadedExecutor + deserialised messages (the baseline)
Reported: messages sent and accepted by the model (joint and load), lost = sent - accepted,
node CPU [% of one core] from /proc/<pid>/stat over the feeding window, the handling time per message
and the model's share of it (the node's `callback_time_us` / `model_time_us` diagnostics keys; with the
events executor the callbacks only copy and these are the batch handling, decode + model, per message).
bench_live_limit.py compares the node with a bare subscriber.
Targets: nothing lost, CPU < 25 % of one core.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

FEEDER = r'''
import sys, time
import numpy as np
import rclpy
from rclpy.qos import QoSProfile, HistoryPolicy, ReliabilityPolicy
from sensor_msgs.msg import JointState
from geometry_msgs.msg import WrenchStamped
from guide_health.io.bag.cdr import encode_joint_states, encode_wrench_stamped
seconds, rate = float(sys.argv[1]), float(sys.argv[2])
n = int(seconds * rate)
t0_ns = 1_700_000_000_000_000_000
t_ns = t0_ns + (np.arange(n) * (1e9 / rate)).astype(np.int64)
phase = (np.arange(n) / rate * 0.05) % 0.4
x = np.where(phase < 0.2, phase, 0.4 - phase)           # 0.05 m/s zigzag over 200 mm
joints = encode_joint_states(t_ns, x, np.full(n, 0.05), "x")
force = np.zeros((n, 3)); force[:, 2] = 6000.0
loads = encode_wrench_stamped(t_ns, force)
rclpy.init()
node = rclpy.create_node("bench_feeder")
qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE)
pj = node.create_publisher(JointState, "/joint_states", qos)
pl = node.create_publisher(WrenchStamped, "/guide/load", qos)
subscribers = int(sys.argv[3]) if len(sys.argv) > 3 else 1     # readers to wait for
while pj.get_subscription_count() < subscribers or pl.get_subscription_count() < subscribers:
    time.sleep(0.01)
time.sleep(0.5)
print("start", flush=True)
start = time.monotonic()
for i in range(n):
    due = start + i / rate
    delay = due - time.monotonic()
    if delay > 0:
        time.sleep(delay)
    pj.publish(joints[i])
    pl.publish(loads[i])
print(f"sent {n} {time.monotonic() - start:.3f}", flush=True)
from rclpy.duration import Duration
pj.wait_for_all_acked(Duration(seconds=10)); pl.wait_for_all_acked(Duration(seconds=10))
'''


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def trial(executor: str, seconds: float, rate: float, env: dict) -> dict:
    from guide_health.nodes.session import DiagnosticsCollector, start_node, stop_node

    with tempfile.TemporaryDirectory() as tmp:
        collector = DiagnosticsCollector(f"bench_collector_{executor}")
        node = start_node("guide_health.nodes.wear_monitor", ROOT / "config" / "bench_000.yaml",
                          {"state_file": f"{tmp}/state.db", "executor": executor, "input_timeout_s": 30.0},
                          env, Path(tmp) / "node.log")
        try:
            assert collector.wait_for("bench_000/wear_monitor: x precision", timeout=30) is not None
            feeder = subprocess.Popen([sys.executable, "-c", FEEDER, str(seconds), str(rate)], env=env,
                                      stdout=subprocess.PIPE, text=True, cwd=ROOT)
            assert feeder.stdout.readline().strip() == "start"
            cpu0, t0 = cpu_seconds(node.pid), time.monotonic()
            sent_line = feeder.stdout.readline().split()
            cpu1, t1 = cpu_seconds(node.pid), time.monotonic()
            feeder.wait(timeout=60)
            n_sent = int(sent_line[1])
            status = collector.wait_settled("bench_000/wear_monitor: x precision", "samples", settle_s=2.0, timeout=120)
        finally:
            stop_node(node)
            collector.close()
    v = status["values"]
    return {
        "sent": n_sent,
        "joint": int(float(v["samples"])),
        "load": int(float(v.get("load_samples", "nan"))) if v.get("load_samples", "nan") != "nan" else -1,
        "cpu_pct": 100.0 * (cpu1 - cpu0) / (t1 - t0),
        "callback_us": float(v.get("callback_time_us", "nan")),
        "model_us": float(v.get("model_time_us", "nan")),
        "feed_s": t1 - t0,
    }


def main() -> int:
    from guide_health.nodes.session import clean_fastdds_shm, isolated_ros_env

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--rate-hz", type=float, default=1000.0)
    ap.add_argument("--executors", nargs="+", default=["events", "single_threaded"])
    args = ap.parse_args()
    env = isolated_ros_env()
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    rows = {}
    for executor in args.executors:
        r = trial(executor, args.seconds, args.rate_hz, env)
        clean_fastdds_shm()
        rows[executor] = r
        lost_j, lost_l = r["sent"] - r["joint"], r["sent"] - r["load"]
        share = r["model_us"] / r["callback_us"] if r["callback_us"] > 0 else float("nan")
        print(f"{executor:16s} sent {r['sent']:,} + {r['sent']:,} in {r['feed_s']:.1f} s; accepted joint "
              f"{r['joint']:,} load {r['load']:,} (lost {lost_j} + {lost_l}); node CPU {r['cpu_pct']:.1f} % "
              f"of one core; callback {r['callback_us']:.1f} us/msg, model {r['model_us']:.1f} us/msg "
              f"({100 * share:.0f} % of the callback)", flush=True)
    if {"events", "single_threaded"} <= set(rows):
        ratio = rows['events']['cpu_pct'] / rows['single_threaded']['cpu_pct']
        print(f"CPU ratio events / single_threaded: {ratio:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
