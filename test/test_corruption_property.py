"""Random byte corruptions of 1 % of a bag's messages, offline: `guide-health replay` never ends in a traceback
(exit 0, one JSON object), every corrupted message that cannot be read is counted as rejected, and the model's
result equals the result of the same bag with those messages removed.

Which corrupted messages "cannot be read" is decided here with rosbags' reference decoder (``deserialize_cdr``,
not the package's fast layouts) and the meaning of the topic: a JointState naming joint x with a position at
its index, a header nanosec below 1e9. A corruption that still decodes to such a message is a message like any
other (its numbers may then fail a sample rule: in both bags alike)."""
from __future__ import annotations

import contextlib
import io
import json
import shutil
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from corrupt_bags import BENCH, clean_bench_bag, delete_rows, replace_rows, topic_rows

from guide_health.analysis.replay import analyse_bag
from guide_health.io.bag.interfaces import FLOAT64, JOINT_STATE, WRENCH_STAMPED
from guide_health.io.bag.typestore import typestore

hypothesis = pytest.importorskip("hypothesis")
st = hypothesis.strategies

TOPICS = {"/joint_states": JOINT_STATE, "/guide/load": WRENCH_STAMPED, "/guide/straightness": FLOAT64}
#: the model's numbers compared exactly between the corrupted bag and the bag without its unreadable messages
MODEL_KEYS = ("samples", "load_samples", "measurements", "sliding_distance_m", "wear_coefficient", "straightness_um",
              "remaining_life_h", "strokes", "wear_volume_mm3")


def readable(raw: bytes, msgtype: str) -> bool:
    """The reference decoder's verdict: a message a sample can be taken from."""
    if len(raw) < 4 or raw[:2] not in (b"\x00\x00", b"\x00\x01"):
        return False
    msgdef = typestore().get_msgdef(msgtype)       # rosbags' deserialiser; trailing bytes allowed (Fast CDR)
    try:
        msg = (msgdef.deserialize_cdr_le if raw[1] else msgdef.deserialize_cdr_be)(raw[4:], 0, msgdef.cls,
                                                                                     typestore())[0]
    except Exception:  # noqa: BLE001 - any failure of the reference decoder: unreadable
        return False
    if msgtype == FLOAT64:
        return True
    if msg.header.stamp.nanosec >= 1_000_000_000:
        return False
    if msgtype == JOINT_STATE:
        names = list(msg.name)
        return "x" in names and names.index("x") < len(msg.position)
    return True


def corrupt(raw: bytes, kind: int, a: int, b: int) -> bytes:
    """kind 0: truncate to a share a/256 of its length; 1: zero bytes [a, a + b) (positions mod length);
    2: flip bit b % 8 of byte a."""
    n = len(raw)
    if kind == 0:
        return raw[:n * a // 256]
    start = a % max(n, 1)
    if kind == 1:
        return raw[:start] + bytes(min(b % 16 + 1, n - start)) + raw[start + b % 16 + 1:]
    out = bytearray(raw)
    if n:
        out[start] ^= 1 << (b % 8)
    return bytes(out)


class CleanBag(tuple):
    """(params, bag, [(row, topic), ...]) with a short repr (hypothesis prints the arguments of a failure)."""

    def __repr__(self) -> str:
        return f"CleanBag({self[1]})"


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    params, bag = clean_bench_bag(tmp_path_factory.mktemp("clean"), hours=0.2, seed=11)
    rows = [(row, topic) for topic in TOPICS for row in topic_rows(bag, topic)]
    return CleanBag((params, bag, rows))


def replay_json(bag: Path, out: Path) -> dict:
    """`guide-health replay --json` in this process: (exit code 0 asserted) the JSON it prints."""
    from guide_health.cli.app import main

    stdout, stderr = io.StringIO(), io.StringIO()
    shown = warnings.showwarning
    try:
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            code = main(["replay", str(bag), "--params", str(BENCH), "--out", str(out), "--no-plot", "--json"])
    finally:
        warnings.showwarning = shown
    assert code == 0, stderr.getvalue()
    return json.loads(stdout.getvalue())


def same(a, b) -> bool:
    """Equal numbers, or both not a number (JSON writes NaN as null)."""
    def missing(v):
        return v is None or (isinstance(v, float) and np.isnan(v))
    return a == b or (missing(a) and missing(b))


@hypothesis.settings(max_examples=25, deadline=None, derandomize=True,
                     suppress_health_check=[hypothesis.HealthCheck.function_scoped_fixture,
                                            hypothesis.HealthCheck.too_slow])
@hypothesis.given(seed=st.integers(0, 2**32 - 1), kinds=st.lists(st.integers(0, 2), min_size=1, max_size=3))
def test_corrupted_messages_are_rejected_and_nothing_else_changes(clean, seed, kinds):
    params, bag, rows = clean
    rng = np.random.default_rng(seed)
    chosen = rng.choice(len(rows), size=max(1, len(rows) // 100), replace=False)       # 1 % of the messages
    with tempfile.TemporaryDirectory() as tmp:
        damaged = Path(tmp) / "bag"
        shutil.copytree(bag, damaged)
        edits, unreadable = {}, []
        for k, i in enumerate(chosen.tolist()):
            (row_id, _, raw), topic = rows[i]
            kind = kinds[k % len(kinds)]
            new = corrupt(bytes(raw), kind, int(rng.integers(0, 256)), int(rng.integers(0, 256)))
            edits[row_id] = new
            if not readable(new, TOPICS[topic]):
                unreadable.append(row_id)
        replace_rows(damaged, edits)
        got = replay_json(damaged, Path(tmp) / "report")
        removed = Path(tmp) / "removed"
        shutil.copytree(damaged, removed)
        delete_rows(removed, unreadable)
        _, reference, _ = analyse_bag(removed, params)       # delete_rows recounts metadata.yaml
    assert got["rejected_samples"] == reference["rejected_samples"] + len(unreadable)
    by_reason = {k: v for k, v in got.items() if k.startswith("rejected: ")}
    assert sum(by_reason.values()) == got["rejected_samples"]
    for key in MODEL_KEYS:
        assert same(got[key], reference[key]), (key, got[key], reference[key])
