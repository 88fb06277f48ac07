"""Multi-channel accelerometer blocks as sensor_msgs/PointCloud2 (the layout docs/vibration.md states).

One message = one block of N samples of every channel: height 1, width N, one point per sample; fields: ``t``
FLOAT32 (the sample's time from the header stamp [s]; the block carries its own rate) and one FLOAT32 field per
channel named by the channel (e.g. ``ax``, ``ay``, ``az``; acceleration [m/s^2]). Header stamp = first sample.
Decoding is numpy on the data buffer (a strided view per field); a malformed layout is a ValueError.
"""
from __future__ import annotations

import numpy as np

FLOAT32 = 7                 # sensor_msgs/PointField FLOAT32
TIME_FIELD = "t"


def decode_channels(fields, width: int, height: int, point_step: int, is_bigendian: bool,
                    data) -> tuple[float, dict[str, np.ndarray]]:
    """(sample rate [Hz], {channel: samples as float64}) of a PointCloud2 block in the layout above.

    ``fields``: (name, offset, datatype, count) per field. The rate is (N - 1) / (t_N - t_1); the sample times
    must be uniform to 1e-3 of a sample (else ValueError)."""
    n = int(width) * int(height)
    buf = np.frombuffer(memoryview(data).cast("B"), dtype=np.uint8)
    if n < 2 or point_step <= 0 or buf.size < n * point_step:
        raise ValueError(f"PointCloud2 block: {n} points of {point_step} bytes need {n * point_step} bytes, "
                         f"got {buf.size}")
    dtype = np.dtype(np.float32).newbyteorder(">" if is_bigendian else "<")
    columns = {}
    for name, offset, datatype, count in fields:
        if datatype != FLOAT32 or count != 1 or offset + 4 > point_step:
            raise ValueError(f"PointCloud2 field {name!r}: needs one FLOAT32 inside the point")
        columns[name] = np.ndarray((n,), dtype=dtype, buffer=buf, offset=offset, strides=(point_step,))
    t = columns.pop(TIME_FIELD, None)
    if t is None or not columns:
        raise ValueError(f"PointCloud2 block needs a {TIME_FIELD!r} field and at least one channel field")
    t = t.astype(np.float64)
    span = float(t[-1] - t[0])
    if not span > 0:
        raise ValueError("PointCloud2 block: sample times do not increase")
    dt = span / (n - 1)
    if np.max(np.abs(np.diff(t) - dt)) > 1e-3 * dt + 4.0 * np.spacing(np.float32(t[-1])):
        raise ValueError("PointCloud2 block: sample times are not uniform")
    return 1.0 / dt, {name: col.astype(np.float64) for name, col in columns.items()}


def encode_channels(sample_rate_hz: float, channels: dict[str, np.ndarray]) -> tuple[list, int, bytes]:
    """(fields as (name, offset, datatype, count), point_step, data little-endian) of a block in the layout."""
    names = [TIME_FIELD, *channels]
    n = len(next(iter(channels.values())))
    table = np.empty((n, len(names)), dtype="<f4")
    table[:, 0] = np.arange(n) / sample_rate_hz
    for j, name in enumerate(channels, start=1):
        table[:, j] = channels[name]
    return [(name, 4 * j, FLOAT32, 1) for j, name in enumerate(names)], 4 * len(names), table.tobytes()
