"""Reading a bag into duty cells in a child process while the caller gets the fit and the report ready.

``diagnose`` spends about a second importing scipy.stats, scipy.optimize and matplotlib, none of which the
reading needs; on a 2-core machine that second can run beside the read. :func:`start_duty_cells` forks a
child that runs :func:`~guide_health.analysis.discrepancy.duty.read_duty_cells` (the same function, so
the same cells, bit for bit) and sends the cells back through a pipe; :meth:`PendingCells.result` waits
for them. An error in the child (an InputError for a bad bag) is raised again in the caller.

The child is used only where it pays and is safe: a large bag (``BACKGROUND_MIN_BYTES`` of data files),
the ``fork`` start method available and no other Python thread running in the caller (a fork copies
only the calling thread). Otherwise the read runs in the caller, when ``result()`` is called.
"""
from __future__ import annotations

import os
import sys
import threading
from pathlib import Path

BACKGROUND_MIN_BYTES = 32 * 2**20       # below this the read takes well under the imports it would hide


def _bag_bytes(bag) -> int:
    path = Path(bag)
    files = [path] if path.is_file() else [*path.glob("*.db3"), *path.glob("*.mcap")]
    return sum(f.stat().st_size for f in files if f.is_file())


def background_possible(bag, min_bytes: int = BACKGROUND_MIN_BYTES) -> bool:
    """Whether :func:`start_duty_cells` reads in a child (module docstring)."""
    import multiprocessing

    return ("fork" in multiprocessing.get_all_start_methods() and threading.active_count() == 1
            and _bag_bytes(bag) >= min_bytes)


def _child(conn, bag, params: dict, namespace, progress) -> None:
    from guide_health.analysis.discrepancy.duty import read_duty_cells

    try:
        out = (True, read_duty_cells(bag, params, namespace, progress))
    except BaseException as exc:  # noqa: BLE001 - handed to the parent, which raises it
        out = (False, exc)
    try:
        conn.send(out)
    except Exception as exc:  # noqa: BLE001 - an exception that does not pickle: its text
        conn.send((False, RuntimeError(f"{type(exc).__name__}: {exc}")))
    finally:
        conn.close()


class PendingCells:
    """The duty cells of a bag, read in a child process or (``process`` None) on ``result()``."""

    def __init__(self, bag, params: dict, namespace, progress, background: bool):
        self.args = (bag, params, namespace, progress)
        self.process = self.conn = None
        if background:
            import multiprocessing

            ctx = multiprocessing.get_context("fork")
            self.conn, child_conn = ctx.Pipe(duplex=False)
            for stream in (sys.stdout, sys.stderr):     # a forked child must not flush the parent's buffers
                stream.flush()
            self.process = ctx.Process(target=_child, args=(child_conn, *self.args), daemon=True)
            self.process.start()
            child_conn.close()

    @property
    def background(self) -> bool:
        return self.process is not None

    def result(self):
        """(DutyCells, messages read), as read_duty_cells returns them."""
        if self.process is None:
            from guide_health.analysis.discrepancy.duty import read_duty_cells

            return read_duty_cells(*self.args)
        try:
            ok, value = self.conn.recv()
        except EOFError:
            self.process.join()
            raise RuntimeError(f"the duty-cell reader died (exit code {self.process.exitcode})") from None
        finally:
            self.conn.close()
        self.process.join()
        if not ok:
            raise value
        return value


def start_duty_cells(bag, params: dict, namespace: str | None = None, progress=None,
                     background: bool | None = None) -> PendingCells:
    """Start reading `bag` into duty cells; ``background`` None: in a child when that pays (module docstring)."""
    if background is None:
        background = background_possible(bag)
    return PendingCells(bag, params, namespace, progress, bool(background and os.name == "posix"))
