"""Issue 10 item 6 (files): metadata.yaml counts that disagree with the stored rows are reported (one
warning line + `bag_count_mismatch` in the JSON), storage files outside the bag folder are refused with one
line, report files are never written through a symbolic link and are 0640, a joint missing offline is an
error naming the joint and the joints present (exit 2)."""
from __future__ import annotations

import contextlib
import io
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from guide_health.cli.app import main
from guide_health.errors import InputError
from guide_health.io.bag import reader as bag_reader
from guide_health.io.bag import writer as bag_writer
from guide_health.io.outputs.files import REPORT_MODE, open_output, write_text
from guide_health.runs import MachineRun

ROOT = Path(__file__).resolve().parents[1]
T0 = 1_700_000_000 * 10**9
PARAMS = ROOT / "config" / "bench_000.yaml"


def _run(n=2000, joint="x") -> MachineRun:
    t = T0 + np.arange(n, dtype=np.int64) * 10_000_000            # 100 Hz
    pos = 0.2 + 0.1 * np.sin(np.arange(n) / 50.0)
    tl = t[::2]
    ts = t[::500] + 1
    return MachineRun(joint_name=joint, joint_t_ns=t, joint_position_m=pos, joint_velocity_m_s=np.zeros(0),
                      load_t_ns=tl, load_n=np.full(tl.size, 2000.0), straightness_t_ns=ts,
                      straightness_m=15e-6 + 1e-8 * np.arange(ts.size), temperature_t_ns=np.zeros(0, np.int64),
                      temperature_c=np.zeros(0), metadata={})


@pytest.fixture(scope="module")
def bag(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("bags") / "b"
    bag_writer.write_machine_bag(_run(), path)
    return path


def cli(*args):
    """The console script (an interpreter of its own): the warning line of a stale count on its stderr."""
    return subprocess.run([sys.executable, "-m", "guide_health.cli", *map(str, args)], capture_output=True,
                          text=True, timeout=120, env=dict(os.environ, PYTHONPATH=str(ROOT)))


def in_process(*args) -> subprocess.CompletedProcess:
    """main() in this process (what the console script runs, without an interpreter start per call), as `cli`
    gives it: exit code, stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([*map(str, args)])
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


def _copy_with_count(bag: Path, dest: Path, old: int, new: int) -> Path:
    shutil.copytree(bag, dest)
    meta = dest / "metadata.yaml"
    text = meta.read_text()
    assert f"message_count: {old}\n" in text
    meta.write_text(text.replace(f"message_count: {old}\n", f"message_count: {new}\n", 1))
    return dest


def test_metadata_counts_that_disagree_are_reported_with_the_stored_rows_used(bag, tmp_path):
    """2000 joint_states stored; metadata.yaml claims 1500 (stale: an edited bag): the stored rows are used,
    with one warning line and bag_count_mismatch in the report."""
    wrong = _copy_with_count(bag, tmp_path / "wrong", 2000, 1500)
    stats = {}
    with pytest.warns(UserWarning, match="1500 in metadata.yaml, 2000 stored"):
        run = bag_reader.read_machine_bag(wrong, stats=stats)
    assert run.joint_t_ns.size == 2000
    assert stats["bag_count_mismatch"] == {"/joint_states": {"metadata": 1500, "rows": 2000}}
    proc = cli("replay", wrong, "--params", PARAMS, "--json", "--no-plot", "--out", tmp_path / "r")
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert report["bag_count_mismatch"] == {"/joint_states": {"metadata": 1500, "rows": 2000}}
    warning = [line for line in proc.stderr.splitlines() if "warning" in line]
    assert len(warning) == 1 and "/joint_states 1500 in metadata.yaml, 2000 stored" in warning[0], proc.stderr
    good = in_process("replay", bag, "--params", PARAMS, "--json", "--no-plot", "--out", tmp_path / "g")
    assert "bag_count_mismatch" not in json.loads(good.stdout) and "warning" not in good.stderr


def test_metadata_counting_more_messages_than_read_is_an_error(bag, tmp_path):
    """metadata.yaml claims 2500 joint_states, 2000 can be read: messages the storage does not deliver, an
    error naming the topic and both counts (exit 2, one line), never a replay of the rest."""
    wrong = _copy_with_count(bag, tmp_path / "more", 2000, 2500)
    with pytest.raises(InputError, match="topic /joint_states: metadata.yaml counts 2500 messages, only 2000"):
        bag_reader.read_machine_bag(wrong)
    proc = in_process("replay", wrong, "--params", PARAMS, "--json", "--no-plot", "--out", tmp_path / "r")
    assert proc.returncode == 2 and proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "2500" in lines[0] and "2000" in lines[0] and "stale" not in lines[0], proc.stderr


@pytest.mark.parametrize("how", ["dotdot", "absolute", "symlink"])
def test_storage_files_outside_the_bag_folder_are_refused(bag, tmp_path, how):
    evil = tmp_path / "evil"
    evil.mkdir()
    shutil.copy(bag / "metadata.yaml", evil / "metadata.yaml")
    db = next(bag.glob("*.db3"))
    if how == "dotdot":
        name = os.path.relpath(db, evil)
    elif how == "absolute":
        name = str(db)
    else:
        (evil / "link.db3").symlink_to(db)
        name = "link.db3"
    meta = evil / "metadata.yaml"
    meta.write_text(meta.read_text().replace(db.name, name))
    with pytest.raises(InputError, match="outside the bag folder"):
        bag_reader.read_machine_bag(evil)
    proc = in_process("replay", evil, "--params", PARAMS, "--json", "--no-plot", "--out", tmp_path / "r")
    assert proc.returncode == 2 and proc.stdout == "", proc.stdout
    assert proc.stderr.count("\n") == 1 and "outside the bag folder" in proc.stderr and repr(name) in proc.stderr


def test_a_joint_missing_offline_is_an_error_naming_the_joints_present(bag, tmp_path):
    """main: a stderr warning and JSON level WARN 'waiting for motion'."""
    with pytest.raises(InputError, match=r"no joint_states message has joint 'y' \(joints present: x\)"):
        bag_reader.read_machine_bag(bag, joint="y")
    params = tmp_path / "y.yaml"
    params.write_text(PARAMS.read_text().replace("joint: x", "joint: 'y'"))     # bare y is a bool to rcl
    assert "joint: 'y'" in params.read_text()
    proc = in_process("replay", bag, "--params", params, "--json", "--no-plot", "--out", tmp_path / "r")
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "joint 'y' (joints present: x)" in proc.stderr, proc.stderr


def test_replay_never_writes_through_a_symlink_and_reports_are_0640(bag, tmp_path):
    out = tmp_path / "r"
    out.mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    (out / "report.json").symlink_to(victim)
    proc = in_process("replay", bag, "--params", PARAMS, "--json", "--out", out)
    assert proc.returncode == 2 and victim.read_text() == "keep me"
    assert proc.stderr.count("\n") == 1 and "symbolic link" in proc.stderr and "report.json" in proc.stderr
    (out / "report.json").unlink()
    (out / "straightness.csv").write_text("old")
    os.chmod(out / "straightness.csv", 0o666)               # an older, wider file is narrowed
    proc = in_process("replay", bag, "--params", PARAMS, "--json", "--out", out)
    assert proc.returncode == 0, proc.stderr
    for name in ("report.json", "straightness.csv", "straightness.png"):
        assert (out / name).stat().st_mode & 0o777 == REPORT_MODE == 0o640, name
    assert (out / "straightness.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_open_output_refuses_links_and_special_files(tmp_path):
    target = tmp_path / "t"
    target.write_text("x")
    (tmp_path / "l").symlink_to(target)
    with pytest.raises(InputError, match="symbolic link"):
        write_text(tmp_path / "l", "y")
    os.mkfifo(tmp_path / "fifo")
    with pytest.raises(InputError, match="not a regular file"):
        write_text(tmp_path / "fifo", "y")
    with pytest.raises(InputError, match="cannot be written"):
        write_text(tmp_path / "nodir" / "f", "y")
    with open_output(tmp_path / "f") as handle:
        handle.write("a\n")
    assert (tmp_path / "f").read_text() == "a\n" and target.read_text() == "x"


def test_every_report_writer_goes_through_output_files():
    """A new writer that opens its file directly would follow a planted symlink and leave 0644 (issue 10
    item 6): every report, CSV, PNG and params file goes through guide_health/io/outputs/files.py."""
    import re

    direct = re.compile(r"\.write_text\(|\.write_bytes\(|\bopen\([^)]*[\"'][wa]b?[\"']"
                        r"|\.savefig\(\s*(?!buffer)|np\.savetxt\(\s*files")
    allowed = {"guide_health/io/outputs/files.py",
               "guide_health/nodes/session.py"}      # the log of a node a test/bench starts, path from the caller
    offenders = []
    for path in sorted((ROOT / "guide_health").rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel in allowed:
            continue
        for number, line in enumerate(path.read_text().splitlines(), 1):
            if direct.search(line) and not line.lstrip().startswith("#"):
                offenders.append(f"{rel}:{number}: {line.strip()}")
    assert not offenders, "\n".join(offenders)
