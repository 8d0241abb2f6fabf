"""Arguments a Python caller gives odsuite's functions, checked before any work: a wrong one is one
ConfigError line "<function>: '<argument>' must be <what>, got <value>" (inside, a text order or a
None raised a TypeError far from the call, and an order of 0 looped without end)."""

from __future__ import annotations

import math
import numbers
import os
import re
from collections.abc import Mapping, Sequence
from typing import Any, NoReturn

from odsuite.domain.errors import ConfigError


#: worker processes a command or renderer may start per core (as batch allows): each is a
#: process, and a million of them never start
WORKERS_PER_CORE = 4


def most_workers() -> int:
    return WORKERS_PER_CORE * (os.cpu_count() or 1)


def check_workers(workers: Any) -> None:
    """A count of worker processes (``--workers``, a renderer's ``workers`` option) within
    ``most_workers``, refused naming the option as the command line does (any caller's line)."""
    most = most_workers()
    if workers is not None and workers > most:
        raise ConfigError(f"--workers: at most {most} processes ({WORKERS_PER_CORE} per core), got {workers}")


def shown(value: Any) -> str:
    """``repr(value)`` on one line (an array's repr wraps), cut to 80 characters."""
    text = re.sub(r"\s*\n\s*", " ", repr(value))
    return text if len(text) <= 80 else text[:77] + "..."


def refuse(where: str, name: str, value: Any, expected: str) -> NoReturn:
    raise ConfigError(f"{where}: {name!r} must be {expected}, got {shown(value)}")


def whole(where: str, name: str, value: Any, low: int | None = None) -> int:
    """An integer (a numpy one too; not a bool, not 2.0: an order or a count), at least ``low``."""
    ok = isinstance(value, numbers.Integral) and not isinstance(value, bool)
    if not ok or (low is not None and value < low):
        refuse(where, name, value, "an integer" + (f" of at least {low}" if low is not None else ""))
    return int(value)


def real(where: str, name: str, value: Any, *, positive: bool = False, minimum: float | None = None) -> float:
    """A finite real number (not a bool, not text), > 0 when ``positive``, >= ``minimum`` if given."""
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or (positive and value <= 0) or (minimum is not None and value < minimum):
        limit = " > 0" if positive else f" >= {minimum:g}" if minimum is not None else ""
        refuse(where, name, value, f"a finite number{limit}")
    return float(value)


def text(where: str, name: str, value: Any, what: str = "text") -> str:
    """Non-empty text."""
    if not isinstance(value, str) or not value.strip():
        refuse(where, name, value, what)
    return value


def listed(where: str, name: str, value: Any, what: str) -> list:
    """A list, tuple or 1-D array (not text, not a mapping: one of ``what`` given for the list)."""
    import numpy as np  # here: the messages' helpers above load with any command, numpy need not

    if isinstance(value, np.ndarray) and value.ndim == 1:
        return value.tolist()
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, Sequence):
        refuse(where, name, value, f"a list of {what}")
    return list(value)
