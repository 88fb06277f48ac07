"""The words of the discrepancy report on naming (text and report.md; plain formatting, no fitting: the command
line imports it at start-up): what the record resolves, "too little data", and the named effects that are a
reading or ambiguous (consistency.py)."""
from __future__ import annotations

from typing import Any


def consistency_lines(result: dict[str, Any], markdown: bool = False) -> list[str]:
    """The report's lines on the checks of the named effects (before the effects: a reading first)."""
    lines = []
    for effect, c in result.get("consistency", {}).items():
        if c["status"] == "finding":
            continue
        alt = ", ".join(f"{a['form']} (dBIC {a['delta_bic']:+.1f})" for a in c["alternatives"]
                        if a["delta_bic"] <= c["tie_bic"])
        own_failed = not c.get("own_check", {"passed": True})["passed"]
        what = ("AMBIGUOUS: an alternative fits as well" if c["status"] == "ambiguous"
                else "a READING, not a finding: " + ("it fails its own check" if own_failed
                                                    else "an alternative fits better"))
        text = f"{effect} is {what} ({c['check']})" + (f"; fits as well or better: {alt}" if alt else "")
        if c["separating_measurement"]:
            text += f". To separate them: {c['separating_measurement']}"
        lines.append(f"> **{text}**" if markdown else text)
        if markdown:
            lines.append("")
    return lines


def naming_lead_lines(result: dict[str, Any], markdown: bool = False) -> list[str]:
    """What comes before the effects in text and report.md: "too little data: ..." when the record cannot
    separate the candidates, then each named effect that is a reading or ambiguous."""
    lines = []
    resolution = result.get("data_resolution", {})
    if resolution.get("too_little_data"):
        lines += [f"> **{resolution['message']}**", ""] if markdown else [resolution["message"]]
    return lines + consistency_lines(result, markdown)


def resolution_markdown(result: dict[str, Any]) -> list[str]:
    """report.md's section on what the record resolves (K's interval, the detectable size per candidate)."""
    r = result.get("data_resolution")
    if not r:
        return []
    low, high = r["wear_coefficient_interval_95"]
    lines = ["## What the record resolves", "",
             f"{r['fit_measurements']} fitted measurements over {r['fit_span_h']:.1f} h, noise "
             f"{r['noise_sd_um']:.3f} um; K = {r['wear_coefficient']:.4g} (95 %: {low:.4g} .. {high:.4g}). "
             f"Detectable: {r['detectable_sd']:g} sd of the effect's size from the Fisher information at the "
             "fitted baseline; separable: still detectable with "
             "any one other detectable candidate freed.", "",
             "| candidate | size | plausible | detectable (3 sd) | separable |", "|---|---|---|---|---|"]
    lines += [f"| {c['effect']} | {c['size']} | {c['plausible_size']:.3g} | {c['detectable_size']:.3g} | "
              f"{'yes' if c['separable'] else 'no'} |" for c in r["candidates"]]
    return lines + [""]
