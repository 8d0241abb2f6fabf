"""The diagnosis's worker processes: candidates are screened and fitted on forked processes (or one
after another in this process), each with one BLAS thread, sharing what they need through
``JOBS``."""

from __future__ import annotations

import itertools
import multiprocessing
import os
import signal
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from threadpoolctl import threadpool_limits


class Deferred:
    """A call run when its result is asked for: a fit that is never asked for costs nothing."""

    def __init__(self, fn: Callable, args: tuple) -> None:
        self._fn, self._args = fn, args

    def cancel(self) -> bool:
        return True

    def done(self) -> bool:  # it runs when asked for
        return False

    def result(self) -> Any:
        return self._fn(*self._args)


class InOrder:
    """The part of concurrent.futures' executor interface diagnose uses, one call after another
    in this thread (workers=1)."""

    def __enter__(self) -> InOrder:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    def map(self, fn: Callable, *items) -> Any:
        return map(fn, *items)

    def submit(self, fn: Callable, *args: Any) -> Deferred:
        return Deferred(fn, args)


def default_workers(n_candidates: int) -> int:
    """As many worker processes as cores, at most 2 for a handful of candidates (a pool's start
    and the fits' transfer cost more than a third process gains there) and never more than there
    are candidates."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(cores, n_candidates, 2 if n_candidates <= SMALL_JOB else cores))


#: up to this many candidates a diagnosis is a small job (default_workers)
SMALL_JOB = 32

#: what a diagnosis's worker processes need, keyed by a token per call: filled before the pool
#: forks, so the processes inherit it (models hold the effects' shape functions, which do not
#: pickle) and only effect names, starts and fitted numbers travel
JOBS: dict[int, dict[str, Any]] = {}
TOKENS = itertools.count()


def forked_pool(workers: int) -> ProcessPoolExecutor:
    """``workers`` forked processes (worker_start), every one started before this returns with a
    Ctrl-C held back meanwhile: a process forked with the command line's handler and interrupted
    before its initializer ran printed that handler's traceback (1 of 5 interrupted diagnoses)."""
    from odsuite.store.storage import interrupts_held

    pool = ProcessPoolExecutor(workers, multiprocessing.get_context("fork"), initializer=worker_start)
    try:
        with interrupts_held():
            pool.submit(int)  # a fork context starts every process at the first task
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    return pool


def worker_start() -> None:
    # a terminal's Ctrl-C reaches every process of the command: the command line reports it once,
    # and a worker ends without a word (forked, it would raise the command's interrupt and print
    # its traceback); a task it runs ends as the command's does. While this initializer runs it
    # only silences the process: an exception here is logged with its traceback
    # (concurrent.futures), and the command ends the process anyway
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _silenced)
    # one BLAS thread per process: the processes share the cores, and a BLAS pool per process
    # would spin against the other process's work
    threadpool_limits(1)
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _end_quietly)


def _silenced(signum: int, frame: object) -> None:
    # after the command's interrupt nothing this process prints is news: a queue read that the
    # command's own exit cut short ended in an EOFError traceback (1 of 20 interrupted diagnoses)
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 2)
    os.close(devnull)


def _end_quietly(signum: int, frame: object) -> None:
    _silenced(signum, frame)
    raise SystemExit(1)  # multiprocessing ends a process on SystemExit without a traceback
