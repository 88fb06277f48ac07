"""What is in a bag: topics with types and counts, time span, storage and run metadata."""
from __future__ import annotations

from pathlib import Path

from .metadata import bag_yaml, read_run_metadata
from .storage import SUFFIX_STORAGE, open_storage


def bag_topic_types(path) -> dict[str, str]:
    """{topic: message type} of a bag, cheaply (no message scan for a single-file sqlite3 bag)."""
    with open_storage(path) as storage:
        return {c.topic: c.msgtype for c in storage.connections}


def is_slewing_bag(path) -> bool:
    """A slewing-bearing bag: `slewing/load` and no machine joint_states (the slewing axis's own are
    `slewing/joint_states`)."""
    topics = bag_topic_types(path)
    return (any(t.endswith("slewing/load") for t in topics)
            and not any(t.endswith("joint_states") and not t.endswith("slewing/joint_states") for t in topics))


def bag_info(path) -> dict:
    """Topics (type, count), message count, duration, storage and run metadata of a bag.

    The bag is opened checked (rosbags reads every storage file's index), so a damaged bag raises
    InputError here rather than showing counts from its metadata.yaml."""
    path = Path(path)
    with open_storage(path, checked=True) as storage:
        count = int(storage.message_count)
        topics = {c.topic: {"type": c.msgtype, "count": int(c.msgcount)} for c in storage.connections}
        start = int(storage.start_ns) if count else None
        end = int(storage.end_ns) - 1 if count else None
    info = bag_yaml(path)
    storage_id = info.get("storage_identifier") or SUFFIX_STORAGE.get(path.suffix)
    return {
        "path": str(path),
        "storage": storage_id,
        "topics": topics,
        "messages": count,
        "start_ns": start,
        "end_ns": end,
        "duration_s": (end - start) * 1e-9 if count else 0.0,
        "metadata": read_run_metadata(path),
    }
