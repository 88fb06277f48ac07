"""`make demo`: the seed-000 bench, end to end.

1. generate the bench bag (config/bench_000.yaml: 6000 N, 0.05 m/s, strokes normal(200, 47) mm in
   100..300 mm, straightness every 0.5 h) with `guide-health simulate`'s generator;
2. start the live `wear_monitor` node and replay the bag into it with `bag_player` (real ROS 2 topics);
3. print the node's last `/diagnostics` status as a health report, beside the offline `replay` of the same
   bag, and write a PNG plot of measured vs model straightness.
"""
from __future__ import annotations

import argparse
import math
import os
import shutil
import sys
import time
from pathlib import Path

from guide_health.analysis.replay import analyse, write_outputs
from guide_health.io.bag.reader import read_machine_bag
from guide_health.io.bag.writer import write_machine_bag
from guide_health.models.levels import LEVEL_NAMES
from guide_health.nodes.session import (
    PLAYER_WAIT_TIMEOUT_S,
    DiagnosticsCollector,
    clean_fastdds_shm,
    isolated_ros_env,
    play_bag,
    start_node,
    stop_node,
)
from guide_health.params import simulation_params, wear_monitor_params
from guide_health.sim.machine import simulate_machine

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--params", default=str(ROOT / "config" / "bench_000.yaml"))
    parser.add_argument("--out", default="out/demo")
    parser.add_argument("--hours", type=float, default=20.0)
    parser.add_argument("--rate", type=float, default=5.0, help="JointState rate of the demo bag [Hz]")
    parser.add_argument("--storage", choices=("sqlite3", "mcap"), default="sqlite3")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    out = Path(args.out)
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    params = wear_monitor_params(args.params)
    sim = simulation_params(args.params)
    sim["duration_h"], sim["joint_state_rate_hz"] = args.hours, args.rate
    sim["load_rate_hz"] = min(sim["load_rate_hz"], args.rate)

    print(f"[1/3] simulating {args.hours:g} h of the seed-000 bench at {args.rate:g} Hz ...", file=sys.stderr)
    machine = simulate_machine(params, sim, seed=args.seed)
    bag = out / "bench_000"
    write_machine_bag(machine, bag, storage=args.storage)
    print(f"      {machine.messages} messages -> {bag}", file=sys.stderr)

    env = isolated_ros_env()
    os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID")})
    print("[2/3] live: bag_player -> wear_monitor -> /diagnostics ...", file=sys.stderr)
    collector = DiagnosticsCollector("demo_health_report")
    node = start_node("guide_health.nodes.wear_monitor", args.params,
                      {"state_file": str(out / "wear_state.db"), "diagnostics_period_s": 0.5}, env,
                      log_path=out / "wear_monitor.log")
    name = f"{params['machine_id']}/wear_monitor: {params['joint']} precision"
    try:
        # the first status: ends as soon as it arrives; the bound is the live tests' start-up bound (a node's
        # imports and discovery took over 30 s at a load average of ~20)
        if collector.wait_for(name, timeout=PLAYER_WAIT_TIMEOUT_S) is None:
            print("demo: wear_monitor did not come up (see out/demo/wear_monitor.log)", file=sys.stderr)
            return 1
        t0 = time.monotonic()
        played = play_bag(bag, env, ["--wait-subscribers", "1", "--max-rate", "0"])
        sys.stderr.write(played.stderr)
        if played.returncode != 0:
            print("demo: bag_player failed", file=sys.stderr)
            return 1
        live = collector.wait_settled(name, "sliding_distance_m", settle_s=2.0, timeout=120.0)
        live_s = time.monotonic() - t0
    finally:
        stop_node(node)
        collector.close()
        clean_fastdds_shm()

    print("[3/3] offline replay of the same bag ...", file=sys.stderr)
    offline_run = read_machine_bag(bag, joint=params["joint"])
    monitor, offline = analyse(offline_run, params)
    offline["level_name"] = LEVEL_NAMES[offline["level"]]
    files = write_outputs(out / "report", monitor, offline, plot=True)

    v = live["values"]
    f = lambda key: float(v.get(key, "nan"))  # noqa: E731
    print()
    print(f"=== guide health report: {live['hardware_id']} / joint {params['joint']} ===")
    print(f"status            {LEVEL_NAMES.get(live['level'], live['level'])}: {live['message']}")
    print(f"straightness      {f('straightness_um'):8.2f} um model   {f('straightness_measured_um'):8.2f} um measured"
          f"   limit {f('straightness_limit_um'):.0f} um")
    print(f"remaining life    {f('remaining_life_h'):8.1f} h   (90 %: {f('remaining_life_h_low'):.1f} .. "
          f"{f('remaining_life_h_high'):.1f} h) at the current duty")
    print(f"wear              {f('wear_volume_mm3'):8.3f} mm^3 over {f('sliding_distance_m'):.1f} m sliding")
    print(f"wear coefficient  {f('wear_coefficient'):.4g}  (configured {params['wear_coefficient']:.4g}, "
          f"updated from {v.get('measurements')} straightness measurements)")
    print(f"live replay       {machine.messages} messages in {live_s:.1f} s")
    life_gap_pct = (100 * (f("remaining_life_h") / offline["remaining_life_h"] - 1)
                    if math.isfinite(offline["remaining_life_h"]) else math.nan)
    print("offline replay    straightness {:.2f} um, remaining life {:.1f} h  (live - offline: {:+.3f} %, {:+.3f} %)"
          .format(offline["straightness_um"], offline["remaining_life_h"],
                  100 * (f("straightness_um") / offline["straightness_um"] - 1), life_gap_pct))
    print(f"plot              {files['png']}")
    print(f"report            {files['json']}, {files['csv']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
