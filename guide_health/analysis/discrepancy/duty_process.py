"""Reading a bag into duty cells beside the rest of ``diagnose``: a pipeline of two processes.

``diagnose`` spends about a second importing scipy.stats, scipy.optimize and matplotlib, none of which the
reading needs, and reading (sqlite3 queries, CDR decoding) is most of the rest. :func:`start_duty_cells`
forks a child that reads and decodes the bag (``duty.iter_bag_chunks``) and sends each MachineRun chunk
through a pipe (from a sending thread and a queue, so the reading never waits for the caller); the caller
imports meanwhile, and :meth:`PendingCells.result` adds the chunks, in order, to the same accumulator
``duty.read_duty_cells`` uses (``duty.bag_accumulator``). (A receiving thread in the caller, beside its
imports, was slower: the two threads take turns at the GIL.) The same chunks in the same order: the same
cells, bit for bit (tested). An error in the child (an InputError
for a bad bag) is raised again by :meth:`PendingCells.result`. With ``plot``, the child then imports
matplotlib while the parent fits and draws the PNG when asked (:meth:`PendingCells.plot`), so neither
the import nor the drawing competes with the parent's imports during the read.

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
_CHUNK, _DONE, _ERROR, _PLOTTED = range(4)


def _bag_bytes(bag) -> int:
    """Bytes of the storage files of a bag, or of every bag of a BagSet."""
    if hasattr(bag, "paths"):
        return sum(_bag_bytes(p) for p in bag.paths)
    path = Path(bag)
    files = [path] if path.is_file() else [*path.glob("*.db3"), *path.glob("*.mcap")]
    return sum(f.stat().st_size for f in files if f.is_file())


def background_possible(bag, min_bytes: int = BACKGROUND_MIN_BYTES) -> bool:
    """Whether :func:`start_duty_cells` reads in a child (module docstring)."""
    import multiprocessing

    return (sys.platform.startswith("linux") and "fork" in multiprocessing.get_all_start_methods()
            and threading.active_count() == 1 and _bag_bytes(bag) >= min_bytes)


def _child(conn, requests, bag, params: dict, namespace, progress, plot: bool) -> None:
    """Read and decode the bag; a sending thread writes the pickled chunks to the pipe, so the reading goes on
    while the parent is still importing (the queue holds what the pipe cannot take yet)."""
    import queue
    from multiprocessing.reduction import ForkingPickler

    from guide_health.analysis.discrepancy.duty import iter_bag_chunks

    pending: queue.SimpleQueue = queue.SimpleQueue()

    def send() -> None:
        while (item := pending.get()) is not None:
            conn.send_bytes(item)

    sender = threading.Thread(target=send, name="duty-cells-send", daemon=True)
    sender.start()
    failed = False
    try:
        for chunk in iter_bag_chunks(bag, params, namespace, progress):
            pending.put(ForkingPickler.dumps((_CHUNK, chunk)))
        pending.put(ForkingPickler.dumps((_DONE, None)))
    except BaseException as exc:  # noqa: BLE001 - handed to the parent, which raises it
        failed = True
        try:
            pending.put(ForkingPickler.dumps((_ERROR, exc)))
        except Exception:  # noqa: BLE001 - an exception that does not pickle: its text
            pending.put(ForkingPickler.dumps((_ERROR, RuntimeError(f"{type(exc).__name__}: {exc}"))))
    pending.put(None)
    sender.join()
    if plot and not failed:
        _plot_server(conn, requests)


def _send_error(conn, exc: BaseException) -> None:
    try:
        conn.send((_ERROR, exc))
    except Exception:  # noqa: BLE001 - an exception that does not pickle: its text
        conn.send((_ERROR, RuntimeError(f"{type(exc).__name__}: {exc}")))


def _plot_server(conn, requests) -> None:
    """After the read: import matplotlib while the parent fits, then draw the PNG it asks for."""
    from guide_health.analysis.discrepancy.report import plot, preload_plotting

    preload_plotting()
    while True:
        try:
            request = requests.recv()
        except EOFError:
            return
        if request is None:
            return
        try:
            plot(*request)
            conn.send((_PLOTTED, None))
        except BaseException as exc:  # noqa: BLE001 - handed to the parent, which raises it
            _send_error(conn, exc)


class PendingCells:
    """The duty cells of a bag: read by a child and accumulated here on ``result()``, or (``process`` None)
    read here on ``result()``."""

    def __init__(self, bag, params: dict, namespace, progress, background: bool, plot: bool = False, resets=()):
        self.args = (bag, params, namespace, progress)
        self.resets = tuple(resets)          # the axis's wear resets (duty.bag_accumulator)
        self.process = self.conn = self.requests = None
        self.out: tuple | None = None
        if background:
            import multiprocessing

            ctx = multiprocessing.get_context("fork")
            self.conn, child_conn = ctx.Pipe(duplex=False)
            child_requests, self.requests = ctx.Pipe(duplex=False)
            for stream in (sys.stdout, sys.stderr):     # a forked child must not flush the parent's buffers
                stream.flush()
            self.process = ctx.Process(target=_child, args=(child_conn, child_requests, *self.args, plot),
                                       daemon=True)
            self.process.start()
            child_conn.close()
            child_requests.close()

    @property
    def background(self) -> bool:
        return self.process is not None

    def _accumulate(self, conn) -> None:
        from guide_health.analysis.discrepancy.duty import bag_accumulator

        acc = bag_accumulator(self.args[1], self.resets)
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

    def result(self):
        """(DutyCells, messages read), as read_duty_cells returns them."""
        if self.process is None:
            from guide_health.analysis.discrepancy.duty import read_duty_cells

            return read_duty_cells(*self.args, resets=self.resets)
        self._accumulate(self.conn)
        ok, value = self.out
        if not ok:
            self.close()
            raise value
        return value

    def plot(self, result: dict, path) -> None:
        """report.plot(result, path): by the child when it stayed to plot (it imported matplotlib while
        this process fitted), else here."""
        from guide_health.analysis.discrepancy.report import plot

        if self.process is None or not self.process.is_alive():
            plot(result, path)
            return
        self.requests.send((result, path))
        try:
            kind, value = self.conn.recv()
        except EOFError:
            raise RuntimeError("the plotting process ended without drawing the PNG") from None
        if kind == _ERROR:
            raise value

    def close(self) -> None:
        """End the child: it has sent everything asked of it and at most waits for a plot request, so it
        is stopped rather than left to tear down its interpreter (matplotlib, numpy) before this one exits."""
        if self.process is None:
            return
        if self.process.is_alive():
            self.process.terminate()
        self.process.join()
        for conn in (self.conn, self.requests):
            conn.close()
        self.process = None


def start_duty_cells(bag, params: dict, namespace: str | None = None, progress=None,
                     background: bool | None = None, plot: bool = False, resets=()) -> PendingCells:
    """Start reading `bag` (a path or a BagSet) into duty cells; ``background`` None: in a child when that pays
    (module docstring). ``plot``: the child then stays to draw the PNG (:meth:`PendingCells.plot`; call
    ``close()`` at the end). ``resets``: the wear resets (duty.bag_accumulator)."""
    if background is None:
        background = background_possible(bag)
    return PendingCells(bag, params, namespace, progress, bool(background and os.name == "posix"), plot, resets)
