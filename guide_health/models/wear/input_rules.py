"""The input rules of the wear models: what a sample must be to count, written once.

Every consumer of a machine's inputs applies these rules, so the live node, the offline replay and the
discrepancy workflow see the same data:

- :class:`~guide_health.models.wear.gate.InputGate`, the one gate of an axis, sample by sample (live
  callbacks, through :class:`~guide_health.models.wear.feed.StampAlignedFeed` on the arrival of a live
  message) and over whole arrays (the live batch and ``process_run``, vectorised);
- :class:`~guide_health.analysis.discrepancy.duty.DutyCellAccumulator` (``guide-health diagnose``).

The rules, applied in this order (so a rejected sample has exactly one reason); the limits are
:class:`InputLimits`, made from the wear_monitor parameters (docs/interfaces.md, "Input rules"):

joint sample
    position and velocity finite (an absent velocity counts as finite); position inside the rail travel
    ``[rail_start_m - travel_margin_m, rail_start_m + rail_length_m + travel_margin_m]``; stamp in time
    (below).
load sample (guide load, force.z [N])
    finite; |force.z| <= the plausible maximum (``load_max_n``; rolling guides with a load rating C also
    ``load_max_rating_multiple`` x carriages x C); stamp in time. The sign is physics, not bad
    input: force.z > 0 presses the carriage/slider onto the way, force.z < 0 is a reverse (lift-off) load.
    A four-row rolling guide carries it on its lower rows, rated with ``reverse_load_rating_factor``
    (:mod:`guide_health.models.rolling.rolling_guide`); a sliding guide carries it on its gibs/retainer
    strips, not on the main way, so the main-way wear uses :func:`main_way_load_n` = 0 for it (never
    the last positive load).
straightness measurement [m]
    finite; >= 0; <= ``straightness_max_multiple`` x ``straightness_limit_m``; stamp not before the last
    accepted measurement, and a measurement with the stamp of one already applied is not applied again
    (a measurement is identified by its stamp: a resumed node or a replayed bag never counts it twice).
stamp in time (joint and load, each stream its own time base)
    strictly after the last accepted stamp of the stream and at most ``stamp_horizon_s`` after it. A
    sample that jumps further is held back as a candidate for a new time base and rejected, unless it is
    the ``stamp_rebase_samples``-th of consecutive candidates that agree (each after the previous one and
    within the horizon of it): then it is accepted and the stream continues from it (a genuine restart
    after a long pause). An accepted sample in time forgets the candidates, so one outlier, however far in
    the future, never moves the time base; the first sample of a stream sets it.
load at a joint sample
    the latest accepted load stamped at or before the joint sample; NaN (no load known: the distance
    counts, the wear does not) before the first.

A rejected sample changes nothing but the count of its reason and the candidates of its stream (not part
of the saved state). The vectorised forms give the same result as the scalar ones sample by sample (a fast
path when no stamp jumps beyond the horizon, the scalar rule otherwise). The message-level reasons (a
joint missing from a JointState or without a position, empty arrays, undecodable messages, straightness
without a time base, an invalid header stamp) are named here too, with :func:`joint_state_reason`, the one
rule for a decoded JointState: the live node and the bag reader (io/bag/message_judge.py) give the same
bytes the same reason. ``INPUT_OF_REASON``: the input whose samples each reason counts (a report's shares).
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from guide_health.models.wear.effects.registry import GAUGE_TEMPERATURE

# --- reasons (the text the node logs and the reports count) ---------------------------------------
NON_FINITE_JOINT = "non-finite joint position/velocity"
POSITION_OUT_OF_TRAVEL = "joint position outside the rail travel"
JOINT_TIME_BACKWARDS = "joint_states time going backwards"
JOINT_STAMP_JUMP = "joint_states stamp jump beyond the horizon"
NON_FINITE_LOAD = "non-finite load"
LOAD_ABOVE_MAX = "load above the plausible maximum"
LOAD_TIME_BACKWARDS = "load time going backwards"
LOAD_STAMP_JUMP = "load stamp jump beyond the horizon"
NON_FINITE_STRAIGHTNESS = "non-finite straightness"
NEGATIVE_STRAIGHTNESS = "negative straightness"
STRAIGHTNESS_ABOVE_MAX = "straightness above the plausible maximum"
STRAIGHTNESS_TIME_BACKWARDS = "straightness time going backwards"
MEASUREMENT_ALREADY_APPLIED = "measurement already applied"
# message level (live node)
MALFORMED_JOINT_STATES = "malformed joint_states message"
MALFORMED_LOAD = "malformed guide/load message"
MALFORMED_STRAIGHTNESS = "malformed guide/straightness message"
MALFORMED_TEMPERATURE = "malformed guide/temperature message"
EMPTY_JOINT_STATES = "empty joint_states arrays"
JOINT_POSITION_MISSING = "joint_states position shorter than name"
STRAIGHTNESS_WITHOUT_TIME_BASE = "straightness before any joint_states (no time base)"
STRAIGHTNESS_WITHOUT_TEMPERATURE = f"straightness before any guide/temperature ({GAUGE_TEMPERATURE.id} correction)"
TEMPERATURE_IMPLAUSIBLE = "guide temperature non-finite or outside -100..500 degC"
INVALID_STAMP = "invalid header stamp (nanosec >= 1e9)"
# maintenance events (models/wear/maintenance.py): an event not applied, counted under
# "rejected: maintenance event <reason>" (the service's reply and the log add the details)
MAINTENANCE_UNKNOWN_KIND = "maintenance event unknown kind"
MAINTENANCE_UNKNOWN_GUIDE = "maintenance event unknown guide"
MAINTENANCE_STRAIGHTNESS_NOT_A_NUMBER = "maintenance event straightness not a number"
MAINTENANCE_STRAIGHTNESS_IMPLAUSIBLE = "maintenance event straightness not plausible"
MAINTENANCE_STRAIGHTNESS_NOT_BELOW_LIMIT = "maintenance event straightness not below the limit"
MAINTENANCE_MEASURE_WITHOUT_VALUE = "maintenance event measure without a value"
MAINTENANCE_MALFORMED = "maintenance event malformed"
MAINTENANCE_REPEATED = "maintenance event repeated within maintenance_repeat_window_s"

# sample reasons by code (0 = accepted): the per-sample form of the vectorised rules
REASON_CODES = (None, NON_FINITE_JOINT, POSITION_OUT_OF_TRAVEL, JOINT_TIME_BACKWARDS, JOINT_STAMP_JUMP,
                NON_FINITE_LOAD, LOAD_ABOVE_MAX, LOAD_TIME_BACKWARDS, LOAD_STAMP_JUMP,
                NON_FINITE_STRAIGHTNESS, NEGATIVE_STRAIGHTNESS, STRAIGHTNESS_ABOVE_MAX,
                STRAIGHTNESS_TIME_BACKWARDS, MEASUREMENT_ALREADY_APPLIED)
CODE_OF_REASON = {reason: code for code, reason in enumerate(REASON_CODES)}
MESSAGE_REASONS = (MALFORMED_JOINT_STATES, MALFORMED_LOAD, EMPTY_JOINT_STATES, JOINT_POSITION_MISSING,
                   STRAIGHTNESS_WITHOUT_TIME_BASE, INVALID_STAMP, STRAIGHTNESS_WITHOUT_TEMPERATURE,
                   TEMPERATURE_IMPLAUSIBLE, MALFORMED_STRAIGHTNESS, MALFORMED_TEMPERATURE)
MAINTENANCE_REASONS = (MAINTENANCE_UNKNOWN_KIND, MAINTENANCE_UNKNOWN_GUIDE, MAINTENANCE_STRAIGHTNESS_NOT_A_NUMBER,
                       MAINTENANCE_STRAIGHTNESS_IMPLAUSIBLE, MAINTENANCE_STRAIGHTNESS_NOT_BELOW_LIMIT,
                       MAINTENANCE_MEASURE_WITHOUT_VALUE, MAINTENANCE_MALFORMED, MAINTENANCE_REPEATED)
#: the input each reason's samples come from (the denominator of its share in a report); a reason of several
#: inputs (an invalid header stamp) names them all
JOINT_INPUT, LOAD_INPUT = "joint_states", "guide/load"
STRAIGHTNESS_INPUT, TEMPERATURE_INPUT = "guide/straightness", "guide/temperature"
INPUT_OF_REASON = {
    **dict.fromkeys((NON_FINITE_JOINT, POSITION_OUT_OF_TRAVEL, JOINT_TIME_BACKWARDS, JOINT_STAMP_JUMP,
                     MALFORMED_JOINT_STATES, EMPTY_JOINT_STATES, JOINT_POSITION_MISSING), (JOINT_INPUT,)),
    **dict.fromkeys((NON_FINITE_LOAD, LOAD_ABOVE_MAX, LOAD_TIME_BACKWARDS, LOAD_STAMP_JUMP, MALFORMED_LOAD),
                    (LOAD_INPUT,)),
    **dict.fromkeys((NON_FINITE_STRAIGHTNESS, NEGATIVE_STRAIGHTNESS, STRAIGHTNESS_ABOVE_MAX,
                     STRAIGHTNESS_TIME_BACKWARDS, MEASUREMENT_ALREADY_APPLIED,
                     STRAIGHTNESS_WITHOUT_TIME_BASE, STRAIGHTNESS_WITHOUT_TEMPERATURE, MALFORMED_STRAIGHTNESS),
                    (STRAIGHTNESS_INPUT,)),
    **dict.fromkeys((TEMPERATURE_IMPLAUSIBLE, MALFORMED_TEMPERATURE), (TEMPERATURE_INPUT,)),
    INVALID_STAMP: (JOINT_INPUT, LOAD_INPUT, TEMPERATURE_INPUT),
}
NS_PER_S = 1_000_000_000


def joint_missing(joint: str) -> str:
    """Reason for a JointState message that does not name the monitored joint."""
    return f"joint '{joint}' not in joint_states"


def input_of_reason(reason: str) -> tuple[str, ...]:
    """The inputs (JOINT_INPUT, ...) whose samples a rejection reason counts; () for an unknown reason."""
    if reason.startswith("joint '") and reason.endswith("' not in joint_states"):
        return (JOINT_INPUT,)
    return INPUT_OF_REASON.get(reason, ())


def joint_state_reason(names, position_count: int, joint: str) -> tuple[str | None, int]:
    """(rejection reason or None, index of ``joint``) of a decoded JointState with joint ``names`` and
    ``position_count`` positions, checked in this order: no names or no positions, the joint not named, no
    position at the joint's index. The live node and the bag reader take one rule."""
    names = list(names)
    if not names or position_count == 0:
        return EMPTY_JOINT_STATES, -1
    try:
        index = names.index(joint)
    except ValueError:
        return joint_missing(joint), -1
    if index >= position_count:
        return JOINT_POSITION_MISSING, index
    return None, index


def rejected_key(reason: str) -> str:
    """The status key of the count of one rejection reason."""
    return f"rejected: {reason}"


def rejected_keys(joint: str) -> tuple[str, ...]:
    """The status keys of every rejection reason a wear_monitor of ``joint`` can count."""
    return tuple(rejected_key(r) for r in REASON_CODES[1:] + MESSAGE_REASONS + MAINTENANCE_REASONS
                 + (joint_missing(joint),))


def header_stamp_ns(sec: int, nanosec: int) -> int | None:
    """A header stamp in ns, None when it is not a valid builtin_interfaces/Time (nanosec >= 1e9)."""
    if not 0 <= nanosec < NS_PER_S:
        return None
    return int(sec) * NS_PER_S + int(nanosec)


class RejectionCounter(dict):
    """Rejected samples by reason, ``{reason: count}``; a reason that never occurred is absent."""

    def reject(self, reason: str) -> str:
        """Count one rejected sample; returns the reason (for the caller's log)."""
        self[reason] = self.get(reason, 0) + 1
        return reason

    def count(self, reason: str, n: int) -> None:
        """Count ``n`` rejected samples of one reason (n = 0 adds nothing)."""
        if n:
            self[reason] = self.get(reason, 0) + int(n)

    def count_all(self, counts: dict[str, int]) -> None:
        for reason, n in counts.items():
            self.count(reason, n)

    @property
    def total(self) -> int:
        return int(sum(self.values()))


@dataclass(frozen=True)
class InputLimits:
    """The plausibility limits of the inputs (SI units); the defaults check nothing but finiteness,
    sign and time order. ``stamp_horizon_ns`` None: no horizon."""

    position_min_m: float = -math.inf
    position_max_m: float = math.inf
    load_max_n: float = math.inf
    straightness_max_m: float = math.inf
    stamp_horizon_ns: int | None = None
    rebase_samples: int = 1

    @classmethod
    def from_params(cls, p: Any) -> InputLimits:
        """The limits of a guide's frozen wear_monitor parameters (guide_health.params.typed.WearAxisParams)."""
        margin = p.travel_margin_m
        load_max = p.load_max_n
        rating = p.dynamic_load_rating_n * p.carriages
        if p.guide_type == "rolling" and rating > 0 and p.load_max_rating_multiple > 0:
            load_max = min(load_max, p.load_max_rating_multiple * rating)
        return cls(position_min_m=p.rail_start_m - margin,
                   position_max_m=p.rail_start_m + p.rail_length_m + margin,
                   load_max_n=load_max,
                   straightness_max_m=p.straightness_max_multiple * p.straightness_limit_m,
                   stamp_horizon_ns=int(round(p.stamp_horizon_s * NS_PER_S)),
                   rebase_samples=int(p.stamp_rebase_samples))


NO_LIMITS = InputLimits()


@dataclass(frozen=True)
class StampBase:
    """The time base of one input stream: the last accepted stamp (None before the first) and the stamps
    of the consecutive candidates for a new time base seen since (module docstring)."""

    last_t_ns: int | None = None
    candidates: tuple = ()

    @classmethod
    def of(cls, base) -> StampBase:
        """A StampBase from a StampBase or a last accepted stamp (int or None)."""
        return base if isinstance(base, StampBase) else cls(None if base is None else int(base))


# stamp verdicts
_IN_TIME, _EARLIER, _EQUAL, _JUMP = range(4)


def _stamp_verdict(t_ns: int, base: StampBase, limits: InputLimits) -> tuple[int, StampBase]:
    """(verdict, the base after the sample) of a sample with valid values."""
    last = base.last_t_ns
    if last is None:
        return _IN_TIME, StampBase(int(t_ns))
    if t_ns < last:
        return _EARLIER, base
    if t_ns == last:
        return _EQUAL, base
    horizon = limits.stamp_horizon_ns
    if horizon is None or t_ns - last <= horizon:
        return _IN_TIME, StampBase(int(t_ns))
    run = base.candidates
    agrees = run and run[-1] < t_ns <= run[-1] + horizon
    run = (run + (int(t_ns),)) if agrees else (int(t_ns),)
    if len(run) >= limits.rebase_samples:
        return _IN_TIME, StampBase(int(t_ns))
    return _JUMP, StampBase(last, run)


# --- one sample at a time (live) -------------------------------------------------------------------
def check_joint_sample(t_ns: int, position_m: float, velocity_m_s: float, last_t_ns,
                       limits: InputLimits = NO_LIMITS) -> tuple[str | None, StampBase]:
    """(rejection reason or None when it counts, the stream's time base after it) of an axis sample;
    ``last_t_ns``: the stream's :class:`StampBase` or its last accepted stamp."""
    base = StampBase.of(last_t_ns)
    if not (math.isfinite(position_m) and math.isfinite(velocity_m_s)):
        return NON_FINITE_JOINT, base
    if not limits.position_min_m <= position_m <= limits.position_max_m:
        return POSITION_OUT_OF_TRAVEL, base
    verdict, after = _stamp_verdict(t_ns, base, limits)
    return (None, JOINT_TIME_BACKWARDS, JOINT_TIME_BACKWARDS, JOINT_STAMP_JUMP)[verdict], after


def check_load_sample(t_ns: int, load_n: float, last_t_ns,
                      limits: InputLimits = NO_LIMITS) -> tuple[str | None, StampBase]:
    """(rejection reason or None, time base after it) of a guide-load sample [N]."""
    base = StampBase.of(last_t_ns)
    if not math.isfinite(load_n):
        return NON_FINITE_LOAD, base
    if abs(load_n) > limits.load_max_n:
        return LOAD_ABOVE_MAX, base
    verdict, after = _stamp_verdict(t_ns, base, limits)
    return (None, LOAD_TIME_BACKWARDS, LOAD_TIME_BACKWARDS, LOAD_STAMP_JUMP)[verdict], after


def check_straightness_sample(t_ns: int, straightness_m: float, last_t_ns: int | None,
                              limits: InputLimits = NO_LIMITS) -> str | None:
    """The rejection reason of a straightness measurement [m], None when it counts (``last_t_ns``: the
    stamp of the last applied measurement)."""
    if not math.isfinite(straightness_m):
        return NON_FINITE_STRAIGHTNESS
    if straightness_m < 0:
        return NEGATIVE_STRAIGHTNESS
    if straightness_m > limits.straightness_max_m:
        return STRAIGHTNESS_ABOVE_MAX
    if last_t_ns is not None and t_ns < last_t_ns:
        return STRAIGHTNESS_TIME_BACKWARDS
    if last_t_ns is not None and t_ns == last_t_ns:
        return MEASUREMENT_ALREADY_APPLIED
    return None


#: a guide/temperature reading outside this [degC] is a sensor fault (a machine-tool guide with oil: -20..80)
TEMPERATURE_RANGE_C = (-100.0, 500.0)


def plausible_temperature(temperature_c):
    """True where a guide/temperature reading [degC] counts (finite, inside TEMPERATURE_RANGE_C); scalar or
    array alike."""
    t = np.asarray(temperature_c, dtype=float)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(t) & (t >= TEMPERATURE_RANGE_C[0]) & (t <= TEMPERATURE_RANGE_C[1])
    return bool(ok) if ok.ndim == 0 else ok


def reading_in_force_index(reading_stamps, at):
    """Index of the reading in force at a stamp: the last one stamped at or before it (zero-order hold), -1
    before the first; ``reading_stamps`` sorted. The one rule for which guide/temperature reading corrects a
    straightness measurement (registry.GAUGE_TEMPERATURE), live and in diagnose. A scalar ``at`` gives an int (bisect on
    the kept list: the live path), an array an array (searchsorted: the same rule, vectorised)."""
    if np.ndim(at) == 0:
        return bisect.bisect_right(reading_stamps, at) - 1
    return np.searchsorted(np.asarray(reading_stamps), np.asarray(at), side="right") - 1


# --- whole arrays (offline, chunk by chunk) ---------------------------------------------------------
@dataclass(frozen=True)
class Acceptance:
    """Which samples of an array count, why the others do not, and the stream's time base after them."""

    accepted: np.ndarray          # bool, one per input sample
    rejected: dict                # {reason: count}, reasons with count > 0 in rule order
    codes: np.ndarray             # int8 per sample: index into REASON_CODES (0 = accepted)
    base: StampBase | None = None


def after_last_accepted(t_ns: np.ndarray, candidate: np.ndarray, last_t_ns: int | None,
                        strict: bool = True) -> np.ndarray:
    """Mask of the candidates whose stamp is after (``strict``) or not before every earlier candidate's
    stamp and ``last_t_ns``: the time rule without a horizon over an array."""
    t = np.asarray(t_ns, dtype=np.int64)
    keep = np.zeros(t.size, dtype=bool)
    index = np.flatnonzero(candidate)
    if index.size == 0:
        return keep
    tc = t[index]
    previous = np.empty_like(tc)
    previous[1:] = np.maximum.accumulate(tc)[:-1]
    if last_t_ns is None:
        previous[0] = tc[0]                     # the first candidate has nothing before it
    else:
        previous[0] = last_t_ns
        np.maximum(previous, last_t_ns, out=previous)
    in_time = tc > previous if strict else tc >= previous
    if last_t_ns is None:
        in_time[0] = True
    keep[index] = in_time
    return keep


def _stamps_in_time(t_ns: np.ndarray, valid: np.ndarray, base: StampBase,
                    limits: InputLimits) -> tuple[np.ndarray, np.ndarray, StampBase]:
    """(accepted, jumped) masks of the valid samples and the base after them: :func:`_stamp_verdict`
    sample by sample, vectorised when no accepted stamp would jump beyond the horizon."""
    t = np.asarray(t_ns, dtype=np.int64)
    keep = after_last_accepted(t, valid, base.last_t_ns, strict=True)
    kept = t[keep]
    horizon = limits.stamp_horizon_ns
    if horizon is None or kept.size == 0 or base.last_t_ns is None and kept.size == 1:
        fast = True
    else:
        previous = kept[:-1] if base.last_t_ns is None else np.concatenate(([base.last_t_ns], kept[:-1]))
        steps = (kept[1:] if base.last_t_ns is None else kept) - previous
        fast = not np.any(steps > horizon)
    if fast:
        after = StampBase(int(kept[-1])) if kept.size else base
        return keep, np.zeros(t.size, dtype=bool), after
    keep = np.zeros(t.size, dtype=bool)
    jumped = np.zeros(t.size, dtype=bool)
    for i in np.flatnonzero(valid).tolist():
        verdict, base = _stamp_verdict(int(t[i]), base, limits)
        keep[i] = verdict == _IN_TIME
        jumped[i] = verdict == _JUMP
    return keep, jumped, base


def _acceptance(size: int, accepted: np.ndarray, base: StampBase | None,
                *pairs: tuple[str, np.ndarray]) -> Acceptance:
    codes = np.zeros(size, dtype=np.int8)
    counts = {}
    for reason, mask in pairs:
        if mask.any():
            codes[mask] = CODE_OF_REASON[reason]
            counts[reason] = int(mask.sum())
    return Acceptance(accepted, counts, codes, base)


def accept_joint_samples(t_ns, position_m, velocity_m_s, last_t_ns,
                         limits: InputLimits = NO_LIMITS) -> Acceptance:
    """:func:`check_joint_sample` over arrays; an empty velocity array means no velocities."""
    x = np.asarray(position_m, dtype=float)
    v = np.asarray(velocity_m_s, dtype=float)
    finite = np.isfinite(x)
    if v.size == x.size:
        finite &= np.isfinite(v)
    outside = finite & ~((x >= limits.position_min_m) & (x <= limits.position_max_m))
    valid = finite & ~outside
    in_time, jumped, base = _stamps_in_time(t_ns, valid, StampBase.of(last_t_ns), limits)
    return _acceptance(x.size, in_time, base, (NON_FINITE_JOINT, ~finite), (POSITION_OUT_OF_TRAVEL, outside),
                       (JOINT_TIME_BACKWARDS, valid & ~in_time & ~jumped), (JOINT_STAMP_JUMP, jumped))


def accept_load_samples(t_ns, load_n, last_t_ns, limits: InputLimits = NO_LIMITS) -> Acceptance:
    """:func:`check_load_sample` over arrays."""
    w = np.asarray(load_n, dtype=float)
    finite = np.isfinite(w)
    above = finite & (np.abs(w) > limits.load_max_n)
    valid = finite & ~above
    in_time, jumped, base = _stamps_in_time(t_ns, valid, StampBase.of(last_t_ns), limits)
    return _acceptance(w.size, in_time, base, (NON_FINITE_LOAD, ~finite),
                       (LOAD_ABOVE_MAX, above), (LOAD_TIME_BACKWARDS, valid & ~in_time & ~jumped),
                       (LOAD_STAMP_JUMP, jumped))


def main_way_load_n(load_n):
    """The load the main way of a sliding guide bears [N]: force.z where >= 0, 0 under a reverse (lifting)
    load, which bears on the gibs/retainer strips, not on the main way (seed 000 models the main way only).
    NaN (no load known yet) stays NaN. Scalar in, float out; array in, array out."""
    if np.ndim(load_n) == 0:
        w = float(load_n)
        return w if not w < 0.0 else 0.0
    w = np.asarray(load_n, dtype=float)
    return np.where(w < 0.0, 0.0, w)


def accept_straightness_samples(t_ns, straightness_m, last_t_ns: int | None,
                                limits: InputLimits = NO_LIMITS) -> Acceptance:
    """:func:`check_straightness_sample` over arrays."""
    t = np.asarray(t_ns, dtype=np.int64)
    a = np.asarray(straightness_m, dtype=float)
    finite = np.isfinite(a)
    negative = finite & (a < 0)
    above = finite & (a > limits.straightness_max_m)
    valid = finite & ~negative & ~above
    in_time = after_last_accepted(t, valid, last_t_ns, strict=True)
    not_before = after_last_accepted(t, valid, last_t_ns, strict=False)
    return _acceptance(a.size, in_time, None, (NON_FINITE_STRAIGHTNESS, ~finite),
                       (NEGATIVE_STRAIGHTNESS, negative), (STRAIGHTNESS_ABOVE_MAX, above),
                       (STRAIGHTNESS_TIME_BACKWARDS, valid & ~not_before),
                       (MEASUREMENT_ALREADY_APPLIED, not_before & ~in_time))


def load_at_joint_samples(joint_t_ns: np.ndarray, load_t_ns: np.ndarray, load_n: np.ndarray,
                          prior_load_t_ns: int | None = None, prior_load_n: float = math.nan) -> np.ndarray:
    """The latest accepted load stamped at or before each joint sample [N] (NaN before the first).

    ``load_t_ns``/``load_n`` are accepted loads (stamps strictly increasing); ``prior_load_*`` is the load
    accepted before them (carried over from an earlier chunk), None when there is none.
    """
    lt = np.asarray(load_t_ns, dtype=np.int64)
    lw = np.asarray(load_n, dtype=float)
    if prior_load_t_ns is not None:
        lt = np.concatenate(([prior_load_t_ns], lt))
        lw = np.concatenate(([prior_load_n], lw))
    idx = np.searchsorted(lt, joint_t_ns, side="right") - 1
    return np.where(idx >= 0, lw[np.clip(idx, 0, None)] if lw.size else np.nan, np.nan)


@dataclass(frozen=True)
class AcceptedRun:
    """The axis and load samples of one :class:`~guide_health.runs.MachineRun` chunk that count."""

    joint_t_ns: np.ndarray
    joint_position_m: np.ndarray
    load_at_joint_n: np.ndarray       # the load each accepted joint sample is integrated with
    load_t_ns: np.ndarray             # accepted loads of the chunk
    load_n: np.ndarray
    rejected: dict                    # {reason: count}: joint reasons, then load reasons
    joints: Acceptance                # per-sample codes and the time bases after the chunk
    loads: Acceptance


def accept_run(run, last_joint_t_ns, last_load_t_ns, last_load_n: float,
               limits: InputLimits = NO_LIMITS, load_share: float = 1.0) -> AcceptedRun:
    """Apply the joint and load rules to a chunk, given the time bases (:class:`StampBase` or last
    accepted stamps) and the load carried from the samples before it, and align every accepted joint
    sample with its load. ``load_share``: the load rule judges that share of each load (an axis judges
    its first guide's share); the loads returned are the run's own."""
    jt = np.asarray(run.joint_t_ns, dtype=np.int64)
    joints = accept_joint_samples(jt, run.joint_position_m, run.joint_velocity_m_s, last_joint_t_ns, limits)
    lt = np.asarray(run.load_t_ns, dtype=np.int64)
    judged = run.load_n if load_share == 1.0 else np.asarray(run.load_n, dtype=float) * load_share
    loads = accept_load_samples(lt, judged, last_load_t_ns, limits)
    jt = jt[joints.accepted]
    lt = lt[loads.accepted]
    lw = np.asarray(run.load_n, dtype=float)[loads.accepted]
    prior_load_t = StampBase.of(last_load_t_ns).last_t_ns
    return AcceptedRun(
        joint_t_ns=jt,
        joint_position_m=np.asarray(run.joint_position_m, dtype=float)[joints.accepted],
        load_at_joint_n=load_at_joint_samples(jt, lt, lw, prior_load_t, last_load_n),
        load_t_ns=lt,
        load_n=lw,
        rejected={**joints.rejected, **loads.rejected},
        joints=joints,
        loads=loads,
    )
