"""Whether bytes can be a CDR payload of their message type (bag_player publishes only those).

The fixed part of a type: the size of its smallest valid payload (every string empty, every sequence empty),
with the 4-byte encapsulation header; a message shorter than this cannot be a payload of its type whatever
its content. A longer one is a payload when it decodes: the fixed-layout types through the live nodes'
decoder (:class:`~guide_health.io.bag.cdr.RawMessageDecoder`, the bag reader's layouts, a few microseconds
per message), then rosbags' deserialiser (typestore.deserialize, trailing bytes allowed as Fast CDR allows
them), the reference, for what no layout fits and for every other type. (A truncated message must be refused
before DDS carries it: the transport pads a payload to a multiple of 4 bytes, and a JointState 1 byte short
arrives as a valid message with its last count completed by a padding zero.)

XCDR1 alignment: a primitive of n bytes starts at a multiple of n counted from after the encapsulation
header; a string is a uint32 length then its bytes with the terminating NUL (an empty string is 5 bytes); a
sequence is a uint32 count then its elements; a fixed array is its elements.
"""
from __future__ import annotations

from functools import cache

from .cdr import RawMessageDecoder
from .interfaces import FLOAT64, JOINT_STATE, TEMPERATURE, WRENCH_STAMPED
from .typestore import deserialize, typestore

_ENCAPSULATION = 4
_PRIMITIVE_BYTES = {"bool": 1, "byte": 1, "char": 1, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2,
                    "int32": 4, "uint32": 4, "float32": 4, "int64": 8, "uint64": 8, "float64": 8}
_BASE, _NAME, _ARRAY, _SEQUENCE = 1, 2, 3, 4      # rosbags Nodetype values


def _aligned(offset: int, alignment: int) -> int:
    rem = (offset - _ENCAPSULATION) % alignment
    return offset if rem == 0 else offset + alignment - rem


def _node_end(node: int, desc, offset: int) -> int:
    if node == _BASE:
        name = desc[0]
        if name in ("string", "wstring"):
            return _aligned(offset, 4) + 4 + (1 if name == "string" else 0)
        size = _PRIMITIVE_BYTES[name]
        return _aligned(offset, size) + size
    if node == _NAME:
        return _fields_end(desc, offset)
    if node == _ARRAY:
        (sub_node, sub_desc), count = desc
        for _ in range(count):
            offset = _node_end(int(sub_node), sub_desc, offset)
        return offset
    if node == _SEQUENCE:
        return _aligned(offset, 4) + 4
    raise ValueError(f"unknown field node {node}")


def _fields_end(msgtype: str, offset: int) -> int:
    for _, (node, desc) in typestore().fielddefs[msgtype][1]:
        offset = _node_end(int(node), desc, offset)
    return offset


@cache
def min_cdr_size(msgtype: str) -> int:
    """Bytes of the smallest CDR payload of ``msgtype`` (encapsulation header included); KeyError for a type
    the typestore does not know."""
    return _fields_end(msgtype, _ENCAPSULATION)


class PayloadCheck:
    """``check(raw)``: True when ``raw`` is a CDR payload of ``msgtype`` (module docstring)."""

    def __init__(self, msgtype: str):
        self.msgtype = msgtype
        try:
            self.fixed_bytes = min_cdr_size(msgtype)
        except (KeyError, ValueError):       # a type the typestore does not know: its header at least
            self.fixed_bytes = 4
            self.known = False
        else:
            self.known = True
        fast = msgtype in (JOINT_STATE, WRENCH_STAMPED, TEMPERATURE, FLOAT64)
        self.decoder = RawMessageDecoder(msgtype, ("sec", "nsec") if msgtype != FLOAT64 else ("data",), joint="",
                                         absent=0.0) if fast else None

    def __call__(self, raw) -> bool:
        if len(raw) < self.fixed_bytes:
            return False
        if self.decoder is not None and self.decoder.decode(raw) is not None:
            return True
        if not self.known:
            return True
        try:
            deserialize(raw, self.msgtype)
        except Exception:  # noqa: BLE001 - any decoding failure: not a payload of this type
            return False
        return True
