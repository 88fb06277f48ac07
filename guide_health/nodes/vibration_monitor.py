"""`vibration_monitor`: seed 004's failure signs of a rolling guide, live.

Subscribes `guide/acceleration` (sensor_msgs/LaserScan, one accelerometer block per message: ranges =
acceleration [m/s^2], header stamp = first sample, time_increment = 1/fs), `guide/acceleration_channels`
(sensor_msgs/PointCloud2, one block of every channel, io/accel_channels.py), `guide/sound_pressure`
(sensor_msgs/FluidPressure, rms sound pressure [Pa]; dB = 20 log10(p / 20 uPa)), `guide/sound_level_db`
(std_msgs/Float64, a meter's dB(A), stamped on arrival) and `joint_states` (the test axis' position: travel =
sum |dx|; without it speed x moving time); publishes `/diagnostics` task
`<joint> vibration` every `status_period_s`: band energies, the abnormal-band statistic and its threshold, the
named defect frequency, the noise level trend (rise, drop after the rise) and the level: WARN on a sustained
abnormal band or a noise rise, ERROR on the seed's end-of-test pattern (abnormal band and the noise drop).

A node of its own, not a task of wear_monitor: its inputs (25.6 kHz blocks) and cost have nothing in common with
the joint/load integration, it can run on the computer the accelerometer is wired to, and wear_monitor is being
restructured into a multi-axis machine node by another change. The model is the one the offline chain
(`guide-health life test BAG`) uses: :func:`~guide_health.analysis.life_signs.feed_from_params`.
Blocks are decoded from the raw CDR with numpy (no per-sample Python objects).
"""
from __future__ import annotations

import math
import struct
import sys
import time

import numpy as np
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import FluidPressure, JointState, LaserScan, PointCloud2
from std_msgs.msg import Float64

from guide_health.analysis.life_signs import (
    ACCEL_CHANNELS_TOPIC,
    LEVEL_DB_TOPIC,
    POSITION_TOPIC,
    feed_from_params,
    vibration_status_values,
)
from guide_health.io.accel_channels import decode_channels
from guide_health.io.bag.writer import SOUND_LEVEL_REFERENCE_PA
from guide_health.models.rolling.vibration import persistence_false_alarm, z_threshold
from guide_health.nodes.common import run_node
from guide_health.nodes.live_params import PeriodicTimers, apply_common
from guide_health.nodes.status import RejectionLog, StatusTask, StatusUpdater
from guide_health.params import VIBRATION_MONITOR_SCHEMA, declare_parameters
from guide_health.params.typed import vibration_monitor_params

# reliable keep_all: a block is never dropped silently (a lagging node pushes back on the writer)
DATA_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE)
INPUTS = ("guide/acceleration", "guide/sound_pressure")
VIBRATION_KEYS = ("blocks", "channel", "travel_km", "travel_source", "z_max", "z_threshold", "abnormal_band_hz",
                  "defect", "defect_frequency_hz", "defect_frequency_uncertainty_hz", "defect_resolution_hz",
                  "defect_spectrum", "noise_level_db", "noise_rise_db", "noise_sd_db", "noise_rise_km",
                  "noise_drop_km", "failure_travel_km", "band_energies_m2_s4")
EXTRA_KEYS = ("levels", "rejected_blocks", "rejected_levels", "rejected_positions", "false_alarm_per_block",
              "false_alarm_k_of_n",
              "raceway_hz", "ball_defect_hz", "recirculation_hz", "callback_time_us", "block_model_time_us")


def decode_laser_scan_block(data: bytes) -> tuple[int, float, np.ndarray]:
    """(stamp [ns], time_increment [s], ranges as float64) of a CDR LaserScan without building the message.

    CDR (little/big endian by the encapsulation header): stamp int32 sec, uint32 nanosec, frame_id string,
    7 float32 (angle_min .. range_max; time_increment is the 4th), ranges: uint32 count + float32s (4-aligned).
    ValueError on a malformed buffer."""
    if len(data) < 12:
        raise ValueError("LaserScan buffer too short")
    endian = "<" if data[1] == 1 else ">"
    body = memoryview(data)[4:]
    try:
        sec, nsec, slen = struct.unpack_from(endian + "iII", body, 0)
        off = 12 + slen
        off += (-off) % 4
        floats = struct.unpack_from(endian + "7f", body, off)
        off += 28
        (count,) = struct.unpack_from(endian + "I", body, off)
        off += 4
        if off + 4 * count > len(body):
            raise ValueError("LaserScan ranges run past the buffer")
        ranges = np.frombuffer(body, dtype=np.dtype(np.float32).newbyteorder(endian), count=count, offset=off)
    except struct.error as exc:
        raise ValueError(f"malformed LaserScan: {exc}") from None
    return sec * 1_000_000_000 + nsec, float(floats[3]), ranges.astype(np.float64)


def apply_vibration_changes(changed: dict, feed) -> None:
    """The dynamic parameters into a running StampedLifeTest (every channel and the fresh copy new channels start
    from), its state (baseline, flags, CUSUMs) kept: the abnormal-band threshold from the new false-alarm
    probability, the k-of-n persistence (the flags kept to the newest n), the noise rise CUSUM and the level-shift
    CUSUM (allowance, decision interval in noise sd, smallest drop)."""
    for signs in [*feed.channels.values(), feed.fresh]:
        bands, noise = signs.bands, signs.noise
        if "false_alarm_per_block" in changed:
            bands.alpha_block = float(changed["false_alarm_per_block"])
            bands.threshold = z_threshold(bands.alpha_block, bands.n_bands)
        if "persist_k" in changed:
            bands.persist_k = int(changed["persist_k"])
        if "persist_n" in changed:
            bands.persist_n = int(changed["persist_n"])
            bands.flags = bands.flags[-bands.persist_n:]
            signs.abnormal_travels = signs.abnormal_travels[-bands.persist_n:]
        for name, obj, attr in (("noise_rise_allowance_db", noise, "rise_allowance_db"),
                                ("noise_rise_cusum_db", noise, "rise_cusum_db"),
                                ("noise_drop_db", noise.shift, "min_drop_db"),
                                ("noise_change_allowance_sd", noise.shift, "allowance_sd"),
                                ("noise_change_decision_sd", noise.shift, "decision_sd")):
            if name in changed:
                setattr(obj, attr, float(changed[name]))


class VibrationMonitorNode(Node):
    def __init__(self, **kwargs):
        super().__init__("vibration_monitor", **kwargs)
        params = declare_parameters(self, VIBRATION_MONITOR_SCHEMA, on_applied=self._apply_params)
        self.params = vibration_monitor_params(params)     # a run-time change goes to the model, not here
        p = self.params
        self.periodic = PeriodicTimers(self)
        self.feed = feed_from_params(p)
        self.rejections = RejectionLog(self.get_logger())
        self._callback_s = 0.0
        self._model_s = 0.0
        self._blocks_in = 0
        self.updater = StatusUpdater(self, p.machine_id, p.input_timeout_s)
        self.task = f"{p.joint_name} vibration"
        self.updater.add(StatusTask(self.task, self.report, VIBRATION_KEYS, EXTRA_KEYS, stale_inputs=INPUTS))
        self.diag_pub = self.updater.publisher
        self.create_subscription(LaserScan, "guide/acceleration", self._on_block_raw, DATA_QOS, raw=True)
        self.create_subscription(PointCloud2, ACCEL_CHANNELS_TOPIC, self._on_channels, DATA_QOS)
        self.create_subscription(FluidPressure, "guide/sound_pressure", self._on_pressure, DATA_QOS)
        self.create_subscription(Float64, LEVEL_DB_TOPIC, self._on_level_db, DATA_QOS)
        self.create_subscription(JointState, POSITION_TOPIC, self._on_joint_states, DATA_QOS)
        self.periodic.create("status_period_s", p.status_period_s, self.publish_diagnostics)

    def _apply_params(self, changed: dict) -> None:
        """An accepted ``ros2 param set`` (validated by the schema) reaches the running model: next block/level."""
        apply_vibration_changes(changed, self.feed)
        apply_common(changed, self.updater, self.periodic)

    # --- inputs --------------------------------------------------------------------------------------------
    def _on_block_raw(self, data: bytes) -> None:
        t0 = time.perf_counter()
        self.updater.touch("guide/acceleration")
        self._blocks_in += 1
        try:
            t_ns, dt_s, block = decode_laser_scan_block(data)
        except ValueError as exc:
            self.feed.rejected_blocks += 1
            self.rejections.log(f"guide/acceleration: {exc}")
            return
        t1 = time.perf_counter()
        if self.feed.on_block(t_ns, block, "", 1.0 / dt_s if dt_s > 0 else 0.0) is None:
            self.rejections.log(f"guide/acceleration: block at {1.0 / dt_s if dt_s > 0 else 0.0:g} Hz "
                                f"(sample_rate_hz {self.params.sample_rate_hz:g}), non-finite, too short or "
                                "out-of-order")
        t2 = time.perf_counter()
        self._model_s += t2 - t1
        self._callback_s += t2 - t0

    def _on_channels(self, msg: PointCloud2) -> None:
        t0 = time.perf_counter()
        self.updater.touch("guide/acceleration")
        self._blocks_in += 1
        t_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        try:
            fs, channels = decode_channels([(f.name, f.offset, f.datatype, f.count) for f in msg.fields],
                                           msg.width, msg.height, msg.point_step, msg.is_bigendian, msg.data)
        except ValueError as exc:
            self.feed.rejected_blocks += 1
            self.rejections.log(f"{ACCEL_CHANNELS_TOPIC}: {exc}")
            return
        t1 = time.perf_counter()
        for name, block in channels.items():
            if self.feed.on_block(t_ns, block, name, fs) is None:
                self.rejections.log(f"{ACCEL_CHANNELS_TOPIC}: channel {name} at {fs:g} Hz (sample_rate_hz "
                                    f"{self.params.sample_rate_hz:g}), non-finite, too short or out-of-order")
        t2 = time.perf_counter()
        self._model_s += t2 - t1
        self._callback_s += t2 - t0

    def _on_level_db(self, msg: Float64) -> None:
        self.updater.touch("guide/sound_pressure")
        if not self.feed.on_level(self.get_clock().now().nanoseconds, float(msg.data)):
            self.rejections.log(f"{LEVEL_DB_TOPIC}: non-finite or out-of-order level")

    def _on_joint_states(self, msg: JointState) -> None:
        name = self.params.joint_name
        if name in msg.name:
            i = list(msg.name).index(name)
            t_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            if i >= len(msg.position):
                self.feed.rejected_positions += 1
                self.rejections.log(f"{POSITION_TOPIC}: joint {name} without a position")
            elif not self.feed.on_position(t_ns, float(msg.position[i])):
                self.rejections.log(f"{POSITION_TOPIC}: joint {name} position not finite")

    def _on_pressure(self, msg: FluidPressure) -> None:
        self.updater.touch("guide/sound_pressure")
        p = float(msg.fluid_pressure)
        t_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        if not (math.isfinite(p) and p > 0):
            self.feed.rejected_levels += 1
            self.rejections.log("guide/sound_pressure: non-positive or non-finite sound pressure")
        elif not self.feed.on_level(t_ns, 20.0 * math.log10(p / SOUND_LEVEL_REFERENCE_PA)):
            self.rejections.log("guide/sound_pressure: out-of-order level")

    # --- output ------------------------------------------------------------------------------------------------
    def report(self) -> tuple[int, str, dict]:
        signs = self.feed.signs
        values = vibration_status_values(self.feed)
        values["false_alarm_per_block"] = signs.bands.alpha_block
        values["false_alarm_k_of_n"] = persistence_false_alarm(signs.bands.alpha_block, signs.bands.persist_k,
                                                               signs.bands.persist_n)
        n = self._blocks_in
        values["callback_time_us"] = self._callback_s / n * 1e6 if n else math.nan
        values["block_model_time_us"] = self._model_s / n * 1e6 if n else math.nan
        level, message = signs.level()
        return int(level), message, values

    def publish_diagnostics(self) -> None:
        self.updater.update()


def main(argv: list[str] | None = None) -> int:
    return run_node("vibration_monitor", VibrationMonitorNode, argv)


if __name__ == "__main__":
    sys.exit(main())
