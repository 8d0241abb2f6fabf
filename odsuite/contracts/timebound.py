"""A time bound on a third-party plugin's own code (its import and its registration hooks): a
plugin stuck in an endless loop is interrupted and left out instead of hanging every command."""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Iterator

from odsuite.domain.errors import PluginLoadError

#: s a third-party plugin may spend importing, and again in each registration hook
PLUGIN_SECONDS = 20.0
PLUGIN_SECONDS_ENV = "ODSUITE_PLUGIN_TIMEOUT"


class PluginTimeout(BaseException):
    """A plugin's code ran past its time bound (a BaseException, like KeyboardInterrupt, so the
    plugin's own ``except Exception`` does not swallow it)."""


def plugin_seconds() -> float:
    """The bound from ``ODSUITE_PLUGIN_TIMEOUT`` (seconds; 0 turns it off), else PLUGIN_SECONDS."""
    raw = os.environ.get(PLUGIN_SECONDS_ENV, "").strip()
    if not raw:
        return PLUGIN_SECONDS
    try:
        value = float(raw)
    except ValueError:
        value = float("nan")
    if not 0 <= value <= 3600:
        raise PluginLoadError(f"{PLUGIN_SECONDS_ENV}: expected seconds from 0 (no bound) to 3600, got {raw!r}")
    return value


@contextlib.contextmanager
def time_bound(seconds: float) -> Iterator[None]:
    """Raise PluginTimeout in the block after ``seconds`` (SIGALRM; repeated every second, so a
    plugin that swallows one still stops). Only the main thread receives signals: elsewhere, and
    where there is no SIGALRM (Windows), the block runs unbounded. Code blocked inside one C call
    that ignores signals, or a loop catching every exception with a bare ``except``, is not
    interrupted."""
    if (seconds <= 0 or not hasattr(signal, "setitimer")
            or threading.current_thread() is not threading.main_thread()):
        yield
        return

    def alarm(signum, frame):
        raise PluginTimeout(f"still running after {seconds:g} s (the bound is {PLUGIN_SECONDS_ENV})")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds, 1.0)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
