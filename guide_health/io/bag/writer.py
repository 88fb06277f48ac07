"""Write machine and slewing runs as rosbag2 bags (version 9, Jazzy types) with rosbags.

Messages are encoded with numpy templates (`cdr.encode_*`), merged across topics in log-time order, and
written with log time = header stamp (Float64 straightness has no header: its time is the log time).
The run metadata is stored as JSON in metadata.yaml custom_data[METADATA_KEY].
"""
from __future__ import annotations

import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...errors import InputError
from ...runs import MachineRun, SlewingLoadRun
from ..accel_channels import encode_channels
from .cdr import (
    encode_float64,
    encode_joint_states,
    encode_joint_states_multi,
    encode_temperature,
    encode_wrench_stamped,
    stamp_parts,
)
from .interfaces import FLOAT64, JOINT_STATE, TEMPERATURE, WRENCH_STAMPED, topic_name
from .metadata import METADATA_KEY, one_line, run_metadata_json
from .typestore import header, message, typestore

if TYPE_CHECKING:
    from ..outputs.progress import ProgressFn

STORAGES = ("sqlite3", "mcap")
_WRITE_CHUNK = 100_000            # messages encoded per merge window when writing


@dataclass
class _TopicSeries:
    """One topic to write: its log times and how to encode any of its rows."""

    topic: str
    msgtype: str
    t_ns: np.ndarray                          # log time (= header stamp)
    encode: Callable[[np.ndarray], list]      # row indices -> list of CDR bytes


def _check_len(name: str, t: np.ndarray, *arrays) -> None:
    for values in arrays:
        if len(values) != len(t):
            raise InputError(f"{name}: {len(values)} values for {len(t)} time stamps")
    if t.size and t.min() < 0:
        raise InputError(f"{name}: negative time stamp")


def _write_bag(series: list[_TopicSeries], path, storage: str, metadata: dict,
               progress: ProgressFn | None = None) -> Path:
    """Write `series` merged by log time into a new bag at `path`; removes it again on any error."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    path = Path(path)
    if storage not in STORAGES:
        raise InputError(f"unknown storage {storage!r}: use one of {', '.join(STORAGES)}")
    if path.exists():
        raise InputError(f"{path} exists already: not overwriting")
    meta_json = run_metadata_json(metadata)
    # every series gets a connection (an empty topic is still declared, so readers find it)
    times = np.concatenate([s.t_ns for s in series] + [np.zeros(0, np.int64)])
    which = np.concatenate([np.full(s.t_ns.size, k, np.int16) for k, s in enumerate(series)]
                           + [np.zeros(0, np.int16)])
    local = np.concatenate([np.arange(s.t_ns.size) for s in series] + [np.zeros(0, np.int64)])
    order = np.argsort(times, kind="stable")          # merge topics by log time
    total = int(order.size)

    writer = Writer(path, version=9, storage_plugin=StoragePlugin[storage.upper()])
    try:
        writer.open()
    except Exception as exc:
        raise InputError(f"cannot create bag {path}: {one_line(exc)}") from None
    try:
        store = typestore()
        conns = [writer.add_connection(s.topic, s.msgtype, typestore=store) for s in series]
        writer.set_custom_data(METADATA_KEY, meta_json)
        write = writer.write
        for start in range(0, total, _WRITE_CHUNK):
            sel = order[start:start + _WRITE_CHUNK]
            w_sel, l_sel = which[sel], local[sel]
            msgs: list = [None] * sel.size
            for k in np.unique(w_sel):
                pos = np.flatnonzero(w_sel == k)
                for p, raw in zip(pos.tolist(), series[k].encode(l_sel[pos])):
                    msgs[p] = raw
            for c, t, raw in zip(w_sel.tolist(), times[sel].tolist(), msgs):
                write(conns[c], t, raw)
            if progress is not None:
                progress(start + sel.size, total)
        writer.close()
    except BaseException:
        try:
            writer.abort()
        finally:
            shutil.rmtree(path, ignore_errors=True)
        raise
    if progress is not None and total == 0:
        progress(0, 0)
    return path


def write_machine_bag(run: MachineRun, path, storage: str = "sqlite3", namespace: str = "",
                      progress: ProgressFn | None = None, extra: list | None = None) -> Path:
    """Write `run` as a rosbag2 bag (version 9, Jazzy types) at `path` (a new directory).

    Topics `<ns>/joint_states`, `<ns>/guide/load`, `<ns>/guide/straightness` and, when there are
    temperatures, `<ns>/guide/temperature`; log time = header stamp; messages merged in time order.
    `run.metadata` is stored as JSON in metadata.yaml custom_data[METADATA_KEY].
    Raises InputError if `path` exists or the run's arrays do not fit together.
    """
    jt = np.asarray(run.joint_t_ns, dtype=np.int64)
    pos = np.asarray(run.joint_position_m, dtype=np.float64)
    vel = np.asarray(run.joint_velocity_m_s, dtype=np.float64)
    _check_len("joint_states", jt, pos, *([vel] if vel.size else []))
    lt = np.asarray(run.load_t_ns, dtype=np.int64)
    load = np.asarray(run.load_n, dtype=np.float64)
    _check_len("guide/load", lt, load)
    st = np.asarray(run.straightness_t_ns, dtype=np.int64)
    straight = np.asarray(run.straightness_m, dtype=np.float64)
    _check_len("guide/straightness", st, straight)
    tt = np.asarray(run.temperature_t_ns, dtype=np.int64)
    temp = np.asarray(run.temperature_c, dtype=np.float64)
    _check_len("guide/temperature", tt, temp)
    for t in (jt, lt, tt):
        stamp_parts(t)
    name = run.joint_name or "x"

    def load_msgs(i):
        force = np.zeros((i.size, 3))
        force[:, 2] = load[i]
        return encode_wrench_stamped(lt[i], force)

    series = [
        _TopicSeries(topic_name(namespace, "joint_states"), JOINT_STATE, jt,
                     lambda i: encode_joint_states(jt[i], pos[i], vel[i] if vel.size else None, name)),
        _TopicSeries(topic_name(namespace, "guide/load"), WRENCH_STAMPED, lt, load_msgs),
        _TopicSeries(topic_name(namespace, "guide/straightness"), FLOAT64, st,
                     lambda i: encode_float64(straight[i])),
        _TopicSeries(topic_name(namespace, "guide/temperature"), TEMPERATURE, tt,
                     lambda i: encode_temperature(tt[i], temp[i])),
    ]
    # joint_states, load and straightness are always declared (empty topics too), temperature if any
    keep = [s for s in series if s.t_ns.size or s.msgtype != TEMPERATURE]
    keep += _extra_series(extra, namespace)
    return _write_bag(keep, path, storage, run.metadata, progress)


def _extra_series(extra: list | None, namespace: str) -> list[_TopicSeries]:
    """(topic, msgtype, t_ns, encode) tuples (e.g. maintenance events) as series of the bag."""
    return [_TopicSeries(topic_name(namespace, topic), msgtype, np.asarray(t_ns, np.int64), encode)
            for topic, msgtype, t_ns, encode in extra or []]


def write_slewing_bag(run: SlewingLoadRun, path, storage: str = "sqlite3", namespace: str = "",
                      progress: ProgressFn | None = None, axis_topic: str = "slewing/joint_states",
                      axis_joint: str = "slew", clearance_topic: str = "slewing/tilting_clearance") -> Path:
    """Write `<ns>/slewing/load` WrenchStamped: force.z = axial, force.x = radial, torque.x = moment; when the
    run has axis angles, `<ns>/<axis_topic>` JointState with the one joint `axis_joint` (rad); when it has
    tilting clearances, `<ns>/<clearance_topic>` Float64 [m] at their times (the log time dates them)."""
    at = np.asarray(run.axis_t_ns, dtype=np.int64)
    angle = np.asarray(run.axis_angle_rad, dtype=np.float64)
    _check_len(axis_topic, at, angle)
    stamp_parts(at)
    t = np.asarray(run.t_ns, dtype=np.int64)
    axial = np.asarray(run.axial_n, dtype=np.float64)
    radial = np.asarray(run.radial_n, dtype=np.float64)
    moment = np.asarray(run.moment_nm, dtype=np.float64)
    _check_len("slewing/load", t, axial, radial, moment)
    stamp_parts(t)

    def msgs(i):
        force = np.zeros((i.size, 3))
        force[:, 0] = radial[i]
        force[:, 2] = axial[i]
        torque = np.zeros((i.size, 3))
        torque[:, 0] = moment[i]
        return encode_wrench_stamped(t[i], force, torque)

    series = [_TopicSeries(topic_name(namespace, "slewing/load"), WRENCH_STAMPED, t, msgs)]
    if at.size:
        series.append(_TopicSeries(topic_name(namespace, axis_topic), JOINT_STATE, at,
                                   lambda i: encode_joint_states(at[i], angle[i], None, axis_joint)))
    ct = np.asarray(run.clearance_t_ns, dtype=np.int64)
    clearance = np.asarray(run.clearance_m, dtype=np.float64)
    _check_len(clearance_topic, ct, clearance)
    if ct.size:
        series.append(_TopicSeries(topic_name(namespace, clearance_topic), FLOAT64, ct,
                                   lambda i: encode_float64(clearance[i])))
    return _write_bag(series, path, storage, run.metadata, progress)


# ---------------------------------------------------------------------------------------------


SOUND_LEVEL_REFERENCE_PA = 20e-6      # 0 dB SPL


def write_life_test_bag(record, path, storage: str = "sqlite3", namespace: str = "", *, channels=None,
                        sound: str = "pressure", positions=None, joint_name: str = "x") -> Path:
    """A simulated life test (sim/life_test.py LifeTestRecord) as a bag: ``guide/sound_pressure``
    sensor_msgs/FluidPressure (rms sound pressure [Pa] = 20 uPa 10^(L/20), header-stamped; ``sound="db"``:
    ``guide/sound_level_db`` std_msgs/Float64 [dB] at the level's stamp) and ``guide/acceleration``
    sensor_msgs/LaserScan blocks (ranges = acceleration [m/s^2], header stamp = first sample, time_increment =
    1/fs: the block carries its sample rate). ``channels`` {name: blocks like record.blocks}: the blocks as
    ``guide/acceleration_channels`` sensor_msgs/PointCloud2 instead (io/accel_channels.py). ``positions``
    (t_ns, x_m): ``joint_states`` of ``joint_name``."""
    fs = float(record.sample_rate_hz)
    n = record.blocks.shape[1] if record.blocks.ndim == 2 else 0
    store = typestore()

    def pressure(idx):
        return [store.serialize_cdr(message(
            "sensor_msgs/msg/FluidPressure", header=header(int(record.level_t_ns[i])),
            fluid_pressure=SOUND_LEVEL_REFERENCE_PA * 10 ** (float(record.level_db[i]) / 20.0), variance=0.0),
            "sensor_msgs/msg/FluidPressure").tobytes() for i in idx]

    def level_db(idx):
        return [store.serialize_cdr(message("std_msgs/msg/Float64", data=float(record.level_db[i])),
                                    "std_msgs/msg/Float64").tobytes() for i in idx]

    def blocks(idx):
        return [store.serialize_cdr(message(
            "sensor_msgs/msg/LaserScan", header=header(int(record.t_ns[i])), angle_min=0.0, angle_max=0.0,
            angle_increment=0.0, time_increment=1.0 / fs, scan_time=n / fs, range_min=-1e6, range_max=1e6,
            ranges=np.asarray(record.blocks[i], dtype=np.float32), intensities=np.zeros(0, np.float32)),
            "sensor_msgs/msg/LaserScan").tobytes() for i in idx]

    def cloud(idx):
        out = []
        for i in idx:
            fields, step, data = encode_channels(fs, {name: b[i] for name, b in channels.items()})
            out.append(store.serialize_cdr(message(
                "sensor_msgs/msg/PointCloud2", header=header(int(record.t_ns[i])), height=1, width=n,
                fields=[message("sensor_msgs/msg/PointField", name=a, offset=o, datatype=d, count=c)
                        for a, o, d, c in fields],
                is_bigendian=False, point_step=step, row_step=step * n, data=np.frombuffer(data, np.uint8),
                is_dense=True), "sensor_msgs/msg/PointCloud2").tobytes())
        return out

    sound_series = (_TopicSeries(topic_name(namespace, "guide/sound_level_db"), "std_msgs/msg/Float64",
                                 np.asarray(record.level_t_ns, np.int64), level_db) if sound == "db" else
                    _TopicSeries(topic_name(namespace, "guide/sound_pressure"), "sensor_msgs/msg/FluidPressure",
                                 np.asarray(record.level_t_ns, np.int64), pressure))
    block_series = (_TopicSeries(topic_name(namespace, "guide/acceleration"), "sensor_msgs/msg/LaserScan",
                                 np.asarray(record.t_ns, np.int64), blocks) if channels is None else
                    _TopicSeries(topic_name(namespace, "guide/acceleration_channels"), "sensor_msgs/msg/PointCloud2",
                                 np.asarray(record.t_ns, np.int64), cloud))
    series = [sound_series, block_series]
    if positions is not None:
        pt, px = (np.asarray(a) for a in positions)
        series.append(_TopicSeries(topic_name(namespace, "joint_states"), JOINT_STATE, pt.astype(np.int64),
                                   lambda i: encode_joint_states(pt[i], px[i], joint_name=joint_name)))
    return _write_bag(series, path, storage, record.metadata)


def write_machine_axes_bag(runs: dict[str, MachineRun], topics: dict[str, dict], path, storage: str = "sqlite3",
                           namespace: str = "", metadata: dict | None = None,
                           extra: list | None = None, progress: ProgressFn | None = None) -> Path:
    """A machine of several axes as one bag: one `<ns>/joint_states` whose messages carry every joint (the
    runs must share their joint stamps), and per axis its load, straightness and temperature topics
    (``topics[axis]``: load_topic, straightness_topic, temperature_topic, relative to the namespace).
    ``extra``: more (topic, msgtype, t_ns, encode) series, e.g. maintenance events."""
    axes = list(runs)
    first = runs[axes[0]]
    jt = np.asarray(first.joint_t_ns, dtype=np.int64)
    for axis in axes[1:]:
        if not np.array_equal(runs[axis].joint_t_ns, jt):
            raise InputError(f"axis {axis}: joint stamps differ from axis {axes[0]}'s (one JointState per stamp)")
    names = [runs[a].joint_name or a for a in axes]
    pos = np.column_stack([np.asarray(runs[a].joint_position_m, dtype=np.float64) for a in axes])
    vel = np.column_stack([np.asarray(runs[a].joint_velocity_m_s, dtype=np.float64) if runs[a].joint_velocity_m_s.size
                           else np.zeros(jt.size) for a in axes])
    stamp_parts(jt)
    series = [_TopicSeries(topic_name(namespace, "joint_states"), JOINT_STATE, jt,
                           lambda i: encode_joint_states_multi(jt[i], pos[i], vel[i], names))]
    for axis in axes:
        series.extend(_axis_series(runs[axis], topics[axis], namespace))
    series += _extra_series(extra, namespace)
    return _write_bag(series, path, storage, metadata or {}, progress)


def _axis_series(run: MachineRun, topics: dict, namespace: str) -> list[_TopicSeries]:
    """The load, straightness and (when recorded) temperature topics of one axis."""
    lt = np.asarray(run.load_t_ns, dtype=np.int64)
    load = np.asarray(run.load_n, dtype=np.float64)
    _check_len(topics["load_topic"], lt, load)
    st = np.asarray(run.straightness_t_ns, dtype=np.int64)
    straight = np.asarray(run.straightness_m, dtype=np.float64)
    _check_len(topics["straightness_topic"], st, straight)
    tt = np.asarray(run.temperature_t_ns, dtype=np.int64)
    temp = np.asarray(run.temperature_c, dtype=np.float64)
    _check_len(topics["temperature_topic"], tt, temp)
    stamp_parts(lt)
    stamp_parts(tt)

    def load_msgs(i):
        force = np.zeros((i.size, 3))
        force[:, 2] = load[i]
        return encode_wrench_stamped(lt[i], force)

    series = [_TopicSeries(topic_name(namespace, topics["load_topic"]), WRENCH_STAMPED, lt, load_msgs),
              _TopicSeries(topic_name(namespace, topics["straightness_topic"]), FLOAT64, st,
                           lambda i: encode_float64(straight[i]))]
    if tt.size:
        series.append(_TopicSeries(topic_name(namespace, topics["temperature_topic"]), TEMPERATURE, tt,
                                   lambda i: encode_temperature(tt[i], temp[i])))
    return series
