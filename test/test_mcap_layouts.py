"""mcap bags written by the official `mcap` Python writer in every layout a recorder can produce (compression,
chunk size, no chunking, no summary, no message index, messages shuffled within and across chunks, chunks
overlapping in time) are read whole: replay equals the sqlite3 original exactly (the same report, timing
and file keys aside), the regrind event and the straightness readings included. A file holding messages that
no reader path delivers is refused with one line naming the topic and both counts (exit 2).

Truth: the sqlite3 bag that `guide-health simulate` writes, replayed by the same code (its messages are
copied byte for byte into each mcap file).
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from mcap import writer as mcap_writer

from guide_health.analysis.replay import analyse_bag
from guide_health.cli.app import main
from guide_health.errors import InputError
from guide_health.io.bag.info import bag_info
from guide_health.params import wear_monitor_params

ROOT = Path(__file__).resolve().parents[1]
PARAMS = ROOT / "config" / "bench_000.yaml"
#: report keys that are not results: wall times and the paths of written files
NOT_RESULTS = ("read_s", "model_s", "files")
MAINTENANCE = "/maintenance/events"
STRAIGHTNESS = "/guide/straightness"


def cli(*args):
    return subprocess.run([sys.executable, "-m", "guide_health.cli", *map(str, args)], capture_output=True,
                          text=True, timeout=300, env=dict(os.environ, PYTHONPATH=str(ROOT)))


def in_process(*args) -> subprocess.CompletedProcess:
    """main() in this process (what the console script runs, without an interpreter start per call), as `cli`
    gives it: exit code, stdout, stderr. One end-to-end replay and one refusal still go through `cli`."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([*map(str, args)])
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


@pytest.fixture(scope="module")
def original(tmp_path_factory):
    """(bag, messages [(topic, type, msgdef, log time, data)] in log-time order) of a simulated 2 h bag with
    a regrind at 1 h and a straightness reading every 0.5 h; joint states and loads at 2 Hz (14 400 messages
    each: still 671 chunks of 4 KiB in the zstd layout, each message written by the mcap writer's Python code)."""
    from rosbags.rosbag2 import Reader

    tmp = tmp_path_factory.mktemp("mcap_layouts")
    bag, sim_params = tmp / "sqlite3", tmp / "bench_2hz.yaml"
    text = PARAMS.read_text()
    assert text.count("load_rate_hz: 10.0\n") == 1
    sim_params.write_text(text.replace("load_rate_hz: 10.0\n", "load_rate_hz: 2.0\n"))
    proc = in_process("simulate", "--params", sim_params, "--hours", 2, "--rate", 2, "--seed", 4, "--out", bag,
                      "--maintenance", "regrind:x@1h=10um")
    assert proc.returncode == 0, proc.stderr
    with Reader(bag) as reader:
        messages = [(c.topic, c.msgtype, c.msgdef.data, t, bytes(raw)) for c, t, raw in reader.messages()]
    topics = {m[0] for m in messages}
    assert MAINTENANCE in topics and STRAIGHTNESS in topics
    return bag, messages


def write_mcap_bag(original_bag: Path, messages: list, out: Path, **writer_kwargs) -> Path:
    """A bag directory: `messages` (in the given order) in one .mcap file written by the official writer,
    and the original's metadata.yaml naming it (storage mcap; the same counts and run metadata)."""
    out.mkdir()
    with open(out / "bag_0.mcap", "wb") as f:
        writer = mcap_writer.Writer(f, **writer_kwargs)
        writer.start(profile="ros2", library="guide_health test")
        channels: dict = {}
        for topic, msgtype, msgdef, t, data in messages:
            if topic not in channels:
                schema = writer.register_schema(name=msgtype, encoding="ros2msg", data=msgdef.encode())
                channels[topic] = writer.register_channel(topic=topic, message_encoding="cdr", schema_id=schema)
            writer.add_message(channel_id=channels[topic], log_time=t, data=data, publish_time=t)
        writer.finish()
    info = yaml.safe_load((original_bag / "metadata.yaml").read_text())
    meta = info["rosbag2_bagfile_information"]
    meta["storage_identifier"] = "mcap"
    meta["relative_file_paths"] = ["bag_0.mcap"]
    for entry in meta["files"]:
        entry["path"] = "bag_0.mcap"
    (out / "metadata.yaml").write_text(yaml.safe_dump(info))
    return out


def _shuffled_within(messages: list, window: int, seed: int) -> list:
    """Each run of `window` consecutive messages in a random order (so within a chunk's time range)."""
    rng = np.random.default_rng(seed)
    out = []
    for start in range(0, len(messages), window):
        part = messages[start:start + window]
        out.extend(part[i] for i in rng.permutation(len(part)))
    return out


def _layouts(messages: list) -> dict:
    """{name: (messages in file order, Writer keyword arguments)}."""
    comp = mcap_writer.CompressionType
    index = mcap_writer.IndexType
    no_message_index = index.ALL & ~index.MESSAGE
    shuffled = [messages[i] for i in np.random.default_rng(7).permutation(len(messages))]
    by_topic = sorted(messages, key=lambda m: m[0])               # stable: each topic in time order
    return {
        "zstd_4KiB": (messages, dict(compression=comp.ZSTD, chunk_size=4096)),
        "lz4_4KiB": (messages, dict(compression=comp.LZ4, chunk_size=4096)),
        "none_4KiB": (messages, dict(compression=comp.NONE, chunk_size=4096)),
        "zstd_8MiB": (messages, dict(compression=comp.ZSTD, chunk_size=8 << 20)),
        "lz4_8MiB": (messages, dict(compression=comp.LZ4, chunk_size=8 << 20)),
        "unchunked": (messages, dict(use_chunking=False)),
        "no_summary": (messages, dict(compression=comp.LZ4, chunk_size=4096, index_types=index.NONE,
                                      repeat_channels=False, repeat_schemas=False, use_statistics=False,
                                      use_summary_offsets=False)),
        "shuffled_within_chunks": (_shuffled_within(messages, 40, 3), dict(compression=comp.ZSTD, chunk_size=4096)),
        "shuffled_across_chunks": (shuffled, dict(compression=comp.ZSTD, chunk_size=4096)),
        "no_message_index_zstd": (messages, dict(compression=comp.ZSTD, chunk_size=4096,
                                                 index_types=no_message_index)),
        "no_message_index_none": (messages, dict(compression=comp.NONE, chunk_size=8 << 20,
                                                 index_types=no_message_index)),
        "overlapping_no_message_index": (by_topic, dict(compression=comp.LZ4, chunk_size=4096,
                                                        index_types=no_message_index)),
        "shuffled_across_no_message_index": (shuffled, dict(compression=comp.NONE, chunk_size=4096,
                                                            index_types=no_message_index)),
    }


def _result(report: dict) -> str:
    return json.dumps({k: v for k, v in report.items() if k not in NOT_RESULTS}, sort_keys=True, default=str)


#: one layout per reader path: zstd, lz4 and uncompressed chunks, unchunked records, a file without summary,
#: message indexes over a chunk's shuffled messages, records walked without indexes across chunks that overlap
#: in time (the overlapping by-topic layout without indexes: the end-to-end test below)
TWIN_LAYOUTS = ("zstd_4KiB", "lz4_8MiB", "unchunked", "no_summary", "shuffled_within_chunks",
                "shuffled_across_no_message_index")


def _check_layouts(original, tmp_path, names) -> None:
    """Every message of each layout in `names` read (bag_info counts, replay messages), the regrind applied,
    the report equal to the original's."""
    bag, messages = original
    params = wear_monitor_params(PARAMS)
    truth = analyse_bag(bag, params)[1]
    assert truth["maintenance_events"][0]["applied"] is True and truth["measurements"] >= 2
    counts = {t: sum(m[0] == t for m in messages) for t in {m[0] for m in messages}}
    layouts = _layouts(messages)
    assert set(names) <= set(layouts)
    for name in names:
        msgs, kwargs = layouts[name]
        path = write_mcap_bag(bag, msgs, tmp_path / name, **kwargs)
        info = bag_info(path)
        assert {t: v["count"] for t, v in info["topics"].items()} == counts, name
        report = analyse_bag(path, params)[1]
        assert report["messages"] == truth["messages"], name
        assert _result(report) == _result(truth), name


def test_each_reader_path_replays_equal_to_the_sqlite3_original(original, tmp_path):
    """The default run's twin of the 13-layout test: one layout per reader path (TWIN_LAYOUTS)."""
    _check_layouts(original, tmp_path, TWIN_LAYOUTS)


@pytest.mark.slow
def test_every_layout_replays_equal_to_the_sqlite3_original(original, tmp_path):
    """13 layouts: every message read (bag_info counts, replay messages), the regrind applied, the report
    equal to the original's. On the rosbags reader the no-message-index layouts lost the maintenance and
    straightness topics or every message."""
    _check_layouts(original, tmp_path, list(_layouts(original[1])))


def test_replay_of_an_mcap_bag_without_message_indexes_equals_sqlite3_end_to_end(original, tmp_path):
    """The CLI (the console script) on chunks that overlap in time and have no message index: exit 0, no
    warning, the JSON of the original's replay (main() in this process)."""
    bag, messages = original
    msgs, kwargs = _layouts(messages)["overlapping_no_message_index"]
    path = write_mcap_bag(bag, msgs, tmp_path / "mcap", **kwargs)
    got = [run("replay", b, "--params", PARAMS, "--json", "--no-plot", "--out", tmp_path / f"r{i}")
           for i, (run, b) in enumerate(((in_process, bag), (cli, path)))]
    assert [p.returncode for p in got] == [0, 0], got[1].stderr
    assert "warning" not in got[1].stderr
    assert _result(json.loads(got[1].stdout)) == _result(json.loads(got[0].stdout))


def _hide_message(mcap_file: Path, messages: list, topic: str) -> None:
    """Turn the record of the first message of `topic` into an unknown opcode (readers skip those): the
    file's statistics still count it, no record delivers it."""
    first = next(m for m in messages if m[0] == topic)
    raw = bytearray(mcap_file.read_bytes())
    at = raw.find(first[4]) - 9 - 22
    assert raw[at] == 0x05 and raw.count(first[4]) == 1
    raw[at] = 0x80
    mcap_file.write_bytes(bytes(raw))


@pytest.mark.parametrize("topic", [MAINTENANCE, STRAIGHTNESS])
def test_messages_no_reader_delivers_are_refused_naming_topic_and_counts(original, tmp_path, topic):
    """Uncompressed chunks without message indexes; one message of `topic` hidden: open checked (info) and
    replay (main() in this process) both refuse in one line with the topic and both counts (never 'stale
    metadata'), exit 2."""
    bag, messages = original
    msgs, kwargs = _layouts(messages)["no_message_index_none"]
    path = write_mcap_bag(bag, msgs, tmp_path / "bag", **kwargs, enable_crcs=False)     # a valid edit
    _hide_message(path / "bag_0.mcap", messages, topic)
    n = sum(m[0] == topic for m in messages)
    with pytest.raises(InputError, match=f"topic {topic}: the file holds {n} messages, {n - 1} were read"):
        bag_info(path)
    with pytest.raises(InputError, match=f"topic {topic}: the file holds {n} messages, {n - 1} were read"):
        analyse_bag(path, wear_monitor_params(PARAMS))
    proc = in_process("replay", path, "--params", PARAMS, "--json", "--no-plot", "--out", tmp_path / "r")
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and proc.stdout == "" and len(lines) == 1, proc.stderr
    assert topic in lines[0] and f"{n} messages, {n - 1} were read" in lines[0] and "stale" not in lines[0]


def test_a_chunk_in_a_compression_no_reader_reads_is_refused(original, tmp_path):
    """A chunk whose compression is not none/zstd/lz4: its messages cannot be delivered, exit 2, one line (the
    console script)."""
    bag, messages = original
    path = write_mcap_bag(bag, messages, tmp_path / "bag", compression=mcap_writer.CompressionType.LZ4,
                          chunk_size=4096)
    raw = bytearray((path / "bag_0.mcap").read_bytes())
    at = raw.find(b"\x03\x00\x00\x00lz4")
    raw[at + 4:at + 7] = b"bz2"
    (path / "bag_0.mcap").write_bytes(bytes(raw))
    proc = cli("replay", path, "--params", PARAMS, "--json", "--no-plot", "--out", tmp_path / "r")
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and "'bz2'" in lines[0], proc.stderr
