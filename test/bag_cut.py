"""Test helpers: cut a bag into consecutive bags by log time, and join such cuts into one split bag (one
metadata.yaml over several storage files, as `ros2 bag record --max-bag-duration` leaves it). Raw CDR bytes
are copied with rosbags' own reader and writer, so the pieces hold exactly the messages of the original."""
from __future__ import annotations

import shutil
from pathlib import Path

import yaml
from rosbags.rosbag2 import Reader, Writer

from guide_health.io.bag.metadata import METADATA_KEY, bag_yaml
from guide_health.io.bag.typestore import typestore


def cut_bag(src: Path, edges_ns: list[int], out_dir: Path, names: list[str]) -> list[Path]:
    """Bags ``out_dir/names[i]`` holding the messages of ``src`` with log time in [edges[i], edges[i + 1])."""
    custom = (bag_yaml(src).get("custom_data") or {}).get(METADATA_KEY)
    store = typestore()
    outs = []
    with Reader(src) as reader:
        for i, name in enumerate(names):
            lo, hi = edges_ns[i], edges_ns[i + 1]
            path = out_dir / name
            writer = Writer(path, version=9)
            writer.open()
            conns = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=store) for c in reader.connections}
            if custom is not None:
                writer.set_custom_data(METADATA_KEY, custom)
            for c, t, raw in reader.messages(start=lo, stop=hi):
                writer.write(conns[c.id], t, raw)
            writer.close()
            outs.append(path)
    return outs


def join_as_split_bag(parts: list[Path], out: Path) -> Path:
    """One bag directory ``out`` whose storage files are those of ``parts`` (each a one-file sqlite3 bag)."""
    out.mkdir()
    infos = [bag_yaml(p) for p in parts]
    files, counts = [], {}
    for part, info in zip(parts, infos):
        (name,) = info["relative_file_paths"]
        shutil.copy(part / name, out / name)
        files.append(info["files"][0])
        for t in info["topics_with_message_count"]:
            key = t["topic_metadata"]["name"]
            if key in counts:
                counts[key]["message_count"] += t["message_count"]
            else:
                counts[key] = dict(t)
    start = min(i["starting_time"]["nanoseconds_since_epoch"] for i in infos)
    end = max(i["starting_time"]["nanoseconds_since_epoch"] + i["duration"]["nanoseconds"] for i in infos)
    info = dict(infos[0], relative_file_paths=[i["relative_file_paths"][0] for i in infos], files=files,
                topics_with_message_count=list(counts.values()),
                message_count=sum(i["message_count"] for i in infos),
                starting_time={"nanoseconds_since_epoch": start}, duration={"nanoseconds": end - start})
    (out / "metadata.yaml").write_text(yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False))
    return out
