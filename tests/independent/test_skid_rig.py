"""The fifth rig (a pump and its motor on a welded skid on four inclined mounts) against closed
forms, the characteristic polynomial of the rig file's own numbers, and odsuite's compare on a
record set with no hidden change."""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest

from . import calibrate, writers
from .rigs import skid_rig
from .rigsim import Model
from .structure import GROUND, Structure
from .test_calibration_cases import (_mk_from_rig_file, _point_map,
                                     generator_modes_checked_against_the_rig_file, rig_layout)

G = 9.80665  # m/s^2
# the design numbers the rig states: the skid's mounts (N/m along and across their axes, tilt from
# the vertical towards the skid's long centre line) and the motor's pads (vertical, horizontal)
K_AXIAL, K_SHEAR, TILT_DEG = 5.0e5, 1.0e5, 40.0
MOTOR_PAD_Z, MOTOR_PAD_XY = 8.0e5, 2.0e5
MASSES = {"skid": 110.0, "motor": 75.0, "pump": 48.0}


@pytest.fixture(scope="module")
def skid_doc(tmp_path_factory):
    path = writers.write_rig_toml(tmp_path_factory.mktemp("rig") / "skid.toml", skid_rig())
    return tomllib.loads(path.read_text())


def test_generator_modes_are_the_roots_of_the_rig_files_characteristic_polynomial(skid_doc):
    """Each of the generator's 18 frequencies is a root of det(K - w^2 M) of the file's numbers."""
    f = generator_modes_checked_against_the_rig_file(skid_doc, skid_rig())
    assert len(f) == 18
    # every rigid-body mode in 5-60 Hz, as a skid on rubber with machines on pads has them
    assert 5.0 < f[0] < 7.0 and 50.0 < f[-1] < 60.0


def test_skid_mounts_in_the_rig_file_are_inclined_towards_the_centre_line(skid_doc):
    """Each skid mount's 3x3 stiffness is K_SHEAR I + (K_AXIAL - K_SHEAR) n n^T with n tilted
    TILT_DEG from +z towards y = 0 (in the y-z plane)."""
    mounts = [s for s in skid_doc["springs"] if s["other"] == "ground"]
    assert len(mounts) == 4 and all(s["body"] == "skid" for s in mounts)
    t = np.radians(TILT_DEG)
    for s in mounts:
        n = np.array([0.0, -np.sign(s["position"][1]) * np.sin(t), np.cos(t)])
        np.testing.assert_allclose(np.asarray(s["stiffness"]),
                                   K_SHEAR * np.eye(3) + (K_AXIAL - K_SHEAR) * np.outer(n, n), atol=1e-9 * K_AXIAL)


def test_static_sag_is_the_weight_over_the_mounts_vertical_stiffness(skid_doc):
    """The mounts are the only springs to ground; their vertical stiffness is
    K_SHEAR + (K_AXIAL - K_SHEAR) cos^2 tilt, and the pairs' opposite tilts cancel sideways, so
    under gravity their mean vertical deflection is the whole weight over four of them."""
    M, K = _mk_from_rig_file(skid_doc)
    weight = np.zeros(M.shape[0])
    for i, b in enumerate(skid_doc["bodies"]):
        weight[6 * i + 2] = -b["mass"] * G
    q = np.linalg.solve(K, weight)
    skid = skid_doc["bodies"][0]
    assert {b["name"]: b["mass"] for b in skid_doc["bodies"]} == MASSES
    mounts = [s for s in skid_doc["springs"] if s["other"] == "ground"]
    sag = [(_point_map(np.asarray(s["position"]) - np.asarray(skid["com"])) @ q[:6])[2] for s in mounts]
    k_z = K_SHEAR + (K_AXIAL - K_SHEAR) * np.cos(np.radians(TILT_DEG)) ** 2
    assert np.mean(sag) == pytest.approx(-sum(MASSES.values()) * G / (4 * k_z), rel=1e-9)


def test_motor_bounce_and_yaw_on_its_pads_with_the_skid_held_are_closed_forms():
    """The skid held still: the motor's four diagonal pads lie symmetric about its centre of mass
    (at +-a, +-b), so bounce and yaw are uncoupled: sqrt(4 k_z / m) and sqrt(4 k_xy (a^2 + b^2) / Izz)."""
    rig = skid_rig()
    motor = rig.structure.body("motor")
    pads = [s for s in rig.structure.springs if s.body == "motor"]
    for s in pads:
        s.other = GROUND
    f = Model(Structure([motor], pads)).natural_frequencies()
    r2 = np.mean([np.sum((s.position[:2] - motor.com[:2]) ** 2) for s in pads])
    bounce = np.sqrt(4 * MOTOR_PAD_Z / motor.mass) / (2 * np.pi)
    yaw = np.sqrt(4 * MOTOR_PAD_XY * r2 / motor.inertia[2, 2]) / (2 * np.pi)
    for closed in (bounce, yaw):
        assert np.min(np.abs(f - closed)) / closed < 1e-9, (closed, f)


def test_sensors_mix_sensitivities_and_one_axis_is_tilted_out_of_both_vertical_planes(skid_doc):
    sensors = {s["name"]: s for s in skid_doc["sensors"]}
    volute = np.asarray(sensors["pump_volute"]["axis"])
    assert np.linalg.norm(volute) == pytest.approx(1.0, abs=1e-12)
    assert volute[2] == pytest.approx(np.cos(np.radians(35.0)), rel=1e-12)
    assert abs(volute[0]) > 0.1 and abs(volute[1]) > 0.1  # neither in the x-z nor the y-z plane
    volts_per_g = {round(float(np.mean(np.atleast_1d(s["sensitivity"])) * G), 6)
                   for s in skid_doc["sensors"] if s["kind"] != "force"}
    assert volts_per_g == {0.1, 0.5, 1.0}
    assert skid_doc["acquisition"]["anti_aliasing"]["family"] == "elliptic"
    assert skid_doc["acquisition"]["sampling_rate"] not in {calibrate.cases.RIGS[name]().daq.sampling_rate
                                                            for name in calibrate.cases.RIGS if name != "skid"}


def test_calibrate_rigs_option_cycles_the_skid():
    only = calibrate.specs("faults", 8, ("skid",))
    assert {s["rig"] for s in only} == {"skid"} and {s["case"] for s in only} == {"softer-mount", "added-mass"}


def test_odsuite_accepts_the_skid_rig_file(tmp_path, capsys):
    """`odsuite new` on the written rig file: three bodies, a least-squares solver for each (six
    sensor directions on each body), twelve springs."""
    layout = rig_layout(tmp_path, capsys, skid_rig())
    assert {b["name"]: b["mass_kg"] for b in layout["bodies"]} == MASSES
    assert all(b["solver"] == "least-squares" and b["solver_problem"] is None for b in layout["bodies"])
    assert len(layout["springs"]) == 12


def test_records_with_no_hidden_change_compare_at_the_noise_floor(tmp_path):
    """Four records (30 N, 50 uV of noise) of the rig exactly as its file states it: odsuite's
    error lies on its noise floor (measured 1.01x) with no residual peak."""
    spec = {"case": "null", "rig": "skid", "seed": 100, "force_n": 30.0, "noise_v": 50e-6}
    case = calibrate.build(spec)
    truth = writers.to_jsonable(case.truth_document())
    rig = writers.write_rig_toml(tmp_path / "rig.toml", calibrate.true_rig(case))
    lvms = [writers.write_lvm(tmp_path / f"r{i:02d}.lvm", calibrate.without_unused(rec))
            for i, rec in enumerate(case.simulate())]
    project = calibrate.make_project(tmp_path, rig, lvms, truth)
    doc = json.loads(calibrate.odsuite("compare", project, "--json"))
    assert 0.9 <= doc["error"] / doc["noise_floor_error"] <= 1.15, (doc["error"], doc["noise_floor_error"])
    assert doc["residual_peaks"] == []
