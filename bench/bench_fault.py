"""Fault benchmark (not CI): N random SIGKILLs of a live wear_monitor while a bag plays into it (issue 10).

    .venv/bin/python bench/bench_fault.py [--kills 5] [--hours 1.5] [--seed 1]

A seed-000 bench bag (config/bench_000.yaml, 10 Hz JointState, 1 Hz load, straightness every 3 min, so
that kills often fall right after a measurement) is played with `bag_player` into the real node
(`state_file`, checkpoint every 1 s). At a random moment (uniform 0..4 s after the node's status shows
motion beyond the last checkpoint) the
node is SIGKILLed (no clean shutdown: only checkpoints survive) and the player stopped; the node is
restarted, and the bag is played again from the checkpoint with `bag_player --start-after-ns <the
checkpoint's last joint stamp>` (the documented resume procedure, docs/ros.md). After N kills the rest
of the bag plays, the node stops cleanly and its last state is compared with the offline replay of the
same bag. Then the node is restarted, resumed the same way and SIGKILLed --restarts-at-end (3) times more
with the bag complete (the bag's last straightness message, logged after its last joint sample, plays
again each time). Printed:
  - per kill: the checkpoint read back (parsed, validated like a resuming node does, restored by
    PrecisionMonitor, measurement stamps strictly increasing, sliding distance and samples not below the
    previous checkpoint's) and the samples lost at the kill (the node's last status before the kill minus
    the checkpoint), also in seconds at the node's sample rate just before the kill (the player plays
    faster than 10 Hz);
  - state never corrupt: checkpoints validated / read;
  - measurements counted (live vs offline: a measurement counted twice makes live > offline);
  - joint samples and sliding distance lost (offline - live) against one checkpoint period of samples.
Targets: state never corrupt, no measurement counted twice, loss <= one checkpoint period.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

BENCH = ROOT / "config" / "bench_000.yaml"
STATUS = "bench_000/wear_monitor: x precision"
CHECKPOINT_S = 1.0
RATE_HZ = 10.0


CHECKS = {"read": 0, "valid": 0}


def read_checkpoint(state_db: Path, params: dict) -> dict:
    """The saved state, checked like a resuming node checks it (models/wear/state_schema.py: every field
    present, of its kind, finite, lengths agree; then restored): counted in CHECKS; says so when
    measurement stamps repeat."""
    from guide_health.errors import InputError
    from guide_health.io.state_store import _decode
    from guide_health.models.wear.precision import PrecisionMonitor
    from guide_health.models.wear.state_schema import check_precision_state
    from guide_health.params.typed import wear_axis_params

    with sqlite3.connect(state_db) as db:
        rows = db.execute("SELECT state_json FROM monitor_state WHERE key LIKE '%/precision'").fetchall()
    if len(rows) != 1:
        raise AssertionError(f"{len(rows)} precision states in the state file")
    CHECKS["read"] += 1
    state = _decode(json.loads(rows[0][0]))
    monitor = PrecisionMonitor(wear_axis_params(params))
    try:
        check_precision_state(state, monitor.state())
    except InputError as exc:
        raise SystemExit(f"FAIL: checkpoint {CHECKS['read']} refused by the state schema: {exc}") from None
    monitor.restore(state)
    CHECKS["valid"] += 1
    stamps = state["estimator"]["measurement_t_ns"]
    twice = sum(b <= a for a, b in zip(stamps, stamps[1:]))
    if twice:
        print(f"  !! {twice} measurement(s) counted twice (stamps not strictly increasing)")
    return state


def processing_rate(collector, seen: dict | None) -> float:
    """Samples per wall second the node counted over the ~2 s of statuses before ``seen`` (the player plays
    faster than the bag's 10 Hz, so a checkpoint period holds more samples than 10)."""
    if seen is None:
        return float("inf")
    t = seen["received"]
    recent = [h for h in collector.history.get(STATUS, []) if t - 2.5 <= h["received"] <= t]
    if len(recent) < 2 or recent[-1]["received"] <= recent[0]["received"]:
        return float("inf")
    counted = float(recent[-1]["values"]["samples"]) - float(recent[0]["values"]["samples"])
    return max(counted, 1.0) / (recent[-1]["received"] - recent[0]["received"])


def resumed(state: dict | None):
    """Status predicate: the (new) node publishes the checkpoint's sliding distance (the killed node is
    silent), so it is up and resumed before the player starts."""
    if state is None:
        return lambda status: True
    distance = state["integrator"]["sliding_distance_m"]
    return lambda status: abs(float(status["values"]["sliding_distance_m"]) - distance) < 1e-6


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kills", type=int, default=5)
    ap.add_argument("--hours", type=float, default=1.5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--restarts-at-end", type=int, default=3)
    args = ap.parse_args(argv)

    from guide_health.analysis.replay import analyse
    from guide_health.io.bag.reader import read_machine_bag
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.nodes.session import (
        DiagnosticsCollector,
        clean_fastdds_shm,
        isolated_ros_env,
        play_bag,
        start_node,
        stop_node,
    )
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    rng = random.Random(args.seed)
    # UDP only: a SIGKILLed node must not strand shared memory; a domain id above the tests' 1..100, so that
    # test runs elsewhere on the host (same node and status names) do not answer this one
    env = isolated_ros_env(domain_id=random.Random().randint(101, 232), transports="UDPv4")
    os.environ.update(env)
    params = wear_monitor_params(BENCH)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        sim = dict(simulation_params(BENCH), duration_h=args.hours, joint_state_rate_hz=RATE_HZ,
                   load_rate_hz=1.0, measurement_interval_h=0.05)
        bag = tmp / "bench"
        write_machine_bag(simulate_machine(params, sim, seed=args.seed), bag)
        offline = analyse(read_machine_bag(bag, joint="x"), params)[1]
        state_db = tmp / "state.db"
        overrides = {"state_file": str(state_db), "diagnostics_period_s": 0.25,
                     "checkpoint_period_s": CHECKPOINT_S}
        collector = DiagnosticsCollector("bench_fault_collector")
        previous = None
        start_after: int | None = None
        print(f"bag: {args.hours} h, {offline['samples']} joint samples, {offline['measurements']} measurements")
        kill_losses: list[float] = []
        print(f"{'kill':>4} {'after s':>7} {'checkpoint stamp':>20} {'measurements':>12} {'samples':>8} "
              f"{'distance m':>10} {'lost/kill':>9} {'= s':>9}  state")
        try:
            for kill in range(1, args.kills + 1):
                node = start_node("guide_health.nodes.wear_monitor", BENCH, overrides, env, tmp / f"node{kill}.log")
                if collector.wait_for(STATUS, resumed(previous), timeout=60.0) is None:
                    raise SystemExit(f"node {kill} did not come up: {(tmp / f'node{kill}.log').read_text()}")
                extra = ["--wait-subscribers", "1", "--ack-timeout", "5"]
                if start_after is not None:
                    extra += ["--start-after-ns", str(start_after)]
                player = subprocess.Popen([sys.executable, "-m", "guide_health.nodes.bag_player", str(bag), *extra],
                                          env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                # the kill: a random moment (0..4 s) after the node shows motion beyond the checkpoint
                done = 0.0 if previous is None else previous["integrator"]["sliding_distance_m"]
                collector.wait_for(STATUS, lambda st, d=done: float(st["values"]["sliding_distance_m"]) > d + 0.5,
                                   timeout=120.0)
                delay = rng.uniform(0.0, 4.0)
                time.sleep(delay)
                seen = collector.get(STATUS)            # what the node had counted just before the kill
                os.kill(node.pid, signal.SIGKILL)
                node.wait()
                player.send_signal(signal.SIGINT)
                try:
                    player.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    player.kill()
                    player.wait()
                clean_fastdds_shm()
                state = read_checkpoint(state_db, params) if state_db.exists() else None
                verdict = "none yet"
                if state is not None and state["integrator"]["last_t_ns"] is not None:
                    integ = state["integrator"]
                    verdict = "ok"
                    if previous is not None and (integ["sliding_distance_m"] < previous["integrator"][
                            "sliding_distance_m"] or integ["samples"] < previous["integrator"]["samples"]):
                        verdict = "WENT BACK"
                    start_after = integ["last_t_ns"]
                    n_meas = len(state["estimator"]["measurement_t_ns"])
                    at_kill = int(float(seen["values"]["samples"])) if seen else integ["samples"]
                    lost_at_kill = at_kill - integ["samples"]
                    kill_losses.append(lost_at_kill / processing_rate(collector, seen))
                    print(f"{kill:>4} {delay:>7.1f} {start_after:>20} {n_meas:>12} "
                          f"{integ['samples']:>8} {integ['sliding_distance_m']:>10.2f} {lost_at_kill:>9} "
                          f"{kill_losses[-1]:>9.2f}  {verdict}")
                    previous = state
                else:
                    print(f"{kill:>4} {delay:>7.1f} {'-':>20} {'-':>12} {'-':>8} {'-':>10}  {verdict}")
            node = start_node("guide_health.nodes.wear_monitor", BENCH, overrides, env, tmp / "final.log")
            if collector.wait_for(STATUS, resumed(previous), timeout=60.0) is None:
                raise SystemExit(f"the last node did not come up: {(tmp / 'final.log').read_text()}")
            extra = ["--wait-subscribers", "1", "--max-rate", "0"]
            if start_after is not None:
                extra += ["--start-after-ns", str(start_after)]
            played = play_bag(bag, env, extra)
            if played.returncode != 0:
                raise SystemExit(played.stderr)
            collector.wait_settled(STATUS, "sliding_distance_m", settle_s=2.0, timeout=120.0)
            stop_node(node)
            # the bag is complete; restart and resume --restarts-at-end times more: the bag's last
            # straightness message (logged after the last joint sample) plays again each time
            for again in range(args.restarts_at_end):
                state = read_checkpoint(state_db, params)
                node = start_node("guide_health.nodes.wear_monitor", BENCH, overrides, env, tmp / f"end{again}.log")
                if collector.wait_for(STATUS, resumed(state), timeout=60.0) is None:
                    raise SystemExit(f"node did not come up: {(tmp / f'end{again}.log').read_text()}")
                played = play_bag(bag, env, ["--wait-subscribers", "1", "--max-rate", "0",
                                             "--start-after-ns", str(state["integrator"]["last_t_ns"])])
                time.sleep(3 * CHECKPOINT_S)
                last = collector.get(STATUS)
                dup = last["values"].get("rejected: measurement already applied", "0") if last else "?"
                os.kill(node.pid, signal.SIGKILL)
                node.wait()
                clean_fastdds_shm()
                n_meas = len(read_checkpoint(state_db, params)["estimator"]["measurement_t_ns"])
                print(f"end restart {again + 1}: {n_meas} measurements, player rc {played.returncode}, "
                      f"status 'rejected: measurement already applied' = {dup}")
        finally:
            collector.close()
            clean_fastdds_shm()
        final = read_checkpoint(state_db, params)
        live_meas = len(final["estimator"]["measurement_t_ns"])
        live_samples = final["integrator"]["samples"]
        lost = offline["samples"] - live_samples
        print(f"measurements: live {live_meas}, offline {offline['measurements']} "
              f"({'none counted twice' if live_meas <= offline['measurements'] else 'COUNTED TWICE'})")
        print(f"joint samples: live {live_samples}, offline {offline['samples']}, lost {lost} "
              f"(one checkpoint period = {CHECKPOINT_S * RATE_HZ:.0f} samples)")
        print(f"sliding distance: live {final['integrator']['sliding_distance_m']:.3f} m, offline "
              f"{offline['sliding_distance_m']:.3f} m")
        period = CHECKPOINT_S * RATE_HZ
        worst = max(kill_losses, default=0.0)
        print(f"state never corrupt: {CHECKS['valid']}/{CHECKS['read']} checkpoints read back validated and "
              f"restored")
        print(f"no measurement counted twice: {'yes' if live_meas <= offline['measurements'] else 'NO'} "
              f"(live {live_meas}, offline {offline['measurements']})")
        print(f"loss at a kill (samples the node had counted at its last status before the kill - the "
              f"checkpoint's, over the node's sample rate then): max {worst:.2f} s of <= {CHECKPOINT_S} s (one "
              f"checkpoint period); after resume {lost} samples lost")
        ok = (live_meas <= offline["measurements"] and abs(lost) <= period and worst <= CHECKPOINT_S + 0.25
              and CHECKS["valid"] == CHECKS["read"])
        print("PASS" if ok else "FAIL")
        return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
