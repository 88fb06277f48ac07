"""rosbag2 bags <-> numpy: write and read machine runs, bag info, a progress bar.

Works offline: no rclpy import here (rosbags does the storage, numpy the CDR).

Topics (INTERFACES.md, relative to a machine namespace ``<ns>``):
``<ns>/joint_states`` sensor_msgs/msg/JointState, ``<ns>/guide/load`` geometry_msgs/msg/WrenchStamped
(force.z), ``<ns>/guide/straightness`` std_msgs/msg/Float64, ``<ns>/guide/temperature``
sensor_msgs/msg/Temperature, ``<ns>/slewing/load`` geometry_msgs/msg/WrenchStamped.

Speed: fixed-layout messages are encoded and decoded with numpy over whole chunks (a byte template
made once per layout and strided views at the field offsets), not one rosbags ``serialize_cdr`` /
``deserialize_cdr`` call per message. A decode template is found by parsing one message of a chunk
(`_joint_state_layout`, `_stamped_layout`); every other message of the same length is checked against
the template's structural bytes (encapsulation, string lengths and names, sequence lengths) and,
when they match, its numbers are read at the template's offsets. Padding bytes are never compared
(Fast DDS leaves garbage in them) and trailing bytes are allowed. Anything else (big-endian CDR,
names that vary from message to message in a way the few templates do not cover, malformed data)
falls back to ``deserialize_cdr``.

Times are int64 nanoseconds. Header stamps are used for JointState, WrenchStamped and Temperature,
the bag's log time for Float64 (it has no header). The writer sets log time = header stamp.
"""
from __future__ import annotations

import functools
import gc
import json
import math
import operator
import shutil
import struct
import sys
import time
import warnings
from contextlib import closing, contextmanager
from itertools import islice
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

from .errors import InputError
from .runs import MachineRun, SlewingLoadRun

__all__ = [
    "JOINT_STATE", "WRENCH_STAMPED", "FLOAT64", "TEMPERATURE",
    "MACHINE_TOPICS", "SLEWING_TOPICS", "METADATA_KEY", "SIDECAR_NAME",
    "write_machine_bag", "write_slewing_bag", "read_machine_bag", "read_slewing_bag",
    "bag_info", "bag_topic_types", "ProgressBar", "open_bag", "iter_raw_messages", "detect_namespace",
    "encode_joint_states", "encode_wrench_stamped", "encode_float64", "encode_temperature",
]

JOINT_STATE = "sensor_msgs/msg/JointState"
WRENCH_STAMPED = "geometry_msgs/msg/WrenchStamped"
FLOAT64 = "std_msgs/msg/Float64"
TEMPERATURE = "sensor_msgs/msg/Temperature"

#: topic (relative to the machine namespace) -> message type
MACHINE_TOPICS = {
    "joint_states": JOINT_STATE,
    "guide/load": WRENCH_STAMPED,
    "guide/straightness": FLOAT64,
    "guide/temperature": TEMPERATURE,
}
SLEWING_TOPICS = {"slewing/load": WRENCH_STAMPED}

#: key of the run metadata (a JSON string) in the bag's metadata.yaml custom_data
METADATA_KEY = "guide_health.metadata"
#: a sidecar JSON file that is also read (bags written by other tools may carry one)
SIDECAR_NAME = "guide_health_meta.json"

STORAGES = ("sqlite3", "mcap")
_WRITE_CHUNK = 100_000            # messages encoded per merge window when writing
_MAX_TEMPLATES = 8                # decode templates tried per chunk and message length
_CDR_LE = b"\x00\x01"             # encapsulation id CDR little endian
_U32 = struct.Struct("<I")
_NS_PER_S = 1_000_000_000
_INT32_MAX = 2**31 - 1

ProgressFn = Callable[[int, int], None]


# ---------------------------------------------------------------------------------------------
# typestore (rosbags)
# ---------------------------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def _typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def _msg(typename: str, **fields):
    return _typestore().types[typename](**fields)


def _header(t_ns: int = 0, frame_id: str = ""):
    sec, nsec = divmod(int(t_ns), _NS_PER_S)
    return _msg("std_msgs/msg/Header", stamp=_msg("builtin_interfaces/msg/Time", sec=sec, nanosec=nsec),
                frame_id=frame_id)


def _one_line(exc: BaseException, limit: int = 160) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _topic(namespace: str | None, relative: str) -> str:
    ns = (namespace or "").strip("/")
    return f"/{ns}/{relative}" if ns else f"/{relative}"


# ---------------------------------------------------------------------------------------------
# CDR layouts (little endian XCDR1, as rosbag2 / Fast DDS use in Jazzy)
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Layout:
    """Where the numbers are in one message layout, and which bytes make that layout."""

    fields: tuple            # ((offset, bytes), ...) structural bytes every matching message has
    values: dict             # name -> (offset, numpy dtype str)
    missing: bool = False    # layout valid, but the wanted item (joint) is not in it
    size: int = 0            # bytes used by the content (the message may carry trailing padding)


def _align(offset: int, alignment: int) -> int:
    """Align an absolute offset; CDR alignment counts from after the 4-byte encapsulation header."""
    rem = (offset - 4) % alignment
    return offset if rem == 0 else offset + alignment - rem


def _header_end(raw: bytes):
    """Parse std_msgs/Header; return (offset after it, structural fields) or None."""
    if len(raw) < 17 or raw[0:2] != _CDR_LE:
        return None
    fid_len = _U32.unpack_from(raw, 12)[0]
    if fid_len < 1 or 16 + fid_len > len(raw) or raw[15 + fid_len] != 0:
        return None
    return 16 + fid_len, [(0, _CDR_LE), (12, bytes(raw[12:16]))]


_STAMP = {"sec": (4, "<i4"), "nsec": (8, "<u4")}


def _joint_state_layout(raw: bytes, joint: bytes) -> _Layout | None:
    """Layout of one sensor_msgs/JointState message, with the offsets of `joint`'s numbers."""
    head = _header_end(raw)
    if head is None:
        return None
    o, fields = head
    n = len(raw)
    o = _align(o, 4)
    if o + 4 > n:
        return None
    n_names = _U32.unpack_from(raw, o)[0]
    if n_names > 256:
        return None
    fields.append((o, bytes(raw[o:o + 4])))
    o += 4
    j = -1
    for k in range(n_names):
        o = _align(o, 4)
        if o + 4 > n:
            return None
        slen = _U32.unpack_from(raw, o)[0]
        if slen < 1 or o + 4 + slen > n or raw[o + 3 + slen] != 0:
            return None
        fields.append((o, bytes(raw[o:o + 4 + slen])))
        if j < 0 and raw[o + 4:o + 3 + slen] == joint:
            j = k
        o += 4 + slen
    seqs = []
    for _ in range(3):                      # position, velocity, effort
        o = _align(o, 4)
        if o + 4 > n:
            return None
        count = _U32.unpack_from(raw, o)[0]
        fields.append((o, bytes(raw[o:o + 4])))
        o += 4
        if count:                           # empty sequences are not aligned (rosbags == Fast CDR)
            o = _align(o, 8)
        data = o
        o += 8 * count
        if o > n:
            return None
        seqs.append((count, data))
    values = dict(_STAMP)
    if j < 0 or j >= seqs[0][0]:
        return _Layout(tuple(fields), values, missing=True, size=o)
    values["position"] = (seqs[0][1] + 8 * j, "<f8")
    if j < seqs[1][0]:
        values["velocity"] = (seqs[1][1] + 8 * j, "<f8")
    return _Layout(tuple(fields), values, size=o)


def _stamped_layout(raw: bytes, names: tuple) -> _Layout | None:
    """Layout of a Header followed by len(names) float64 (Temperature, WrenchStamped)."""
    head = _header_end(raw)
    if head is None:
        return None
    o, fields = head
    o = _align(o, 8)
    end = o + 8 * len(names)
    if end > len(raw):
        return None
    values = dict(_STAMP)
    for k, name in enumerate(names):
        values[name] = (o + 8 * k, "<f8")
    return _Layout(tuple(fields), values, size=end)


def _float64_layout(raw: bytes) -> _Layout | None:
    if len(raw) < 12 or raw[0:2] != _CDR_LE:
        return None
    return _Layout(((0, _CDR_LE),), {"data": (4, "<f8")}, size=12)


_WRENCH_NAMES = ("fx", "fy", "fz", "tx", "ty", "tz")
_TEMPERATURE_NAMES = ("temperature", "variance")


_STRUCT_OF_DTYPE = {"<f8": "<d", "<i4": "<i", "<u4": "<I"}
MISSING = "missing"


class RawMessageDecoder:
    """Per-message decoding of raw CDR for a live node (the same layouts as the bag reader).

    The layout of the first message of each size is parsed once; a later message of that size is
    checked against the layout's structural bytes (encapsulation, frame id, joint names, sequence
    lengths) and its numbers are read at fixed offsets, a few microseconds instead of the tens that
    rclpy deserialisation takes. decode(raw) -> tuple of the numbers in `names` order (NaN for an
    absent optional number such as velocity), MISSING when the message is valid but lacks the wanted
    joint, or None when it is not a message of this type.
    """

    def __init__(self, msgtype: str, names: tuple, joint: str = "x"):
        self.layout_fn = _decoder(msgtype, joint)[0]
        self.names = tuple(names)
        self._cache: dict[int, tuple] = {}

    def _compile(self, raw) -> tuple | None:
        layout = self.layout_fn(raw)
        if layout is None:
            return None
        if layout.missing:
            return (layout.fields, None)
        readers = tuple((struct.Struct(_STRUCT_OF_DTYPE[layout.values[name][1]]), layout.values[name][0])
                        if name in layout.values else None for name in self.names)
        return (layout.fields, readers)

    def decode(self, raw):
        raw = bytes(raw)
        entry = self._cache.get(len(raw))
        if entry is not None:
            for offset, expect in entry[0]:
                if raw[offset:offset + len(expect)] != expect:
                    entry = None
                    break
        if entry is None:
            entry = self._compile(raw)
            if entry is None:
                return None
            self._cache[len(raw)] = entry
        readers = entry[1]
        if readers is None:
            return MISSING
        return tuple(math.nan if r is None else r[0].unpack_from(raw, r[1])[0] for r in readers)


# ---------------------------------------------------------------------------------------------
# encoding (writer side): one template per layout, numbers filled with numpy
# ---------------------------------------------------------------------------------------------

def _stamp_parts(t_ns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t_ns = np.asarray(t_ns, dtype=np.int64)
    sec, nsec = np.divmod(t_ns, _NS_PER_S)
    if sec.size and (sec.min() < -_INT32_MAX - 1 or sec.max() > _INT32_MAX):
        raise InputError("time stamp out of the int32 seconds range of builtin_interfaces/Time")
    return sec, nsec


def _fill_template(template: bytes, layout: _Layout, columns: dict) -> list[bytes]:
    """Copy `template` once per row and write the columns at the layout's offsets."""
    n = len(next(iter(columns.values()))) if columns else 0
    size = len(template)
    buf = np.empty((n, size), dtype=np.uint8)
    buf[:] = np.frombuffer(template, dtype=np.uint8)
    for name, values in columns.items():
        offset, dtype = layout.values[name]
        view = np.ndarray((n,), dtype=dtype, buffer=buf, offset=offset, strides=(size,))
        view[:] = values
    raw = buf.tobytes()
    return [raw[o:o + size] for o in range(0, n * size, size)]


def encode_joint_states(t_ns, position_m, velocity_m_s=None, joint_name: str = "x",
                        frame_id: str = "") -> list[bytes]:
    """CDR bytes of sensor_msgs/JointState messages with one joint (velocity may be empty/None)."""
    position_m = np.asarray(position_m, dtype=np.float64)
    velocity = np.asarray(velocity_m_s if velocity_m_s is not None else (), dtype=np.float64)
    has_velocity = velocity.size > 0
    sec, nsec = _stamp_parts(t_ns)
    template = bytes(_typestore().serialize_cdr(
        _msg(JOINT_STATE, header=_header(0, frame_id), name=[joint_name],
             position=np.zeros(1), velocity=np.zeros(1 if has_velocity else 0),
             effort=np.zeros(0)), JOINT_STATE))
    layout = _joint_state_layout(template, joint_name.encode())
    assert layout is not None and not layout.missing
    columns = {"sec": sec, "nsec": nsec, "position": position_m}
    if has_velocity:
        columns["velocity"] = velocity
    return _fill_template(template, layout, columns)


def encode_wrench_stamped(t_ns, force_n, torque_nm=None, frame_id: str = "") -> list[bytes]:
    """CDR bytes of geometry_msgs/WrenchStamped; force_n, torque_nm: (n, 3) arrays [N], [N m]."""
    force_n = np.asarray(force_n, dtype=np.float64).reshape(-1, 3)
    torque_nm = (np.zeros_like(force_n) if torque_nm is None
                 else np.asarray(torque_nm, dtype=np.float64).reshape(-1, 3))
    sec, nsec = _stamp_parts(t_ns)
    template = bytes(_typestore().serialize_cdr(_msg(WRENCH_STAMPED, header=_header(0, frame_id), wrench=_msg(
        "geometry_msgs/msg/Wrench", force=_msg("geometry_msgs/msg/Vector3", x=0.0, y=0.0, z=0.0),
        torque=_msg("geometry_msgs/msg/Vector3", x=0.0, y=0.0, z=0.0))), WRENCH_STAMPED))
    layout = _stamped_layout(template, _WRENCH_NAMES)
    columns = {"sec": sec, "nsec": nsec}
    for k, name in enumerate(_WRENCH_NAMES):
        columns[name] = force_n[:, k] if k < 3 else torque_nm[:, k - 3]
    return _fill_template(template, layout, columns)


def encode_float64(values) -> list[bytes]:
    """CDR bytes of std_msgs/Float64 messages."""
    template = bytes(_typestore().serialize_cdr(_msg(FLOAT64, data=0.0), FLOAT64))
    return _fill_template(template, _float64_layout(template),
                          {"data": np.asarray(values, dtype=np.float64)})


def encode_temperature(t_ns, temperature_c, variance=0.0, frame_id: str = "") -> list[bytes]:
    """CDR bytes of sensor_msgs/Temperature messages [degC]."""
    temperature_c = np.asarray(temperature_c, dtype=np.float64)
    sec, nsec = _stamp_parts(t_ns)
    template = bytes(_typestore().serialize_cdr(
        _msg(TEMPERATURE, header=_header(0, frame_id), temperature=0.0, variance=0.0), TEMPERATURE))
    return _fill_template(template, _stamped_layout(template, _TEMPERATURE_NAMES), {
        "sec": sec, "nsec": nsec, "temperature": temperature_c,
        "variance": np.broadcast_to(np.asarray(variance, dtype=np.float64), temperature_c.shape)})


# ---------------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------------

@dataclass
class _TopicSeries:
    topic: str
    msgtype: str
    t_ns: np.ndarray                          # log time (= header stamp)
    encode: Callable[[np.ndarray], list]      # row indices -> list of CDR bytes


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"metadata value of type {type(value).__name__} is not JSON serialisable")


def _check_len(name: str, t: np.ndarray, *arrays) -> None:
    for values in arrays:
        if len(values) != len(t):
            raise InputError(f"{name}: {len(values)} values for {len(t)} time stamps")
    if t.size and t.min() < 0:
        raise InputError(f"{name}: negative time stamp")


def _write_bag(series: list[_TopicSeries], path, storage: str, metadata: dict,
               progress: ProgressFn | None = None) -> Path:
    from rosbags.rosbag2 import StoragePlugin, Writer

    path = Path(path)
    if storage not in STORAGES:
        raise InputError(f"unknown storage {storage!r}: use one of {', '.join(STORAGES)}")
    if path.exists():
        raise InputError(f"{path} exists already: not overwriting")
    try:
        meta_json = json.dumps(metadata or {}, default=_json_default, allow_nan=True, sort_keys=True)
    except (TypeError, ValueError) as exc:
        raise InputError(f"run metadata is not JSON serialisable: {_one_line(exc)}") from None
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
        raise InputError(f"cannot create bag {path}: {_one_line(exc)}") from None
    try:
        typestore = _typestore()
        conns = [writer.add_connection(s.topic, s.msgtype, typestore=typestore) for s in series]
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
                      progress: ProgressFn | None = None) -> Path:
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
        _stamp_parts(t)
    name = run.joint_name or "x"

    def load_msgs(i):
        force = np.zeros((i.size, 3))
        force[:, 2] = load[i]
        return encode_wrench_stamped(lt[i], force)

    series = [
        _TopicSeries(_topic(namespace, "joint_states"), JOINT_STATE, jt,
                     lambda i: encode_joint_states(jt[i], pos[i], vel[i] if vel.size else None, name)),
        _TopicSeries(_topic(namespace, "guide/load"), WRENCH_STAMPED, lt, load_msgs),
        _TopicSeries(_topic(namespace, "guide/straightness"), FLOAT64, st,
                     lambda i: encode_float64(straight[i])),
        _TopicSeries(_topic(namespace, "guide/temperature"), TEMPERATURE, tt,
                     lambda i: encode_temperature(tt[i], temp[i])),
    ]
    # joint_states, load and straightness are always declared (empty topics too), temperature if any
    keep = [s for s in series if s.t_ns.size or s.msgtype != TEMPERATURE]
    return _write_bag(keep, path, storage, run.metadata, progress)


def write_slewing_bag(run: SlewingLoadRun, path, storage: str = "sqlite3", namespace: str = "",
                      progress: ProgressFn | None = None) -> Path:
    """Write `<ns>/slewing/load` WrenchStamped: force.z = axial, force.x = radial, torque.x = moment."""
    t = np.asarray(run.t_ns, dtype=np.int64)
    axial = np.asarray(run.axial_n, dtype=np.float64)
    radial = np.asarray(run.radial_n, dtype=np.float64)
    moment = np.asarray(run.moment_nm, dtype=np.float64)
    _check_len("slewing/load", t, axial, radial, moment)
    _stamp_parts(t)

    def msgs(i):
        force = np.zeros((i.size, 3))
        force[:, 0] = radial[i]
        force[:, 2] = axial[i]
        torque = np.zeros((i.size, 3))
        torque[:, 0] = moment[i]
        return encode_wrench_stamped(t[i], force, torque)

    series = [_TopicSeries(_topic(namespace, "slewing/load"), WRENCH_STAMPED, t, msgs)]
    return _write_bag(series, path, storage, run.metadata, progress)


# ---------------------------------------------------------------------------------------------
# opening bags
# ---------------------------------------------------------------------------------------------

def _reader_errors() -> tuple:
    """Exceptions that mean "this is not a good bag" when raised by rosbags while opening or reading.

    rosbags raises ReaderError, but a damaged file also surfaces as apsw/sqlite, struct, zstd, lz4,
    OverflowError, UnicodeError, KeyError... from deep inside; only reader code runs in these try blocks.
    """
    return (Exception,)


@contextmanager
def open_bag(path):
    """Open a rosbag2 bag (directory, .db3 or .mcap) with rosbags; errors become InputError."""
    from rosbags.rosbag2 import Reader

    path = Path(path)
    if not path.exists():
        raise InputError(f"bag not found: {path}")
    try:
        reader = Reader(path)
        reader.open()
    except _reader_errors() as exc:
        raise InputError(f"not a readable rosbag2 bag: {path}: {_one_line(exc)}") from None
    try:
        yield reader
    finally:
        try:
            reader.close()
        except Exception:  # noqa: BLE001 - closing a broken reader must not hide the real error
            pass


def iter_raw_messages(reader, connections, path="bag", start_ns: int | None = None) -> Iterator[tuple]:
    """(connection, log time ns, raw CDR bytes) in log-time order, from log time `start_ns` on
    (inclusive; None: from the first message); read errors become InputError."""
    errors = _reader_errors()
    it = reader.messages(connections=connections, start=start_ns)
    while True:
        try:
            item = next(it)
        except StopIteration:
            return
        except errors as exc:
            raise InputError(f"corrupt bag {path}: {_one_line(exc)}") from None
        yield item


def _bag_yaml(path: Path) -> dict:
    meta = path / "metadata.yaml" if path.is_dir() else None
    if meta is None or not meta.exists():
        return {}
    try:
        import yaml

        info = yaml.safe_load(meta.read_text(encoding="utf8")) or {}
        return info.get("rosbag2_bagfile_information", {}) or {}
    except Exception:  # noqa: BLE001 - the rosbags reader reports broken metadata itself
        return {}


def _read_metadata(path: Path) -> dict:
    info = _bag_yaml(path)
    custom = info.get("custom_data") or {}
    text = custom.get(METADATA_KEY) if isinstance(custom, dict) else None
    sidecar = path / SIDECAR_NAME if path.is_dir() else None
    if text is None and sidecar is not None and sidecar.exists():
        text = sidecar.read_text(encoding="utf8")
    if not text:
        return {}
    try:
        value = json.loads(text)
    except ValueError as exc:
        raise InputError(f"bag {path}: run metadata is not valid JSON: {_one_line(exc)}") from None
    return value if isinstance(value, dict) else {"value": value}


def detect_namespace(topics: dict, suffix: str, msgtype: str) -> str:
    """The namespace of the unique topic `<ns>/<suffix>` of type `msgtype` in {topic: type}."""
    found = sorted(t for t, ty in topics.items()
                   if (t == "/" + suffix or t.endswith("/" + suffix)) and ty == msgtype)
    if not found:
        raise InputError(f"no {suffix} topic of type {msgtype} in the bag")
    if len(found) > 1:
        raise InputError(f"several {suffix} topics in the bag ({', '.join(found)}): choose a namespace")
    return found[0][:-len("/" + suffix)]


# ---------------------------------------------------------------------------------------------
# decoding (reader side)
# ---------------------------------------------------------------------------------------------

@dataclass
class _Decoded:
    """One chunk of one topic: numbers for the kept messages, in bag order."""

    values: dict            # name -> array (only kept messages)
    present: dict           # name -> bool array (value was in the message; NaN otherwise)
    keep: np.ndarray        # indices (into the chunk) of kept messages
    missing: int = 0        # valid messages without the wanted item
    malformed: int = 0
    fast: int = 0
    fallback: int = 0


def _field_mask(layout: _Layout) -> tuple[np.ndarray, np.ndarray]:
    """Column indices and expected values of a layout's structural bytes."""
    cols = [np.arange(off, off + len(expect)) for off, expect in layout.fields]
    values = [np.frombuffer(expect, np.uint8) for _, expect in layout.fields]
    return (np.concatenate(cols) if cols else np.zeros(0, np.intp),
            np.concatenate(values) if values else np.zeros(0, np.uint8))


def _decode(raws: list, layout_fn: Callable, fallback_fn: Callable, names: tuple,
            fast: bool = True) -> _Decoded:
    """Decode a chunk of raw CDR messages of one type into arrays `names`.

    layout_fn(raw) -> _Layout | None; fallback_fn(raw) -> dict name -> value, 'missing' or None.
    """
    n = len(raws)
    out = {k: np.full(n, np.nan) if k not in ("sec", "nsec") else np.zeros(n, np.int64) for k in names}
    present = {k: np.zeros(n, bool) for k in names}
    status = np.full(n, -1, np.int8)            # 0 kept, 1 missing, 2 malformed, -1 not done
    n_fast = 0
    pending: list = []
    if fast and n:
        lengths = np.fromiter(map(len, raws), dtype=np.int64, count=n)
        sizes = np.unique(lengths)
        for size in sizes.tolist():
            if sizes.size == 1:
                idx = np.arange(n)
                buf = b"".join(raws)
            else:
                idx = np.flatnonzero(lengths == size)
                buf = b"".join([raws[i] for i in idx.tolist()])
            rows = np.frombuffer(buf, dtype=np.uint8).reshape(idx.size, size)
            rem = np.arange(idx.size)
            for _ in range(_MAX_TEMPLATES):
                if not rem.size:
                    break
                layout = layout_fn(raws[int(idx[rem[0]])])
                if layout is None:
                    pending.append(int(idx[rem[0]]))
                    rem = rem[1:]
                    continue
                whole = rem.size == idx.size
                cols, expect = _field_mask(layout)
                if cols.size and cols.max() >= size:
                    match = np.zeros(rem.size, bool)
                else:               # one gather of all structural bytes, one comparison
                    got = rows[:, cols] if whole else rows[rem[:, None], cols]
                    match = (got == expect).all(axis=1)
                hit = rem[match]
                target = idx[hit]
                if layout.missing:
                    status[target] = 1
                else:
                    status[target] = 0
                    for name, (off, dtype) in layout.values.items():
                        if name in out:
                            col = np.ndarray((idx.size,), dtype=dtype, buffer=buf, offset=off,
                                             strides=(size,))
                            out[name][target] = col if whole and hit.size == idx.size else col[hit]
                            present[name][target] = True
                n_fast += hit.size
                rem = rem[~match]
            pending.extend(idx[rem].tolist())
    else:
        pending = list(range(n))
    n_fallback = len(pending)
    for i in pending:
        got = fallback_fn(raws[i])
        if got is None:
            status[i] = 2
        elif got == "missing":
            status[i] = 1
        else:
            status[i] = 0
            for name, value in got.items():
                out[name][i] = value
                present[name][i] = True
    keep = np.flatnonzero(status == 0)
    return _Decoded({k: v[keep] for k, v in out.items()}, {k: v[keep] for k, v in present.items()},
                    keep, int((status == 1).sum()), int((status == 2).sum()), n_fast, n_fallback)


def _deserialize(raw, msgtype):
    try:
        return _typestore().deserialize_cdr(raw, msgtype)
    except Exception:  # noqa: BLE001 - any decoding failure is a malformed message
        return None


def _joint_state_fallback(joint: str):
    def decode(raw):
        msg = _deserialize(raw, JOINT_STATE)
        if msg is None:
            return None
        try:
            j = list(msg.name).index(joint)
        except ValueError:
            return "missing"
        if j >= len(msg.position):
            return "missing"
        got = {"sec": msg.header.stamp.sec, "nsec": msg.header.stamp.nanosec, "position": msg.position[j]}
        if j < len(msg.velocity):
            got["velocity"] = msg.velocity[j]
        return got
    return decode


def _wrench_fallback(raw):
    msg = _deserialize(raw, WRENCH_STAMPED)
    if msg is None:
        return None
    f, t = msg.wrench.force, msg.wrench.torque
    return {"sec": msg.header.stamp.sec, "nsec": msg.header.stamp.nanosec,
            "fx": f.x, "fy": f.y, "fz": f.z, "tx": t.x, "ty": t.y, "tz": t.z}


def _temperature_fallback(raw):
    msg = _deserialize(raw, TEMPERATURE)
    if msg is None:
        return None
    return {"sec": msg.header.stamp.sec, "nsec": msg.header.stamp.nanosec,
            "temperature": msg.temperature, "variance": msg.variance}


def _float64_fallback(raw):
    msg = _deserialize(raw, FLOAT64)
    return None if msg is None else {"data": msg.data}


def _decoder(msgtype: str, joint: str = "x"):
    """(layout_fn, fallback_fn, value names) for a message type."""
    if msgtype == JOINT_STATE:
        joint_b = joint.encode()
        return (lambda raw: _joint_state_layout(raw, joint_b), _joint_state_fallback(joint),
                ("sec", "nsec", "position", "velocity"))
    if msgtype == WRENCH_STAMPED:
        return (lambda raw: _stamped_layout(raw, _WRENCH_NAMES), _wrench_fallback,
                ("sec", "nsec") + _WRENCH_NAMES)
    if msgtype == TEMPERATURE:
        return (lambda raw: _stamped_layout(raw, _TEMPERATURE_NAMES), _temperature_fallback,
                ("sec", "nsec") + _TEMPERATURE_NAMES)
    if msgtype == FLOAT64:
        return _float64_layout, _float64_fallback, ("data",)
    raise InputError(f"no decoder for message type {msgtype}")  # pragma: no cover


class _TopicAccumulator:
    """Raw messages of one topic for the current chunk, then per-chunk arrays (bounded memory)."""

    def __init__(self, msgtype: str, joint: str, fast: bool, log_time: bool):
        self.layout_fn, self.fallback_fn, self.names = _decoder(msgtype, joint)
        self.fast = fast
        self.raws: list = []
        self.log_times: list | None = [] if log_time else None
        self.parts: list[_Decoded] = []
        self.log_parts: list[np.ndarray] = []

    def flush(self) -> None:
        if not self.raws:
            return
        dec = _decode(self.raws, self.layout_fn, self.fallback_fn, self.names, self.fast)
        self.parts.append(dec)
        if self.log_times is not None:
            self.log_parts.append(np.asarray(self.log_times, dtype=np.int64)[dec.keep])
            self.log_times.clear()
        self.raws.clear()

    def take(self) -> tuple[dict, dict, dict]:
        """The decoded arrays so far, then forget them (streaming: memory bounded by one batch)."""
        out = self.result()
        self.parts.clear()
        self.log_parts.clear()
        return out

    def result(self) -> tuple[dict, dict, dict]:
        self.flush()
        values = {k: np.concatenate([p.values[k] for p in self.parts]) if self.parts
                  else np.zeros(0, np.int64 if k in ("sec", "nsec") else np.float64) for k in self.names}
        present = {k: np.concatenate([p.present[k] for p in self.parts]) if self.parts
                   else np.zeros(0, bool) for k in self.names}
        counts = {key: sum(getattr(p, key) for p in self.parts)
                  for key in ("missing", "malformed", "fast", "fallback")}
        counts["kept"] = sum(p.keep.size for p in self.parts)
        if self.log_times is not None:
            values["log_t_ns"] = (np.concatenate(self.log_parts) if self.log_parts
                                  else np.zeros(0, np.int64))
        return values, present, counts


def _stamps(values: dict) -> np.ndarray:
    return values["sec"].astype(np.int64) * _NS_PER_S + values["nsec"].astype(np.int64)


@contextmanager
def _gc_paused():
    """Pause the cyclic garbage collector while millions of short-lived tuples are made: a batch of
    (connection, time, bytes) tuples is acyclic, yet each generation-0 collection walks it (measured:
    read time 3.5 s -> 2.5 s for 1.1 M messages). Reference counting still frees everything."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


def _read_topics(path, wanted: dict, namespace: str | None, suffix_for_ns: str, joint: str,
                 progress: ProgressFn | None, chunk_messages: int, fast: bool):
    """Read the topics `wanted` ({relative topic: type}) in one pass: (namespace, {topic: arrays})."""
    batches = _iter_topic_batches(path, wanted, namespace, suffix_for_ns, joint, progress, chunk_messages,
                                  fast, stream=False)
    return next(batches)


def _iter_topic_batches(path, wanted: dict, namespace: str | None, suffix_for_ns: str, joint: str,
                        progress: ProgressFn | None, chunk_messages: int, fast: bool, stream: bool):
    """One pass over the bag in batches of `chunk_messages` (log-time order).

    stream=False: yields once, (namespace, {topic: (values, present, counts)}) for the whole bag;
    stream=True: yields that for every batch (arrays of the batch only), so memory stays bounded.
    """
    path = Path(path)
    chunk_messages = max(1, int(chunk_messages))
    database = _sqlite_database(path)
    with (closing(database[0]) if database is not None else open_bag(path)) as reader:
        connections = database[1] if database is not None else reader.connections
        types = {c.topic: c.msgtype for c in connections}
        if namespace is None:
            namespace = detect_namespace(types, suffix_for_ns, wanted[suffix_for_ns])
        accs: dict[str, _TopicAccumulator] = {}
        conns = []
        for rel, msgtype in wanted.items():
            topic = _topic(namespace, rel)
            here = [c for c in connections if c.topic == topic]
            if not here:
                continue
            bad = sorted({c.msgtype for c in here if c.msgtype != msgtype})
            if bad:
                raise InputError(f"bag {path}: topic {topic} has type {bad[0]}, expected {msgtype}")
            accs[topic] = _TopicAccumulator(msgtype, joint, fast, log_time=(msgtype == FLOAT64))
            conns.extend(here)
        if _topic(namespace, suffix_for_ns) not in accs:
            raise InputError(f"bag {path} has no topic {_topic(namespace, suffix_for_ns)} "
                             f"(topics: {', '.join(sorted(types)) or 'none'})")
        total = int(sum(c.msgcount for c in conns))
        acc_of = {c.id: accs[c.topic] for c in conns}
        errors = _reader_errors()
        if database is not None:          # (topic id, log time, bytes) rows straight from the .db3
            fetch = _sqlite_rows(database[0], conns, chunk_messages)
            conn_id = int
        else:
            conn_id = operator.attrgetter("id")
            it = reader.messages(connections=conns) if conns else iter(())

            def fetch():
                return list(islice(it, chunk_messages))
        if progress is not None:
            progress(0, total)
        done = 0
        while True:
            with _gc_paused():
                try:                              # reader errors only: decoding and progress are outside
                    batch = fetch()
                except errors as exc:
                    raise InputError(f"corrupt bag {path}: {_one_line(exc)}") from None
                got = len(batch)
                if not got:
                    break
                _split_batch(batch, acc_of, conn_id)
                del batch
                for acc in accs.values():
                    acc.flush()
            done += got
            if progress is not None:
                progress(done, max(total, done))
            if stream:
                yield namespace, {topic: acc.take() for topic, acc in accs.items()}
        if total == 0 and progress is not None:
            progress(0, 0)
        if not stream:
            yield namespace, {topic: acc.result() for topic, acc in accs.items()}
        elif done == 0:                       # an empty bag still yields one (empty) batch
            yield namespace, {topic: acc.take() for topic, acc in accs.items()}


@dataclass
class _DbTopic:
    """A topic of a sqlite3 bag as rosbags' Connection presents it (the fields used here)."""

    id: int
    topic: str
    msgtype: str
    msgcount: int


def _sqlite_database(path: Path):
    """A single-file, uncompressed sqlite3 bag whose metadata.yaml gives every topic's message count:
    (apsw connection, [_DbTopic]); else None, and the caller reads with rosbags.

    Why: rosbags' Reader.open() counts the messages of every topic with a full scan (0.64 s of a 1.5 s
    read of 1.1 M messages), and its reader yields each row as one Python generator step; here the
    counts come from metadata.yaml and the rows from the apsw cursor (rosbags' own sqlite binding) in C
    with islice. Measured on 1.1 M messages: 0.7 s for the rows against 1.4 s through the generator
    (1.0 s with the stdlib sqlite3 module)."""
    try:
        import apsw
    except ImportError:  # pragma: no cover - rosbags depends on it
        return None
    info = _bag_yaml(path) if path.is_dir() else {}
    files = info.get("relative_file_paths") or []
    if info.get("storage_identifier") != "sqlite3" or len(files) != 1 or info.get("compression_format"):
        return None
    counts = {}
    for entry in info.get("topics_with_message_count") or []:
        try:
            counts[entry["topic_metadata"]["name"]] = int(entry["message_count"])
        except (KeyError, TypeError, ValueError):
            return None
    db_path = path / files[0]
    if not db_path.is_file():
        return None
    try:
        db = apsw.Connection(str(db_path), flags=apsw.SQLITE_OPEN_READONLY)
        topics = [_DbTopic(int(tid), name, msgtype, counts.get(name, -1))
                  for tid, name, msgtype in db.execute("SELECT id, name, type FROM topics ORDER BY id")]
    except apsw.Error:
        return None                       # let rosbags open it and report what is wrong
    if any(t.msgcount < 0 for t in topics):
        db.close()
        return None
    return db, topics


def _sqlite_rows(db, conns: list, chunk_messages: int) -> Callable[[], list]:
    """fetch() -> the next `chunk_messages` rows (topic id, log time, raw bytes) of the topics `conns`
    in log-time order (as rosbags orders them)."""
    ids = tuple(c.id for c in conns)
    marks = ",".join("?" * len(ids))
    cursor = db.execute(f"SELECT topic_id, timestamp, data FROM messages WHERE topic_id IN ({marks}) "
                        "ORDER BY timestamp", ids) if ids else iter(())
    return lambda: list(islice(cursor, chunk_messages))


def _split_batch(batch: list, acc_of: dict, conn_id) -> None:
    """Hand each topic's accumulator its raw bytes (and log times) from a batch of reader tuples, with
    C-level zip/map/itemgetter rather than a Python statement per message."""
    got = len(batch)
    b_conns, b_times, b_raws = zip(*batch)
    ids = np.fromiter(map(conn_id, b_conns), dtype=np.int64, count=got)
    for cid in np.unique(ids).tolist():
        acc = acc_of[cid]
        idx = np.flatnonzero(ids == cid)
        if idx.size == got:
            acc.raws.extend(b_raws)
            if acc.log_times is not None:
                acc.log_times.extend(b_times)
            continue
        pick = operator.itemgetter(*idx.tolist())
        picked = pick(b_raws)
        acc.raws.extend(picked if idx.size > 1 else (picked,))
        if acc.log_times is not None:
            times = pick(b_times)
            acc.log_times.extend(times if idx.size > 1 else (times,))


def _empty_values(names, log=False):
    values = {k: np.zeros(0, np.int64 if k in ("sec", "nsec") else np.float64) for k in names}
    if log:
        values["log_t_ns"] = np.zeros(0, np.int64)
    return values, {k: np.zeros(0, bool) for k in names}, {
        "missing": 0, "malformed": 0, "fast": 0, "fallback": 0, "kept": 0}


def read_machine_bag(path, joint: str = "x", namespace: str | None = None,
                     progress: ProgressFn | None = None, chunk_messages: int = 200_000,
                     *, fast: bool = True, stats: dict | None = None) -> MachineRun:
    """Read a machine bag into a MachineRun (header stamps; log time for straightness).

    namespace None: the namespace of the bag's unique `.../joint_states` topic.
    JointState messages without `joint` (or without its position) are skipped and counted;
    velocity is NaN where a message has none, and empty when no message has one.
    progress(done_messages, total_messages) is called after every chunk.
    fast=False decodes every message with rosbags deserialize_cdr (the reference path).
    stats, when given, receives per-topic counts: kept, missing, malformed, fast, fallback.
    Raises InputError for a missing, corrupt or unsuitable bag. See iter_machine_bag for bounded memory.
    """
    path = Path(path)
    namespace, res = _read_topics(path, MACHINE_TOPICS, namespace, "joint_states", joint,
                                  progress, chunk_messages, fast)
    run, counts = _machine_run(path, namespace, res, joint, _read_metadata(path))
    _report_counts(path, joint, namespace, counts, stats)
    return run


def iter_machine_bag(path, joint: str = "x", namespace: str | None = None,
                     progress: ProgressFn | None = None, chunk_messages: int = 200_000,
                     *, fast: bool = True, stats: dict | None = None) -> Iterator[MachineRun]:
    """A machine bag as consecutive MachineRun chunks of about `chunk_messages` messages each, in
    log-time order (every chunk carries the run metadata); memory stays bounded by one chunk.
    Feeding them one after another to PrecisionMonitor.process_run gives the result of the whole run.
    Same arguments and errors as read_machine_bag; stats are filled once the iteration ends."""
    path = Path(path)
    metadata = _read_metadata(path)
    total: dict = {}
    namespace_seen = namespace
    for namespace_seen, res in _iter_topic_batches(path, MACHINE_TOPICS, namespace, "joint_states", joint,
                                                   progress, chunk_messages, fast, stream=True):
        run, counts = _machine_run(path, namespace_seen, res, joint, metadata)
        for topic, c in counts.items():
            acc = total.setdefault(topic, dict.fromkeys(c, 0))
            for key, value in c.items():
                acc[key] += value
        yield run
    _report_counts(path, joint, namespace_seen, total, stats)


_MACHINE_EMPTY = {
    "joint_states": ("sec", "nsec", "position", "velocity"),
    "guide/load": ("sec", "nsec", "fz"),
    "guide/straightness": ("data",),
    "guide/temperature": ("sec", "nsec", "temperature"),
}


def _machine_run(path, namespace: str, res: dict, joint: str, metadata: dict) -> tuple[MachineRun, dict]:
    got = {rel: res.get(_topic(namespace, rel), _empty_values(names, log=(rel == "guide/straightness")))
           for rel, names in _MACHINE_EMPTY.items()}
    js_v, js_p, _ = got["joint_states"]
    ld_v, st_v, tp_v = got["guide/load"][0], got["guide/straightness"][0], got["guide/temperature"][0]
    velocity = js_v["velocity"] if js_p["velocity"].any() else np.zeros(0)
    run = MachineRun(
        joint_name=joint,
        joint_t_ns=_stamps(js_v), joint_position_m=js_v["position"], joint_velocity_m_s=velocity,
        load_t_ns=_stamps(ld_v), load_n=ld_v["fz"],
        straightness_t_ns=st_v["log_t_ns"], straightness_m=st_v["data"],
        temperature_t_ns=_stamps(tp_v), temperature_c=tp_v["temperature"],
        metadata=metadata,
    )
    return run, {rel: v[2] for rel, v in got.items()}


def _report_counts(path, joint: str, namespace, counts: dict, stats: dict | None) -> None:
    if stats is not None:
        stats.update({"namespace": namespace, **counts})
    if not counts:
        return
    missing = counts["joint_states"]["missing"]
    dropped = missing + sum(c["malformed"] for c in counts.values())
    if dropped:
        warnings.warn(f"bag {path}: skipped {missing} joint_states without joint {joint!r} "
                      f"and {dropped - missing} malformed messages", stacklevel=3)


def read_slewing_bag(path, namespace: str | None = None, progress: ProgressFn | None = None,
                     chunk_messages: int = 200_000, *, fast: bool = True,
                     stats: dict | None = None) -> SlewingLoadRun:
    """Read `<ns>/slewing/load` into a SlewingLoadRun (axial = force.z, radial = hypot(force.x, force.y),
    moment = hypot(torque.x, torque.y)); namespace None = auto-detected. Raises InputError on a bad bag."""
    path = Path(path)
    namespace, res = _read_topics(path, SLEWING_TOPICS, namespace, "slewing/load", "x",
                                  progress, chunk_messages, fast)
    values, _, counts = res.get(_topic(namespace, "slewing/load"),
                                _empty_values(("sec", "nsec") + _WRENCH_NAMES))
    if stats is not None:
        stats.update({"namespace": namespace, "slewing/load": counts})
    if counts["malformed"]:
        warnings.warn(f"bag {path}: skipped {counts['malformed']} malformed slewing/load messages",
                      stacklevel=2)
    return SlewingLoadRun(
        t_ns=_stamps(values), axial_n=values["fz"],
        radial_n=np.hypot(values["fx"], values["fy"]), moment_nm=np.hypot(values["tx"], values["ty"]),
        metadata=_read_metadata(path),
    )


# ---------------------------------------------------------------------------------------------
# info and progress
# ---------------------------------------------------------------------------------------------

def bag_topic_types(path) -> dict[str, str]:
    """{topic: message type} of a bag, cheaply (no message scan for a single-file sqlite3 bag)."""
    path = Path(path)
    database = _sqlite_database(path)
    if database is not None:
        database[0].close()
        return {t.topic: t.msgtype for t in database[1]}
    with open_bag(path) as reader:
        return {c.topic: c.msgtype for c in reader.connections}


def bag_info(path) -> dict:
    """Topics (type, count), message count, duration, storage and run metadata of a bag."""
    path = Path(path)
    with open_bag(path) as reader:
        count = int(reader.message_count)
        topics = {c.topic: {"type": c.msgtype, "count": int(c.msgcount)} for c in reader.connections}
        start = int(reader.start_time) if count else None
        end = int(reader.end_time) - 1 if count else None
    info = _bag_yaml(path)
    storage = info.get("storage_identifier") or {".db3": "sqlite3", ".mcap": "mcap"}.get(path.suffix)
    return {
        "path": str(path),
        "storage": storage,
        "topics": topics,
        "messages": count,
        "start_ns": start,
        "end_ns": end,
        "duration_s": (end - start) * 1e-9 if count else 0.0,
        "metadata": _read_metadata(path),
    }


class ProgressBar:
    """One-line progress bar on stderr, usable as `progress(done, total)`.

    Redraws with '\\r' at most `max_hz` times a second; disabled when the stream is not a TTY
    unless `force`. Shows done/total messages, msg/s and the ETA; ends the line when done.
    """

    def __init__(self, label: str = "reading", stream=None, force: bool = False, max_hz: float = 5.0,
                 width: int = 24):
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        try:
            tty = bool(self.stream.isatty())
        except (AttributeError, ValueError):
            tty = False
        self.enabled = force or tty
        self.min_interval = 1.0 / max_hz if max_hz > 0 else 0.0
        self.width = width
        self._t0: float | None = None
        self._last = -math.inf
        self._finished = False
        self._last_len = 0

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled or self._finished:
            return
        now = time.monotonic()
        if self._t0 is None:
            self._t0 = now
        final = total > 0 and done >= total
        if not final and now - self._last < self.min_interval:
            return
        self._last = now
        self.stream.write("\r" + self.render(done, total, now - self._t0))
        if final:
            self.stream.write("\n")
            self._finished = True
        self.stream.flush()

    def render(self, done: int, total: int, elapsed_s: float) -> str:
        frac = min(1.0, done / total) if total > 0 else 0.0
        filled = int(round(frac * self.width))
        rate = done / elapsed_s if elapsed_s > 0 else 0.0
        if done >= total > 0:
            eta = "done"
        elif rate > 0 and total > 0:
            eta = f"ETA {(total - done) / rate:.0f} s"
        else:
            eta = "ETA ?"
        text = (f"{self.label} [{'#' * filled}{'.' * (self.width - filled)}] {100 * frac:5.1f}% "
                f"{done}/{total} msg {rate:,.0f} msg/s {eta}")
        pad = max(0, self._last_len - len(text))
        self._last_len = len(text)
        return text + " " * pad

    def close(self) -> None:
        """End the line if the bar was drawn but never reached 100 %."""
        if self.enabled and not self._finished and self._t0 is not None:
            self.stream.write("\n")
            self.stream.flush()
        self._finished = True

    def __enter__(self) -> "ProgressBar":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
