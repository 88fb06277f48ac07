"""Strict JSON: the one rule for every JSON the project writes (report files, --json, fleet files, run metadata).

JSON has no NaN or Infinity (``json`` would write them, but jq, browsers and strict parsers refuse the file).
A non-finite float is written as ``null``, meaning "unbounded or unknown": a remaining life or K interval
without an upper bound, a standard error without information, a value not yet known. Everything is written
with ``allow_nan=False``, so a non-finite number that escaped the rule is an error, never a non-JSON file.
A reader that needs a number back uses :func:`number` with what null means in that field (inf for an
unbounded bound or standard error, NaN for an unknown value).
"""
from __future__ import annotations

import json
import math
import sys


def plain(value, finite_only: bool = True):
    """`value` with numpy scalars/arrays as plain Python and tuples as lists; with ``finite_only`` a
    non-finite float (NaN, +-inf) as None (JSON null). numpy is not imported here: a program that has not
    loaded it holds no numpy values (the CLI's --help stays light)."""
    np = sys.modules.get("numpy")
    if isinstance(value, dict):
        generic = np.generic if np is not None else ()
        return {(k.item() if isinstance(k, generic) else k): plain(v, finite_only) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v, finite_only) for v in value]
    if np is not None and isinstance(value, np.ndarray):
        return plain(value.tolist(), finite_only)
    if np is not None and isinstance(value, np.generic):
        value = value.item()
    if finite_only and isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_text(value, **kwargs) -> str:
    """``json.dumps`` of `value` under the rule: non-finite floats as null, ``allow_nan=False``."""
    return json.dumps(plain(value), allow_nan=False, **kwargs)


def number(value, null: float = math.nan) -> float:
    """A number read from the project's JSON: ``null`` (None) is `null` (inf for an unbounded bound or a
    standard error without information, NaN for an unknown value)."""
    return null if value is None else float(value)
