"""The input rules of the wear models: what a sample must be to count, written once.

Every consumer of a machine's inputs applies these rules, so the live node, the offline replay and the
discrepancy workflow see the same data:

- :class:`~guide_health.models.wear.precision.PrecisionMonitor`, sample by sample (live callbacks) and
  over whole arrays (``process_run``, vectorised);
- :class:`~guide_health.models.wear.feed.StampAlignedFeed`, on the arrival of a live message;
- :class:`~guide_health.analysis.discrepancy.duty.DutyCellAccumulator` (``guide-health diagnose``).

The rules, applied in this order (so a rejected sample has exactly one reason):

joint sample
    position and velocity finite (an absent velocity counts as finite); stamp strictly greater than the
    last accepted joint stamp.
load sample (guide load, force.z [N])
    finite; stamp strictly greater than the last accepted load stamp. The sign is physics, not bad
    input: force.z > 0 presses the carriage/slider onto the way, force.z < 0 is a reverse (lift-off) load.
    A four-row rolling guide carries it on its lower rows, rated with ``reverse_load_rating_factor``
    (:mod:`guide_health.models.rolling.rolling_guide`); a sliding guide carries it on its gibs/retainer
    strips, not on the main way, so the main-way wear uses :func:`main_way_load_n` = 0 for it (never
    the last positive load).
straightness measurement [m]
    finite; >= 0; stamp not before the last accepted measurement.
load at a joint sample
    the latest accepted load stamped at or before the joint sample; NaN (no load known: the distance
    counts, the wear does not) before the first.

A rejected sample changes nothing, so the time rules compare with the last *accepted* stamp; the
vectorised forms keep a sample whose stamp exceeds every earlier candidate's stamp, which is the same
(a rejected stamp never exceeds the running maximum). The live node's message-level reasons (a joint
missing from a JointState, undecodable messages, straightness without a time base) are named here too.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# --- reasons (the text the node logs and the reports count) ---------------------------------------
NON_FINITE_JOINT = "non-finite joint position/velocity"
JOINT_TIME_BACKWARDS = "joint_states time going backwards"
NON_FINITE_LOAD = "non-finite load"
LOAD_TIME_BACKWARDS = "load time going backwards"
NON_FINITE_STRAIGHTNESS = "non-finite straightness"
NEGATIVE_STRAIGHTNESS = "negative straightness"
STRAIGHTNESS_TIME_BACKWARDS = "straightness time going backwards"
# message level (live node)
MALFORMED_JOINT_STATES = "malformed joint_states message"
MALFORMED_LOAD = "malformed guide/load message"
EMPTY_JOINT_STATES = "empty joint_states arrays"
JOINT_POSITION_MISSING = "joint_states position shorter than name"
STRAIGHTNESS_WITHOUT_TIME_BASE = "straightness before any joint_states (no time base)"


def joint_missing(joint: str) -> str:
    """Reason for a JointState message that does not name the monitored joint."""
    return f"joint '{joint}' not in joint_states"


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


# --- one sample at a time (live) -------------------------------------------------------------------
def check_joint_sample(t_ns: int, position_m: float, velocity_m_s: float,
                       last_t_ns: int | None) -> str | None:
    """The rejection reason of an axis sample, None when it counts (``last_t_ns``: last accepted stamp)."""
    if not (math.isfinite(position_m) and math.isfinite(velocity_m_s)):
        return NON_FINITE_JOINT
    if last_t_ns is not None and t_ns <= last_t_ns:
        return JOINT_TIME_BACKWARDS
    return None


def check_load_sample(t_ns: int, load_n: float, last_t_ns: int | None) -> str | None:
    """The rejection reason of a guide-load sample [N], None when it counts."""
    if not math.isfinite(load_n):
        return NON_FINITE_LOAD
    if last_t_ns is not None and t_ns <= last_t_ns:
        return LOAD_TIME_BACKWARDS
    return None


def check_straightness_sample(t_ns: int, straightness_m: float, last_t_ns: int | None) -> str | None:
    """The rejection reason of a straightness measurement [m], None when it counts (equal stamps count)."""
    if not math.isfinite(straightness_m):
        return NON_FINITE_STRAIGHTNESS
    if straightness_m < 0:
        return NEGATIVE_STRAIGHTNESS
    if last_t_ns is not None and t_ns < last_t_ns:
        return STRAIGHTNESS_TIME_BACKWARDS
    return None


# --- whole arrays (offline, chunk by chunk) ---------------------------------------------------------
@dataclass(frozen=True)
class Acceptance:
    """Which samples of an array count, and how many were rejected for each reason."""

    accepted: np.ndarray          # bool, one per input sample
    rejected: dict                # {reason: count}, reasons with count > 0 in rule order


def after_last_accepted(t_ns: np.ndarray, candidate: np.ndarray, last_t_ns: int | None,
                        strict: bool = True) -> np.ndarray:
    """Mask of the candidates whose stamp is after (``strict``) or not before every earlier candidate's
    stamp and ``last_t_ns``: the time rule of :func:`check_joint_sample` etc. over an array."""
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


def _counts(*pairs: tuple[str, np.ndarray]) -> dict[str, int]:
    return {reason: int(mask.sum()) for reason, mask in pairs if mask.any()}


def accept_joint_samples(t_ns, position_m, velocity_m_s, last_t_ns: int | None) -> Acceptance:
    """:func:`check_joint_sample` over arrays; an empty velocity array means no velocities."""
    x = np.asarray(position_m, dtype=float)
    v = np.asarray(velocity_m_s, dtype=float)
    finite = np.isfinite(x)
    if v.size == x.size:
        finite &= np.isfinite(v)
    in_time = after_last_accepted(t_ns, finite, last_t_ns, strict=True)
    return Acceptance(in_time, _counts((NON_FINITE_JOINT, ~finite), (JOINT_TIME_BACKWARDS, finite & ~in_time)))


def accept_load_samples(t_ns, load_n, last_t_ns: int | None) -> Acceptance:
    """:func:`check_load_sample` over arrays."""
    w = np.asarray(load_n, dtype=float)
    finite = np.isfinite(w)
    in_time = after_last_accepted(t_ns, finite, last_t_ns, strict=True)
    return Acceptance(in_time, _counts((NON_FINITE_LOAD, ~finite), (LOAD_TIME_BACKWARDS, finite & ~in_time)))


def main_way_load_n(load_n):
    """The load the main way of a sliding guide bears [N]: force.z where >= 0, 0 under a reverse (lifting)
    load, which bears on the gibs/retainer strips, not on the main way (seed 000 models the main way only).
    NaN (no load known yet) stays NaN. Scalar in, float out; array in, array out."""
    if np.ndim(load_n) == 0:
        w = float(load_n)
        return w if not w < 0.0 else 0.0
    w = np.asarray(load_n, dtype=float)
    return np.where(w < 0.0, 0.0, w)


def accept_straightness_samples(t_ns, straightness_m, last_t_ns: int | None) -> Acceptance:
    """:func:`check_straightness_sample` over arrays."""
    a = np.asarray(straightness_m, dtype=float)
    finite = np.isfinite(a)
    negative = finite & (a < 0)
    valid = finite & ~negative
    in_time = after_last_accepted(t_ns, valid, last_t_ns, strict=False)
    return Acceptance(in_time, _counts((NON_FINITE_STRAIGHTNESS, ~finite), (NEGATIVE_STRAIGHTNESS, negative),
                                       (STRAIGHTNESS_TIME_BACKWARDS, valid & ~in_time)))


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


def accept_run(run, last_joint_t_ns: int | None, last_load_t_ns: int | None,
               last_load_n: float) -> AcceptedRun:
    """Apply the joint and load rules to a chunk, given the last accepted joint stamp and load carried
    from the samples before it, and align every accepted joint sample with its load."""
    jt = np.asarray(run.joint_t_ns, dtype=np.int64)
    joints = accept_joint_samples(jt, run.joint_position_m, run.joint_velocity_m_s, last_joint_t_ns)
    lt = np.asarray(run.load_t_ns, dtype=np.int64)
    loads = accept_load_samples(lt, run.load_n, last_load_t_ns)
    jt = jt[joints.accepted]
    lt = lt[loads.accepted]
    lw = np.asarray(run.load_n, dtype=float)[loads.accepted]
    return AcceptedRun(
        joint_t_ns=jt,
        joint_position_m=np.asarray(run.joint_position_m, dtype=float)[joints.accepted],
        load_at_joint_n=load_at_joint_samples(jt, lt, lw, last_load_t_ns, last_load_n),
        load_t_ns=lt,
        load_n=lw,
        rejected={**joints.rejected, **loads.rejected},
    )
