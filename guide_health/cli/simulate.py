"""`guide-health simulate`: write a rosbag2 bag of a simulated machine run."""
from __future__ import annotations

import math
import shutil
import sys
import time
from pathlib import Path

from guide_health.cli.command import Command, check_out_path
from guide_health.errors import InputError
from guide_health.io.bag.maintenance import DIAGNOSTIC_ARRAY, MAINTENANCE_TOPIC, encode_events
from guide_health.io.bag.writer import write_life_test_bag, write_machine_axes_bag, write_machine_bag, write_slewing_bag
from guide_health.models.wear.effects.registry import BY_ID, EFFECTS
from guide_health.models.wear.maintenance import RESETS_WEAR, MaintenanceEvent
from guide_health.params import (
    SCHEMAS,
    SIMULATION_SCHEMA,
    SLEWING_MONITOR_SCHEMA,
    SLEWING_SIMULATION_DEFAULTS,
    load_node_params,
    simulation_params,
    validate_wear_params,
    wear_monitor_params,
)
from guide_health.params.machine import axes_params, simulation_axes
from guide_health.params.simulation import REALISTIC_MOTION, SLEWING_DUTIES
from guide_health.params.typed import slewing_monitor_params
from guide_health.sim.machine import (
    START_TIME_NS,
    apply_maintenance_truth,
    parse_effects,
    parse_maintenance,
    simulate_axes,
    simulate_machine,
)
from guide_health.sim.slewing import simulate_slewing

#: bag bytes per message (sqlite3, one joint: 105 measured on a 2 h bench bag; mcap is smaller); the
#: simulation holds about as much in memory while it writes
BYTES_PER_MESSAGE = 110
#: the default size limit of a simulated bag (--max-bag-gb)
DEFAULT_MAX_BAG_GB = 4.0


def add_arguments(parser) -> None:
    parser.add_argument("--params", required=True,
                        help="ROS 2 parameters YAML (wear_monitor + guide_health_simulation)")
    parser.add_argument("--kind", choices=("machine", "slewing", "life-test"), default="machine",
                        help="machine: axis motion, guide load, straightness; slewing: slewing/load of a crane "
                             "duty (the params file's guide_health_slewing_simulation section, if any); life-test: "
                             "a seed-004 accelerated life test (sound level and accelerometer blocks; sections "
                             "vibration_monitor and guide_health_life_test_simulation)")
    parser.add_argument("--out", required=True, help="bag directory to create (must not exist)")
    parser.add_argument("--storage", choices=("sqlite3", "mcap"), default="sqlite3")
    parser.add_argument("--hours", type=float, help="duration [h] (default: duration_h of the params file)")
    parser.add_argument("--rate", type=float, help="JointState rate [Hz] (default: joint_state_rate_hz)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (strokes, noise)")
    parser.add_argument("--max-bag-gb", type=float, default=DEFAULT_MAX_BAG_GB, metavar="GB",
                        help=f"refuse a bag estimated above this size (duration x rates x {BYTES_PER_MESSAGE} "
                             f"bytes per message; default {DEFAULT_MAX_BAG_GB:g} GB) or above the free disk space")
    parser.add_argument("--motion", choices=("file", "realistic"), default="file",
                        help="file: the params file's motion (constant-speed moves unless motion_profile says "
                             "otherwise); realistic: jerk-limited moves, joint_states at 250 Hz with 1 um encoder "
                             "noise, guide/load at 100 Hz on its own clock (params/simulation.py REALISTIC_MOTION, "
                             "applied before --rate and --hours)")
    parser.add_argument("--namespace", default="", help="topic namespace, e.g. /m1")
    parser.add_argument("--duty", choices=SLEWING_DUTIES, default=None,
                        help="--kind slewing: crane work cycles, yaw (long dwell, occasional large rotations) or "
                             "pitch (constant small oscillations), with the axis angle and tilting-clearance "
                             "readings (default: the section's duty)")
    parser.add_argument("--effect", action="append", metavar="NAME=VALUE",
                        help="physics the baseline model lacks, hidden in the truth (models/wear/effects/, "
                             "docs/discrepancy.md's table), VALUE in SI: " + ", ".join(
                                 f"{e.id}={e.simulate.name}" + (f" [{e.simulate.unit}]" if e.simulate.unit != "-"
                                                                else "") for e in EFFECTS)
                             + "; " + ", ".join(f"{e.id}'s {e.simulate.note}" for e in EFFECTS if e.simulate.note))
    parser.add_argument("--maintenance", action="append", metavar="KIND:AXIS[.GUIDE]@TIME[=VALUE]",
                        help="a maintenance event on maintenance/events (docs/machine.md): KIND regrind, "
                             "replace_rail, replace_carriage, relubricate or measure; TIME from the start in h "
                             "(default), min or s; VALUE the straightness after a regrind/rail replacement or the "
                             "manual reading, with its unit (7.5um); e.g. regrind:x@10h=8um")


def new_bag_path(path: str) -> Path:
    """The bag directory to create; InputError when it exists (a bag is never overwritten) or a part of
    its parent is a file."""
    out = Path(path)
    if out.exists():
        raise InputError(f"output bag {out} already exists")
    return check_out_path(out)


def messages_per_second(sims: list[dict], shared_joint_states: bool = True) -> float:
    """Messages per simulated second of a machine bag: joint_states (one topic for every axis), and per axis
    guide/load, guide/temperature and the straightness measurements."""
    joint = max(sim["joint_state_rate_hz"] for sim in sims) if shared_joint_states else 0.0
    return joint + sum(sim["load_rate_hz"] + sim["temperature_rate_hz"]
                       + 1.0 / (3600.0 * sim["measurement_interval_h"]) for sim in sims)


def check_bag_budget(args, duration_h: float, rate_per_s: float, out: Path) -> None:
    """Refuse, before anything is allocated, a bag estimated above --max-bag-gb or the free disk space."""
    if not (math.isfinite(args.max_bag_gb) and args.max_bag_gb > 0):
        raise InputError(f"--max-bag-gb must be a finite number > 0, got {args.max_bag_gb!r}")
    messages = duration_h * 3600.0 * rate_per_s
    estimate = messages * BYTES_PER_MESSAGE
    budget = args.max_bag_gb * 1e9
    parent = next((p for p in [out.parent, *out.parent.parents] if p.exists()), Path("."))
    free = shutil.disk_usage(parent).free
    what = f"{duration_h:g} h x {rate_per_s:.4g} messages/s = {messages:.3g} messages, about {estimate / 1e9:.3g} GB"
    if estimate > budget:
        raise InputError(f"simulate: {what}, above --max-bag-gb {args.max_bag_gb:g} (raise it to allow more)")
    if estimate > free:
        raise InputError(f"simulate: {what}, above the {free / 1e9:.3g} GB free on {parent}")


def run_slewing(args) -> dict:
    if args.effect:
        raise InputError("--effect applies to machine bags only")
    sim = load_node_params(args.params, "guide_health_slewing_simulation", SLEWING_SIMULATION_DEFAULTS,
                           required=False)     # the scenario section is optional: its defaults are a crane
    _override_duration(args, sim, "load_rate_hz")
    if args.duty is not None:
        sim["duty"] = args.duty
    bearing = slewing_monitor_params(load_node_params(args.params, "slewing_monitor",
                                                      SLEWING_MONITOR_SCHEMA.defaults(), required=False))
    out = new_bag_path(args.out)
    check_bag_budget(args, sim["duration_h"], _slewing_messages_per_s(sim), out)
    t0 = time.perf_counter()
    run = simulate_slewing(sim, seed=args.seed, bearing=bearing)
    write_slewing_bag(run, out, storage=args.storage, namespace=args.namespace, axis_topic=bearing.axis_topic,
                      axis_joint=bearing.axis_joint, clearance_topic=bearing.tilting_clearance_topic)
    print(f"wrote {run.t_ns.size} slewing loads ({sim['duration_h']:g} h) to {out} in "
          f"{time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return {"bag": str(out), "storage": args.storage, "kind": "slewing", "messages": int(run.t_ns.size),
            "duration_h": float(sim["duration_h"]), "load_rate_hz": float(sim["load_rate_hz"])}


def _slewing_messages_per_s(sim: dict) -> float:
    """Expected messages per simulated second: the load rate of the crane duty; for the oscillating duties, a
    motion's load and its axis samples (one per axis_sample_step_rad, the first and the end) over the mean
    cycle (yaw: mean dwell + mean rotation / slew speed; pitch: half a period, a swing of twice the mean
    amplitude). The expectation, not a worst case: over the thousands of motions of a long duty the count is
    close to it, where the shortest dwell would overstate a yaw duty ~3600-fold."""
    if sim["duty"] == "crane":
        return float(sim["load_rate_hz"])
    step = float(sim["axis_sample_step_rad"])
    if sim["duty"] == "yaw":
        rotation_rad = 0.5 * (float(sim["yaw_rotation_min_rad"]) + float(sim["yaw_rotation_max_rad"]))
        cycle_s = float(sim["yaw_dwell_mean_s"]) + rotation_rad / float(sim["slew_speed_rad_s"])
        return (3.0 + rotation_rad / step) / cycle_s
    swing_rad = float(sim["pitch_amplitude_min_rad"]) + float(sim["pitch_amplitude_max_rad"])
    return (3.0 + swing_rad / step) / (0.5 * float(sim["pitch_period_s"]))


def run_life_test(args) -> dict:
    from guide_health.sim.life_test import simulate_life_test

    p = {}
    for section in ("vibration_monitor", "guide_health_life_test_simulation"):
        p.update(load_node_params(args.params, section, SCHEMAS[section].defaults()))
    out = new_bag_path(args.out)
    record = simulate_life_test(p, seed=args.seed)
    write_life_test_bag(record, out, storage=args.storage, namespace=args.namespace)
    return {"bag": str(out), "kind": "life-test", "blocks": int(record.t_ns.size),
            "sound_levels": int(record.level_t_ns.size), **record.metadata["truth"]}


def run(args) -> dict:
    if args.kind == "slewing":
        return run_slewing(args)
    if args.kind == "life-test":
        return run_life_test(args)

    params = wear_monitor_params(args.params)
    sim = simulation_params(args.params)
    if args.motion == "realistic":
        sim.update(REALISTIC_MOTION)
    if params["axes"]:
        return run_machine_axes(args, params, sim)
    _check_axis_free(args, sim)
    _override_duration(args, sim)
    effects = parse_effects(args.effect)
    for name in (e for e in effects if BY_ID[e].needs_temperature and not sim["temperature_rate_hz"] > 0):
        print(f"guide-health simulate: {name} needs a temperature record: guide/temperature at 0.1 Hz",
              file=sys.stderr)
    out = new_bag_path(args.out)
    check_bag_budget(args, sim["duration_h"], messages_per_second([sim]), out)
    t0 = time.perf_counter()
    events = parse_maintenance(args.maintenance, {params["joint"]: params})
    resets = [(e.t_ns - START_TIME_NS) * 1e-9 for e in events if e.kind in ("regrind", "replace_rail")]
    relubed = [(e.t_ns - START_TIME_NS) * 1e-9 for e in events if e.kind == "relubricate"]
    machine = simulate_machine(params, sim, seed=args.seed, effects=effects, new_surface_t_s=resets,
                               relubrication_t_s=relubed)
    apply_maintenance_truth(machine, events, params)
    events = sorted(events + automatic_relubrications(machine, relubed, params["joint"]), key=lambda e: e.t_ns)
    write_machine_bag(machine, out, storage=args.storage, namespace=args.namespace,
                      extra=event_series(events, params["machine_id"]))
    elapsed = time.perf_counter() - t0
    print(f"wrote {machine.messages} messages ({sim['duration_h']:g} h) to {out} in {elapsed:.1f} s",
          file=sys.stderr)
    truth = machine.metadata["truth"]
    return {
        "bag": str(out),
        "storage": args.storage,
        "messages": machine.messages,
        "duration_h": sim["duration_h"],
        "joint_state_rate_hz": sim["joint_state_rate_hz"],
        "motion_profile": sim["motion_profile"],
        "effects": effects,
        "true_wear_coefficient": truth["wear_coefficient"],
        "true_straightness_final_um": truth["straightness_m"][-1] * 1e6,
        **({"maintenance_events": [e.as_dict() for e in events]} if events else {}),
    }


def automatic_relubrications(machine, recorded_t_s, joint: str) -> list:
    """The simulator's relubrications every relubrication_interval_h as relubricate maintenance events (an
    automatic lubricator logs its cycles), besides the recorded ones."""
    done = {round(t, 6) for t in recorded_t_s}
    return [MaintenanceEvent(START_TIME_NS + int(round(t * 1e9)), "relubricate", joint, source="simulate")
            for t in machine.metadata.get("relubrication_t_s", []) if round(t, 6) not in done]


def _check_axis_free(args, sim: dict) -> None:
    dotted = sorted({k.partition(".")[0] for k in sim if "." in k})
    if dotted:
        raise InputError(f"{args.params}: guide_health_simulation has per-axis sections {dotted} but "
                         f"wear_monitor has no 'axes'")


def event_series(events: list, machine_id: str) -> list:
    """The maintenance events as an extra bag series (maintenance/events, DiagnosticArray)."""
    if not events:
        return []

    encoded = encode_events(events, machine_id)
    return [(MAINTENANCE_TOPIC, DIAGNOSTIC_ARRAY, [e.t_ns for e in events], lambda i: [encoded[k] for k in i])]


def _positive_finite(value, flag: str) -> float:
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{flag} must be a finite number > 0, got {value!r}")
    return value


def _override_duration(args, sim: dict, rate_name: str = "joint_state_rate_hz") -> None:
    if args.hours is not None:
        sim["duration_h"] = _positive_finite(args.hours, "--hours")
    if args.rate is not None:
        sim[rate_name] = _positive_finite(args.rate, "--rate")


def run_machine_axes(args, params: dict, sim: dict) -> dict:
    """A machine of several axes (wear_monitor ``axes``): every axis with its duty in one bag."""
    axes = axes_params(params, validate_wear_params)
    effects = axis_effects(args.effect, axes)
    unknown = sorted({k.partition(".")[0] for k in sim if "." in k} - set(axes))
    if unknown:
        raise InputError(f"{args.params}: guide_health_simulation has sections {unknown} that are not axes "
                         f"{list(axes)}")
    _override_duration(args, sim)
    sims = simulation_axes(sim, list(axes))
    for axis, scenario in sims.items():
        try:
            SIMULATION_SCHEMA.validate(scenario)
        except InputError as exc:
            raise InputError(f"{args.params}: guide_health_simulation axis '{axis}': {exc}") from None
    out = new_bag_path(args.out)
    check_bag_budget(args, sim["duration_h"], messages_per_second(list(sims.values())), out)
    t0 = time.perf_counter()
    events = parse_maintenance(args.maintenance, axes)
    resets = {axis: [(e.t_ns - START_TIME_NS) * 1e-9 for e in events if e.axis == axis and e.kind in RESETS_WEAR]
              for axis in axes}
    runs = simulate_axes(axes, sims, seed=args.seed, effects=effects, new_surface_t_s=resets)
    for axis, run in runs.items():
        apply_maintenance_truth(run, [e for e in events if e.axis == axis], axes[axis])
    metadata = {"generator": "guide_health.simulate", "seed": args.seed, "axes": {
        axis: {k: v for k, v in run.metadata.items() if k != "jobs"} for axis, run in runs.items()}}
    write_machine_axes_bag(runs, axes, out, storage=args.storage, namespace=args.namespace, metadata=metadata,
                           extra=event_series(events, params["machine_id"]))
    messages = sum(r.messages for r in runs.values()) - (len(runs) - 1) * next(iter(runs.values())).joint_t_ns.size
    print(f"wrote {messages} messages ({sim['duration_h']:g} h, axes {', '.join(axes)}) to {out} in "
          f"{time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return {"bag": str(out), "storage": args.storage, "messages": messages, "duration_h": sim["duration_h"],
            "joint_state_rate_hz": sim["joint_state_rate_hz"],
            "axes": {axis: {"true_wear_coefficient": run.metadata["truth"]["wear_coefficient"],
                            "true_straightness_final_um": run.metadata["truth"]["straightness_m"][-1] * 1e6}
                     for axis, run in runs.items()},
            **({"maintenance_events": [e.as_dict() for e in events]} if events else {})}


def axis_effects(items: list[str] | None, axes: dict) -> dict[str, dict[str, float]]:
    """``--effect AXIS.NAME=VALUE`` items of a machine of several axes: {axis: {effect: value}}."""
    by_axis: dict[str, list[str]] = {}
    for item in items or []:
        axis, dot, rest = item.partition(".")
        if not dot or axis not in axes:
            raise InputError(f"--effect {item!r}: on a machine of several axes write AXIS.NAME=VALUE "
                             f"(axes: {', '.join(axes)})")
        by_axis.setdefault(axis, []).append(rest)
    return {axis: parse_effects(rest) for axis, rest in by_axis.items()}


SIMULATE = Command(add_arguments, run)
