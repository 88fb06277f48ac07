"""The parameter walk: the modules ("rooms") the wear parameters are handed through, from the loader to the
physics and back to the report, and how often the walk returns to a room it had left.

A replay of a short simulated bench run (config/bench_000.yaml with the live effects running_in and
thermal_drift) is traced with ``sys.setprofile``: every call that receives the wear parameters as an argument
(a mapping or an object holding at least ``--min-names`` wear_monitor parameter names: the loader's dict, a
copy of it, a typed parameter object), or whose code reads ``.params`` of an argument that holds them (a model
method reading its ``self.params``), is a step into the callee's module. Consecutive steps in one module are
one visit. Printed: rooms (distinct modules), returns (visits to a module already visited and left) and the
walk itself, whole and from the loader's result on (the steps outside params/). Only the parameter sets are
followed, not the numbers taken out of them (a model that takes a plain number is where the walk ends).

    PYTHONPATH=$PWD python bench/parameter_walk.py           # this tree
    PYTHONPATH=/work/main python bench/parameter_walk.py     # another tree, for before/after
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def is_parameter_set(value, names: set[str], min_names: int) -> bool:
    """A mapping or a (dataclass) object holding at least ``min_names`` of ``names``; a model's own input
    dataclass (defined under guide_health/models, e.g. EffectParameters) is not one: it is where a walk ends."""
    if isinstance(value, dict):
        keys = value.keys()
    elif (dataclasses.is_dataclass(value) and not isinstance(value, type)
          and not type(value).__module__.startswith("guide_health.models")):
        keys = (f.name for f in dataclasses.fields(value))
    else:
        return False
    return sum(1 for k in keys if k in names) >= min_names


def walk(steps: list[str]) -> tuple[list[str], int, int]:
    """(visits: consecutive steps in one module merged, rooms, returns) of a list of modules."""
    visits = [m for i, m in enumerate(steps) if i == 0 or steps[i - 1] != m]
    returns = sum(1 for i, m in enumerate(visits) if m in visits[:i])
    return visits, len(set(visits)), returns


def trace(min_names: int) -> list[str]:
    """The modules of the calls that received the wear parameters, in call order, during load + replay."""
    import guide_health
    from guide_health.analysis.replay import analyse
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.params.wear_monitor import WEAR_MONITOR_SCHEMA
    from guide_health.sim.machine import simulate_machine

    config = ROOT / "config" / "bench_000.yaml"
    sim = simulation_params(config)
    sim.update(duration_h=2.0, joint_state_rate_hz=20.0, measurement_interval_h=0.5)
    base = dict(wear_monitor_params(config), effects="running_in,thermal_drift")
    run = simulate_machine(base, sim, seed=1)
    names = {p.name for p in WEAR_MONITOR_SCHEMA.params}
    package = Path(guide_health.__file__).parent     # the tree on PYTHONPATH
    steps: list[str] = []

    def profile(frame, event, _arg):
        if event != "call" or not frame.f_code.co_filename.startswith(str(package)):
            return
        code = frame.f_code
        args = [frame.f_locals.get(n) for n in code.co_varnames[:code.co_argcount + code.co_kwonlyargcount]]
        holds = any(is_parameter_set(a, names, min_names) for a in args) or (
            "params" in code.co_names and any(is_parameter_set(getattr(a, "params", None), names, min_names)
                                              for a in args if not isinstance(a, (dict, type(None)))))
        if holds:
            steps.append(str(Path(code.co_filename).relative_to(package.parent)))

    sys.setprofile(profile)
    try:
        params = wear_monitor_params(config)
        params["effects"] = "running_in,thermal_drift"
        _, report = analyse(run, params)
    finally:
        sys.setprofile(None)
    assert report["measurements"] > 0
    return steps


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--min-names", type=int, default=10, help="parameter names that make a parameter set")
    args = ap.parse_args(argv)
    steps = trace(args.min_names)
    visits, rooms, returns = walk(steps)
    print(f"whole walk: rooms {rooms}  returns {returns}  visits {len(visits)}")
    visits, rooms, returns = walk([m for m in steps if not m.startswith("guide_health/params/")])
    print(f"after the loader: rooms {rooms}  returns {returns}  visits {len(visits)}")
    for module in visits:
        print(f"  {module}")


if __name__ == "__main__":
    main()
