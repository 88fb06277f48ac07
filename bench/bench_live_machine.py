"""Whole machine live: one wear_monitor for a machine of 3 (and 5) axes against a bare subscriber of the same
topics, in the same run: CPU per message, loss, and the status period.

    .venv/bin/python bench/bench_live_machine.py [--axes 3 5] [--seconds 20] [--rate-hz 1000] [--repeat 1]

bench_live_limit.py's machine mode. A feeder process publishes, at --rate-hz each (reliable keep_all,
pre-encoded CDR, paced on the wall clock; a publish refused because a reader fell behind and the writer's
history is full is sent again, counted): one `joint_states` JointState carrying every axis (a controller's
message) and one WrenchStamped per axis on `<axis>/guide/load`. The node is `wear_monitor` with
config/machine_xyz.yaml (3 axes x, y, z; for 5 axes two more axes a, b with z's ways, written to a temporary
parameter file), events executor. A bare subscriber (a process with the node's QoS and executor, raw
subscriptions of the same topics, callbacks that only count) takes the same messages at the same time, so
both CPUs are over the same window and the same load of the shared machine (bench_live_limit --together).
Printed per trial: CPU per received message of each [us] (/proc/<pid>/stat over the feeding window) and the
ratio node / bare (target <= 1.2); lost = sent - integrated by the model, per axis, joint and load (target 0);
the period of the node's `<axis> precision` status while it was fed: median, smallest and largest interval
between header stamps (target 1.00 s); the machine's load average. No timed assertion: the machine is shared.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_live_limit import _line  # noqa: E402
from bench_live_node import cpu_seconds  # noqa: E402

MACHINE = ROOT / "config" / "machine_xyz.yaml"
MACHINE_ID = "vmc_xyz_01"
AXES = ("x", "y", "z", "a", "b")

FEEDER = r'''
import sys, time
import numpy as np
import rclpy
from rclpy.qos import QoSProfile, HistoryPolicy, ReliabilityPolicy
from sensor_msgs.msg import JointState
from geometry_msgs.msg import WrenchStamped
from guide_health.io.bag.cdr import encode_joint_states_multi, encode_wrench_stamped
seconds, rate, axes, readers = float(sys.argv[1]), float(sys.argv[2]), sys.argv[3].split(","), int(sys.argv[4])
n = int(seconds * rate)
t_ns = 1_700_000_000_000_000_000 + (np.arange(n) * (1e9 / rate)).astype(np.int64)
phase = (np.arange(n) / rate * 0.05) % 0.4
x = np.where(phase < 0.2, phase, 0.4 - phase)           # 0.05 m/s zigzag over 200 mm, every axis
v = np.where(phase < 0.2, 0.05, -0.05)
joints = encode_joint_states_multi(t_ns, np.repeat(x[:, None], len(axes), 1), np.repeat(v[:, None], len(axes), 1),
                                   axes)
force = np.zeros((n, 3)); force[:, 2] = 6000.0
loads = encode_wrench_stamped(t_ns, force)
rclpy.init()
node = rclpy.create_node("bench_machine_feeder")
qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE)
pj = node.create_publisher(JointState, "/joint_states", qos)
pls = [node.create_publisher(WrenchStamped, f"/{a}/guide/load", qos) for a in axes]
while any(p.get_subscription_count() < readers for p in [pj, *pls]):
    time.sleep(0.01)
time.sleep(0.5)
print("start", flush=True)
from rclpy._rclpy_pybind11 import RCLError
retries = 0
def publish(pub, data):
    """A reliable keep_all writer whose history is full blocks max_blocking_time (Fast DDS: 100 ms), then
    refuses ("cannot publish data"); a controller waits and sends it again: nothing is dropped."""
    global retries
    while True:
        try:
            pub.publish(data)
            return
        except RCLError:
            retries += 1
            time.sleep(0.001)
start = time.monotonic()
for i in range(n):
    due = start + i / rate
    delay = due - time.monotonic()
    if delay > 0:
        time.sleep(delay)
    publish(pj, joints[i])
    for p in pls:
        publish(p, loads[i])
print(f"sent {n} {time.monotonic() - start:.3f} {retries}", flush=True)
from rclpy.duration import Duration
for p in [pj, *pls]:
    p.wait_for_all_acked(Duration(seconds=10))
'''

BARE = r'''
import os, sys, time
import rclpy
from rclpy.experimental import EventsExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from geometry_msgs.msg import WrenchStamped
from sensor_msgs.msg import JointState
expected, deadline, axes = int(sys.argv[1]), time.monotonic() + float(sys.argv[2]), sys.argv[3].split(",")
rclpy.init()
node = rclpy.create_node("bare_machine_subscriber")
qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE)
counts = [0] * (1 + len(axes))
def counter(k):
    def on_message(raw):
        counts[k] += 1
    return on_message
node.create_subscription(JointState, "/joint_states", counter(0), qos, raw=True)
for k, a in enumerate(axes):
    node.create_subscription(WrenchStamped, f"/{a}/guide/load", counter(k + 1), qos, raw=True)
def check():
    if min(counts) >= expected or time.monotonic() > deadline:
        print("count " + " ".join(map(str, counts)), flush=True)
        os._exit(0)
node.create_timer(0.2, check)
executor = EventsExecutor()
executor.add_node(node)
while rclpy.ok():
    executor.spin_once(timeout_sec=0.1)
'''


def machine_params(axes: tuple[str, ...], tmp: Path) -> Path:
    """config/machine_xyz.yaml, or for more axes a copy with a, b added (z's ways): edited as text, since a
    YAML dump would write the axis y bare, which rcl reads as a bool."""
    if axes == AXES[:3]:
        return MACHINE
    text = MACHINE.read_text()
    lines = text.splitlines(keepends=True)
    start = lines.index("    z:\n")
    end = next(i for i in range(start + 1, len(lines)) if not lines[i].startswith("      "))
    extra = "".join(f"    {a}:\n" + "".join(lines[start + 1:end]) for a in axes[3:])
    text = "".join(lines[:end]) + extra + "".join(lines[end:])
    names = ", ".join(f'"{a}"' for a in axes)
    text = text.replace('axes: ["x", "y", "z"]', f"axes: [{names}]", 1)
    path = tmp / f"machine_{len(axes)}.yaml"
    path.write_text(text)
    return path


def status_period(history: list[dict], t0: float, t1: float) -> tuple[float, float, float, int]:
    """(median, smallest, largest) interval [s] between the header stamps of the statuses received in
    [t0, t1], and their count (one late status makes one long and one short interval: the median is the
    period the timer holds)."""
    stamps = [h["stamp_ns"] for h in history if t0 <= h["received"] <= t1]
    gaps = [(b - a) * 1e-9 for a, b in zip(stamps, stamps[1:])] or [float("nan")]
    return statistics.median(gaps), min(gaps), max(gaps), len(stamps)


def trial(axes: tuple[str, ...], seconds: float, rate: float, env: dict) -> dict:
    """The node and the bare subscriber on the same messages: CPU of both over the feeding window, the
    node's integrated counts per axis, its status period."""
    from guide_health.nodes.session import DiagnosticsCollector, start_node, stop_node

    n = int(seconds * rate)
    names = [f"{MACHINE_ID}/wear_monitor: {a} precision" for a in axes]
    bare = subprocess.Popen([sys.executable, "-c", BARE, str(n), str(seconds + 60.0), ",".join(axes)], env=env,
                            stdout=subprocess.PIPE, text=True, cwd=ROOT)
    with tempfile.TemporaryDirectory() as tmp:
        collector = DiagnosticsCollector("bench_machine_collector")
        node = start_node("guide_health.nodes.wear_monitor", machine_params(axes, Path(tmp)),
                          {"state_file": f"{tmp}/state.db", "executor": "events", "input_timeout_s": 30.0}, env,
                          Path(tmp) / "node.log")
        try:
            if any(collector.wait_for(name, timeout=90) is None for name in names):
                raise SystemExit(f"no status from the node:\n{(Path(tmp) / 'node.log').read_text()[-1500:]}")
            feeder = subprocess.Popen([sys.executable, "-c", FEEDER, str(seconds), str(rate), ",".join(axes), "2"],
                                      env=env, stdout=subprocess.PIPE, text=True, cwd=ROOT)
            _line(feeder, "start")
            cpu0, bare0, t0 = cpu_seconds(node.pid), cpu_seconds(bare.pid), time.monotonic()
            _, sent, _, retries = _line(feeder, "sent").split()
            sent, retries = int(sent), int(retries)
            cpu1, bare1, t1 = cpu_seconds(node.pid), cpu_seconds(bare.pid), time.monotonic()
            feeder.wait(timeout=120)
            status = {a: collector.wait_settled(name, "samples", settle_s=2.0, timeout=120)
                      for a, name in zip(axes, names)}
            period = status_period(collector.history[names[0]], t0 + 2.0, t1)
            got = [int(c) for c in _line(bare, "count").split()[1:]]
            bare.wait(timeout=60)
        finally:
            stop_node(node)
            collector.close()
            if bare.poll() is None:
                bare.kill()
    joint = {a: int(float(s["values"]["samples"])) for a, s in status.items()}
    load = {a: int(float(s["values"]["load_samples"])) for a, s in status.items()}
    return {"sent": sent, "feed_s": t1 - t0, "node_cpu_s": cpu1 - cpu0, "bare_cpu_s": bare1 - bare0,
            "joint": joint, "load": load, "bare_counts": got, "period": period, "topics": 1 + len(axes),
            "retries": retries}


def show(axes: tuple[str, ...], r: dict, rate: float) -> float:
    received = r["sent"] * r["topics"]
    node_us = r["node_cpu_s"] / received * 1e6
    bare_us = r["bare_cpu_s"] / sum(r["bare_counts"]) * 1e6
    lost_joint = {a: r["sent"] - n for a, n in r["joint"].items()}
    lost_load = {a: r["sent"] - n for a, n in r["load"].items()}
    median, shortest, longest, count = r["period"]
    print(f"{len(axes)} axes at {rate:g} Hz: sent {r['sent']:,} JointState + {len(axes)} x {r['sent']:,} "
          f"WrenchStamped in {r['feed_s']:.1f} s (load {os.getloadavg()[0]:.1f}); {r['retries']} publishes "
          "sent again after a full writer history")
    print(f"  bare subscriber   CPU {bare_us:6.2f} us/msg  ({100 * r['bare_cpu_s'] / r['feed_s']:.0f} % of a core; "
          f"received {r['bare_counts']})")
    print(f"  wear_monitor      CPU {node_us:6.2f} us/msg  ({100 * r['node_cpu_s'] / r['feed_s']:.0f} % of a core)")
    print(f"  ratio node / bare     {node_us / bare_us:6.2f}   (target <= 1.2)")
    print(f"  lost joint samples {lost_joint}, load samples {lost_load}  (target 0)")
    print(f"  status period: median {median:.3f} s, {shortest:.3f} .. {longest:.3f} s over {count} statuses "
          f"(target 1.00 s)", flush=True)
    return node_us / bare_us


def main() -> int:
    from guide_health.nodes.session import clean_fastdds_shm, isolated_ros_env

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--axes", type=int, nargs="+", default=[3, 5], choices=range(1, 6))
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--rate-hz", type=float, default=1000.0)
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    env = isolated_ros_env()
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    print(f"load average at start: {os.getloadavg()[0]:.1f} (on {os.cpu_count()} cores)", flush=True)
    for count in args.axes:
        axes = AXES[:count]
        ratios = []
        for _ in range(args.repeat):
            try:
                ratios.append(show(axes, trial(axes, args.seconds, args.rate_hz, env), args.rate_hz))
            except SystemExit as exc:
                print(f"{count} axes: trial failed: {str(exc).splitlines()[0]}", flush=True)
            finally:
                clean_fastdds_shm()
        if len(ratios) > 1:
            print(f"{count} axes: median ratio node / bare {statistics.median(ratios):.2f} over {len(ratios)}")
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
