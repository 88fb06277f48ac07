"""`guide-health diagnose` on a 20 h bench bag at 50 Hz (issue 6.5: under 30 s, with the read/fit split).

    .venv/bin/python bench/bench_diagnose.py [--hours 20] [--rate 50] [--effect running_in=2.5] [--workdir DIR]

Writes (once, cached in --workdir) seed 000's bench bag (config/bench_000.yaml) with a hidden effect, then
measures in the same run:
  limit     the read limit of the same bag, every message (bench/read_limit.py: stdlib sqlite3
            `SELECT data FROM messages`, or a minimal mcap chunk scan; the baseline);
  rosbags   rosbags Reader.messages() over the whole bag (for reference);
  diagnose  `guide-health diagnose BAG --json` in a fresh process: wall time from process start to exit,
            with its own split into reading the bag into duty cells, fitting and writing the report.
It prints them, the ratio diagnose / limit read time, and what diagnose named.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_replay import raw_read_rate  # noqa: E402
from read_limit import read_limit  # noqa: E402

PARAMS = ROOT / "config" / "bench_000.yaml"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hours", type=float, default=20.0)
    ap.add_argument("--rate", type=float, default=50.0, help="JointState rate [Hz]")
    ap.add_argument("--effect", default="running_in=2.5")
    ap.add_argument("--workdir", default="/tmp/guide_health_bench")
    args = ap.parse_args()
    workdir = Path(args.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    bag = workdir / f"diagnose_{args.hours:g}h_{args.rate:g}hz_{args.effect.replace('=', '_')}"
    if not bag.exists():
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "guide_health.cli", "simulate", "--params", str(PARAMS), "--out",
                        str(bag), "--hours", str(args.hours), "--rate", str(args.rate), "--seed", "1",
                        "--effect", args.effect], check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
        print(f"wrote {bag} in {time.perf_counter() - t0:.1f} s", flush=True)
    n_lim, t_lim, what = read_limit(bag)
    n_raw, t_raw = raw_read_rate(bag)
    assert n_lim == n_raw, (n_lim, n_raw)
    cmd = [sys.executable, "-m", "guide_health.cli", "diagnose", str(bag), "--params", str(PARAMS),
           "--out", str(workdir / (bag.name + ".diagnose")), "--json"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, cwd=ROOT)
    stdout = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit("diagnose failed")
    res = json.loads(stdout)
    other = wall - res["read_s"] - res["fit_s"] - res["report_s"]
    print(f"bag: {n_raw:,} messages, {args.hours:g} h at {args.rate:g} Hz, hidden {args.effect}")
    print(f"  read limit             {t_lim:7.2f} s   ({n_lim / t_lim:,.0f} msg/s, {what})   <- baseline")
    print(f"  rosbags Reader         {t_raw:7.2f} s   ({n_raw / t_raw:,.0f} msg/s)")
    print(f"  diagnose, wall         {wall:7.2f} s   (target < 30 s; peak RSS {usage.ru_maxrss / 1024:.0f} MiB)")
    print(f"    read -> duty cells   {res['read_s']:7.2f} s   ({res['data']['segments']:,} segments -> "
          f"{res['data']['cells']:,} cells)")
    print(f"    fit + selection      {res['fit_s']:7.2f} s   ({len(res['candidates'])} candidate fits)")
    print(f"    report (md/png/csv)  {res['report_s']:7.2f} s")
    print(f"    start-up, imports    {other:7.2f} s")
    print(f"  ratio diagnose / limit read time  {wall / t_lim:.2f}")
    print(f"  named: {res['named_effects']}; held-out RMSE {res['baseline']['heldout_rmse_um']:.2f} -> "
          f"{res['final']['heldout_rmse_um']:.2f} um")
    return 0


if __name__ == "__main__":
    sys.exit(main())
