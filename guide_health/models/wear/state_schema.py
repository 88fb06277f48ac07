"""What a saved PrecisionMonitor state must look like before it is restored, and whose it is.

A state is refused whole, never half-loaded: ``check_state_like`` compares a saved state with the state of a
freshly built monitor of the same parameters (the template): the same fields, of the same kinds (a number
where a number is, a list of numbers of the same length where the template's list is non-empty, a
sub-state where a sub-state is), and the parallel lists of the duty buckets and of the measurements of equal
lengths. ``state_fingerprint`` names what a state belongs to (machine, axis, guide type and the geometry
that fixes the meaning of the stored work profile); a state saved under another fingerprint is refused.

Pure Python (no ROS, no I/O): the caller reads the state and names the file in its message.
"""
from __future__ import annotations

import math
import numbers
from typing import Any

from guide_health.errors import InputError
from guide_health.models.wear.effect_wear import STATE_LIST_LENGTHS
from guide_health.models.wear.precision import TEMPERATURE_HISTORY

#: the parameters a saved precision state belongs to: another value makes it another guide
FINGERPRINT_PARAMS = ("machine_id", "joint", "guide_type", "contact_width_m", "slider_length_m", "rail_start_m",
                      "rail_length_m", "profile_bin_m")
#: lists that grow together (one entry per duty bucket, per straightness measurement)
PARALLEL_LISTS = {
    "integrator": ("duty_bucket_index", "duty_bucket_work_nm"),
    "estimator": ("measurement_t_ns", "measurement_m", "measurement_loss_per_k_m", "measurement_work_nm"),
    "temperatures": ("reading_t_ns", "reading_c"),
    "effects": ("measurement_gradients", "measurement_pass_work_n", "measurement_temperature_offset_k"),
}


def state_fingerprint(machine_id: str, params: Any) -> dict[str, Any]:
    """{name: value} of FINGERPRINT_PARAMS: the node's ``machine_id`` and the others of an axis's frozen wear
    parameters (guide_health.params.typed.WearAxisParams)."""
    return {name: machine_id if name == "machine_id" else getattr(params, name) for name in FINGERPRINT_PARAMS}


def fingerprint_mismatch(saved: dict[str, Any], current: dict[str, Any]) -> str:
    """'' when ``saved`` fits ``current``; else the differences, e.g. "machine_id 'm2' (now 'm1')"."""
    diffs = [f"{name} {saved[name]!r} (now {current.get(name)!r})" for name in sorted(saved)
             if name in current and saved[name] != current[name]]
    return ", ".join(diffs)


#: fields that are sums of non-negative terms (distances, counts, work): a negative value is a corrupt state.
#: (Not measurement_m: with the gauge's temperature term a reading is stored corrected, c_T (T - T_ref) taken off,
#: which may leave a reading near zero slightly below it.)
#: Not the per-bin profile and per-bucket/measurement work lists: made by differences, they may round to
#: -1e-16 in a legal state (found by test_state_property's arbitrary runs).
NON_NEGATIVE = frozenset({
    "sliding_distance_m", "archard_work_nm", "samples", "stroke_count", "stroke_sum_m",
    "stroke_sum_sq_m2", "stroke_min_m", "stroke_max_m", "load_samples", "travel_m",
    "load_power_travel", "recent_travel_m", "recent_load_power_travel", "boundary_travel_m", "window_travel_m",
    "boundary", "mixed", "full_film", "reverse_travel_m", "pass_length_m",
    "cusum_high", "cusum_low", "innovations"})
#: element kind of lists that are empty in a fresh monitor (the template cannot show it)
#: (a NaN element marks a measurement taken before the stroke was known: Eq. 7's g_j not yet defined)
#: fields added to the state after it was first written, with the value a state saved before them restores to
#: (effect_wear: the work gradient at each measurement and where the present surface was made; the
#: relubrication time base; older bucket rows and gradients are zero-padded by effect_wear.restore).
#: Such a state is accepted without them; every other missing field is refused.
ADDED_FIELDS = {"measurement_gradients": [], "surface_start_m": 0.0,
                # the relubrication factor's time base
                "last_relubrication_t_ns": None, "first_sample_t_ns": None,
                # the pass work (PrecisionMonitor.restore estimates P without it)
                "pass_work_n": 0.0, "pass_direction": 0, "pass_length_m": 0.0, "pass_open_work_nm": 0.0,
                "pass_open_buckets": [], "measurement_pass_work_n": [],
                # the gauge temperature's T - T_ref per measurement (without it c_T's spread is not carried)
                "measurement_temperature_offset_k": [],
                # the rolling guide's stamp of the oil temperature reading in force
                "oil_temperature_t_ns": None,
                # the running clock (models/wear/running_time.py): a state without it ran without idle pauses
                "idle_ns": 0, "last_motion_t_ns": None, "last_counted_t_ns": None, "idle_pause_start_ns": [],
                "idle_pause_end_ns": [],
                # the model-fit test (models/wear/fit_watch.py): a state without it starts a new test
                "fit_watch": None}
EMPTY_LIST_ELEMENT = {"duty_bucket_index": 0, "measurement_t_ns": 0, "measurement_loss_per_k_m": float("nan"),
                      "reading_t_ns": 0, "idle_pause_start_ns": 0, "idle_pause_end_ns": 0,
                      # NaN: a measurement restored from a state saved before these were kept (effect_wear.restore)
                      "measurement_pass_work_n": float("nan"), "measurement_temperature_offset_k": float("nan")}
#: stamp lists a monitor keeps in stamp order and bounded (the gauge correction's temperature
#: readings): another order or a longer list is a corrupt state (restoring it would re-sort or trim it)
STAMP_ORDERED_LISTS = {"reading_t_ns": TEMPERATURE_HISTORY}
#: lists of rows of finite numbers, empty in a fresh monitor (effect_wear's duty buckets: index then sums; the
#: work gradient at each measurement)
NUMBER_ROWS = frozenset({"buckets", "measurement_gradients", "pass_open_buckets"})
#: of those, the rows led by a duty bucket's index (an integer)
INDEXED_ROWS = frozenset({"buckets", "pass_open_buckets"})
_INT64 = 2**63


def _is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _is_int(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool) and -_INT64 <= value < _INT64


def _kind(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, numbers.Integral):
        return "an integer"
    if _is_number(value):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, (list, tuple)):
        return "a list"
    if isinstance(value, dict):
        return "a mapping"
    return type(value).__name__


def _field(where: str) -> str:
    """The field name of a path such as ``state.estimator.measurement_m[3]``."""
    return where.rsplit(".", 1)[-1].split("[", 1)[0]


def _scalar_problem(value: Any, template: Any, where: str) -> str:
    """'' when ``value`` fits the template's kind, else what it must be. An integer field takes 64-bit
    integers; a number field any number, finite where the fresh value is finite (NaN/inf only where they
    are the 'not yet known' marker); a template None (not yet known) takes None or a finite number (an
    integer for a ``*_t_ns`` stamp, of any sign: which stamps are valid is the input rules' business); sums
    of non-negative terms (NON_NEGATIVE) are >= 0."""
    name = _field(where)
    stamp = name.endswith("_t_ns")
    if template is None:
        if value is None:
            return ""
        template = 0 if stamp else 0.0
    if isinstance(template, bool):
        return "" if isinstance(value, bool) else "true/false"
    if isinstance(template, str):
        return "" if isinstance(value, str) else "a string"
    if isinstance(template, numbers.Integral):
        if not _is_int(value):
            return "a 64-bit integer"
    elif _is_number(template):
        if not _is_number(value):
            return "a number"
        if math.isfinite(template) and not math.isfinite(value):
            return "a finite number"
    else:
        return f"of the kind {_kind(template)}"
    if name in NON_NEGATIVE and not value >= 0:
        return "a number >= 0"
    return ""


def _check_list(value: list, template: list, where: str) -> None:
    lengths = STATE_LIST_LENGTHS.get(_field(where))
    if template and len(value) != len(template) and not (lengths and len(value) in lengths):
        raise InputError(f"state field {where} has {len(value)} entries, the parameters need {len(template)}")
    if not template and _field(where) in NUMBER_ROWS:
        for i, row in enumerate(value):
            if not isinstance(row, (list, tuple)) or not all(_is_number(v) and math.isfinite(v) for v in row):
                raise InputError(f"state field {where}[{i}] must be a list of finite numbers, got {row!r}"[:200])
            if _field(where) in INDEXED_ROWS and not _is_int(row[0] if row else None):
                raise InputError(f"state field {where}[{i}] must start with a bucket index (an integer), "
                                 f"got {row[0] if row else None!r}"[:200])
            if lengths and (len(row) not in lengths or len(row) != len(value[0])):
                raise InputError(f"state field {where}[{i}] has {len(row)} numbers, rows have "
                                 f"{' or '.join(map(str, lengths))}, all alike")
        return
    element = template[0] if template else EMPTY_LIST_ELEMENT.get(_field(where), 0.0)
    for i, item in enumerate(value):
        if isinstance(element, (dict, list)):
            check_state_like(item, element, f"{where}[{i}]")
            continue
        problem = _scalar_problem(item, element, where)
        if problem:
            raise InputError(f"state field {where}[{i}] must be {problem}, got {item!r}"[:200])


def check_state_like(value: Any, template: Any, where: str = "state") -> None:
    """InputError (one line: the field and what it must be) unless ``value`` has the structure and kinds
    of ``template``."""
    if isinstance(template, dict):
        if not isinstance(value, dict):
            raise InputError(f"state field {where} must be a mapping, got {_kind(value)}")
        missing = [k for k in template if k not in value and k not in ADDED_FIELDS]
        extra = [k for k in value if k not in template]
        if missing:
            raise InputError(f"state field {where}.{missing[0]} is missing")
        if extra:
            raise InputError(f"state field {where}.{str(extra[0])[:40]!s} is not a field of this monitor")
        for key, sub in template.items():
            if key in value:
                check_state_like(value[key], sub, f"{where}.{key}")
        parallel = PARALLEL_LISTS.get(_field(where), ())
        for name in parallel[1:]:
            if name in value and parallel[0] in value and len(value[name]) != len(value[parallel[0]]):
                raise InputError(f"state field {where}.{name}: its length differs from {where}.{parallel[0]}")
    elif isinstance(template, (list, tuple)) and _field(where) in STAMP_ORDERED_LISTS:
        if not isinstance(value, (list, tuple)):
            raise InputError(f"state field {where} must be a list, got {_kind(value)}")
        _check_list(list(value), list(template), where)
        if len(value) > STAMP_ORDERED_LISTS[_field(where)]:
            raise InputError(f"state field {where} has {len(value)} entries, at most "
                             f"{STAMP_ORDERED_LISTS[_field(where)]}")
        if any(b < a for a, b in zip(value, value[1:])):
            raise InputError(f"state field {where} is not in stamp order")
    elif isinstance(template, (list, tuple)):
        if not isinstance(value, (list, tuple)):
            raise InputError(f"state field {where} must be a list, got {_kind(value)}")
        _check_list(list(value), list(template), where)
    else:
        problem = _scalar_problem(value, template, where)
        if problem:
            raise InputError(f"state field {where} must be {problem}, got {value!r}"[:200])


def check_precision_state(saved: Any, template: dict[str, Any]) -> None:
    """A saved PrecisionMonitor state against ``template`` (a fresh monitor's ``state()``): the guide type
    first (a rolling-guide state for a sliding guide is another guide), then every field."""
    if not isinstance(saved, dict):
        raise InputError(f"state must be a mapping, got {_kind(saved)}")
    if saved.get("version") != template.get("version"):
        raise InputError(f"state version {saved.get('version')!r}, this monitor reads version "
                         f"{template.get('version')!r}")
    rolling_saved, rolling_now = saved.get("rolling"), template.get("rolling")
    if (rolling_saved is None) != (rolling_now is None):
        kinds = ("a sliding", "a rolling") if rolling_now is not None else ("a rolling", "a sliding")
        raise InputError(f"state of {kinds[0]} guide, but guide_type is {kinds[1]} guide")
    check_state_like(saved, template)
