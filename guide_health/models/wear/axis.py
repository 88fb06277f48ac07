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

import numpy as np

from guide_health.models.wear.maintenance import MaintenanceEvent, apply_baseline, apply_event, baseline, check_event
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
        self.events: list[MaintenanceEvent] = []       # applied, in order (models/wear/maintenance.py)
        self.pending: list[MaintenanceEvent] = []      # stamped after the present: applied when time gets there
        self.baselines: dict[str, dict] = {}           # guide -> what a wear reset changed

    # --- maintenance events ------------------------------------------------------------------------
    def schedule(self, event: MaintenanceEvent) -> str | None:
        """Take a maintenance event: applied now when stamped at or before the present (the last joint
        sample), else when the first joint sample stamped after it arrives (live and offline alike).
        Returns a rejection reason (the event is not applied), or None (applied, pending or a repeat)."""
        reason = check_event(event, list(self.guides), self.params["straightness_limit_m"])
        if reason is not None:
            return self.reject(f"maintenance event: {reason}")
        if any(e.key == event.key for e in self.events + self.pending):
            return None                      # seen before (the node's own event back from the topic)
        if self.last_t_ns is not None and event.t_ns <= self.last_t_ns:
            return self._apply(event)
        self.pending.append(event)
        self.pending.sort(key=lambda e: e.t_ns)
        return None

    def _apply(self, event: MaintenanceEvent) -> str | None:
        reasons = []
        for name, guide in self.guides.items():
            if event.guide in ("", name):
                reasons.append(apply_event(guide, event))
                if event.kind in ("regrind", "replace_rail"):
                    self.baselines[name] = baseline(guide)
        self.events.append(event)
        return next((r for r in reasons if r), None)

    def apply_due(self, t_ns: int | None = None) -> list[str]:
        """Apply the pending events stamped before ``t_ns`` (None: all of them); rejection reasons."""
        reasons = []
        while self.pending and (t_ns is None or self.pending[0].t_ns < t_ns):
            reason = self._apply(self.pending.pop(0))
            if reason:
                reasons.append(reason)
        return reasons

    def maintenance_state(self) -> dict:
        return {"events": [e.as_dict() for e in self.events], "pending": [e.as_dict() for e in self.pending],
                "baselines": self.baselines}

    def restore_maintenance(self, state: dict) -> None:
        """After the guides were restored: their baselines again, the event log and the pending events."""
        self.events = [MaintenanceEvent.from_dict(d) for d in state.get("events", [])]
        self.pending = [MaintenanceEvent.from_dict(d) for d in state.get("pending", [])]
        self.baselines = {name: dict(b) for name, b in state.get("baselines", {}).items() if name in self.guides}
        for name, values in self.baselines.items():
            apply_baseline(self.guides[name], values)

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

    @property
    def load_n(self) -> float:
        """The latest accepted axis load [N] (the first guide's share of it, scaled back)."""
        share = self.shares[self.primary_name]
        return self.primary.load_n if share == 1.0 else self.primary.load_n / share

    def integrate_joint(self, t_ns: int, position_m: float, load_n: float | None = None) -> None:
        """An accepted sample; ``load_n``: the axis load [N] to integrate it with (None: the latest)."""
        if self.pending and self.pending[0].t_ns < t_ns:
            self.apply_due(t_ns)
        for name, guide in self.guides.items():
            guide.integrate_joint(t_ns, position_m, None if load_n is None else self._guide_load(name, load_n))

    def integrate_many(self, t_ns, position_m, load_n, own=None) -> None:
        """:meth:`integrate_joint` of accepted samples in stamp order, through the guides' batch path
        (PrecisionMonitor._advance_many), split at the pending maintenance events as sample by sample.
        ``load_n``: the axis load [N] of each sample; ``own``: None or (indices, [loads per guide]) of
        samples each guide integrates with its own latest load (``integrate_joint(..., None)``)."""
        t_ns = np.asarray(t_ns, dtype=np.int64)
        lo, n = 0, int(t_ns.size)
        while self.pending and lo < n:
            hi = int(np.searchsorted(t_ns, self.pending[0].t_ns, side="right"))   # stamped <= the event
            if hi >= n:
                break
            self._integrate_guides(t_ns, position_m, load_n, own, lo, hi)
            self.apply_due(int(t_ns[hi]))
            lo = hi
        self._integrate_guides(t_ns, position_m, load_n, own, lo, n)

    def _integrate_guides(self, t_ns, position_m, load_n, own, lo: int, hi: int) -> None:
        if hi <= lo:
            return
        for k, (name, guide) in enumerate(self.guides.items()):
            share = self.shares[name]
            w = load_n[lo:hi] if share == 1.0 else load_n[lo:hi] * share
            if own is not None:
                sel = (own[0] >= lo) & (own[0] < hi)
                if sel.any():
                    w = w.copy()
                    w[own[0][sel] - lo] = own[1][k][sel]
            guide._advance_many(t_ns[lo:hi], position_m[lo:hi], w)

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

    def on_temperature(self, t_ns: int, temperature_c: float) -> str | None:
        """A guide/temperature reading: every rolling guide's oil viscosity from its stamp on (Walther oil),
        every guide's thermal_drift correction; the rejection reason of an implausible one, else None."""
        reasons = [g.on_temperature(t_ns, temperature_c) for g in self.guides.values()]
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
        """Every guide through PrecisionMonitor.process_run with its share of the run's load; the run is
        split at the pending maintenance events, each applied after the samples stamped at or before it."""
        while self.pending and run.joint_t_ns.size and self.pending[0].t_ns < int(run.joint_t_ns[-1]):
            head, run = split_run(run, self.pending[0].t_ns)
            self._process(head, progress)
            self._apply(self.pending.pop(0))
        self._process(run, progress)

    def _process(self, run, progress=None) -> None:
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
        report["maintenance_event_count"] = len(self.events)
        if self.events:
            last = self.events[-1]
            report["last_maintenance"] = f"{last.kind}{'/' + last.guide if last.guide else ''}@{last.t_ns}"
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


def split_run(run, t_ns: int):
    """(samples stamped at or before ``t_ns``, the rest) of a MachineRun."""
    def cut(t):
        return int(np.searchsorted(t, t_ns, side="right"))

    j, ld, st, tp = cut(run.joint_t_ns), cut(run.load_t_ns), cut(run.straightness_t_ns), cut(run.temperature_t_ns)
    vel = run.joint_velocity_m_s
    head = dataclasses.replace(
        run, joint_t_ns=run.joint_t_ns[:j], joint_position_m=run.joint_position_m[:j],
        joint_velocity_m_s=vel[:j] if vel.size else vel, load_t_ns=run.load_t_ns[:ld], load_n=run.load_n[:ld],
        straightness_t_ns=run.straightness_t_ns[:st], straightness_m=run.straightness_m[:st],
        temperature_t_ns=run.temperature_t_ns[:tp], temperature_c=run.temperature_c[:tp])
    tail = dataclasses.replace(
        run, joint_t_ns=run.joint_t_ns[j:], joint_position_m=run.joint_position_m[j:],
        joint_velocity_m_s=vel[j:] if vel.size else vel, load_t_ns=run.load_t_ns[ld:], load_n=run.load_n[ld:],
        straightness_t_ns=run.straightness_t_ns[st:], straightness_m=run.straightness_m[st:],
        temperature_t_ns=run.temperature_t_ns[tp:], temperature_c=run.temperature_c[tp:])
    return head, tail
