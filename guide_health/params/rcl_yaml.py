"""A ROS 2 parameters YAML file read as rcl reads it (rcl_yaml_param_parser), so the CLI and the node agree.

rcl parses with libyaml and types each scalar itself (parse.c ``get_value``), not by YAML 1.1 or 1.2:

* a quoted scalar, or one tagged ``!!str``, is a string; other tags are ignored;
* a plain scalar is a bool when it is one of ``y Y yes Yes YES true True TRUE on On ON`` (``n ... off``
  for false), else an integer when C ``strtol(text, base 0)`` reads all of it without overflow (``0x1F``
  = 31, ``017`` = 15 octal, ``+1``; not ``1_000``, ``0b101``, ``0o17``, ``08``), else a float when
  ``strtod`` reads all of it without overflow or underflow (``1e3``, ``.5``, ``1.``, ``inf``, ``nan``,
  ``Infinity``, ``0x1p3``; an integer beyond int64 becomes a float; not ``1e400``), else a string
  (``~``, ``null``, ``1:00:00``, ``2020-01-01`` stay text);
* a list holds one type (``[1, 2.0]`` is refused), an empty value or list is refused ("No value"), an
  alias (``*name``) is refused ("Will not support aliasing");
* nested mapping keys above ``ros__parameters`` join into the node name (``/m1: {wear_monitor: ...}`` is
  ``/m1/wear_monitor``), a name without a leading ``/`` gets one, and sections apply in file order.

Each rule above was read off rcl by running it (test/test_params_shopfloor.py compares this reader with a
real rclpy node on every spelling). On top of rcl, a file above MAX_PARAMS_FILE_BYTES and a duplicated
key (rcl keeps the last one silently) are refused, and error messages show at most VALUE_CHARS characters
of a value.
"""
from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from guide_health.errors import InputError

#: a parameters file larger than this is refused before it is parsed (docs/interfaces.md)
MAX_PARAMS_FILE_BYTES = 1 << 20
#: characters of a value shown in an error message
VALUE_CHARS = 80
PARAMS_KEY = "ros__parameters"

_TRUE = {"y", "Y", "yes", "Yes", "YES", "true", "True", "TRUE", "on", "On", "ON"}
_FALSE = {"n", "N", "no", "No", "NO", "false", "False", "FALSE", "off", "Off", "OFF"}
_STRTOL = re.compile(r"([+-]?)(?:0[xX]([0-9a-fA-F]+)|(0[0-7]*)|([1-9][0-9]*))\Z")
_STRTOD_DEC = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\Z")
_STRTOD_HEX = re.compile(r"[+-]?0[xX](?:[0-9a-fA-F]+\.?[0-9a-fA-F]*|\.[0-9a-fA-F]+)(?:[pP][+-]?[0-9]+)?\Z")
_STRTOD_WORD = re.compile(r"[+-]?(?:inf|infinity|nan(?:\([0-9A-Za-z_]*\))?)\Z", re.IGNORECASE)
_DOT_WORDS = {**{sign + word: float(sign + "inf") for sign in ("", "+", "-") for word in (".inf", ".Inf", ".INF")},
              **{word: math.nan for word in (".nan", ".NaN", ".NAN")}}     # rcl's own YAML spellings
_DBL_MIN = 2.2250738585072014e-308          # below it glibc's strtod reports ERANGE (rcl: a string)
_INT64 = (-(2 ** 63), 2 ** 63 - 1)
_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)     # libyaml, the parser rcl uses
_STR_TAG, _UNTAGGED = "tag:yaml.org,2002:str", "rcl:untagged"


def short(value: Any, limit: int = VALUE_CHARS) -> str:
    """``repr(value)`` cut to ``limit`` characters (``...`` and the full length after a cut)."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def _strtol(text: str) -> int | None:
    match = _STRTOL.match(text)
    if match is None:
        return None
    sign, hexa, octal, decimal = match.groups()
    value = int(hexa, 16) if hexa else int(octal, 8) if octal else int(decimal)
    value = -value if sign == "-" else value
    return value if _INT64[0] <= value <= _INT64[1] else None        # ERANGE: rcl tries a float


def _nonzero(mantissa: str) -> bool:
    return any(c not in "0." for c in mantissa)


def _strtod(text: str) -> float | None:
    if text in _DOT_WORDS:
        return _DOT_WORDS[text]
    if _STRTOD_WORD.match(text):
        return float(text.split("(")[0])
    body = text.lstrip("+-")
    if _STRTOD_HEX.match(text):
        hexa = body[2:] if "p" in body[2:].lower() else body[2:] + "p0"
        try:
            value = float.fromhex(("-" if text[0] == "-" else "") + "0x" + hexa)
        except OverflowError:
            return None
        mantissa = re.split("[pP]", body[2:])[0]
    elif _STRTOD_DEC.match(text):
        value = float(text)
        mantissa = re.split("[eE]", body)[0]
    else:
        return None
    if math.isinf(value) or (value == 0.0 and _nonzero(mantissa)) or (value != 0.0 and abs(value) < _DBL_MIN):
        return None                                     # ERANGE (overflow, underflow): rcl keeps the text
    return value


def rcl_scalar(text: str, quoted: bool) -> Any:
    """The value rcl makes of one scalar (the module text); ``quoted``: quoted or tagged ``!!str``."""
    if quoted:
        return text
    if text in _TRUE:
        return True
    if text in _FALSE:
        return False
    as_int = _strtol(text)
    if as_int is not None:
        return as_int
    as_float = _strtod(text)
    return as_float if as_float is not None else text


@dataclass
class Section:
    """One ``<name>: ros__parameters:`` block: its node name (leading ``/``) and parameters."""
    name: str
    params: dict
    #: (key, line) of keys beside ros__parameters that are neither it nor a nested node mapping
    stray: list = field(default_factory=list)


class _Reader:
    """Walks libyaml's node tree once (never expanding an alias) into Python values typed as by rcl."""

    def __init__(self, path: Path):
        self.path = path
        self.seen: set[int] = set()

    def fail(self, node, what: str) -> InputError:
        return InputError(f"parameters file {self.path}: line {node.start_mark.line + 1}: {what}")

    def value(self, node, where=None) -> Any:
        """``where``: the node that refers to ``node`` (its line is the alias's, not the anchor's)."""
        if id(node) in self.seen:
            raise self.fail(where or node, "YAML aliases (*name) are not supported: rcl refuses them "
                                           "(\"Will not support aliasing\"); write the value out")
        self.seen.add(id(node))
        if isinstance(node, yaml.ScalarNode):
            if node.value == "" and node.style in (None, "", ":"):
                raise self.fail(node, "a key has no value (rcl: \"No value\")")
            return rcl_scalar(node.value, node.style in ("'", '"') or node.tag == _STR_TAG)
        if isinstance(node, yaml.SequenceNode):
            return self.sequence(node)
        return self.mapping(node)

    def sequence(self, node) -> list:
        items = [self.value(item, node) for item in node.value]
        if not items:
            raise self.fail(node, "an empty list has no type: rcl leaves the parameter unset")
        kinds = {type(item) for item in items}
        if len(kinds) > 1 or kinds & {list, dict}:
            names = ", ".join(sorted(kind.__name__ for kind in kinds))
            hint = "; a bare y, n, yes, no, on, off is a bool: quote it" if kinds == {bool, str} else ""
            raise self.fail(node, f"a list must hold one type (rcl: \"Sequence should be of same type\"), "
                                  f"got {names}: {short(items)}{hint}")
        return items

    def mapping(self, node) -> dict:
        out: dict = {}
        lines: dict = {}
        for key_node, value_node in node.value:
            key = self.value(key_node)
            key = key if isinstance(key, str) else key_node.value
            if key in out:
                raise self.fail(key_node, f"duplicate key {short(key)} (lines {lines[key]} and "
                                          f"{key_node.start_mark.line + 1}; rcl keeps the last one silently)")
            lines[key] = key_node.start_mark.line + 1
            out[key] = self.value(value_node, key_node)
        return out


class _RclLoader(_Loader):
    """libyaml's composer with every untagged scalar left untyped: rcl_scalar types it."""

    def resolve(self, kind, value, implicit):
        return _UNTAGGED if kind is yaml.ScalarNode else super().resolve(kind, value, implicit)


def read_params_file(path: str | Path) -> Any:
    """The file's top-level value, typed as by rcl; InputError (one line) for a missing, oversized,
    unreadable or invalid file, an alias, a duplicate key, a mixed list or an empty value."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"parameters file not found: {path}")
    size = path.stat().st_size
    if size > MAX_PARAMS_FILE_BYTES:
        raise InputError(f"parameters file {path} is {size} bytes, above the limit of {MAX_PARAMS_FILE_BYTES} "
                         f"bytes for a parameters file (docs/interfaces.md)")
    try:
        text = path.read_text(encoding="utf8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"parameters file {path} cannot be read: {exc}".splitlines()[0]) from None
    loader = _RclLoader(text)
    try:
        node = loader.get_single_node()
    except yaml.YAMLError as exc:
        raise InputError(" ".join(f"parameters file {path} is not valid YAML: {exc}".split())) from None
    finally:
        loader.dispose()
    return None if node is None else _Reader(path).value(node)


def read_value_text(text: str, where: str) -> Any:
    """The value of a ``-p name:=TEXT`` argument, typed as rcl types it (the same rules as a file)."""
    loader = _RclLoader(text)
    try:
        node = loader.get_single_node()
    except yaml.YAMLError:
        return text
    finally:
        loader.dispose()
    return text if node is None else _Reader(Path(where)).value(node)


def _stray_is_typo(key: str) -> bool:
    return bool(difflib.get_close_matches(key, [PARAMS_KEY], n=1, cutoff=0.6))


def sections(path: str | Path) -> list[Section]:
    """Every ``ros__parameters`` block of the file in file order, its name the joined keys above it
    (``/m1: {wear_monitor: ...}`` is ``/m1/wear_monitor``)."""
    data = read_params_file(path)
    if not isinstance(data, dict):
        raise InputError(f"parameters file {path} holds no '<node>: ros__parameters:' mapping")
    found: list[Section] = []
    _walk(data, "", found)
    return found


def _walk(mapping: dict, prefix: str, found: list[Section]) -> None:
    for key, value in mapping.items():
        name = prefix + "/" + key.strip("/") if prefix else "/" + key.lstrip("/")
        if not isinstance(value, dict):
            continue
        section = Section(name, {})
        for inner, inner_value in value.items():
            if inner == PARAMS_KEY:
                section.params = inner_value if isinstance(inner_value, dict) else {}
                if inner_value is not None and not isinstance(inner_value, dict):
                    section.stray.append(PARAMS_KEY)
            elif isinstance(inner_value, dict) and not _stray_is_typo(inner):
                continue
            else:
                section.stray.append(inner)
        if PARAMS_KEY in value or section.stray:
            found.append(section)
        _walk({k: v for k, v in value.items() if k != PARAMS_KEY and isinstance(v, dict)
               and not _stray_is_typo(k)}, name, found)


def _token_pattern(name: str) -> re.Pattern:
    parts = [p for p in name.split("/") if p]
    out = ""
    for part in parts:
        out += "(?:/[^/]+)*" if part == "**" else "/[^/]+" if part == "*" else "/" + re.escape(part)
    return re.compile(out + r"\Z")


def applies(section_name: str, node_fqn: str) -> bool:
    """rcl's match of a section name against a node's full name: ``**`` is any number of name parts (none
    too), ``*`` exactly one; ``wear_monitor`` is ``/wear_monitor``, the node in the root namespace only."""
    return _token_pattern(section_name).match(node_fqn) is not None


def any_namespace(section_name: str, node_name: str) -> bool:
    """The section applies to ``node_name`` in every namespace (``/**``, ``/**/wear_monitor``, ``/**/*``)."""
    return all(applies(section_name, ns + node_name) for ns in ("/", "/m1/", "/a/b/"))


def edit_distance(a: str, b: str) -> int:
    """Levenshtein distance (insertions, deletions, substitutions)."""
    row = list(range(len(b) + 1))
    for i, ca in enumerate(a, 1):
        prev, row[0] = row[0], i
        for j, cb in enumerate(b, 1):
            prev, row[j] = row[j], min(row[j] + 1, row[j - 1] + 1, prev + (ca != cb))
    return row[-1]
