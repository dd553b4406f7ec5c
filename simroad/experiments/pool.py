"""Run a sweep's cells in worker processes that stop at once when interrupted.

A small process pool with one pipe per worker, so the parent alone decides when
workers end (no queue locks or feeder threads that a signal can leave half-held):

- workers ignore SIGINT (a terminal's Ctrl-C reaches the whole process group; only
  the parent acts on it);
- the parent's first SIGINT stops handing out cells and terminates the workers
  (SIGTERM), waits for them and raises :class:`KeyboardInterrupt`;
- a second SIGINT while it waits kills them (SIGKILL) and raises at once.

Rows are written by the parent only, one whole line per write, so an interrupt can
at worst leave the last line torn, which the next run moves aside.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from multiprocessing import get_context
from multiprocessing.connection import Connection, wait
from types import FrameType
from typing import Any

__all__ = ["Interrupts", "default_workers", "run_in_workers"]

#: How often (s) the parent checks for an interrupt while waiting for results.
_POLL_S = 0.1
#: How long (s) terminated workers get to exit before they are killed.
_TERM_GRACE_S = 2.0


#: Imported once by the fork server, before it forks any worker: every worker starts with
#: simroad's episode machinery loaded (about a second each otherwise).
_PRELOAD = ["simroad.experiments.ablate"]


def default_workers() -> int:
    """Worker processes by default: the cores this process may use (its CPU affinity
    where the platform has one, else every core)."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def _context() -> Any:
    """How to start workers: from a fork server where the platform has one (Linux, macOS),
    else spawn (Windows). Never a plain fork of the caller: OpenCV's thread pool, numba's
    and Ray's threads hold locks that a forked child inherits taken, and the child hangs
    on the first of them (seen: ``cv2.setNumThreads`` in a forked worker waiting forever
    in ``pthread_cond_destroy`` after the parent had run OpenCV). The fork server is a
    clean process started once per parent; the cell function must be importable (a
    top-level function of a module), as :func:`~simroad.experiments.ablate.run_cell` is."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return get_context("spawn")
    ctx = get_context("forkserver")
    ctx.set_forkserver_preload(_PRELOAD)  # no effect once the server runs
    return ctx


class Interrupts:
    """Count SIGINTs in the main thread instead of raising (a context manager).

    Outside the main thread (where Python cannot install handlers) it counts nothing
    and leaves Ctrl-C to Python's default.
    """

    def __init__(self) -> None:
        self.count = 0
        self._previous: Any = None
        self._installed = False

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        self.count += 1

    def __enter__(self) -> Interrupts:
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, self._handle)
            self._installed = True
        return self

    def __exit__(self, *exc: object) -> None:
        if self._installed:
            signal.signal(signal.SIGINT, self._previous)
            self._installed = False


def _worker(conn: Connection, cell_fn: Callable, initializer: Callable[[], None] | None) -> None:
    """A worker's loop: receive a cell, send ``(True, record)`` or ``(False, exception)``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if initializer is not None:
        initializer()
    while True:
        try:
            item = conn.recv()
        except EOFError:
            return
        if item is None:
            return
        try:
            result: tuple[bool, Any] = (True, cell_fn(item))
        except Exception as exc:
            result = (False, exc)
        try:
            try:
                conn.send(result)
            except OSError:
                raise
            except Exception as exc:  # an unpicklable result or exception
                conn.send((False, RuntimeError(f"{result[1]!r} (could not be sent back: {exc})")))
        except OSError:  # the parent is gone
            return


class _Workers:
    def __init__(self, n: int, cell_fn: Callable, initializer: Callable[[], None] | None) -> None:
        ctx = _context()
        self.procs: list[Any] = []
        self.conns: list[Connection] = []
        for _ in range(n):
            parent, child = ctx.Pipe()
            proc = ctx.Process(target=_worker, args=(child, cell_fn, initializer), daemon=True)
            proc.start()
            child.close()
            self.procs.append(proc)
            self.conns.append(parent)

    def stop(self, interrupts: Interrupts | None, *, graceful: bool) -> None:
        """End every worker: ask (graceful), else terminate, then kill after the grace
        period or at once on a (further) interrupt."""
        seen = interrupts.count if interrupts is not None else 0
        for conn, proc in zip(self.conns, self.procs):
            if not proc.is_alive():
                continue
            if graceful:
                try:
                    conn.send(None)
                except OSError:
                    proc.terminate()
            elif seen >= 2:
                proc.kill()
            else:
                proc.terminate()
        deadline = time.monotonic() + _TERM_GRACE_S
        while any(p.is_alive() for p in self.procs):
            if time.monotonic() > deadline or (interrupts is not None and interrupts.count > seen):
                for p in self.procs:
                    if p.is_alive():
                        p.kill()
                break
            wait([p.sentinel for p in self.procs if p.is_alive()], timeout=_POLL_S)
        for p in self.procs:
            p.join(timeout=1.0)
        for conn in self.conns:
            conn.close()


def run_in_workers(
    items: list[Any],
    n: int,
    cell_fn: Callable[[Any], Any],
    *,
    initializer: Callable[[], None] | None = None,
    interrupts: Interrupts | None = None,
) -> Iterator[Any]:
    """Yield ``cell_fn(item)`` for every item, computed in ``n`` worker processes.

    Parameters
    ----------
    items : list
        Picklable work items (the cells' specs), handed out in order.
    n : int
        Number of worker processes (>= 1).
    cell_fn : callable
        A picklable top-level function ``item -> record``.
    initializer : callable, optional
        Run once in each worker before its first item.
    interrupts : Interrupts, optional
        The SIGINT counter of the caller; when it counts, workers are ended and
        :class:`KeyboardInterrupt` is raised.

    Yields
    ------
    object
        Each result (a sweep's record) as soon as it is done (not in item order).

    Raises
    ------
    KeyboardInterrupt
        After an interrupt, once every worker has ended.
    RuntimeError
        If a worker process dies (e.g. killed) while running an item.
    """
    if not items:
        return
    queue = list(reversed(items))
    workers = _Workers(min(n, len(items)), cell_fn, initializer)
    busy: dict[Connection, Any] = {}
    graceful = False
    try:
        for conn in workers.conns:
            if queue:
                busy[conn] = queue.pop()
                conn.send(busy[conn])
        while busy:
            if interrupts is not None and interrupts.count:
                raise KeyboardInterrupt
            ready = wait(list(busy), timeout=_POLL_S)  # a result, or EOF: the worker died
            for conn in [c for c in busy if c in ready]:
                item = busy.pop(conn)
                try:
                    ok, value = conn.recv()
                except EOFError:
                    proc = workers.procs[workers.conns.index(conn)]
                    proc.join(1.0)
                    raise RuntimeError(
                        f"a sweep worker died (exit code {proc.exitcode}) while running {item!r}; "
                        "the rows written so far are kept: run the same command again to resume."
                    ) from None
                if not ok:
                    raise value
                yield value
                if queue and not (interrupts is not None and interrupts.count):
                    busy[conn] = queue.pop()
                    conn.send(busy[conn])
        graceful = True
    finally:
        workers.stop(interrupts, graceful=graceful)
