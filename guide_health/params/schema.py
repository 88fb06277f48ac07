"""Parameter schema: every parameter declared once, with its type, default, unit, range and description.

A :class:`Param` carries the name, the default (its Python type is the parameter's type), the unit, the
allowed range in interval notation (``"(0, inf)"``, ``"[0, 0.5)"``, ``"[1e6, 1e11]"``) or a tuple of
allowed choices, a one-line description and ``dynamic``: True when the value may be changed while the node
runs (thresholds and timeouts), False for read-only parameters (geometry, materials, file paths, guide
type, ...); read-only parameters refuse ``ros2 param set``, the nodes apply an accepted dynamic one to the
running model (``guide_health.nodes.live_params``).

A :class:`NodeSchema` is one node's (or YAML section's) parameter list plus the cross-checks that a range
cannot express (``stroke_min_m <= stroke_max_m``, rollers fitting on the raceway, ...). ``validate`` runs
the cross-checks first (their one-line messages are the long-standing ones), then every declared range.

Pure Python: no ROS, no file I/O (see ``loader.py`` for YAML files and ``ros.py`` for rclpy nodes).
"""
from __future__ import annotations

import difflib
import math
import numbers
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from guide_health.errors import InputError
from guide_health.models.wear.effects.registry import COVARIANCE_SIZES


def _parse_interval(text: str) -> tuple[float, float, bool, bool]:
    """``"(0, inf)"`` -> (low, high, low_open, high_open); brackets: ``[`` closed, ``(`` open."""
    text = text.strip()
    if len(text) < 5 or text[0] not in "[(" or text[-1] not in "])" or text.count(",") != 1:
        raise ValueError(f"interval must look like '[a, b]', '(a, b)', '[a, b)' or '(a, b]', got {text!r}")
    low, high = (float(part) for part in text[1:-1].split(","))
    if not low <= high:
        raise ValueError(f"interval {text!r}: low end above high end")
    return low, high, text[0] == "(", text[-1] == ")"


def _is_number(value: Any) -> bool:
    """A real number (numpy scalars included), not a bool."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


class NumberList(list):
    """The default of a table parameter: a list of finite numbers of any length (type ``float[]``); a
    ``list`` default of numbers fixes the length instead."""


@dataclass(frozen=True)
class Param:
    """One parameter: ``interval`` (numbers) or ``choices`` (strings) is its allowed range, '' = any."""

    name: str
    default: Any
    unit: str
    interval: str
    description: str
    dynamic: bool = False
    choices: tuple[str, ...] = ()
    bounds: tuple[float, float, bool, bool] | None = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "bounds", _parse_interval(self.interval) if self.interval else None)
        if self.choices and self.default not in self.choices:
            raise ValueError(f"{self.name}: default {self.default!r} not among {self.choices}")

    @property
    def type_name(self) -> str:
        """bool | int | float | string | float[n] (the type the YAML value must have)."""
        if isinstance(self.default, NumberList):
            return "float[]"
        if isinstance(self.default, list):
            if not self.default or isinstance(self.default[0], str):
                return "string[]"
            return f"float[{len(self.default)}]"
        return {bool: "bool", int: "int", float: "float", str: "string"}[type(self.default)]

    @property
    def unit_suffix(self) -> str:
        """' Pa' after a number or an interval; '' for dimensionless ('-') and unitless parameters."""
        return f" {self.unit}" if self.unit not in ("", "-") else ""

    @property
    def range_text(self) -> str:
        """The allowed range as declared: the interval, or the choices joined by ' | ', '' = any."""
        return " | ".join(self.choices) if self.choices else self.interval

    def accepts(self, value: Any) -> bool:
        """Is ``value`` inside the declared range (every element for a list)? No range: always True."""
        if self.choices:
            return value in self.choices
        if self.bounds is None:
            return True
        if isinstance(value, (list, tuple)):
            return all(self.accepts(v) for v in value)
        if not _is_number(value) or not math.isfinite(value):
            return False
        low, high, low_open, high_open = self.bounds
        above = value > low if low_open else value >= low
        below = value < high if high_open else value <= high
        return above and below


def _square_block_padded(values: list, size: int) -> list:
    """A row-major n x n matrix as the leading block of an m x m one (m^2 = size), zeros elsewhere."""
    n, m = math.isqrt(len(values)), math.isqrt(size)
    out = [0.0] * size
    for i in range(n):
        out[i * m:i * m + n] = values[i * n:(i + 1) * n]
    return out


#: numeric-list parameters that grew, with the older lengths a file may still hold and how it widens (every
#: loader goes through coerce_value): the effect_covariance of older model files (the effect registry's
#: generations of covariance rows: 6 x 6, 9 x 9, 10 x 10, 12 x 12)
LIST_UPGRADES = {"effect_covariance": (tuple(n * n for n in COVARIANCE_SIZES[:-1]), _square_block_padded)}


def coerce_value(name: str, value: Any, default: Any) -> Any:
    """``value`` converted to the type of ``default`` (int -> float; '199.0e6' -> float, as ROS's rcl parser
    reads it); InputError with a one-line reason when it cannot be."""
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise InputError(f"parameter {name} must be true/false, got {value!r}")
        return value
    if isinstance(default, float):
        if isinstance(value, str):
            # YAML 1.1 (PyYAML) reads 199.0e6 as a string; ROS's rcl parser reads it as a double
            try:
                value = float(value)
            except ValueError:
                raise InputError(f"parameter {name} must be a number, got {value!r}") from None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputError(f"parameter {name} must be a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise InputError(f"parameter {name} must be finite, got {value!r}")
        return value
    if isinstance(default, int):
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"parameter {name} must be an integer, got {value!r}")
        return value
    if isinstance(default, str):
        if not isinstance(value, str):
            raise InputError(f"parameter {name} must be a string, got {value!r}")
        return value
    if isinstance(default, NumberList):
        if not isinstance(value, (list, tuple)) or not all(_is_number(v) and math.isfinite(v) for v in value):
            raise InputError(f"parameter {name} must be a list of finite numbers, got {value!r}"[:200])
        return [float(v) for v in value]
    if isinstance(default, list) and (not default or isinstance(default[0], str)):
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise InputError(f"parameter {name} must be a list of strings, got {value!r}")
        return list(value)
    if isinstance(default, list):
        upgrade = LIST_UPGRADES.get(name)
        if upgrade and isinstance(value, list) and len(value) in upgrade[0] and len(value) != len(default):
            value = upgrade[1](value, len(default))
        if not isinstance(value, list) or len(value) != len(default):
            raise InputError(f"parameter {name} must be a list of {len(default)} numbers, got {value!r}")
        return [coerce_value(f"{name}[{i}]", v, d) for i, (v, d) in enumerate(zip(value, default))]
    return value


def unknown_key_message(section: str, name: str, known: Iterable[str]) -> str:
    """"unknown parameter 'hardnes_pa' for wear_monitor (did you mean 'hardness_pa'?)"."""
    close = difflib.get_close_matches(name, list(known), n=1)
    hint = f" (did you mean '{close[0]}'?)" if close else ""
    return f"unknown parameter '{name}' for {section}{hint}"


def check_unknown_keys(section: str, names: Iterable[str], known: Iterable[str], source: str = "") -> None:
    """InputError for the first of ``names`` not in ``known``, with the closest known name suggested."""
    known = list(known)
    for name in names:
        if name not in known:
            prefix = f"{source}: " if source else ""
            raise InputError(prefix + unknown_key_message(section, name, known))


@dataclass(frozen=True)
class NodeSchema:
    """The parameters of one node or YAML section (``section`` = ``<node>`` of ``<node>: ros__parameters``)."""

    section: str
    params: tuple[Param, ...]
    cross_checks: Callable[[dict[str, Any]], None] | None = None
    by_name: dict[str, Param] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        by_name = {p.name: p for p in self.params}
        if len(by_name) != len(self.params):
            raise ValueError(f"{self.section}: a parameter is declared twice")
        object.__setattr__(self, "by_name", by_name)

    def __getitem__(self, name: str) -> Param:
        return self.by_name[name]

    def defaults(self) -> dict[str, Any]:
        """{name: default} (a fresh dict; list defaults copied)."""
        return {p.name: list(p.default) if isinstance(p.default, list) else p.default for p in self.params}

    def check_ranges(self, values: dict[str, Any]) -> None:
        """InputError (one line: section, key, value, range) for the first value outside its range.
        Names missing from ``values`` are skipped (model code passes partial dicts)."""
        for p in self.params:
            if p.name in values and not p.accepts(values[p.name]):
                where = f"one of {p.range_text}" if p.choices else f"in {p.range_text}{p.unit_suffix}"
                raise InputError(f"{self.section}: parameter {p.name} = {values[p.name]!r} must be {where}")

    def validate(self, values: dict[str, Any]) -> None:
        """The cross-checks (long-standing messages), then every declared range."""
        if self.cross_checks is not None:
            self.cross_checks(values)
        self.check_ranges(values)

    def check_unknown_keys(self, names: Iterable[str], source: str = "") -> None:
        """InputError for a name this schema does not declare, with the closest declared name suggested."""
        check_unknown_keys(self.section, names, self.by_name, source)


def _markdown_cell(text: str) -> str:
    return text.replace("|", "\\|")


def _format_default(default: Any) -> str:
    if isinstance(default, str):
        return f"`{default!r}`" if default == "" else f"`{default}`"
    if isinstance(default, bool):
        return "true" if default else "false"
    if isinstance(default, float):
        return f"{default:g}"
    if isinstance(default, list):
        return "[" + ", ".join(_format_default(v) for v in default) + "]"
    return str(default)


def markdown_table(schema: NodeSchema) -> str:
    """The Markdown table of a node's parameters (README/docs): name, type, default, unit, range, dynamic,
    description."""
    lines = [f"**{schema.section}**", "",
             "| name | type | default | unit | range | dynamic | description |",
             "|---|---|---|---|---|---|---|"]
    for p in schema.params:
        cells = (f"`{p.name}`", p.type_name, _format_default(p.default), p.unit, p.range_text,
                 "yes" if p.dynamic else "no", p.description)
        lines.append("| " + " | ".join(_markdown_cell(c) for c in cells) + " |")
    return "\n".join(lines) + "\n"


def alarm_and_sensor_qos_params(topics: str) -> tuple[Param, ...]:
    """The alarm hysteresis and sensor-QoS parameters every monitor node shares (one range each);
    ``topics`` names the node's data topics in the descriptions."""
    return (
        Param("alarm_clear_margin", 0.05, "-", "[0, 0.5]",
              "hysteresis: a raised level drops only once its value is back this fraction inside the threshold "
              "(no toggling at a threshold); 0 = none", dynamic=True),
        Param("sensor_qos", "auto", "", "", f"reader QoS of {topics}: auto (per topic: reliable KEEP_ALL while "
              "every publisher is reliable, best effort once one is), reliable or best_effort (docs/ros.md)",
              choices=("auto", "reliable", "best_effort")),
        Param("sensor_queue_depth", 1000, "-", "[1, 1000000]", "best-effort subscriptions: reader queue depth"),
    )


def executor_param(events_description: str) -> Param:
    """The ``executor`` parameter of the monitor nodes (one set of choices; the rule for ``auto`` is
    guide_health/nodes/qos.py resolve_executor); ``events_description`` says what ``events`` brings the node."""
    return Param("executor", "auto", "", "", f"events ({events_description}), single_threaded (message info: "
                 "exact loss count of best-effort sensors) or auto (single_threaded when sensor_qos is best_effort "
                 "or the node runs on /clock, else events)", choices=("auto", "events", "single_threaded"))
