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

import functools
import re
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


@functools.lru_cache(maxsize=16)
def _key_pattern(keys: frozenset) -> re.Pattern:
    """Matches, at a key's first byte and within its bytes, a wanted key's text ended by a NUL or by the
    key's end: the key's text (its bytes up to the first NUL) is that key."""
    texts = sorted((re.escape(k.encode("ascii")) for k in keys), key=len, reverse=True)
    return re.compile(b"(" + b"|".join(texts) + rb")(?:\x00|\Z)", re.DOTALL)


def _wanted_values(raw: bytes, offset: int, pairs: int, pattern: re.Pattern) -> tuple[dict, int]:
    """The KeyValues whose key is one `pattern` (_key_pattern) matches: every pair is walked reading only
    its two lengths and matching the key in C; only the wanted texts are decoded. A length that runs past
    the end is caught by struct (a read past the end) or by the check after the last pair."""
    values = {}
    match = pattern.match
    try:
        for _ in range(pairs):
            offset += -(offset - 4) & 3
            start = offset + 4
            offset = start + _U32(raw, offset)[0]
            found = match(raw, start, offset)
            offset += -(offset - 4) & 3
            if found is not None:
                values[found.group(1).decode("ascii")], offset = _string(raw, offset)
                continue
            offset += 4 + _U32(raw, offset)[0]
    except struct.error:
        raise MalformedMessage(f"key or value length at byte {offset} past the end ({len(raw)} bytes)") from None
    if offset > len(raw):
        raise MalformedMessage(f"key or value ending at byte {offset} past the end ({len(raw)} bytes)")
    return values, offset


def decode_diagnostic_array(raw: bytes, keys: frozenset | None = None) -> list[RawStatus]:
    """The statuses of one serialised DiagnosticArray (see the module's layout); with `keys` (ASCII key
    names) only those values (the others are skipped, not decoded). MalformedMessage if the bytes are none."""
    raw = bytes(raw)
    if len(raw) < 16 or raw[0:2] not in _CDR_LE:
        raise MalformedMessage(f"no little endian CDR DiagnosticArray ({len(raw)} bytes, "
                               f"encapsulation {raw[0:2].hex() or 'none'})")
    pattern = None if keys is None else _key_pattern(frozenset(keys))
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
        if pattern is not None:
            values, offset = _wanted_values(raw, offset, pairs, pattern)
        else:
            values = {}
            for _ in range(pairs):
                key, offset = _string(raw, _aligned4(offset))
                values[key], offset = _string(raw, _aligned4(offset))
        statuses.append(RawStatus(level, name, message, hardware_id, values))
    return statuses
