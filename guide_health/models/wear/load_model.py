"""The normal load on an axis's guides from its masses and its motion, for a machine without a load cell.

Rigid-body statics and Newton's second law of the moving assembly (carriage or table plus workpiece, mass
m = m_carriage + m_workpiece) on an axis inclined by theta from the horizontal (0: a horizontal axis
whose ways carry the weight; 90 deg: a vertical axis, its weight along the axis, carried by the drive):

    W_weight = m g cos(theta)                         weight component normal to the ways
    F_axial  = m (a + g sin(theta))                   force the drive transmits along the axis
    W_couple = |F_axial| e / h                        the couple of F_axial about the drive line, reacted by
                                                      carriages (or way ends) a distance h apart; e: the
                                                      centre of mass's offset from the drive line
    W        = W_weight + W_couple                    normal load on the axis's guides [N] (their sum;
                                                      the axis shares it out by guide_load_weights)

(e.g. Shigley's Mechanical Engineering Design, free-body diagram of a carriage: sum of forces along the
axis and moments about the drive nut). docs/machine.md's z axis: 600 kg, theta = 90 deg, a = 0,
e / h = 0.35 / 0.5 gives 4.1 kN.

The acceleration a comes from the joint positions only (every controller publishes them; the velocity
field is optional in JointState): with j the latest earlier sample stamped at least T =
``acceleration_window_s`` before sample i (the oldest kept sample when none is), the velocity
v_i = (x_i - x_j) / (t_i - t_j) and the acceleration a_i = (v_i - v_j) / (t_i - t_j): the mean acceleration
over about the last 2 T, a moving secant that smooths encoder noise (noise sd sigma gives an acceleration
noise of about 2 sigma / T^2). The first sample has v = a = 0. The live path (:meth:`NormalLoadModel.load_n`,
sample by sample) and the offline path (:meth:`NormalLoadModel.loads_n`, arrays) keep the same history and
give the same numbers; the history is not saved (after a restart the first sample starts it again).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

#: standard gravity [m/s^2] (ISO 80000-3)
STANDARD_GRAVITY_M_S2 = 9.80665
NS_PER_S = 1_000_000_000


def normal_load_n(mass_kg, incline_rad: float, acceleration_m_s2, lever_ratio: float):
    """W = m g cos(theta) + |m (a + g sin(theta))| e / h [N] (scalar or arrays; the module docstring)."""
    weight = mass_kg * STANDARD_GRAVITY_M_S2 * math.cos(incline_rad)
    axial = mass_kg * (acceleration_m_s2 + STANDARD_GRAVITY_M_S2 * math.sin(incline_rad))
    return weight + np.abs(axial) * lever_ratio


@dataclass
class NormalLoadModel:
    """The axis's normal load from its configured masses and its motion (parameters ``moving_mass_kg``,
    ``workpiece_mass_kg``, ``axis_incline_deg``, ``load_lever_ratio``, ``acceleration_window_s``)."""

    moving_mass_kg: float
    workpiece_mass_kg: float
    axis_incline_deg: float
    load_lever_ratio: float
    acceleration_window_s: float

    def __post_init__(self) -> None:
        self.history: deque = deque()      # (t_ns, position_m, velocity_m_s) from the lag sample on

    @classmethod
    def from_params(cls, p) -> NormalLoadModel:
        """From an axis's typed parameters (params.typed.WearAxisParams)."""
        return cls(float(p.moving_mass_kg), float(p.workpiece_mass_kg), float(p.axis_incline_deg),
                   float(p.load_lever_ratio), float(p.acceleration_window_s))

    @property
    def mass_kg(self) -> float:
        return self.moving_mass_kg + self.workpiece_mass_kg

    def _load(self, acceleration_m_s2):
        return normal_load_n(self.mass_kg, math.radians(self.axis_incline_deg), acceleration_m_s2,
                             self.load_lever_ratio)

    def load_n(self, t_ns: int, position_m: float) -> float:
        """The normal load [N] at one accepted joint sample (stamps increasing)."""
        lag_ns = int(round(self.acceleration_window_s * NS_PER_S))
        h = self.history
        if not h:
            h.append((int(t_ns), float(position_m), 0.0))
            return float(self._load(0.0))
        while len(h) > 1 and h[1][0] <= t_ns - lag_ns:
            h.popleft()
        tj, xj, vj = h[0]
        dt = (t_ns - tj) * 1e-9
        v = (position_m - xj) / dt
        a = (v - vj) / dt
        h.append((int(t_ns), float(position_m), v))
        return float(self._load(a))

    def loads_n(self, t_ns, position_m) -> np.ndarray:
        """:meth:`load_n` of arrays of accepted joint samples (the same arithmetic)."""
        t = np.asarray(t_ns, dtype=np.int64)
        x = np.asarray(position_m, dtype=float)
        if t.size == 0:
            return np.zeros(0)
        lag_ns = int(round(self.acceleration_window_s * NS_PER_S))
        kept = len(self.history)
        start = [] if kept else [(int(t[0]), float(x[0]), 0.0)]
        ht = np.array([e[0] for e in self.history] + [e[0] for e in start] + t[len(start):].tolist(), dtype=np.int64)
        hx = np.concatenate(([e[1] for e in self.history] + [e[1] for e in start], x[len(start):]))
        hv = np.zeros(ht.size)
        hv[:kept + len(start)] = [e[2] for e in self.history] + [e[2] for e in start]
        first = kept + len(start)                 # the samples computed here
        # j(i): the latest sample stamped <= t_i - T, else the oldest kept one
        j = np.maximum(np.searchsorted(ht, ht[first:] - lag_ns, side="right") - 1, 0)
        dt = (ht[first:] - ht[j]) * 1e-9
        v = (hx[first:] - hx[j]) / dt
        hv[first:] = v                             # j(i) < i: v_j is known before v_i is needed
        a = np.zeros(ht.size)
        a[first:] = (v - hv[j]) / dt
        keep = int(j[-1]) if j.size else 0
        self.history = deque(zip(ht[keep:].tolist(), hx[keep:].tolist(), hv[keep:].tolist()))
        out = self._load(a[kept:])
        return np.asarray(out, dtype=float)
