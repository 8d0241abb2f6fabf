"""Operating records of the simulated rig (a running machine or a moving ground, no force channel
stored) through the command line: output-only modes against the model's, the ODS against the
model's mode shapes and its forced response, operating files imported, bad operating options
refused in one line."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from odsuite.cli import main
from odsuite.analysis.modal import mac
from odsuite.domain.model import Input, Output
from odsuite.contracts.plugins import registries
from odsuite.store.project import open_project
from odsuite.domain.systeminfo import SensorType

RIGS = Path(__file__).resolve().parents[3] / "plugins" / "models" / "rigs"
CORNER = "35.7,76.4,-11.4"  # mm: near the top face's far corner, so that every rigid-body mode takes part


def _json(capsys, args):
    capsys.readouterr()
    assert main(args) == 0
    return json.loads(capsys.readouterr().out)


def _model_modes(project):
    """The model's poles and its mode shapes at the rig's accelerometers (C of the acceleration
    outputs times the state eigenvectors), ascending, straight from the state-space matrices."""
    with open_project(project) as p:
        rig = p.rig
    model = registries().models.get(rig.default_model)(rig)
    ss = model.state_space([Input.force(np.zeros(3), np.array([0.0, 0.0, 1.0]), body=rig.bodies[0].name)],
                           [Output.sensor(s) for s in rig.accelerometers])
    lam, psi = np.linalg.eig(ss.A)
    keep = lam.imag > 0
    order = np.argsort(np.abs(lam[keep]))
    return lam[keep][order], (ss.C @ psi[:, keep])[:, order], [s.name for s in rig.accelerometers], model, rig


@pytest.fixture(scope="module")
def light_rig(tmp_path_factory):
    """The thesis rig with a tenth of its isolators' damping (modes at 1.4-1.7 % instead of
    15-17 %): see test_six_modes_from_operating_data_alone for why."""
    d = tmp_path_factory.mktemp("light")
    text = (RIGS / "thesis-dynamometer.toml").read_text()
    light = re.sub(r"damping = \[140\.0, 125\.0, 275\.0\]", "damping = [14.0, 12.5, 27.5]", text)
    assert light.count("[14.0, 12.5, 27.5]") == 4
    (d / "light.toml").write_text(light.replace('name = "thesis-dynamometer"', 'name = "thesis-light"', 1))
    (d / "thesis-table-e3.CTR").write_bytes((RIGS / "thesis-table-e3.CTR").read_bytes())
    p = d / "run.h5"
    assert main(["new", str(p), "--rig", str(d / "light.toml")]) == 0
    assert main(["acquire", str(p), "--name", "run", "--rate", "1000", "--samples", "150000",
                 f"--force-point={CORNER}", "--force-dir=1,1,0.3", "--operating", "random", "--force-rms", "0.5",
                 "--seed", "3"]) == 0
    return p


def test_six_modes_from_operating_data_alone(light_rig, capsys):
    """150 s of a random force at a corner, responses only: SSI-cov finds the model's six modes
    within 1 % (measured: 0.1 %). On the thesis rig as modelled (isolator damping 15-17 %, three
    modes within 6 % of each other) no output-only method separates them from one record: its
    exact output covariances give a block Hankel matrix whose 12th singular value is 4e-4 of the
    first, below the estimation error of any record of practical length (docs/operating.md)."""
    with open_project(light_rig) as p:
        exp = p.experiment("run")
        assert exp.excitation is None  # no force stored
        assert SensorType.LOADCELL not in [c.sensor_type for c in exp.systeminfo.channels]
        assert "operating=random" in p.info()["experiments"]["run"]["source"]
    lam, *_ = _model_modes(light_rig)
    model = _json(capsys, ["model", str(light_rig), "--json"])
    want = np.array([m["frequency_hz"] for m in model["modes"]])
    np.testing.assert_allclose(want, np.abs(lam) / (2 * np.pi), rtol=1e-9)
    doc = _json(capsys, ["modes", str(light_rig), "--experiment", "run", "--output-only", "--json"])
    assert doc["output_only"] is True
    got = np.array([m["frequency_hz"] for m in doc["modes"]])
    assert got.size == 6, got
    np.testing.assert_allclose(got, want, rtol=0.01)
    zeta = np.array([m["damping_ratio"] for m in doc["modes"]])
    np.testing.assert_allclose(zeta, -lam.real / np.abs(lam), rtol=0.25)
    # the shapes (unscaled, at the responses) are the model's
    names = list(doc["modes"][0]["shape"])
    _, shapes, sensors, *_ = _model_modes(light_rig)
    assert names == sensors
    measured = np.array([[complex(*m["shape"][n]) for n in names] for m in doc["modes"]]).T
    assert np.diag(mac(measured, shapes)).min() > 0.9


@pytest.fixture(scope="module")
def thesis_heave(tmp_path_factory):
    """The thesis rig as modelled, driven by a random vertical force at the top face's centre."""
    p = tmp_path_factory.mktemp("heave") / "run.h5"
    assert main(["new", str(p)]) == 0
    assert main(["acquire", str(p), "--name", "z", "--rate", "1000", "--samples", "60000",
                 "--force-point=-0.795,4.124,-11.4", "--force-dir=+z", "--operating", "random", "--seed", "2"]) == 0
    return p


def test_ods_at_a_mode_is_the_models_mode_shape(thesis_heave, capsys):
    """A vertical force at the centre drives the heave mode (216.9 Hz) and hardly any other: the
    ODS there is the model's mode shape (MAC >= 0.95) and unlike the other five."""
    lam, shapes, names, _, rig = _model_modes(thesis_heave)
    f = float(np.abs(lam[3]) / (2 * np.pi))
    doc = _json(capsys, ["ods", str(thesis_heave), "z", "--reference", "zC", "--at", f"{f:.3f}", "--json"])
    assert doc["reference"] == "zC" and abs(doc["frequency_hz"] - f) <= doc["resolution_hz"] / 2
    assert set(doc) >= {"frequency_hz", "reference", "shape", "coordinates"}
    assert doc["shape"]["zC"][1] == pytest.approx(0.0, abs=1e-12)  # the reference's own phase is 0
    shape = np.array([complex(*doc["shape"][n]) for n in names])
    m = mac(shape[:, None], shapes)[0]
    assert m[3] >= 0.95, m
    assert np.delete(m, 3).max() < 0.3, m
    # heave: z at G dominates the platform's coordinates (m), the rotations (rad) times a 50 mm arm small
    z = {c: complex(*v) for c, v in doc["coordinates"]["platform"].items()}
    assert abs(z["z"]) > 5 * max(abs(z["x"]), abs(z["y"]), 0.05 * abs(z["theta"]), 0.05 * abs(z["phi"]))
    assert doc["units"]["zC"] == "m/s^2"


def test_unbalance_ods_is_the_models_forced_response(tmp_path, capsys):
    """An unbalanced rotor (axis +z at the corner, 150 Hz): the ODS at the rotor speed equals the
    model's response to the rotating force, C (i w - A)^-1 B + D for the two in-plane forces a
    quarter period apart, relative to the reference sensor (each sensor within 3 %)."""
    p = tmp_path / "u.h5"
    assert main(["new", str(p)]) == 0
    assert main(["acquire", str(p), "--name", "u", "--rate", "1000", "--samples", "20000",
                 f"--force-point={CORNER}", "--force-dir=+z", "--operating", "unbalance:150", "--seed", "4"]) == 0
    doc = _json(capsys, ["ods", str(p), "u", "--reference", "x1", "--at", "150", "--json"])
    _, _, names, model, rig = _model_modes(p)
    point = np.array([float(v) for v in CORNER.split(",")]) * 1e-3
    body = rig.force_body(point)
    # the simulator's rotor: u, v complete the axis +z to a right-handed frame
    from odsuite_plugins.daq_sim.operating import perpendicular_axes

    u, v = perpendicular_axes(np.array([0.0, 0.0, 1.0]))
    ss = model.state_space([Input.force(point, u, body=body), Input.force(point, v, body=body)],
                           [Output.sensor(s) for s in rig.accelerometers])
    w = 2 * np.pi * doc["frequency_hz"]
    H = ss.C @ np.linalg.solve(1j * w * np.eye(len(ss.A)) - ss.A, ss.B) + ss.D
    # cos(wt) along u and sin(wt) = cos(wt - 90 deg) along v
    expected = H @ np.array([1.0, -1j])
    measured = np.array([complex(*doc["shape"][n]) for n in names])
    ref = names.index("x1")
    np.testing.assert_allclose(measured / measured[ref], expected / expected[ref], rtol=0.03, atol=0.01)
    assert min(doc["coherence"].values()) > 0.99  # a tone: every response moves with the reference


def test_operating_records_are_refused_where_a_force_is_needed(thesis_heave, capsys):
    capsys.readouterr()
    assert main(["frf", str(thesis_heave), "--experiment", "z"]) == 1
    assert "has no force channel" in capsys.readouterr().err


@pytest.mark.parametrize("args, words", [
    (["--operating", "hum"], "--operating: expected random, sweep, unbalance:HZ or base-random, got 'hum'"),
    (["--operating", "unbalance:0"], "the speed must lie between 0 and the Nyquist frequency 500 Hz"),
    (["--operating", "unbalance:fast"], "HZ must be the rotor's speed in Hz, got 'fast'"),
    (["--operating", "random:3"], "--operating random: takes no value"),
    (["--force-rms", "2"], "--force-rms sets an operating load: give --operating too"),
    (["--operating", "random", "--force-rms", "-1"], "--force-rms: an operating load's rms force, 0.001 to 1e+06 N, "
                                                     "got -1.0"),
    # 1e300 N was recorded with every accelerometer clipped; 1e-300 N as ADC noise alone
    (["--operating", "random", "--force-rms", "1e300"], "--force-rms: an operating load's rms force, 0.001 to 1e+06 N, "
                                                        "got 1e+300"),
    (["--operating", "unbalance:50", "--force-rms", "1e-300"], "--force-rms: an operating load's rms force, 0.001 to "
                                                               "1e+06 N, got 1e-300"),
    (["--operating", "sweep", "--force-peak", "3"], "drop the hammer's hits, --force-peak and --contact-ms"),
    (["--operating", "base-random", "--force-rms", "1"], "the ground moves, no force acts; drop --force-rms"),
    (["--operating", "base-random", "--force-point=0,0,0", "--force-dir=+z"], "drop --force-rms, --force-point"),
    (["--operating", "base-random:3"], "--operating base-random: takes no value"),
    (["--operating", "random", "--base-rms", "1"], "--base-rms sets the ground's motion: give --operating base-random"),
    (["--operating", "base-random", "--base-rms", "-1"], "--base-rms: must be > 0 and at most 10000 m/s^2, got -1.0"),
    # every sample of a 1e300 m/s^2 ground motion clipped, and the record was stored
    (["--operating", "base-random", "--base-rms", "1e300"], "--base-rms: must be > 0 and at most 10000 m/s^2, got 1e+300"),
])
def test_bad_operating_options_are_one_line(tmp_path, capsys, args, words):
    p = tmp_path / "p.h5"
    assert main(["new", str(p)]) == 0
    capsys.readouterr()
    assert main(["acquire", str(p), "--name", "r", "--rate", "1000", "--samples", "2000", *args]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and words in err, err
    with open_project(p) as proj:
        assert proj.experiment_names() == []


def test_sweep_covers_the_band(tmp_path, capsys):
    """A linear sweep from 0.5 Hz to 400 Hz at 1 kHz: the response's spectrum holds both rig
    mode groups, and the record has no force channel."""
    import scipy.signal

    from odsuite.analysis.modal_project import physical, response_columns

    p = tmp_path / "s.h5"
    assert main(["new", str(p)]) == 0
    assert main(["acquire", str(p), "--name", "s", "--rate", "1000", "--samples", "20000", f"--force-point={CORNER}",
                 "--force-dir=1,1,1", "--operating", "sweep"]) == 0
    with open_project(p) as proj:
        exp = proj.experiment("s")
        assert exp.excitation is None and "ai0" in exp.channel_names and "force" not in exp.channel_names
        y = physical(exp)[:, response_columns(exp)]
    f, psd = scipy.signal.welch(y, 1000.0, nperseg=1024, axis=0)
    total = psd.sum(axis=1)
    # the sweep's band carries the response; above its 400 Hz top only the filters' tails remain
    assert total[(f > 80) & (f < 250)].mean() > 100 * total[f > 450].mean()


def test_operating_files_import_without_a_force(real_data, tmp_path, capsys):
    """pyuff's four-channel ambient acceleration file has no force: stored as an operating record
    with a note; naming one of its accelerations as the force is refused."""
    src = real_data / "pyuff_uff_samples" / "mpstd_set001_58b_4ch_accel.uff"
    p = tmp_path / "a.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    capsys.readouterr()
    assert main(["import", str(p), str(src), "--name", "amb"]) == 0
    assert "stored as an operating record" in capsys.readouterr().err
    with open_project(p) as proj:
        exp = proj.experiment("amb")
        assert exp.excitation is None
        assert [c.sensor_type for c in exp.systeminfo.channels] == [SensorType.ACCELEROMETER] * 4
    assert main(["import", str(p), str(src), "--name", "bad", "--force-channel", "MPS set1 Dof2"]) == 1
    err = capsys.readouterr().err.strip()
    assert err.endswith("--force-channel 'MPS set1 Dof2' is in 'm/s2', a response, not a force"), err
    with open_project(p) as proj:
        assert proj.experiment_names() == ["amb"]


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_six_modes_from_base_motion_alone(tmp_path, capsys, seed):
    """The thesis rig as modelled (15-17 % damping, 97.4 and 98.3 Hz 1 % apart) on a ground moving
    in all six directions, 10 min at 1 kHz, responses only: `modes --output-only` reports six modes,
    each within 1 % of the model's undamped natural frequency (measured: within 0.3 %, per seed in
    docs/operating.md), and the ODS at the 227.45 Hz mode against a y sensor is the model's mode
    shape (MAC >= 0.95). With one random force no record of practical length separates them."""
    p = tmp_path / "b.h5"
    assert main(["new", str(p), "--rig", "thesis-dynamometer"]) == 0
    capsys.readouterr()
    assert main(["acquire", str(p), "--daq", "sim", "--name", "b", "--rate", "1000", "--samples", "600000",
                 "--operating", "base-random", "--seed", str(seed)]) == 0
    assert "clipped" not in capsys.readouterr().err  # docs/operating.md: no sample is clipped
    lam, shapes, names, _, _ = _model_modes(p)
    want = np.abs(lam) / (2 * np.pi)
    model = _json(capsys, ["model", str(p), "--json"])
    np.testing.assert_allclose([m["frequency_hz"] for m in model["modes"]], want, rtol=1e-9)
    doc = _json(capsys, ["modes", str(p), "--experiment", "b", "--output-only", "--json"])
    assert doc["output_only"] is True
    got = np.array([m["frequency_hz"] for m in doc["modes"]])
    assert got.size == 6, (got, doc["unresolved"])
    np.testing.assert_allclose(got, want, rtol=0.01)
    ods = _json(capsys, ["ods", str(p), "b", "--reference", "y3", "--at", f"{want[5]:.3f}", "--json"])
    shape = np.array([complex(*ods["shape"][n]) for n in names])
    assert mac(shape[:, None], shapes[:, 5:6])[0, 0] >= 0.95


@pytest.mark.slow
@pytest.mark.render
def test_ods_movie(thesis_heave, tmp_path, capsys):
    out = tmp_path / "ods.gif"
    assert main(["ods", str(thesis_heave), "z", "--reference", "zC", "--at", "216.9", "--movie", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out and out.read_bytes()[:6] == b"GIF89a"


def _acquire_on_two_body_rig_with(tmp_path, capsys, old: str, new: str, samples: str) -> tuple[Path, str]:
    """A project on the two-body rig file with ``old`` replaced by ``new``, and the standard error of
    an acquisition of ``samples`` samples into it (which must fail)."""
    text = (Path(__file__).resolve().parents[3] / "projects" / "rigs" / "two-body-machine.toml").read_text()
    assert old in text
    rig = tmp_path / "changed.toml"
    rig.write_text(text.replace(old, new, 1))
    p = tmp_path / "p.h5"
    assert main(["new", str(p), "--rig", str(rig)]) == 0
    capsys.readouterr()
    assert main(["acquire", str(p), "--name", "h", "--force-point=100mm,50mm,250mm", "--force-dir=-z",
                 "--samples", samples, "--pretrigger", "100"]) == 1
    return p, capsys.readouterr().err


def test_an_anti_aliasing_order_the_simulator_does_not_model_names_the_rig_file(tmp_path, capsys):
    # docs/rig-format.md allows orders 1..16; the simulated front end models 1..12, and said so in
    # "chain field 'aaf_order' must be 1..12", naming no file
    _, err = _acquire_on_two_body_rig_with(tmp_path, capsys, 'family = "butterworth", order = 8, cutoff_hz = 2000.0',
                                           'family = "butterworth", order = 16, cutoff_hz = 2000.0', "1024")
    assert "changed.toml [acquisition] field 'anti_aliasing.order': the simulated DAQ models orders 1 to 12, got 16" in err


def test_a_record_shorter_than_the_rigs_offset_window_is_refused_before_it_is_recorded(tmp_path, capsys):
    # the rig's offset window (samples 0-1023) in a record of 512 samples: acquire stored the record
    # and compare then refused it in "step 'offset': window samples 0..1023 lies outside the record
    # of 512 samples", naming no project, experiment or channel
    p, err = _acquire_on_two_body_rig_with(tmp_path, capsys, "offset_samples = [0, 256]", "offset_samples = [0, 1024]", "512")
    assert f"{p}: rig 'two-body-machine' for --samples 512: row 16 (offset length), channel 0: offset window samples " \
           "0..1023 lies outside the record of 512 samples" in err
    with open_project(p) as project:
        assert project.experiment_names() == []
