"""Message types and topic names of the interfaces (INTERFACES.md); times are int64 nanoseconds.

Topics, relative to a machine namespace ``<ns>``:
``<ns>/joint_states`` sensor_msgs/msg/JointState, ``<ns>/guide/load`` geometry_msgs/msg/WrenchStamped
(force.z), ``<ns>/guide/straightness`` std_msgs/msg/Float64, ``<ns>/guide/temperature``
sensor_msgs/msg/Temperature, ``<ns>/slewing/load`` geometry_msgs/msg/WrenchStamped.
"""
from __future__ import annotations

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

NS_PER_S = 1_000_000_000


def topic_name(namespace: str | None, relative: str) -> str:
    """Absolute topic of `relative` in the machine namespace (None or '' = the root)."""
    ns = (namespace or "").strip("/")
    return f"/{ns}/{relative}" if ns else f"/{relative}"
