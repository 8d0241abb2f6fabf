"""The sixth rig (a gearbox bolted to a machine bed through stiff elastomer pads, a motor overhung
on flange bushings: the generator's stiff structure) against closed forms, the characteristic
polynomial of the rig file's own numbers, and odsuite's compare on a record set with no hidden
change."""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest
from scipy import linalg

from . import calibrate, writers
from .rigs import gearbox_rig
from .rigsim import Model
from .structure import GROUND, Structure
from .test_calibration_cases import (_mk_from_rig_file, _point_map,
                                     generator_modes_checked_against_the_rig_file, rig_layout)

G = 9.80665  # m/s^2
# the design numbers the rig states: the pads (N/m in compression and shear), the motor's flange
# bushings (along and across its axis) and the bolt pattern's half-width around the motor's axis
PAD_Z, PAD_SHEAR = 4.0e7, 1.4e7
BUSHING_AXIAL, BUSHING_RADIAL, HALF_PATTERN = 8.0e7, 2.5e7, 0.045
MASSES = {"gearbox": 17.0, "motor": 5.0}


@pytest.fixture(scope="module")
def gearbox_doc(tmp_path_factory):
    path = writers.write_rig_toml(tmp_path_factory.mktemp("rig") / "gearbox.toml", gearbox_rig())
    return tomllib.loads(path.read_text())


def _c_from_rig_file(doc: dict) -> np.ndarray:
    """The damping matrix of the file's springs, assembled like _mk_from_rig_file's stiffness."""
    bodies = {b["name"]: i for i, b in enumerate(doc["bodies"])}
    com = {b["name"]: np.asarray(b["com"]) for b in doc["bodies"]}
    C = np.zeros((6 * len(bodies), 6 * len(bodies)))
    for s in doc["springs"]:
        L = np.zeros((3, C.shape[0]))
        p = np.asarray(s["position"])
        L[:, 6 * bodies[s["body"]]:6 * bodies[s["body"]] + 6] = _point_map(p - com[s["body"]])
        if s["other"] != "ground":
            L[:, 6 * bodies[s["other"]]:6 * bodies[s["other"]] + 6] -= _point_map(p - com[s["other"]])
        c = np.asarray(s["damping"], float)
        C += L.T @ (np.diag(c) if c.ndim == 1 else c) @ L
    return C


def test_generator_modes_are_the_roots_of_the_rig_files_characteristic_polynomial(gearbox_doc):
    """Each of the generator's 12 frequencies is a root of det(K - w^2 M) of the file's numbers;
    the slowest is where a stiffly mounted machine has it (150-400 Hz), the highest well inside
    the anti-aliasing filter's pass band the file states."""
    f = generator_modes_checked_against_the_rig_file(gearbox_doc, gearbox_rig())
    assert len(f) == 12
    assert 150.0 < f[0] < 400.0
    assert f[-1] < 0.7 * gearbox_doc["acquisition"]["anti_aliasing"]["cutoff_hz"]


def test_every_mode_of_the_rig_file_is_damped_1_to_4_percent_and_rings_out_in_the_record(gearbox_doc):
    """The eigenvalues of the file's M, C, K (first-order form): every mode's damping ratio is
    -Re(s)/|s| in 1-4 %, and the slowest decay (Re(s)) leaves under 2 % of the amplitude at the
    end of the calibration's records (2048 samples)."""
    M, K = _mk_from_rig_file(gearbox_doc)
    C = _c_from_rig_file(gearbox_doc)
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-linalg.solve(M, K), -linalg.solve(M, C)]])
    s = linalg.eigvals(A)
    s = s[s.imag > 0]
    zeta = -s.real / np.abs(s)
    assert len(s) == 12 and np.all((0.01 < zeta) & (zeta < 0.04)), np.round(100 * zeta, 2)
    acq = gearbox_doc["acquisition"]
    after_blow = (calibrate.SAMPLES["gearbox"] - acq["pre_trigger"]) / acq["sampling_rate"]
    assert np.exp(np.max(s.real) * after_blow) < 0.02


def test_motor_axial_and_roll_on_its_bushings_with_the_gearbox_held_are_closed_forms():
    """The gearbox held still: the four bushings lie in the flange plane on a square centred on
    the motor's axis, through its centre of mass, so motion along the axis and roll about it are
    uncoupled from the rest: sqrt(4 k_axial / m) and sqrt(4 k_radial 2 h^2 / Ixx) (each bushing
    h from the axis along y and z; its tangential stiffness is the radial one)."""
    rig = gearbox_rig()
    motor = rig.structure.body("motor")
    bushings = [s for s in rig.structure.springs if s.body == "motor"]
    assert len(bushings) == 4 and all(s.other == "gearbox" for s in bushings)
    for s in bushings:
        np.testing.assert_allclose(np.abs(s.position[1:] - motor.com[1:]), HALF_PATTERN, rtol=1e-12)
        s.other = GROUND
    f = Model(Structure([motor], bushings)).natural_frequencies()
    axial = np.sqrt(4 * BUSHING_AXIAL / motor.mass) / (2 * np.pi)
    roll = np.sqrt(4 * BUSHING_RADIAL * 2 * HALF_PATTERN ** 2 / motor.inertia[0, 0]) / (2 * np.pi)
    for closed in (axial, roll):
        assert np.min(np.abs(f - closed)) / closed < 1e-9, (closed, f)


def test_static_sag_is_the_weight_over_the_four_pads(gearbox_doc):
    """The pads are the only springs to ground and are diagonal, so under gravity their mean
    vertical deflection is the whole weight over 4 k_z (a stiff mount: microns), however the
    overhung motor tilts the housing."""
    M, K = _mk_from_rig_file(gearbox_doc)
    weight = np.zeros(M.shape[0])
    for i, b in enumerate(gearbox_doc["bodies"]):
        weight[6 * i + 2] = -b["mass"] * G
    q = np.linalg.solve(K, weight)
    assert {b["name"]: b["mass"] for b in gearbox_doc["bodies"]} == MASSES
    com = np.asarray(gearbox_doc["bodies"][0]["com"])
    pads = [s for s in gearbox_doc["springs"] if s["other"] == "ground"]
    assert len(pads) == 4 and all(s["stiffness"] == [PAD_SHEAR, PAD_SHEAR, PAD_Z] for s in pads)
    sag = [(_point_map(np.asarray(s["position"]) - com) @ q[:6])[2] for s in pads]
    assert np.mean(sag) == pytest.approx(-sum(MASSES.values()) * G / (4 * PAD_Z), rel=1e-9)
    assert 1e-6 < -np.mean(sag) < 2e-6 and np.ptp(sag) > 1e-7  # the motor's weight tilts the housing


def test_sensors_mix_sensitivities_one_axis_off_both_vertical_planes_and_a_hard_hammer(gearbox_doc):
    sensors = {s["name"]: s for s in gearbox_doc["sensors"]}
    chamfer = np.asarray(sensors["gb_chamfer"]["axis"])
    assert np.linalg.norm(chamfer) == pytest.approx(1.0, abs=1e-12)
    assert chamfer[2] == pytest.approx(np.cos(np.radians(50.0)), rel=1e-12)
    assert abs(chamfer[0]) > 0.1 and abs(chamfer[1]) > 0.1  # neither in the x-z nor the y-z plane
    assert sensors["mot_z3"]["sign"] == -1
    volts_per_g = {round(float(np.mean(np.atleast_1d(s["sensitivity"])) * G), 6)
                   for s in gearbox_doc["sensors"] if s["kind"] != "force"}
    assert volts_per_g == {0.01, 0.05, 0.1, 0.5}
    acq = gearbox_doc["acquisition"]
    assert 10e3 <= acq["sampling_rate"] <= 25e3 and acq["adc_range"] == [-10.0, 10.0]
    assert acq["sampling_rate"] not in {calibrate.cases.RIGS[name]().daq.sampling_rate
                                        for name in calibrate.cases.RIGS if name != "gearbox"}
    assert all(0.2e-3 <= h.duration_s <= 0.5e-3 for h in gearbox_rig().hits)
    assert "processing" not in gearbox_doc  # modes far above the default 20 Hz high-pass


def test_calibrate_rigs_option_cycles_the_gearbox():
    only = calibrate.specs("faults", 12, ("gearbox",))
    assert {s["rig"] for s in only} == {"gearbox"} and {s["case"] for s in only} == {"softer-mount", "added-mass"}
    assert {s["rig"] for s in calibrate.specs("fixed", 6, ("gearbox",))} == {"gearbox"}


def test_odsuite_accepts_the_gearbox_rig_file(tmp_path, capsys):
    """`odsuite new` on the written rig file: both bodies, a least-squares solver for each (six
    sensor directions on each body), eight springs."""
    layout = rig_layout(tmp_path, capsys, gearbox_rig())
    assert {b["name"]: b["mass_kg"] for b in layout["bodies"]} == MASSES
    assert all(b["solver"] == "least-squares" and b["solver_problem"] is None for b in layout["bodies"])
    assert len(layout["springs"]) == 8


def test_records_with_no_hidden_change_compare_at_the_noise_floor(tmp_path, capsys):
    """Four records (30 N, 50 uV of noise) of the rig exactly as its file states it, through
    `odsuite new`, `import`, `process` and `compare` (in this process, as calibrate.make_project
    runs them): odsuite's error lies on its noise floor (measured 1.007x) with no residual peak."""
    from odsuite.cli import main

    spec = {"case": "null", "rig": "gearbox", "seed": 100, "force_n": 30.0, "noise_v": 50e-6}
    case = calibrate.build(spec)
    truth = writers.to_jsonable(case.truth_document())
    rig = writers.write_rig_toml(tmp_path / "rig.toml", calibrate.true_rig(case))
    project = tmp_path / "p.h5"
    assert main(["new", str(project), "--rig", str(rig)]) == 0
    for i, (rec, hits) in enumerate(zip(case.simulate(), truth["records"])):
        lvm = writers.write_lvm(tmp_path / f"r{i:02d}.lvm", calibrate.without_unused(rec))
        hit = hits[0]
        point = ",".join(f"{1e3 * v!r}" for v in hit["point_m"])
        direction = ",".join(f"{v!r}" for v in hit["direction"])
        assert main(["import", str(project), str(lvm), "--name", f"r{i}", f"--force-point={point}",
                     f"--force-dir={direction}", "--force-body", hit["body"]]) == 0
    assert main(["process", str(project)]) == 0
    capsys.readouterr()
    assert main(["compare", str(project), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert 0.9 <= doc["error"] / doc["noise_floor_error"] <= 1.15, (doc["error"], doc["noise_floor_error"])
    assert doc["residual_peaks"] == []
