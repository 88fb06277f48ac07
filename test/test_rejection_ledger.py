"""One rejection ledger live and offline: damaged messages (empty, 1 byte short, wrong layout, invalid stamp)
count under the same ``rejected: <reason>`` keys in replay, diagnose's duty cells and the live node;
bag_player never publishes a message shorter than its type's fixed part and says so in its exit code; the
reports list the rejections by reason with share and hint, leading above 1 %."""
from __future__ import annotations

import json
import math
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from corrupt_bags import (
    BENCH,
    KINDS,
    PLAYER_SKIPS,
    bag_with_every_damage,
    clean_bench_bag,
    expected_counts,
    joint_state,
    replace_rows,
    topic_rows,
)

from guide_health.analysis.discrepancy.duty import read_duty_cells
from guide_health.analysis.rejections import REJECTED_SHARE_LEAD, misfit_note, rejection_summary
from guide_health.analysis.replay import analyse, analyse_bag
from guide_health.io.bag.cdr import encode_float64, encode_joint_states, encode_temperature, encode_wrench_stamped
from guide_health.io.bag.payload import PayloadCheck, min_cdr_size
from guide_health.io.bag.reader import read_machine_bag
from guide_health.io.bag.typestore import header, message, typestore
from guide_health.models.wear import input_rules as rules
from guide_health.params.typed import wear_axis_params

ROOT = Path(__file__).resolve().parents[1]


def offline_counts(report: dict) -> dict[str, int]:
    return {k.removeprefix("rejected: "): int(v) for k, v in report.items() if k.startswith("rejected: ")}


@pytest.fixture(scope="module")
def damaged_bag(tmp_path_factory):
    return bag_with_every_damage(tmp_path_factory.mktemp("damaged"))


# --- the fixed part of a type (bag_player's skip rule) -----------------------------------------------------
def test_fixed_part_is_the_smallest_payload_of_each_type():
    """XCDR1 by hand: JointState = 4 (encapsulation) + 8 (stamp) + 4 + 1 (empty frame_id) -> 17, aligned to 4
    -> 20, + 4 sequence counts = 36; WrenchStamped: 17 aligned to 8 after the header (offset 16 + 4) = 20, + 6 x
    8 = 68; Temperature: 20 + 2 x 8 = 36; Float64: 4 + 8 = 12. The project's encoders with an empty frame_id
    and no effort are exactly that long but for the JointState's one joint."""
    assert min_cdr_size("sensor_msgs/msg/JointState") == 36
    assert min_cdr_size("geometry_msgs/msg/WrenchStamped") == 68
    assert min_cdr_size("sensor_msgs/msg/Temperature") == 36
    assert min_cdr_size("std_msgs/msg/Float64") == 12
    assert len(joint_state(0, [], [])) == 36
    assert len(encode_wrench_stamped([0], [[0.0, 0.0, 0.0]])[0]) == 68
    assert len(encode_temperature([0], [20.0])[0]) == 36
    assert len(encode_float64([1.0])[0]) == 12
    # one joint with velocity: + name (4 + 2 -> aligned 32) + position (36 + 8) + velocity (52 + 8) + effort = 64
    assert len(encode_joint_states([0], [0.0], [0.0])[0]) == 64


def test_payload_check_refuses_short_and_undecodable_messages_only():
    """Every damaged kind bag_player must skip is refused, every other kind (valid CDR with a layout the rules
    reject) and a valid message with trailing padding pass."""
    import struct

    joint = PayloadCheck("sensor_msgs/msg/JointState")
    load = PayloadCheck("geometry_msgs/msg/WrenchStamped")
    raw = encode_joint_states([5], [0.25], [0.5])[0]
    assert joint(raw) and joint(raw + bytes(4)) and not joint(raw[:-1]) and not joint(b"")
    assert joint(joint_state(5, ["y", "x"], [0.1], [0.0])) and joint(joint_state(5, [], []))
    wrench = encode_wrench_stamped([5], [[0.0, 0.0, 100.0]])[0]
    assert load(wrench) and not load(wrench[:-1])
    assert not load(wrench[:12] + struct.pack("<I", 10_000) + wrench[16:])
    events = PayloadCheck("diagnostic_msgs/msg/DiagnosticArray")       # no fast layout: rosbags decides
    array = bytes(typestore().serialize_cdr(message("diagnostic_msgs/msg/DiagnosticArray", header=header(5, "ab"),
                                                    status=[]), "diagnostic_msgs/msg/DiagnosticArray"))
    assert events(array) and not events(array[:-1]) and not events(array[:4])


def test_incomplete_play_line_names_topics_and_counts():
    from guide_health.nodes.bag_player import incomplete_play_line

    assert incomplete_play_line({}, []) == ""
    line = incomplete_play_line({"/joint_states": 1, "/guide/load": 2}, ["/guide/straightness"])
    assert line == ("skipped 3 messages that are not a CDR payload of their type (/guide/load: 2, "
                    "/joint_states: 1); not every message acknowledged on /guide/straightness")


# --- offline: every damaged kind under its reason ------------------------------------------------------------
def test_every_damaged_kind_is_counted_under_its_reason_offline(damaged_bag):
    params, bag, _ = damaged_bag
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, streamed, _ = analyse_bag(bag, params, chunk_messages=5000)     # several chunks
        _, whole = analyse(read_machine_bag(bag, joint="x"), params)
        cells, _ = read_duty_cells(bag, params)
    expected = expected_counts()
    assert offline_counts(streamed) == expected
    assert offline_counts(whole) == expected
    assert streamed["rejected_samples"] == whole["rejected_samples"] == sum(expected.values()) == len(KINDS)
    assert dict(cells.rejected_samples) == expected
    # the damaged messages carry no sample: 7 of the 18000 joint messages, 4 of the 1800 loads, 1 of 6 measurements
    assert streamed["samples"] == whole["samples"]
    assert streamed["load_samples"] == 1800 - 4
    assert streamed["measurements"] == whole["measurements"]


def test_report_lists_rejections_by_reason_with_share(damaged_bag):
    params, bag, _ = damaged_bag
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, report, _ = analyse_bag(bag, params)
    block = report["rejections"]
    rows = {r["reason"]: r for r in block["reasons"]}
    assert rows[rules.MALFORMED_JOINT_STATES]["count"] == 2
    assert rows[rules.MALFORMED_JOINT_STATES]["input_samples"] == 18000
    assert rows[rules.MALFORMED_JOINT_STATES]["share"] == pytest.approx(2 / 18000, rel=1e-12)
    assert rows[rules.MALFORMED_LOAD]["share"] == pytest.approx(3 / 1800, rel=1e-12)
    # 1 of the 6 straightness messages (0.5 h / 0.1 h + the one at 0): 16.7 % > 1 %: the report leads with it
    assert rows[rules.MALFORMED_STRAIGHTNESS]["input_samples"] == 6
    assert block["reasons"][0]["reason"] == rules.MALFORMED_STRAIGHTNESS and block["leads"]
    assert rows[rules.INVALID_STAMP]["input_samples"] == 18000 + 1800


def test_replay_text_and_json_lead_with_rejections_above_one_percent(tmp_path, damaged_bag):
    params, bag, _ = damaged_bag
    out = tmp_path / "report"
    done = subprocess.run([sys.executable, "-m", "guide_health.cli", "replay", str(bag), "--params", str(BENCH),
                           "--out", str(out), "--no-plot"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    first = done.stdout.splitlines()[0]
    assert first.startswith("REJECTED INPUT: more than 1 %"), done.stdout
    assert f"rejected: {rules.MALFORMED_STRAIGHTNESS}: 1 (16.7 % of 6 guide/straightness samples)" in done.stdout
    saved = json.loads((out / "report.json").read_text())
    assert saved["rejections"]["rejected_samples"] == len(KINDS)


# --- hints and the misfit flag ------------------------------------------------------------------------------
def test_rail_travel_hint_names_the_largest_position_and_rail_length(tmp_path):
    """Positions beyond the rail: every sample past rail_start + rail_length + margin is rejected; the hint
    names the largest |position| of the bag (written in the test) and rail_length_m."""
    params, bag = clean_bench_bag(tmp_path, hours=0.2)
    rows = topic_rows(bag, "/joint_states")
    limit = params["rail_start_m"] + params["rail_length_m"] + params["travel_margin_m"]
    beyond = {row[0]: joint_state(row[1], ["x"], [limit + 0.13], [0.0]) for row in rows[100:400]}
    replace_rows(bag, beyond)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, report, _ = analyse_bag(bag, params)
    row = report["rejections"]["reasons"][0]
    assert row["reason"] == rules.POSITION_OUT_OF_TRAVEL and row["count"] == 300
    assert row["share"] == pytest.approx(300 / len(rows), rel=1e-12) and report["rejections"]["leads"]
    assert f"largest |position| seen {limit + 0.13:.4g} m against rail_length_m {params['rail_length_m']:g} m" \
        in row["hint"]


def test_misfit_flag_needs_named_effects_and_a_wear_share_above_the_lead():
    tally_rows = [{"reason": rules.POSITION_OUT_OF_TRAVEL, "count": 23, "input": rules.JOINT_INPUT,
                   "input_samples": 1000, "share": 0.023, "hint": ""}]
    summary = {"rejected_samples": 23, "reasons": tally_rows, "leads": True}
    assert misfit_note(summary, ["running_in"])[0]
    assert not misfit_note(summary, [])[0]
    small = {"rejected_samples": 1, "reasons": [dict(tally_rows[0], count=10, share=0.01)], "leads": False}
    assert not misfit_note(small, ["running_in"])[0]         # exactly the lead share: not above it
    straightness = [dict(tally_rows[0], input=rules.STRAIGHTNESS_INPUT)]
    assert not misfit_note({"reasons": straightness}, ["running_in"])[0]   # measurements carry no wear
    assert REJECTED_SHARE_LEAD == 0.01


def test_no_rejections_no_block():
    from guide_health.analysis.rejections import InputTally

    assert rejection_summary({}, InputTally(), {}) == {}


# --- live == offline ------------------------------------------------------------------------------------------
@pytest.mark.ros
def test_live_node_counts_what_replay_counts_and_bag_player_skips_short_messages(tmp_path, live_wear_node,
                                                                              damaged_bag):
    """bag_player -> wear_monitor on the bag with every damage: the player skips the messages shorter than
    their type's fixed part (exit 3, one line naming topics and counts) and publishes the others; the node
    counts each published damaged message under the reason replay gives it, and receives every other message
    (samples, load samples, measurements equal to replay's)."""
    from guide_health.nodes.session import bag_counts

    params, bag, _ = damaged_bag
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, offline, _ = analyse_bag(bag, params)
    skipped = {}
    for kind in PLAYER_SKIPS:
        skipped[KINDS[kind][1]] = skipped.get(KINDS[kind][1], 0) + 1
    live_expected = {reason: n - skipped.get(reason, 0) for reason, n in offline_counts(offline).items()}
    live_expected = {reason: n for reason, n in live_expected.items() if n}
    status_name = "bench_000/wear_monitor: x precision"
    live_wear_node.start(BENCH, {"state_file": str(tmp_path / "state.db"), "diagnostics_period_s": 0.25}, status_name)
    played = live_wear_node.play(bag, returncode=None)
    counts = dict(bag_counts(offline), **{rules.rejected_key(r): n for r, n in live_expected.items()})
    live = live_wear_node.wait_counts(status_name, counts)
    assert played.returncode == 3, played.stderr
    assert ("error: skipped 6 messages that are not a CDR payload of their type (/guide/load: 3, "
            "/guide/straightness: 1, /joint_states: 2)") in played.stderr.splitlines()[-1]
    values = live["values"]
    live_counts = {k.removeprefix("rejected: "): int(float(v)) for k, v in values.items()
                   if k.startswith("rejected: ") and float(v) > 0}
    assert live_counts == live_expected
    for key in ("samples", "load_samples", "measurements"):
        assert float(values[key]) == offline[key], key
    assert float(values["sliding_distance_m"]) == pytest.approx(offline["sliding_distance_m"], rel=1e-9)
    assert math.isfinite(float(values["wear_coefficient"]))
    assert np.isclose(float(values["wear_coefficient"]), offline["wear_coefficient"], rtol=1e-9)


# --- diagnose ----------------------------------------------------------------------------------------------
def test_diagnose_report_starts_with_rejections_and_says_when_they_may_explain_the_misfit(tmp_path):
    """2.3 % of the joint samples of a 3 h bench bag beyond the rail (the issue's shop-floor case): diagnose's
    text and report.md start with the rejections (rail hint with the largest |position| and rail_length_m),
    the JSON has them and the misfit flag; with named effects, the sentence comes before the effects."""
    from guide_health.analysis.discrepancy.report import markdown

    params, bag = clean_bench_bag(tmp_path, hours=3.0, seed=5)
    rows = topic_rows(bag, "/joint_states")
    limit = params["rail_start_m"] + params["rail_length_m"] + params["travel_margin_m"]
    count = int(0.023 * len(rows))
    start = len(rows) // 2
    replace_rows(bag, {r[0]: joint_state(r[1], ["x"], [limit + 0.13], [0.0]) for r in rows[start:start + count]})
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "guide_health.cli", "diagnose", str(bag), "--params", str(BENCH),
                           "--out", str(out), "--no-plot"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("REJECTED INPUT: more than 1 %"), done.stdout
    md = (out / "report.md").read_text().splitlines()
    assert md[2] == "## Rejected input", md[:6]
    hint = f"largest \\|position\\| seen {limit + 0.13:.4g} m against rail_length_m {params['rail_length_m']:g} m"
    assert any(line.startswith(f"| {rules.POSITION_OUT_OF_TRAVEL} | {count} | 2.3 % of {len(rows)} joint_states")
               and hint in line for line in md), md[:10]
    result = json.loads((out / "report.json").read_text())
    assert result["rejections"]["reasons"][0]["count"] == count
    assert result["rejections_may_explain_misfit"] is (len(result["named_effects"]) > 0
                                                       or result.get("rejected_wear", {}).get("explains_misfit", False))
    named = dict(result, rejections_note="NOTE", rejections_may_explain_misfit=True)
    text = markdown(named)
    assert text.index("NOTE") < min(text.index(h) for h in ("## Effects named", "## No missing effect found",
                                                            "## No library effect") if h in text)


# --- the reader's message rejections inside the model ---------------------------------------------------------
def _run_with_messages(messages):
    from guide_health.runs import MachineRun

    t = 1_000_000_000 * np.arange(1, 6)
    return MachineRun(joint_t_ns=t, joint_position_m=np.linspace(0.0, 0.1, 5), joint_velocity_m_s=np.zeros(5),
                      load_t_ns=t, load_n=np.full(5, 1000.0), rejected_messages=tuple(messages))


def test_message_rejections_enter_the_recent_window_at_their_place():
    """Joint messages rejected before sample 0 and after sample 3 (of 5 accepted): the window holds them
    where the live callbacks would have recorded them; loads after sample 5 at the end."""
    from guide_health.models.wear.gate import InputGate
    from guide_health.params import WEAR_MONITOR_DEFAULTS

    gate = InputGate(wear_axis_params(dict(WEAR_MONITOR_DEFAULTS)))
    bad, missing = rules.MALFORMED_JOINT_STATES, rules.joint_missing("x")
    gate.accept_run(_run_with_messages([("joint_states", 0, bad), ("joint_states", 3, missing),
                                        ("guide/load", 5, rules.MALFORMED_LOAD),
                                        ("guide/straightness", 0, rules.MALFORMED_STRAIGHTNESS)]))
    assert list(gate.recent["joint_states"]) == [bad, None, None, None, missing, None, None]
    assert list(gate.recent["guide/load"]) == [None] * 5 + [rules.MALFORMED_LOAD]
    assert dict(gate.rejected) == {bad: 1, missing: 1, rules.MALFORMED_LOAD: 1, rules.MALFORMED_STRAIGHTNESS: 1}


def test_split_run_keeps_each_message_rejection_on_its_side():
    from guide_health.models.wear.axis import split_run

    run = _run_with_messages([("joint_states", 0, "a"), ("joint_states", 2, "b"), ("joint_states", 4, "c"),
                              ("guide/load", 3, "d")])
    head, tail = split_run(run, 2_000_000_000)           # 2 joint and 2 load samples stamped at or before
    assert head.rejected_messages == (("joint_states", 0, "a"), ("joint_states", 2, "b"))
    assert tail.rejected_messages == (("joint_states", 2, "c"), ("guide/load", 1, "d"))


@pytest.mark.ros
def test_a_malformed_load_of_an_axis_counts_in_its_load_window(ros_context, tmp_path):
    """A node of two axes: a malformed x/guide/load message is counted and enters the axis's guide/load recent
    window (its rejected share), as the bag reader's load rejections do offline (the window is per input,
    whatever the topic's name)."""
    from rclpy.parameter import Parameter

    from guide_health.nodes.wear_monitor import WearMonitorNode

    node = WearMonitorNode(context=ros_context, parameter_overrides=[
        Parameter("state_file", value=str(tmp_path / "state.db")), Parameter("machine_id", value="m1"),
        Parameter("axes", value=["x", "y"])])
    try:
        channel = node.by_axis["x"]
        assert channel.load_input == "x/guide/load"
        channel.on_load_raw(b"\x00\x01")
        node.process_inputs()
        assert list(channel.model.gate.recent["guide/load"]) == [rules.MALFORMED_LOAD]
        assert dict(channel.model.rejected) == {rules.MALFORMED_LOAD: 1}
    finally:
        node.close()
        node.destroy_node()


def test_machine_replay_reports_rejections_per_axis(tmp_path):
    """A three-axis bag whose joint_states message #50 is empty and whose x load #20 is 1 byte short: every
    axis counts the joint message, only x the load; each axis's block has its own shares, the text its lines."""
    from test_machine import make_machine_bag

    from guide_health.analysis.machine_replay import analyse_machine_bag
    from guide_health.cli.replay import format_machine_text

    bag = tmp_path / "xyz"
    axes, _ = make_machine_bag(bag, hours=0.2)
    joints, loads = topic_rows(bag, "/joint_states"), topic_rows(bag, "/x/guide/load")
    replace_rows(bag, {joints[50][0]: b"", loads[20][0]: bytes(loads[20][2])[:-1]})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, report = analyse_machine_bag(bag, axes)
    for axis in "xyz":
        rows = {r["reason"]: r for r in report["axes"][axis]["rejections"]["reasons"]}
        assert rows[rules.MALFORMED_JOINT_STATES]["count"] == 1
        assert rows[rules.MALFORMED_JOINT_STATES]["input_samples"] == len(joints)
        assert (rules.MALFORMED_LOAD in rows) == (axis == "x")
    assert report["axes"]["x"]["rejections"]["rejected_samples"] == 2
    report["files"] = {"json": "report.json"}
    text = format_machine_text(report)
    assert "rejected input on axis y (1 samples):" in text and text.splitlines()[-1].startswith("  files:")
