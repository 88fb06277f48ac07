"""The slewing bearing's fatigue damage survives a restart: the damage per row and the angle-counting state
(the open stroke, the load in force, the stamps) saved to the node's SQLite state file and restored give the
numbers of the uninterrupted run; a saved state that does not read back is refused in one line, counted, and
the damage starts at zero. Truth: the same SlewingFatigue fed the same samples without interruption, and the
damage 2 / L10 of ISO 281 written in the test (seed 003 bearing, 55 HRC)."""
import dataclasses
import json
import math
import os
import signal
import sqlite3
import time
from pathlib import Path

import numpy as np
import pytest

from guide_health.io.state_store import StateStore
from guide_health.models.slewing.fatigue import SlewingFatigue, check_fatigue_state
from guide_health.models.slewing.rating import ROWS, slewing_ratings
from guide_health.params import SLEWING_MONITOR_DEFAULTS, load_node_params
from guide_health.sim.slewing import simulate_slewing

Z, D_M, L_M, DPW_M = 170, 0.032, 0.0313, 2.0
# ISO 281 Eq. (11), thrust f_c interpolated in Table 9 at D/D_pw = 0.016, b_m = 1.0, hardness (55/58)^3.6
C_AXIAL_55 = (105.4 + 0.6 * (122.9 - 105.4)) * 31.3 ** (7 / 9) * Z ** 0.75 * 32.0 ** (29 / 27) * (55 / 58) ** 3.6


def duty():
    """(kind, values) samples: loads that reverse the moment, a yaw-like large rotation, pitch-like small
    oscillations (below theta_crit = 2.1 deg), encoder noise, and a stroke left open at the end."""
    rng = np.random.default_rng(7)
    samples, t, phi0 = [], 0.0, 0.0
    for block in range(6):
        samples.append(("load", (4.0e5 + 5e4 * block, 1.0e5, (-1) ** block * 2.0e6)))
        if block % 2 == 0:       # a large rotation then back part of the way
            path = phi0 + np.concatenate([np.linspace(0, 3.0, 300), np.linspace(3.0, 1.0, 200)])
        else:                    # small oscillations of 1 deg amplitude with noise
            k = np.arange(800)
            path = phi0 + math.radians(1.0) * np.sin(2 * np.pi * k / 100) + rng.normal(0, 1e-4, k.size)
        for phi in path:
            t += 0.5
            samples.append(("angle", (float(phi), t)))
        phi0 = float(path[-1])
    return samples


def feed(fatigue, samples):
    for kind, values in samples:
        if kind == "load":
            fatigue.on_loads(*values)
        else:
            fatigue.on_angle(*values)


def ratings():
    return slewing_ratings(Z, Z, D_M, L_M, DPW_M, 55.0)


def test_save_restore_round_trip_equals_the_uninterrupted_run(tmp_path):
    """Cut anywhere (mid-stroke, right after a load, between blocks), through the SQLite file and back: the
    report (damage per row, remaining lives, strokes, static safety) equals the uninterrupted run's exactly."""
    samples = duty()
    whole = SlewingFatigue(ratings())
    feed(whole, samples)
    _, _, expected = whole.report()
    assert expected["oscillation_strokes_below_critical"] > 10 and expected["fatigue_damage_lower_axial"] > 0
    for cut in (1, 250, 801, 1700, len(samples) - 3):
        first = SlewingFatigue(ratings())
        feed(first, samples[:cut])
        store = StateStore(tmp_path / f"cut{cut}.db")
        store.save({"k": first.state()})
        saved = store.load("k")
        store.close()
        second = SlewingFatigue(ratings())
        second.restore(saved)
        feed(second, samples[cut:])
        _, _, values = second.report()
        assert values == expected, cut
    # without the angle-counting state (damage only) the result differs: the test sees the open stroke
    partial = SlewingFatigue(ratings())
    feed(partial, samples[:801])
    fresh = SlewingFatigue(ratings())
    fresh.damage = dict(partial.damage)
    feed(fresh, samples[801:])
    assert fresh.report()[2]["fatigue_damage_upper_axial"] != expected["fatigue_damage_upper_axial"]


@pytest.mark.parametrize("field, value, words", [
    ("damage", {"upper_axial": -1e-3, "lower_axial": 0.0, "radial": 0.0}, "damage of the upper_axial row"),
    ("damage", {"upper_axial": 0.0, "radial": 0.0}, "damage must hold the rows"),
    ("stroke_weighted", {row: math.nan for row in ROWS}, "stroke_weighted of the upper_axial row"),
    ("direction", 2, "direction must be -1, 0 or 1"),
    ("strokes", 1.5, "strokes must be an integer >= 0"),
    ("last_rad", "x", "last_rad must be finite or null"),
    ("min_static_safety", 0.0, "min_static_safety must be > 0"),
])
def test_a_corrupted_state_is_refused_in_one_line_and_changes_nothing(field, value, words):
    fatigue = SlewingFatigue(ratings())
    feed(fatigue, duty()[:300])
    good = fatigue.state()
    check_fatigue_state(good)
    bad = dict(good, **{field: value})
    other = SlewingFatigue(ratings())
    before = other.state()
    with pytest.raises(ValueError, match=words) as info:
        other.restore(bad)
    assert "\n" not in str(info.value)
    assert other.state() == before
    with pytest.raises(ValueError, match="lacks worst_static"):
        check_fatigue_state({k: v for k, v in good.items() if k != "worst_static"})


def _node(ros_context, state_file):
    from rclpy.parameter import Parameter

    from guide_health.nodes.slewing_monitor import SlewingMonitorNode

    node = SlewingMonitorNode(context=ros_context,      # fed in stamp order here: on arrival
                              parameter_overrides=[Parameter("state_file", value=str(state_file)),
                                                   Parameter("input_align_window_s", value=0.0)])
    node.diag_pub.publish = lambda msg: None
    return node


def _turn(node, revolutions_from, revolutions_to, steps=36):
    from sensor_msgs.msg import JointState

    for k in range(int(revolutions_from * steps), int(revolutions_to * steps) + 1):
        js = JointState(name=["slew"], position=[2 * math.pi * k / steps])
        js.header.stamp.sec = k
        node._on_axis(js)


def test_node_resumes_the_damage_and_refuses_a_corrupted_row(ros_context, tmp_path):
    """1 revolution, close (checkpoint), restart, 1 more: damage 2 / L10 (ISO 281 by hand) as the
    uninterrupted node; then the saved row overwritten with a negative damage: refused in one line, counted,
    the damage starts at zero (and the next checkpoint writes a good row)."""
    from geometry_msgs.msg import WrenchStamped

    state_file = tmp_path / "slewing.db"
    load = WrenchStamped()
    load.wrench.force.z = 5.0e5
    l10 = 1e6 * (C_AXIAL_55 / 5.0e5) ** (10 / 3)
    node = _node(ros_context, state_file)
    try:
        node._on_load(load)
        _turn(node, 0, 1)
        node.close()
    finally:
        node.destroy_node()
    node = _node(ros_context, state_file)
    try:
        assert node.state_refused == 0 and node._report()[2]["state_refused"] == 0
        _turn(node, 1, 2)           # no new load sample: the load in force was restored
        damage = node.core.fatigue.row_damage()
        assert damage["upper_axial"] == pytest.approx(2 / l10, rel=1e-6)
        assert node.core.fatigue.last_t_s == 72 and node.core.fatigue.first_t_s == 0
        node.close()
    finally:
        node.destroy_node()
    db = sqlite3.connect(str(state_file))
    (text,), = db.execute("SELECT state_json FROM monitor_state").fetchall()
    state = json.loads(text)
    state["damage"]["upper_axial"] = -0.5
    db.execute("UPDATE monitor_state SET state_json = ?", (json.dumps(state),))
    db.commit()
    db.close()
    node = _node(ros_context, state_file)
    try:
        assert node.state_refused == 1
        assert node._report()[2]["state_refused"] == 1            # a key of the published status
        assert "state_refused" in node.updater.tasks[0].optional_keys
        assert node.core.fatigue.row_damage() == dict.fromkeys(ROWS, 0.0)
        node.close()
    finally:
        node.destroy_node()
    store = StateStore(state_file)
    try:
        check_fatigue_state(store.load("machine/131.32.2000.00Z/slewing_fatigue"))
    finally:
        store.close()


ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config" / "slewing_131.32.2000.00Z.yaml"
DAMAGE_KEYS = (*(f"fatigue_damage_{row}" for row in ROWS), "oscillation_strokes",
               "oscillation_strokes_below_critical")


def slewing_run_with_axis(seed=2, hours=0.01, load_rate_hz=50.0, axis_rate_hz=10.0):
    """The simulator's crane loads and a slewing axis written here: a yaw-like rotation of 1.5 rad over the
    first half, then 0.5 deg pitch-like oscillations (period 2 s, below theta_crit = 2.1 deg)."""
    run = simulate_slewing({"duration_h": hours, "load_rate_hz": load_rate_hz}, seed=seed)
    t_s = np.arange(int(hours * 3600 * axis_rate_hz)) / axis_rate_hz + 0.013
    half = 0.5 * hours * 3600
    angle = np.where(t_s < half, 1.5 * t_s / half,
                     1.5 + math.radians(0.5) * np.sin(2 * np.pi * (t_s - half) / 2.0))
    t_ns = int(run.t_ns[0]) + np.round(t_s * 1e9).astype(np.int64)
    return dataclasses.replace(run, axis_t_ns=t_ns, axis_angle_rad=angle)


def test_a_slewing_bag_carries_its_axis_and_replay_reports_the_damage(tmp_path):
    """write_slewing_bag -> read_slewing_bag gives the axis arrays back bit for bit; `replay`'s analysis of
    the bag reports the damage keys of the in-memory run exactly; the bag is still a slewing bag."""
    from guide_health.analysis.replay import analyse_slewing_bag
    from guide_health.analysis.slewing_replay import analyse_slewing_run
    from guide_health.io.bag.info import is_slewing_bag
    from guide_health.io.bag.reader import read_slewing_bag
    from guide_health.io.bag.writer import write_slewing_bag

    run = slewing_run_with_axis()
    bag = write_slewing_bag(run, tmp_path / "slewing")
    assert is_slewing_bag(bag)
    back = read_slewing_bag(bag)
    assert np.array_equal(back.axis_t_ns, run.axis_t_ns) and np.array_equal(back.axis_angle_rad, run.axis_angle_rad)
    params = load_node_params(CONFIG, "slewing_monitor", SLEWING_MONITOR_DEFAULTS)
    _, expected = analyse_slewing_run(run, params)
    _, report, _, _ = analyse_slewing_bag(bag, params)
    assert report["oscillation_strokes_below_critical"] > 10 and report["fatigue_damage_upper_axial"] > 0
    for key in DAMAGE_KEYS:
        assert report[key] == expected[key], key
    # the axis under another joint name: none read, no damage keys (the joint is the parameter's)
    other = write_slewing_bag(run, tmp_path / "other", axis_joint="yaw")
    _, report, _, _ = analyse_slewing_bag(other, params)
    assert "fatigue_damage_upper_axial" not in report


@pytest.mark.ros
def test_live_through_a_bag_equals_replay_and_sigkill_restart_resumes(tmp_path, ros_test_env):
    """bag_player -> slewing_monitor: the damage keys equal the offline replay of the same bag (loads and
    angles arrive on two topics; the node takes them in stamp order as the replay does: 1e-6, where one angle
    step at the neighbouring load sample moves the damage by ~1e-4);
    then SIGKILL and a restart: the start-up line says resumed and the first status carries the damage of
    the last checkpoint (the node ran > 2 checkpoint periods past the bag's end before the kill: the final
    damage)."""
    from guide_health.analysis.replay import analyse_slewing_bag
    from guide_health.io.bag.writer import write_slewing_bag
    from guide_health.nodes.session import DiagnosticsCollector, clean_fastdds_shm, play_bag, start_node, stop_node

    env = ros_test_env()
    bag = write_slewing_bag(slewing_run_with_axis(), tmp_path / "slewing")
    params = load_node_params(CONFIG, "slewing_monitor", SLEWING_MONITOR_DEFAULTS)
    _, offline, _, _ = analyse_slewing_bag(bag, params)
    name = "slewing_131/slewing_monitor: 131.32.2000.00Z roller contact"
    overrides = {"diagnostics_period_s": 0.2, "input_timeout_s": 2.0, "checkpoint_period_s": 0.5,
                 "state_file": str(tmp_path / "state.db")}
    collector = DiagnosticsCollector("slewing_state_collector")
    node = start_node("guide_health.nodes.slewing_monitor", CONFIG, overrides, env, tmp_path / "node1.log")
    try:
        assert collector.wait_for(name, timeout=120.0) is not None, (tmp_path / "node1.log").read_text()
        played = play_bag(bag, env, ["--wait-subscribers", "1"])
        assert played.returncode == 0, played.stderr
        done = collector.wait_for(name, lambda s: int(float(s["values"]["oscillation_strokes"])) >= offline[
            "oscillation_strokes"] and s["level"] == 3, timeout=120.0)
        assert done is not None, [(s["level"], s["values"].get("oscillation_strokes"))
                                  for s in collector.history.get(name, [])][-5:]
        # a status stamped > 2 checkpoint periods after the final one: the node's timers ran on past it, so its
        # checkpoint timer fired since (node time, not a quiet wall time, which a CPU-starved node may not use)
        past = done["stamp_ns"] + int(3 * overrides["checkpoint_period_s"] * 1e9)
        assert collector.wait_for(name, lambda s: s["stamp_ns"] >= past, timeout=120.0) is not None
        os.kill(node.pid, signal.SIGKILL)
        node.wait()
        clean_fastdds_shm()
        live = done["values"]
        for key in DAMAGE_KEYS:
            assert float(live[key]) == pytest.approx(offline[key], rel=1e-6), key
        node = start_node("guide_health.nodes.slewing_monitor", CONFIG, overrides, env, tmp_path / "node2.log")
        end = time.monotonic() + 120.0
        while "resumed from" not in (tmp_path / "node2.log").read_text() and time.monotonic() < end:
            time.sleep(0.2)
        started = time.monotonic()          # node 2 has restored the state: its statuses from now on
        resumed = collector.wait_for(name, lambda s: s["received"] > started + 0.5, timeout=120.0)
        assert resumed is not None, (tmp_path / "node2.log").read_text()
    finally:
        stop_node(node)
        collector.close()
        clean_fastdds_shm()
    log = (tmp_path / "node2.log").read_text()
    assert f"state {tmp_path / 'state.db'} (resumed)" in log and "fatigue damage upper_axial" in log, log
    for key in DAMAGE_KEYS:
        assert float(resumed["values"][key]) == float(live[key]), key


def test_stamp_merge_releases_both_topics_in_stamp_order_whatever_the_arrival_order():
    """Random interleavings of two stamp-ordered streams (loads every 20, angles every 100 + 13 and one at a
    load's stamp) come out in the replay's order: by stamp, a load before an angle of equal stamp; the tail
    waits for the other topic's silence (window 0.5 s), then goes."""
    from guide_health.models.slewing.stamp_merge import ANGLE, LOAD, StampMerge

    loads = [(LOAD, 20 * k) for k in range(1, 60)]
    angles = [(ANGLE, 100 * k + 13) for k in range(10)] + [(ANGLE, 1000)]
    expected = sorted(loads + angles, key=lambda s: (s[1], s[0] == ANGLE))
    rng = np.random.default_rng(3)
    for _ in range(20):
        out = []
        merge = StampMerge(lambda kind, t, out=out: out.append((kind, t)), 0.5)
        merge.add(ANGLE, 0, 0, 1.0)         # the first before the other topic is seen goes at once
        merge.add(LOAD, 0, 0, 1.0)          # an angle at its stamp was seen: it goes
        assert out == [(ANGLE, 0), (LOAD, 0)]
        out.clear()
        i = j = 0
        while i < len(loads) or j < len(angles):
            if j >= len(angles) or (i < len(loads) and rng.random() < 0.7):
                merge.add(*loads[i], loads[i][1], 1.0)
                i += 1
            else:
                merge.add(*angles[j], angles[j][1], 1.0)
                j += 1
        merge.release(1.4)
        assert len(out) < len(expected)     # the tail waits for the other topic
        merge.release(1.5)
        assert out == expected
