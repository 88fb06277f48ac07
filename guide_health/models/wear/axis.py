"""One axis of a machine: its guides (rails or ways), each a :class:`PrecisionMonitor` with its share of the
axis load; the single model object behind an axis of the live node and of offline replay.

An axis has one position (its JointState joint) and one load sensor (WrenchStamped force.z of the axis):
guide g carries ``share_g x W`` (the shares are the normalised ``guide_load_weights``; a table on two
rails with its centre of mass between them carries equal shares, a head overhanging one rail loads it
more, static moment balance of a rigid carriage: share_front = b / (a + b) for a mass at a from the front
rail and b from the rear one). Every guide slides the same distance. A straightness measurement of the
axis updates every guide's K (the measured axis is the way pair the carriages ride on). The axis reports
its worst guide (lowest remaining precision life, then highest level).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any

from guide_health.models.wear.precision import PrecisionMonitor

#: the keys every `<axis> precision` status carries ('nan' until known; README "Diagnostics")
PRECISION_KEYS = ("straightness_um", "straightness_measured_um", "straightness_limit_um", "remaining_life_h",
                  "remaining_life_h_low", "remaining_life_h_high", "wear_volume_mm3", "sliding_distance_m",
                  "wear_coefficient", "lubrication_regime")


class AxisMonitor:
    """The guides of one axis (parameters: one axis of guide_health.params.machine.axes_params)."""

    def __init__(self, params: dict[str, Any]):
        self.params = dict(params)
        self.axis = params.get("axis", params["joint"])
        names = list(params.get("guides", ["guide"]))
        shares = list(params.get("guide_load_shares", [1.0 / len(names)] * len(names)))
        self.shares = dict(zip(names, shares))
        self.guides = {name: PrecisionMonitor(params) for name in names}
        self.primary = self.guides[names[0]]

    # --- the interface StampAlignedFeed and the node use -------------------------------------------
    @property
    def load_t_ns(self) -> int | None:
        return self.primary.load_t_ns

    @property
    def last_t_ns(self) -> int | None:
        return self.primary.integrator.last_t_ns

    @property
    def rejected(self):
        """The rejection counter of the axis (every guide counts the same samples: the first guide's)."""
        return self.primary.rejected

    @property
    def rolling(self):
        return self.primary.rolling

    def validate_joint(self, t_ns: int, position_m: float, velocity_m_s: float = 0.0) -> str | None:
        reasons = [g.validate_joint(t_ns, position_m, velocity_m_s) for g in self.guides.values()]
        return reasons[0]

    def integrate_joint(self, t_ns: int, position_m: float) -> None:
        for guide in self.guides.values():
            guide.integrate_joint(t_ns, position_m)

    def on_joint(self, t_ns: int, position_m: float, velocity_m_s: float = 0.0) -> str | None:
        reason = self.validate_joint(t_ns, position_m, velocity_m_s)
        if reason is None:
            self.integrate_joint(t_ns, position_m)
        return reason

    def check_load(self, t_ns: int, load_n: float) -> str | None:
        return self.primary.check_load(t_ns, self._guide_load(self.primary_name, load_n))

    def on_load(self, t_ns: int, load_n: float) -> str | None:
        reasons = [g.on_load(t_ns, self._guide_load(name, load_n)) for name, g in self.guides.items()]
        return reasons[0]

    def on_straightness(self, t_ns: int, straightness_m: float) -> str | None:
        reasons = [g.on_straightness(t_ns, straightness_m) for g in self.guides.values()]
        return reasons[0]

    def reject_input(self, stream: str, reason: str) -> str:
        for guide in self.guides.values():
            guide.reject_input(stream, reason)
        return reason

    def reject(self, reason: str) -> str:
        """Count a rejection that belongs to no stream (e.g. a straightness before any time base)."""
        for guide in self.guides.values():
            guide.rejected.reject(reason)
        return reason

    @property
    def primary_name(self) -> str:
        return next(iter(self.guides))

    def _guide_load(self, name: str, load_n: float) -> float:
        share = self.shares[name]
        return load_n if share == 1.0 else load_n * share

    # --- offline ----------------------------------------------------------------------------------
    def process_run(self, run, progress=None) -> None:
        """Every guide through PrecisionMonitor.process_run with its share of the run's load."""
        for name, guide in self.guides.items():
            share = self.shares[name]
            guide_run = run if share == 1.0 else dataclasses.replace(run, load_n=run.load_n * share)
            guide.process_run(guide_run, progress=progress if guide is self.primary else None)

    # --- results ----------------------------------------------------------------------------------
    def guide_reports(self) -> dict[str, dict]:
        return {name: guide.report() for name, guide in self.guides.items()}

    def report(self) -> dict[str, Any]:
        """The `<axis> precision` numbers: those of the worst guide (highest level, then lowest remaining
        life), with ``guide`` naming it when the axis has several."""
        reports = self.guide_reports()
        name = min(reports, key=lambda n: (-int(reports[n]["level"]), _life_key(reports[n]["remaining_life_h"])))
        report = dict(reports[name])
        if len(reports) > 1:
            report["guide"] = name
            report["message"] = f"{name}: {report['message']}"
        return report

    def fatigue_report(self) -> dict[str, Any] | None:
        """The `<axis> fatigue` numbers of the guide with the largest used life fraction (rolling guides)."""
        if self.rolling is None:
            return None
        reports = {name: g.fatigue_report() for name, g in self.guides.items()}
        name = max(reports, key=lambda n: _used_key(reports[n].get("life_used_fraction", math.nan)))
        report = dict(reports[name])
        if len(reports) > 1:
            report["guide"] = name
            report["message"] = f"{name}: {report['message']}"
        return report

    # --- persistence ------------------------------------------------------------------------------
    def state_keys(self, machine_id: str) -> dict[str, str]:
        """{guide: state key}: ``<machine_id>/<axis>/precision`` for a single guide (the single-joint key
        of old), ``<machine_id>/<axis>/<guide>/precision`` for each of several guides."""
        if len(self.guides) == 1:
            return {self.primary_name: f"{machine_id}/{self.axis}/precision"}
        return {name: f"{machine_id}/{self.axis}/{name}/precision" for name in self.guides}


def _life_key(life_h: float) -> float:
    return math.inf if math.isnan(life_h) else life_h


def _used_key(fraction: float) -> float:
    return -math.inf if math.isnan(fraction) else fraction
