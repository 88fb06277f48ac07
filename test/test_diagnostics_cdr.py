"""fleet_monitor's DiagnosticArray decoder (io/diagnostics_cdr.py) against rclpy's own deserialisation.

Truth: rclpy.serialization (the rosidl C type support fleet_monitor used before): every generated message
(hypothesis: any text incl. non-ASCII and NUL, any level octet, empty and many statuses/values) serialised
by rclpy decodes to the statuses rclpy deserialises it to; bytes that are no DiagnosticArray (truncated,
another encapsulation, a count larger than the message) raise MalformedMessage, never anything else, and
the board counts such a message as one ignored status."""
from __future__ import annotations

import pytest

hypothesis = pytest.importorskip("hypothesis")
st = hypothesis.strategies
serialization = pytest.importorskip("rclpy.serialization")
diagnostic_msgs = pytest.importorskip("diagnostic_msgs.msg")

from guide_health.io.diagnostics_cdr import MalformedMessage, decode_diagnostic_array  # noqa: E402
from guide_health.models.fleet import FleetBoard  # noqa: E402

DiagnosticArray, DiagnosticStatus, KeyValue = (diagnostic_msgs.DiagnosticArray, diagnostic_msgs.DiagnosticStatus,
                                               diagnostic_msgs.KeyValue)
TEXT = st.text(max_size=12)


def reference(msg) -> list[tuple]:
    """What fleet_monitor read from rclpy's message objects: (level, name, message, hardware_id, values)."""
    back = serialization.deserialize_message(serialization.serialize_message(msg), DiagnosticArray)
    return [(s.level[0], s.name, s.message, s.hardware_id, {kv.key: kv.value for kv in s.values})
            for s in back.status]


def build(statuses, frame_id="", sec=0) -> DiagnosticArray:
    msg = DiagnosticArray()
    msg.header.frame_id = frame_id
    msg.header.stamp.sec = sec
    for level, name, message, hw, pairs in statuses:
        msg.status.append(DiagnosticStatus(level=bytes([level]), name=name, message=message, hardware_id=hw,
                                           values=[KeyValue(key=k, value=v) for k, v in pairs]))
    return msg


STATUS = st.tuples(st.integers(0, 255), TEXT, TEXT, TEXT, st.lists(st.tuples(TEXT, TEXT), max_size=5))


@hypothesis.settings(max_examples=150, deadline=None, derandomize=True)
@hypothesis.given(st.lists(STATUS, max_size=4), TEXT, st.integers(-2**31, 2**31 - 1))
def test_decoded_statuses_equal_rclpy_deserialised(statuses, frame_id, sec):
    msg = build(statuses, frame_id, sec)
    raw = serialization.serialize_message(msg)
    truth = reference(msg)
    assert [tuple(s) for s in decode_diagnostic_array(raw)] == truth
    # only some keys (fleet_monitor's): the first key of each status (as rclpy reads it) and one absent key
    wanted = {"remaining_life_h"} | {p[0][0].split("\x00")[0] for *_, p in statuses if p and p[0][0].isascii()}
    assert [tuple(s) for s in decode_diagnostic_array(raw, frozenset(wanted))] == [
        (*head, {k: v for k, v in values.items() if k in wanted}) for *head, values in truth]


def test_a_wear_monitor_status_of_30_values_decodes_exactly():
    pairs = [(f"key_{i:02d}", f"{0.1 * i:.6g}") for i in range(28)] + [("remaining_life_h", "812.5"), ("guide", "")]
    msg = build([(1, "m007/wear_monitor: x precision", "precision life 812 h", "m007", pairs),
                 (0, "m007/wear_monitor: y precision", "", "m007", [])], frame_id="base")
    (x, y) = decode_diagnostic_array(serialization.serialize_message(msg))
    assert (x.level, x.hardware_id, x.values["remaining_life_h"], len(x.values)) == (1, "m007", "812.5", 30)
    assert (y.level, y.name, y.values) == (0, "m007/wear_monitor: y precision", {})


@hypothesis.settings(max_examples=150, deadline=None, derandomize=True)
@hypothesis.given(st.lists(STATUS, min_size=1, max_size=3), st.data())
def test_truncated_or_damaged_bytes_are_malformed_never_a_traceback(statuses, data):
    raw = bytearray(serialization.serialize_message(build(statuses)))
    cut = data.draw(st.integers(0, len(raw) - 1))
    if data.draw(st.booleans()):
        damaged = bytes(raw[:cut])                                  # truncated
    else:
        raw[cut] = data.draw(st.integers(0, 255))                   # one byte changed
        damaged = bytes(raw)
    try:
        decoded = decode_diagnostic_array(damaged)
    except MalformedMessage:
        return
    try:                                                            # accepted: rclpy reads the same statuses
        back = serialization.deserialize_message(damaged, DiagnosticArray)
    except Exception:                                               # noqa: BLE001 (rclpy refuses, we read: fine
        return                                                      # when what we read is well formed)
    assert [tuple(s) for s in decoded] == [(s.level[0], s.name, s.message, s.hardware_id,
                                            {kv.key: kv.value for kv in s.values}) for s in back.status]


@pytest.mark.parametrize("raw, why", [
    (b"", "no little endian CDR"),
    (b"\x00\x00\x00\x00" + bytes(12), "no little endian CDR"),                  # big endian encapsulation
    (b"\x00\x01\x00\x00" + bytes(8) + b"\xff\xff\xff\x7f", "past the end"),     # frame_id of 2 GB
    (b"\x00\x01\x00\x00" + bytes(8) + b"\x01\x00\x00\x00\x00\x00\x00\x00" + b"\xff\xff\xff\xff",
     "larger than"),                                                            # 4 G statuses in 20 bytes
])
def test_malformed_bytes_give_one_line_and_count_as_one_ignored_status(raw, why):
    with pytest.raises(MalformedMessage, match=why) as info:
        decode_diagnostic_array(raw)
    assert "\n" not in str(info.value)
    board = FleetBoard()
    board.reject_message(str(info.value))
    assert board.summary(0.0)["ignored_statuses"] == 1 and why in board.last_problem


def test_a_message_cut_inside_its_last_value_is_malformed_not_a_shorter_value():
    """Cut 3 bytes into the last value's 6 bytes ('812.5' + NUL): the string's length runs past the end."""
    raw = serialization.serialize_message(build([(0, "m1/wear_monitor: x precision", "", "m1",
                                                   [("remaining_life_h", "812.5")])]))
    end = raw.rindex(b"812.5") + 3
    with pytest.raises(MalformedMessage, match=f"string of 6 bytes at byte {end - 7} past the end"):
        decode_diagnostic_array(raw[:end])
    assert decode_diagnostic_array(raw)[0].values == {"remaining_life_h": "812.5"}


@hypothesis.settings(max_examples=150, deadline=None, derandomize=True)
@hypothesis.given(st.lists(STATUS, min_size=1, max_size=3), st.data())
def test_only_the_wanted_keys_of_damaged_bytes_are_the_full_decoding_filtered(statuses, data):
    """fleet_monitor's path (only some keys, the others walked by their lengths and matched in C): on
    truncated or damaged bytes, MalformedMessage exactly when the full decoding raises it, else the full
    decoding's statuses with only the wanted values."""
    raw = bytearray(serialization.serialize_message(build(statuses)))
    cut = data.draw(st.integers(0, len(raw) - 1))
    if data.draw(st.booleans()):
        damaged = bytes(raw[:cut])
    else:
        raw[cut] = data.draw(st.integers(0, 255))
        damaged = bytes(raw)
    wanted = frozenset({"remaining_life_h"} | {p[0][0].split("\x00")[0] for *_, p in statuses
                                               if p and p[0][0].isascii()})
    try:
        full = decode_diagnostic_array(damaged)
    except MalformedMessage:
        with pytest.raises(MalformedMessage):
            decode_diagnostic_array(damaged, wanted)
        return
    assert [tuple(s) for s in decode_diagnostic_array(damaged, wanted)] == [
        (*s[:4], {k: v for k, v in s.values.items() if k in wanted}) for s in full]


def test_a_message_cut_inside_a_skipped_last_value_is_malformed_on_the_wanted_keys_path():
    """fleet_monitor's path skips the values it does not keep by their lengths: a last value whose length
    runs past the end is malformed there too, not a message read short."""
    raw = serialization.serialize_message(build([(0, "m1/wear_monitor: x precision", "", "m1",
                                                   [("remaining_life_h", "812.5"), ("guide", "front")])]))
    end = raw.rindex(b"front") + 3
    with pytest.raises(MalformedMessage, match="past the end"):
        decode_diagnostic_array(raw[:end], frozenset({"remaining_life_h"}))
    assert decode_diagnostic_array(raw, frozenset({"remaining_life_h"}))[0].values == {"remaining_life_h": "812.5"}
