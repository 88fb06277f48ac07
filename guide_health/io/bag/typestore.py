"""The rosbags typestore (ROS 2 Jazzy) and message construction; rosbags is imported on first use."""
from __future__ import annotations

import functools

from .interfaces import NS_PER_S


@functools.lru_cache(maxsize=1)
def typestore():
    """The rosbags typestore of ROS 2 Jazzy (made once)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def deserialize(raw, msgtype: str):
    """rosbags' CDR deserialisation of ``raw`` as ``msgtype``, with trailing bytes after the content allowed
    (as Fast CDR, the live nodes' deserialiser, allows them; rosbags' ``deserialize_cdr`` allows at most 3);
    raises on anything else rosbags refuses (encapsulation, a field running past the end, a bad string)."""
    import struct

    from rosbags.serde import SerdeError

    raw = bytes(raw)
    if len(raw) < 4 or raw[:2] not in (b"\x00\x00", b"\x00\x01"):
        raise SerdeError("invalid or unsupported CDR encapsulation")
    msgdef = typestore().get_msgdef(msgtype)
    decode = msgdef.deserialize_cdr_le if raw[1] else msgdef.deserialize_cdr_be
    try:
        return decode(raw[4:], 0, msgdef.cls, typestore())[0]
    except (struct.error, UnicodeDecodeError, ValueError) as exc:
        raise SerdeError(f"could not deserialize {msgtype!r}: {exc}") from None


def message(typename: str, **fields):
    """A rosbags message object of type `typename`."""
    return typestore().types[typename](**fields)


def header(t_ns: int = 0, frame_id: str = ""):
    """std_msgs/Header stamped `t_ns` [ns since the epoch]."""
    sec, nsec = divmod(int(t_ns), NS_PER_S)
    return message("std_msgs/msg/Header", stamp=message("builtin_interfaces/msg/Time", sec=sec, nanosec=nsec),
                   frame_id=frame_id)
