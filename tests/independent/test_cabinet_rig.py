"""The fourth rig (a tall cabinet with a heavy unit on three inclined mounts) against closed forms
and the characteristic polynomial of the rig file's own numbers."""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest

from . import calibrate, writers
from .rigs import cabinet_rig
from .rigsim import Model
from .structure import GROUND, Structure
from .test_calibration_cases import (_mk_from_rig_file, _point_map,
                                     generator_modes_checked_against_the_rig_file, rig_layout)

G = 9.80665  # m/s^2
# the design numbers the rig states: the unit's mounts (N/m along and across their axes, tilt from
# the vertical towards the unit's centre, radius of the mount circle), the feet's vertical stiffness
K_AXIAL, K_SHEAR, TILT_DEG, RADIUS = 3.0e7, 6.0e6, 25.0, 0.13
K_FOOT_Z = 7.0e5


@pytest.fixture(scope="module")
def cabinet_doc(tmp_path_factory):
    path = writers.write_rig_toml(tmp_path_factory.mktemp("rig") / "cabinet.toml", cabinet_rig())
    return tomllib.loads(path.read_text())


def test_generator_modes_are_the_roots_of_the_rig_files_characteristic_polynomial(cabinet_doc):
    """det(K - w^2 M) of M and K assembled from the file: by Sylvester's law of inertia the count
    of negative eigenvalues of K - lam M is the number of modes below lam, so it steps by one
    across each of the generator's frequencies (all distinct) and nowhere else."""
    f = generator_modes_checked_against_the_rig_file(cabinet_doc, cabinet_rig())
    assert len(f) == 12
    # the spread the rig is for: rocking near 5 Hz, the unit on its mounts up to about 300 Hz
    assert 4.0 < f[0] < 6.0 and 250.0 < f[-1] < 320.0


def test_inclined_mounts_in_the_rig_file_are_stiff_along_their_own_axis(cabinet_doc):
    """Each unit mount's 3x3 stiffness is K_SHEAR I + (K_AXIAL - K_SHEAR) n n^T with n tilted
    TILT_DEG from +z towards the mount circle's centre."""
    unit = next(b for b in cabinet_doc["bodies"] if b["name"] == "unit")
    mounts = [s for s in cabinet_doc["springs"] if s["body"] == "unit"]
    assert len(mounts) == 3 and all(s["other"] == "cabinet" for s in mounts)
    for s in mounts:
        k = np.asarray(s["stiffness"])
        radial = np.asarray(s["position"]) - np.asarray(unit["com"])
        radial[2] = 0.0
        assert np.linalg.norm(radial) == pytest.approx(RADIUS, rel=1e-12)
        radial /= RADIUS
        t = np.radians(TILT_DEG)
        n = np.array([0.0, 0.0, np.cos(t)]) - np.sin(t) * radial
        np.testing.assert_allclose(k, K_SHEAR * np.eye(3) + (K_AXIAL - K_SHEAR) * np.outer(n, n), atol=1e-9 * K_AXIAL)


def test_unit_bounce_and_yaw_on_its_mounts_with_the_cabinet_held_are_closed_forms():
    """The cabinet held still: the three mounts at 120 degrees, tilted in their radial planes, leave
    bounce and yaw uncoupled (the sum of the mounts' radial vectors is zero, the box's principal
    axes are the rig's), so k_z = 3 (K_SHEAR + (K_AXIAL - K_SHEAR) cos^2 tilt) and
    k_yaw = 3 K_SHEAR r^2 (the mounts' tangential stiffness is their shear stiffness)."""
    rig = cabinet_rig()
    unit = rig.structure.body("unit")
    springs = [s for s in rig.structure.springs if s.body == "unit"]
    for s in springs:
        s.other = GROUND  # the cabinet held
    f = Model(Structure([unit], springs)).natural_frequencies()
    t = np.radians(TILT_DEG)
    bounce = np.sqrt(3 * (K_SHEAR + (K_AXIAL - K_SHEAR) * np.cos(t) ** 2) / unit.mass) / (2 * np.pi)
    yaw = np.sqrt(3 * K_SHEAR * RADIUS ** 2 / unit.inertia[2, 2]) / (2 * np.pi)
    for closed in (bounce, yaw):
        assert np.min(np.abs(f - closed)) / closed < 1e-9, (closed, f)


def test_static_sag_is_the_weight_over_the_four_feet(cabinet_doc):
    """The four feet are the only springs to ground and are diagonal, so under gravity their mean
    vertical deflection is the whole weight over 4 k_z, however the off-centre unit tilts it."""
    M, K = _mk_from_rig_file(cabinet_doc)
    weight = np.zeros(M.shape[0])
    for i, b in enumerate(cabinet_doc["bodies"]):
        weight[6 * i + 2] = -b["mass"] * G
    q = np.linalg.solve(K, weight)
    com = np.asarray(cabinet_doc["bodies"][0]["com"])
    feet = [s for s in cabinet_doc["springs"] if s["other"] == "ground"]
    assert len(feet) == 4 and all(s["stiffness"][2] == K_FOOT_Z for s in feet)
    sag = [(_point_map(np.asarray(s["position"]) - com) @ q[:6])[2] for s in feet]
    assert np.mean(sag) == pytest.approx(-(70.0 + 32.0) * G / (4 * K_FOOT_Z), rel=1e-9)
    assert np.ptp(sag) > 1e-5  # the off-centre unit tilts the cabinet


def test_wedge_triaxial_axes_are_an_orthonormal_turned_frame(cabinet_doc):
    top = next(s for s in cabinet_doc["sensors"] if s["name"] == "top")
    axes = np.asarray(top["axes"])
    np.testing.assert_allclose(axes @ axes.T, np.eye(3), atol=1e-12)
    # turned 30 degrees about z, then 20 degrees about the turned x: x stays horizontal at 30 deg
    np.testing.assert_allclose(axes[0], [np.cos(np.radians(30)), np.sin(np.radians(30)), 0.0], atol=1e-12)
    assert axes[2] @ [0, 0, 1] == pytest.approx(np.cos(np.radians(20)), rel=1e-12)
    sens = {s["name"]: s.get("sensitivity") for s in cabinet_doc["sensors"]}
    assert len({round(np.mean(np.atleast_1d(v)), 6) for v in sens.values()}) >= 3  # mixed sensitivities
    assert cabinet_doc["acquisition"]["sampling_rate"] not in {r.daq.sampling_rate for r in (
        calibrate.cases.RIGS[name]() for name in calibrate.RIGS)}


def test_calibrate_rigs_option_cycles_the_new_rig_and_leaves_the_default_sets_alone():
    default = calibrate.specs("faults", 20)
    assert [s["rig"] for s in default[:6]] == ["thesis", "thesis", "two-body", "two-body", "plate-motor",
                                                "plate-motor"]
    only = calibrate.specs("nulls", 12, ("cabinet",))
    assert {s["rig"] for s in only} == {"cabinet"} and len({s["id"] for s in only}) == 12
    assert len({json.dumps({k: v for k, v in s.items() if k in ("noise_v", "noise_fraction", "disturbances")},
                           sort_keys=True) for s in only}) == len(calibrate.NULL_CONDITIONS)


def test_odsuite_accepts_the_cabinet_rig_file(tmp_path, capsys):
    """`odsuite new` on the written rig file: both bodies, a least-squares solver for each (the
    cabinet: two triaxials and a y sensor; the unit: a triaxial and three single axes), seven springs."""
    layout = rig_layout(tmp_path, capsys, cabinet_rig())
    assert {b["name"]: b["mass_kg"] for b in layout["bodies"]} == {"cabinet": 70.0, "unit": 32.0}
    assert all(b["solver"] == "least-squares" and b["solver_problem"] is None for b in layout["bodies"])
    assert len(layout["springs"]) == 7


def test_a_softer_unit_mount_fitted_right_is_explained(tmp_path):
    """faults seed 202 (unit_mount1 x 0.7105, 30 N), only the stiffness effect tried: the right
    spring is fitted, and a project on the simulated rig's own file leaves nothing to explain, so
    the verdict should be 'explained'."""
    spec = next(s for s in calibrate.specs("faults", 3, ("cabinet",)) if s["seed"] == 202)
    case = calibrate.build(spec)
    truth = writers.to_jsonable(case.truth_document())
    rig = writers.write_rig_toml(tmp_path / "rig.toml", case.nominal)
    lvms = [writers.write_lvm(tmp_path / f"r{i:02d}.lvm", calibrate.without_unused(rec))
            for i, rec in enumerate(case.simulate())]
    project = calibrate.make_project(tmp_path, rig, lvms, truth)
    d = json.loads(calibrate.odsuite("diagnose", project, "--effect", "stiffness", "--json", "--workers", "1"))
    top = d["candidates"][0]
    assert top["effect"] == "stiffness" and top["significant"]
    assert top["parameters"]["scale_unit_mount1"] == pytest.approx(case.truth["effect"]["factor"], abs=0.02)
    assert d["baseline_error"] > 3 * d["noise_floor_error"]
    assert d["verdict"] == "explained", (d["verdict"], top["early_late_cells"])
