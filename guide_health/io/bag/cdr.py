"""CDR codec of the fixed-layout messages: layouts, the live nodes' per-message decoder, the bag
reader's chunk decoder and the bag writer's encoders (little endian XCDR1, as rosbag2 / Fast DDS use
in Jazzy). No rclpy here; rosbags only for the templates and the reference (fallback) decoding.

Speed: fixed-layout messages are encoded and decoded with numpy over whole chunks (a byte template
made once per layout and strided views at the field offsets), not one rosbags ``serialize_cdr`` /
``deserialize_cdr`` call per message. A decode template is found by parsing one message of a chunk
(`_joint_state_layout`, `_stamped_layout`); every other message of the same length is checked against
the template's structural bytes (encapsulation, string lengths and names, sequence lengths) and,
when they match, its numbers are read at the template's offsets. Padding bytes are never compared
(Fast DDS leaves garbage in them) and trailing bytes are allowed. Anything else (big-endian CDR,
names that vary from message to message in a way the few templates do not cover, malformed data)
falls back to ``deserialize_cdr``.

Times are int64 nanoseconds; a header stamp is (sec int32, nanosec uint32).
"""
from __future__ import annotations

import math
import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ...errors import InputError
from .interfaces import FLOAT64, JOINT_STATE, NS_PER_S, TEMPERATURE, WRENCH_STAMPED
from .typestore import deserialize, header, message, typestore

_MAX_TEMPLATES = 8                # decode templates tried per chunk and message length
_CDR_LE = b"\x00\x01"             # encapsulation id CDR little endian
_U32 = struct.Struct("<I")
_INT32_MAX = 2**31 - 1


# ---------------------------------------------------------------------------------------------
# layouts
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Layout:
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
    return 16 + fid_len, [(0, _CDR_LE), (12, bytes(raw[12:16])), (15 + fid_len, b"\x00")]   # + its terminator


_STAMP = {"sec": (4, "<i4"), "nsec": (8, "<u4")}


def _joint_state_layout(raw: bytes, joint: bytes) -> Layout | None:
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
        return Layout(tuple(fields), values, missing=True, size=o)
    values["position"] = (seqs[0][1] + 8 * j, "<f8")
    if j < seqs[1][0]:
        values["velocity"] = (seqs[1][1] + 8 * j, "<f8")
    return Layout(tuple(fields), values, size=o)


def _stamped_layout(raw: bytes, names: tuple) -> Layout | None:
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
    return Layout(tuple(fields), values, size=end)


def _float64_layout(raw: bytes) -> Layout | None:
    if len(raw) < 12 or raw[0:2] != _CDR_LE:
        return None
    return Layout(((0, _CDR_LE),), {"data": (4, "<f8")}, size=12)


WRENCH_NAMES = ("fx", "fy", "fz", "tx", "ty", "tz")
TEMPERATURE_NAMES = ("temperature", "variance")


#: a valid message that lacks the wanted item (a JointState without the joint or its position)
MISSING = "missing"


# ---------------------------------------------------------------------------------------------
# codecs per message type: fast layout + rosbags deserialize_cdr reference
# ---------------------------------------------------------------------------------------------

def _deserialize(raw, msgtype):
    try:
        return deserialize(raw, msgtype)
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
            return MISSING
        if j >= len(msg.position):
            return MISSING
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


class MessageCodec(NamedTuple):
    """How to decode one message type: the fast layout, the reference fallback, the value names."""

    layout: Callable[[bytes], Layout | None]        # raw -> its Layout; None: not this type (or not LE)
    fallback: Callable[[bytes], dict | str | None]  # raw -> {name: value}, MISSING, None if malformed
    names: tuple                                    # value names ("sec", "nsec", ...) in order


def codec_for(msgtype: str, joint: str = "x") -> MessageCodec:
    """The codec of a message type (JointState: the numbers of joint `joint`)."""
    if msgtype == JOINT_STATE:
        joint_b = joint.encode()
        return MessageCodec(lambda raw: _joint_state_layout(raw, joint_b), _joint_state_fallback(joint),
                            ("sec", "nsec", "position", "velocity"))
    if msgtype == WRENCH_STAMPED:
        return MessageCodec(lambda raw: _stamped_layout(raw, WRENCH_NAMES), _wrench_fallback,
                            ("sec", "nsec") + WRENCH_NAMES)
    if msgtype == TEMPERATURE:
        return MessageCodec(lambda raw: _stamped_layout(raw, TEMPERATURE_NAMES), _temperature_fallback,
                            ("sec", "nsec") + TEMPERATURE_NAMES)
    if msgtype == FLOAT64:
        return MessageCodec(_float64_layout, _float64_fallback, ("data",))
    raise InputError(f"no decoder for message type {msgtype}")  # pragma: no cover


# ---------------------------------------------------------------------------------------------
# live decoding (one message at a time, nodes)
# ---------------------------------------------------------------------------------------------

_STRUCT_OF_DTYPE = {"<f8": "<d", "<i4": "<i", "<u4": "<I"}


class RawMessageDecoder:
    """Per-message decoding of raw CDR for a live node (the same layouts as the bag reader).

    The layout of the first message of each size is parsed once; a later message of that size is
    checked against the layout's structural bytes (encapsulation, frame id, joint names, sequence
    lengths) and its numbers are read at fixed offsets, a few microseconds instead of the tens that
    rclpy deserialisation takes. decode(raw) -> tuple of the numbers in `names` order (``absent``, NaN
    by default, for an absent optional number such as velocity; a NaN in the message stays NaN),
    MISSING when the message is valid but lacks the wanted joint, or None when it is not a message of
    this type.
    """

    def __init__(self, msgtype: str, names: tuple, joint: str = "x", absent: float = math.nan):
        self.layout_fn = codec_for(msgtype, joint).layout
        self.names = tuple(names)
        self.absent = absent
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
        return tuple(self.absent if r is None else r[0].unpack_from(raw, r[1])[0] for r in readers)


class RawBatchDecoder:
    """:class:`RawMessageDecoder` over a list of messages at once (the live node's batches): the same
    layouts (parsed once per message length, up to _MAX_TEMPLATES each), each message checked against a
    layout's structural bytes and its numbers read at the layout's offsets with numpy.

    decode(raws) -> ({name: array}, status): status 0 decoded (``absent`` for an absent optional number),
    1 valid but without the wanted joint (MISSING), 2 not decoded here (no layout fits: the caller takes
    the per-message path, which gives the exact reason). Stamps: "sec" and "nsec" as int64 arrays."""

    def __init__(self, msgtype: str, names: tuple, joint: str = "x", absent: float = math.nan):
        self.layout_fn = codec_for(msgtype, joint).layout
        self.names = tuple(names)
        self.absent = absent
        self._layouts: dict[int, list] = {}

    def decode(self, raws: list) -> tuple[dict, np.ndarray]:
        n = len(raws)
        out = {k: np.zeros(n, np.int64) if k in ("sec", "nsec") else np.full(n, self.absent) for k in self.names}
        status = np.full(n, 2, np.int8)
        if n:
            for idx, rows in _list_groups(raws):
                self._decode_rows(rows, idx, out, status)
        return out, status

    def _decode_rows(self, rows: np.ndarray, idx: np.ndarray, out: dict, status: np.ndarray) -> None:
        size = rows.shape[1]
        layouts = self._layouts.setdefault(size, [])
        rem = np.arange(idx.size)
        k = 0
        while rem.size:
            if k == len(layouts):
                if k == _MAX_TEMPLATES:
                    return
                layout = self.layout_fn(rows[rem[0]].tobytes())
                if layout is None:
                    return                     # the per-message path for the rest
                layouts.append((layout, *_field_mask(layout)))
            layout, cols, expect = layouts[k]
            k += 1
            if cols.size and cols.max() >= size:
                continue
            match = (rows[rem[:, None], cols] == expect).all(axis=1) if cols.size else np.ones(rem.size, bool)
            hit = rem[match]
            if not hit.size:
                continue
            target = idx[hit]
            status[target] = 1 if layout.missing else 0
            if not layout.missing:
                for name in self.names:
                    if name in layout.values:
                        off, dtype = layout.values[name]
                        col = np.ndarray((idx.size,), dtype=dtype, buffer=rows, offset=off, strides=(size,))
                        out[name][target] = col[hit]
            rem = rem[~match]


# ---------------------------------------------------------------------------------------------
# chunk decoding (bag reader side): numpy over all messages of one topic in a chunk
# ---------------------------------------------------------------------------------------------

@dataclass
class DecodedChunk:
    """One chunk of one topic: numbers for the kept messages, in bag order."""

    values: dict            # name -> array (only kept messages)
    present: dict           # name -> bool array (value was in the message; NaN otherwise)
    keep: np.ndarray        # indices (into the chunk) of kept messages
    missing: int = 0        # valid messages without the wanted item
    malformed: int = 0
    fast: int = 0
    fallback: int = 0
    status: np.ndarray | None = None    # per message of the chunk: 0 kept, 1 missing, 2 malformed


def _field_mask(layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """Column indices and expected values of a layout's structural bytes."""
    cols = [np.arange(off, off + len(expect)) for off, expect in layout.fields]
    values = [np.frombuffer(expect, np.uint8) for _, expect in layout.fields]
    return (np.concatenate(cols) if cols else np.zeros(0, np.intp),
            np.concatenate(values) if values else np.zeros(0, np.uint8))


def _decode_rows(rows: np.ndarray, idx: np.ndarray, codec: MessageCodec, out: dict, present: dict,
                 status: np.ndarray, pending: list) -> int:
    """Decode the messages `idx` (of the chunk) of one length, given as the C-contiguous uint8 matrix `rows`
    (one message per row), into out/present/status at their indices; those no template fits go to
    `pending`. Returns how many were decoded here."""
    size = rows.shape[1]
    n_fast = 0
    rem = np.arange(idx.size)
    for _ in range(_MAX_TEMPLATES):
        if not rem.size:
            break
        layout = codec.layout(rows[rem[0]].tobytes())
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
        # every message of the chunk, all fitting this template (the usual case): slices, not index arrays
        target = slice(None) if whole and hit.size == idx.size == status.size else idx[hit]
        if layout.missing:
            status[target] = 1
        else:
            status[target] = 0
            for name, (off, dtype) in layout.values.items():
                if name in out:
                    col = np.ndarray((idx.size,), dtype=dtype, buffer=rows, offset=off, strides=(size,))
                    out[name][target] = col if whole and hit.size == idx.size else col[hit]
                    present[name][target] = True
        n_fast += hit.size
        rem = rem[~match]
    pending.extend(idx[rem].tolist())
    return n_fast


def _decode(n: int, groups, raw_of: Callable[[int], bytes], codec: MessageCodec) -> DecodedChunk:
    """The DecodedChunk of `n` messages: `groups` yields (indices, rows) per message length (see
    _decode_rows; None: decode every message with the fallback); raw_of(i): the bytes of message i."""
    names = codec.names
    out = {k: np.full(n, np.nan) if k not in ("sec", "nsec") else np.zeros(n, np.int64) for k in names}
    present = {k: np.zeros(n, bool) for k in names}
    status = np.full(n, -1, np.int8)            # 0 kept, 1 missing, 2 malformed, -1 not done
    pending: list = [] if groups is not None else list(range(n))
    n_fast = sum(_decode_rows(rows, idx, codec, out, present, status, pending) for idx, rows in groups or ())
    n_fallback = len(pending)
    for i in pending:
        got = codec.fallback(raw_of(i))
        if got is None:
            status[i] = 2
        elif got == MISSING:
            status[i] = 1
        else:
            status[i] = 0
            for name, value in got.items():
                out[name][i] = value
                present[name][i] = True
    keep = np.flatnonzero(status == 0)
    if keep.size == n:                  # every message kept: the arrays as they are
        return DecodedChunk(out, present, keep, 0, 0, n_fast, n_fallback, status)
    return DecodedChunk({k: v[keep] for k, v in out.items()}, {k: v[keep] for k, v in present.items()},
                        keep, int((status == 1).sum()), int((status == 2).sum()), n_fast, n_fallback, status)


def _list_groups(raws: list):
    n = len(raws)
    lengths = np.fromiter(map(len, raws), dtype=np.int64, count=n)
    sizes = _sizes(lengths)
    for size in sizes.tolist():
        if sizes.size == 1:
            idx = np.arange(n)
            buf = b"".join(raws)
        else:
            idx = np.flatnonzero(lengths == size)
            buf = b"".join([raws[i] for i in idx.tolist()])
        yield idx, np.frombuffer(buf, dtype=np.uint8).reshape(idx.size, size)


def decode_chunk(raws: list, codec: MessageCodec, fast: bool = True) -> DecodedChunk:
    """Decode a chunk of raw CDR messages of one type into arrays `codec.names`.

    fast=False decodes every message with codec.fallback (rosbags deserialize_cdr, the reference).
    """
    groups = _list_groups(raws) if fast else None
    return _decode(len(raws), groups, raws.__getitem__, codec)


def _sizes(lengths: np.ndarray) -> np.ndarray:
    """The distinct message lengths, ascending (np.unique); one min/max pass when all are equal."""
    if lengths.size and lengths.min() == lengths.max():
        return lengths[:1].copy()
    return np.unique(lengths)


def _packed_groups(buf: np.ndarray, offsets: np.ndarray, lengths: np.ndarray):
    sizes = _sizes(lengths)
    for size in sizes.tolist():
        idx = np.arange(lengths.size) if sizes.size == 1 else np.flatnonzero(lengths == size)
        if size == 0:
            yield idx, np.zeros((idx.size, 0), np.uint8)
            continue
        # every window of `size` bytes of the buffer, as a view; indexing its rows copies whole messages
        # (a row copy each, not a gather per byte: 0.03 s against 0.12 s for 180 k messages of 104 bytes)
        windows = np.lib.stride_tricks.sliding_window_view(buf, size)
        yield idx, windows[offsets[idx]]


def decode_packed(buf: np.ndarray, offsets: np.ndarray, lengths: np.ndarray, codec: MessageCodec,
                  fast: bool = True) -> DecodedChunk:
    """decode_chunk for messages packed in one uint8 buffer: message i is buf[offsets[i]:offsets[i] +
    lengths[i]] (what the bulk sqlite3 and mcap chunk readers give). Same result as decode_chunk of the
    list of those bytes."""
    n = int(lengths.size)
    groups = _packed_groups(buf, offsets, lengths) if fast else None
    return _decode(n, groups, lambda i: buf[offsets[i]:offsets[i] + lengths[i]].tobytes(), codec)


# ---------------------------------------------------------------------------------------------
# encoding (writer side): one template per layout, numbers filled with numpy
# ---------------------------------------------------------------------------------------------

def stamp_parts(t_ns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sec, nanosec) of builtin_interfaces/Time for int64 ns stamps; InputError beyond int32 seconds."""
    t_ns = np.asarray(t_ns, dtype=np.int64)
    sec, nsec = np.divmod(t_ns, NS_PER_S)
    if sec.size and (sec.min() < -_INT32_MAX - 1 or sec.max() > _INT32_MAX):
        raise InputError("time stamp out of the int32 seconds range of builtin_interfaces/Time")
    return sec, nsec


def _fill_template(template: bytes, layout: Layout, columns: dict) -> list[bytes]:
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
    sec, nsec = stamp_parts(t_ns)
    template = bytes(typestore().serialize_cdr(
        message(JOINT_STATE, header=header(0, frame_id), name=[joint_name],
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
    sec, nsec = stamp_parts(t_ns)
    zero = message("geometry_msgs/msg/Vector3", x=0.0, y=0.0, z=0.0)
    template = bytes(typestore().serialize_cdr(message(
        WRENCH_STAMPED, header=header(0, frame_id),
        wrench=message("geometry_msgs/msg/Wrench", force=zero, torque=zero)), WRENCH_STAMPED))
    layout = _stamped_layout(template, WRENCH_NAMES)
    columns = {"sec": sec, "nsec": nsec}
    for k, name in enumerate(WRENCH_NAMES):
        columns[name] = force_n[:, k] if k < 3 else torque_nm[:, k - 3]
    return _fill_template(template, layout, columns)


def encode_float64(values) -> list[bytes]:
    """CDR bytes of std_msgs/Float64 messages."""
    template = bytes(typestore().serialize_cdr(message(FLOAT64, data=0.0), FLOAT64))
    return _fill_template(template, _float64_layout(template),
                          {"data": np.asarray(values, dtype=np.float64)})


def encode_temperature(t_ns, temperature_c, variance=0.0, frame_id: str = "") -> list[bytes]:
    """CDR bytes of sensor_msgs/Temperature messages [degC]."""
    temperature_c = np.asarray(temperature_c, dtype=np.float64)
    sec, nsec = stamp_parts(t_ns)
    template = bytes(typestore().serialize_cdr(
        message(TEMPERATURE, header=header(0, frame_id), temperature=0.0, variance=0.0), TEMPERATURE))
    return _fill_template(template, _stamped_layout(template, TEMPERATURE_NAMES), {
        "sec": sec, "nsec": nsec, "temperature": temperature_c,
        "variance": np.broadcast_to(np.asarray(variance, dtype=np.float64), temperature_c.shape)})


def encode_joint_states_multi(t_ns, position_m, velocity_m_s, joint_names, frame_id: str = "") -> list[bytes]:
    """CDR bytes of sensor_msgs/JointState messages with several joints (a machine controller's message):
    position_m and velocity_m_s are (n, joints) arrays, joint_names the joints in column order."""
    names = list(joint_names)
    position_m = np.asarray(position_m, dtype=np.float64).reshape(-1, len(names))
    velocity = np.asarray(velocity_m_s, dtype=np.float64).reshape(-1, len(names))
    sec, nsec = stamp_parts(t_ns)
    template = bytes(typestore().serialize_cdr(
        message(JOINT_STATE, header=header(0, frame_id), name=names, position=np.zeros(len(names)),
                velocity=np.zeros(len(names)), effort=np.zeros(0)), JOINT_STATE))
    values = dict(_STAMP)
    columns = {"sec": sec, "nsec": nsec}
    for k, name in enumerate(names):
        layout = _joint_state_layout(template, name.encode())
        assert layout is not None and not layout.missing
        values[f"position:{name}"] = layout.values["position"]
        values[f"velocity:{name}"] = layout.values["velocity"]
        columns[f"position:{name}"] = position_m[:, k]
        columns[f"velocity:{name}"] = velocity[:, k]
    return _fill_template(template, Layout((), values, size=len(template)), columns)
