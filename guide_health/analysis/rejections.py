"""Rejected samples in the reports of replay and diagnose: by reason, with counts, the share of that input's
samples and a hint where one exists.

The counts are the monitor's (or the duty cells') :class:`~guide_health.models.wear.input_rules.
RejectionCounter`, the same ``rejected: <reason>`` counts the live node reports; the denominators come from
:class:`InputTally`, the samples of each input read from the bag (the kept ones and the messages the reader
rejected). A report starts with the rejections when any reason exceeds ``REJECTED_SHARE_LEAD`` of its input
(a wear model fed a few percent less motion or load is off by about as much, silently).

The functions here work on one axis (one counter, one tally, one parameter set), so a report of several
axes calls them once per axis.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from guide_health.models.wear.input_rules import (
    JOINT_INPUT,
    JOINT_STAMP_JUMP,
    LOAD_ABOVE_MAX,
    LOAD_INPUT,
    LOAD_STAMP_JUMP,
    MALFORMED_JOINT_STATES,
    MALFORMED_LOAD,
    POSITION_OUT_OF_TRAVEL,
    STRAIGHTNESS_INPUT,
    TEMPERATURE_INPUT,
    input_of_reason,
)

#: a reason above this share of its input's samples leads the report (text and report.md)
REJECTED_SHARE_LEAD = 0.01
#: inputs whose rejected samples carry motion or load, hence wear: their share can explain a misfit
WEAR_INPUTS = (JOINT_INPUT, LOAD_INPUT)


def _no_samples() -> dict:
    return dict.fromkeys((JOINT_INPUT, LOAD_INPUT, STRAIGHTNESS_INPUT, TEMPERATURE_INPUT), 0)


@dataclass
class InputTally:
    """The samples of each input of an axis read from a bag (MachineRun chunks, in order), and the largest
    |joint position| among them [m] (finite positions, accepted or not: the rail-travel hint; 0 before any)."""

    samples: dict = field(default_factory=_no_samples)
    largest_position_m: float = 0.0

    def add(self, run) -> None:
        for name, stamps in ((JOINT_INPUT, run.joint_t_ns), (LOAD_INPUT, run.load_t_ns),
                             (STRAIGHTNESS_INPUT, run.straightness_t_ns), (TEMPERATURE_INPUT, run.temperature_t_ns)):
            self.samples[name] += int(np.size(stamps))
        for name, _, _ in getattr(run, "rejected_messages", ()):
            self.samples[name] = self.samples.get(name, 0) + 1
        x = np.abs(np.asarray(run.joint_position_m, dtype=float))
        x = x[np.isfinite(x)]
        if x.size:
            self.largest_position_m = max(self.largest_position_m, float(x.max()))


def _percent(share: float) -> str:
    """A share as '2.3 %' (three significant digits)."""
    return f"{share * 100:.3g} %"


def reason_hint(reason: str, tally: InputTally, params: dict) -> str:
    """What to check for a reason ('' when there is nothing specific to say)."""
    if reason == POSITION_OUT_OF_TRAVEL:
        return (f"largest |position| seen {tally.largest_position_m:.4g} m against rail_length_m "
                f"{params['rail_length_m']:g} m (rail_start_m {params['rail_start_m']:g} m, travel_margin_m "
                f"{params['travel_margin_m']:g} m): check rail_length_m, rail_start_m and the joint's zero")
    if reason == LOAD_ABOVE_MAX:
        return f"load_max_n is {params['load_max_n']:g} N: check the load unit (N) and load_max_n"
    if reason in (JOINT_STAMP_JUMP, LOAD_STAMP_JUMP):
        return f"stamp_horizon_s is {params['stamp_horizon_s']:g} s: check the recorder's clock"
    if reason in (MALFORMED_JOINT_STATES, MALFORMED_LOAD):
        return "messages that do not decode as their type (empty or truncated): check the recorder"
    if reason.startswith("joint '"):
        return f"check the params file's joint ({params['joint']!r}) against the bag's joint names"
    return ""


def rejection_summary(rejected: dict, tally: InputTally, params: dict) -> dict:
    """The report block of one axis's rejections, {} when nothing was rejected: ``rejected_samples``,
    ``reasons`` (largest share first: reason, count, input, samples of that input, share, hint) and
    ``leads`` (a share above REJECTED_SHARE_LEAD)."""
    rows = []
    for reason, count in rejected.items():
        inputs = input_of_reason(reason)
        samples = sum(tally.samples.get(name, 0) for name in inputs)
        rows.append({"reason": reason, "count": int(count), "input": " + ".join(inputs),
                     "input_samples": int(samples), "share": count / samples if samples else math.nan,
                     "hint": reason_hint(reason, tally, params)})
    if not rows:
        return {}
    rows.sort(key=lambda r: (-(r["share"] if math.isfinite(r["share"]) else 1.0), r["reason"]))
    return {"rejected_samples": int(sum(r["count"] for r in rows)), "reasons": rows,
            "leads": any(not r["share"] <= REJECTED_SHARE_LEAD for r in rows)}


def wear_input_share(summary: dict) -> float:
    """The rejected share (all reasons) of the input that carries wear (joint_states, guide/load) with the
    largest one; 0 without any."""
    totals: dict[str, float] = {}
    for r in summary.get("reasons", ()):
        if r["input"] in WEAR_INPUTS and r["input_samples"]:
            totals[r["input"]] = totals.get(r["input"], 0.0) + r["count"] / r["input_samples"]
    return max(list(totals.values()) + [0.0])


def rejection_lines(summary: dict, axis: str = "") -> list[str]:
    """Text lines of the rejections ([] when none): a headline, then one line per reason."""
    if not summary:
        return []
    where = f" on axis {axis}" if axis else ""
    head = (f"REJECTED INPUT{where}: more than {_percent(REJECTED_SHARE_LEAD)} of an input's samples; the results "
            "below leave them out" if summary["leads"] else f"rejected input{where}")
    lines = [f"{head} ({summary['rejected_samples']} samples):"]
    for r in summary["reasons"]:
        share = f"{_percent(r['share'])} of {r['input_samples']} {r['input']} samples" if math.isfinite(r["share"]) \
            else f"of {r['input'] or 'an unknown input'}"
        lines.append(f"  rejected: {r['reason']}: {r['count']} ({share})" + (f"; {r['hint']}" if r["hint"] else ""))
    return lines


def rejection_markdown(summary: dict, axis: str = "") -> list[str]:
    """report.md lines of the rejections ([] when none): a section with a table."""
    if not summary:
        return []
    title = "## Rejected input" + (f" (axis {axis})" if axis else "")
    lines = [title, ""]
    if summary["leads"]:
        lines += [f"> **More than {_percent(REJECTED_SHARE_LEAD)} of an input's samples were rejected; the results "
                  "leave them out.**", ""]
    lines += ["| reason | samples | share of the input | hint |", "|---|---|---|---|"]
    for r in summary["reasons"]:
        share = f"{_percent(r['share'])} of {r['input_samples']} {r['input']}" if math.isfinite(r["share"]) else "n/a"
        hint = r["hint"].replace("|", "\\|")          # a table cell: '|' escaped
        lines.append(f"| {r['reason']} | {r['count']} | {share} | {hint} |")
    return lines + [""]


def misfit_note(summary: dict, named_effects) -> tuple[bool, str]:
    """(whether the rejected samples could explain the misfit the named effects fit, the sentence saying so).
    Rejected joint or load samples carry no wear: a deficit of about their share, concentrated where and
    when they occurred, which an effect can fit. Flagged when effects are named and the rejected share of
    joint_states or guide/load exceeds REJECTED_SHARE_LEAD."""
    share = wear_input_share(summary)
    if not named_effects or not share > REJECTED_SHARE_LEAD:
        return False, ""
    return True, (f"{_percent(share)} of the joint/load samples were rejected and carry no wear: the rejections may "
                  f"explain the misfit the named effects ({', '.join(named_effects)}) fit; resolve them first")


def with_rejection_lines(lines: list[str], summary: dict, axis: str = "") -> list[str]:
    """A text report's ``lines`` with the rejection lines: first when they lead, else before the last line
    (the files)."""
    extra = rejection_lines(summary, axis)
    if not extra:
        return lines
    return extra + lines if summary["leads"] else lines[:-1] + extra + lines[-1:]


def add_diagnose_rejections(result: dict, rejected: dict, tally: InputTally, params: dict) -> None:
    """diagnose's result (one axis) gets ``rejections`` and ``rejections_may_explain_misfit`` (and the sentence
    as ``rejections_note``) when any sample was rejected; the flag is also set when the workflow found that the
    rejected wear could explain the misfit and named nothing (``rejected_wear``, its note kept)."""
    summary = rejection_summary(dict(rejected), tally, params)
    if not summary:
        return
    flag, note = misfit_note(summary, result["named_effects"])
    result["rejections"] = summary
    result["rejections_may_explain_misfit"] = flag or bool(result.get("rejected_wear", {}).get("explains_misfit"))
    if note:
        result["rejections_note"] = note


def diagnose_lead_lines(result: dict, markdown: bool = False) -> list[str]:
    """What a diagnose report starts with: the rejections when they lead, and the misfit sentence before any
    effect is named ([] otherwise)."""
    summary = result.get("rejections", {})
    lines = []
    if summary.get("leads"):
        lines = rejection_markdown(summary) if markdown else rejection_lines(summary)
    if result.get("rejections_note"):
        lines += [f"> **{result['rejections_note']}**", ""] if markdown else [result["rejections_note"]]
    return lines


def diagnose_tail_lines(result: dict, markdown: bool = False) -> list[str]:
    """The rejections where they do not lead ([] otherwise): placed after the findings."""
    summary = result.get("rejections", {})
    if not summary or summary["leads"]:
        return []
    return rejection_markdown(summary) if markdown else rejection_lines(summary)
