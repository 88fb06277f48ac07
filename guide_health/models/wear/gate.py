"""The input gate of one axis: every input rule (models/wear/input_rules.py) applied once per sample.

An axis has one position stream (its JointState joint), one load stream (force.z of its load sensor), one
straightness gauge and one temperature sensor; its guides (models/wear/precision.py, physics only) see the
samples the gate lets through. The gate holds what the rules need and what they count:

- the time bases of the joint and load streams (:class:`~guide_health.models.wear.input_rules.StampBase`);
- the rejections by reason (:class:`~guide_health.models.wear.input_rules.RejectionCounter`) and the recent
  window of each stream (``rejected_window_samples`` samples: None = accepted, or the reason), whose
  rejected share the judgement warns on;
- the stamp gaps of the accepted joint and load samples (:mod:`guide_health.models.wear.stream_gaps`);
- the latest accepted axis load [N] and its stamp, the count of accepted loads.

The load rule is applied to the load of the first guide (its share of the axis load, the verdict the axis
reports); every guide then carries its own share of the accepted load. A sample is judged in one place,
sample by sample (live) or over arrays (the batch and offline paths, vectorised, same result).
"""
from __future__ import annotations

import math
from collections import Counter, deque
from typing import Any

import numpy as np

from guide_health.models.wear.input_rules import (
    REASON_CODES,
    TEMPERATURE_IMPLAUSIBLE,
    Acceptance,
    AcceptedRun,
    InputLimits,
    RejectionCounter,
    StampBase,
    accept_joint_samples,
    accept_load_samples,
    accept_run,
    check_joint_sample,
    check_load_sample,
    check_straightness_sample,
    plausible_temperature,
)
from guide_health.models.wear.stream_gaps import StreamGaps

STREAMS = ("joint_states", "guide/load")     # the inputs whose recent rejected share the status judges


class InputGate:
    """The input rules of one axis (``params``: its frozen parameters, guide_health.params.typed.WearAxisParams);
    ``load_share``: the share of the axis load the load rule judges (the first guide's)."""

    def __init__(self, params: Any, load_share: float = 1.0):
        self.limits = InputLimits.from_params(params)
        self.load_share = float(load_share)
        self.joint_base = StampBase()         # time bases of the joint and load streams (input_rules)
        self.load_base = StampBase()
        self.rejected = RejectionCounter()    # by reason; the node counts its message-level reasons here too
        window = int(params.rejected_window_samples)
        self.recent = {name: deque(maxlen=window) for name in STREAMS}
        self.stream_gaps = StreamGaps()       # samples missing by stamp gaps (not persisted: a count of this run)
        self.load_n = math.nan                # latest accepted axis load [N]
        self.load_t_ns: int | None = None
        self.load_samples = 0                 # accepted load samples

    def judged_load_n(self, load_n):
        """The load the load rule judges [N]: the first guide's share of the axis load (scalar or array)."""
        return load_n if self.load_share == 1.0 else load_n * self.load_share

    # --- one sample (live) ---------------------------------------------------------------------------
    def accept_joint(self, t_ns: int, position_m: float, velocity_m_s: float = 0.0) -> str | None:
        """The joint rules of one axis sample (counted; the time base moves on when accepted); the reason."""
        reason, self.joint_base = check_joint_sample(t_ns, position_m, velocity_m_s, self.joint_base, self.limits)
        if reason is None:
            self.stream_gaps.joint.add(t_ns)
        return self.record("joint_states", reason)

    def check_load(self, t_ns: int, load_n: float) -> str | None:
        """The rejection reason :meth:`accept_load` would give (nothing counted or changed)."""
        return check_load_sample(t_ns, self.judged_load_n(load_n), self.load_base, self.limits)[0]

    def accept_load(self, t_ns: int, load_n: float) -> str | None:
        """The load rules of one axis load [N]; an accepted one becomes the latest load. The reason."""
        reason, self.load_base = check_load_sample(t_ns, self.judged_load_n(load_n), self.load_base, self.limits)
        if reason is not None:
            return self.record("guide/load", reason)
        self.record("guide/load", None)
        self.stream_gaps.load.add(t_ns)
        self.load_n = float(load_n)
        self.load_t_ns = int(t_ns)
        self.load_samples += 1
        return None

    def accept_straightness(self, t_ns: int, straightness_m: float, last_measurement_t_ns: int | None) -> str | None:
        """The straightness rules (``last_measurement_t_ns``: the stamp of the last applied measurement);
        a rejection is counted. The reason, or None."""
        reason = check_straightness_sample(t_ns, straightness_m, last_measurement_t_ns, self.limits)
        return None if reason is None else self.rejected.reject(reason)

    def accept_temperature(self, temperature_c: float) -> str | None:
        """An implausible guide/temperature reading is a counted rejection; the reason, or None."""
        return None if plausible_temperature(temperature_c) else self.rejected.reject(TEMPERATURE_IMPLAUSIBLE)

    def reject(self, reason: str) -> str:
        """Count a rejection that belongs to no stream (e.g. a straightness before any time base)."""
        return self.rejected.reject(reason)

    def record(self, stream: str, reason: str | None) -> str | None:
        """A sample of ``stream`` in its recent window, and its rejection counted; returns the reason. The
        node's message-level rejections (a JointState without the joint, ...) come this way too."""
        window = self.recent.get(stream)
        if window is not None:
            window.append(reason)
        return None if reason is None else self.rejected.reject(reason)

    # --- arrays (the live batch and the offline run, vectorised) ---------------------------------------
    def _record_many(self, stream: str, acceptance: Acceptance) -> None:
        self.rejected.count_all(acceptance.rejected)
        window = self.recent[stream]
        window.extend(REASON_CODES[c] for c in acceptance.codes[-window.maxlen:].tolist())

    def accept_joints(self, t_ns, position_m, velocity_m_s) -> Acceptance:
        """:meth:`accept_joint` of every sample in turn (vectorised)."""
        acc = accept_joint_samples(t_ns, position_m, velocity_m_s, self.joint_base, self.limits)
        self.joint_base = acc.base
        self._record_many("joint_states", acc)
        self.stream_gaps.joint.add_many(np.asarray(t_ns, dtype=np.int64)[acc.accepted])
        return acc

    def accept_loads(self, t_ns, load_n) -> tuple[Acceptance, float]:
        """:meth:`accept_load` of every axis load in turn (vectorised); (acceptance, the latest load before them)."""
        t_ns = np.asarray(t_ns, dtype=np.int64)
        load_n = np.asarray(load_n, dtype=float)
        before = self.load_n
        acc = accept_load_samples(t_ns, self.judged_load_n(load_n), self.load_base, self.limits)
        self.load_base = acc.base
        self._record_many("guide/load", acc)
        ok = np.flatnonzero(acc.accepted)
        if ok.size:
            self.stream_gaps.load.add_many(t_ns[ok])
            self.load_n, self.load_t_ns = float(load_n[ok[-1]]), int(t_ns[ok[-1]])
            self.load_samples += int(ok.size)
        return acc, before

    def accept_run(self, run) -> AcceptedRun:
        """The joint and load rules over a :class:`~guide_health.runs.MachineRun` chunk, each accepted joint
        sample with the axis load in force at its stamp (input_rules.accept_run)."""
        accepted = accept_run(run, self.joint_base, self.load_base, self.load_n, self.limits, self.load_share)
        self.rejected.count_all(accepted.rejected)
        self.joint_base, self.load_base = accepted.joints.base, accepted.loads.base
        messages = getattr(run, "rejected_messages", ())
        for stream, acceptance in (("joint_states", accepted.joints), ("guide/load", accepted.loads)):
            self._extend_window(stream, acceptance.codes, [(i, r) for s, i, r in messages if s == stream])
        for _, _, reason in messages:        # the message rejections of the bag reader, counted
            self.rejected.reject(reason)
        self.stream_gaps.joint.add_many(accepted.joint_t_ns)
        self.stream_gaps.load.add_many(accepted.load_t_ns)
        if accepted.load_t_ns.size:
            self.load_n, self.load_t_ns = float(accepted.load_n[-1]), int(accepted.load_t_ns[-1])
            self.load_samples += int(accepted.load_t_ns.size)
        return accepted

    def _extend_window(self, stream: str, codes: np.ndarray, messages: list[tuple[int, str]]) -> None:
        """The recent window of ``stream`` after samples of rule codes ``codes`` and the rejected messages
        ``[(samples before it, reason), ...]`` at their places (what the live node's callbacks record)."""
        window = self.recent[stream]
        if not messages:
            window.extend(REASON_CODES[c] for c in codes[-window.maxlen:].tolist())
            return
        reasons = [REASON_CODES[c] for c in codes.tolist()]
        for index, reason in reversed(messages):
            reasons.insert(index, reason)
        window.extend(reasons[-window.maxlen:])

    def accept_temperatures(self, t_ns, temperature_c) -> tuple[np.ndarray, np.ndarray]:
        """The plausible readings of arrays (the others counted as rejected)."""
        t = np.asarray(t_ns, dtype=np.int64)
        c = np.asarray(temperature_c, dtype=float)
        plausible = plausible_temperature(c)
        self.rejected.count(TEMPERATURE_IMPLAUSIBLE, int(c.size - plausible.sum()))
        return t[plausible], c[plausible]

    # --- what the judgement and the status take ------------------------------------------------------
    def recent_rejected_share(self) -> tuple[float, str, str]:
        """(share, stream, dominant reason) of the input stream with the largest share of rejected samples
        among its last rejected_window_samples; (0, '', '') before any sample."""
        best = (0.0, "", "")
        for stream, window in self.recent.items():
            reasons = Counter(r for r in window if r is not None)
            if window and reasons:
                share = sum(reasons.values()) / len(window)
                if share > best[0]:
                    best = (share, stream, reasons.most_common(1)[0][0])
        return best

    def set_window(self, samples: int) -> None:
        """A new recent-window length (the windows keep their newest entries)."""
        self.recent = {name: deque(recent, maxlen=int(samples)) for name, recent in self.recent.items()}

    # --- persistence: the gate's part of a guide's saved state ------------------------------------------
    def restore(self, load_n: float, load_t_ns: int | None, load_samples: int, joint_t_ns: int | None) -> None:
        """The saved latest axis load, its stamp and count, and the time bases they and the last integrated
        joint sample (``joint_t_ns``) set."""
        self.load_n = load_n
        self.load_t_ns = load_t_ns
        self.load_samples = int(load_samples)
        self.joint_base = StampBase(joint_t_ns)
        self.load_base = StampBase(load_t_ns)
