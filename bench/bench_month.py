"""A month of one machine offline: `replay` and `diagnose` over a directory of bag splits against the stdlib
`SELECT data` loop over the same files; peak RSS at several sizes; the progress bar across files.

    .venv/bin/python bench/bench_month.py [--messages 1e7] [--splits 20] [--cache DIR] [--sizes 2 6 20]
                                          [--skip-diagnose]

The month is built once and cached under --cache (default ~/.cache/guide_health_bench): one continuous
bench run of --messages JointState at 1 kHz (+ a tenth as WrenchStamped, straightness every 0.05 h;
bench_replay.make_bag, written by a child process), cut by log time into --splits consecutive one-file
sqlite3 bags (shifts; the messages copied row for row by sqlite, so the splits hold exactly the run's
messages), each with its own metadata.yaml. A month of a machining centre at 50 Hz on 3 axes is ~100 M
messages; this host builds and replays 10 M in minutes, so --messages scales it down (the ratios are per
message, measured in the same run).
For each size (the first S splits of the month, a directory of links to them) and in the same run:
  loop      the stdlib `SELECT data FROM messages` loop over every .db3 file of those splits (the baseline);
  replay    `guide-health replay DIR --no-plot --json --progress` in a fresh process: wall time, peak RSS
            (os.wait4 ru_maxrss of the child), and the progress bar's last line (one count across files);
  diagnose  `guide-health diagnose DIR --json` (largest size only): wall time and peak RSS.
Printed: replay rate / loop rate (target >= 0.5, i.e. replay time <= 2x the loop) and diagnose time / loop
time (target <= 2.5), peak RSS per size (no growth with messages beyond the model's own state), and the
machine's load average. No timed assertion: the machine is shared.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from read_limit import sqlite3_read_limit  # noqa: E402

PARAMS = ROOT / "config" / "bench_000.yaml"
LAST_RSS_SAMPLES: list[tuple[float, float]] = []


def _copy_schema(src: sqlite3.Connection, dst: sqlite3.Connection) -> list[str]:
    """Create src's tables in dst (copying every table but messages); return its index statements."""
    rows = src.execute("SELECT type, name, sql FROM sqlite_master WHERE sql IS NOT NULL").fetchall()
    for kind, name, sql in rows:
        if kind == "table":
            dst.execute(sql)
            if name != "messages":
                dst.executemany(f"INSERT INTO {name} VALUES ({','.join('?' * _columns(src, name))})",
                                src.execute(f"SELECT * FROM {name}"))
    return [sql for kind, _, sql in rows if kind == "index"]


def _columns(con: sqlite3.Connection, table: str) -> int:
    return len(con.execute(f"PRAGMA table_info({table})").fetchall())


def _cut_db(src_db: Path, lo_ns: int, hi_ns: int, dst_db: Path) -> tuple[dict[str, int], int, int]:
    """The rows of src_db with log time in [lo_ns, hi_ns) as the sqlite3 file dst_db (same schema, same
    rows, indexes built after the copy): (message count per topic name, first and last log time)."""
    src = sqlite3.connect(f"file:{src_db}?mode=ro", uri=True)
    dst = sqlite3.connect(dst_db)
    indexes = _copy_schema(src, dst)
    dst.commit()
    dst.execute("ATTACH DATABASE ? AS src", (f"file:{src_db}?mode=ro",))
    dst.execute("INSERT INTO main.messages SELECT * FROM src.messages WHERE timestamp >= ? AND timestamp < ? "
                "ORDER BY id", (lo_ns, hi_ns))
    dst.commit()
    for sql in indexes:
        dst.execute(sql)
    counts = dict(dst.execute("SELECT t.name, COUNT(*) FROM messages m JOIN topics t ON t.id = m.topic_id "
                              "GROUP BY t.name"))
    first, last = dst.execute("SELECT MIN(timestamp), MAX(timestamp) FROM messages").fetchone()
    dst.commit()
    dst.close()
    src.close()
    return counts, first, last


def _write_metadata(bag: Path, info: dict, parts: list[tuple[str, dict[str, int], int, int]]) -> None:
    """metadata.yaml of ``bag`` (``info``: the source bag's) over its files ``parts``: (name, counts, first,
    last log time)."""
    def span(first, last):
        return {"starting_time": {"nanoseconds_since_epoch": first}, "duration": {"nanoseconds": last - first}}

    counts = {name: sum(c.get(name, 0) for _, c, _, _ in parts)
              for name in (t["topic_metadata"]["name"] for t in info["topics_with_message_count"])}
    topics = [dict(t, message_count=counts[t["topic_metadata"]["name"]]) for t in info["topics_with_message_count"]]
    files = [dict(path=name, message_count=sum(c.values()), **span(first, last)) for name, c, first, last in parts]
    info = dict(info, relative_file_paths=[p[0] for p in parts], topics_with_message_count=topics,
                message_count=sum(counts.values()), files=files,
                **span(min(p[2] for p in parts), max(p[3] for p in parts)))
    (bag / "metadata.yaml").write_text(yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False))


def cut_bag(src_bag: Path, edges_ns: list[int], out: Path) -> None:
    """The one-file sqlite3 bag src_bag as the bag ``out`` split into len(edges_ns) - 1 storage files by log
    time (what `ros2 bag record --max-bag-duration` leaves): file k holds [edges[k], edges[k + 1])."""
    info = yaml.safe_load((src_bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    (src_db,) = sorted(src_bag.glob("*.db3"))
    tmp = out.with_name(out.name + ".part")
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir(parents=True)
    parts = []
    for k in range(len(edges_ns) - 1):
        name = f"{out.name}_{k}.db3"
        parts.append((name, *_cut_db(src_db, edges_ns[k], edges_ns[k + 1], tmp / name)))
    _write_metadata(tmp, info, parts)
    tmp.rename(out)


def time_edges(bag: Path, pieces: int) -> list[int]:
    """pieces + 1 log times [ns] cutting the bag's messages into equal time spans."""
    (db,) = sorted(bag.glob("*.db3"))
    with sqlite3.connect(f"file:{db}?mode=ro", uri=True) as con:
        first, last = con.execute("SELECT MIN(timestamp), MAX(timestamp) FROM messages").fetchone()
    return [first + (last + 1 - first) * k // pieces for k in range(pieces)] + [last + 1]


def build_month(n_joint: int, splits: int, cache: Path) -> list[Path]:
    """The month's split bags (cached): one bench run cut into ``splits`` consecutive bags."""
    month = cache / f"month_{n_joint}_{splits}"
    paths = [month / f"shift_{k:03d}" for k in range(splits)]
    if all(p.exists() for p in paths):
        return paths
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", f"import sys; sys.path.insert(0, {str(ROOT / 'bench')!r}); "
                    f"from bench_replay import make_bag; from pathlib import Path; "
                    f"make_bag({n_joint}, 'sqlite3', Path({str(cache)!r}))"], check=True, cwd=ROOT)
    whole = cache / f"replay_{n_joint}_sqlite3"
    edges = time_edges(whole, splits)
    month.mkdir(parents=True, exist_ok=True)
    n = 0
    for k, path in enumerate(paths):
        if not path.exists():
            cut_bag(whole, edges[k:k + 2], path)
        n += json_count(path)
    print(f"  built {n:,} messages in {splits} splits under {month} in {time.perf_counter() - t0:.0f} s",
          flush=True)
    return paths


def json_count(bag: Path) -> int:
    return yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]["message_count"]


def month_view(paths: list[Path], count: int, cache: Path) -> Path:
    """A directory holding links to the first ``count`` splits: a smaller month of the same shifts."""
    view = cache / f"{paths[0].parent.name}_first_{count}"
    view.mkdir(exist_ok=True)
    for p in paths[:count]:
        link = view / p.name
        if not link.exists():
            link.symlink_to(p, target_is_directory=True)
    return view


def _rss_mib(pid: int) -> float | None:
    try:
        with open(f"/proc/{pid}/status") as handle:
            return next(float(line.split()[1]) / 1024.0 for line in handle if line.startswith("VmRSS:"))
    except (OSError, StopIteration):
        return None


def rss_shape(samples: list[tuple[float, float]]) -> str:
    """The child's RSS over its run (samples of (s, MiB) every 0.25 s) at 10, 25, 50, 75 and 95 % of the run
    (the messages come at a steady rate, so a state that grows with the messages grows along these; the
    process's exit, after 95 %, frees memory) and the largest sample."""
    if len(samples) < 8:
        return "RSS samples: too few"
    t_end = samples[-1][0]
    at = [next(m for t, m in samples if t >= f * t_end) for f in (0.1, 0.25, 0.5, 0.75, 0.95)]
    return (f"RSS at 10, 25, 50, 75, 95 % of the run: {', '.join(f'{m:.0f}' for m in at)} MiB "
            f"(largest sample {max(m for _, m in samples):.0f} MiB)")


def run_child(args: list[str]) -> tuple[dict, str, float, float]:
    """(json stdout, stderr, wall s, peak RSS MiB) of `guide-health ARGS --json` in a fresh process; its RSS
    over the run (every 0.25 s) in the global LAST_RSS_SAMPLES."""
    import threading

    cmd = [sys.executable, "-m", "guide_health.cli", *args, "--json"]
    with tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=err, cwd=ROOT)
        LAST_RSS_SAMPLES.clear()

        def sample() -> None:
            while proc.poll() is None:
                m = _rss_mib(proc.pid)
                if m is not None:
                    LAST_RSS_SAMPLES.append((time.perf_counter() - t0, m))
                time.sleep(0.25)

        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()
        stdout = proc.stdout.read()
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        stderr = err.read().decode(errors="replace")
    if proc.returncode != 0:
        raise SystemExit(f"{args[0]} failed ({proc.returncode}): {stderr[-500:]}")
    return json.loads(stdout), stderr, wall, usage.ru_maxrss / 1024.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--messages", type=float, default=1e7, help="JointState messages of the month (+10 %% load)")
    ap.add_argument("--splits", type=int, default=20, help="bags (shifts) the month is cut into")
    ap.add_argument("--sizes", type=int, nargs="+", default=[2, 6, 20], help="first S splits replayed")
    ap.add_argument("--cache", type=Path, default=Path.home() / ".cache" / "guide_health_bench")
    ap.add_argument("--skip-diagnose", action="store_true")
    args = ap.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    print(f"load average at start: {os.getloadavg()[0]:.1f} (on {os.cpu_count()} cores)", flush=True)
    paths = build_month(int(args.messages), args.splits, args.cache)
    out = args.cache / "out"
    rows = []
    for size in sorted(s for s in args.sizes if s <= len(paths)):
        view = month_view(paths, size, args.cache)
        n, t_loop = sqlite3_read_limit_dir(paths[:size])
        report, stderr, wall, rss = run_child(["replay", str(view), "--params", str(PARAMS), "--out",
                                               str(out / f"replay_{size}"), "--no-plot", "--progress"])
        assert report["messages"] == n, (report["messages"], n)
        bar = [line for line in stderr.replace("\r", "\n").splitlines() if line.startswith("replay")]
        rows.append((size, n, t_loop, wall, rss))
        print(f"{size} splits, {n:,} messages (load {os.getloadavg()[0]:.1f}):")
        print(f"  stdlib SELECT data loop   {t_loop:8.2f} s   <- baseline")
        print(f"  replay, end to end        {wall:8.2f} s   (read {report['read_s']:.2f} s + model "
              f"{report['model_s']:.2f} s; {len(report.get('bags') or [])} bags; peak RSS {rss:.0f} MiB)")
        print(f"  ratio replay rate / loop rate  {t_loop / wall:5.2f}   (target >= 0.5)")
        print(f"  progress bar: {len(bar)} redraws, last: {bar[-1].strip() if bar else 'NONE'}")
        print(f"  {rss_shape(LAST_RSS_SAMPLES)}", flush=True)
    if not args.skip_diagnose:
        size, n, t_loop = rows[-1][0], rows[-1][1], rows[-1][2]
        view = month_view(paths, size, args.cache)
        res, _, wall, rss = run_child(["diagnose", str(view), "--params", str(PARAMS), "--out",
                                       str(out / f"diagnose_{size}")])
        print(f"diagnose over {size} splits, {n:,} messages: {wall:.2f} s wall (read -> duty cells "
              f"{res['read_s']:.2f} s, fit {res['fit_s']:.2f} s, report {res['report_s']:.2f} s; peak RSS "
              f"{rss:.0f} MiB)")
        print(f"  ratio diagnose time / loop time  {wall / t_loop:5.2f}   (target <= 2.5)")
        print(f"  {rss_shape(LAST_RSS_SAMPLES)}", flush=True)
    print("\nsplits   messages   loop [s]   replay [s]   replay rate/loop rate   us/msg   peak RSS [MiB]")
    for size, n, t_loop, wall, rss in rows:
        print(f"{size:6d} {n:10,} {t_loop:10.2f} {wall:12.2f} {t_loop / wall:23.2f} {wall / n * 1e6:8.2f} "
              f"{rss:16.0f}")
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


def sqlite3_read_limit_dir(bags: list[Path]) -> tuple[int, float]:
    """(messages, seconds) of the stdlib loop over every .db3 of the bags."""
    n = t = 0
    for bag in bags:
        got, dt = sqlite3_read_limit(bag)
        n, t = n + got, t + dt
    return n, t


if __name__ == "__main__":
    sys.exit(main())
