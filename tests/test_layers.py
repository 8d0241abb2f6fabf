"""The layer order of docs/architecture.md, as import-linter contracts (pyproject.toml's
``[tool.importlinter]``): each layer imports only the layers below it, odsuite never imports the
built-in plugins, and the built-in plugins import only ``odsuite.api`` and ``odsuite.contracts``."""

from __future__ import annotations

import importlib
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _layers() -> list[str]:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
    layers = next(c for c in config if c["type"] == "layers")["layers"]
    return [name.strip() for entry in layers for name in entry.split("|")]


def test_import_linter_contracts_are_kept(monkeypatch):
    from importlinter.cli import lint_imports

    monkeypatch.chdir(ROOT)
    monkeypatch.syspath_prepend(str(ROOT))
    assert lint_imports(config_filename=str(ROOT / "pyproject.toml")) == 0


@pytest.mark.parametrize("layer", _layers())
def test_every_layer_says_what_it_holds(layer):
    module = importlib.import_module(layer)
    doc = (module.__doc__ or "").strip()
    assert len(doc) > 80, f"{layer} has no docstring saying what it holds and what it may import"


def test_every_package_is_a_layer():
    """A new folder under odsuite/ is placed in the layer order (or it escapes every contract)."""
    folders = {p.parent.name for p in (ROOT / "odsuite").glob("*/__init__.py")}
    modules = {p.stem for p in (ROOT / "odsuite").glob("*.py")} - {"__init__"}
    named = {layer.split(".")[1] for layer in _layers()}
    assert folders | modules == named, (folders | modules) ^ named


def test_the_api_names_resolve():
    import odsuite.api as api

    missing = [name for name in api.__all__ if getattr(api, name, None) is None]
    assert not missing
