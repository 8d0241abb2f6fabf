"""The third rig (plate-motor), the calibration options (force level, noise, disturbances), the
null, softer-mount and pair cases and the band-residual-to-noise measure, against closed forms and
eigen-solutions computed here from the rig file's numbers."""

from __future__ import annotations

import ast
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy import linalg

from . import cases, truthbands, writers
from .rigs import plate_motor_rig
from .rigsim import Model

G = 9.80665  # m/s^2


def _point_map(r) -> np.ndarray:
    """3x6: the displacement of a point at offset r from the centre of mass under [d, theta]."""
    x, y, z = r
    return np.hstack([np.eye(3), np.array([[0.0, z, -y], [-z, 0.0, x], [y, -x, 0.0]])])


def _mk_from_rig_file(doc: dict) -> tuple[np.ndarray, np.ndarray]:
    """M and K of the rig file's bodies and springs (6 coordinates per body at its centre of
    mass), assembled here from the file's numbers alone."""
    bodies = {b["name"]: i for i, b in enumerate(doc["bodies"])}
    n = 6 * len(bodies)
    M, K = np.zeros((n, n)), np.zeros((n, n))
    for i, b in enumerate(doc["bodies"]):
        M[6 * i:6 * i + 3, 6 * i:6 * i + 3] = b["mass"] * np.eye(3)
        M[6 * i + 3:6 * i + 6, 6 * i + 3:6 * i + 6] = b["inertia"]
    com = {b["name"]: np.asarray(b["com"]) for b in doc["bodies"]}
    for s in doc["springs"]:
        L = np.zeros((3, n))
        p = np.asarray(s["position"])
        i = bodies[s["body"]]
        L[:, 6 * i:6 * i + 6] = _point_map(p - com[s["body"]])
        if s["other"] != "ground":
            j = bodies[s["other"]]
            L[:, 6 * j:6 * j + 6] -= _point_map(p - com[s["other"]])
        k = np.asarray(s["stiffness"], float)
        K += L.T @ (np.diag(k) if k.ndim == 1 else k) @ L
    return M, K


def generator_modes_checked_against_the_rig_file(doc: dict, rig) -> np.ndarray:
    """The generator's natural frequencies of ``rig`` (Hz), each checked to be a root of
    det(K - w^2 M) with M and K assembled from the rig file ``doc``: by Sylvester's law of inertia
    the count of negative eigenvalues of K - lam M is the number of modes below lam, so it steps
    by one across each of them (six per body, all distinct) and nowhere else."""
    M, K = _mk_from_rig_file(doc)
    f = Model(rig.structure).natural_frequencies()
    assert len(f) == 6 * len(doc["bodies"]) and np.all(np.diff(f) > 0.05)

    def below(freq_hz):
        return int(np.sum(linalg.eigvalsh(K - (2 * np.pi * freq_hz) ** 2 * M) < 0))

    for k, fk in enumerate(f):
        assert below(fk * (1 - 1e-7)) == k and below(fk * (1 + 1e-7)) == k + 1, fk
    return f


def rig_layout(tmp_path: Path, capsys, rig) -> dict:
    """`info --json`'s rig layout of a project that `odsuite new` made on the written rig file."""
    from odsuite.cli import main

    toml = writers.write_rig_toml(tmp_path / "rig.toml", rig)
    project = tmp_path / "p.h5"
    assert main(["new", str(project), "--rig", str(toml)]) == 0
    capsys.readouterr()
    assert main(["info", str(project), "--json"]) == 0
    return json.loads(capsys.readouterr().out)["rig_layout"]


@pytest.fixture(scope="module")
def plate_motor_doc(tmp_path_factory):
    path = writers.write_rig_toml(tmp_path_factory.mktemp("rig") / "plate-motor.toml", plate_motor_rig())
    return tomllib.loads(path.read_text())


def test_new_modules_import_nothing_from_odsuite():
    for module in ("truthbands", "calibrate"):
        tree = ast.parse((Path(__file__).parent / f"{module}.py").read_text())
        imported = [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
        imported += [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
        assert not [m for m in imported if m.split(".")[0] in ("odsuite", "odsuite_plugins")], module


def test_plate_motor_rig_file_states_the_issue_rig(plate_motor_doc):
    doc = plate_motor_doc
    masses = {b["name"]: b["mass"] for b in doc["bodies"]}
    assert masses == {"plate": 37.7, "motor": 8.0}
    # a steel plate 0.8 x 0.6 x 0.01 m at 7850 kg/m^3 weighs 37.68 kg
    size = next(b for b in doc["bodies"] if b["name"] == "plate")["plate"]["size"]
    assert np.prod(size) * 7850 == pytest.approx(37.7, rel=1e-3)
    kinds = {}
    for s in doc["sensors"]:
        kinds.setdefault((s.get("body"), s["kind"]), []).append(s)
    for body in ("plate", "motor"):
        assert len(kinds[(body, "triaxial_accelerometer")]) == 2
        z = kinds[(body, "accelerometer")]
        assert len(z) == 1 and z[0]["axis"] == [0.0, 0.0, 1.0]
    assert [s["channel"] for s in doc["sensors"] if s["kind"] == "force"] == [0] and doc["channel_count"] == 15
    # its own chain: the 20 Hz default high-pass would remove the suspension's modes
    assert doc["processing"]["filter"]["cutoff_hz"] < 2.0


def test_plate_motor_suspension_modes_against_an_eigen_solution_of_the_rig_file(plate_motor_doc):
    M, K = _mk_from_rig_file(plate_motor_doc)
    w2 = linalg.eigh(K, M, eigvals_only=True)
    f = np.sqrt(w2) / (2 * np.pi)
    np.testing.assert_allclose(Model(plate_motor_rig().structure).natural_frequencies(), f, rtol=1e-9)
    # the suspension (six modes) 8.5-25 Hz, the motor on its mounts 90-400 Hz
    assert 8.5 < f[0] and f[5] < 25.0 and 90.0 < f[6] and f[-1] < 400.0


def test_plate_motor_static_sag_is_the_weight_over_the_four_rubber_mounts(plate_motor_doc):
    """Equilibrium under gravity: the four equal vertical rubber springs carry the whole weight,
    so their mean deflection is (m_plate + m_motor) g / (4 k_z), whatever the tilt."""
    doc = plate_motor_doc
    M, K = _mk_from_rig_file(doc)
    weight = np.zeros(M.shape[0])
    for i, b in enumerate(doc["bodies"]):
        weight[6 * i + 2] = -b["mass"] * G
    q = np.linalg.solve(K, weight)
    plate_com = np.asarray(doc["bodies"][0]["com"])
    rubber = [s for s in doc["springs"] if s["other"] == "ground"]
    sag = [(_point_map(np.asarray(s["position"]) - plate_com) @ q[:6])[2] for s in rubber]
    kz = rubber[0]["stiffness"][2]
    assert np.mean(sag) == pytest.approx(-(37.7 + 8.0) * G / (4 * kz), rel=1e-9)


def test_the_hammer_force_level_is_honoured():
    """Every record's blow peaks at the chosen force; the load cell's record (through the
    anti-aliasing filter, unit gain at DC) carries the half-sine's impulse 2 F T / pi: the sum of
    the samples of a signal band-limited below fs/2 is its integral over dt."""
    case = cases.build_case("null", 3, "plate-motor", 1024, force_n=30.0)
    assert [hits[0].peak_n for hits in case.records] == [30.0] * 4
    load_cell = case.nominal.force_sensor
    for rec, hits in zip(case.simulate(), case.records):
        dt = rec.time[1] - rec.time[0]
        impulse = rec.clean_volts[:, load_cell.channel].sum() * dt / load_cell.sensitivity
        assert impulse == pytest.approx(2 * 30.0 * hits[0].duration_s / np.pi, rel=0.005)
        assert rec.force_n.max() <= 30.0 + 1e-9


def test_noise_fraction_adds_that_share_of_each_channel_rms():
    case = cases.build_case("null", 4, "thesis", 2048, force_n=20.0, noise_fraction=0.03)
    rec = case.simulate()[0]
    lsb = 10.0 / 2 ** 16
    trigger = case.actual.daq.pre_trigger
    for k, name in enumerate(rec.names):
        if name.startswith("aux"):
            continue
        clean_rms = np.sqrt(np.mean(rec.clean_volts[trigger:, k] ** 2))
        expected = np.sqrt(50e-6 ** 2 + (0.03 * clean_rms) ** 2 + lsb ** 2 / 12)
        measured = np.std(rec.volts[:, k] - rec.clean_volts[:, k])
        assert measured == pytest.approx(expected, rel=0.08), name  # 2048 samples: 1.6 % standard error


def test_disturbances_do_not_change_the_case_draws():
    plain = cases.build_case("added-mass", 2, "two-body", 512)
    disturbed = cases.build_case("added-mass", 2, "two-body", 512, disturbances=["hum", "drift", "double-hit"])
    assert json.dumps(writers.to_jsonable(plain.truth["effect"])) == \
        json.dumps(writers.to_jsonable(disturbed.truth["effect"]))
    assert set(disturbed.truth["disturbances"]) == {"hum", "drift", "double-hit"}
    assert all(len(hits) == 2 for hits in disturbed.records)
    assert np.all(np.asarray(disturbed.actual.daq.hum_v) > 0) and "options" not in plain.truth


@pytest.mark.parametrize("name", ["pair-gain-com", "pair-bending-stiffer", "pair-mount-gain"])
def test_pairs_hide_two_changes(name):
    case = cases.build_case(name, 5, "plate-motor", 512)
    kinds = [e["kind"] for e in case.truth["effects"]]
    assert len(kinds) == 2 and case.truth["effect"]["kind"] == "pair"
    gains = [a.gain_error for a in case.actual.accelerometers if a.gain_error]
    if "sensor_gain" in kinds:
        assert len(gains) == 1 and -0.30 <= gains[0] <= -0.15
    if name == "pair-bending-stiffer":
        assert case.actual.structure.modes and 0.2 <= case.truth["effects"][1]["factor"] - 1 <= 0.4


def test_softer_mount_range():
    factors = [cases.build_case("softer-mount", s, "plate-motor", 512).truth["effect"]["factor"] for s in range(8)]
    assert all(0.6 <= f <= 0.8 for f in factors) and len(set(factors)) == 8


def test_band_energy_is_parseval_and_places_a_sine_in_its_band():
    fs, n = 2048.0, 4096
    t = np.arange(n) / fs
    rng = np.random.default_rng(1)
    x = np.column_stack([0.3 * np.sin(2 * np.pi * 64.0 * t), rng.standard_normal(n)])
    bands = truthbands.octave_bands(fs)
    e = truthbands.band_energy(x, fs, bands)
    np.testing.assert_allclose(e.sum(axis=0), (x ** 2).sum(axis=0), rtol=1e-12)
    k = next(i for i, (lo, hi) in enumerate(bands) if lo <= 64.0 < hi)
    assert e[k, 0] == pytest.approx(n * 0.3 ** 2 / 2, rel=1e-9)  # an exact number of periods
    # white noise spreads by bandwidth: its share of 0..fs/2 within a few standard errors
    share = np.array([(hi - lo) / (fs / 2) for lo, hi in bands])
    np.testing.assert_allclose(e[:, 1] / e[:, 1].sum(), share, atol=0.02)


def test_band_ratio_is_zero_for_a_null_and_grows_with_the_force():
    null = cases.build_case("null", 1, "thesis", 1024, force_n=20.0)
    assert truthbands.band_residual_to_noise(null, null.simulate())["max_ratio"] == 0.0
    ratios = []
    for force in (5.0, 50.0):
        case = cases.build_case("softer-mount", 1, "thesis", 1024, force_n=force)
        ratios.append(truthbands.band_residual_to_noise(case, case.simulate())["max_ratio"])
    # a linear rig: the residual scales with the force, the noise does not
    assert ratios[1] / ratios[0] == pytest.approx(10.0, rel=0.02)


def test_odsuite_accepts_the_plate_motor_rig_file(tmp_path, capsys):
    """`odsuite new` on the written rig file: both bodies, their masses, a coordinate solver for
    each (two triaxials and a z sensor see six independent directions) and the eight springs."""
    layout = rig_layout(tmp_path, capsys, plate_motor_rig())
    assert {b["name"]: b["mass_kg"] for b in layout["bodies"]} == {"plate": 37.7, "motor": 8.0}
    assert all(b["solver"] == "least-squares" and b["solver_problem"] is None for b in layout["bodies"])
    assert len(layout["bodies"][0]["sensors"]) == 7 and len(layout["springs"]) == 8
