"""Several bags of one machine read as one recording: a month of shifts, each its own bag (and each bag
possibly split into several storage files, which the storage back ends read as one).

`resolve_bags(paths)` takes bags and directories of bags, orders them by the log time of their first
message (not by name), refuses overlapping bags, drops bags without messages and lists the gaps between the
others. A BagSet is read through `ChainedStorage`, the bags as one storage: one model object streams across
them as the live node streams across a restart, and the batches run on across the bags' boundaries in the
windows one bag of the same messages is read in (sqlite3: `chunk_messages` rows of every topic), so the result
is that bag's to the last bit, not only to rounding. `events` gathers the maintenance events of every bag; the
progress callback sees one count across all files.
"""
from __future__ import annotations

import datetime
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from ...errors import InputError
from .chained_storage import ChainedStorage
from .maintenance import read_events
from .metadata import metadata_message_counts, read_run_metadata
from .reader import iter_machine_bag
from .storage import SUFFIX_STORAGE, open_storage


@dataclass(frozen=True)
class BagSpan:
    """One bag: its path, log times of its first and last message [ns] and its message count."""

    path: Path
    start_ns: int
    end_ns: int             # log time of the last message + 1
    messages: int


def utc_text(t_ns: int) -> str:
    """ISO 8601 UTC time of a stamp [ns], to the millisecond."""
    return datetime.datetime.fromtimestamp(t_ns * 1e-9, datetime.UTC).isoformat(timespec="milliseconds")


def is_bag(path: Path) -> bool:
    """A rosbag2 directory (metadata.yaml) or a bare storage file (.db3, .mcap)."""
    return (path.is_dir() and (path / "metadata.yaml").is_file()) or (path.is_file() and path.suffix in SUFFIX_STORAGE)


def _bag_paths(path: Path) -> list[Path]:
    """The bag at ``path``, or the bags directly inside the directory ``path``."""
    if is_bag(path) or not path.is_dir():
        return [path]          # a missing or unreadable path: the reader's own error names it
    inside = sorted(p for p in path.iterdir() if is_bag(p))
    if not inside:
        raise InputError(f"{path} is neither a bag nor a directory of bags (no metadata.yaml, .db3 or .mcap in it)")
    return inside


def _span(path: Path) -> BagSpan:
    with open_storage(path) as storage:
        return BagSpan(path, int(storage.start_ns), int(storage.end_ns), int(storage.message_count))


@dataclass(frozen=True)
class BagSet:
    """Bags of one machine in time order (``resolve_bags``)."""

    spans: tuple[BagSpan, ...]

    @property
    def paths(self) -> list[Path]:
        return [s.path for s in self.spans]

    def gaps(self) -> list[dict]:
        """Every interval between one bag's last message and the next bag's first: start, end [UTC and ns],
        duration [s]."""
        out = []
        for a, b in zip(self.spans, self.spans[1:]):
            end_a = a.end_ns - 1
            out.append({"after": str(a.path), "before": str(b.path), "start_utc": utc_text(end_a),
                        "end_utc": utc_text(b.start_ns), "start_ns": end_a, "end_ns": b.start_ns,
                        "duration_s": (b.start_ns - end_a) * 1e-9})
        return out

    def report(self) -> dict:
        """The report keys of a multi-bag run: ``bags`` (path, first and last message, messages) and ``gaps``."""
        return {"bags": [{"path": str(s.path), "start_utc": utc_text(s.start_ns), "end_utc": utc_text(s.end_ns - 1),
                          "messages": s.messages} for s in self.spans],
                "gaps": self.gaps()}

    def events(self, namespace: str | None = None) -> list:
        """The maintenance events of every bag, in stamp order."""
        return sorted((e for path in self.paths for e in read_events(path, namespace)), key=lambda e: e.t_ns)

    def open_storage(self) -> ChainedStorage:
        """The bags as one storage (io.bag.reader reads a BagSet through it)."""
        return ChainedStorage([open_storage(p) for p in self.paths], self)

    def run_metadata(self) -> dict:
        """The run metadata of the first bag that has any."""
        return next((m for m in map(read_run_metadata, self.paths) if m), {})

    def metadata_message_counts(self) -> dict[str, int]:
        """{topic: message count} summed over the bags' metadata.yaml (a bag without counts adds none)."""
        total: dict[str, int] = {}
        for path in self.paths:
            for topic, n in metadata_message_counts(path).items():
                total[topic] = total.get(topic, 0) + n
        return total

    def __str__(self) -> str:
        return f"{self.paths[0]} .. {self.paths[-1]} ({len(self.spans)} bags)"

    def iter_chunks(self, **kwargs) -> Iterator:
        """The MachineRun chunks of every bag in time order (``iter_machine_bag``'s arguments)."""
        return iter_machine_bag(self, **kwargs)


def resolve_bags(paths) -> BagSet | Path:
    """The bags named by ``paths`` (bags or directories of bags): one bag as its Path (read as before), several
    as a BagSet ordered by their first message. InputError (one line) when two bags overlap in time."""
    found = [p for path in paths for p in _bag_paths(Path(path))]
    if len(found) == 1:
        return found[0]
    if len(set(found)) != len(found):
        twice = next(p for p in found if found.count(p) > 1)
        raise InputError(f"bag {twice} is given twice")
    spans = sorted((_span(p) for p in found), key=lambda s: (s.start_ns, s.end_ns))
    spans = [s for s in spans if s.messages]
    for a, b in zip(spans, spans[1:]):
        if b.start_ns < a.end_ns:
            raise InputError(f"bags overlap: {a.path} ({utc_text(a.start_ns)} .. {utc_text(a.end_ns - 1)}) and "
                             f"{b.path} (from {utc_text(b.start_ns)}); give bags of one machine that follow "
                             "each other")
    if not spans:
        raise InputError(f"no messages in the bags {', '.join(str(p) for p in found)}")
    return BagSet(tuple(spans))


def source_events(source, namespace: str | None = None) -> list:
    """The maintenance events of a bag (Path) or a BagSet."""
    return source.events(namespace) if isinstance(source, BagSet) else read_events(source, namespace)


def iter_source_chunks(source, **kwargs) -> Iterator:
    """The MachineRun chunks of a bag (Path) or a BagSet (``iter_machine_bag``'s arguments)."""
    if isinstance(source, BagSet):
        return source.iter_chunks(**kwargs)
    return iter_machine_bag(source, **kwargs)
