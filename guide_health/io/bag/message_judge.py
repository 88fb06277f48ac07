"""Why a bag message gives no sample: the rejection reason of every message the chunk decoder did not keep.

The live node counts a message it cannot use under a reason of :mod:`guide_health.models.wear.input_rules`
(a malformed message, a JointState without the monitored joint or its position, an invalid header stamp);
the bag reader gives the same reason for the same bytes, so replay and diagnose count what the node counts:

- not decodable as its type (the decoder's fallback, rosbags' deserialiser with trailing bytes allowed,
  refuses it; an empty or truncated message): ``malformed <topic> message``;
- a JointState that decodes but has no sample of the joint: :func:`~guide_health.models.wear.input_rules.
  joint_state_reason`, the rule the live node applies to a deserialised JointState;
- a stamped message whose header nanosec is >= 1e9: ``invalid header stamp``, and it is not kept.
"""
from __future__ import annotations

import numpy as np

from guide_health.models.wear.input_rules import (
    INVALID_STAMP,
    MALFORMED_JOINT_STATES,
    MALFORMED_LOAD,
    MALFORMED_STRAIGHTNESS,
    MALFORMED_TEMPERATURE,
    NS_PER_S,
    joint_state_reason,
)

from .cdr import DecodedChunk
from .interfaces import FLOAT64, JOINT_STATE, TEMPERATURE, WRENCH_STAMPED
from .typestore import deserialize

MALFORMED_REASON_OF_TYPE = {JOINT_STATE: MALFORMED_JOINT_STATES, WRENCH_STAMPED: MALFORMED_LOAD,
                            FLOAT64: MALFORMED_STRAIGHTNESS, TEMPERATURE: MALFORMED_TEMPERATURE}


class MessageJudge:
    """The reasons of one topic's messages (type ``msgtype``; a JointState judged for ``joint``)."""

    def __init__(self, msgtype: str, joint: str):
        self.msgtype = msgtype
        self.joint = joint
        self.malformed = MALFORMED_REASON_OF_TYPE[msgtype]

    def missing_reason(self, raw: bytes) -> str:
        """The reason of a message the decoder found valid but without the wanted item (a JointState)."""
        try:
            msg = deserialize(raw, self.msgtype)
        except Exception:  # noqa: BLE001 - any decoding failure is a malformed message
            return self.malformed
        reason, _ = joint_state_reason(msg.name, len(msg.position), self.joint)
        return reason or self.malformed

    def judge(self, dec: DecodedChunk, raw_of) -> tuple[DecodedChunk, list[tuple[int, str]]]:
        """(the chunk without the messages of an invalid stamp, [(kept messages before it, reason), ...] of
        every message not kept, in chunk order); ``raw_of(i)``: the bytes of message i of the chunk."""
        status = dec.status
        reasons = {}
        for i in np.flatnonzero(status != 0).tolist():
            reasons[i] = self.malformed if status[i] == 2 else self.missing_reason(raw_of(i))
        if "nsec" in dec.values:
            invalid = dec.values["nsec"] >= NS_PER_S
            if invalid.any():
                reasons.update(dict.fromkeys(dec.keep[invalid].tolist(), INVALID_STAMP))
                ok = ~invalid
                dec = DecodedChunk({k: v[ok] for k, v in dec.values.items()},
                                   {k: v[ok] for k, v in dec.present.items()}, dec.keep[ok], dec.missing,
                                   dec.malformed, dec.fast, dec.fallback, status)
        if not reasons:
            return dec, []
        order = sorted(reasons)
        before = np.searchsorted(dec.keep, order).tolist()
        return dec, [(int(b), reasons[i]) for b, i in zip(before, order)]
