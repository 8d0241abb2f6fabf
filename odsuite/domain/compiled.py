"""numba's compiler, with its on-disk cache where one can be written.

``numba.njit(cache=True)`` raises at import where neither the package's folder nor a user cache
folder is writable (a read-only install run by a user without a writable home); the functions are
then compiled in each process instead (a few seconds once per process)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numba


def compiled(**options: Any) -> Callable[[Callable], Callable]:
    """``numba.njit(cache=True, **options)``; without a writable cache, ``cache=False``."""

    def wrap(func: Callable) -> Callable:
        try:
            return numba.njit(cache=True, **options)(func)
        except RuntimeError:  # numba: "cannot cache function ...: no locator available"
            return numba.njit(cache=False, **options)(func)

    return wrap
