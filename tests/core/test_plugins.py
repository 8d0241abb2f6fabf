"""The plugin system: registries, conflicts, blocking, a third-party package through entry points."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from odsuite import hookimpl
from odsuite.core.errors import (
    ConfigError,
    PluginConflictError,
    PluginError,
    PluginLoadError,
)
from odsuite.core.plugins import (
    REQUIRED_BUILTINS,
    build_registries,
    make_plugin_manager,
)

THIRD_PARTY = Path(__file__).resolve().parents[1] / "data" / "thirdparty_plugin"


class _Plugin:
    """A plugin object registering one model under a given name."""

    def __init__(self, name, model_name, override=False):
        self.__name__ = name
        self.model_name = model_name
        self.override = override

    @hookimpl
    def odsuite_register_models(self, registry):
        label = f"model from {self.__name__}"
        registry.add(self.model_name, lambda rig=None: label, override=self.override)


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


def test_provider_breaking_its_contract_is_refused_in_one_line():
    class NoParameters:
        """An effect without parameters(): the diagnosis would fail half-way through."""

        name, target, description = "lab_drift", "chain", "drift"

        def apply(self, model, values):
            return model

    class Lab:
        __name__ = "lab_broken"

        @hookimpl
        def odsuite_register_effects(self, registry):
            registry.add("lab_drift", NoParameters())

    pm = make_plugin_manager(load_entry_points=False, extra_plugins=(Lab(),))
    with pytest.raises(PluginError) as err:
        build_registries(pm)
    msg = str(err.value)
    assert "\n" not in msg
    assert "lab_broken" in msg and "'lab_drift'" in msg and "NoParameters" in msg and "parameters()" in msg


def test_entry_point_name_of_two_distributions_is_refused(monkeypatch):
    """A foreign distribution declaring the built-in name 'filters' must not replace the built-in."""
    import importlib.metadata as md

    real = md.entry_points

    class Dist:
        name, version = "lab-filters", "9.9"

    def with_impostor(**kw):
        eps = list(real(**kw))
        impostor = md.EntryPoint("filters", "lab_filters", "odsuite")
        object.__setattr__(impostor, "dist", Dist())
        return eps + [impostor]

    monkeypatch.setattr(md, "entry_points", with_impostor)
    with pytest.raises(PluginConflictError) as err:
        make_plugin_manager()
    msg = str(err.value)
    assert "'filters'" in msg and "'odsuite'" in msg and "'lab-filters'" in msg


def test_entries_know_their_distribution(registries):
    from odsuite import __version__

    entry = registries.effects.entry("stiffness")
    assert (entry.plugin, entry.distribution, entry.version) == ("models", "odsuite", __version__)


def test_override_wins_whatever_the_load_order():
    for order in ((0, 1), (1, 0)):
        plugins = (_Plugin("builtin", "beam"), _Plugin("lab", "beam", override=True))
        pm = make_plugin_manager(load_entry_points=False, extra_plugins=tuple(plugins[i] for i in order))
        regs = build_registries(pm)
        assert regs.models.get("beam")() == "model from lab"
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


def test_third_party_package_is_listed_with_its_distribution(installed_third_party):
    out = _run_with(installed_third_party, "from odsuite.cli import main; main(['plugins'])").stdout
    line = next(line for line in out.splitlines() if "lab_example" in line)
    assert "odsuite-lab-example" in line and "2.3.4" in line
    assert "lab_added_mass" in out and "lab_csv" in out


def test_lab_added_mass_follows_the_parallel_axis_theorem():
    """Independent of the effect's code: a mass at G adds to the mass only; a mass at an offset r
    moves G to m_add r / M and adds m_add (|r|^2 I - r r^T) minus M |dG|^2-terms (Steiner)."""
    sys.path.insert(0, str(THIRD_PARTY))
    try:
        from odsuite_lab_example.effects import AddedPointMass
    finally:
        sys.path.remove(str(THIRD_PARTY))
    from odsuite.core.plugins import registries

    regs = registries()
    model = regs.models.get("thesis-dynamometer")(regs.rigs.get("thesis-dynamometer"))
    body = model.bodies[0]
    effect = AddedPointMass()
    at_g = effect.apply(model, {"added_mass": 0.3, "at_x": body.com[0], "at_y": body.com[1], "at_z": body.com[2]})
    assert at_g.bodies[0].mass == pytest.approx(body.mass + 0.3)
    assert at_g.bodies[0].inertia == pytest.approx(body.inertia)
    r = np.array([0.02, -0.03, 0.005])
    moved = effect.apply(model, {"added_mass": 0.3, **{f"at_{a}": v for a, v in zip("xyz", body.com + r)}})
    m, M = 0.3, body.mass + 0.3
    d = m * r / M  # the new centre of mass, from the old
    assert moved.bodies[0].com == pytest.approx(body.com + d)
    # Steiner about the new centre: body at -d, point at r - d
    expected = (body.inertia + body.mass * (d @ d * np.eye(3) - np.outer(d, d))
                + m * ((r - d) @ (r - d) * np.eye(3) - np.outer(r - d, r - d)))
    assert moved.bodies[0].inertia == pytest.approx(expected, rel=1e-12)
    # heavier: every rigid mode lower
    assert np.all(moved.modes().frequency_hz < model.modes().frequency_hz)


def test_third_party_pieces_work_through_the_cli(installed_third_party, tmp_path):
    """`diagnose` screens the lab's effect with the built-in ones; `render --figure` uses its renderer."""
    env = {**os.environ, "PYTHONPATH": str(installed_third_party)}
    p = str(tmp_path / "lab.h5")

    def odsuite(*args):
        return subprocess.run([sys.executable, "-m", "odsuite.cli", *args], env=env, capture_output=True,
                              text=True, check=True).stdout

    odsuite("new", p)
    odsuite("acquire", p, "--daq", "sim", "--name", "T1", "--samples", "2048", "--scenario", "T1")
    odsuite("process", p)
    doc = json.loads(odsuite("diagnose", p, "--effect", "lab_added_mass", "--effect", "stiffness", "--json"))
    assert {c["effect"] for c in doc["candidates"]} == {"lab_added_mass", "stiffness"}
    out = tmp_path / "T1.csv"
    odsuite("render", p, "T1", "-o", str(out), "--figure", "lab_csv")
    rows = out.read_text().splitlines()
    assert rows[0].startswith("t_s,platform_x_m") and len(rows) == 2049
