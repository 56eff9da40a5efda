"""Independent rendering tasks (a figure file, a section of ``report.html``) run side by side in forked processes.

A report's figures cost as much as a short record's analysis (matplotlib's drawing, ≈ 0.2 s per figure; a loop on a
whole measured record draws ~70). They depend on nothing but the result they show, so they can be drawn by several
processes at once. The processes are forked: each inherits the result (and matplotlib, imported) from this one
instead of receiving a pickled copy of arrays of the record's length, and returns only what it rendered (a path, an
HTML string). Forking is safe only from a process running one thread (a lock another thread holds at the fork stays
held in the child): with more threads (a Dask worker, a node) or where the platform does not fork, the tasks run here
one after the other, with the same results. Why and what it saves: docs/analysis.md, "Why the figures are drawn
as they are", "Drawn side by side".
"""

from __future__ import annotations

import gc
import multiprocessing
import signal
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import TypeVar

T = TypeVar("T")

#: The tasks of the current :func:`run_tasks` call, inherited by its forked processes (which run them by index).
_TASKS: list[Callable[[], object]] = []


def _run(index: int) -> object:
    return _TASKS[index]()


def _leave_interrupts_to_the_caller() -> None:
    """A worker's start: Ctrl-C (sent to the whole process group) is the caller's to handle; it stops the workers."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def can_fork() -> bool:
    """True where this process may fork workers safely: the platform forks and this process runs one thread."""
    return "fork" in multiprocessing.get_all_start_methods() and threading.active_count() == 1


def run_tasks(tasks: Sequence[Callable[[], T]], processes: int) -> list[T]:
    """Each task's return value, in the order of ``tasks``.

    Parameters
    ----------
    tasks
        Callables without arguments; each must depend only on what this process holds when called (no state another
        task changes) and return a picklable value.
    processes
        Largest number of processes to run them in; with fewer than two (or fewer than two tasks), or where
        :func:`can_fork` is False, they run here in turn. Tasks are handed out one at a time in order, so a
        process that finishes early takes the next.

    An exception raised by a task is raised here, and so is the loss of a process (killed, out of memory:
    ``BrokenProcessPool``) instead of a wait without end. Ctrl-C is this process's alone: the workers ignore it and
    are stopped when it leaves (so a user sees no worker's traceback).
    """
    workers = min(processes, len(tasks))
    if workers < 2 or not can_fork():
        return [task() for task in tasks]
    _TASKS[:] = tasks
    others = set(multiprocessing.active_children())
    gc.freeze()  # the collector in a child would write to every object it inherited, copying their pages
    executor = ProcessPoolExecutor(workers, multiprocessing.get_context("fork"), _leave_interrupts_to_the_caller)
    try:
        return list(executor.map(_run, range(len(tasks))))
    except BaseException:
        for process in set(multiprocessing.active_children()) - others:  # its workers, busy or idle
            process.terminate()
        raise
    finally:
        executor.shutdown(wait=True, cancel_futures=True)
        gc.unfreeze()
        _TASKS.clear()
