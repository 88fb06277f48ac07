"""Fingerprint of every output file the offline tools write, for "behaviour unchanged" refactors.

Generates a fixed set of bags (the seed-000 bench, the seed-001 rolling guide, the seed-003 slewing bearing,
the three-axis machine, the jobs machine with a hidden effect), runs `guide-health replay` and
`guide-health diagnose` on them, and prints one sha256 per written file (bags included) and per `--json`
stdout. Run it before and after a change and compare:

    python bench/output_fingerprint.py --out /tmp/fp_before > before.txt
    ... change ...
    python bench/output_fingerprint.py --out /tmp/fp_after > after.txt
    diff before.txt after.txt        # empty: every output byte-identical

`--demo` adds `make demo`'s report files (the live node's run, then the offline report it writes).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config"

#: (name, simulation params file, analysis params file, simulate flags, diagnose too?)
CASES = [
    ("bench", "bench_000.yaml", "bench_000.yaml", ["--hours", "6", "--rate", "10"], True),
    ("rolling", "bench_000.yaml", "nsk_lh45.yaml", ["--hours", "2", "--rate", "10"], False),
    ("xyz", "machine_xyz.yaml", "machine_xyz.yaml", ["--hours", "3", "--rate", "10",
                                                      "--maintenance", "regrind:x@1.5h=8um"], False),
    ("jobs", "machine_jobs.yaml", "machine_jobs.yaml", ["--hours", "8", "--rate", "10",
                                                        "--effect", "running_in=1.0"], True),
    ("slewing", "slewing_131.32.2000.00Z.yaml", "slewing_131.32.2000.00Z.yaml",
     ["--kind", "slewing", "--hours", "0.5"], False),
]


def _env() -> dict[str, str]:
    """This checkout's package first, whatever the venv's editable install points at."""
    return {**os.environ, "PYTHONPATH": str(ROOT)}


def _cli(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "guide_health.cli", *args], cwd=cwd, capture_output=True,
                          text=True, env=_env())


#: wall-clock timings in the JSON outputs: the only keys that differ between two runs of the same code
TIMING_KEYS = {"read_s", "model_s", "fit_s", "report_s", "total_s", "seconds", "wall_s"}


def _without_timings(value):
    if isinstance(value, dict):
        return {k: _without_timings(v) for k, v in value.items() if k not in TIMING_KEYS}
    if isinstance(value, list):
        return [_without_timings(v) for v in value]
    return value


def _hash_text(text: str) -> str:
    """sha256 of a text; a JSON text is hashed without its timing keys."""
    try:
        text = json.dumps(_without_timings(json.loads(text)), sort_keys=True)
    except ValueError:
        pass
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _digest(path: Path) -> str:
    if path.suffix == ".json":
        return _hash_text(path.read_text())
    return hashlib.sha256(path.read_bytes()).hexdigest()[:16]


def _files(folder: Path) -> list[Path]:
    skip = {".log", ".db-wal", ".db-shm"}
    return sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix not in skip)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", required=True, help="work directory (emptied first)")
    parser.add_argument("--demo", action="store_true", help="also run the demo (live node) and hash its report")
    args = parser.parse_args(argv)
    out = Path(args.out)
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    # every path relative to the work directory, so that outputs that name a file do not depend on it
    shutil.copytree(CONFIG, out / "config")
    lines = []
    for name, sim_params, params, flags, diagnose in CASES:
        params_args = ["--params", f"config/{params}"]
        bag = f"{name}/bag"
        (out / name).mkdir()
        steps = [("simulate", ["simulate", "--params", f"config/{sim_params}", "--out", bag, *flags]),
                 ("replay", ["replay", bag, *params_args, "--out", f"{name}/replay", "--json"])]
        if diagnose:
            steps.append(("diagnose", ["diagnose", bag, *params_args, "--out", f"{name}/diagnose", "--json"]))
        for step, cli_args in steps:
            done = _cli(cli_args, out)
            stdout = done.stdout if step != "simulate" else ""
            lines.append(f"{name} {step} exit={done.returncode} stdout="
                         f"{_hash_text(stdout)}")
            if done.returncode != 0:
                lines.append(f"{name} {step} stderr: {done.stderr.strip().splitlines()[-1:]}")
        for path in _files(out / name):
            lines.append(f"{name} {path.relative_to(out / name)} {_digest(path)}")
    if args.demo:
        demo_out = out / "demo"
        done = subprocess.run([sys.executable, "-m", "guide_health.demo", "--out", "demo", "--params",
                               "config/bench_000.yaml"], cwd=out, capture_output=True, text=True, env=_env())
        lines.append(f"demo exit={done.returncode}")
        for path in _files(demo_out / "report") + _files(demo_out / "bench_000"):
            lines.append(f"demo {path.relative_to(demo_out)} {_digest(path)}")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
