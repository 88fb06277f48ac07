"""README/docs promises end to end: the wear_monitor node's levels and output topics, checkpoints
(on shutdown, WAL + synchronous=FULL, loss <= one checkpoint period), `guide-health replay` and
`calibrate pin-on-disc` on the command line (files decoded, numbers against hand computations), and
`make demo`'s live == offline at a small size.

Truths: the status values the same node publishes (topics), the SQLite file read back with the stdlib,
Eq. 7/10 with the work summed here from the bag's positions (replay), ordinary least squares written here
(pin-on-disc), the offline replay of the same bag (demo)."""
from __future__ import annotations

import csv
import json
import math
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "config" / "bench_000.yaml"
SLEWING = ROOT / "config" / "slewing_131.32.2000.00Z.yaml"
PIN_ON_DISC = ROOT / "config" / "pin_on_disc_seed000.csv"


def cli(*args, check=True):
    proc = subprocess.run([sys.executable, "-m", "guide_health.cli", *args], capture_output=True, text=True,
                          timeout=600)
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


def png_pixels(path) -> np.ndarray:
    import matplotlib.image

    return matplotlib.image.imread(str(path))


# --- guide-health replay ---------------------------------------------------------------------------
def test_replay_end_to_end_files_and_eq7_numbers(tmp_path):
    """replay BAG --json: one JSON object equal to report.json, a CSV with one row per measurement whose
    measured column is the bag's values and residual = measured - model, a PNG that decodes; the
    straightness equals A0 + K 2 sum(W ds) / (H b (l_min + l_max)) with sum(W ds) summed here from the
    bag's positions (K held at the configured value by a tiny prior sd and no effect).
    Catches: a dropped factor 2 or swapped b/H in Eq. 7, CSV columns swapped, a report.json that is not
    what --json printed."""
    from guide_health.io.bag.writer import write_machine_bag
    from guide_health.params import simulation_params, wear_monitor_params
    from guide_health.sim.machine import simulate_machine

    doc = yaml.safe_load(BENCH.read_text())
    doc["/**/wear_monitor"]["ros__parameters"]["wear_coefficient_prior_rel_sd"] = 1e-9
    params_file = tmp_path / "bench_fixed_k.yaml"
    params_file.write_text(yaml.safe_dump(doc))
    p = wear_monitor_params(params_file)
    sim = dict(simulation_params(params_file), duration_h=1.0, joint_state_rate_hz=10.0, load_rate_hz=1.0,
               measurement_interval_h=0.25)
    run = simulate_machine(p, sim, seed=3)
    bag = tmp_path / "bag"
    write_machine_bag(run, bag)
    out = tmp_path / "rep"
    printed = json.loads(cli("replay", str(bag), "--params", str(params_file), "--out", str(out), "--json").stdout)
    saved = json.loads((out / "report.json").read_text())
    files = printed.pop("files")
    assert json.dumps(printed, sort_keys=True) == json.dumps(saved, sort_keys=True)
    assert set(files) == {"json", "csv", "png"}
    # the bench holds 6000 N on feed and return (bench_000.yaml): sum(W ds) = 6000 N x the sampled path length
    assert np.all(run.load_n == 6000.0)
    work_nm = 6000.0 * np.abs(np.diff(run.joint_position_m)).sum()
    l_sum = printed["stroke_min_m"] + printed["stroke_max_m"]
    hbl = p["hardness_pa"] * p["contact_width_m"] * l_sum
    eq7_um = 1e6 * (p["straightness_initial_m"] + p["wear_coefficient"] * 2 * work_nm / hbl)
    assert printed["wear_coefficient"] == pytest.approx(p["wear_coefficient"], rel=1e-6)
    assert printed["straightness_um"] == pytest.approx(eq7_um, rel=2e-3)
    assert printed["samples"] == run.joint_t_ns.size and printed["measurements"] == run.straightness_m.size
    with open(out / "straightness.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert list(rows[0]) == ["time_h", "straightness_measured_um", "straightness_model_um", "residual_um"]
    assert len(rows) == run.straightness_m.size
    measured = np.array([float(r["straightness_measured_um"]) for r in rows])
    np.testing.assert_allclose(measured, run.straightness_m * 1e6, atol=2e-6)
    for r in rows:
        assert float(r["residual_um"]) == pytest.approx(
            float(r["straightness_measured_um"]) - float(r["straightness_model_um"]), abs=3e-6)
    assert float(rows[-1]["straightness_model_um"]) == pytest.approx(printed["straightness_um"], rel=1e-3)
    img = png_pixels(out / "straightness.png")
    assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 200 and img.std() > 0


def test_replay_detects_a_slewing_bag(tmp_path):
    """A bag with slewing/load and no joint_states is analysed as a slewing bearing: kind 'slewing',
    one CSV row per load message (200 Hz crane duty), the CSV's worst pressure is the report's, every
    sample counted in a level, contact.png decodes."""
    bag = tmp_path / "slew"
    cli("simulate", "--kind", "slewing", "--params", str(SLEWING), "--out", str(bag), "--hours", "0.02")
    out = tmp_path / "rep"
    rep = json.loads(cli("replay", str(bag), "--params", str(SLEWING), "--out", str(out), "--json").stdout)
    assert rep["kind"] == "slewing"
    assert rep["messages"] == round(0.02 * 3600 * 200)
    data = np.loadtxt(out / "contact.csv", delimiter=",", skiprows=1)
    assert data.shape == (rep["messages"], 5)
    assert data[:, 4].max() == pytest.approx(rep["p_max_MPa"], rel=1e-5)
    assert rep["samples_ok"] + rep["samples_warn"] + rep["samples_error"] == rep["messages"]
    assert png_pixels(out / "contact.png").shape[0] > 200


# --- guide-health calibrate pin-on-disc ----------------------------------------------------------------
def test_calibrate_pin_on_disc_end_to_end_against_least_squares_written_here(tmp_path):
    """calibrate pin-on-disc CSV --json: K = H c with c the least-squares slope of gamma on W v through the
    origin (seed 000 Eq. 13; Table 2 rows in config/), its 95 % interval with Student t(n-1), R^2 centred
    and uncentred; text output without --json; a CSV without the columns is one line, exit 2.
    Catches: a fit with an intercept, a K not multiplied by H, a normal instead of t quantile."""
    from scipy import stats

    with open(PIN_ON_DISC) as handle:
        rows = list(csv.DictReader(handle))
    v = np.array([float(r["speed_m_s"]) for r in rows])
    w = np.array([float(r["load_n"]) for r in rows])
    g = np.array([float(r["wear_rate_m3_s"]) for r in rows])
    x = w * v
    c = (x * g).sum() / (x * x).sum()
    resid = g - c * x
    se = math.sqrt((resid ** 2).sum() / (x.size - 1) / (x * x).sum())
    h = 199e6
    out = json.loads(cli("calibrate", "pin-on-disc", str(PIN_ON_DISC), "--hardness-pa", str(h), "--json").stdout)
    assert out["rows"] == 8
    assert out["wear_coefficient"] == pytest.approx(c * h, rel=1e-9)
    assert out["wear_coefficient"] == pytest.approx(4.42e-6, rel=0.03)            # seed 000's K (3 %)
    t = stats.t.ppf(0.975, x.size - 1)
    assert out["wear_coefficient_ci95"] == pytest.approx([(c - t * se) * h, (c + t * se) * h], rel=1e-6)
    assert out["r_squared"] == pytest.approx(1 - (resid ** 2).sum() / ((g - g.mean()) ** 2).sum(), rel=1e-9)
    assert out["r_squared_uncentred"] == pytest.approx(1 - (resid ** 2).sum() / (g ** 2).sum(), rel=1e-9)
    text = cli("calibrate", "pin-on-disc", str(PIN_ON_DISC), "--hardness-pa", str(h)).stdout
    assert f"{c * h:.6g}" in text
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b\n1,2\n")
    proc = cli("calibrate", "pin-on-disc", str(bad), "--hardness-pa", str(h), check=False)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr


# --- the node: levels, output topics, checkpoints -----------------------------------------------------
rclpy = pytest.importorskip("rclpy")
from std_msgs.msg import Float64  # noqa: E402
from test_wear_monitor_node import feed_cycle, joint, make_node  # noqa: E402

T0 = 1_700_000_000


def _status(node):
    node.publish_diagnostics()
    status = node.published[-1].status[0]
    return status.level, status.message, {kv.key: kv.value for kv in status.values}


@pytest.mark.ros
def test_node_warn_then_error_levels_and_output_topics_carry_the_status_values(ros_context, tmp_path):
    """Thresholds set from the node's own remaining life L (life_warn_h 2L: WARN; life_error_h 2L: ERROR);
    guide/straightness_predicted [m] and guide/remaining_life [s] as received by a subscriber carry the
    status's straightness_um and remaining_life_h (exactly, after the unit change).
    Catches: levels never leaving OK, swapped thresholds, a topic in um or h, a topic not published."""
    from rclpy.executors import SingleThreadedExecutor

    probe = make_node(ros_context, tmp_path / "probe", life_warn_h=1.0, life_error_h=0.1)
    feed_cycle(probe, T0 + 1.0)
    life_h = float(_status(probe)[2]["remaining_life_h"])
    probe.close()
    probe.destroy_node()
    assert math.isfinite(life_h) and life_h > 0
    expected = {"ok": (b"\x00", 0.5 * life_h, 0.25 * life_h), "warn": (b"\x01", 2.0 * life_h, 0.5 * life_h),
                "error": (b"\x02", 4.0 * life_h, 2.0 * life_h)}
    for name, (level, warn_h, error_h) in expected.items():
        node = make_node(ros_context, tmp_path / name, life_warn_h=warn_h, life_error_h=error_h)
        listener = rclpy.create_node(f"listener_{name}", context=ros_context)
        got = {"pred": [], "life": []}
        listener.create_subscription(Float64, "guide/straightness_predicted", got["pred"].append, 10)
        listener.create_subscription(Float64, "guide/remaining_life", got["life"].append, 10)
        executor = SingleThreadedExecutor(context=ros_context)
        executor.add_node(node)
        executor.add_node(listener)
        try:
            feed_cycle(node, T0 + 1.0)
            deadline = time.monotonic() + 120.0      # ends once the listener has matched and received both
            while time.monotonic() < deadline and not (got["pred"] and got["life"]):
                node.publish_diagnostics()
                executor.spin_once(timeout_sec=0.1)
            status = node.published[-1].status[0]
            values = {kv.key: kv.value for kv in status.values}
            assert status.level == level, (name, status.message)
            assert "remaining precision life" in status.message
            assert got["pred"] and got["life"], "output topics not received"
            assert got["pred"][-1].data == float(values["straightness_um"]) * 1e-6
            assert got["life"][-1].data == float(values["remaining_life_h"]) * 3600.0
            assert got["life"][-1].data / 3600.0 == pytest.approx(life_h, rel=1e-9)
        finally:
            executor.shutdown()
            listener.destroy_node()
            node.close()
            node.destroy_node()


@pytest.mark.ros
def test_checkpoint_on_shutdown_wal_and_synchronous_full(ros_context, tmp_path):
    """interfaces.md: 'one atomic transaction every checkpoint_period_s, and again on shutdown; WAL journal,
    synchronous=FULL'. With a checkpoint period far longer than the test, close() alone writes the state,
    and that state is the monitor's, completely (samples included); the journal mode read back from the
    file is WAL and the node's connection runs synchronous=FULL (2)."""
    node = make_node(ros_context, tmp_path, checkpoint_period_s=3600.0)
    try:
        feed_cycle(node, T0 + 1.0)
        node._on_straightness(Float64(data=16e-6))
        assert node.store._db.execute("PRAGMA synchronous").fetchone()[0] == 2
        with sqlite3.connect(tmp_path / "state.db") as db:
            assert db.execute("SELECT COUNT(*) FROM monitor_state").fetchone()[0] == 0   # nothing saved yet
        final = json.loads(json.dumps(node.monitor.state()))
    finally:
        node.close()
        node.destroy_node()
    with sqlite3.connect(tmp_path / "state.db") as db:
        assert db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
        saved = json.loads(db.execute("SELECT state_json FROM monitor_state").fetchone()[0])
    assert saved == final
    assert saved["integrator"]["samples"] > 100


@pytest.mark.ros
def test_a_killed_node_loses_at_most_one_checkpoint_period(ros_context, tmp_path):
    """Samples fed while the node's timers run (checkpoint_period_s = 0.2 s); the node is then dropped without
    close() (a kill: only timer checkpoints survive). The restarted node's samples are every sample fed up to
    at most one checkpoint period (plus one spin) before the kill.
    Catches: no periodic checkpoint, a checkpoint of stale state, a restore that drops counters."""
    from rclpy.executors import SingleThreadedExecutor

    period = 0.2
    node = make_node(ros_context, tmp_path, checkpoint_period_s=period)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    fed = []                           # (wall time, samples fed so far)
    t, x, n = T0 + 1.0, 0.0, 0
    saves = []
    original_save = node.store.save
    node.store.save = lambda *a, **kw: (saves.append(time.monotonic()), original_save(*a, **kw))[1]
    start = time.monotonic()
    while time.monotonic() - start < 1.5:
        for _ in range(20):
            t += 0.02
            x = 0.1 * abs(math.sin(n * 0.01))
            node._on_joint(joint(t, [x]))
            n += 1
        fed.append((time.monotonic(), node.monitor.integrator.samples))
        executor.spin_once(timeout_sec=0.002)
    kill_at = time.monotonic()
    executor.remove_node(node)
    node.store.close()                 # a dead process: its lock goes, no shutdown checkpoint (no node.close())
    node.destroy_node()
    executor.shutdown()
    node2 = make_node(ros_context, tmp_path, checkpoint_period_s=period)
    try:
        restored = node2.monitor.integrator.samples
    finally:
        node2.close()
        node2.destroy_node()
    assert len(saves) >= 4, saves
    total = fed[-1][1]
    floor = max(s for w, s in fed if w <= kill_at - period - 0.05)   # fed one period (+ a spin) before the kill
    assert floor <= restored <= total
    assert restored > 0.5 * total


# --- make demo: live == offline at a small size ----------------------------------------------------------
@pytest.mark.ros
def test_demo_live_equals_offline_small(tmp_path, ros_test_env):
    """`make demo` = guide_health.demo; at 0.5 h and 5 Hz it runs the same four parts (simulate, live
    bag_player -> wear_monitor, offline replay, report + PNG). The printed live - offline gaps of
    straightness and remaining life are 0.000 % and the files decode."""
    from guide_health.nodes.session import clean_fastdds_shm

    out = tmp_path / "demo"
    # the demo reserves a domain of its own; the live tests' transports (UDP only) come with the environment
    proc = subprocess.run([sys.executable, "-m", "guide_health.demo", "--hours", "0.5", "--rate", "5",
                           "--out", str(out)], capture_output=True, text=True, timeout=600, env=ros_test_env())
    clean_fastdds_shm()
    assert proc.returncode == 0, proc.stderr[-2000:]
    line = next(s for s in proc.stdout.splitlines() if s.startswith("offline replay"))
    gaps = line.split("live - offline:")[1].strip(" )").replace("%", "").split(",")
    assert [float(g) for g in gaps] == [0.0, 0.0], line
    report = json.loads((out / "report" / "report.json").read_text())
    assert report["samples"] == round(0.5 * 3600 * 5) + 1 or report["samples"] > 0.99 * 0.5 * 3600 * 5
    assert png_pixels(out / "report" / "straightness.png").shape[0] > 200
