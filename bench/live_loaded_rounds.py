"""The live tests (marked `ros`) N times in a row while CPU burners run: does any of them flake under load?

    python bench/live_loaded_rounds.py --rounds 20 --burners 2

Starts ``--burners`` processes that spin in Python at normal priority (each keeps one core busy), then runs
``python -m pytest -m "ros and not slow" -n 2 --dist loadfile -q -p no:cacheprovider`` ``--rounds`` times
in a row from the repository root (the live set of the default run: a `slow` live test stays out, as in CI).
Per round one line: passed / failed / error counts (pytest's summary line), wall time, and the 1-minute load
average at the round's end; a failing round's failed test ids follow it. The last line:

    rounds: N, failed rounds: F, failures: <test id> x<count>, ...

The burners are stopped on exit, also on Ctrl-C or SIGTERM. Exit 0 when no round failed, 1 otherwise, 2 on
bad arguments. ``--pytest-args`` appends options (e.g. ``-x``, or a file to run only it).
"""
from __future__ import annotations

import argparse
import collections
import multiprocessing
import os
import re
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PYTEST_COMMAND = ["-m", "pytest", "-m", "ros and not slow", "-n", "2", "--dist", "loadfile", "-q",
                  "-p", "no:cacheprovider"]
#: pytest's summary counts ("3 failed, 43 passed, 1 error in 80.1s")
SUMMARY_COUNT = re.compile(r"(\d+) (passed|failed|errors?|skipped|deselected|xfailed|xpassed)")
#: a failed test's line in -q's short summary ("FAILED test/x.py::t - AssertionError ..." / "ERROR ...")
FAILED_LINE = re.compile(r"^(FAILED|ERROR) (\S+)")


def burn() -> None:
    """Keep one core busy until killed (pure Python arithmetic, no sleep)."""
    x = 0
    while True:
        x = (x * 1103515245 + 12345) % 2147483648


def start_burners(count: int) -> list[multiprocessing.Process]:
    burners = [multiprocessing.Process(target=burn, daemon=True, name=f"burner{i}") for i in range(count)]
    for proc in burners:
        proc.start()
    return burners


def stop_burners(burners: list[multiprocessing.Process]) -> None:
    for proc in burners:
        if proc.is_alive():
            proc.terminate()
    for proc in burners:
        proc.join(timeout=5)
        if proc.is_alive():
            proc.kill()
            proc.join()


def parse_pytest_output(text: str) -> tuple[dict[str, int], list[str]]:
    """(counts per outcome from the last summary line, failed/errored test ids) of pytest -q's output."""
    counts: dict[str, int] = collections.Counter()
    summary = [line for line in text.splitlines() if SUMMARY_COUNT.search(line) and " in " in line]
    if summary:
        for number, outcome in SUMMARY_COUNT.findall(summary[-1]):
            counts["error" if outcome.startswith("error") else outcome] += int(number)
    failed = [match.group(2) for line in text.splitlines() if (match := FAILED_LINE.match(line))]
    return dict(counts), failed


def run_round(index: int, extra: list[str], log_dir: Path | None) -> tuple[bool, list[str]]:
    """One pytest run of the live set; prints its line; (failed?, failed ids)."""
    start = time.monotonic()
    proc = subprocess.run([sys.executable] + PYTEST_COMMAND + extra, cwd=ROOT, capture_output=True, text=True)
    wall_s = time.monotonic() - start
    load_1min = os.getloadavg()[0]
    output = proc.stdout + proc.stderr
    if log_dir is not None:
        (log_dir / f"round{index:02d}.log").write_text(output)
    counts, failed = parse_pytest_output(output)
    bad = proc.returncode != 0
    if bad and not failed:                           # pytest stopped before any summary (collection, crash)
        failed = [f"pytest exit {proc.returncode}: {output.strip().splitlines()[-1:] or ['no output']}"]
    print(f"round {index}: {counts.get('passed', 0)} passed, {counts.get('failed', 0)} failed, "
          f"{counts.get('error', 0)} errors, {counts.get('skipped', 0)} skipped; wall {wall_s:.1f} s; "
          f"load average (1 min) {load_1min:.2f}" + ("" if not bad else "  FAILED"), flush=True)
    for test_id in failed:
        print(f"  {test_id}", flush=True)
    return bad, failed


def interrupt(signum, frame) -> None:
    """SIGTERM ends the run as Ctrl-C does (the burners are stopped in main's finally)."""
    raise KeyboardInterrupt


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rounds", type=int, default=20, help="pytest runs of the live set, one after the other")
    p.add_argument("--burners", type=int, default=2, help="CPU burner processes (not niced)")
    p.add_argument("--log-dir", type=Path, default=None, help="write each round's pytest output here")
    p.add_argument("--pytest-args", nargs=argparse.REMAINDER, default=[],
                   help="options appended to the pytest command (the rest of the command line)")
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.rounds < 1 or args.burners < 0:
        print("live_loaded_rounds: --rounds must be >= 1 and --burners >= 0", file=sys.stderr)
        return 2
    if args.log_dir is not None:
        args.log_dir.mkdir(parents=True, exist_ok=True)
    burners = start_burners(args.burners)
    signal.signal(signal.SIGTERM, interrupt)
    failures: collections.Counter = collections.Counter()
    failed_rounds = done = 0
    try:
        print(f"{args.burners} burners (pids {[proc.pid for proc in burners]}); "
              f"{shlex.join([sys.executable] + PYTEST_COMMAND + args.pytest_args)}", flush=True)
        for index in range(1, args.rounds + 1):
            bad, failed = run_round(index, args.pytest_args, args.log_dir)
            failed_rounds += bad
            failures.update(failed)
            done += 1
    except KeyboardInterrupt:
        print("interrupted", flush=True)
    finally:
        stop_burners(burners)
    listed = ", ".join(f"{test_id} x{count}" for test_id, count in failures.most_common()) or "none"
    print(f"rounds: {done}, failed rounds: {failed_rounds}, failures: {listed}", flush=True)
    return 1 if failed_rounds or done < args.rounds else 0


if __name__ == "__main__":
    sys.exit(main())
