"""A model file loaded live survives a restart (nodes/model_service.py: the loaded-model record in the state
file): the restart runs on the loaded model and gives the numbers of a run that was never interrupted; a
newer configured model wins over the record; a record that does not read back is refused in one line and
counted, the node runs on the configured model. The anchor stamp is part of the model's digest."""
import dataclasses
from pathlib import Path
from types import SimpleNamespace

import pytest
import yaml
from test_fit_watch import CHANGE_H, HOUR_NS
from test_fit_watch_reload import changed_run

from guide_health.errors import InputError
from guide_health.io.state_store import StateStore
from guide_health.models.levels import Level
from guide_health.models.wear import fit_watch
from guide_health.models.wear.axis import AxisMonitor, split_run
from guide_health.nodes.model_service import model_digest, on_load_model, resume_loaded_model, resumed_model
from guide_health.params.typed import wear_axis_params

ROOT = Path(__file__).resolve().parents[1]
COMPARED = ("straightness_um", "wear_coefficient", "remaining_life_h", "remaining_life_h_low", "measurements")


def stand_in(params: dict, axis: AxisMonitor, model_file: str = ""):
    """A node with one channel: what on_load_model and resume_loaded_model use of wear_monitor, without ROS."""
    channel = SimpleNamespace(name="x", model=axis, params=params, model_params=wear_axis_params(params),
                              loaded_model=None, loaded_model_key=lambda machine: f"{machine}/x/loaded_model")
    return SimpleNamespace(params=params, channels=[channel], process_inputs=lambda: None, checkpoint=lambda: None,
                           get_name=lambda: "wear_monitor",
                           get_parameter=lambda name: SimpleNamespace(value=model_file),
                           get_logger=lambda: SimpleNamespace(warning=print, info=print), model_records_refused=0)


def anchored_load(tmp_path):
    """Seed 3, +3 um at 15 h, the anchored model (diagnose --since's kind) loaded at 16 h: (params, the record,
    the guide states as a restart reads them from the state file, the tail of the run, the uninterrupted end)."""
    params, run = changed_run(3, "gauge", hours=20.0)
    t0 = int(run.straightness_t_ns[0])
    head, tail = split_run(run, t0 + int(16 * HOUR_NS))
    path = tmp_path / "model.yaml"
    path.write_text(yaml.safe_dump({"/**/wear_monitor": {"ros__parameters": {
        "wear_coefficient": params["wear_coefficient"], "straightness_initial_m": 70e-6,
        "model_from_stamp_s": (t0 + CHANGE_H * HOUR_NS) * 1e-9}}}))
    axis = AxisMonitor(wear_axis_params(params))
    axis.process_run(head)
    node = stand_in(params, axis, str(path))
    assert on_load_model(node, SimpleNamespace(success=None, message="")).success
    channel = node.channels[0]
    store = StateStore(tmp_path / "state.db")
    try:
        store.save({**{name: axis.guide_state(name) for name in axis.guides}, "record": channel.loaded_model})
        saved = {name: store.load(name) for name in axis.guides}
        record = store.load("record")
    finally:
        store.close()
    axis.process_run(tail)
    return params, record, saved, tail, axis.report()


def restarted(params: dict, record: dict | None, saved: dict, tail) -> tuple[dict, str]:
    """A restart on the configured ``params``: the record (None: none) put on the axis first, then the guides
    restored, then the rest of the run; (its end report, the start-up line)."""
    axis = AxisMonitor(wear_axis_params(params))
    line = resume_loaded_model(stand_in(params, axis).channels[0], record) if record is not None else ""
    for name, state in saved.items():
        axis.restore_guide(name, state)
    axis.process_run(tail)
    return axis.report(), line


def test_restart_runs_on_the_loaded_model_and_equals_the_uninterrupted_run(tmp_path):
    params, record, saved, tail, uninterrupted = anchored_load(tmp_path)
    end, line = restarted(params, record, saved, tail)
    assert line.startswith("resumed with the model loaded at ") and line.endswith(f"from {tmp_path / 'model.yaml'}")
    for key in COMPARED:
        assert end[key] == pytest.approx(uninterrupted[key], rel=1e-12), key
    for key in fit_watch.FIT_STATUS_KEYS:
        if isinstance(uninterrupted[key], str):
            assert end[key] == uninterrupted[key], key
        else:
            assert end[key] == pytest.approx(uninterrupted[key], rel=1e-12, nan_ok=True), key
    # without the record (the state restored under the parameters files' A0 = 30 um, the work counted from
    # the anchor): the straightness is wrong by the difference of the two A0, ~40 um, silently
    lost, _ = restarted(params, None, saved, tail)
    assert abs(lost["straightness_um"] - uninterrupted["straightness_um"]) > 20.0


def test_a_newer_configured_model_wins_over_the_record(tmp_path):
    params, record, saved, tail, _ = anchored_load(tmp_path)
    assert resumed_model(record, params)[0] == record["params"]
    newer = {**params, "wear_coefficient": 1.5 * params["wear_coefficient"]}
    axis_params, line = resumed_model(record, newer)
    assert axis_params is None and "the parameters win" in line and str(tmp_path / "model.yaml") in line
    end, _ = restarted(newer, record, saved, tail)
    assert end["wear_coefficient"] != pytest.approx(restarted(params, record, saved, tail)[0]["wear_coefficient"])


def test_a_corrupted_record_is_refused_in_one_line(tmp_path):
    params, record, _, _, _ = anchored_load(tmp_path)
    cases = (({k: v for k, v in record.items() if k != "digest"}, "fields"),
             ({**record, "digest": "0" * 16}, "digest does not match"),
             ({**record, "params": {**record["params"], "wear_coefficient": 3e-9}}, "digest does not match"),
             ({**record, "params": {**record["params"], "wear_coefficient": -1.0}}, "wear_coefficient"),
             ({**record, "params": "x"}, "fields"),
             ({**record, "loaded_unix_s": "never"}, "refused"),
             ({**record, "params": {**record["params"], "contact_width_m": 0.05},
               "digest": model_digest(wear_axis_params({**record["params"], "contact_width_m": 0.05}))},
              "contact_width_m"))
    for bad, words in cases:
        with pytest.raises(InputError, match=words) as err:
            resumed_model(bad, params)
        assert "\n" not in str(err.value)


def test_a_corrupted_record_in_the_state_file_is_counted_and_the_configured_model_runs(tmp_path):
    """wear_monitor's start-up step on a stand-in node: a record that is not JSON, then one altered."""
    pytest.importorskip("rclpy")
    import sqlite3

    from guide_health.nodes.axis_channel import EXTRA_PRECISION_KEYS
    from guide_health.nodes.wear_monitor import WearMonitorNode

    params, record, saved, _, _ = anchored_load(tmp_path)
    logged = []
    for i, text in enumerate(("{not json", '{"file": "m.yaml"}')):
        store = StateStore(tmp_path / f"s{i}.db")
        store.save({"bench_000/x/loaded_model": record})
        store.close()
        with sqlite3.connect(tmp_path / f"s{i}.db") as db:
            db.execute("UPDATE monitor_state SET state_json = ? WHERE key = 'bench_000/x/loaded_model'", (text,))
        store = StateStore(tmp_path / f"s{i}.db")
        axis = AxisMonitor(wear_axis_params(params))
        node = stand_in(params, axis)
        node.store = store
        node.get_logger = lambda: SimpleNamespace(warning=logged.append, info=logged.append)
        try:
            WearMonitorNode._resume_loaded_model(node, node.channels[0], None)
        finally:
            store.close()
        assert node.model_records_refused == 1 and node.channels[0].loaded_model == {}
        report = {"message": ""}          # the count is a key of the published status of each axis
        WearMonitorNode._timing_values(SimpleNamespace(
            _callbacks=0, _callback_s=0.0, _model_s=0.0, model_records_refused=node.model_records_refused,
            sensors=SimpleNamespace(values=dict, message_suffix=str)), report)
        assert report["model_records_refused"] == 1 and "model_records_refused" in EXTRA_PRECISION_KEYS
        assert axis.params == wear_axis_params(params)
        assert logged[-1].startswith("loaded-model record refused (") and "runs on the configured model" in logged[-1]
        assert "\n" not in logged[-1]


def test_the_anchor_stamp_is_part_of_the_model_digest():
    params, _ = changed_run(0, "gauge", hours=1.0)
    typed = wear_axis_params(params)
    a, b = (dataclasses.replace(typed, model_from_stamp_s=s) for s in (1.7e9, 1.7e9 + 3600.0))
    effects = None
    assert fit_watch.model_key(a, effects) != fit_watch.model_key(b, effects)
    assert fit_watch.model_key(typed, effects) != fit_watch.model_key(a, effects)
    assert model_digest(a) != model_digest(b)


@pytest.mark.ros
def test_sigkill_after_a_live_load_and_restart_with_the_original_params(tmp_path, live_wear_node):
    """bag 1 (0-2 h, +6 um from 1 h: the test fires) -> wear_monitor; ~/load_model of a file anchored at 1 h;
    SIGKILL; a restart with the same parameters (the files as before the load); bag 2 (2-3 h): every fit key
    and the model's numbers equal the uninterrupted run (offline replay of both bags with the file loaded at
    2 h, which test_fit_watch_reload shows equal to the live run without a kill)."""
    from live_node import BENCH_STATUS, TriggerClient, reload_scenario

    from guide_health.nodes.session import bag_counts

    scene = reload_scenario(tmp_path)
    overrides = {"state_file": str(tmp_path / "state.db"), "diagnostics_period_s": 0.25,
                 "model_file": str(scene.good)}
    live_wear_node.start(scene.bench_file, overrides)
    live_wear_node.play(scene.b1)
    assert live_wear_node.wait_counts(BENCH_STATUS, bag_counts(scene.half))["values"]["model_fit"] == "broken"
    client = TriggerClient()
    try:
        assert client.load().success                    # checkpointed with the record at once
    finally:
        client.close()
    live_wear_node.kill()                               # no clean shutdown: only the checkpoint survives
    live_wear_node.start(scene.bench_file, overrides, up=lambda s: s["values"]["model_fit"] == "ok")
    log = live_wear_node.log_path
    live_wear_node.play(scene.b2)
    live = live_wear_node.wait_counts(BENCH_STATUS, bag_counts(scene.whole))
    values, whole = live["values"], scene.whole
    assert live["level"] < Level.WARN
    for key in fit_watch.FIT_STATUS_KEYS + COMPARED:
        if isinstance(whole[key], str):
            assert values[key] == whole[key], key
        else:
            assert float(values[key]) == pytest.approx(whole[key], rel=1e-4, abs=1e-9), key
    text = log.read_text()
    assert "axis x: resumed with the model loaded at " in text and f"from {scene.good}" in text
