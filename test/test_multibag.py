"""Many bags, many axes, offline: `replay` and `diagnose` over several bags (or a directory of bags, or a bag
split into several storage files) equal the same over one bag of the same messages; a machine of several
axes is diagnosed per axis, a regrind splitting its axis's record.

Truth: the unsplit recording's own replay/diagnose (the bags are cut from it with rosbags' reader and writer,
test/bag_cut.py, so they hold exactly its messages); for the per-axis diagnosis, the effect hidden in the
simulator on one axis (never handed to the fit) and the simulator's K (3e-6: the fit with the regrind split
recovers it within 10 %, which a fit across the regrind does not)."""
from __future__ import annotations

import contextlib
import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bag_cut import cut_bag, join_as_split_bag  # noqa: E402

from guide_health.analysis.discrepancy.duty import read_duty_cells  # noqa: E402
from guide_health.cli.app import main  # noqa: E402
from guide_health.io.bag.bag_set import resolve_bags  # noqa: E402
from guide_health.params import wear_monitor_params  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "config" / "bench_000.yaml"
XYZ = ROOT / "config" / "machine_xyz.yaml"
T0_NS = 1_700_000_000_000_000_000          # the simulator's first stamp
HOUR_NS = 3600 * 10**9
TIMING = ("read_s", "model_s", "fit_s", "report_s", "total_s", "files", "bags", "gaps")


def cli(*args):
    return subprocess.run([sys.executable, "-m", "guide_health.cli", *map(str, args)], capture_output=True,
                          text=True, timeout=600)


def in_process(*args) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of main() in this process: what the console script runs, without starting
    an interpreter per call (one replay and one diagnose still go through `cli`, the console script)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([*map(str, args)])
    return code, out.getvalue(), err.getvalue()


def ok_json(*args) -> dict:
    """The command's JSON from main() in this process."""
    code, out, err = in_process(*args, "--json")
    assert code == 0, err
    return json.loads(out)


def without(report: dict, keys=TIMING) -> dict:
    return {k: v for k, v in report.items() if k not in keys}


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """A 2 h bench recording (10 Hz) with a relubrication at 1 h, and three consecutive bags cut from it at
    0.7 h and 1.3 h, named against their time order (c_b first, then c_a, then c_c)."""
    tmp = tmp_path_factory.mktemp("recording")
    one = tmp / "one"
    code, _, err = in_process("simulate", "--params", BENCH, "--out", one, "--hours", "2", "--rate", "10",
                              "--maintenance", "relubricate:x@1h")
    assert code == 0, err
    shifts = tmp / "shifts"
    shifts.mkdir()
    edges = [T0_NS, T0_NS + int(0.7 * HOUR_NS), T0_NS + int(1.3 * HOUR_NS), T0_NS + 3 * HOUR_NS]
    parts = cut_bag(one, edges, shifts, ["c_b", "c_a", "c_c"])
    return {"one": one, "parts": parts, "dir": shifts, "tmp": tmp}


@pytest.fixture(scope="module")
def recording_replay(recording) -> dict:
    """The recording's own replay (JSON), the truth of the bag-set replays."""
    return ok_json("replay", recording["one"], "--params", BENCH, "--out", recording["tmp"] / "r_one", "--no-plot")


def test_three_consecutive_bags_replay_exactly_as_the_recording(recording, recording_replay):
    """The same JSON to the last bit (timing and file keys aside), whatever order the bags are named in, and
    as a directory of bags; the relubrication recorded in the middle bag is applied; two gaps of one sample
    period (the cuts) are listed with start, end and duration."""
    tmp, one = recording["tmp"], recording_replay
    c_b, c_a, c_c = recording["parts"]
    three = ok_json("replay", c_c, c_b, c_a, "--params", BENCH, "--out", tmp / "r_three", "--no-plot")
    folder = ok_json("replay", recording["dir"], "--params", BENCH, "--out", tmp / "r_dir", "--no-plot")
    assert without(three) == without(one)
    assert without(folder) == without(one)
    assert one["maintenance_events"][0]["kind"] == "relubricate" and one["maintenance_events"][0]["applied"]
    assert [b["path"] for b in three["bags"]] == [str(c_b), str(c_a), str(c_c)]      # by time, not by name
    assert sum(b["messages"] for b in three["bags"]) == one["messages"] + 1           # + the maintenance event
    assert len(three["gaps"]) == 2
    for gap, cut in zip(three["gaps"], (0.7, 1.3)):
        assert gap["end_ns"] == T0_NS + int(cut * HOUR_NS)                           # the next bag's first message
        assert 0 < gap["duration_s"] <= 0.1 + 1e-9                                    # one 10 Hz sample period
        assert gap["duration_s"] == pytest.approx((gap["end_ns"] - gap["start_ns"]) * 1e-9, abs=1e-12)
    text = in_process("replay", c_a, c_b, c_c, "--params", BENCH, "--out", tmp / "r_text", "--no-plot")[1]
    assert text.count("gap:") == 2 and "bags:  3 from" in text


def test_split_bag_directory_replays_as_the_unsplit_bag(recording, recording_replay):
    """One bag of three storage files (one metadata.yaml, as `ros2 bag record` splits) == the unsplit bag."""
    tmp, one = recording["tmp"], recording_replay
    split = join_as_split_bag(recording["parts"], tmp / "split")
    assert len(list(split.glob("*.db3"))) == 3
    out = ok_json("replay", split, "--params", BENCH, "--out", tmp / "s_split", "--no-plot")
    assert without(out) == without(one)
    assert "gaps" not in out                       # one bag


def packed_messages(storage, chunk_messages: int) -> list[tuple[str, int, bytes]]:
    """Every message of a storage's packed reading: (topic, log time, bytes)."""
    topic = {c.id: c.topic for c in storage.connections}
    out = []
    for group in storage.iter_packed(storage.connections, chunk_messages):
        for b in group:
            buf = b.buf.tobytes()
            out += [(topic[int(c)], int(t), buf[o:o + n]) for c, t, o, n in
                    zip(b.connection_ids, b.log_time_ns, b.offsets, b.lengths)]
    return out


def test_a_split_sqlite3_bag_is_read_on_the_fast_path_with_every_message_in_order(recording):
    """The split bag opens on the sqlite3 back end (packed reading, not the rosbags fallback) and gives the
    unsplit bag's messages (topic, log time, bytes) in the same order, at a window that cuts across the files
    and at one larger than a file; its counts are metadata.yaml's. Files listed out of time order go to the
    rosbags fallback, which merges them by time."""
    from guide_health.io.bag.rosbags_storage import RosbagsStorage
    from guide_health.io.bag.storage import open_storage

    tmp = recording["tmp"]
    split = join_as_split_bag(recording["parts"], tmp / "split_fast")
    with open_storage(recording["one"]) as one:
        truth = packed_messages(one, 1000)
        counts = {c.topic: c.msgcount for c in one.connections}
    with open_storage(split) as storage:
        assert not isinstance(storage, RosbagsStorage)
        assert {c.topic: c.msgcount for c in storage.connections} == counts
        assert (storage.start_ns, storage.end_ns - 1) == (truth[0][1], truth[-1][1])
        for chunk in (997, 10**6):
            got = packed_messages(storage, chunk)
            assert len(got) == len(truth) and got == truth
    c_b, c_a, c_c = recording["parts"]
    shuffled = join_as_split_bag([c_a, c_b, c_c], tmp / "split_shuffled")
    with open_storage(shuffled) as storage:
        assert isinstance(storage, RosbagsStorage)


def test_a_gap_between_shifts_is_reported_and_overlapping_bags_refused(recording):
    """The first and the last of the three cuts (0.6 h missing between them): the gap's duration is 0.6 h (to
    one sample period); bags that overlap in time: exit 2 with one line naming both (the console script)."""
    tmp = recording["tmp"]
    early, _, late = recording["parts"]                      # c_b: 0 .. 0.7 h, c_c: 1.3 .. 2 h
    out = ok_json("replay", late, early, "--params", BENCH, "--out", tmp / "g", "--no-plot")
    (gap,) = out["gaps"]
    assert gap["duration_s"] == pytest.approx(0.6 * 3600.0, abs=0.1 + 1e-9)
    assert gap["start_utc"] < gap["end_utc"]
    overlap = cut_bag(recording["one"], [T0_NS + int(0.5 * HOUR_NS), T0_NS + HOUR_NS], tmp, ["overlap"])[0]
    proc = cli("replay", early, overlap, "--params", BENCH, "--out", tmp / "o", "--no-plot")
    assert proc.returncode == 2
    err = proc.stderr.strip().splitlines()
    assert len(err) == 1 and "overlap" in err[0] and early.name in err[0] and "overlap" in err[0]


def test_duty_cells_of_three_bags_are_the_recordings(recording):
    """diagnose's duty cells (every array) of the three bags equal those of the recording exactly."""
    params = wear_monitor_params([BENCH])
    one, n_one = read_duty_cells(recording["one"], params)
    three, n_three = read_duty_cells(resolve_bags(recording["parts"]), params)
    assert n_three == n_one
    for name, value in vars(one).items():
        if isinstance(value, np.ndarray):
            assert np.array_equal(getattr(three, name), value), name
        elif name != "metadata":
            assert getattr(three, name) == value, name


@pytest.mark.slow
def test_diagnose_of_three_bags_names_what_the_one_names(tmp_path):
    """A bench run with running-in hidden, cut into three bags: diagnose gives the recording's result (named
    effects, fitted values, scores), timing and file keys aside. (CI: the duty cells test above, the workflow's
    whole input, equal array by array.)"""
    one = tmp_path / "one"
    proc = cli("simulate", "--params", BENCH, "--out", one, "--hours", "6", "--rate", "5", "--seed", "2",
               "--effect", "running_in=2.5")
    assert proc.returncode == 0, proc.stderr
    parts = cut_bag(one, [T0_NS, T0_NS + 2 * HOUR_NS, T0_NS + 4 * HOUR_NS, T0_NS + 7 * HOUR_NS], tmp_path,
                    ["a", "b", "c"])
    single = ok_json("diagnose", one, "--params", BENCH, "--out", tmp_path / "d_one", "--no-plot")
    three = ok_json("diagnose", *parts, "--params", BENCH, "--out", tmp_path / "d_three", "--no-plot")
    assert single["named_effects"] == ["running_in"]
    assert without(three) == without(single)
    assert len(three["gaps"]) == 2
    assert "gaps between them" in (tmp_path / "d_three" / "report.md").read_text()


# --- a machine of several axes ------------------------------------------------------------------------
#: machine_xyz.yaml made fast to test: K 100 x (8 h then wear ~5-20 um), straightness every 0.5 h with
#: 0.2 um noise, 2 Hz sensors, a 1000 m running-in distance where the simulator hides running-in
FAST_XYZ = [("wear_coefficient: 3.0e-8", "wear_coefficient: 3.0e-6"),
            ("straightness_limit_m: 30.0e-6", "straightness_limit_m: 200.0e-6"),
            ("straightness_noise_m: 1.0e-6", "straightness_noise_m: 0.2e-6"),
            ("joint_state_rate_hz: 50.0", "joint_state_rate_hz: 2.0"),
            ("load_rate_hz: 10.0", "load_rate_hz: 2.0"),
            ("measurement_interval_h: 1.0", "measurement_interval_h: 0.5"),
            ("\n    dwell_s: 1.0\n", "\n    dwell_s: 1.0\n    running_in_distance_m: 1000.0\n")]


@pytest.fixture(scope="module")
def xyz(tmp_path_factory):
    """8 h of the three-axis machine, running-in hidden on y only, a regrind of x at 4 h to 2 um (A0 6 um)."""
    tmp = tmp_path_factory.mktemp("xyz")
    text = XYZ.read_text()
    for old, new in FAST_XYZ:          # every occurrence (the noise is in the node's and the simulator's section)
        assert old in text, old
        text = text.replace(old, new)
    params = tmp / "xyz_fast.yaml"
    params.write_text(text)
    bag = tmp / "bag"
    code, _, err = in_process("simulate", "--params", params, "--out", bag, "--seed", "0", "--effect",
                              "y.running_in=2.5", "--maintenance", "regrind:x@4h=2um")
    assert code == 0, err
    return {"params": params, "bag": bag, "tmp": tmp}


@pytest.fixture(scope="module")
def xyz_diagnose(xyz) -> dict:
    """diagnose of the whole machine (every axis), written under xyz's "d"."""
    return ok_json("diagnose", xyz["bag"], "--params", xyz["params"], "--out", xyz["tmp"] / "d", "--no-plot")


def test_diagnose_per_axis_names_the_effect_hidden_on_y_only(xyz, xyz_diagnose):
    """axes {x, y, z}: running_in named on y and nothing on x (regrind split: K within 10 % of the
    simulator's 3e-6 on both surfaces, the new one from the 2 um entered, residuals at the noise) or z;
    report.md a section per axis, a CSV per axis, model.yaml with a section per axis that replay loads."""
    tmp = xyz["tmp"]
    axes = xyz_diagnose["axes"]
    assert list(axes) == ["x", "y", "z"]
    assert {a: r["named_effects"] for a, r in axes.items()} == {"x": [], "y": ["running_in"], "z": []}
    assert axes["x"]["data"]["wear_resets"] == [{"t_h": 4.0, "straightness_after_um": pytest.approx(2.0)}]
    assert "wear_resets" not in axes["z"]["data"]
    assert axes["x"]["final"]["wear_coefficient"] == pytest.approx(3.0e-6, rel=0.1)
    assert axes["x"]["baseline"]["rmse_um"] < 2 * 0.2          # the noise: both surfaces fitted from their A0
    assert [r["data"]["measurements"] for r in axes.values()] == [16, 16, 16]       # 0 .. 7.5 h
    md = (tmp / "d" / "report.md").read_text()
    assert [md.count(f"axis {a}\n") for a in "xyz"] == [1, 1, 1]
    assert all((tmp / "d" / f"residuals_{a}.csv").exists() for a in "xyz")
    replay = ok_json("replay", xyz["bag"], "--params", xyz["params"], "--params", tmp / "d" / "model.yaml",
                     "--out", tmp / "r", "--no-plot")
    assert replay["axes"]["y"]["effects"] == "running_in"


def test_diagnose_axis_choice_and_too_few_measurements_name_the_axes(xyz, xyz_diagnose):
    """--axis x diagnoses x alone, giving x's result of the whole machine's diagnose (its fit time aside); an
    unknown axis (the console script), and a record with 5 measurements per axis (the first 2 h), exit 2 with
    one line naming the axes present and the count per axis."""
    tmp = xyz["tmp"]
    only = ok_json("diagnose", xyz["bag"], "--params", xyz["params"], "--axis", "x", "--out", tmp / "dx",
                   "--no-plot")
    assert list(only["axes"]) == ["x"]
    assert without(only["axes"]["x"], ("fit_s",)) == without(xyz_diagnose["axes"]["x"], ("fit_s",))
    assert only["axes"]["x"]["data"]["wear_resets"] and only["axes"]["x"]["named_effects"] == []
    proc = cli("diagnose", xyz["bag"], "--params", xyz["params"], "--axis", "q", "--out", tmp / "dq")
    assert proc.returncode == 2
    (line,) = proc.stderr.strip().splitlines()
    assert "q" in line and "x, y, z" in line
    short = cut_bag(xyz["bag"], [T0_NS, T0_NS + 2 * HOUR_NS + 1], tmp, ["short"])[0]
    code, _, err = in_process("diagnose", short, "--params", xyz["params"], "--out", tmp / "ds")
    assert code == 2
    (line,) = err.strip().splitlines()
    assert "axis x has 5" in line and "x: 5, y: 5, z: 5" in line


def test_machine_replay_of_three_bags_equals_the_recording(xyz):
    """Every axis's replay of three consecutive bags of the machine equals that of the recording."""
    tmp = xyz["tmp"]
    parts = cut_bag(xyz["bag"], [T0_NS, T0_NS + 3 * HOUR_NS, T0_NS + 5 * HOUR_NS, T0_NS + 9 * HOUR_NS], tmp,
                    ["m1", "m2", "m3"])
    one = ok_json("replay", xyz["bag"], "--params", xyz["params"], "--out", tmp / "mr1", "--no-plot")
    three = ok_json("replay", *parts, "--params", xyz["params"], "--out", tmp / "mr3", "--no-plot")
    assert without(three) == without(one)
    assert three["axes"]["x"]["maintenance_events"][0]["kind"] == "regrind"


def test_a_wear_reset_splits_the_duty_cells_without_losing_work():
    """Bench run (2 h, 10 Hz) with a reset at 0.83 h: the cells of epoch 0 carry exactly the work of the run
    cut at the reset, epoch 1 the rest (total unchanged); epoch 1's sliding distance counts from the reset: its
    work-weighted mean (a sum over segments, whatever the cells) is that of the run after the reset read as a
    record of its own (to the one segment across the reset: 1e-3)."""
    import dataclasses

    from guide_health.analysis.discrepancy.duty import DutyCellAccumulator, duty_cells_from_runs
    from guide_health.params.loader import simulation_params
    from guide_health.sim.machine import _cut_run, simulate_machine

    params = wear_monitor_params([BENCH])
    sim = dict(simulation_params(BENCH), duration_h=2.0, joint_state_rate_hz=10.0, load_rate_hz=10.0)
    run = simulate_machine(params, sim, seed=1)
    reset_ns = T0_NS + int(0.83 * HOUR_NS) + 12_345
    acc = DutyCellAccumulator(params["slider_length_m"], resets_ns=[reset_ns], reset_straightness_m=[4e-6])
    acc.add(run)
    split = acc.finish()
    whole = duty_cells_from_runs(run, params["slider_length_m"])
    before = duty_cells_from_runs(_cut_run(run, reset_ns + 1), params["slider_length_m"])
    j, ld = (int(np.searchsorted(t, at)) for t, at in ((run.joint_t_ns, reset_ns), (run.load_t_ns, reset_ns - 10**8)))
    after_run = dataclasses.replace(
        run, joint_t_ns=run.joint_t_ns[j:], joint_position_m=run.joint_position_m[j:],
        joint_velocity_m_s=run.joint_velocity_m_s[j:] if run.joint_velocity_m_s.size else run.joint_velocity_m_s,
        load_t_ns=run.load_t_ns[ld:], load_n=run.load_n[ld:], straightness_t_ns=run.straightness_t_ns[:0],
        straightness_m=run.straightness_m[:0])
    after = duty_cells_from_runs(after_run, params["slider_length_m"])
    e0, e1 = split.epoch == 0, split.epoch == 1
    assert split.work_nm[e0].sum() == pytest.approx(before.work_nm.sum(), rel=1e-12)
    assert split.work_nm.sum() == pytest.approx(whole.work_nm.sum(), rel=1e-12)
    assert split.reset_t_s.tolist() == [pytest.approx((reset_ns - T0_NS) * 1e-9)]
    assert split.reset_straightness_m.tolist() == [4e-6]

    def mean_s(cells, mask):
        return float(np.sum((cells.work_nm * cells.sliding_distance_m)[mask]) / np.sum(cells.work_nm[mask]))

    assert mean_s(split, e1) == pytest.approx(mean_s(after, slice(None)), rel=1e-3)
    assert mean_s(split, e0) == pytest.approx(mean_s(before, slice(None)), rel=1e-12)


def test_a_chain_of_bags_holds_one_bags_sqlite_cache_not_one_each(recording):
    """Reading a directory of splits, each storage read to its end frees its page cache: the SQLite memory
    held after the last split is the same for a chain of two bags and of three (it grew by a cache per bag)."""
    import apsw

    def held_after_reading(paths) -> int:
        with resolve_bags(paths).open_storage() as chained:
            before = apsw.memory_used()
            groups = chained.iter_packed(chained.connections, 500)
            assert sum(b.lengths.size for g in groups for b in g) == chained.message_count
            return apsw.memory_used() - before

    parts = recording["parts"]
    two, three = held_after_reading(parts[:2]), held_after_reading(parts)
    assert three <= two + 64 * 1024, (two, three)
