"""diagnostic_msgs/DiagnosticArray from its raw CDR bytes (little endian XCDR1, as Fast DDS hands it to a
``raw=True`` subscription): the statuses fleet_monitor needs, without building rclpy message objects.

Layout (OMG CDR; alignment counted from after the 4-byte encapsulation header):
  header: stamp.sec int32, stamp.nanosec uint32, frame_id string
  status: uint32 count, then per DiagnosticStatus: level octet, name, message, hardware_id strings,
          values: uint32 count, then per KeyValue: key, value strings
  string: uint32 length (4-aligned) counting the terminating NUL, then the bytes.
A string's text is what rclpy gives: its bytes up to the first NUL, UTF-8 with invalid bytes replaced
(rosidl_generator_py converts with strlen and "replace"). Anything that does not parse (another
encapsulation, a length past the end, a count larger than the bytes could hold) raises
MalformedMessage with one line; trailing bytes are allowed (Fast DDS pads to 4).
"""
from __future__ import annotations

import struct
from typing import NamedTuple

_U32 = struct.Struct("<I").unpack_from
_CDR_LE = (b"\x00\x01", )           # encapsulation id CDR little endian (the only one Fast DDS sends here)
_MIN_STATUS_BYTES = 1 + 3 + 4 * 4    # level, padding, 3 string lengths, the values count
_MIN_PAIR_BYTES = 4 + 4               # two string lengths (a string of no bytes at all is 4)


class MalformedMessage(ValueError):
    """The bytes are no DiagnosticArray in little endian CDR."""


class RawStatus(NamedTuple):
    """One DiagnosticStatus as fleet_monitor reads it; `level` is the octet's integer value."""

    level: int
    name: str
    message: str
    hardware_id: str
    values: dict


def _string(raw: bytes, offset: int) -> tuple[str, int]:
    """(text, offset after it) of the CDR string at `offset` (already 4-aligned)."""
    if offset + 4 > len(raw):
        raise MalformedMessage(f"string length at byte {offset} past the end ({len(raw)} bytes)")
    (length,) = _U32(raw, offset)
    start = offset + 4
    end = start + length
    if end > len(raw):
        raise MalformedMessage(f"string of {length} bytes at byte {offset} past the end ({len(raw)} bytes)")
    text = raw[start:end]
    cut = text.find(b"\x00")
    if cut >= 0:
        text = text[:cut]
    return text.decode("utf-8", "replace"), end


def _aligned4(offset: int) -> int:
    """The next 4-aligned offset (counted from byte 4, after the encapsulation header)."""
    return offset + (-(offset - 4) & 3)


def _count(raw: bytes, offset: int, least_bytes: int, what: str) -> tuple[int, int]:
    """A sequence length at a 4-aligned offset, checked against the bytes left (each element needs at least
    `least_bytes`): a corrupt count is refused before anything is allocated for it."""
    if offset + 4 > len(raw):
        raise MalformedMessage(f"{what} count at byte {offset} past the end ({len(raw)} bytes)")
    (n,) = _U32(raw, offset)
    if n * least_bytes > len(raw) - offset - 4:
        raise MalformedMessage(f"{what} count {n} at byte {offset} larger than the {len(raw)} bytes hold")
    return n, offset + 4


def _wanted_values(raw: bytes, offset: int, pairs: int, wanted: frozenset) -> tuple[dict, int]:
    """The KeyValues whose key (its bytes up to the first NUL) is in `wanted` (ASCII keys as bytes): every
    pair is walked, only those texts are decoded."""
    values = {}
    size = len(raw)
    for _ in range(pairs):
        offset += -(offset - 4) & 3
        if offset + 4 > size:
            raise MalformedMessage(f"key length at byte {offset} past the end ({size} bytes)")
        (length,) = _U32(raw, offset)
        start, offset = offset + 4, offset + 4 + length
        if offset > size:
            raise MalformedMessage(f"key of {length} bytes at byte {start - 4} past the end ({size} bytes)")
        cut = raw.find(b"\x00", start, offset)
        key = raw[start:offset if cut < 0 else cut]
        offset += -(offset - 4) & 3
        if key in wanted:
            values[key.decode("ascii")], offset = _string(raw, offset)
            continue
        if offset + 4 > size:
            raise MalformedMessage(f"value length at byte {offset} past the end ({size} bytes)")
        offset += 4 + _U32(raw, offset)[0]
        if offset > size:
            raise MalformedMessage(f"value at byte {offset} past the end ({size} bytes)")
    return values, offset


def decode_diagnostic_array(raw: bytes, keys: frozenset | None = None) -> list[RawStatus]:
    """The statuses of one serialised DiagnosticArray (see the module's layout); with `keys` (ASCII key
    names) only those values (the others are skipped, not decoded). MalformedMessage if the bytes are none."""
    raw = bytes(raw)
    if len(raw) < 16 or raw[0:2] not in _CDR_LE:
        raise MalformedMessage(f"no little endian CDR DiagnosticArray ({len(raw)} bytes, "
                               f"encapsulation {raw[0:2].hex() or 'none'})")
    wanted = None if keys is None else frozenset(k.encode("ascii") for k in keys)
    _, offset = _string(raw, 12)                      # after stamp.sec, stamp.nanosec: frame_id
    n, offset = _count(raw, _aligned4(offset), _MIN_STATUS_BYTES, "status")
    statuses = []
    for _ in range(n):
        if offset >= len(raw):
            raise MalformedMessage(f"status level at byte {offset} past the end ({len(raw)} bytes)")
        level = raw[offset]
        name, offset = _string(raw, _aligned4(offset + 1))
        message, offset = _string(raw, _aligned4(offset))
        hardware_id, offset = _string(raw, _aligned4(offset))
        pairs, offset = _count(raw, _aligned4(offset), _MIN_PAIR_BYTES, "values")
        if wanted is not None:
            values, offset = _wanted_values(raw, offset, pairs, wanted)
        else:
            values = {}
            for _ in range(pairs):
                key, offset = _string(raw, _aligned4(offset))
                values[key], offset = _string(raw, _aligned4(offset))
        statuses.append(RawStatus(level, name, message, hardware_id, values))
    return statuses
