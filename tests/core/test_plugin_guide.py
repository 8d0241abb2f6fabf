"""docs/plugins.md: every example plugin of the guide runs as printed.

Each ```python block of the guide starts with ``# plugin: NAME``; it is run as a module, registered
next to the installed plugins and its provider is used with real numbers against independent
references (closed-form physics, scipy, the project's own readers).
"""

from __future__ import annotations

import json
import re
import sys
import types
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import scipy.signal

from odsuite import open_project
from odsuite.contracts import hookspecs
from odsuite.domain.errors import ConfigError
from odsuite.contracts.plugins import build_registries, make_plugin_manager

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "plugins.md"

#: example name -> the hook it implements
HOOKS = {"sensor": "odsuite_register_sensor_types", "effect": "odsuite_register_effects", "model": "odsuite_register_models",
         "step": "odsuite_register_processing_steps", "solver": "odsuite_register_coordinate_solvers",
         "renderer": "odsuite_register_renderers", "importer": "odsuite_register_importers",
         "daq": "odsuite_register_daq_backends", "rig": "odsuite_register_rigs",
         "command": "odsuite_register_commands"}


def _snippets() -> dict[str, str]:
    blocks = re.findall(r"^```python\n(.*?)^```", GUIDE.read_text(), flags=re.S | re.M)
    out = {}
    for code in blocks:
        marker = re.fullmatch(r"# plugin: (\w+)", code.splitlines()[0])
        assert marker, f"{GUIDE.name}: a python block without a '# plugin: NAME' first line: {code[:60]!r}"
        assert marker.group(1) not in out, f"{GUIDE.name}: two examples named {marker.group(1)!r}"
        out[marker.group(1)] = code
    return out


SNIPPETS = _snippets()


@pytest.fixture
def guide(monkeypatch):
    """``guide(*names)`` -> (modules, registries) with those examples registered as plugins."""

    def load(*names):
        modules = []
        for name in names:
            module = types.ModuleType(f"odsuite_guide_{name}")
            monkeypatch.setitem(sys.modules, module.__name__, module)
            exec(compile(SNIPPETS[name], f"{GUIDE}: example {name!r}", "exec"), module.__dict__)
            modules.append(module)
        pm = make_plugin_manager(load_entry_points=True, extra_plugins=tuple(modules))
        return (modules[0] if len(modules) == 1 else modules), build_registries(pm), pm

    return load


def test_one_example_per_hook_importing_only_odsuite():
    assert set(SNIPPETS) == set(HOOKS)
    declared = {n for n in vars(hookspecs) if n.startswith("odsuite_register_")}
    assert set(HOOKS.values()) == declared
    for name, code in SNIPPETS.items():
        assert f"def {HOOKS[name]}(" in code, name
        imported = re.findall(r"^(?:from|import) ([\w.]+)", code, flags=re.M)
        assert not [m for m in imported if m.startswith("odsuite_plugins")], name
    headings = re.findall(r"^## .*`(\w+)`$", GUIDE.read_text(), flags=re.M)
    assert sorted(headings) == sorted(declared)  # one section per hook


def _hit_project(path: Path, peak: float = 20.0, width: float = 0.5e-3, pretrigger: int = 256):
    """A project on the thesis rig with one record: a half-sine force of ``peak`` N starting at the
    pretrigger sample on the force channel (volts through the rig's Systeminfo), 0 V elsewhere."""
    from odsuite.contracts.daq import channel_name, rig_systeminfo
    from odsuite.store.project import Excitation, create_project

    fs, n = 20_000.0, 2048
    t = (np.arange(n) - pretrigger) / fs
    force = np.where((t >= 0) & (t <= width), peak * np.sin(np.pi * t / width), 0.0)
    with create_project(path) as project:
        rig = project.rig
        si = rig_systeminfo(rig, fs)
        fc = si.channels[rig.force_channel]
        volts = np.zeros((n, rig.channel_count))
        volts[:, rig.force_channel] = force * fc.sensitivity * fc.daq_gain * (-1.0 if fc.invert else 1.0)
        project.add_experiment("H1", volts, sampling_rate=fs, systeminfo=si, pretrigger=pretrigger,
                               excitation=Excitation(rig.force_channel, np.zeros(3), np.array([0.0, 0.0, 1.0])),
                               channel_names=[channel_name(rig, k) for k in range(rig.channel_count)])
    return force, t


def test_effect_scales_every_predicted_acceleration_by_the_gain(guide):
    module, regs, _ = guide("effect")
    assert regs.effects.entry("lab_amplifier_gain").plugin == module.__name__
    effect = regs.effects.get("lab_amplifier_gain")
    rig = regs.rigs.get("thesis-dynamometer")
    model = regs.models.get("thesis-dynamometer")(rig)
    from odsuite.domain.model import Input, Output

    force = Input.force([-0.8e-3, 4.1e-3, -11.4e-3], [0, 0, 1])  # T1: the top face's centre, +z
    outputs = [Output.sensor(s) for s in rig.sensors]
    f = np.linspace(50.0, 1500.0, 60)
    changed = effect.apply(model, {"gain": 1.25})
    # a chain effect: the structure (M, C, K, modes) is the same object, every sensor 1.25 x larger
    assert changed.structure is model.structure
    assert changed.transfer(force, outputs, f) == pytest.approx(1.25 * model.transfer(force, outputs, f), rel=1e-12)
    assert changed.parameters["lab_amplifier_gain"] == {"gain": 1.25}
    # the nominal changes nothing; a value out of bounds is one line naming effect and parameter
    assert effect.apply(model).transfer(force, outputs, f) == pytest.approx(model.transfer(force, outputs, f),
                                                                           rel=1e-15)
    with pytest.raises(ConfigError, match=r"effect 'lab_amplifier_gain' parameter 'gain': expected [0-9.e+-]+ to [0-9.e+-]+, got 3.0$"):
        effect.apply(model, {"gain": 3.0})
    # a model without rig sensors: the effect says it does not apply
    assert effect.parameters(regs.models.get("thesis-car-2dof")(None)) == []
    # its correction undoes it: the model's sensor signals with the gain, corrected, are the
    # signals without it (the force channel untouched)
    from odsuite.analysis.correction import MeasurementCorrection, undo_measurement
    from odsuite.contracts.effects import corrects

    assert corrects(effect)
    t = np.arange(2048) / 20_000.0
    q = np.column_stack([np.sin(2 * np.pi * f0 * t) * np.exp(-t / 0.02) for f0 in (97, 104, 217, 98, 222, 227)])
    accs = [Output.sensor(s) for s in rig.accelerometers]
    recorded = q @ changed.output_rows(accs)[1].T
    undone = undo_measurement(rig, [s.name for s in rig.accelerometers], recorded, 20_000.0,
                              [MeasurementCorrection("lab_amplifier_gain", effect, {"gain": 1.25}, {}, model)],
                              regs.coordinate_solvers)
    assert undone == pytest.approx(q @ model.output_rows(accs)[1].T, rel=1e-13, abs=1e-15)
    _, kept = effect.correct(rig, {"force": t, rig.accelerometers[0].name: t}, 20_000.0, {"gain": 1.25})
    assert kept["force"] is t and kept[rig.accelerometers[0].name] == pytest.approx(t / 1.25, rel=1e-15)


def test_model_modes_match_the_closed_form(guide):
    """Mounts in the plane of the centre of mass, symmetric, diagonal inertia: the six motions
    decouple, omega^2 = 4 k / m (x, y, z), 4 k_z b^2 / Ixx, 4 k_z a^2 / Iyy, 4 k_t (a^2 + b^2) / Izz;
    damping c = beta k gives zeta = beta omega / 2 for every mode."""
    module, regs, _ = guide("model")
    factory = regs.models.get("lab-block-on-mounts")
    model = factory(None)
    L, W, H = 0.100, 0.150, 0.020
    m = 7850.0 * L * W * H
    Ixx, Iyy, Izz = m / 12 * (W**2 + H**2), m / 12 * (L**2 + H**2), m / 12 * (L**2 + W**2)
    a, b, kt, kz, beta = 0.4 * L, 0.4 * W, 2.0e5, 1.0e6, 1.0e-4
    omega = np.sqrt([4 * kt / m, 4 * kt / m, 4 * kz / m, 4 * kz * b**2 / Ixx, 4 * kz * a**2 / Iyy,
                     4 * kt * (a**2 + b**2) / Izz])
    modes = model.modes()
    assert model.bodies[0].mass == pytest.approx(m, rel=1e-12)
    assert modes.frequency_hz == pytest.approx(np.sort(omega) / (2 * np.pi), rel=1e-9)
    assert modes.damping_ratio == pytest.approx(beta * np.sort(omega) / 2, rel=1e-9)
    # on the thesis rig: its platform (products of inertia couple the motions); proportional
    # damping keeps the undamped frequencies, which scipy's generalized eigensolver gives
    rig = regs.rigs.get("thesis-dynamometer")
    on_rig = factory(rig)
    assert on_rig.bodies[0].mass == rig.body("platform").mass
    w = np.sqrt(scipy.linalg.eigh(on_rig.K, on_rig.M, eigvals_only=True))
    assert on_rig.modes().frequency_hz == pytest.approx(w / (2 * np.pi), rel=1e-9)
    assert on_rig.modes().damping_ratio == pytest.approx(beta * w / 2, rel=1e-9)


def test_step_streams_what_its_linear_form_and_scipy_say(guide):
    from odsuite.processing.chain_spec import build_chain
    from odsuite.processing.executor import run_array

    module, regs, _ = guide("step")
    fs, fc = 20_000.0, 5.0
    rng = np.random.default_rng(7)
    x = 0.3 + rng.standard_normal(5000)
    chain = build_chain([{"step": "lab-dc-block", "cutoff_hz": fc}], fs=fs, registry=regs.processing_steps)
    streamed = run_array([chain], x[:, None], chunk=257)[0]["output"]  # chunks that cut the record oddly
    r = np.exp(-2 * np.pi * fc / fs)
    reference = scipy.signal.lfilter([1.0, -1.0], [1.0, -r], x)
    assert streamed == pytest.approx(reference, rel=1e-12, abs=1e-12)
    (op,) = regs.processing_steps.get("lab-dc-block").linear_form(fs=fs, cutoff_hz=fc)
    assert scipy.signal.sosfilt(op.sos, x) == pytest.approx(streamed, rel=1e-12, abs=1e-12)
    # physics: -3 dB at the cut-off, a constant decays as r^n
    (h,) = scipy.signal.freqz_sos(op.sos, worN=[fc], fs=fs)[1]
    assert abs(h) == pytest.approx(1 / np.sqrt(2), rel=1e-3)
    assert chain.run(np.ones(100))["output"] == pytest.approx(r ** np.arange(100), rel=1e-12)
    with pytest.raises(ConfigError, match=r"'lab-dc-block' parameter 'cutoff_hz': must lie in \(0, 10000\) Hz, got 2"):
        build_chain([{"step": "lab-dc-block", "cutoff_hz": 20000.0}], fs=fs, registry=regs.processing_steps)


def _three_point_rig(points, solver=None):
    from odsuite.domain.rig import rig_from_dict

    sensors = [{"name": f"p{i}{a}", "channel": 3 * i + k + 1, "body": "table", "position": list(p),
                "axis": [float(a == "x"), float(a == "y"), float(a == "z")]}
               for i, p in enumerate(points) for k, a in enumerate("xyz")]
    body = {"name": "table", "com": [0.003, -0.002, 0.001], "mass": 2.0, "inertia": np.diag([0.01] * 3).tolist(),
            **({"solver": solver} if solver else {})}
    from odsuite.contracts.plugins import registries

    return rig_from_dict({"name": "three-points", "bodies": [body], "sensors": sensors, "force_channel": 0},
                         registries().sensor_types)


def test_solver_recovers_a_rigid_motion(guide):
    """Readings of a known small rigid motion, s = a . (t + Theta x (p - G)) (closed form), give it back."""
    from odsuite.contracts.solvers import choose_solver

    module, regs, _ = guide("solver")
    solvers = regs.coordinate_solvers
    solver = solvers.get("lab-triaxial")
    rig = _three_point_rig([(-0.04, -0.06, -0.01), (0.04, -0.06, -0.01), (-0.04, 0.06, -0.01)])
    body = rig.body("table")
    t = np.linspace(0.0, 0.04, 300)
    d = np.stack([amp * np.sin(2 * np.pi * f * t + ph) for amp, f, ph in
                  zip((3e-6, -2e-6, 5e-6, 6e-5, -4e-5, 2e-5), (80, 95, 120, 140, 165, 210), (0, 1, 2, 3, 4, 5))],
                 axis=1)
    signals = {s.name: d[:, :3] @ s.axis + np.cross(d[:, 3:], s.position - body.com) @ s.axis for s in rig.sensors}
    res = solver.solve(rig, body, signals)
    assert res.at_g == pytest.approx(d, abs=1e-12 * np.abs(d).max())
    names = [s.name for s in rig.sensors]
    # unnamed, the built-in least squares (suitability 1 > 0.5) runs; named, the lab's
    assert choose_solver(rig, body, names, solvers).name == "least-squares"
    named = _three_point_rig([(-0.04, -0.06, -0.01), (0.04, -0.06, -0.01), (-0.04, 0.06, -0.01)], "lab-triaxial")
    assert choose_solver(named, named.body("table"), names, solvers).solver is solver
    # three points on one line cannot give the rotation about that line: one line naming rig and body
    line = _three_point_rig([(-0.04, 0.0, -0.01), (0.0, 0.0, -0.01), (0.04, 0.0, -0.01)], "lab-triaxial")
    assert solver.suitability(line, line.body("table"), names) is None
    with pytest.raises(ConfigError, match=r"rig 'three-points'.*body 'table'.*'lab-triaxial' cannot solve"):
        choose_solver(line, line.body("table"), names, solvers)


def test_renderer_draws_the_force_and_reports_its_peak(guide, tmp_path):
    from odsuite.contracts.renderers import RenderRequest, choose_renderer

    module, regs, _ = guide("renderer")
    force, t = _hit_project(tmp_path / "p.h5", peak=20.0, width=0.5e-3)
    out = tmp_path / "H1-force.png"
    renderer = choose_renderer(regs.renderers, out, "lab-force-plot", "figure")
    done = renderer.render(RenderRequest(tmp_path / "p.h5", "H1", out, {}))
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 10_000
    # the 20 N half-sine of 0.5 ms peaks 0.25 ms (5 samples) after its start at the trigger
    peak, at_ms = re.fullmatch(r"peak (\S+) N at (\S+) ms", done.summary).groups()
    assert float(peak) == pytest.approx(20.0, rel=1e-6) and float(at_ms) == pytest.approx(0.25, abs=1e-9)
    with pytest.raises(ConfigError, match="renderer 'lab-force-plot' does not take option"):
        renderer.render(RenderRequest(tmp_path / "p.h5", "H1", out, {"magnify": (10.0, 10.0)}))
    with pytest.raises(ConfigError, match=r"writes \.png, \.svg, \.pdf files"):
        choose_renderer(regs.renderers, tmp_path / "x.mp4", "lab-force-plot", "figure")


def test_importer_stores_the_file_it_reads(guide, tmp_path):
    from odsuite.contracts.importers import check_options, choose_importer
    from odsuite.store.project import create_project

    module, regs, _ = guide("importer")
    fs, n = 10_000.0, 1500
    t = np.arange(n) / fs
    force = np.where(t < 1e-3, 50.0 * np.sin(np.pi * t / 1e-3), 0.0)  # N
    acc = np.stack([3.0 * np.sin(2 * np.pi * 120 * t), -1.5 * np.cos(2 * np.pi * 310 * t)], axis=1)  # m/s^2
    record = tmp_path / "run3.npz"
    np.savez(record, data=np.column_stack([force, acc]), fs_hz=fs, names=["hammer", "a1", "a2"],
             units=["N", "m/s^2", "m/s^2"], force_point_m=[0.01, 0.02, 0.0], force_direction=[0.0, 0.0, -1.0])
    create_project(tmp_path / "bench.h5", None).close()
    importer = choose_importer(regs.importers, record)  # by the suffix
    assert importer.name == "lab-npz"
    done = importer.import_file(tmp_path / "bench.h5", record, "run3", **check_options(importer, {}))
    assert done.summary == "1500 samples x 3 channels at 10000 Hz"
    with open_project(tmp_path / "bench.h5") as p:
        exp = p.experiment("run3")
        stored = exp.raw()
        assert exp.sampling_rate == fs and exp.channel_names == ["hammer", "a1", "a2"]
        assert exp.excitation.force_channel == 0
        assert exp.excitation.point == pytest.approx([0.01, 0.02, 0.0])
        assert exp.excitation.direction == pytest.approx([0.0, 0.0, -1.0])
        assert [c.unit for c in exp.systeminfo.channels] == ["N", "m/s^2", "m/s^2"]
        assert [c.sensitivity for c in exp.systeminfo.channels] == [1.0, 1.0, 1.0]
        assert p.info()["experiments"]["run3"]["clipped"] == []
    assert np.array_equal(stored, np.column_stack([force, acc]))
    # a file without its sampling rate: one line naming file and field, project unchanged
    bad = tmp_path / "bad.npz"
    np.savez(bad, data=np.zeros((10, 1)), names=["f"], units=["N"], force_point_m=[0, 0, 0], force_direction=[0, 0, 1])
    before = (tmp_path / "bench.h5").read_bytes()
    with pytest.raises(ConfigError, match=r"bad\.npz: missing field\(s\) fs_hz"):
        importer.import_file(tmp_path / "bench.h5", bad, "bad")
    assert (tmp_path / "bench.h5").read_bytes() == before


def test_daq_backend_records_into_a_project_with_its_options(guide, tmp_path):
    from odsuite.processing.acquisition import acquire
    from odsuite.contracts.daq import AcquisitionSettings, parse_backend_options
    from odsuite.store.project import create_project

    module, regs, _ = guide("daq")
    backend = regs.daq_backends.get("lab-pulse")
    options = parse_backend_options("lab-pulse", backend, ["--peak", "35", "--width-ms=0.8", "--hum"])
    assert options == {"peak": 35.0, "width_ms": 0.8, "hum": True}
    with pytest.raises(ConfigError, match=r"'lab-pulse' does not take '--seed' \(its options: --hum, --peak, --width-ms\)"):
        parse_backend_options("lab-pulse", backend, ["--seed", "3"])
    fs, n, pre, level = 20_000.0, 2048, 256, 1.0
    settings = AcquisitionSettings(sampling_rate=fs, n_samples=n, pretrigger=pre, trigger_level=level)
    stages = []
    with create_project(tmp_path / "p.h5") as project:
        exp, rec = acquire(project, backend, "P1", settings, progress=lambda *a: stages.append(a), **options)
        raw = exp.raw()
        si, rig = exp.systeminfo, project.rig
    assert stages[0] == ("waiting for trigger", 0, n) and stages[-1] == ("reading", n, n)
    # closed form: 35 N half-sine of 0.8 ms crossing 1 N at the trigger sample, plus 1 mV of 50 Hz
    t = (np.arange(n) - pre) / fs
    start = -0.8e-3 / np.pi * np.arcsin(level / 35.0)
    pulse = np.where((t >= start) & (t <= start + 0.8e-3), 35.0 * np.sin(np.pi * (t - start) / 0.8e-3), 0.0)
    hum = 1e-3 * np.sin(2 * np.pi * 50.0 * t)
    fc = si.channels[rig.force_channel]
    assert raw[:, rig.force_channel] == pytest.approx(pulse * fc.sensitivity * fc.daq_gain + hum, abs=1e-12)
    assert raw[:, 3] == pytest.approx(hum, abs=1e-15)
    newtons = (raw[:, rig.force_channel] - hum) / (fc.sensitivity * fc.daq_gain)
    assert newtons[pre] == pytest.approx(level, rel=1e-9) and newtons[pre - 1] < level
    assert newtons.max() == pytest.approx(35.0, rel=2e-3)  # the crest lies between two samples
    assert exp.pretrigger == pre and exp.source == "lab-pulse peak=35 N width=0.8 ms hum=True"


def test_rig_is_registered_and_loads_into_a_project(guide, tmp_path):
    from odsuite.store.project import create_project
    from odsuite.contracts.solvers import body_solvers

    (rig_module, model_module), regs, _ = guide("rig", "model")
    assert regs.rigs.entry("lab-table").plugin == rig_module.__name__
    rig = regs.rigs.get("lab-table")
    with create_project(tmp_path / "t.h5", rig):
        pass
    with open_project(tmp_path / "t.h5") as p:
        stored = p.rig
    assert stored.name == "lab-table" and [s.name for s in stored.sensors] == [s.name for s in rig.sensors]
    assert np.array([s.position for s in stored.sensors]) == pytest.approx(np.array([s.position for s in rig.sensors]))
    table = stored.body("table")
    # the box formula for the steel plate: m = rho L W H, I = m / 12 (W^2 + H^2, ...)
    L, W, H = table.plate.size
    m = 7850.0 * L * W * H
    assert table.mass == pytest.approx(m, rel=1e-12)
    assert np.diag(table.inertia) == pytest.approx(m / 12 * np.array([W**2 + H**2, L**2 + H**2, L**2 + W**2]),
                                                   rel=1e-12)
    chosen, notes = body_solvers(stored, [s.name for s in stored.sensors], regs.coordinate_solvers)
    assert [(c.body.name, c.name) for c in chosen] == [("table", "least-squares")] and notes == []
    model = regs.models.get(stored.default_model)(stored)
    assert model.bodies[0].mass == table.mass and len(model.modes()) == 6


def test_command_is_added_and_runs(guide, tmp_path, monkeypatch, capsys, request):
    from odsuite import cli
    from odsuite.contracts import plugins

    module, regs, pm = guide("command")
    _hit_project(tmp_path / "p.h5", peak=20.0)
    # the command line's own path: its plugin manager adds the commands to its typer app (a copy
    # of the command list, restored afterwards, as is the manager)
    monkeypatch.setattr(plugins, "default_manager", lambda: pm)
    monkeypatch.setattr(cli.app, "registered_commands", list(cli.app.registered_commands))
    request.addfinalizer(lambda: (monkeypatch.undo(), plugins.reset_default()))  # forget what `pm` cached
    assert cli.main(["lab-headroom", str(tmp_path / "p.h5"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    with open_project(tmp_path / "p.h5") as p:
        info = p.info()["experiments"]["H1"]  # odsuite's own peak per channel, in SI
        chains = dict(zip(p.experiment("H1").channel_names, p.experiment("H1").systeminfo.channels))
        limits = {n: (c.limit_low, c.limit_high) for n, c in chains.items()}
    assert set(doc["H1"]) == set(info["peak"])
    for channel, row in doc["H1"].items():  # volts at the converter: through the sensitivity and the gain
        volts = info["peak"][channel][0] * abs(chains[channel].sensitivity * chains[channel].daq_gain)
        assert row["peak_v"] == pytest.approx(volts, rel=1e-12)
    # the 20 N hit through the load cell's V/N and the DAQ gain, against the +5 V limit
    low, high = limits["force"]
    assert doc["H1"]["force"]["of_range"] == pytest.approx(doc["H1"]["force"]["peak_v"] / high, rel=1e-12)
    assert cli.main(["lab-headroom", str(tmp_path / "p.h5")]) == 0
    assert "H1: closest to its range: force" in capsys.readouterr().out
    assert cli.main(["lab-headroom", str(tmp_path / "missing.h5")]) == 1  # one line, exit 1


def test_sensor_type_example_reads_its_rig_entries(guide):
    """The two axes land on their channels at the entry's point; a bad entry (dependent axes, an
    axis that is not a unit vector) is one line naming the entry and field."""
    from odsuite.domain.rig import rig_from_dict

    _, regs, _ = guide("sensor")
    data = {"name": "bench", "bodies": [{"name": "plate", "mass": 1.0, "inertia": np.eye(3).tolist()}],
            "sensors": [{"name": "b1", "kind": "lab_biaxial", "body": "plate", "position": [0.1, 0.0, 0.0],
                         "channels": [4, 5], "axes": [[1, 0, 0], [0, 0, 1]], "sensitivity": 0.01}]}
    rig = rig_from_dict(data, regs.sensor_types)
    assert [(s.name, s.channel, s.group) for s in rig.sensors] == [("b1_1", 4, "b1"), ("b1_2", 5, "b1")]
    assert np.allclose([s.axis for s in rig.sensors], [[1, 0, 0], [0, 0, 1]])
    assert all(np.allclose(s.position, [0.1, 0, 0]) and s.sensitivity == 0.01 for s in rig.sensors)
    data["sensors"][0]["axes"] = [[1, 0, 0], [1, 0.1, 0]]
    with pytest.raises(ConfigError) as err:
        rig_from_dict(data, regs.sensor_types)
    assert "sensors[0] 'b1'" in str(err.value) and "field 'axes'" in str(err.value) and "\n" not in str(err.value)
    data["sensors"][0]["axes"] = [[2, 0, 0], [0, 0, 1]]
    with pytest.raises(ConfigError) as err:
        rig_from_dict(data, regs.sensor_types)
    assert "sensors[0] 'b1'" in str(err.value) and "expected a unit vector" in str(err.value)


def test_a_plugin_passed_as_registries_runs_diagnose_render_and_import(guide, tmp_path, monkeypatch):
    """The guide's route for testing a plugin without installing it: registries built with
    ``make_plugin_manager(extra_plugins=...)`` given to ``open_project``/``create_project`` and to
    a render request. No engine reads the installed plugins' registries on the way (they would
    raise here), and nothing is monkeypatched into odsuite."""
    import odsuite.contracts.plugins as plugins
    from hidden_effects import make_project

    from odsuite.contracts.renderers import RenderRequest
    from odsuite.diagnosis.diagnose import diagnose
    from odsuite.store.project import create_project

    (effect_module, renderer_module, importer_module), regs, _ = guide("effect", "renderer", "importer")
    source = make_project(tmp_path / "sim.h5", scenarios=("T1",), n_samples=2048)
    with open_project(source) as p:
        exp = p.experiment("T1")
        raw, si, rig = exp.raw(), exp.systeminfo, p.rig
        excitation, fs, pre = exp.excitation, exp.sampling_rate, exp.pretrigger
    gained = raw.copy()
    accelerometers = [s.channel for s in rig.accelerometers]
    gained[:, accelerometers] *= 1.25  # an amplifier 25 % hot on every accelerometer

    def installed_registries(*args, **kwargs):
        raise AssertionError("an engine read the installed plugins' registries")

    monkeypatch.setattr(plugins, "registries", installed_registries)
    path = tmp_path / "p.h5"
    with create_project(path, rig, registries=regs) as p:
        p.add_experiment("T1", gained, sampling_rate=fs, systeminfo=si, excitation=excitation, pretrigger=pre)
    with open_project(path, registries=regs) as p:
        found = diagnose(p, effects=["lab_amplifier_gain", "stiffness"], workers=1)
    top = found.candidates[0]
    assert top.effect == "lab_amplifier_gain" and top.significant
    assert top.parameters["gain"] == pytest.approx(1.25, rel=2e-3)
    out = tmp_path / "T1-force.png"
    done = regs.renderers.get("lab-force-plot").render(RenderRequest(path, "T1", out, {}, registries=regs))
    assert out.stat().st_size > 10_000 and done.summary.startswith("peak ")
    record = tmp_path / "run3.npz"
    np.savez(record, data=np.ones((100, 2)), fs_hz=1000.0, names=["hammer", "a1"], units=["N", "m/s^2"],
             force_point_m=[0.0, 0.0, 0.0], force_direction=[0.0, 0.0, 1.0])
    create_project(tmp_path / "bench.h5", None, registries=regs).close()
    assert regs.importers.get("lab-npz").import_file(tmp_path / "bench.h5", record, "run3").experiment == "run3"
