"""`guide-health diagnose` on a 20 h bench bag at 50 Hz against the stdlib read loop and against the
pre-issue-15 diagnose, every variant measured in the same run, interleaved (issues 14 and 15).

    .venv/bin/python bench/bench_diagnose.py [--hours 20] [--rate 50] [--effect running_in=2.5] [--repeat 3]
                                             [--ref COMMIT ...] [--rosbags] [--workdir DIR]

Writes (once, cached in --workdir) seed 000's bench bag (config/bench_000.yaml) with a hidden effect, then
runs --repeat rounds of, in turn:
  loop      the stdlib `SELECT data FROM messages` loop over the bag's .db3, one Python row per message
            (bench_read_limit.loop_time; an mcap bag: the minimal chunk scan of read_limit.py); the baseline;
  diagnose  `guide-health diagnose BAG --json` of this checkout in a fresh process: wall time from process
            start to exit, with its own split (read -> duty cells, which overlaps the imports of the fit and
            plotting when the bag is read in a child process; fit + selection; report);
  pre15     the same checkout with what issue 15 added switched off (bench/diagnose_pre15.py: the seven
            pre-issue-15 candidates, no backward pass, no model-file refit or forecast, no deadband);
  ref:X     `diagnose` of git commit X (exported with `git archive` into --workdir, run with its own
            package): e.g. the commit before issue 15 landed (f5ee444) or main before this work (849e0ec).
It prints the median and the minimum of each over the rounds and the ratios of the medians: diagnose / loop
(issue 14: <= 2.5) and diagnose / pre15 (issue 15: time grows by no more than 20 %, i.e. <= 1.2).
No timed assertion: the machine is shared; compare ratios from one run.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from read_limit import read_limit, storage_of  # noqa: E402

PARAMS = ROOT / "config" / "bench_000.yaml"


def loop_time(bag: Path) -> tuple[int, float, str]:
    """(messages, seconds, what) of the baseline: the stdlib row loop (sqlite3) or the mcap chunk scan."""
    if storage_of(bag) == "mcap":
        return read_limit(bag)
    from bench_read_limit import loop_time as sqlite_loop

    n, t = sqlite_loop(bag)
    return n, t, "stdlib sqlite3 SELECT data loop"


def export_commit(commit: str, workdir: Path) -> Path:
    """The tree of `commit` (git archive, no worktree registered), cached in workdir."""
    sha = subprocess.run(["git", "rev-parse", "--short", commit], cwd=ROOT, check=True, capture_output=True,
                         text=True).stdout.strip()
    dest = workdir / f"tree_{sha}"
    if not (dest / "guide_health").exists():
        dest.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", "archive", sha], cwd=ROOT, check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    return dest


def run_diagnose(cmd: list[str], cwd: Path, env: dict) -> tuple[float, dict, float, float]:
    """(wall s, JSON result, peak RSS MiB, CPU s of the process and the children it waited for) of one
    diagnose process."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, cwd=cwd, env=env)
    stdout = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"failed: {' '.join(cmd)}")
    return wall, json.loads(stdout), usage.ru_maxrss / 1024, usage.ru_utime + usage.ru_stime


def variants(bag: Path, refs: list[str], workdir: Path) -> dict[str, tuple[list[str], Path, dict]]:
    out = workdir / (bag.name + ".diagnose")
    args = [str(bag), "--params", str(PARAMS), "--out", str(out), "--json"]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    found = {"diagnose": ([sys.executable, "-m", "guide_health.cli", "diagnose", *args], ROOT, env),
             "pre15": ([sys.executable, str(ROOT / "bench" / "diagnose_pre15.py"), *args], ROOT, env)}
    for ref in refs:
        tree = export_commit(ref, workdir)
        found[f"ref:{ref}"] = ([sys.executable, "-m", "guide_health.cli", "diagnose", *args], tree,
                               dict(os.environ, PYTHONPATH=str(tree)))
    return found


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hours", type=float, default=20.0)
    ap.add_argument("--rate", type=float, default=50.0, help="JointState rate [Hz]")
    ap.add_argument("--effect", default="running_in=2.5")
    ap.add_argument("--repeat", type=int, default=3, help="rounds (each runs every variant once)")
    ap.add_argument("--ref", nargs="*", default=[], help="git commits whose diagnose to run beside")
    ap.add_argument("--rosbags", action="store_true", help="also time rosbags' Reader over the bag")
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
    print(f"load average at start: {os.getloadavg()[0]:.1f} (2 cores)")
    todo = variants(bag, args.ref, workdir)
    times: dict[str, list[float]] = {"loop": [], **{k: [] for k in todo}}
    last: dict[str, tuple[dict, float]] = {}
    cpu: dict[str, list[float]] = {k: [] for k in todo}
    n = what = None
    for _ in range(max(1, args.repeat)):
        n, t, what = loop_time(bag)
        times["loop"].append(t)
        for name, (cmd, cwd, env) in todo.items():
            wall, res, rss, cpu_s = run_diagnose(cmd, cwd, env)
            times[name].append(wall)
            cpu[name].append(cpu_s)
            last[name] = (res, rss)
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"bag: {n:,} messages, {args.hours:g} h at {args.rate:g} Hz, hidden {args.effect}; "
          f"{args.repeat} rounds, median (min)")
    print(f"  {what:34s} {med['loop']:6.2f} s ({min(times['loop']):.2f})   <- baseline")
    for name in todo:
        res, rss = last[name]
        split = (f"read {res.get('read_s', float('nan')):.2f} + fit {res.get('fit_s', float('nan')):.2f} + "
                 f"report {res.get('report_s', float('nan')):.2f} s, {len(res.get('candidates', []))} candidate "
                 f"fits, named {res.get('named_effects')}, CPU {statistics.median(cpu[name]):.2f} s, "
                 f"peak RSS {rss:.0f} MiB")
        print(f"  {name:34s} {med[name]:6.2f} s ({min(times[name]):.2f})   {split}")
    if args.rosbags:
        from bench_replay import raw_read_rate

        n_raw, t_raw = raw_read_rate(bag)
        print(f"  rosbags Reader (reference)         {t_raw:6.2f} s ({n_raw:,} messages)")
    low = {k: min(v) for k, v in times.items()}      # the load only adds time: the minimum is the least disturbed
    print("  ratios of the medians (of the minima):")

    def ratio(name: str, other: str) -> str:
        return f"{med[name] / med[other]:5.2f} ({low[name] / low[other]:.2f})"

    print(f"  ratio diagnose / loop time     {ratio('diagnose', 'loop')}   (issue 14 target <= 2.5)")
    print(f"  ratio diagnose / pre15 time    {ratio('diagnose', 'pre15')}   (issue 15: <= 1.2)")
    for name in todo:
        if name.startswith("ref:"):
            print(f"  ratio diagnose / {name:13s} {ratio('diagnose', name)}")
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
