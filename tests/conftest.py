"""Shared fixtures: a fresh plugin manager per test and a temporary-project factory."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_REAL = REPO.parent / "shared" / "data" / "real"


@pytest.fixture
def plugin_manager():
    from odsuite.contracts.plugins import make_plugin_manager

    return make_plugin_manager()


@pytest.fixture
def registries(plugin_manager):
    from odsuite.contracts.plugins import build_registries

    return build_registries(plugin_manager)


@pytest.fixture
def thesis_rig(registries):
    return registries.rigs.get("thesis-dynamometer")


@pytest.fixture
def shared_real() -> Path:
    if not SHARED_REAL.is_dir():
        pytest.skip(f"real data folder {SHARED_REAL} not present (it lies beside the repository)")
    return SHARED_REAL
