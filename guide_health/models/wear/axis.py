"""One axis of a machine: its input gate and its guides (rails or ways), each guide's physics with its share
of the axis load; the single model object behind an axis of the live node and of offline replay.

A sample passes the axis's :class:`~guide_health.models.wear.gate.InputGate` once (every input rule, the
rejection counts, the recent windows, the stamp gaps); each accepted sample then advances the physics of
every guide (:class:`~guide_health.models.wear.guide.GuideWear`). The remaining life, its interval, the
forecast and the judgement are functions of typed inputs (models/wear/life.py).

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

from guide_health.models.wear.form_average import life_form_lists
from guide_health.models.wear.gate import InputGate
from guide_health.models.wear.guide import GuideWear
from guide_health.models.wear.input_rules import (
    MAINTENANCE_REPEATED,
    STRAIGHTNESS_WITHOUT_TIME_BASE,
    InputLimits,
    rejected_key,
)
from guide_health.models.wear.life import (
    ForecastNow,
    LifeNow,
    PrecisionNow,
    RecentInputs,
    Thresholds,
    forecast,
    judge,
    judge_model_fit,
)
from guide_health.models.wear.load_model import NormalLoadModel
from guide_health.models.wear.maintenance import (
    RESETS_WEAR,
    MaintenanceEvent,
    apply_baseline,
    apply_event,
    baseline,
    event_rejection,
    repeat_of,
    stamp_text,
)
from guide_health.models.wear.planning import LifeInputs, life_interval, status_calendar_keys

#: the keys every `<axis> precision` status carries ('nan' until known; README "Diagnostics")
PRECISION_KEYS = ("straightness_um", "straightness_measured_um", "straightness_limit_um", "remaining_life_h",
                  "remaining_life_h_low", "remaining_life_h_high", "wear_volume_mm3", "sliding_distance_m",
                  "wear_coefficient")


class AxisMonitor:
    """The input gate and the guides of one axis (``params``: its frozen parameters,
    guide_health.params.typed.WearAxisParams; ``guides``: their names, default the parameter ``guides``)."""

    def __init__(self, params: Any, guides=None):
        self.params = params
        self.axis = params.axis
        names = list(params.guides if guides is None else guides)
        shares = [1.0 / len(names)] * len(names)          # named guides: equal shares
        if guides is None:
            shares = list(params.guide_load_shares)
        self.shares = dict(zip(names, shares))
        self.gate = InputGate(params, self.shares[names[0]])     # every input rule, once per sample
        self.guides = {name: GuideWear(params) for name in names}   # physics only
        self.events: list[MaintenanceEvent] = []       # applied, in order (models/wear/maintenance.py)
        self.pending: list[MaintenanceEvent] = []      # stamped after the present: applied when time gets there
        self.baselines: dict[str, dict] = {}           # guide -> what a wear reset changed
        # load_source model: the normal load of every accepted joint sample from the masses and the motion
        self.load_model = NormalLoadModel.from_params(params) if params.load_source == "model" else None

    # --- maintenance events ------------------------------------------------------------------------
    def schedule(self, event: MaintenanceEvent) -> str | None:
        """Take a maintenance event: applied now when stamped at or before the present (the last joint
        sample), else when the first joint sample stamped after it arrives (live and offline alike).
        Returns a rejection reason (the event is not applied; counted under its input_rules reason), or None
        (applied, pending, or the same event seen again: the node's own event back from the topic)."""
        rejection = event_rejection(event, list(self.guides), self.params.straightness_limit_m)
        if rejection is not None:
            return self.reject_event(*rejection)
        if any(e.key == event.key for e in self.events + self.pending):
            return None
        earlier = self.repeat_of(event)
        if earlier is not None:
            return self.reject_event(MAINTENANCE_REPEATED, f"already applied at {stamp_text(earlier.t_ns)}")
        if self.last_t_ns is not None and event.t_ns <= self.last_t_ns:
            return self._apply(event)
        self.pending.append(event)
        self.pending.sort(key=lambda e: e.t_ns)
        return None

    def repeat_of(self, event: MaintenanceEvent) -> MaintenanceEvent | None:
        """The applied or pending event that ``event`` repeats within maintenance_repeat_window_s, or None."""
        return repeat_of(event, self.events + self.pending, self.params.maintenance_repeat_window_s)

    def reject_event(self, reason: str, details: str) -> str:
        """Count a maintenance event not applied under ``reason``; returns the reason with the details."""
        self.reject(reason)
        return f"{reason}: {details}"

    def _apply(self, event: MaintenanceEvent) -> str | None:
        names = [name for name in self.guides if event.guide in ("", name)]
        reason = None
        if event.kind == "measure":          # a straightness measurement through the gate, of these guides
            reason = self.on_straightness(int(event.t_ns), float(event.straightness_m), names)
        else:
            for name in names:
                apply_event(self.guides[name], event)
                if event.kind in RESETS_WEAR:
                    self.baselines[name] = baseline(self.guides[name])
                    if math.isfinite(event.straightness_m):     # the value measured after it
                        self.baselines[name]["straightness_measured_m"] = float(event.straightness_m)
                    self.guides[name].fit_watch.clear(int(event.t_ns))   # a new surface: a new fit test
        self.events.append(event)
        return reason

    def apply_due(self, t_ns: int | None = None) -> list[str]:
        """Apply the pending events stamped before ``t_ns`` (None: all of them); rejection reasons."""
        reasons = []
        while self.pending and (t_ns is None or self.pending[0].t_ns < t_ns):
            reason = self._apply(self.pending.pop(0))
            if reason:
                reasons.append(reason)
        return reasons

    def measured_after_reset(self, name: str) -> float:
        """The straightness [m] entered with guide ``name``'s last regrind or rail replacement (NaN: none):
        its measured straightness until the next measurement."""
        return float(self.baselines.get(name, {}).get("straightness_measured_m", math.nan))

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

    # --- the present --------------------------------------------------------------------------------
    @property
    def primary_name(self) -> str:
        return next(iter(self.guides))

    @property
    def load_t_ns(self) -> int | None:
        return self.gate.load_t_ns

    @property
    def load_n(self) -> float:
        """The latest accepted axis load [N]."""
        return self.gate.load_n

    @property
    def last_t_ns(self) -> int | None:
        """The stamp of the last integrated joint sample (every guide integrates the same samples)."""
        return self.guides[self.primary_name].integrator.last_t_ns

    @property
    def rejected(self):
        """The rejection counter of the axis (the gate's)."""
        return self.gate.rejected

    @property
    def rolling(self):
        return self.guides[self.primary_name].rolling

    @property
    def primary(self) -> GuideView:
        """The first guide seen whole."""
        return self.guide()

    def guide(self, name: str | None = None) -> GuideView:
        """One guide seen whole (its physics, this axis's gate and life functions); None: the first."""
        return GuideView(self, self.primary_name if name is None else name)

    def guide_load(self, name: str, load_n):
        """Guide ``name``'s share of an axis load [N] (scalar or array)."""
        share = self.shares[name]
        return load_n if share == 1.0 else load_n * share

    # --- samples: the gate once, then every guide's physics -------------------------------------------
    def validate_joint(self, t_ns: int, position_m: float, velocity_m_s: float = 0.0) -> str | None:
        """The joint rules of an axis sample (counted) without integrating it; the reason or None (the
        caller integrates it later: :meth:`integrate_joint`)."""
        return self.gate.accept_joint(t_ns, position_m, velocity_m_s)

    def integrate_joint(self, t_ns: int, position_m: float, load_n: float | None = None) -> None:
        """An accepted sample; ``load_n``: the axis load [N] to integrate it with (None: the latest)."""
        if self.pending and self.pending[0].t_ns < t_ns:
            self.apply_due(t_ns)
        if self.load_model is not None:
            load_n = self.load_model.load_n(t_ns, position_m)
        load = self.gate.load_n if load_n is None else load_n
        for name, guide in self.guides.items():
            guide.advance(t_ns, position_m, self.guide_load(name, load))

    def on_joint(self, t_ns: int, position_m: float, velocity_m_s: float = 0.0) -> str | None:
        """Axis sample; returns the rejection reason or None when accepted (and integrated)."""
        reason = self.validate_joint(t_ns, position_m, velocity_m_s)
        if reason is None:
            self.integrate_joint(t_ns, position_m)
        return reason

    def accept_joints(self, t_ns, position_m, velocity_m_s):
        """:meth:`validate_joint` of arrays (input_rules.Acceptance)."""
        return self.gate.accept_joints(t_ns, position_m, velocity_m_s)

    def check_load(self, t_ns: int, load_n: float) -> str | None:
        """The rejection reason :meth:`on_load` would give (nothing counted or changed)."""
        return self.gate.check_load(t_ns, load_n)

    def on_load(self, t_ns: int, load_n: float) -> str | None:
        """Axis load sample [N]; returns the rejection reason or None when accepted."""
        return self.gate.accept_load(t_ns, load_n)

    def accept_loads(self, t_ns, load_n):
        """:meth:`on_load` of arrays: (input_rules.Acceptance, the latest axis load before them)."""
        return self.gate.accept_loads(t_ns, load_n)

    def integrate_many(self, t_ns, position_m, load_n, own=None) -> None:
        """:meth:`integrate_joint` of accepted samples in stamp order (each guide's batch path), split at the
        pending maintenance events as sample by sample. ``load_n``: the axis load [N] of each sample;
        ``own``: None or (indices, axis loads) of samples integrated with the latest load at their turn."""
        t_ns = np.asarray(t_ns, dtype=np.int64)
        if self.load_model is not None:
            load_n, own = self.load_model.loads_n(t_ns, position_m), None
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
        for name, guide in self.guides.items():
            w = self.guide_load(name, load_n[lo:hi])
            if own is not None:
                sel = (own[0] >= lo) & (own[0] < hi)
                if sel.any():
                    w = w.copy()
                    w[own[0][sel] - lo] = self.guide_load(name, own[1][sel])
            guide.advance_many(t_ns[lo:hi], position_m[lo:hi], w)

    def on_straightness(self, t_ns: int, straightness_m: float, guides=None) -> str | None:
        """Straightness measurement [m] of the axis (``guides``: the names it concerns, None: all); returns
        the rejection reason or None when accepted. A measurement is identified by its stamp: one with the
        stamp of an applied measurement is not applied again."""
        names = list(self.guides) if guides is None else list(guides)
        if self.last_t_ns is None:   # before any integrated joint sample (discrepancy/duty.py alike)
            return self.gate.reject(STRAIGHTNESS_WITHOUT_TIME_BASE)
        reason = self.gate.accept_straightness(t_ns, straightness_m, self.guides[names[0]].last_measurement_t_ns)
        if reason is not None:
            return reason
        reasons = [self.guides[name].measure(t_ns, straightness_m) for name in names]
        return None if reasons[0] is None else self.gate.reject(reasons[0])

    def on_temperature(self, t_ns: int, temperature_c: float) -> str | None:
        """A guide/temperature reading: every rolling guide's oil viscosity from its stamp on (Walther oil),
        every guide's temperature correction of the gauge; the rejection reason of an implausible one, else None."""
        reason = self.gate.accept_temperature(temperature_c)
        if reason is None:
            for guide in self.guides.values():
                guide.add_temperature(t_ns, temperature_c)
        return reason

    def reject_input(self, stream: str, reason: str) -> str:
        """Count a message-level rejection of an input stream (the live node: a JointState without the
        joint, an undecodable message, ...); it counts in the stream's recent rejected share."""
        return self.gate.record(stream, reason)

    def reject(self, reason: str) -> str:
        """Count a rejection that belongs to no stream (e.g. a straightness before any time base)."""
        return self.gate.reject(reason)

    # --- offline ----------------------------------------------------------------------------------
    def process_run(self, run, progress=None) -> None:
        """A whole :class:`~guide_health.runs.MachineRun` with the rules of the live callbacks, split at the
        pending maintenance events, each applied after the samples stamped at or before it."""
        while self.pending and run.joint_t_ns.size and self.pending[0].t_ns < int(run.joint_t_ns[-1]):
            head, run = split_run(run, self.pending[0].t_ns)
            self._process(head, progress)
            self._apply(self.pending.pop(0))
        self._process(run, progress)

    def _process(self, run, progress=None) -> None:
        """Samples filtered by the gate (vectorised), each accepted joint sample with the load in force at
        its stamp, the integration split at the measurement times so each measurement sees the wear state
        at its own time."""
        temp_t, temp_c = self.gate.accept_temperatures(getattr(run, "temperature_t_ns", np.zeros(0, np.int64)),
                                                getattr(run, "temperature_c", np.zeros(0)))
        for guide in self.guides.values():
            guide.add_temperatures(temp_t, temp_c)   # the record's readings while its measurements are applied
        accepted = self.gate.accept_run(run)
        jt, jx, load_at_joint = accepted.joint_t_ns, accepted.joint_position_m, accepted.load_at_joint_n
        if self.load_model is not None:
            load_at_joint = self.load_model.loads_n(jt, jx)
        total, done, start = int(jt.size), 0, 0
        for t_meas, value in zip(np.asarray(run.straightness_t_ns, dtype=np.int64).tolist(),
                                 np.asarray(run.straightness_m, dtype=float).tolist()):
            stop = int(np.searchsorted(jt, t_meas, side="right"))
            if stop > start:
                self._integrate_guides(jt, jx, load_at_joint, None, start, stop)
                done += stop - start
                if progress:
                    progress(done, total)
            start = max(start, stop)
            self.on_straightness(t_meas, value)
        # chunks bound the temporaries of the vectorised profile update
        for lo in range(start, total, 500_000):
            hi = min(total, lo + 500_000)
            self._integrate_guides(jt, jx, load_at_joint, None, lo, hi)
            if progress:
                progress(hi, total)
        for guide in self.guides.values():
            guide.trim_temperatures()

    # --- results ----------------------------------------------------------------------------------
    def _life(self, name: str) -> tuple[LifeNow, tuple[float, float, float]]:
        """One guide's :class:`~guide_health.models.wear.life.LifeNow` and its (life, low, high) [s]: with the
        effects effect_life.life_interval_s (delta method), else life.remaining_life_interval_s."""
        inputs = self.life_inputs(name)
        return inputs.now, life_interval(inputs)

    def life_inputs(self, name: str) -> LifeInputs:
        """What one guide's remaining life is computed from (models/wear/planning.py: the status and every
        planning scenario go through planning.life_interval)."""
        guide = self.guides[name]
        p = guide.params
        k_low, k, k_high = guide.estimator.interval90(guide.measurement_losses_per_k_m())
        loss_per_k, rate_per_k = guide.loss_per_k_m(), guide.integrator.straightness_rate_per_k_m_s()
        now = LifeNow(p.straightness_initial_m, p.straightness_limit_m, loss_per_k, rate_per_k, k, k_low, k_high)
        effect = forms = None
        if guide.effect_wear is not None and math.isfinite(loss_per_k) and math.isfinite(rate_per_k):
            effect = guide.effect_life_inputs(k)
            # the running-in's decay laws (in the step's place when the file carries the step) averaged in
            weights, offsets, ratios = life_form_lists(
                p.life_form_weights, p.life_form_ln_life_offsets, p.life_form_ln_life_sd_ratios,
                p.running_in_form_weights, p.running_in_form_ln_life_offsets)
            forms = (offsets, weights, guide.life_z(), ratios, p.life_form_interval == "envelope")
        # while the model-fit test says broken: the interval from the innovations' observed spread
        widen = guide.fit_watch.rms_sigma() if guide.fit_watch.model_fit == "broken" else None
        return LifeInputs(now, effect, widen, forms)

    def guide_report(self, name: str) -> dict[str, Any]:
        """The numbers of one guide's `<axis> precision` status (INTERFACES.md keys) plus level and message."""
        guide, gate = self.guides[name], self.gate
        p = guide.params
        now, (life, life_low, life_high) = self._life(name)
        k, loss_per_k = now.wear_coefficient, now.loss_per_k_m
        limit = p.straightness_limit_m
        straightness = guide.straightness_m(k, loss_per_k) if math.isfinite(loss_per_k) else math.nan
        l_min, l_max = guide.integrator.stroke_range_m()
        measured = guide.estimator.measurement_m[-1] if guide.estimator.count else self.measured_after_reset(name)
        share, stream, reason = gate.recent_rejected_share()
        result = {
            "straightness_um": straightness * 1e6,
            "straightness_measured_um": measured * 1e6,
            "straightness_limit_um": limit * 1e6,
            "remaining_life_h": life / 3600.0,
            "remaining_life_h_low": life_low / 3600.0,
            "remaining_life_h_high": life_high / 3600.0,
            "wear_volume_mm3": k * guide.work_nm() / guide.geometry.hardness_pa * 1e9,
            "sliding_distance_m": guide.integrator.sliding_distance_m,
            "wear_coefficient": k,
            "wear_coefficient_low": now.wear_coefficient_low,
            "wear_coefficient_high": now.wear_coefficient_high,
            "wear_coefficient_configured": p.wear_coefficient,
            "effects": p.effects,
            "measurements": guide.estimator.count,
            "duty_load_speed_w": guide.integrator.duty_work_rate_w(),
            "stroke_min_m": l_min,
            "stroke_max_m": l_max,
            "strokes": guide.integrator.strokes.stroke_count,
            "straightness_model": guide.geometry.straightness_model,
            "samples": guide.integrator.samples,
            "load_samples": gate.load_samples,
            "rejected_samples": gate.rejected.total,
            "rejected_recent_share": share,
            **{rejected_key(r): n for r, n in gate.rejected.items()},
            **gate.stream_gaps.values(),
            **guide.fit_watch.values(),
        }
        result.update(load_source=guide.params.load_source,
                      **status_calendar_keys(guide.integrator.clock, (life, life_low, life_high)))
        if guide.temperature_corrected:
            # straightness_measured_um is the corrected reading; this is what was taken off the last one
            result["straightness_thermal_correction_um"] = guide.thermal_correction_m * 1e6
        judged = PrecisionNow(result["straightness_um"], result["straightness_limit_um"], result["remaining_life_h"],
                              guide.integrator.samples, p.joint)
        recent = RecentInputs(share, stream, reason, len(gate.recent[stream]) if stream else 0)
        result["level"], result["message"], clear = judge(judged, recent, Thresholds.from_params(p))
        result["level"], result["message"] = judge_model_fit(result["level"], result["message"], result)
        clear = judge_model_fit(clear, "", result)[0]
        gaps = gate.stream_gaps.message()
        if gaps:
            result["message"] = f"{result['message']}; {gaps}"
        # the level with every threshold moved by the clear margin (models/levels.py hysteresis_level)
        result["level_clear"] = clear
        if guide.rolling is not None:
            result.update(guide.rolling.lubrication_values())
            level, text = guide.rolling.lubrication_level()
            result["level_clear"] = max(result["level_clear"], level)
            if level > result["level"]:
                result["level"], result["message"] = level, f"{text}; {result['message']}"
            else:
                result["message"] = f"{result['message']}; {text}"
        return result

    def guide_forecast(self, name: str, points: int = 60) -> dict[str, Any]:
        """One guide's straightness from now to the limit (models/wear/life.forecast): {} without a finite
        life."""
        guide, r = self.guides[name], self.guide_report(name)
        now = ForecastNow(r["remaining_life_h"], r["remaining_life_h_low"], r["remaining_life_h_high"],
                          r["straightness_um"], r["straightness_limit_um"], guide.integrator.last_t_ns,
                          guide.integrator.first_t_ns, guide.forecast_terms(r["wear_coefficient"]))
        return forecast(now, points)

    def guide_reports(self) -> dict[str, dict]:
        return {name: self.guide_report(name) for name in self.guides}

    def report(self) -> dict[str, Any]:
        """The `<axis> precision` numbers: those of the worst guide (highest level, then lowest remaining
        life), with ``guide`` naming it when the axis has several."""
        reports = {name: self.guide_report(name) for name in self.guides}
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

    # --- run-time parameter changes ----------------------------------------------------------------
    def apply_params(self, changed: dict, with_changes, limit_params=()) -> None:
        """An accepted run-time change (nodes/live_params.py): every guide's parameters (``with_changes(params,
        changed)``: the new frozen object), the rolling models, K's measurement noise; the gate's limits (any of
        ``limit_params`` changed) and recent windows."""
        self.params = with_changes(self.params, changed)
        for guide in self.guides.values():
            guide.set_params(with_changes(guide.params, changed))
            if "straightness_noise_m" in changed:
                guide.estimator.noise_sd_m = float(changed["straightness_noise_m"])
        if any(name in changed for name in limit_params):
            self.gate.limits = InputLimits.from_params(self.guides[self.primary_name].params)
        if "rejected_window_samples" in changed:
            self.gate.set_window(int(changed["rejected_window_samples"]))

    # --- persistence ------------------------------------------------------------------------------
    def state_keys(self, machine_id: str) -> dict[str, str]:
        """{guide: state key}: ``<machine_id>/<axis>/precision`` for a single guide (the single-joint key
        of old), ``<machine_id>/<axis>/<guide>/precision`` for each of several guides."""
        if len(self.guides) == 1:
            return {self.primary_name: f"{machine_id}/{self.axis}/precision"}
        return {name: f"{machine_id}/{self.axis}/{name}/precision" for name in self.guides}

    def guide_state(self, name: str) -> dict:
        """The saved state of one guide: its physics and the gate's latest load (the guide's share of it)."""
        gate = self.gate
        return self.guides[name].state(self.guide_load(name, gate.load_n), gate.load_t_ns, gate.load_samples)

    def restore_guide(self, name: str, state: dict) -> None:
        """One guide from a :meth:`guide_state`; the gate takes the latest load (back to the axis load), its
        count and the time bases."""
        guide = self.guides[name]
        guide.restore(state)
        share = self.shares[name]
        load = state["load_n"] if share == 1.0 else state["load_n"] / share
        self.gate.restore(load, state["load_t_ns"], state.get("load_samples", 0), guide.integrator.last_t_ns)


def _gate_attribute(name: str) -> property:
    """An attribute of the axis's input gate, read and set through a GuideView."""
    return property(lambda view: getattr(view.axis.gate, name),
                    lambda view, value: setattr(view.axis.gate, name, value))


class GuideView:
    """One guide of an axis seen whole: its physics (attributes of models/wear/guide.GuideWear), the axis's
    input gate (rejections, recent windows, time bases, latest load), its report, forecast and saved state."""

    def __init__(self, axis: AxisMonitor, name: str):
        self.axis, self.name = axis, name

    @property
    def physics(self) -> GuideWear:
        return self.axis.guides[self.name]

    def __getattr__(self, attr: str):
        # the guide's physics: integrator, estimator, effect_wear, effects, geometry, params, rolling, ...
        if attr in ("axis", "name"):
            raise AttributeError(attr)
        return getattr(self.axis.guides[self.name], attr)

    def __setattr__(self, attr: str, value) -> None:
        if attr in ("axis", "name") or isinstance(getattr(type(self), attr, None), property):
            object.__setattr__(self, attr, value)
        else:
            setattr(self.axis.guides[self.name], attr, value)

    # the axis gate's (read and set through the view)
    rejected = _gate_attribute("rejected")
    recent = _gate_attribute("recent")
    limits = _gate_attribute("limits")
    load_samples = _gate_attribute("load_samples")
    load_t_ns = _gate_attribute("load_t_ns")
    joint_base = _gate_attribute("joint_base")
    load_base = _gate_attribute("load_base")
    stream_gaps = _gate_attribute("stream_gaps")

    @property
    def load_n(self) -> float:
        """The latest accepted load of this guide [N] (its share of the axis load)."""
        return self.axis.guide_load(self.name, self.axis.gate.load_n)

    @load_n.setter
    def load_n(self, value: float) -> None:
        share = self.axis.shares[self.name]
        self.axis.gate.load_n = value if share == 1.0 else value / share

    def recent_rejected_share(self) -> tuple[float, str, str]:
        return self.axis.gate.recent_rejected_share()

    def report(self) -> dict[str, Any]:
        return self.axis.guide_report(self.name)

    def forecast(self, points: int = 60) -> dict[str, Any]:
        return self.axis.guide_forecast(self.name, points)

    def state(self) -> dict:
        return self.axis.guide_state(self.name)

    def restore(self, state: dict) -> None:
        self.axis.restore_guide(self.name, state)


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
    cuts = {"joint_states": j, "guide/load": ld, "guide/straightness": st, "guide/temperature": tp}
    messages = getattr(run, "rejected_messages", ())
    head_messages = tuple(m for m in messages if m[1] <= cuts[m[0]])
    tail_messages = tuple((s, i - cuts[s], r) for s, i, r in messages if i > cuts[s])
    head = dataclasses.replace(
        run, rejected_messages=head_messages, joint_t_ns=run.joint_t_ns[:j], joint_position_m=run.joint_position_m[:j],
        joint_velocity_m_s=vel[:j] if vel.size else vel, load_t_ns=run.load_t_ns[:ld], load_n=run.load_n[:ld],
        straightness_t_ns=run.straightness_t_ns[:st], straightness_m=run.straightness_m[:st],
        temperature_t_ns=run.temperature_t_ns[:tp], temperature_c=run.temperature_c[:tp])
    tail = dataclasses.replace(
        run, rejected_messages=tail_messages, joint_t_ns=run.joint_t_ns[j:], joint_position_m=run.joint_position_m[j:],
        joint_velocity_m_s=vel[j:] if vel.size else vel, load_t_ns=run.load_t_ns[ld:], load_n=run.load_n[ld:],
        straightness_t_ns=run.straightness_t_ns[st:], straightness_m=run.straightness_m[st:],
        temperature_t_ns=run.temperature_t_ns[tp:], temperature_c=run.temperature_c[tp:])
    return head, tail
