"""Live wear_monitor against a bare rclpy subscriber (issue 14): CPU per message and loss.

    .venv/bin/python bench/bench_live_limit.py [--seconds 10] [--rate-hz 5000] [--loss-rate-hz 8000]
                                               [--repeat 1] [--baseline CHECKOUT]

bench_live_node's feeder publishes JointState + WrenchStamped at --rate-hz each (reliable keep_all,
pre-encoded CDR) into, one after the other in the same run:
  bare         a subscriber process with the node's QoS and executor (EventsExecutor, raw subscriptions)
               whose callbacks only count (the floor of any rclpy node);
  wear_monitor the node of this checkout (events executor: the callbacks copy the raw messages, which are
               decoded and integrated in batches, guide_health/nodes/wear_monitor.py);
  baseline     (--baseline DIR) the node of another checkout, e.g. one that handles every message in its
               callback, started from DIR.
--repeat N runs the bare / node (/ baseline) trials N times, alternating, so that a change of the machine's
load hits all of them; --together runs the bare subscriber at the same time as the node, on the same
messages (both CPUs over the same window: the ratio is less sensitive to the load of a shared machine).
A trial whose feeder fails (a reliable reader so far behind that the writer cannot publish) is reported
and left out. Printed per trial: CPU per received message [us] (from /proc/<pid>/stat over the
feeding window); then the ratios node / bare (target <= 1.2) of each round and their median, and the
samples the node lost at --loss-rate-hz joint + load (target 0; counted: sent vs integrated by the model).
No timed assertion: the machine is shared.
Machine mode (`--machine [--axes 3 5] [--seconds 20] [--rate-hz 1000]`): a whole machine, one JointState of
every axis + a load topic per axis, against a bare subscriber of the same topics (bench_live_machine.py).
"""
from __future__ import annotations

import argparse
import os
import statistics
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


def start_node_in(checkout: Path, overrides: dict, env: dict, log_path: Path) -> subprocess.Popen:
    """``python -m guide_health.nodes.wear_monitor`` of ``checkout`` (its package first on the path)."""
    cmd = [sys.executable, "-m", "guide_health.nodes.wear_monitor", "--ros-args", "--params-file",
           str(ROOT / "config" / "bench_000.yaml")]
    for key, value in overrides.items():
        cmd += ["-p", f"{key}:={value}"]
    env = dict(env, PYTHONPATH=str(checkout))
    return subprocess.Popen(cmd, env=env, stdout=open(log_path, "w"), stderr=subprocess.STDOUT, cwd=checkout)


def trial(seconds: float, rate: float, env: dict, checkout: Path = ROOT, with_bare: bool = False):
    """bench_live_node.trial for the events executor, reading the feeder's lines past Fast DDS noise.
    with_bare: a bare subscriber takes the same messages at the same time (the feeder's reliable writers
    serve both), its CPU measured over the same window; returns (node, bare or None)."""
    from guide_health.nodes.session import DiagnosticsCollector, stop_node

    status_name = "bench_000/wear_monitor: x precision"
    n = int(seconds * rate)
    bare = None
    sub = (subprocess.Popen([sys.executable, "-c", BARE, str(n), str(seconds + 40.0)], env=env,
                            stdout=subprocess.PIPE, text=True, cwd=ROOT) if with_bare else None)
    with tempfile.TemporaryDirectory() as tmp:
        collector = DiagnosticsCollector("bench_collector_limit")
        node = start_node_in(checkout, {"state_file": f"{tmp}/state.db", "executor": "events",
                                        "input_timeout_s": 30.0}, env, Path(tmp) / "node.log")
        try:
            if collector.wait_for(status_name, timeout=60) is None:
                raise SystemExit(f"no status from the node of {checkout}:\n{(Path(tmp) / 'node.log').read_text()}")
            feeder = subprocess.Popen([sys.executable, "-c", FEEDER, str(seconds), str(rate), "2" if sub else "1"],
                                      env=env, stdout=subprocess.PIPE, text=True, cwd=ROOT)
            _line(feeder, "start")
            cpu0, t0 = cpu_seconds(node.pid), time.monotonic()
            bare0 = cpu_seconds(sub.pid) if sub else 0.0
            sent = int(_line(feeder, "sent").split()[1])
            cpu1, t1 = cpu_seconds(node.pid), time.monotonic()
            bare1 = cpu_seconds(sub.pid) if sub else 0.0
            feeder.wait(timeout=60)
            status = collector.wait_settled(status_name, "samples", settle_s=2.0, timeout=120)
            if sub:
                got = _line(sub, "count").split()
                sub.wait(timeout=60)
                bare = {"sent": sent, "joint": int(got[1]), "load": int(got[2]), "cpu_s": bare1 - bare0,
                        "feed_s": t1 - t0}
        finally:
            stop_node(node)
            collector.close()
            if sub and sub.poll() is None:
                sub.kill()
    v = status["values"]
    return ({"sent": sent, "joint": int(float(v["samples"])), "load": int(float(v["load_samples"])),
             "cpu_s": cpu1 - cpu0, "feed_s": t1 - t0, "callback_us": float(v.get("callback_time_us", "nan")),
             "model_us": float(v.get("model_time_us", "nan"))}, bare)


def per_message_us(r: dict) -> float:
    return r["cpu_s"] / (r["joint"] + max(r["load"], 0)) * 1e6


def show(name: str, r: dict) -> None:
    timing = (f" (batches: {r['callback_us']:.2f} us/msg, model {r['model_us']:.2f} us/msg)"
              if "callback_us" in r else "")
    print(f"{name:12s} sent {r['sent']:,} + {r['sent']:,} in {r['feed_s']:.1f} s, handled {r['joint']:,} + "
          f"{r['load']:,}; CPU {per_message_us(r):.2f} us/msg{timing}", flush=True)


def round_ratio(args, env, checkout: Path, name: str) -> float | None:
    """One trial of the node of ``checkout`` against a bare subscriber (together or one after the other);
    its ratio of CPU per message, None when a trial failed (printed)."""
    from guide_health.nodes.session import clean_fastdds_shm

    try:
        if args.together:
            node, bare = trial(args.seconds, args.rate_hz, env, checkout, with_bare=True)
        else:
            bare = bare_trial(args.seconds, args.rate_hz, env)
            clean_fastdds_shm()
            node, _ = trial(args.seconds, args.rate_hz, env, checkout)
    except SystemExit as exc:        # e.g. the reliable feeder could not publish: a reader fell behind
        print(f"{name}: trial failed: {str(exc).splitlines()[0]}", flush=True)
        return None
    finally:
        clean_fastdds_shm()
    show("bare", bare)
    show(name, node)
    ratio = per_message_us(node) / per_message_us(bare)
    print(f"ratio {name} / bare CPU per message  {ratio:.2f}", flush=True)
    return ratio


def main() -> int:
    from guide_health.nodes.session import clean_fastdds_shm, isolated_ros_env

    if "--machine" in sys.argv[1:]:
        import bench_live_machine

        sys.argv.remove("--machine")
        return bench_live_machine.main()

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--rate-hz", type=float, default=5000.0)
    ap.add_argument("--loss-rate-hz", type=float, default=8000.0)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--baseline", type=Path, default=None, help="checkout whose node runs as 'baseline'")
    ap.add_argument("--together", action="store_true",
                    help="the bare subscriber runs at the same time as the node, on the same messages")
    ap.add_argument("--skip-loss", action="store_true")
    args = ap.parse_args()
    env = isolated_ros_env()
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    print(f"load average at start: {os.getloadavg()[0]:.1f} (2 cores shared); {args.rate_hz:g} Hz joint + load"
          f"{'; bare subscriber at the same time' if args.together else ''}", flush=True)
    ratios, base_ratios = [], []
    for _ in range(args.repeat):
        ratios.append(round_ratio(args, env, ROOT, "wear_monitor"))
        if args.baseline is not None:
            base_ratios.append(round_ratio(args, env, args.baseline, "baseline"))
    ratios = [r for r in ratios if r is not None]
    base_ratios = [r for r in base_ratios if r is not None]
    if ratios:
        print(f"median ratio node / bare {statistics.median(ratios):.2f} over {len(ratios)} round(s) "
              f"(target <= 1.2)" + (f"; baseline / bare {statistics.median(base_ratios):.2f} over "
                                    f"{len(base_ratios)}" if base_ratios else ""), flush=True)
    if not args.skip_loss:
        try:
            loss, _ = trial(args.seconds, args.loss_rate_hz, env)
            print(f"loss at {args.loss_rate_hz:g} Hz joint + load, reliable: sent {loss['sent']:,} + "
                  f"{loss['sent']:,} in {loss['feed_s']:.1f} s; integrated {loss['joint']:,} + {loss['load']:,}: "
                  f"lost {loss['sent'] - loss['joint']} + {loss['sent'] - loss['load']} (target 0); node CPU "
                  f"{100.0 * loss['cpu_s'] / loss['feed_s']:.0f} % of one core")
        except SystemExit as exc:
            print(f"loss trial failed: {str(exc).splitlines()[0]}")
        clean_fastdds_shm()
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
