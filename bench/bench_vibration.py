"""vibration_monitor cost at 25.6 kHz (issue 12): per-block model cost and the node's CPU share of a core.

    .venv/bin/python bench/bench_vibration.py [--seconds 20] [--block-samples 4096] [--model-only]

1. Model: StampedLifeTest.on_block (Welch PSD, band energies, abnormal-band z test, and the fine PSD + tone
   naming on an abnormal block) on simulated seed-004 life-test blocks, healthy and spalled, plus the raw CDR
   decoding of the node (decode_laser_scan_block). Real time at 25.6 kHz is block_samples / 25600 s per block
   (160 ms for 4096 samples).
2. Envelope path: the defect measured from the spectrum (models/rolling/envelope.py: kurtosis band, band-pass,
   Hilbert envelope, envelope and direct spectra, harmonics) on impacts written here, once on one block and once
   on a 2 s contiguous span (run once per 2 s of new signal: its cost per block is the span's over 12.5 blocks);
   printed as a share of the block's real time (target < 5 % of a core) and as a ratio to the current per-block
   path (Welch PSD + band test) measured in the same run.
3. Node: the vibration_monitor node in its own process on an isolated ROS domain, fed by a publisher in this
   process at the real-time rate (25.6 kHz in blocks, sound levels at 10 Hz) for --seconds; its CPU time
   (utime + stime from /proc/<pid>/stat) over the wall time is its share of one core. Target < 25 %.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from guide_health.analysis.life_signs import signs_from_params  # noqa: E402
from guide_health.models.rolling.life_signs import StampedLifeTest  # noqa: E402
from guide_health.params import SCHEMAS  # noqa: E402
from guide_health.params.typed import vibration_monitor_params  # noqa: E402
from guide_health.sim.life_test import simulate_life_test  # noqa: E402

FS_HZ = 25600.0


def bench_params(block_samples: int) -> dict:
    return (SCHEMAS["vibration_monitor"].defaults() | SCHEMAS["guide_health_life_test_simulation"].defaults()
            | {"failure_km": 450.0, "block_every_m": 5000.0, "block_samples": block_samples})


def model_cost(block_samples: int) -> dict:
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import LaserScan

    from guide_health.nodes.vibration_monitor import decode_laser_scan_block

    p = bench_params(block_samples)
    rec = simulate_life_test(p, seed=0)
    feed = StampedLifeTest(signs_from_params(vibration_monitor_params(p)), p["carriage_speed_m_s"])
    per_block = []
    for t, x in zip(rec.t_ns, rec.blocks):
        block = np.asarray(x, dtype=np.float64)
        t0 = time.perf_counter()
        feed.on_block(int(t), block)
        per_block.append(time.perf_counter() - t0)
    per_block = np.array(per_block[p["baseline_blocks"]:])        # after learning
    onset = int(np.searchsorted(rec.travel_m[p["baseline_blocks"]:], 450e3))
    msg = LaserScan()
    msg.time_increment = 1.0 / FS_HZ
    msg.ranges = rec.blocks[0].astype(np.float32).tolist()
    raw = serialize_message(msg)
    n = 2000
    t0 = time.perf_counter()
    for _ in range(n):
        decode_laser_scan_block(raw)
    decode_s = (time.perf_counter() - t0) / n
    real_time_s = block_samples / FS_HZ
    return {"block_samples": block_samples, "block_real_time_ms": real_time_s * 1e3,
            "model_healthy_ms_median": float(np.median(per_block[:onset])) * 1e3,
            "model_spalled_ms_median": float(np.median(per_block[onset:])) * 1e3 if onset < per_block.size else None,
            "model_max_ms": float(per_block.max()) * 1e3, "decode_ms": decode_s * 1e3,
            "model_share_of_real_time_worst": (float(per_block.max()) + decode_s) / real_time_s}


def envelope_cost(block_samples: int, repeats: int = 20) -> dict:
    """Median cost of measure_defect on one block and on a 2 s span of impacts, against the band test's per-block
    cost (AbnormalBand.update) on the same blocks."""
    from guide_health.models.rolling.envelope import measure_defect
    from guide_health.models.rolling.vibration import AbnormalBand

    rng = np.random.default_rng(0)
    cands = {"raceway": 75.76, "ball_defect": 70.89}
    span_s = 2.0
    n_span = int(span_s * FS_HZ)
    x = rng.standard_normal(n_span)
    ring = 3.0 * np.exp(-np.arange(400) / FS_HZ / 5e-4) * np.sin(2 * np.pi * 4200.0 * np.arange(400) / FS_HZ)
    for h in np.arange(0.0, span_s - 0.02, 1.0 / cands["raceway"]):
        i = int(h * FS_HZ)
        x[i:i + 400] += ring

    def median_s(fn) -> float:
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        return float(np.median(times))

    band = AbnormalBand(FS_HZ, baseline_blocks=3)
    blocks = x[: (n_span // block_samples) * block_samples].reshape(-1, block_samples)
    for b in blocks[:3]:
        band.update(b)
    current = median_s(lambda: band.update(blocks[3]))
    one = median_s(lambda: measure_defect(blocks[0], FS_HZ, cands, 4.0))
    span = median_s(lambda: measure_defect(x, FS_HZ, cands, 4.0))
    real_time_s = block_samples / FS_HZ
    per_block_span = span / (n_span / block_samples)
    return {"current_path_ms": current * 1e3, "envelope_one_block_ms": one * 1e3, "envelope_span_2s_ms": span * 1e3,
            "envelope_per_block_ms": per_block_span * 1e3,
            "envelope_share_of_core_span": per_block_span / real_time_s,
            "envelope_share_of_core_every_block": one / real_time_s,
            "ratio_envelope_per_block_to_current": per_block_span / current,
            "ratio_envelope_one_block_to_current": one / current}


def _cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def node_share(seconds: float, block_samples: int, workdir: Path) -> dict:
    import rclpy
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import FluidPressure, LaserScan

    from guide_health.nodes.session import clean_fastdds_shm, isolated_ros_env, start_node, stop_node

    env = isolated_ros_env()
    os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID")})
    workdir.mkdir(parents=True, exist_ok=True)
    params = workdir / "vib.yaml"
    params.write_text("vibration_monitor:\n  ros__parameters:\n    status_period_s: 1.0\n")
    proc = start_node("guide_health.nodes.vibration_monitor", params, {}, env, workdir / "node.log")
    rec = simulate_life_test(bench_params(block_samples) | {"block_every_m": 2000.0}, seed=0)
    ctx = rclpy.context.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node("bench_vibration_pub", context=ctx)
    qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE)
    pub_block = node.create_publisher(LaserScan, "guide/acceleration", qos)
    pub_level = node.create_publisher(FluidPressure, "guide/sound_pressure", qos)
    try:
        end = time.monotonic() + 60.0
        while pub_block.get_subscription_count() < 1 and time.monotonic() < end:
            time.sleep(0.1)
        time.sleep(2.0)                                          # the node has finished starting up
        period = block_samples / FS_HZ
        cpu0, wall0 = _cpu_s(proc.pid), time.monotonic()
        k = 0
        next_t = wall0
        while time.monotonic() - wall0 < seconds:
            i = k % rec.blocks.shape[0]
            msg = LaserScan()
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(1.7e18) + int(k * period * 1e9), 10 ** 9)
            msg.time_increment = 1.0 / FS_HZ
            msg.ranges = rec.blocks[i].astype(np.float32).tolist()
            pub_block.publish(msg)
            for j in range(2):                                   # ~10 Hz sound levels (2 per 160 ms block)
                lv = FluidPressure()
                lv.header.stamp = msg.header.stamp
                lv.header.stamp.nanosec = (lv.header.stamp.nanosec + j * 80_000_000) % 10 ** 9
                lv.fluid_pressure = 0.0632
                pub_level.publish(lv)
            k += 1
            next_t += period
            time.sleep(max(0.0, next_t - time.monotonic()))
        time.sleep(period)
        cpu1, wall1 = _cpu_s(proc.pid), time.monotonic()
    finally:
        node.destroy_node()
        rclpy.shutdown(context=ctx)
        stop_node(proc)
        clean_fastdds_shm()
    return {"seconds": wall1 - wall0, "blocks_published": k, "node_cpu_s": cpu1 - cpu0,
            "node_core_share": (cpu1 - cpu0) / (wall1 - wall0)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--block-samples", type=int, default=4096)
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/bench_vibration"))
    ap.add_argument("--model-only", action="store_true", help="skip the live node (no ROS domain needed)")
    args = ap.parse_args()
    out = {"model": model_cost(args.block_samples), "envelope": envelope_cost(args.block_samples)}
    if not args.model_only:
        out["node"] = node_share(args.seconds, args.block_samples, args.workdir)
    print(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
