"""Report files (JSON, CSV, Markdown, PNG) written without following a symbolic link, mode 0640.

A pre-existing symbolic link at an output path is refused (``O_NOFOLLOW``), never written through: a
report directory beside a bag is often shared, and a link planted there must not make `replay` overwrite
its target. Anything else that is not a regular file (a FIFO, a device, a directory) is refused too. A new
or rewritten file gets mode REPORT_MODE (owner rw, group r, others nothing); the state file has its own
0600 (io/state_store.py).
"""
from __future__ import annotations

import io
import os
import stat
from contextlib import contextmanager
from pathlib import Path

from ...errors import InputError

#: mode of a report file (rw-r-----)
REPORT_MODE = 0o640


def _refuse(path: Path, what: str) -> InputError:
    return InputError(f"output file {path} {what}; remove it or choose another --out")


@contextmanager
def open_output(path, binary: bool = False, mode: int = REPORT_MODE):
    """Open `path` for writing (truncated, created `mode`), never through a symbolic link; InputError (one
    line naming the file and what to do) for a link, a non-regular file or a path that cannot be written."""
    path = Path(path)
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise _refuse(path, f"cannot be inspected ({exc.strerror})") from None
    if st is not None and stat.S_ISLNK(st.st_mode):
        raise _refuse(path, "is a symbolic link (not written through)")
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise _refuse(path, "exists and is not a regular file")
    flags = os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_NOFOLLOW | os.O_CLOEXEC
    try:
        fd = os.open(path, flags, mode)
    except OSError as exc:
        what = "is a symbolic link (not written through)" if os.path.islink(path) else \
            f"cannot be written ({exc.strerror})"
        raise _refuse(path, what) from None
    try:
        os.fchmod(fd, mode)             # an older file keeps no wider mode
        handle = os.fdopen(fd, "wb" if binary else "w", **({} if binary else {"newline": "", "encoding": "utf8"}))
    except BaseException:
        os.close(fd)
        raise
    with handle:
        yield handle


def write_text(path, text: str) -> None:
    """`text` into the report file `path` (open_output)."""
    with open_output(path) as handle:
        handle.write(text)


def save_figure(fig, path, dpi: int = 110) -> None:
    """A matplotlib figure as PNG into the report file `path` (open_output)."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    with open_output(path, binary=True) as handle:
        handle.write(buffer.getvalue())
