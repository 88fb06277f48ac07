"""Time series of one machine as numpy arrays: the common currency of simulate, bags and replay.

Times are int64 nanoseconds (header stamps, same clock as rosbag2 log times). SI units.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def _f64(values=()) -> np.ndarray:
    return np.asarray(values, dtype=np.float64)


def _i64(values=()) -> np.ndarray:
    return np.asarray(values, dtype=np.int64)


@dataclass
class MachineRun:
    """Axis motion, guide load, straightness measurements (and optional temperature) of one machine."""

    joint_name: str = "x"
    joint_t_ns: np.ndarray = field(default_factory=_i64)
    joint_position_m: np.ndarray = field(default_factory=_f64)
    joint_velocity_m_s: np.ndarray = field(default_factory=_f64)   # may be empty: derive from position
    load_t_ns: np.ndarray = field(default_factory=_i64)
    load_n: np.ndarray = field(default_factory=_f64)               # WrenchStamped wrench.force.z
    straightness_t_ns: np.ndarray = field(default_factory=_i64)    # bag log time (Float64 has no header)
    straightness_m: np.ndarray = field(default_factory=_f64)
    temperature_t_ns: np.ndarray = field(default_factory=_i64)
    temperature_c: np.ndarray = field(default_factory=_f64)
    metadata: dict = field(default_factory=dict)                   # e.g. simulation truth, effects
    # messages no sample could be read from (malformed, without the joint, invalid stamp), in bag order:
    # ((input, index, reason), ...), index = the samples of that input ("joint_states", "guide/load", ...) of
    # this run that came before it
    rejected_messages: tuple = ()

    @property
    def messages(self) -> int:
        return int(self.joint_t_ns.size + self.load_t_ns.size + self.straightness_t_ns.size
                   + self.temperature_t_ns.size)

    @property
    def duration_s(self) -> float:
        stamps = [a for a in (self.joint_t_ns, self.load_t_ns, self.straightness_t_ns) if a.size]
        if not stamps:
            return 0.0
        t0 = min(int(a[0]) for a in stamps)
        t1 = max(int(a[-1]) for a in stamps)
        return (t1 - t0) * 1e-9


@dataclass
class SlewingLoadRun:
    """Slewing-bearing loads from geometry_msgs/WrenchStamped on `slewing/load`."""

    t_ns: np.ndarray = field(default_factory=_i64)
    axial_n: np.ndarray = field(default_factory=_f64)        # force.z
    radial_n: np.ndarray = field(default_factory=_f64)       # hypot(force.x, force.y)
    moment_nm: np.ndarray = field(default_factory=_f64)      # hypot(torque.x, torque.y)
    metadata: dict = field(default_factory=dict)
    # slewing axis angle (sensor_msgs/JointState, the rating life's angle travelled); empty: none recorded
    axis_t_ns: np.ndarray = field(default_factory=_i64)
    axis_angle_rad: np.ndarray = field(default_factory=_f64)
    # measured tilting clearances (std_msgs/Float64 [m], dated by their log time); empty: none recorded
    clearance_t_ns: np.ndarray = field(default_factory=_i64)
    clearance_m: np.ndarray = field(default_factory=_f64)
