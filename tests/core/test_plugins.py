"""The plugin system: registries, conflicts, blocking, a third-party package through entry points."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from odsuite import hookimpl
from odsuite.domain.errors import (
    ConfigError,
    PluginConflictError,
    PluginError,
    PluginLoadError,
)
from odsuite.contracts.plugins import (
    REQUIRED_BUILTINS,
    build_registries,
    make_plugin_manager,
)

THIRD_PARTY = Path(__file__).resolve().parents[1] / "data" / "thirdparty_plugin"
THESIS_RIG = Path(__file__).resolve().parents[2] / "plugins" / "models" / "rigs" / "thesis-dynamometer.toml"


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


def _cli(target: Path, *args) -> str:
    """stdout of `odsuite ARGS` in a process that sees the installed lab package."""
    env = {**os.environ, "PYTHONPATH": str(target)}
    done = subprocess.run([sys.executable, "-m", "odsuite.cli", *map(str, args)], env=env, capture_output=True,
                          text=True)
    assert done.returncode == 0, f"odsuite {' '.join(map(str, args))}: {done.stderr}"
    return done.stdout


def _lab_module(name: str):
    """A module of the lab package imported from its source tree (tests of its physics)."""
    import importlib

    sys.path.insert(0, str(THIRD_PARTY))
    try:
        return importlib.import_module(f"odsuite_lab_example.{name}")
    finally:
        sys.path.remove(str(THIRD_PARTY))


def test_third_party_package_is_listed_with_its_distribution(installed_third_party):
    out = _run_with(installed_third_party, "from odsuite.cli import main; main(['plugins'])").stdout
    line = next(line for line in out.splitlines() if "lab_example" in line)
    assert "odsuite-lab-example" in line and "2.3.4" in line
    assert "lab_added_mass" in out and "lab_csv" in out and "lab_wls" in out and "lab_si_csv" in out
    assert "lab_mv_per_g" in out


def test_lab_added_mass_follows_the_parallel_axis_theorem():
    """Independent of the effect's code: a mass at G adds to the mass only; a mass at an offset r
    moves G to m_add r / M and adds m_add (|r|^2 I - r r^T) minus M |dG|^2-terms (Steiner)."""
    AddedPointMass = _lab_module("effects").AddedPointMass
    from odsuite.contracts.plugins import registries

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
    p = str(tmp_path / "lab.h5")

    def odsuite(*args):
        return _cli(installed_third_party, *args)

    odsuite("new", p)
    odsuite("acquire", p, "--daq", "sim", "--name", "T1", "--samples", "2048", "--scenario", "T1")
    odsuite("process", p)
    doc = json.loads(odsuite("diagnose", p, "--effect", "lab_added_mass", "--effect", "stiffness", "--json"))
    assert {c["effect"] for c in doc["candidates"]} == {"lab_added_mass", "stiffness"}
    out = tmp_path / "T1.csv"
    odsuite("render", p, "T1", "-o", str(out), "--figure", "lab_csv")
    rows = out.read_text().splitlines()
    assert rows[0].startswith("t_s,platform_x_m") and len(rows) == 2049


def test_lab_wls_recovers_a_rigid_motion_and_weighs_by_sensitivity(registries):
    """Signals of a known rigid motion (s_i = a_i . (t + Theta x r_i), closed form) give that motion
    back; a direction measured twice comes out as the mean weighted by sensitivity^2 (with six
    other independent directions the rest of the fit is exact, so the weighted mean is the
    minimiser); the solver is never chosen over the built-ins unless the rig file names it."""
    from dataclasses import replace

    from odsuite.contracts.solvers import choose_solver

    solver = _lab_module("solvers").WeightedLeastSquares()
    thesis = registries.rigs.get("thesis-dynamometer")
    body = thesis.body("platform")
    t = np.linspace(0.0, 0.05, 400)
    d = np.stack([a * np.sin(2 * np.pi * f * t) for a, f in
                  zip((2e-6, -1e-6, 3e-6, 4e-5, -2e-5, 1e-5), (90, 110, 130, 150, 170, 190))], axis=1)

    def reading(motion, sensor):
        return motion[:, :3] @ sensor.axis + np.cross(motion[:, 3:], sensor.position - body.com) @ sensor.axis

    signals = {s.name: reading(d, s) for s in thesis.sensors}
    assert solver.solve(thesis, body, signals).at_g == pytest.approx(d, abs=1e-12 * np.abs(d).max())

    zc = thesis.sensor("zC")
    twin = replace(zc, name="zC_twin", channel=11, sensitivity=2 * zc.sensitivity)  # weight 4 x zC's
    six = ("xC", "yC", "zC", "z1", "y2", "x3")  # six independent directions
    rig = replace(thesis, sensors=tuple(thesis.sensor(n) for n in six) + (twin,), channel_count=12)
    delta = 1e-7 * np.cos(2 * np.pi * 70 * t)
    res = solver.solve(rig, body, {**{n: signals[n] for n in six}, "zC_twin": signals["zC"] + delta})
    assert reading(res.at_g, zc) == pytest.approx(signals["zC"] + 4 / 5 * delta, abs=1e-9 * np.abs(delta).max())
    for n in six[:2] + six[3:]:  # the other directions are fitted exactly
        assert reading(res.at_g, thesis.sensor(n)) == pytest.approx(signals[n], abs=1e-9 * np.abs(delta).max())

    names = [s.name for s in thesis.sensors]
    assert solver.suitability(thesis, body, names) == 0.5
    assert solver.suitability(thesis, body, names[:5]) is None
    assert choose_solver(thesis, body, names, registries.coordinate_solvers).name == "padgaonkar-nine"


def test_third_party_solver_and_importer_work_through_the_cli(installed_third_party, tmp_path):
    """`process` uses the lab's solver where the rig file names it (provenance and the body's
    solver attribute say so); `import` reads the lab's CSV by its suffix, and that record,
    processed, gives the same coordinates as the acquired one it was written from."""
    from odsuite import open_project
    from odsuite.contracts.plugins import registries

    text = THESIS_RIG.read_text()
    assert text.count('name = "platform"\n') == 1
    text = text.replace('name = "platform"\n', 'name = "platform"\nsolver = "lab_wls"\n')
    # sensor xC as the lab's datasheet kind: its sensitivity in mV/g
    xc = next(s for s in registries().rigs.get("thesis-dynamometer").sensors if s.name == "xC")
    start = text.index('name = "xC"')
    end = text.index("[[sensors]]", start)
    block = "\n".join(f"sensitivity = {xc.sensitivity * 1000 * 9.80665!r}" if ln.startswith("sensitivity")
                      else 'kind = "lab_mv_per_g"' if ln.startswith("kind") else ln
                      for ln in text[start:end].split("\n"))
    assert 'kind = "lab_mv_per_g"' in block
    text = text[:start] + block + text[end:]
    rig_file = tmp_path / "lab-rig.toml"
    rig_file.write_text(text)
    shutil.copy(THESIS_RIG.with_name("thesis-table-e3.CTR"), tmp_path)  # the rig file's Systeminfo
    p = tmp_path / "lab.h5"
    _cli(installed_third_party, "new", p, "--rig", rig_file)
    _cli(installed_third_party, "acquire", p, "--daq", "sim", "--name", "T1", "--samples", "2048",
         "--scenario", "T1")
    assert "platform: lab_wls" in _cli(installed_third_party, "process", p)
    with open_project(p) as project:
        info = project.derived_info("T1", "gencoords")
        lab = project.read_derived("T1", "gencoords")["platform_at_g"]
        processed = project.read_derived("T1", "processed")
        names = project.derived_info("T1", "processed")["attrs"]["channel_names"].split(", ")
        rig = project.rig
        exp = project.experiment("T1")
        si, raw = exp.systeminfo, exp.raw()
    assert info["attrs"]["platform_solver"] == "lab_wls"
    assert rig.sensor("xC").sensitivity == pytest.approx(xc.sensitivity, rel=1e-12)
    assert info["provenance"]["parameters"]["providers"]["platform"] == {
        "plugin": "lab_example", "distribution": "odsuite-lab-example", "version": "2.3.4"}

    # The built-in solvers on the same stored displacements. For a rigid body every unbiased
    # linear solver gives the same coordinates; they differ only through the part of the signals
    # no rigid motion explains (noise, each channel's offset drift after the high-pass), which the
    # built-in least squares reports as its residual (0.8 % of the signals' RMS in this record).
    signals = {n: processed["displacement"][:, j] for j, n in enumerate(names)}
    body = rig.body("platform")
    solvers = registries().coordinate_solvers
    ls = solvers.get("least-squares").solve(rig, body, signals)
    assert ls.residual < 0.02
    # Same estimator but for the weights, which lie within +-7 % of their mean ((21.413 /
    # 19.986)^2 = 1.148); the residual of least squares is orthogonal to the layout, so the two
    # differ by at most ~7 % of that residual times the layout's amplification: a few 1e-3 of the
    # body's largest translation (rotation); measured 2e-4
    scale = np.r_[[np.abs(ls.at_g[:, :3]).max()] * 3, [np.abs(ls.at_g[:, 3:]).max()] * 3]
    assert np.all(np.abs(lab - ls.at_g).max(0) / scale < 2e-3)
    # Padgaonkar's closed form takes each angle as the mean of two estimates from disjoint sensor
    # pairs, e1 = angle + n1 and e2 = angle + n2, so it differs from the (far less noisy) weighted
    # fit by about -(n1 + n2) / 2, whose RMS is RMS(e1 - e2) / 2 for independent n1, n2: the
    # difference stays below its own rigidity check's RMS(e1 - e2); measured 0.48, 0.45, 0.27 of it
    nine_solver = solvers.get("padgaonkar-nine")
    nine = nine_solver.solve(rig, body, signals)
    check = nine_solver.rigidity_check(rig, body, signals)  # the Eq. 4.12 pairs, on displacements
    angle_rms = np.sqrt(sum(np.mean(nine.at_g[:, 3 + k] ** 2) for k in range(3)))
    for k, axis in enumerate("xyz"):
        difference = np.sqrt(np.mean((lab[:, 3 + k] - nine.at_g[:, 3 + k]) ** 2))
        assert difference < check.fractions[axis] * angle_rms, axis

    # the lab's CSV, written from the acquired record in SI (volts / (sensitivity x gain), sign
    # undone), is found by its suffix and stored as written
    columns = {"force": 0, **{s.name: s.channel for s in rig.sensors}}
    physical = raw * np.array([(-1 if c.invert else 1) / (c.sensitivity * c.daq_gain) for c in si.channels])
    csv_file = tmp_path / "T1-si.csv"
    table = np.column_stack([np.arange(raw.shape[0]) / exp.sampling_rate, physical[:, list(columns.values())]])
    header = "t_s," + ",".join(f"{n}_N" if n == "force" else f"{n}_m/s^2" for n in columns)
    np.savetxt(csv_file, table, fmt="%.17g", delimiter=",", header=header, comments="")  # 17 digits: exact
    out = _cli(installed_third_party, "import", p, csv_file, "--name", "C1", "--force-point", "0,0,-11.4",
               "--force-dir", "+z")
    assert "lab_si_csv" in out
    with open_project(p) as project:
        imported = project.experiment("C1")
        assert imported.sampling_rate == exp.sampling_rate
        assert imported.excitation.point == pytest.approx([0.0, 0.0, -0.0114])
        stored = imported.raw()
    for c in columns.values():
        assert np.array_equal(stored[:, c], physical[:, c])
    _cli(installed_third_party, "process", p, "--experiment", "C1")
    with open_project(p) as project:
        again = project.read_derived("C1", "gencoords")["platform_at_g"]
    # the same linear chain on the same values: equal up to the order of floating-point rounding
    assert np.all(np.abs(again - lab).max(0) / scale < 1e-9)


@pytest.mark.parametrize("essential", ["filters", "models"])
def test_an_essential_plugin_cannot_be_disabled(monkeypatch, essential, capsys):
    """The core writes the filter plugin's step names and reads rig files through the models
    plugin's sensor kinds: disabling either is refused in one line saying why, before any work."""
    from odsuite.cli import main
    from odsuite.contracts.plugins import reset_default

    monkeypatch.setenv("ODSUITE_DISABLE_PLUGINS", f"renderers,{essential}")
    with pytest.raises(PluginLoadError, match=rf"plugin '{essential}' cannot be disabled: .*plugins that can: beam,"):
        make_plugin_manager()
    reset_default()  # the command line builds its manager afresh, as a new process does
    try:
        assert main(["plugins"]) == 1
    finally:
        monkeypatch.delenv("ODSUITE_DISABLE_PLUGINS")
        reset_default()
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ODSUITE_DISABLE_PLUGINS: plugin") and "\n" not in err


def test_a_project_opens_without_the_plugin_that_registered_its_rig(tmp_path):
    """A lab plugin registers a rig; the project made on it opens, rig and model included, in an
    odsuite where that plugin is not installed (the project holds the rig's definition)."""
    import dataclasses
    import types

    from odsuite.api import hookimpl, open_project
    from odsuite.contracts.plugins import build_registries
    from odsuite.domain.rig import load_rig
    from odsuite.store.project import create_project

    lab = types.ModuleType("lab_rig_plugin")

    @hookimpl
    def odsuite_register_rigs(registry):
        rig = load_rig(THESIS_RIG, registry.sensor_types)
        registry.add("lab-bench", dataclasses.replace(rig, name="lab-bench"))

    lab.odsuite_register_rigs = odsuite_register_rigs
    with_lab = build_registries(make_plugin_manager(extra_plugins=(lab,)))
    create_project(tmp_path / "p.h5", "lab-bench", registries=with_lab).close()
    installed = build_registries(make_plugin_manager())
    assert "lab-bench" not in installed.rigs
    with open_project(tmp_path / "p.h5", registries=installed) as p:
        assert p.rig.name == "lab-bench" and len(p.rig.sensors) == len(with_lab.rigs.get("lab-bench").sensors)
        from odsuite.analysis.modelrev import revision_model

        assert len(revision_model(p).shared.modes()) == 6


def test_registration_imports_no_heavy_module():
    """Every command builds the registries before it runs: registering the installed plugins
    imports none of numpy, scipy (and its signal, stats, interpolate), h5py, matplotlib, pyvista or
    VTK, nor the model, the rig or a contract module that needs them (providers load on first use),
    and `odsuite plugins` runs without numpy, so it and `odsuite info` start at once."""
    heavy = ("numpy", "scipy", "scipy.signal", "scipy.stats", "scipy.interpolate", "h5py", "matplotlib",
             "pyvista", "vtk", "odsuite.domain.model", "odsuite.domain.rig", "odsuite.contracts.effects")
    code = ("import sys; from odsuite.contracts.plugins import registries; registries(); "
            f"print(sorted(m for m in {heavy!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
    code = ("import contextlib, io, sys; from odsuite.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()) as out: code = main(['plugins'])\n"
            "assert code == 0 and 'acquire --daq sim options:' in out.getvalue(), out.getvalue()\n"
            f"print(sorted(m for m in {heavy!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_every_deferred_builtin_loads_as_registered(registries):
    """The built-in plugins name their providers without importing them: each name loads a
    provider that meets its kind's contract, under its own name, and a DAQ backend's options as
    registered (what `odsuite plugins` printed) are the backend's own."""
    from dataclasses import fields

    for f in fields(registries):
        registry = getattr(registries, f.name)
        for name, provider in registry.items():  # loads and checks each deferred provider
            assert registry.contract.missing(provider) == [], (f.name, name)
            assert getattr(provider, "name", name) == name, (f.name, name)
    for backend in ("sim", "ni"):
        assert registries.daq_backends.attribute(backend, "options") is registries.daq_backends.get(backend).options
    from odsuite_plugins.filters.steps import PROVIDERS

    assert sorted(PROVIDERS) == [n for n in registries.processing_steps if registries.processing_steps.entry(n).plugin == "filters"]
    from odsuite_plugins.importers.providers import builtin_importers
    from odsuite_plugins.renderers.providers import builtin_renderers

    # the names each plugin registers without importing its providers are those they make, once each
    assert sorted(r.name for r in builtin_renderers()) == registries.renderers.by_plugin("renderers")
    assert sorted(i.name for i in builtin_importers()) == registries.importers.by_plugin("importers")


def test_deferred_provider_is_made_once_and_checked_when_first_used():
    """``add_deferred``: nothing is made at registration; the first use makes the provider once,
    checks it against the contract (one line naming the plugin) and against the attributes given
    at registration, which ``attribute`` reads without making it."""
    from odsuite.contracts.daq import BackendOption
    from odsuite.contracts.registry import Contract, Registry, Source

    made = []

    class Backend:
        description = "a lab card"
        options = (BackendOption("gain", float, 1.0, "input gain"),)

        def record(self, rig, settings, **kw):
            raise AssertionError

    def make(cls=Backend):
        made.append(cls)
        return cls()

    registry = Registry("daq backend", Contract(module="odsuite.contracts.daq"))
    lab = Source("lab", "lab-daq", "1.0")
    registry.add_deferred("card", make, source=lab, options=Backend.options)
    assert made == [] and "card" in registry and registry.names() == ["card"]
    assert registry.attribute("card", "options") is Backend.options and made == []
    assert registry.get("card") is registry.get("card") and made == [Backend]

    class NoRecord:
        description, options = "no record()", ()

    registry.add_deferred("broken", lambda: make(NoRecord), source=lab)
    with pytest.raises(PluginError) as err:
        registry.get("broken")
    assert "\n" not in str(err.value) and "'lab'" in str(err.value) and "record()" in str(err.value)

    registry.add_deferred("other", make, source=lab, options=())
    with pytest.raises(PluginError, match=r"'lab'.* 'other' has other options than it registered"):
        registry.get("other")


@pytest.mark.parametrize("body, why", [
    ("from odsuite import hookimpl\n@hookimpl\ndef odsuite_register_effects(registry):\n"
     "    raise RuntimeError('lab plugin broke')\n", "in its hook odsuite_register_effects: RuntimeError: lab plugin broke"),
    ("import sys\nsys.exit(3)\n", "to load: SystemExit: 3"),
    ("print('noise')\nraise ImportError('needs labdriver')\n", "to load: ImportError: needs labdriver"),
])
def test_failing_third_party_plugin_is_left_out(tmp_path, body, why):
    """An installed plugin whose import or registration hook fails is one line naming it and its
    distribution; every other command runs, and `odsuite plugins --json` lists the failure."""
    _left_out(tmp_path, body, why, {})


def _left_out(tmp_path, body, why, env):
    """``body`` installed as the plugin lab_broken (distribution lab-broken-plugin) is left out with
    the line naming ``why``: by `plugins --json` and by `new`, which still runs."""
    site = tmp_path / "site"
    (site / "lab_broken_plugin-1.0.dist-info").mkdir(parents=True)
    (site / "lab_broken_plugin.py").write_text(body)
    (site / "lab_broken_plugin-1.0.dist-info" / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: lab-broken-plugin\nVersion: 1.0\n")
    (site / "lab_broken_plugin-1.0.dist-info" / "entry_points.txt").write_text("[odsuite]\nlab_broken = lab_broken_plugin\n")
    env = {**os.environ, "PYTHONPATH": str(site), **env}
    line = f"note: plugin 'lab_broken' (distribution 'lab-broken-plugin') left out: it failed {why}\n"
    done = subprocess.run([sys.executable, "-m", "odsuite.cli", "plugins", "--json"], env=env, capture_output=True,
                          text=True, cwd=tmp_path)
    assert (done.returncode, done.stderr) == (0, line)
    doc = json.loads(done.stdout)
    assert doc["failed"] == {"lab_broken": line[len("note: "):].rstrip("\n")} and "models" in doc["plugins"]
    done = subprocess.run([sys.executable, "-m", "odsuite.cli", "new", "q.h5"], env=env, capture_output=True,
                          text=True, cwd=tmp_path)
    assert (done.returncode, done.stderr) == (0, line) and (tmp_path / "q.h5").is_file()


@pytest.mark.parametrize("body, why", [
    ("while True:\n    pass\n", "to load: PluginTimeout: still running after 2 s (the bound is ODSUITE_PLUGIN_TIMEOUT)"),
    ("import time\nwhile True:\n    try:\n        time.sleep(100)\n    except Exception:\n        pass\n",
     "to load: PluginTimeout: still running after 2 s (the bound is ODSUITE_PLUGIN_TIMEOUT)"),
    ("from odsuite import hookimpl\n@hookimpl\ndef odsuite_register_effects(registry):\n    while True:\n        pass\n",
     "in its hook odsuite_register_effects: PluginTimeout: still running after 2 s (the bound is ODSUITE_PLUGIN_TIMEOUT)"),
])
def test_endless_plugin_is_left_out_after_its_time_bound(tmp_path, body, why):
    """A plugin looping for ever at import or in its hook (even one swallowing the first
    interruption) is left out after ODSUITE_PLUGIN_TIMEOUT seconds, not a hang."""
    _left_out(tmp_path, body, why, {"ODSUITE_PLUGIN_TIMEOUT": "2"})


def test_plugin_time_bound_is_checked(tmp_path):
    done = subprocess.run([sys.executable, "-m", "odsuite.cli", "plugins"], capture_output=True, text=True,
                          env={**os.environ, "ODSUITE_PLUGIN_TIMEOUT": "-1"}, cwd=tmp_path)
    assert (done.returncode, done.stderr) == (1, "error: ODSUITE_PLUGIN_TIMEOUT: expected seconds from 0 (no bound) "
                                                 "to 3600, got '-1'\n")
