"""Reading a bag into duty cells beside the rest of ``diagnose``: a pipeline of two processes.

``diagnose`` spends about a second importing scipy.stats, scipy.optimize and matplotlib, none of which the
reading needs, and reading (sqlite3 queries, CDR decoding) is most of the rest. :func:`start_duty_cells`
forks a child that reads and decodes the bag (``duty.iter_bag_chunks``) and sends each MachineRun chunk
through a pipe; a thread of the caller receives them and adds them, in order, to the same accumulator
``duty.read_duty_cells`` uses (``duty.bag_accumulator``), while the caller's main thread imports. The
same chunks in the same order: the same cells, bit for bit (tested). An error in the child (an InputError
for a bad bag) is raised again by :meth:`PendingCells.result`.

The pipeline is used only where it pays and is safe: a large bag (``BACKGROUND_MIN_BYTES`` of data files),
Linux with the ``fork`` start method (forking is not safe with macOS system libraries) and no other
Python thread running in the caller (a fork copies only the calling thread). Otherwise the read runs
in the caller, when ``result()`` is called.
"""
from __future__ import annotations

import os
import sys
import threading
from pathlib import Path

BACKGROUND_MIN_BYTES = 32 * 2**20       # below this the read takes well under the imports it would hide
_CHUNK, _DONE, _ERROR = range(3)


def _bag_bytes(bag) -> int:
    path = Path(bag)
    files = [path] if path.is_file() else [*path.glob("*.db3"), *path.glob("*.mcap")]
    return sum(f.stat().st_size for f in files if f.is_file())


def background_possible(bag, min_bytes: int = BACKGROUND_MIN_BYTES) -> bool:
    """Whether :func:`start_duty_cells` reads in a child (module docstring)."""
    import multiprocessing

    return (sys.platform.startswith("linux") and "fork" in multiprocessing.get_all_start_methods()
            and threading.active_count() == 1 and _bag_bytes(bag) >= min_bytes)


def _child(conn, bag, params: dict, namespace, progress) -> None:
    from guide_health.analysis.discrepancy.duty import iter_bag_chunks

    try:
        for chunk in iter_bag_chunks(bag, params, namespace, progress):
            conn.send((_CHUNK, chunk))
        conn.send((_DONE, None))
    except BaseException as exc:  # noqa: BLE001 - handed to the parent, which raises it
        try:
            conn.send((_ERROR, exc))
        except Exception:  # noqa: BLE001 - an exception that does not pickle: its text
            conn.send((_ERROR, RuntimeError(f"{type(exc).__name__}: {exc}")))
    finally:
        conn.close()


class PendingCells:
    """The duty cells of a bag: read by a child and accumulated by a thread, or (``process`` None) read
    here on ``result()``."""

    def __init__(self, bag, params: dict, namespace, progress, background: bool):
        self.args = (bag, params, namespace, progress)
        self.process = self.thread = None
        self.out: tuple | None = None
        if background:
            import multiprocessing

            ctx = multiprocessing.get_context("fork")
            conn, child_conn = ctx.Pipe(duplex=False)
            for stream in (sys.stdout, sys.stderr):     # a forked child must not flush the parent's buffers
                stream.flush()
            self.process = ctx.Process(target=_child, args=(child_conn, *self.args), daemon=True)
            self.process.start()
            child_conn.close()
            self.thread = threading.Thread(target=self._accumulate, args=(conn,), name="duty-cells", daemon=True)
            self.thread.start()

    @property
    def background(self) -> bool:
        return self.process is not None

    def _accumulate(self, conn) -> None:
        from guide_health.analysis.discrepancy.duty import bag_accumulator

        acc = bag_accumulator(self.args[1])
        messages = 0
        try:
            while True:
                kind, value = conn.recv()
                if kind == _CHUNK:
                    acc.add(value)
                    messages += value.messages
                elif kind == _DONE:
                    self.out = (True, (acc.finish(), messages))
                    return
                else:
                    self.out = (False, value)
                    return
        except EOFError:
            self.out = (False, RuntimeError("the bag reader process ended without its result"))
        except BaseException as exc:  # noqa: BLE001 - raised again by result()
            self.out = (False, exc)
        finally:
            conn.close()

    def result(self):
        """(DutyCells, messages read), as read_duty_cells returns them."""
        if self.process is None:
            from guide_health.analysis.discrepancy.duty import read_duty_cells

            return read_duty_cells(*self.args)
        self.thread.join()
        ok, value = self.out
        if not ok and self.process.is_alive():      # the accumulator failed: the reader may wait to send
            self.process.terminate()
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
