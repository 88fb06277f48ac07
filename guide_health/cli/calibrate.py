"""`guide-health calibrate pin-on-disc CSV --hardness-pa H`: K from pin-on-disc wear rates."""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from guide_health.cli.command import Command
from guide_health.errors import InputError
from guide_health.models.wear.calibration import fit_pin_on_disc

REQUIRED = ("speed_m_s", "load_n", "wear_rate_m3_s")


def add_arguments(parser) -> None:
    parser.add_argument("csv", help="CSV with a header holding at least speed_m_s,load_n,wear_rate_m3_s")
    parser.add_argument("--hardness-pa", type=float, required=True,
                        help="hardness H of the worn material [Pa] (HT200: 199e6)")
    parser.add_argument("--wear-law", action="store_true",
                        help="also ask the discrepancy workflow's selection (BIC + leave-one-out) whether a "
                             "load or speed exponent earns its place in gamma = c W v")


def read_rows(path: str) -> dict[str, np.ndarray]:
    p = Path(path)
    if not p.is_file():
        raise InputError(f"CSV not found: {p}")
    with p.open(newline="") as handle:
        reader = csv.DictReader(handle)
        missing = [c for c in REQUIRED if c not in (reader.fieldnames or [])]
        if missing:
            raise InputError(f"{p}: missing column(s) {', '.join(missing)}")
        columns: dict[str, list[float]] = {c: [] for c in REQUIRED}
        for line, row in enumerate(reader, start=2):
            for c in REQUIRED:
                try:
                    columns[c].append(float(row[c]))
                except (TypeError, ValueError):
                    raise InputError(f"{p}:{line}: {c} = {row[c]!r} is not a number") from None
    return {c: np.asarray(v) for c, v in columns.items()}


def run(args) -> dict:
    if not (args.hardness_pa > 0 and np.isfinite(args.hardness_pa)):
        raise InputError("--hardness-pa must be a positive number")
    rows = read_rows(args.csv)
    try:
        fit = fit_pin_on_disc(rows["speed_m_s"], rows["load_n"], rows["wear_rate_m3_s"], args.hardness_pa)
    except ValueError as exc:
        raise InputError(f"{args.csv}: {exc}") from None
    result = {
        "wear_coefficient": fit.wear_coefficient,
        "wear_coefficient_ci95": list(fit.wear_coefficient_ci95),
        "wear_rate_per_load_speed": fit.wear_rate_per_load_speed,
        "r_squared": fit.r_squared,
        "r_squared_uncentred": fit.r_squared_uncentred,
        "rows": fit.rows,
        "regression": "ordinary least squares through the origin, gamma = c W v; K = c H",
    }
    if args.wear_law:
        from guide_health.analysis.discrepancy.selection import select_pin_on_disc_law
        result["wear_law"] = select_pin_on_disc_law(rows["speed_m_s"], rows["load_n"], rows["wear_rate_m3_s"])
    return result


PIN_ON_DISC = Command(add_arguments, run)
