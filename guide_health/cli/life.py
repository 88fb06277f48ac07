"""`guide-health life MODE ...`: rolling-guide rating life, Miner consumption, and C from life tests.

Modes (nested sub-commands; ``--json`` may go before or after the mode's options):

* ``rating``  -- L = (fh ft fc C / (fw P))^p x L_ref and C converted between 50 km and 100 km ratings.
* ``test``    -- C_test / C from one test life at F = fraction x C (seed 004 Eq. 5).
* ``weibull`` -- Weibull ML fit of interval-censored failure mileages (CSV), B10 and C_test / C with CI,
  next to the seed's equal-spacing estimate.
* ``miner``   -- equivalent load and Miner life consumption of a duty (CSV ``travel_m,load_n``).
"""
from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path
from typing import Any

import numpy as np

from guide_health.analysis.life_test import (
    SINGLE_SPECIMEN_WEIBULL_SHAPE,
    LifeTestLoad,
    c_ratio_alternatives,
    equal_spacing_refit,
    life_test_readings,
)
from guide_health.cli.command import Command, value_errors_as_input_errors
from guide_health.cli.text import format_key_values
from guide_health.errors import InputError
from guide_health.models.rolling import rating_life as lm
from guide_health.models.rolling import weibull
from guide_health.models.rolling.iso_rating import B_M, LAMBDA_REDUCTION, ball_guide_dynamic_rating_n
from guide_health.params import SCHEMAS, WEAR_MONITOR_DEFAULTS, load_node_params
from guide_health.params.typed import typed_params


class _OneLineParser(argparse.ArgumentParser):
    """Mode parser whose usage errors are one line on stderr (exit 2), like InputError."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message}\n")


def _add_rating_options(p: argparse.ArgumentParser, element_default: str | None = lm.BALL) -> None:
    p.add_argument("--element", choices=(lm.BALL, lm.ROLLER), default=element_default,
                   help="rolling element: ball (p = 3) or roller (p = 10/3)"
                        + ("" if element_default else "; default from --params, else ball"))
    p.add_argument("--rating-distance-km", type=float, default=None, metavar="KM",
                   help="reference travel L_ref of C: 50 (catalogues, seed 004; default) or 100 (ISO 14728-1)")
    p.add_argument("--exponent", type=float, default=None, metavar="P",
                   help="override the load-life exponent p (default 3 ball, 10/3 roller)")
    p.add_argument("--factors", type=float, nargs=4, default=None, metavar=("FH", "FT", "FC", "FW"),
                   help="life factors fh ft fc fw (default 1 1 1 1)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    modes = parser.add_subparsers(dest="life_mode", metavar="MODE", required=True,
                                  parser_class=_OneLineParser)

    def mode(name: str, help_text: str) -> argparse.ArgumentParser:
        p = modes.add_parser(name, help=help_text, description=help_text)
        # default SUPPRESS: a --json given before the mode is not reset by the mode parser
        p.add_argument("--json", action="store_true", default=argparse.SUPPRESS,
                       help="print exactly one JSON object on stdout")
        return p

    p = mode("rating", "rating life L = (fh ft fc C / (fw P))^p x L_ref (ISO 14728-1 / catalogue form)")
    p.add_argument("--c-n", type=float, default=None, metavar="N",
                   help="dynamic load rating C [N] for --rating-distance-km (or dynamic_load_rating_n from --params)")
    p.add_argument("--load-n", type=float, required=True, metavar="N", help="equivalent load P [N]")
    p.add_argument("--params", default=None, metavar="FILE",
                   help="wear_monitor parameters YAML (C, rolling_element, life_factors, rating_distance_km)")
    _add_rating_options(p, element_default=None)

    p = mode("test", "C_test / C from one life-test result (seed 004 Eq. 5), or from a life-test BAG")
    p.add_argument("bag", nargs="*", default=[], metavar="BAG[=PARAMS]",
                   help="life-test bag(s): the failure travel is detected from the sound level and vibration "
                        "(docs/vibration.md; --params gives the vibration_monitor section, BAG=PARAMS a rig's own "
                        "file for that bag, or for every bag inside a directory BAG); several bags = several "
                        "specimens -> one interval-censored Weibull fit, B10 and C_test / C per rig")
    p.add_argument("--travel-offset-km", type=float, default=None, metavar="KM",
                   help="with BAG: travel of the specimen before the recording (default travel_offset_km)")
    p.add_argument("--start-stamp", type=float, default=None, metavar="UNIX_S",
                   help="with BAG: the stamp of travel 0 [s] (default test_start_time_s, else the first stamp)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="with BAG: write <bag>_life_test.png (noise vs travel, spectrogram with the defect "
                        "frequency marked) into DIR")
    p.add_argument("--params", default=None, metavar="FILE",
                   help="parameters YAML: vibration_monitor section (with BAG); a wear_monitor section adds the "
                        "geometry check of its C (ISO 14728-1 / Lundberg-Palmgren, b_m = 1.3)")
    p.add_argument("--load-fraction", type=float, default=None, metavar="F_OVER_C",
                   help="test load as a fraction of the catalogue C (e.g. 0.30)")
    p.add_argument("--life-km", type=float, default=None, metavar="KM", help="test life [km] (without BAG)")
    p.add_argument("--weibull-shape", type=float, default=None, metavar="BETA",
                   help="also treat the single life as a median and convert it to B10 with this Weibull shape "
                        f"(the readings table uses it too; default there {SINGLE_SPECIMEN_WEIBULL_SHAPE})")
    _add_rating_options(p)

    p = mode("weibull", "Weibull fit of interval-censored failure mileages, B10 and C_test / C with CI")
    p.add_argument("csv", metavar="CSV",
                   help="columns lower_km,upper_km (upper empty or inf = survived) or failure_interval "
                        "(1-based inspection number); optional count")
    p.add_argument("--interval-km", type=float, default=None, metavar="KM",
                   help="inspection interval [km] (seed 004: 5), needed for failure_interval")
    p.add_argument("--load-fraction", type=float, default=None, metavar="F_OVER_C",
                   help="test load / catalogue C: adds C_test / C from B10")
    p.add_argument("--confidence", type=float, default=0.90, help="two-sided confidence (default 0.90)")
    p.add_argument("--ci-method", choices=("profile", "wald"), default="profile",
                   help="profile likelihood (default) or Wald/delta method on log scale")
    _add_rating_options(p)

    p = mode("miner", "equivalent load and Miner life consumption of a duty")
    p.add_argument("csv", metavar="CSV", help="columns travel_m (increments, >= 0) and load_n")
    p.add_argument("--c-n", type=float, default=None, metavar="N",
                   help="dynamic load rating C [N] (or dynamic_load_rating_n from --params)")
    p.add_argument("--params", default=None, metavar="FILE",
                   help="wear_monitor parameters YAML (C, rolling_element, life_factors, rating_distance_km)")
    p.add_argument("--recent-window-m", type=float, default=0.0, metavar="M",
                   help="remaining life at the duty of the last ~M metres (exponential weight); 0 = whole CSV")
    _add_rating_options(p, element_default=None)


# ------------------------------------------------------------------------------------------------

def _positive(value: float | None, name: str) -> float:
    if value is None or not (math.isfinite(value) and value > 0):
        raise InputError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


def _rating_setup(args, from_params: bool) -> dict:
    """C, element, exponent, L_ref, factors from the options (over --params when given)."""
    loaded = {}
    if from_params and getattr(args, "params", None):
        loaded = load_node_params(args.params, "wear_monitor", WEAR_MONITOR_DEFAULTS)
    params = typed_params("wear_monitor", loaded, validate=False)     # without --params: the schema defaults
    element = args.element or params.rolling_element
    if element not in (lm.BALL, lm.ROLLER):
        raise InputError(f"rolling_element must be 'ball' or 'roller', got {element!r}")
    l_ref = args.rating_distance_km if args.rating_distance_km is not None else params.rating_distance_km
    l_ref = _positive(l_ref, "--rating-distance-km")
    exponent = lm.life_exponent(element) if args.exponent is None else _positive(args.exponent, "--exponent")
    factors = args.factors if args.factors is not None else params.life_factors
    factors = [float(f) for f in factors]
    if len(factors) != 4 or not all(math.isfinite(f) and f > 0 for f in factors):
        raise InputError(f"life factors fh ft fc fw must be 4 numbers > 0, got {factors}")
    out = {"element": element, "exponent": exponent, "rating_distance_km": l_ref, "life_factors": factors}
    if hasattr(args, "c_n"):
        if args.c_n is not None:
            _positive(args.c_n, "--c-n")
        c = args.c_n if args.c_n is not None else params.dynamic_load_rating_n
        if c is None or not c > 0:
            raise InputError("dynamic load rating needed: --c-n N or dynamic_load_rating_n > 0 in --params")
        out["c_n"] = _positive(c, "--c-n")
    return out


def _read_csv(path: str) -> tuple[list[str], list[dict[str, str]]]:
    p = Path(path)
    if not p.is_file():
        raise InputError(f"CSV not found: {path}")
    with p.open(newline="") as fh:
        reader = csv.DictReader(fh)
        if not reader.fieldnames:
            raise InputError(f"{path}: empty CSV (a header row is needed)")
        header = [h.strip() for h in reader.fieldnames]
        reader.fieldnames = header
        rows = [r for r in reader if any((v or "").strip() for v in r.values() if isinstance(v, str))]
    if not rows:
        raise InputError(f"{path}: no data rows")
    return header, rows


def _cell(path: str, line: int, name: str, text: str | None, allow_empty_inf: bool = False) -> float:
    text = (text or "").strip()
    if text == "" and allow_empty_inf:
        return math.inf
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{path}: line {line}: {name} is not a number: {text!r}") from None
    if math.isnan(value) or (math.isinf(value) and not allow_empty_inf):
        raise InputError(f"{path}: line {line}: {name} must be a finite number, got {text!r}")
    return value


def _run_rating(args) -> dict:
    s = _rating_setup(args, from_params=True)
    load = args.load_n
    if load is None or not math.isfinite(load) or load < 0:
        raise InputError(f"--load-n must be a finite number >= 0, got {load!r}")
    life = lm.rating_life_km(s["c_n"], load, s["element"], s["rating_distance_km"], s["life_factors"],
                             s["exponent"])
    c50 = lm.convert_rating_n(s["c_n"], s["rating_distance_km"], 50.0, exponent=s["exponent"])
    c100 = lm.convert_rating_n(s["c_n"], s["rating_distance_km"], 100.0, exponent=s["exponent"])
    return {"mode": "rating", "rating_life_km": life, "c_n": s["c_n"], "load_n": float(load),
            "load_ratio": float(load) / (lm.factor_ratio(s["life_factors"]) * s["c_n"]),
            "element": s["element"], "exponent": s["exponent"],
            "rating_distance_km": s["rating_distance_km"], "life_factors": s["life_factors"],
            "c_50km_n": c50, "c_100km_n": c100}


def _test_load(load_fraction: float, s: dict) -> LifeTestLoad:
    return LifeTestLoad(load_fraction, s["rating_distance_km"], s["exponent"], s["life_factors"])


def _bag_params(args, text: str) -> tuple[str, Any]:
    """(bag, its vibration_monitor parameters): BAG=FILE takes FILE, else --params, else the defaults; the
    command line's --load-fraction over either."""
    bag, _, own = text.partition("=")
    section = SCHEMAS["vibration_monitor"]
    source = own or args.params
    loaded = load_node_params(source, section.section, section.defaults()) if source else {}
    if args.load_fraction is not None:
        loaded["load_fraction"] = _positive(args.load_fraction, "--load-fraction")
    return bag, typed_params(section.section, loaded, validate=False)


def _bags(args) -> list[tuple[str, Any]]:
    """Every bag with its parameters; a directory given as BAG=FILE holding bags (no metadata.yaml of its own)
    stands for each bag inside it."""
    out = []
    for text in args.bag:
        bag, p = _bag_params(args, text)
        d = Path(bag)
        if d.is_dir() and not (d / "metadata.yaml").exists():
            inner = sorted(x for x in d.iterdir() if (x / "metadata.yaml").exists())
            if not inner:
                raise InputError(f"{bag}: neither a bag nor a directory of bags")
            out.extend((str(x), p) for x in inner)
        else:
            out.append((bag, p))
    return out


def _run_test_bag(args) -> dict:
    from guide_health.analysis.life_signs import (
        life_test_from_data,
        read_life_test_bag,
        specimen_interval_km,
        weibull_of_rigs,
    )

    offset = None if args.travel_offset_km is None else _non_negative(args.travel_offset_km, "--travel-offset-km")
    start_ns = None if args.start_stamp is None else int(round(_positive(args.start_stamp, "--start-stamp") * 1e9))
    out_dir = None if args.out is None else Path(args.out)
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
    specimens, ps = [], []
    for bag, p in _bags(args):
        data = read_life_test_bag(bag)
        one = {"bag": bag} | life_test_from_data(bag, data, p, offset, start_ns)
        if out_dir is not None:
            from guide_health.analysis.life_plots import plot_life_test

            png = out_dir / f"{Path(bag).name}_life_test.png"
            keep = [i for i, c in enumerate(data["channels"]) if c == one["channel"]]      # the reported channel
            shown = data | {k: [data[k][i] for i in keep] for k in ("block_t_ns", "blocks")}
            one["png"] = str(plot_life_test(png, shown, one, p, title=f"{Path(bag).name}: life test (seed 004)"))
        specimens.append(one)
        ps.append(p)
    if len(specimens) == 1:
        out = {"mode": "test"} | specimens[0]
        if out.get("failure_travel_km") is not None:
            out |= life_test_readings(ps[0].load_fraction, out["failure_travel_km"], [1.0] * 4, _shape(args))
        return out | _geometry_check(args)
    intervals = [specimen_interval_km(s) for s in specimens]
    if not any(math.isfinite(u) for _, u in intervals):
        raise InputError(f"no failure detected in any of the {len(intervals)} bags: no Weibull fit")
    fit = weibull_of_rigs(intervals, ps)
    for one, rig in zip(specimens, fit["rigs"]):
        one["rig"] = rig
    return {"mode": "test", "specimens": specimens, "intervals_km": [list(i) for i in intervals],
            "weibull": fit, "c_ratio": fit["c_ratio"], "c_ratio_ci": fit["c_ratio_ci"],
            "c_ratio_per_rig": [r["c_ratio"] for r in fit["rigs"]],
            "load_fraction": ps[0].load_fraction} | _geometry_check(args)


def _non_negative(value: float, name: str) -> float:
    if not (math.isfinite(value) and value >= 0):
        raise InputError(f"{name} must be a finite number >= 0, got {value!r}")
    return float(value)


def _shape(args) -> float:
    return SINGLE_SPECIMEN_WEIBULL_SHAPE if args.weibull_shape is None else _positive(args.weibull_shape,
                                                                                      "--weibull-shape")


def _geometry_check(args) -> dict:
    """C from the wear_monitor geometry of --params (when the file has that section) next to its catalogue C."""
    if not args.params:
        return {}
    g = typed_params("wear_monitor", load_node_params(args.params, "wear_monitor", WEAR_MONITOR_DEFAULTS,
                                                      required=False), validate=False)
    if g.guide_type != "rolling" or g.rolling_element != lm.BALL:
        return {}
    l_ref = g.rating_distance_km
    c_geo = ball_guide_dynamic_rating_n(2 * g.ball_radius_m, g.groove_conformity, g.contact_angle_deg,
                                        g.balls_per_row, l_ref)
    c_low = ball_guide_dynamic_rating_n(2 * g.ball_radius_m, g.groove_conformity, g.contact_angle_deg,
                                        g.balls_per_row, l_ref, lam=0.7)
    catalogue = float(g.dynamic_load_rating_n)
    return {"c_geometry_n": c_geo, "c_geometry_lambda_0p7_n": c_low, "c_geometry_b_m": B_M,
            "c_geometry_lambda": LAMBDA_REDUCTION, "c_geometry_rating_distance_km": l_ref,
            "c_catalogue_n": catalogue,
            "c_catalogue_over_geometry": catalogue / c_geo if catalogue > 0 else float("nan")}


def _run_test(args) -> dict:
    if args.bag:
        return _run_test_bag(args)
    if args.out is not None or args.travel_offset_km is not None or args.start_stamp is not None:
        raise InputError("--out, --travel-offset-km and --start-stamp need a life-test BAG")
    if args.life_km is None or args.load_fraction is None:
        raise InputError("life test needs --load-fraction and --life-km (or a life-test BAG)")
    s = _rating_setup(args, from_params=False)
    frac = _positive(args.load_fraction, "--load-fraction")
    life = _positive(args.life_km, "--life-km")
    test_load = _test_load(frac, s)
    out = {"mode": "test", "c_ratio": test_load.c_ratio(life), "load_fraction": frac, "life_km": life,
           "element": s["element"], "exponent": s["exponent"], "rating_distance_km": s["rating_distance_km"],
           "life_factors": s["life_factors"], "alternatives": c_ratio_alternatives(frac, life, s["life_factors"])}
    out |= life_test_readings(frac, life, s["life_factors"], _shape(args)) | _geometry_check(args)
    if args.weibull_shape is not None:
        beta = _positive(args.weibull_shape, "--weibull-shape")
        b10 = lm.median_to_b_life(life, beta)
        out.update({"weibull_shape": beta, "b10_from_median_km": b10, "c_ratio_b10": test_load.c_ratio(b10)})
    return out


def _weibull_rows(args) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    header, rows = _read_csv(args.csv)
    has_count = "count" in header
    counts = np.array([_cell(args.csv, i + 2, "count", r.get("count")) if has_count else 1.0
                       for i, r in enumerate(rows)])
    if np.any(counts < 0) or np.any(counts != np.round(counts)):
        raise InputError(f"{args.csv}: count must be a whole number >= 0")
    if "lower_km" in header and "upper_km" in header:
        lo = np.array([_cell(args.csv, i + 2, "lower_km", r.get("lower_km")) for i, r in enumerate(rows)])
        up = np.array([_cell(args.csv, i + 2, "upper_km", r.get("upper_km"), allow_empty_inf=True)
                       for i, r in enumerate(rows)])
        bad = np.flatnonzero((lo < 0) | (up < lo) | ((up == lo) & (lo == 0)))
        if bad.size:
            raise InputError(f"{args.csv}: line {bad[0] + 2}: need 0 <= lower_km < upper_km "
                             "(or lower_km == upper_km > 0 for an exact failure)")
    elif "failure_interval" in header:
        if args.interval_km is None:
            raise InputError("failure_interval rows need --interval-km (seed 004 inspects every 5 km)")
        interval = _positive(args.interval_km, "--interval-km")
        j = np.array([_cell(args.csv, i + 2, "failure_interval", r.get("failure_interval"))
                      for i, r in enumerate(rows)])
        bad = np.flatnonzero((j < 1) | (j != np.round(j)))
        if bad.size:
            raise InputError(f"{args.csv}: line {bad[0] + 2}: failure_interval must be a whole number >= 1")
        lo, up = weibull.intervals_from_index(j, interval)
    else:
        raise InputError(f"{args.csv}: need columns lower_km,upper_km or failure_interval "
                         f"(found {','.join(header)})")
    return lo, up, counts


def _run_weibull(args) -> dict:
    s = _rating_setup(args, from_params=False)
    if not 0 < args.confidence < 1:
        raise InputError(f"--confidence must be in (0, 1), got {args.confidence}")
    frac = None if args.load_fraction is None else _positive(args.load_fraction, "--load-fraction")
    lo, up, counts = _weibull_rows(args)
    try:
        fit = weibull.fit_weibull(lo, up, counts, confidence=args.confidence, ci_method=args.ci_method)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    out = {"mode": "weibull", "n": fit.n, "failures": fit.failures, "suspended": fit.n - fit.failures,
           "shape": fit.shape, "shape_ci": list(fit.shape_ci), "scale_km": fit.scale_km,
           "scale_ci_km": list(fit.scale_ci_km), "b10_km": fit.b_life_km, "b10_ci_km": list(fit.b_life_ci_km),
           "confidence": fit.confidence, "ci_method": fit.ci_method, "log_likelihood": fit.log_likelihood,
           "element": s["element"], "exponent": s["exponent"], "rating_distance_km": s["rating_distance_km"]}
    test_load = None if frac is None else _test_load(frac, s)
    if test_load is not None:
        out["load_fraction"] = frac
        out["c_ratio"] = test_load.c_ratio(fit.b_life_km)
        out["c_ratio_ci"] = [test_load.c_ratio(v) for v in fit.b_life_ci_km]
    out["equal_spacing"] = equal_spacing_refit(lo, up, counts, args.confidence, test_load)
    return out


def _run_miner(args) -> dict:
    s = _rating_setup(args, from_params=True)
    window = args.recent_window_m
    if not (math.isfinite(window) and window >= 0):
        raise InputError(f"--recent-window-m must be >= 0, got {window}")
    header, rows = _read_csv(args.csv)
    if "travel_m" not in header or "load_n" not in header:
        raise InputError(f"{args.csv}: need columns travel_m,load_n (found {','.join(header)})")
    ds = np.array([_cell(args.csv, i + 2, "travel_m", r.get("travel_m")) for i, r in enumerate(rows)])
    f = np.array([_cell(args.csv, i + 2, "load_n", r.get("load_n")) for i, r in enumerate(rows)])
    bad = np.flatnonzero(ds < 0)
    if bad.size:
        raise InputError(f"{args.csv}: line {bad[0] + 2}: travel_m must be >= 0 (increments |dx|)")
    summ = lm.miner_summary(ds, f, s["c_n"], s["element"], s["rating_distance_km"], s["life_factors"],
                            window, s["exponent"])
    return {"mode": "miner", "equivalent_load_n": summ.equivalent_load_n,
            "rating_life_km": summ.rating_life_km, "travel_km": summ.travel_km,
            "life_used_fraction": summ.life_used_fraction, "remaining_life_km": summ.remaining_life_km,
            "duty_load_n": summ.duty_load_n, "samples": int(ds.size), "c_n": s["c_n"],
            "element": s["element"], "exponent": s["exponent"], "rating_distance_km": s["rating_distance_km"],
            "life_factors": s["life_factors"], "recent_window_m": window}


def run(args) -> dict:
    handlers = {"rating": _run_rating, "test": _run_test, "weibull": _run_weibull, "miner": _run_miner}
    with value_errors_as_input_errors():
        return handlers[args.life_mode](args)


def format_text(result: dict) -> str:
    """Key: value lines, numbers (also inside lists) to 6 significant digits."""
    return format_key_values(result, compact_lists=True)


LIFE = Command(add_arguments, run, format_text)
