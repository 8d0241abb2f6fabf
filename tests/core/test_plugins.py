"""The plugin system: registries, conflicts, blocking, a third-party package through entry points."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from odsuite import hookimpl
from odsuite.core.errors import ConfigError, PluginConflictError, PluginLoadError
from odsuite.core.plugins import REQUIRED_BUILTINS, build_registries, make_plugin_manager

THIRD_PARTY = Path(__file__).resolve().parents[1] / "data" / "thirdparty_plugin"


class _Plugin:
    """A plugin object registering one model under a given name."""

    def __init__(self, name, model_name, override=False):
        self.__name__ = name
        self.model_name = model_name
        self.override = override

    @hookimpl
    def odsuite_register_models(self, registry):
        registry.add(self.model_name, f"model from {self.__name__}", override=self.override)


def test_builtins_all_load_and_register(plugin_manager):
    names = {name for name, _ in plugin_manager.list_name_plugin()}
    assert set(REQUIRED_BUILTINS) <= names
    regs = build_registries(plugin_manager)
    assert "thesis-dynamometer" in regs.rigs
    assert regs.rigs.entry("thesis-dynamometer").plugin == "models"


def test_conflicting_names_name_both_plugins():
    pm = make_plugin_manager(load_entry_points=False,
                             extra_plugins=(_Plugin("lab_a", "beam"), _Plugin("lab_b", "beam")))
    with pytest.raises(PluginConflictError) as err:
        build_registries(pm)
    assert "lab_a" in str(err.value) and "lab_b" in str(err.value) and "'beam'" in str(err.value)


def test_override_wins_whatever_the_load_order():
    for order in ((0, 1), (1, 0)):
        plugins = (_Plugin("builtin", "beam"), _Plugin("lab", "beam", override=True))
        pm = make_plugin_manager(load_entry_points=False, extra_plugins=tuple(plugins[i] for i in order))
        regs = build_registries(pm)
        assert regs.models.get("beam") == "model from lab"
        assert regs.models.entry("beam").plugin == "lab"


def test_unknown_provider_lists_the_known_ones(registries):
    with pytest.raises(ConfigError, match=r"unknown rig 'nope' \(known: .*thesis-dynamometer"):
        registries.rigs.get("nope")


def test_disabled_plugins_are_blocked(monkeypatch):
    monkeypatch.setenv("ODSUITE_DISABLE_PLUGINS", "renderers, daq_ni")
    pm = make_plugin_manager()
    assert pm.get_plugin("renderers") is None and pm.get_plugin("daq_ni") is None
    assert pm.get_plugin("models") is not None


def test_missing_builtin_says_rerun_make_venv(monkeypatch):
    import importlib.metadata as md

    real = md.entry_points

    def without_filters(**kw):
        return [ep for ep in real(**kw) if ep.name != "filters"]

    monkeypatch.setattr(md, "entry_points", without_filters)
    with pytest.raises(PluginLoadError, match=r"filters.*re-run `make venv`"):
        make_plugin_manager()


def test_plugin_with_unknown_hook_is_refused():
    class Bad:
        __name__ = "bad_lab"

        @hookimpl
        def odsuite_register_modles(self, registry):  # misspelt hook
            pass

    with pytest.raises(PluginLoadError, match="bad_lab"):
        make_plugin_manager(load_entry_points=False, extra_plugins=(Bad(),))


@pytest.fixture(scope="module")
def installed_third_party(tmp_path_factory):
    """The lab package built and installed into a separate target directory by pip."""
    target = tmp_path_factory.mktemp("site")
    build = tmp_path_factory.mktemp("build")
    src = build / "src"
    subprocess.run(["cp", "-r", str(THIRD_PARTY), str(src)], check=True)
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
         "--target", str(target), str(src)],
        check=True, capture_output=True, text=True,
    )
    return target


def _run_with(target: Path, code: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(target)}
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)


def test_third_party_package_is_listed_with_its_version(installed_third_party):
    out = _run_with(installed_third_party, "from odsuite.cli import main; main(['plugins'])").stdout
    line = next(line for line in out.splitlines() if "lab_example" in line)
    assert "2.3.4" in line
    assert "lab_thermal_drift" in out and "lab_ascii" in out


def test_third_party_providers_are_usable(installed_third_party):
    code = (
        "from odsuite.core.plugins import registries\n"
        "r = registries()\n"
        "print(r.effects.get('lab_thermal_drift').apply_to_signal([1.0, 1.0, 1.0], 0.5).tolist())\n"
        "print(r.renderers.get('lab_ascii').render([1, -1, 2]))\n"
        "print(r.effects.entry('lab_thermal_drift').plugin)\n"
    )
    out = _run_with(installed_third_party, code).stdout.split("\n")
    assert out[0] == "[1.0, 1.5, 2.0]"
    assert out[1] == "#.#"
    assert out[2] == "lab_example"
