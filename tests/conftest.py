"""Shared fixtures: a fresh plugin manager per test and a temporary-project factory."""

from __future__ import annotations

from pathlib import Path

import pytest

# the shared command-line helper asserts like a test module does, its failures showing the values
pytest.register_assert_rewrite("tests.cli.clirun")

REPO = Path(__file__).resolve().parents[1]
#: Real recordings from other labs, kept in the repository with their origin and licence
#: (tests/data/real/README.md).
REAL_DATA = REPO / "tests" / "data" / "real"


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
def real_data() -> Path:
    """The folder of real recordings (one subfolder per source, each with README and LICENSE).
    They ship with the repository: a missing folder is an error, never a skip."""
    assert REAL_DATA.is_dir(), f"real data folder {REAL_DATA} missing from the repository"
    return REAL_DATA
