"""A bag directory's metadata.yaml, the run metadata stored in it, and one-line error texts.

The run metadata (seed, truth, effects, ...) is a JSON string in metadata.yaml
custom_data[METADATA_KEY]; bags written by other tools may carry it in a sidecar file SIDECAR_NAME.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...errors import InputError
from ..outputs.json_text import json_text

#: key of the run metadata (a JSON string) in the bag's metadata.yaml custom_data
METADATA_KEY = "guide_health.metadata"
#: a sidecar JSON file that is also read (bags written by other tools may carry one)
SIDECAR_NAME = "guide_health_meta.json"


def one_line(exc: BaseException, limit: int = 160) -> str:
    """The text of `exc` on one line of at most `limit` characters (for InputError messages)."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= limit else text[:limit - 3] + "..."


#: parsed metadata.yaml files by (path, inode, size, mtime, ctime): a replay reads the same file about ten
#: times (storage, counts, run metadata, topics, fleet machine), 2.8 ms each with the pure-Python parser
_YAML_CACHE: dict[tuple, dict] = {}
_YAML_CACHE_SIZE = 64


def bag_yaml(path: Path) -> dict:
    """rosbag2_bagfile_information of a bag directory's metadata.yaml; {} if absent or unreadable.
    Parsed once per version of the file (libyaml's loader where installed: the same safe_load result,
    10x faster); callers get their own copy."""
    import copy

    meta = path / "metadata.yaml" if path.is_dir() else None
    try:
        st = meta.stat() if meta is not None else None
    except OSError:
        st = None
    if st is None:
        return {}
    key = (str(meta.absolute()), st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
    if key not in _YAML_CACHE:
        if len(_YAML_CACHE) >= _YAML_CACHE_SIZE:
            _YAML_CACHE.pop(next(iter(_YAML_CACHE)))
        _YAML_CACHE[key] = _parse_bag_yaml(meta)
    return copy.deepcopy(_YAML_CACHE[key])


def _parse_bag_yaml(meta: Path) -> dict:
    try:
        import yaml

        loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
        info = yaml.load(meta.read_text(encoding="utf8"), Loader=loader) or {}     # noqa: S506 - a safe loader
        return info.get("rosbag2_bagfile_information", {}) or {}
    except Exception:  # noqa: BLE001 - the rosbags reader reports broken metadata itself
        return {}


def read_run_metadata(path: Path) -> dict:
    """The run metadata of the bag at `path` ({} if none); InputError if it is not valid JSON."""
    info = bag_yaml(path)
    custom = info.get("custom_data") or {}
    text = custom.get(METADATA_KEY) if isinstance(custom, dict) else None
    sidecar = path / SIDECAR_NAME if path.is_dir() else None
    if text is None and sidecar is not None and sidecar.exists():
        text = sidecar.read_text(encoding="utf8")
    if not text:
        return {}
    try:
        value = json.loads(text)
    except ValueError as exc:
        raise InputError(f"bag {path}: run metadata is not valid JSON: {one_line(exc)}") from None
    return value if isinstance(value, dict) else {"value": value}


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"metadata value of type {type(value).__name__} is not JSON serialisable")


def run_metadata_json(metadata: dict | None) -> str:
    """The run metadata as the JSON string stored in the bag (numpy values as numbers and lists)."""
    try:
        return json_text(metadata or {}, default=_json_default, sort_keys=True)
    except (TypeError, ValueError) as exc:
        raise InputError(f"run metadata is not JSON serialisable: {one_line(exc)}") from None


def _storage_file_entries(info: dict) -> list:
    """Every storage file path metadata.yaml names (relative_file_paths and files[].path)."""
    entries = list(info.get("relative_file_paths") or [])
    for item in info.get("files") or []:
        if isinstance(item, dict) and "path" in item:
            entries.append(item["path"])
    return entries


def check_bag_file_paths(path: Path) -> None:
    """InputError (one line) unless every storage file metadata.yaml of the bag directory `path` names lies
    inside the bag folder: an absolute path, a '..' and a symbolic link that leads out are refused (a
    metadata.yaml must not make guide_health read, or the player publish, another folder's files)."""
    path = Path(path)
    if not path.is_dir():
        return
    folder = path.resolve()
    for entry in _storage_file_entries(bag_yaml(path)):
        text = str(entry)
        inside = not Path(text).is_absolute()
        if inside:
            try:
                (folder / text).resolve().relative_to(folder)
            except (ValueError, OSError, RuntimeError):
                inside = False
        if not inside:
            raise InputError(f"bag {path}: metadata.yaml names the storage file {text!r} outside the bag folder; "
                             "a bag's files must be inside its folder (copy the file into it and name it "
                             "relative to it)")


def metadata_message_counts(path: Path) -> dict[str, int]:
    """{topic: message_count} of metadata.yaml's topics_with_message_count ({} if absent or unreadable)."""
    counts: dict[str, int] = {}
    for entry in bag_yaml(Path(path)).get("topics_with_message_count") or []:
        try:
            counts[str(entry["topic_metadata"]["name"])] = int(entry["message_count"])
        except (KeyError, TypeError, ValueError):
            continue
    return counts


def count_mismatches(path: Path, rows_by_topic: dict[str, int]) -> dict[str, dict[str, int]]:
    """{topic: {"metadata": n, "rows": m}} for the topics read whose metadata.yaml count n differs from the
    m rows the storage holds ({} when they agree, or the bag has no metadata.yaml counts)."""
    counts = path.metadata_message_counts() if hasattr(path, "metadata_message_counts") else (
        metadata_message_counts(path))              # a bag_set.BagSet: the sum over its bags
    return {topic: {"metadata": counts[topic], "rows": int(rows)} for topic, rows in sorted(rows_by_topic.items())
            if topic in counts and counts[topic] != int(rows)}


def count_mismatch_text(path: Path, mismatches: dict[str, dict[str, int]]) -> str:
    """One line for the warning: which topics, how many messages metadata.yaml says and the storage holds."""
    parts = ", ".join(f"{topic} {m['metadata']} in metadata.yaml, {m['rows']} stored"
                      for topic, m in mismatches.items())
    return (f"bag {path}: message counts disagree ({parts}); the stored messages were used (metadata.yaml is "
            "stale: a recorder that died or an edited bag; `ros2 bag reindex` rewrites it)")


def check_no_missing_messages(path: Path, mismatches: dict[str, dict[str, int]]) -> None:
    """InputError naming the first topic of which metadata.yaml counts more messages than were read: the
    bag holds messages that no reader path delivered (a result from the rest would be silently wrong)."""
    for topic, m in mismatches.items():
        if m["metadata"] > m["rows"]:
            raise InputError(f"bag {path}: topic {topic}: metadata.yaml counts {m['metadata']} messages, only "
                             f"{m['rows']} could be read (the bag holds messages its storage does not deliver)")
