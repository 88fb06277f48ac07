"""The rosbags typestore (ROS 2 Jazzy) and message construction; rosbags is imported on first use."""
from __future__ import annotations

import functools

from .interfaces import NS_PER_S


@functools.lru_cache(maxsize=1)
def typestore():
    """The rosbags typestore of ROS 2 Jazzy (made once)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def message(typename: str, **fields):
    """A rosbags message object of type `typename`."""
    return typestore().types[typename](**fields)


def header(t_ns: int = 0, frame_id: str = ""):
    """std_msgs/Header stamped `t_ns` [ns since the epoch]."""
    sec, nsec = divmod(int(t_ns), NS_PER_S)
    return message("std_msgs/msg/Header", stamp=message("builtin_interfaces/msg/Time", sec=sec, nanosec=nsec),
                   frame_id=frame_id)
