"""Flood benchmark (not CI, issue 10): JointState at 10 kHz for 60 s into a live wear_monitor.

    .venv/bin/python bench/bench_flood.py [--duration 60] [--rate-hz 10000] [--profiles keep_last reliable]

For each publisher QoS profile a feeder process publishes pre-encoded JointState (joint x, a sine stroke of
+-0.1 m at 0.125 Hz, stamps 1/rate apart) at --rate-hz, plus WrenchStamped (2 kN) at 100 Hz reliable
keep_all, paced on the wall clock in 1 ms bursts, for --duration seconds, into the node under test (its
own process, config/bench_000.yaml, no state file, status every 1 s; UDP transport on a private domain):
  keep_last    reliable, KEEP_LAST depth 10 (rclpy's default profile): a lagging reader loses samples
               that the writer's history overwrote before they were acknowledged;
  reliable     reliable, KEEP_ALL: the writer blocks instead (back-pressure), nothing may be lost;
  best_effort  best effort, KEEP_LAST depth 10 (SensorDataQoS-like), optional.
Printed per profile: messages published and the rate reached; the node's RSS at the start, its maximum
and at the end (growth); the status period during the flood (mean and max interval of the precision
status at a subscriber); the loss measured = published - (samples accepted + rejected) from the settled
status, and the loss the node itself reports (a status key naming lost samples; if the node has no such
key, that is said). Targets: RSS growth bounded (< 20 MB), status period ~1 s, reported loss == measured.
"""
from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
STATUS = "bench_000/wear_monitor: x precision"     # <machine_id>/<node>: <task>

FEEDER = r'''
import sys, time, math
import numpy as np
import rclpy
from rclpy.qos import QoSProfile, HistoryPolicy, ReliabilityPolicy
from sensor_msgs.msg import JointState
from geometry_msgs.msg import WrenchStamped
from guide_health.io.bag.cdr import encode_joint_states, encode_wrench_stamped
seconds, rate, profile = float(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
n = int(seconds * rate)
t0_ns = 1_700_000_000_000_000_000
t_ns = t0_ns + (np.arange(n) * (1e9 / rate)).astype(np.int64)
t_s = np.arange(n) / rate
x = 0.2 + 0.1 * np.sin(2 * math.pi * 0.125 * t_s)
v = 0.1 * 2 * math.pi * 0.125 * np.cos(2 * math.pi * 0.125 * t_s)
joints = encode_joint_states(t_ns, x, v, "x")
n_load = int(seconds * 100)
tl = t0_ns + (np.arange(n_load) * 1e7).astype(np.int64)
force = np.zeros((n_load, 3)); force[:, 2] = 2000.0
loads = encode_wrench_stamped(tl, force)
qos = {"keep_last": QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE),
       "reliable": QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE),
       "best_effort": QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                                 reliability=ReliabilityPolicy.BEST_EFFORT)}[profile]
rclpy.init()
node = rclpy.create_node("bench_flood_feeder")
pj = node.create_publisher(JointState, "/joint_states", qos)
pl = node.create_publisher(WrenchStamped, "/guide/load",
                           QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE))
while pj.get_subscription_count() < 1 or pl.get_subscription_count() < 1:
    time.sleep(0.01)
time.sleep(0.5)
print("start", flush=True)
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
retries = 0
def publish(pub, raw):
    # a reliable KEEP_ALL writer whose history is full blocks (max_blocking_time), then fails: retry
    global retries
    while True:
        try:
            pub.publish(raw)
            return
        except _rclpy.RCLError:
            retries += 1
start = time.monotonic()
i = k = 0
while i < n:
    due = int((time.monotonic() - start) * rate) + 1
    for j in range(i, min(due, n)):
        publish(pj, joints[j])
        if j % int(rate / 100) == 0 and k < n_load:
            publish(pl, loads[k]); k += 1
    i = max(i, min(due, n))
    time.sleep(0.001)
elapsed = time.monotonic() - start
print(f"sent {n} {k} {elapsed:.3f} {retries}", flush=True)
from rclpy.duration import Duration
pj.wait_for_all_acked(Duration(seconds=10)); pl.wait_for_all_acked(Duration(seconds=10))
'''


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


class RssSampler(threading.Thread):
    def __init__(self, pid: int, period_s: float = 0.5):
        super().__init__(daemon=True)
        self.pid, self.period_s, self.samples, self._halt = pid, period_s, [], threading.Event()

    def run(self) -> None:
        while not self._halt.is_set():
            try:
                self.samples.append(rss_mb(self.pid))
            except OSError:
                return
            self._halt.wait(self.period_s)

    def stop(self) -> None:
        self._halt.set()
        if self.is_alive():
            self.join(timeout=2)


LOSS_WORDS = ("lost", "dropped", "gap", "missing")


def node_reported_loss(values: dict) -> dict:
    """The status keys that count lost samples (names with 'lost', 'dropped', 'gap' or 'missing', e.g.
    messages_lost and samples_missing_estimate), if the node has any."""
    return {k: v for k, v in values.items() if any(w in k for w in LOSS_WORDS)}


def trial(profile: str, seconds: float, rate: float, env: dict) -> dict:
    from guide_health.nodes.session import DiagnosticsCollector, start_node, stop_node

    with tempfile.TemporaryDirectory() as tmp:
        collector = DiagnosticsCollector(f"bench_flood_collector_{profile}")
        node = start_node("guide_health.nodes.wear_monitor", ROOT / "config" / "bench_000.yaml",
                          {"state_file": "none", "input_timeout_s": 30.0, "diagnostics_period_s": 1.0},
                          env, Path(tmp) / "node.log")
        rss = RssSampler(node.pid)
        feeder = None
        try:
            if collector.wait_for(STATUS, timeout=60) is None:
                raise SystemExit(f"node did not come up: {(Path(tmp) / 'node.log').read_text()}")
            feeder = subprocess.Popen([sys.executable, "-c", FEEDER, str(seconds), str(rate), profile], env=env,
                                      stdout=subprocess.PIPE, text=True, cwd=ROOT)
            if feeder.stdout.readline().strip() != "start":
                raise SystemExit(f"{profile}: the feeder never matched the node's subscriptions")
            rss_start = rss_mb(node.pid)
            rss.start()
            t_start = time.monotonic()
            sent = feeder.stdout.readline().split()
            t_end = time.monotonic()
            feeder.wait(timeout=120)
            status = collector.wait_settled(STATUS, "samples", settle_s=3.0, timeout=300)
            rss.stop()
            rss_end = rss_mb(node.pid)
            history = [s["received"] for s in collector.history.get(STATUS, []) if t_start <= s["received"] <= t_end]
        finally:
            rss.stop()
            if feeder is not None and feeder.poll() is None:
                feeder.kill()
                feeder.wait()
            stop_node(node)
            collector.close()
    gaps = [b - a for a, b in zip(history, history[1:])]
    v = status["values"]
    accepted = int(float(v["samples"]))
    rejected = int(float(v.get("rejected_samples", "0")))
    return {"sent": int(sent[1]), "loads": int(sent[2]), "feed_s": float(sent[3]), "retries": int(sent[4]),
            "accepted": accepted,
            "rejected": rejected, "rss_start": rss_start, "rss_max": max(rss.samples or [rss_end]),
            "rss_end": rss_end, "period_mean": sum(gaps) / len(gaps) if gaps else float("nan"),
            "period_max": max(gaps) if gaps else float("nan"), "reported": node_reported_loss(v),
            "load_samples": v.get("load_samples", "?")}


def main() -> int:
    from guide_health.nodes.session import clean_fastdds_shm, isolated_ros_env

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=60.0, help="seconds of flood per profile (60)")
    ap.add_argument("--rate-hz", type=float, default=10000.0)
    ap.add_argument("--profiles", nargs="+", default=["keep_last", "reliable"],
                    choices=["keep_last", "reliable", "best_effort"])
    args = ap.parse_args()
    # UDP only and a domain id above the tests' 1..100 (as bench_fault.py): other runs on the host, and
    # shared-memory ports left locked by a killed process, cannot interfere
    env = isolated_ros_env(domain_id=random.Random().randint(101, 232), transports="UDPv4")
    os.environ.update(env)
    clean_fastdds_shm()
    for profile in args.profiles:
        r = trial(profile, args.duration, args.rate_hz, env)
        clean_fastdds_shm()
        lost = r["sent"] - r["accepted"] - r["rejected"]
        reported = (", ".join(f"{k} = {v}" for k, v in r["reported"].items()) if r["reported"]
                    else "the node reports no loss counter (no status key names lost samples)")
        print(f"{profile:11s} published {r['sent']:,} JointState in {r['feed_s']:.1f} s "
              f"({r['sent'] / r['feed_s']:,.0f} Hz; {r['retries']:,} publish calls refused by a full writer "
              f"history and retried) + {r['loads']:,} loads; accepted {r['accepted']:,}, "
              f"rejected {r['rejected']:,}; loss measured {lost:,} ({100.0 * lost / max(r['sent'], 1):.2f} %); "
              f"node reports: {reported}", flush=True)
        print(f"{'':11s} RSS {r['rss_start']:.1f} MB at the start, max {r['rss_max']:.1f}, end {r['rss_end']:.1f} "
              f"(growth {r['rss_end'] - r['rss_start']:+.1f} MB); status period during the flood mean "
              f"{r['period_mean']:.2f} s, max {r['period_max']:.2f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
