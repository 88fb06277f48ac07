"""Issue 10 item 5 and issue 16 (state): every state-file failure is one InputError line naming the file and
what to do; a state that does not validate, or belongs to another machine/guide, is refused whole; two
processes on one state file: the second is refused; the file is 0600 and never written through a symlink."""
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from guide_health.errors import InputError
from guide_health.io.state_store import StateStore, resolve_state_path
from guide_health.models.wear.precision import PrecisionMonitor
from guide_health.models.wear.state_schema import check_precision_state, state_fingerprint
from guide_health.params import WEAR_MONITOR_DEFAULTS
from guide_health.params.typed import wear_axis_params

ROOT = Path(__file__).resolve().parents[1]
PARAMS = dict(WEAR_MONITOR_DEFAULTS, machine_id="m1")


def fingerprint(params: dict) -> dict:
    """The saved state's fingerprint of a wear_monitor parameter dict (models/wear/state_schema.py)."""
    return state_fingerprint(params["machine_id"], wear_axis_params(params))


def _one_line(exc, *words):
    text = str(exc.value)
    assert "\n" not in text and all(w in text for w in words), text


def test_garbage_directory_and_unreachable_paths_are_one_line(tmp_path):
    garbage = tmp_path / "garbage.db"
    garbage.write_bytes(os.urandom(4096))
    with pytest.raises(InputError) as err:
        StateStore(garbage)
    _one_line(err, str(garbage), "not a usable guide_health state database", "move it away")
    with pytest.raises(InputError) as err:
        StateStore(tmp_path)
    _one_line(err, str(tmp_path), "is a directory")
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(InputError) as err:
        StateStore(blocker / "state.db")
    _one_line(err, "cannot create its folder")


def test_state_file_is_private_and_never_written_through_a_symlink(tmp_path):
    store = StateStore(tmp_path / "s.db")
    store.save({"k": {"a": 1.0}})
    store.close()
    assert (tmp_path / "s.db").stat().st_mode & 0o777 == 0o600
    target = tmp_path / "victim"
    target.write_text("keep")
    (tmp_path / "link.db").symlink_to(target)
    with pytest.raises(InputError) as err:
        StateStore(tmp_path / "link.db")
    _one_line(err, "symbolic link")
    assert target.read_text() == "keep"


def test_second_store_on_one_file_is_refused_until_the_first_closes(tmp_path):
    first = StateStore(tmp_path / "s.db")
    with pytest.raises(InputError) as err:
        StateStore(tmp_path / "s.db")
    _one_line(err, "in use by another process", f"pid {os.getpid()}")
    first.close()
    StateStore(tmp_path / "s.db").close()


def test_second_process_is_refused(tmp_path):
    code = ("import sys, time; from guide_health.io.state_store import StateStore; "
            f"s = StateStore({str(tmp_path / 's.db')!r}); print('locked', flush=True); time.sleep(30)")
    holder = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True,
                              env=dict(os.environ, PYTHONPATH=str(ROOT)))
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(InputError) as err:
            StateStore(tmp_path / "s.db")
        _one_line(err, f"pid {holder.pid}")
    finally:
        holder.kill()
        holder.wait()
    StateStore(tmp_path / "s.db").close()      # the lock went with the killed process


def test_auto_path_is_derived_from_ros_home_machine_and_node(monkeypatch, tmp_path):
    monkeypatch.setenv("ROS_HOME", str(tmp_path))
    assert resolve_state_path("auto", "m1", "wear_monitor") == tmp_path / "guide_health" / "m1" / "wear_monitor.db"
    assert resolve_state_path("auto", "../evil", "wm") == tmp_path / "guide_health" / ".._evil" / "wm.db"
    assert resolve_state_path("", "m1", "wm") is None and resolve_state_path("none", "m1", "wm") is None
    monkeypatch.delenv("ROS_HOME")
    assert resolve_state_path("auto", "m1", "wm") == Path.home() / ".ros" / "guide_health" / "m1" / "wm.db"


def _state():
    return PrecisionMonitor(wear_axis_params(PARAMS)).state()


@pytest.mark.parametrize("edit,words", [
    (lambda s: s["integrator"].pop("sliding_distance_m"), ["integrator.sliding_distance_m is missing"]),
    (lambda s: s["integrator"].__setitem__("sliding_distance_m", "12"), ["integrator.sliding_distance_m",
                                                                         "a number"]),
    (lambda s: s["integrator"].__setitem__("samples", 1.5), ["integrator.samples", "64-bit integer"]),
    (lambda s: s["integrator"]["profile_work_n"].pop(), ["profile_work_n", "entries"]),
    (lambda s: s["estimator"]["measurement_m"].append(1e-5), ["estimator.measurement_", "length"]),
    (lambda s: s.__setitem__("rolling", {"version": 1}), ["rolling guide, but guide_type is a sliding"]),
    (lambda s: s.__setitem__("extra", 1), ["state.extra is not a field"]),
    (lambda s: s["integrator"].__setitem__("archard_work_nm", float("nan")), ["archard_work_nm", "finite"]),
    (lambda s: s["integrator"].__setitem__("sliding_distance_m", -1.0), ["sliding_distance_m", ">= 0"]),
    (lambda s: s["integrator"].__setitem__("last_t_ns", "123"), ["last_t_ns", "64-bit integer"]),
    (lambda s: s["integrator"].__setitem__("samples", 2**64), ["integrator.samples", "64-bit integer"]),
    (lambda s: s["estimator"]["measurement_t_ns"].append(1.5), ["measurement_t_ns[0]", "64-bit integer"]),
    (lambda s: s.__setitem__("load_n", None), ["load_n", "a number"]),
])
def test_a_state_that_does_not_validate_is_refused(edit, words):
    state = _state()
    edit(state)
    with pytest.raises(InputError) as err:
        check_precision_state(state, _state())
    _one_line(err, *words)


def test_nan_sentinels_of_a_fresh_monitor_are_accepted_and_a_saved_state_round_trips(tmp_path):
    """NaN/inf are the 'not yet known' markers of a fresh monitor (last position, stroke minimum): kept."""
    store = StateStore(tmp_path / "s.db")
    store.save({"k": _state()})
    loaded = store.load("k", None, lambda s: check_precision_state(s, _state()))
    assert json.dumps(loaded, sort_keys=True) == json.dumps(_state(), sort_keys=True)
    store.close()


def test_a_measurement_before_the_stroke_is_known_round_trips(tmp_path):
    """A straightness taken before any stroke has g_j = NaN (Eq. 7 undefined): a legal saved state, found by
    test_live_replay's SIGKILL restart (the node refused its own state)."""
    monitor = PrecisionMonitor(wear_axis_params(dict(WEAR_MONITOR_DEFAULTS)))
    state = monitor.state()
    state["estimator"].update(measurement_t_ns=[5], measurement_m=[1e-6], measurement_loss_per_k_m=[float("nan")],
                              measurement_work_nm=[0.0])
    check_precision_state(state, monitor.state())
    state["estimator"]["measurement_m"] = [float("nan")]
    with pytest.raises(InputError):
        check_precision_state(state, monitor.state())


def test_a_refused_state_is_one_line_naming_the_file_and_what_to_do(tmp_path):
    store = StateStore(tmp_path / "s.db")
    state = _state()
    state["integrator"]["profile_work_n"][3] = float("inf")
    store.save({"k": state})
    with pytest.raises(InputError) as err:
        store.load("k", None, lambda s: check_precision_state(s, _state()))
    _one_line(err, str(tmp_path / "s.db"), "profile_work_n[3]", "finite", "move the file away")
    store._db.execute("UPDATE monitor_state SET state_json = ?", ("[" * 100000,))
    with pytest.raises(InputError) as err:
        store.load("k")
    _one_line(err, "not valid JSON", "move the file away")
    store.close()


def test_unwritable_folder_is_one_line(tmp_path):
    """A folder the process cannot write in (root writes anywhere but in /proc)."""
    locked = tmp_path / "ro"
    locked.mkdir(mode=0o500)
    path = Path("/proc/self/s.db") if os.geteuid() == 0 else locked / "s.db"
    with pytest.raises(InputError) as err:
        StateStore(path)
    _one_line(err, str(path), "lock file", "writable path")


def test_fingerprint_refuses_another_geometry_or_machine(tmp_path):
    store = StateStore(tmp_path / "s.db")
    store.save({"m1/x/precision": _state()}, fingerprint(PARAMS))
    assert store.load("m1/x/precision", fingerprint(PARAMS)) is not None
    with pytest.raises(InputError) as err:
        store.load("m1/x/precision", state_fingerprint("m1", wear_axis_params(dict(PARAMS, rail_length_m=0.9))))
    _one_line(err, "saved for another guide", "rail_length_m 0.5 (now 0.9)")
    with pytest.raises(InputError) as err:
        store.load("m2/x/precision", state_fingerprint("m2", wear_axis_params(PARAMS)))
    _one_line(err, "machine_id 'm1'")
    store.close()


rclpy = pytest.importorskip("rclpy")


def _node(ros_context, path, **overrides):
    from rclpy.parameter import Parameter

    from guide_health.nodes.wear_monitor import WearMonitorNode

    values = dict({"state_file": str(path), "machine_id": "m1"}, **overrides)
    return WearMonitorNode(context=ros_context, parameter_overrides=[Parameter(k, value=v) for k, v in values.items()])


def test_node_refuses_a_broken_state_whole_and_releases_its_lock(ros_context, tmp_path):
    path = tmp_path / "s.db"
    node = _node(ros_context, path)
    node.close()
    node.destroy_node()
    import sqlite3

    db = sqlite3.connect(path)
    state = json.loads(db.execute("SELECT state_json FROM monitor_state").fetchone()[0])
    state["integrator"]["sliding_distance_m"] = "abc"            # main: resumed, then crashed at the status
    db.execute("UPDATE monitor_state SET state_json = ?", (json.dumps(state),))
    db.commit()
    db.close()
    with pytest.raises(InputError) as err:
        _node(ros_context, path)
    _one_line(err, str(path), "sliding_distance_m", "move the file away")
    with pytest.raises(InputError) as err:                       # another geometry: refused, not resumed
        _node(ros_context, path, rail_length_m=0.9)
    _one_line(err, "rail_length_m")
    time.sleep(0)


def test_node_process_on_a_garbage_state_exits_2_with_one_line(tmp_path):
    garbage = tmp_path / "g.db"
    garbage.write_bytes(b"not sqlite" * 100)
    proc = subprocess.run([sys.executable, "-m", "guide_health.nodes.wear_monitor", "--ros-args", "-p",
                           f"state_file:={garbage}"], capture_output=True, text=True, timeout=60,
                          env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert str(garbage) in proc.stderr and "Traceback" not in proc.stderr


def _node_process(*ros_params, env=None):
    args = [sys.executable, "-m", "guide_health.nodes.wear_monitor", "--ros-args"]
    for p in ros_params:
        args += ["-p", p]
    return subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONPATH=str(ROOT), **(env or {})))


def _wait_for_lock(lock: Path, proc, timeout_s=60.0):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if lock.exists() and lock.read_text().strip() == str(proc.pid):
            return
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.1)
    raise AssertionError("the first node never took the lock")


def test_two_node_processes_on_the_default_state_file_second_refused_then_mismatch_refused(tmp_path, ros_test_env):
    """issue 16: state_file auto (the default) -> $ROS_HOME/guide_health/<machine>/wear_monitor.db; a second
    node on it exits 2 with one line; after the first stops, a node with another rail_length_m is refused."""
    ros_test_env()                                      # the test's own domain, in os.environ
    env = {"ROS_HOME": str(tmp_path)}
    state = tmp_path / "guide_health" / "m7" / "wear_monitor.db"
    first = _node_process("machine_id:=m7", env=env)
    try:
        _wait_for_lock(Path(f"{state}.lock"), first)
        second = _node_process("machine_id:=m7", env=env)
        _, err = second.communicate(timeout=60)
        assert second.returncode == 2 and len(err.strip().splitlines()) == 1, err
        assert str(state) in err and f"in use by another process (pid {first.pid}" in err, err
    finally:
        first.send_signal(2)                            # SIGINT: final checkpoint, lock released
        first.communicate(timeout=60)
    assert first.returncode == 0 and state.stat().st_mode & 0o777 == 0o600
    other = _node_process("machine_id:=m7", "rail_length_m:=0.9", env=env)
    _, err = other.communicate(timeout=60)
    assert other.returncode == 2 and len(err.strip().splitlines()) == 1, err
    assert "saved for another guide: rail_length_m 0.5 (now 0.9)" in err and "Traceback" not in err, err


def test_every_shipped_wear_monitor_config_persists_by_default():
    import yaml

    for path in sorted((ROOT / "config").glob("*.yaml")):
        section = (yaml.safe_load(path.read_text()) or {}).get("/**/wear_monitor")
        if section is not None:
            assert section["ros__parameters"].get("state_file", "auto") == "auto", path
    for path in sorted((ROOT / "launch").glob("*.py")):
        text = path.read_text()
        assert '"state_file": ""' not in text and "state_file:=''" not in text, path


def test_a_malformed_maintenance_log_is_one_line(tmp_path):
    """The axis maintenance log has no schema of its own: whatever its restore raises is one line."""
    from guide_health.io.state_store import resume_with

    store = StateStore(tmp_path / "s.db")
    store.save({"m1/x/maintenance": {"events": [{"kind": 3}]}, "m1/x/other": {"a": 1}})
    store._db.execute("UPDATE monitor_state SET state_json = '[1, 2]' WHERE key = 'm1/x/other'")

    def restore(saved):
        return [dict(e)["time_ns"] for e in saved["events"]]          # KeyError on the malformed event

    with pytest.raises(InputError) as err:
        resume_with(store, "m1/x/maintenance", None, restore)
    _one_line(err, str(tmp_path / "s.db"), "m1/x/maintenance", "cannot be restored", "move the file away")
    with pytest.raises(InputError) as err:
        resume_with(store, "m1/x/other", None, restore)
    _one_line(err, "must be a mapping")
    assert resume_with(store, "m1/x/none", None, restore) is False
    store.close()


def test_a_failed_checkpoint_write_is_one_line_and_the_node_keeps_running(ros_context, tmp_path):
    """A write that fails (disk full, the file gone read-only: here sqlite refusing a query-only connection)
    is one InputError line from the store, and only a logged error in the node (retried next period)."""
    store = StateStore(tmp_path / "s.db")
    store._db.execute("PRAGMA query_only = ON")
    with pytest.raises(InputError) as err:
        store.save({"k": {"a": 1.0}})
    _one_line(err, str(tmp_path / "s.db"), "cannot be written", "retries at the next checkpoint")
    store.close()
    node = _node(ros_context, tmp_path / "n.db")
    try:
        node.store._db.execute("PRAGMA query_only = ON")
        node.checkpoint()                                # logged, no exception
        node.store._db.execute("PRAGMA query_only = OFF")
        node.checkpoint()
        assert node.store.load("m1/x/precision") is not None
    finally:
        node.close()
        node.destroy_node()


def strokes_and_measurements(params: dict) -> PrecisionMonitor:
    """A monitor after 200 s of 20 Hz triangular strokes under 2 kN with 4 straightness measurements."""
    monitor = PrecisionMonitor(wear_axis_params(dict(params)))
    t = 0
    for i in range(4000):
        t += 50_000_000
        monitor.on_load(t, 2000.0)
        monitor.on_joint(t, 0.1 + 0.1 * abs(((i % 80) - 40) / 40.0), 0.2)
        if i % 1000 == 999:
            monitor.on_straightness(t, 5e-6 + 1e-9 * i)
    return monitor


def test_a_state_saved_before_the_effect_fields_were_added_is_accepted_and_restores():
    """A state with effects saved before stop 10 has no measurement_gradients / surface_start_m
    (ADDED_FIELDS): accepted, restored to the same straightness and life as the full state, and a missing
    field that is not an added one is still refused."""
    params = {**WEAR_MONITOR_DEFAULTS, "effects": "running_in", "running_in_ratio": 2.0,
              "running_in_distance_m": 300.0}
    monitor = strokes_and_measurements(params)
    full = monitor.state()
    assert len(full["effects"]["buckets"]) > 0 and len(full["effects"]["measurement_gradients"]) == 4
    check_precision_state(full, PrecisionMonitor(wear_axis_params(dict(params))).state())  # its own state (was refused)
    bad = json.loads(json.dumps(full))
    bad["effects"]["buckets"][0][1] = "x"
    with pytest.raises(InputError, match="buckets"):
        check_precision_state(bad, PrecisionMonitor(wear_axis_params(dict(params))).state())
    old = json.loads(json.dumps(full))
    for name in ("measurement_gradients", "surface_start_m"):
        assert name in old["effects"]
        del old["effects"][name]
    check_precision_state(old, PrecisionMonitor(wear_axis_params(dict(params))).state())
    again = PrecisionMonitor(wear_axis_params(dict(params)))
    again.restore(old)
    assert again.effect_wear.surface_start_m == 0.0 and again.effect_wear.measurement_gradients == []
    before, after = monitor.report(), again.report()
    for key in ("straightness_um", "wear_volume_mm3", "wear_coefficient", "remaining_life_h"):
        assert after[key] == pytest.approx(before[key], rel=1e-12), key
    assert before["measurements"] == 4 and math.isfinite(after["remaining_life_h"])
    assert after["remaining_life_h_low"] <= after["remaining_life_h"] <= after["remaining_life_h_high"]
    del old["effects"]["effective_work_nm"]
    with pytest.raises(InputError):
        check_precision_state(old, PrecisionMonitor(wear_axis_params(dict(params))).state())


def test_an_effects_state_from_before_the_duty_effects_is_accepted_and_restores():
    """A state saved at stop 10 (5 work gradients, bucket rows of 1 + 6, measurement gradients of 5, no
    relubrication time base): accepted, zero-padded, restored to the same straightness, K and life; a row of
    another length, or rows of mixed lengths, are refused."""
    from guide_health.models.wear.effect_wear import STATE_LIST_LENGTHS

    params = {**WEAR_MONITOR_DEFAULTS, "effects": "running_in,retract_asymmetry", "running_in_ratio": 2.0,
              "running_in_distance_m": 300.0, "retract_wear_factor": 0.5}
    monitor = strokes_and_measurements(params)
    now = json.loads(json.dumps(monitor.state()))
    phi, row, _ = (STATE_LIST_LENGTHS[k][0] for k in ("work_gradient", "buckets", "measurement_gradients"))
    old = json.loads(json.dumps(now))
    eff = old["effects"]
    # the padded duty-effect gradients (g, f, b) are 0 where a fresh state holds the derivatives at the
    # no-effect values; they only meet the zero covariance rows of effects the file does not name
    eff["work_gradient"] = eff["work_gradient"][:5]
    eff["buckets"] = [r[:7] for r in eff["buckets"]]
    eff["measurement_gradients"] = [g[:5] for g in eff["measurement_gradients"]]
    del eff["last_relubrication_t_ns"], eff["first_sample_t_ns"]
    check_precision_state(old, PrecisionMonitor(wear_axis_params(dict(params))).state())
    again = PrecisionMonitor(wear_axis_params(dict(params)))
    again.restore(old)
    assert len(again.effect_wear.work_gradient) == phi and all(len(r) == row - 1
                                                               for r in again.effect_wear.buckets.values())
    before, after = monitor.report(), again.report()
    for key in ("straightness_um", "wear_coefficient", "remaining_life_h", "remaining_life_h_low",
                "remaining_life_h_high"):
        assert after[key] == pytest.approx(before[key], rel=1e-12), key
    first = now["effects"]["buckets"][0]
    for bad_rows in ([first[:8]], [first, first[:7]]):       # a length of neither kind; mixed lengths
        bad = json.loads(json.dumps(now))
        bad["effects"]["buckets"] = bad_rows
        with pytest.raises(InputError, match="buckets"):
            check_precision_state(bad, PrecisionMonitor(wear_axis_params(dict(params))).state())


def test_an_effects_state_from_stop_11_is_accepted_and_restores():
    """A state saved at stop 11 (8 work gradients, bucket rows of 1 + 9, no pass work): accepted, zero-padded,
    restored to the same straightness, K and life. Loaded with stroke_distribution now named, its pass work
    P, which it never kept, is estimated as G / max(mean stroke, L_s): exact for strokes of one length
    (0.1 m here, as long as the slider), so P, the straightness, K and life equal those of a monitor that ran
    with stroke_distribution from the start (1e-9); without the estimate (P and the duty window's pass sums
    zero) that life was 111 h against 54 h."""
    params = {**WEAR_MONITOR_DEFAULTS, "effects": "running_in,retract_asymmetry", "running_in_ratio": 2.0,
              "running_in_distance_m": 300.0, "retract_wear_factor": 0.5, "slider_length_m": 0.1}
    monitor = strokes_and_measurements(params)
    old = json.loads(json.dumps(monitor.state()))
    eff = old["effects"]
    eff["work_gradient"] = eff["work_gradient"][:8]
    eff["buckets"] = [r[:10] for r in eff["buckets"]]
    eff["measurement_gradients"] = [g[:8] for g in eff["measurement_gradients"]]
    for name in ("pass_work_n", "pass_direction", "pass_length_m", "pass_open_work_nm", "pass_open_buckets",
                 "measurement_pass_work_n"):
        del eff[name]
    check_precision_state(old, PrecisionMonitor(wear_axis_params(dict(params))).state())
    again = PrecisionMonitor(wear_axis_params(dict(params)))
    again.restore(json.loads(json.dumps(old)))
    before, after = monitor.report(), again.report()
    keys = ("straightness_um", "wear_coefficient", "remaining_life_h", "remaining_life_h_low", "remaining_life_h_high")
    for key in keys:
        assert after[key] == pytest.approx(before[key], rel=1e-12), key
    with_w = {**params, "effects": "running_in,retract_asymmetry,stroke_distribution",
              "stroke_distribution_weight": 0.5}
    fresh = strokes_and_measurements(with_w)
    restored = PrecisionMonitor(wear_axis_params(dict(with_w)))
    restored.restore(json.loads(json.dumps(old)))
    assert restored.effect_wear.pass_work_now_n() == pytest.approx(fresh.effect_wear.pass_work_now_n(), rel=1e-9)
    # the restored state meets another model, which restarts its fit test (models/wear/fit_watch.py); the
    # synthetic readings broke the fresh one's, which widens its life interval: compared with a new test
    fresh.fit_watch.clear(None)
    a, b = fresh.report(), restored.report()
    for key in keys:
        assert b[key] == pytest.approx(a[key], rel=1e-9), key
    # the closed form: strokes of L = L_s, so P = G / L, and each bucket's pass sum is its effective work / L
    ew = restored.effect_wear
    assert ew.pass_work_now_n() == pytest.approx(ew.effective_work_nm / 0.1, rel=1e-9)
    assert all(row[9] == pytest.approx(row[1] / 0.1, rel=1e-12) and row[9] > 0 for row in ew.buckets.values())
    # the measurements it did not keep them for are NaN (then estimated), so the lists stay parallel: after more
    # measurements the monitor's own state passes the schema and restores
    assert np.isnan(ew.measurement_pass_work_n).all() and len(ew.measurement_pass_work_n) == 4
    t = restored.integrator.last_t_ns
    for i in range(200):
        t += 50_000_000
        restored.on_joint(t, 0.1 + 0.1 * abs(((i % 80) - 40) / 40.0), 0.2)
    assert restored.on_straightness(t, 6e-6) is None
    saved = json.loads(json.dumps(restored.state()))
    check_precision_state(saved, PrecisionMonitor(wear_axis_params(dict(with_w))).state())
    again = PrecisionMonitor(wear_axis_params(dict(with_w)))
    again.restore(saved)
    assert again.report()["remaining_life_h"] == pytest.approx(restored.report()["remaining_life_h"], rel=1e-12)


def test_a_rate_effect_added_later_restores_every_older_state_by_name(tmp_path, monkeypatch):
    """A rate-type effect registered here (covariance row 13 of a new generation 6, ``rate``: its d(work)/d(its
    parameter) becomes a bucket sum) needs no state-file generation of its own: registry.state_layouts derives
    its rows and names every older list, and restore maps saved lists to today's names. A state saved today
    (bucket rows of 1 + 10, gradients of 12) and one of the duty-effect generation (1 + 9, 8: no pass work), each
    through the SQLite store, restore under the extended registry to their own sums and gradients by name, 0 in
    the new effect's places (its no-effect value, as before it existed) and in those their generation lacked; the
    extended state then saves and restores exactly. Positional padding would put today's pass work sum into the
    new effect's derivative (it sits before the pass work in a bucket row)."""
    from guide_health.models.wear import effect_wear
    from guide_health.models.wear.effects import registry
    from guide_health.models.wear.effects.base import CovarianceRow

    params = {**WEAR_MONITOR_DEFAULTS, "effects": "running_in,retract_asymmetry,stroke_distribution",
              "running_in_ratio": 2.0, "running_in_distance_m": 300.0, "retract_wear_factor": 0.5,
              "stroke_distribution_weight": 0.5, "slider_length_m": 0.05}
    today = json.loads(json.dumps(strokes_and_measurements(params).state()))["effects"]
    older = json.loads(json.dumps(today))
    older["buckets"] = [row[:10] for row in older["buckets"]]
    older["work_gradient"] = older["work_gradient"][:8]
    older["measurement_gradients"] = [g[:8] for g in older["measurement_gradients"]]
    assert any(row[-1] > 0 for row in today["buckets"])          # a pass work sum that positional padding moves
    store = StateStore(tmp_path / "s.db")
    store.save({"today": today, "older": older})
    store.close()

    rows = registry.COVARIANCE_ROWS + (CovarianceRow("extra_rate_per_unit", 13, 6, rate=True),)
    phi_layouts, bucket_layouts = registry.state_layouts(rows)
    phi, sums = phi_layouts[max(phi_layouts)], bucket_layouts[max(bucket_layouts)]
    assert phi == registry.PHI_NAMES + ("extra_rate_per_unit",)
    assert sums == registry.BUCKET_SUMS[:-1] + ("d_extra_rate_per_unit", "pass_work_n")
    assert {n: bucket_layouts[n] for n in (6, 9, 10)} == registry.BUCKET_LAYOUTS      # the older ones unchanged
    for name, value in (("PHI_LAYOUTS", phi_layouts), ("BUCKET_LAYOUTS", bucket_layouts), ("PHI_NAMES", phi),
                        ("BUCKET_SUMS", sums)):
        monkeypatch.setattr(effect_wear, name, value)
    store = StateStore(tmp_path / "s.db")
    saved = {key: store.load(key) for key in ("today", "older")}
    store.close()
    for key, names_then in (("today", registry.BUCKET_SUMS), ("older", registry.BUCKET_LAYOUTS[9])):
        wear = PrecisionMonitor(wear_axis_params(dict(params))).effect_wear
        wear.restore(saved[key])
        for row in saved[key]["buckets"]:
            restored = dict(zip(sums, wear.buckets[row[0]]))
            assert [restored[n] for n in names_then] == row[1:]
            assert restored["d_extra_rate_per_unit"] == 0.0 and (key == "today" or restored["pass_work_n"] == 0.0)
        kept = len(saved[key]["work_gradient"])
        assert wear.work_gradient == saved[key]["work_gradient"] + [0.0] * (len(phi) - kept)
        assert [g[:kept] for g in wear.measurement_gradients] == saved[key]["measurement_gradients"]
        again = json.loads(json.dumps(wear.state()))
        assert {len(r) for r in again["buckets"]} == {1 + len(sums)} and len(again["work_gradient"]) == len(phi)
        round_trip = PrecisionMonitor(wear_axis_params(dict(params))).effect_wear
        round_trip.restore(again)
        assert round_trip.state() == wear.state()
