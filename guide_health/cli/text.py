"""Results as text: plain Python values for json, and the indented key/value listing."""
from __future__ import annotations

from typing import Any

from guide_health.io.outputs.json_text import plain


def jsonable(value):
    """numpy scalars/arrays to plain Python, non-finite floats kept (for text; JSON output goes through
    io/json_text.json_text, which writes them as null)."""
    return plain(value, finite_only=False)


def format_key_values(result: dict[str, Any], indent: str = "", compact_lists: bool = False) -> str:
    """``key: value`` lines, a nested dict indented under its key, floats to 6 significant digits.
    With ``compact_lists`` a list's numbers too, and a list of dicts one ``- k: v, ...`` line per item;
    without, a list as Python prints it."""
    lines = []
    for key, value in result.items():
        if isinstance(value, dict):
            lines.append(f"{indent}{key}:")
            lines.append(format_key_values(value, indent + "  ", compact_lists))
        elif compact_lists and isinstance(value, list) and value and isinstance(value[0], dict):
            lines.append(f"{indent}{key}:")
            for item in value:
                lines.append(f"{indent}  - " + ", ".join(f"{k}: {_compact(v)}" for k, v in item.items()))
        else:
            lines.append(f"{indent}{key}: {_compact(value) if compact_lists else _plain(value)}")
    return "\n".join(lines)


def _plain(value) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _compact(value) -> str:
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_compact(v) for v in value) + "]"
    return _plain(value)


def bag_set_lines(report: dict, indent: str) -> list[str]:
    """The bags of a multi-bag run and the gaps between them (none for one bag)."""
    if "bags" not in report:
        return []
    lines = [f"{indent}bags:  {len(report['bags'])} from {report['bags'][0]['start_utc']} to "
             f"{report['bags'][-1]['end_utc']}"]
    lines.extend(f"{indent}gap:   {g['start_utc']} .. {g['end_utc']} ({g['duration_s']:.3f} s)" for g in report["gaps"])
    return lines

