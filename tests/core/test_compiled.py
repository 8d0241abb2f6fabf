"""odsuite.domain.compiled: numba's cache where one can be written, compiled per process where not."""

from __future__ import annotations

import numba.core.caching
import numpy as np
import pytest

from odsuite.domain.compiled import compiled


def _twice(x):
    return 2.0 * x


def test_without_a_writable_cache_the_functions_still_compile(monkeypatch):
    # no cache folder can be written (a read-only install, a user without a writable home): numba
    # finds no locator, and its njit(cache=True) refuses at import
    monkeypatch.setattr(numba.core.caching.CacheImpl, "_locator_classes", [])
    with pytest.raises(RuntimeError, match="no locator"):
        numba.njit(cache=True)(_twice)
    assert compiled(nogil=True)(_twice)(np.float64(1.5)) == 3.0


def test_the_simulation_modules_import_without_a_writable_cache(monkeypatch):
    import importlib
    import sys

    monkeypatch.setattr(numba.core.caching.CacheImpl, "_locator_classes", [])
    for name in ("odsuite.domain.recursions", "odsuite.domain.cubic_steps"):
        monkeypatch.delitem(sys.modules, name, raising=False)
        module = importlib.import_module(name)
        assert module.__name__ == name
