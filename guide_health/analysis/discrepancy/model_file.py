"""``diagnose --out DIR`` writes DIR/model.yaml: what the workflow learnt, as wear_monitor parameters.

A ROS 2 parameters file (``wear_monitor: ros__parameters:``) with the calibrated K, the A0 the fit used,
the named effects the live model integrates (``effects`` and their parameters, params/wear_monitor.py) and
the covariance of the fitted K and effect parameters (6 x 6, models/wear/effect_wear.COVARIANCE_NAMES).
Load it after the base file, the later overriding, as ROS merges several ``--params-file``:

    guide-health replay BAG --params config/bench_000.yaml --params DIR/model.yaml
    ros2 run guide_health wear_monitor --ros-args --params-file base.yaml --params-file DIR/model.yaml

Effects the live model cannot integrate (thermal_drift: a measurement term; stroke_distribution: the
pass-length weighting) are listed in a comment, not applied; initial_offset is folded into A0.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from guide_health.io.output_files import write_text
from guide_health.models.wear.effect_wear import COVARIANCE_NAMES
from guide_health.params import validate_wear_params
from guide_health.params.wear_monitor import LIVE_EFFECT_IDS

EFFECT_PARAMETERS = {
    "running_in": ("running_in_ratio", "running_in_distance_m"),
    "retract_asymmetry": ("retract_wear_factor",),
    "speed_dependent_wear": ("lift_speed_m_s",),
    "load_exponent": ("load_exponent",),
}


def model_parameters(problem, final, named: list[str]) -> dict[str, Any]:
    """The wear_monitor parameters of a fitted model (``problem``: WearProblem, ``final``: its FitResult)."""
    v = final.values
    a0 = v.get("straightness_initial_m", problem.a0_m) if problem.a0_free else problem.a0_m
    a0 += v.get("initial_offset_m", 0.0)
    live = [e for e in named if e in LIVE_EFFECT_IDS]
    out: dict[str, Any] = {
        "wear_coefficient": float(v["wear_coefficient"]),
        "straightness_initial_m": float(max(a0, 0.0)),
        "effects": ",".join(live),
        "load_reference_n": float(problem.load_reference_n),
        "retract_direction": "+x" if problem.retract_sign > 0 else "-x",
    }
    for e in live:
        for name in EFFECT_PARAMETERS[e]:
            out[name] = float(v[name])
    cov = final.extra.get("covariance")
    matrix = np.zeros((len(COVARIANCE_NAMES), len(COVARIANCE_NAMES)))
    if cov is not None:
        index = {n: i for i, n in enumerate(cov["names"])}
        keep = [n for n in COVARIANCE_NAMES if n in index and (n == "wear_coefficient" or n in out)]
        for a in keep:
            for b in keep:
                matrix[COVARIANCE_NAMES.index(a), COVARIANCE_NAMES.index(b)] = cov["matrix"][index[a], index[b]]
    out["effect_covariance"] = [float(x) if math.isfinite(x) else 0.0 for x in matrix.ravel()]
    return out


def write_model_file(path: Path, base_params: dict[str, Any], model: dict[str, Any], named: list[str],
                     source: str = "") -> None:
    """DIR/model.yaml; the merged parameters (base then model) are validated first."""
    validate_wear_params({**base_params, **model})
    not_live = [e for e in named if e not in LIVE_EFFECT_IDS and e != "initial_offset"]
    header = [f"# guide-health diagnose {source}: the model it learnt, as wear_monitor parameters.",
              "# Load after the base parameters: --params BASE --params model.yaml (replay, diagnose) or",
              "# --params-file BASE --params-file model.yaml (wear_monitor); the later file overrides.",
              f"# effect_covariance: 6 x 6 row-major over {', '.join(COVARIANCE_NAMES)}."]
    if not_live:
        header.append(f"# named but not integrated live: {', '.join(not_live)}")
    body = yaml.safe_dump({"wear_monitor": {"ros__parameters": model}}, sort_keys=False, width=200)
    write_text(path, "\n".join(header) + "\n" + body)
