"""The rigid-multibody builder against App. B's printed matrices, Eq. 3.13-3.18 and python-control."""

from __future__ import annotations

import numpy as np
import pytest
from odsuite_plugins.models.thesis import (
    APP_B,
    APP_C_UNIT,
    dynamometer_springs,
    inertia_tensor,
    thesis_car_2dof,
    thesis_dynamometer,
)

from odsuite.domain.errors import ConfigError
from odsuite.domain.model import Input, Model, Output, RigidBody, SpringDamper


def app_b_k(kx, ky, kz, a, b, h):
    """App. B.1's k matrix as printed (kx etc. indexed 1..4 as kx[0..3])."""
    kx1, kx2, kx3, kx4 = kx
    ky1, ky2, ky3, ky4 = ky
    kz1, kz2, kz3, kz4 = kz
    sx, sy, sz = sum(kx), sum(ky), sum(kz)
    return np.array([
        [sx, 0, 0, 0, sx * h, (kx4 + kx3 - kx2 - kx1) * b],
        [0, sy, 0, -sy * h, 0, (-ky1 + ky2 - ky3 + ky4) * a],
        [0, 0, sz, (kz1 + kz2 - kz3 - kz4) * b, (kz1 - kz2 + kz3 - kz4) * a, 0],
        [0, -sy * h, (kz1 + kz2 - kz3 - kz4) * b, sz * b**2 + sy * h**2, (kz4 - kz2 + kz1 - kz3) * b * a,
         (-ky4 + ky3 + ky1 - ky2) * h * a],
        [sx * h, 0, (kz1 - kz2 + kz3 - kz4) * a, (kz4 - kz2 + kz1 - kz3) * b * a, sz * a**2 + sx * h**2,
         (kx4 + kx3 - kx2 - kx1) * h * b],
        [(kx4 + kx3 - kx2 - kx1) * b, (-ky1 + ky2 - ky3 + ky4) * a, 0, (-ky4 + ky3 + ky1 - ky2) * h * a,
         (kx4 + kx3 - kx2 - kx1) * h * b, sy * a**2 + sx * b**2]])


def app_b_c(cx, cy, cz, a, b, h):
    """App. B.1's c matrix as printed, with erratum 5 fixed (row 4, column 3: + cz1)."""
    cx1, cx2, cx3, cx4 = cx
    cy1, cy2, cy3, cy4 = cy
    cz1, cz2, cz3, cz4 = cz
    sx, sy, sz = sum(cx), sum(cy), sum(cz)
    return np.array([
        [sx, 0, 0, 0, sx * h, (cx3 - cx1 + cx4 - cx2) * b],
        [0, sy, 0, -sy * h, 0, (cy4 + cy2 - cy1 - cy3) * a],
        [0, 0, sz, (-cz4 - cz3 + cz2 + cz1) * b, (-cz4 - cz2 + cz1 + cz3) * a, 0],
        [0, -sy * h, (-cz4 - cz3 + cz2 + cz1) * b, sz * b**2 + sy * h**2, (-cz2 - cz3 + cz4 + cz1) * b * a,
         (cy3 + cy1 - cy2 - cy4) * h * a],
        [sx * h, 0, (-cz4 - cz2 + cz1 + cz3) * a, (-cz2 - cz3 + cz4 + cz1) * b * a, sz * a**2 + sx * h**2,
         (cx3 - cx1 + cx4 - cx2) * h * b],
        [(cx3 - cx1 + cx4 - cx2) * b, (cy4 + cy2 - cy1 - cy3) * a, 0, (cy3 + cy1 - cy2 - cy4) * h * a,
         (cx3 - cx1 + cx4 - cx2) * h * b, sy * a**2 + sx * b**2]])


def app_b_cu(ax, ay, az):
    return np.array([[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0],
                     [0, -az, ay, 1, 0, 0], [az, 0, -ax, 0, 1, 0], [-ay, ax, 0, 0, 0, 1]], float)


def _rel(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def test_k_and_c_from_geometry_equal_app_b_formulas_with_distinct_springs():
    rng = np.random.default_rng(1)
    a, b, h = APP_B["a"], APP_B["b"], APP_B["h"]
    k = rng.uniform(1e5, 2e6, (4, 3))  # distinct per spring and axis: every sign pattern shows
    c = rng.uniform(50, 500, (4, 3))
    body = RigidBody("platform", 2.714, np.diag([6e-3, 2.4e-3, 8.4e-3]))
    model = Model.build([body], dynamometer_springs(a, b, h, k, c))
    assert _rel(model.K, app_b_k(k[:, 0], k[:, 1], k[:, 2], a, b, h)) < 1e-12
    assert _rel(model.C, app_b_c(c[:, 0], c[:, 1], c[:, 2], a, b, h)) < 1e-12
    # the printed c (erratum 5 kept) is not symmetric and differs from geometry
    printed = app_b_c(c[:, 0], c[:, 1], c[:, 2], a, b, h)
    printed[3, 2] += -2 * c[0, 2] * b
    assert _rel(model.C, printed) > 1e-3


def test_thesis_model_matrices_are_app_b(thesis_rig):
    p = APP_B
    model = thesis_dynamometer(thesis_rig)
    m = np.zeros((6, 6))
    m[:3, :3] = p["mass"] * np.eye(3)
    m[3:, 3:] = [[p["Ixx"], -p["Ixy"], -p["Ixz"]], [-p["Ixy"], p["Iyy"], -p["Iyz"]], [-p["Ixz"], -p["Iyz"], p["Izz"]]]
    assert _rel(model.M, m) < 1e-12
    k4 = np.full(4, p["kx"]), np.full(4, p["ky"]), np.full(4, p["kz"])
    c4 = np.full(4, p["cx"]), np.full(4, p["cy"]), np.full(4, p["cz"])
    assert _rel(model.K, app_b_k(*k4, p["a"], p["b"], p["h"])) < 1e-12
    assert _rel(model.C, app_b_c(*c4, p["a"], p["b"], p["h"])) < 1e-12


def test_force_input_matrix_is_app_b_cu(thesis_rig):
    model = thesis_dynamometer(thesis_rig)
    r = np.array([-0.037325, -0.068141, -0.0114])  # Table 5.3, tests 6/7 (SI: erratum 4)
    forces = [Input.force(r, e) for e in np.eye(3)]
    moments = [Input.moment(e) for e in np.eye(3)]
    bf, bv = model.input_matrices(forces + moments)
    assert np.max(np.abs(bf - app_b_cu(*r))) < 1e-15
    assert not np.any(bv)


def test_state_space_is_eq_3_13_to_3_16_and_acceleration_needs_d(thesis_rig):
    model = thesis_dynamometer(thesis_rig)
    r = np.array([0.05, -0.0758, -0.0063])
    inp = Input.force(r, (-1, 0, 0))
    cu = app_b_cu(*r)[:, :1] * -1
    minv = np.linalg.inv(model.M)
    ss = model.state_space([inp], Output.coordinates("platform"))
    a_ref = np.block([[np.zeros((6, 6)), np.eye(6)], [-minv @ model.K, -minv @ model.C]])
    assert _rel(ss.A, a_ref) < 1e-13
    assert _rel(ss.B, np.vstack([np.zeros((6, 1)), minv @ cu])) < 1e-13
    assert np.array_equal(ss.C, np.hstack([np.eye(6), np.zeros((6, 6))]))
    assert not np.any(ss.D)
    acc = model.state_space([inp], Output.coordinates("platform", "acceleration"))
    assert _rel(acc.D, minv @ cu) < 1e-13


def test_transfer_matches_eq_3_18(thesis_rig):
    model = thesis_dynamometer(thesis_rig)
    r = np.array([-0.037325, -0.068141, -0.0114])
    inputs = [Input.force(r, e) for e in np.eye(3)]
    f = np.array([10.0, 97.0, 150.0, 228.0, 900.0])
    H = model.transfer(inputs, Output.coordinates("platform"), f)
    cu = app_b_cu(*r)[:, :3]
    for i, fi in enumerate(f):
        w = 2 * np.pi * fi
        ref = np.linalg.solve(-w * w * model.M + 1j * w * model.C + model.K, cu)
        assert _rel(H[i], ref) < 1e-10


def test_sensor_output_is_point_kinematics(thesis_rig):
    """A sensor's displacement is d + Theta x (p - G) along its axis, from the coordinates."""
    model = thesis_dynamometer(thesis_rig)
    inp = Input.force((0.0, 0.004122, -0.011399), (0, 0, 1))
    f = [120.0]
    Hd = model.transfer([inp], Output.coordinates("platform"), f)[0, :, 0]
    for s in thesis_rig.sensors:
        Hs = model.transfer([inp], [Output.sensor(s, "displacement")], f)[0, 0, 0]
        ref = s.axis @ (Hd[:3] + np.cross(Hd[3:], s.position))
        assert abs(Hs - ref) < 1e-12 * abs(Hd).max()


def test_dynamometer_modes_match_python_control(thesis_rig):
    control = pytest.importorskip("control")
    model = thesis_dynamometer(thesis_rig)
    modes = model.modes()
    assert len(modes) == 6
    # six modes between about 97 and 228 Hz (digest §1)
    assert 97.0 < modes.frequency_hz[0] < 98.0 and 227.0 < modes.frequency_hz[-1] < 228.0
    assert np.all(np.diff(modes.frequency_hz) > 0)
    ss = model.state_space([Input.moment((1, 0, 0))], Output.coordinates("platform"))
    wn, zeta, _ = control.damp(control.ss(ss.A, ss.B, ss.C, ss.D), doprint=False)
    order = np.argsort(wn)[::2]  # one pole of each conjugate pair
    assert np.allclose(modes.frequency_hz, wn[order] / (2 * np.pi), rtol=1e-9)
    assert np.allclose(modes.damping_ratio, zeta[order], rtol=1e-8)
    # each shape solves the quadratic eigenproblem
    for lam, phi in zip(modes.eigenvalues, modes.shapes.T):
        res = (lam**2 * model.M + lam * model.C + model.K) @ phi
        assert np.linalg.norm(res) < 1e-9 * np.linalg.norm(model.K @ phi)
        assert np.isclose(np.max(np.abs(phi)), 1.0)


def test_app_c_inertia_products_option(thesis_rig):
    b = thesis_dynamometer(thesis_rig)
    c = thesis_dynamometer(thesis_rig, inertia_products="app-c")
    I = c.M[3:, 3:]
    assert np.isclose(I[0, 1], 0.05 * APP_C_UNIT) and np.isclose(I[0, 2], 0.9 * APP_C_UNIT)
    assert np.isclose(I[1, 2], -0.9048 * APP_C_UNIT)
    assert np.allclose(np.diag(I), np.diag(b.M[3:, 3:]))
    # the products barely move the modes: under 0.01 %
    assert np.allclose(c.modes().frequency_hz, b.modes().frequency_hz, rtol=1e-4)
    with pytest.raises(ConfigError, match="inertia_products"):
        thesis_dynamometer(thesis_rig, inertia_products="app-d")


def test_car_2dof_reproduces_thesis_section_2_1():
    model = thesis_car_2dof()
    modes = model.modes()
    w = modes.frequency_hz * 2 * np.pi
    assert np.allclose(w, [6.90, 9.05], atol=0.006)
    assert np.allclose(modes.damping_ratio, 0.0, atol=1e-12)
    ratio = (modes.shapes[0] / modes.shapes[1]).real / 0.3048  # Z/Phi in ft/rad
    assert np.isclose(abs(ratio[0]), 14.6, atol=0.01) and np.isclose(abs(ratio[1]), 1.096, atol=0.01)
    assert ratio[0] * ratio[1] < 0  # erratum 11: opposite signs
    # closed form of the two equations of motion (Thomson): det = 0
    m, J, k1, k2, l1, l2 = 100.0, 1600.0, 2400.0, 2600.0, 4.5, 5.5
    poly = [m * J, -(m * (k1 * l1**2 + k2 * l2**2) + J * (k1 + k2)),
            (k1 + k2) * (k1 * l1**2 + k2 * l2**2) - (k2 * l2 - k1 * l1) ** 2]
    assert np.allclose(np.sort(np.sqrt(np.roots(poly))), w, rtol=1e-9)


@pytest.mark.parametrize("make, match", [
    (lambda: RigidBody("p", -1.0, np.eye(3)), "mass"),
    (lambda: RigidBody("p", 1.0, np.diag([1.0, 1.0, -1e-3])), "positive definite"),
    (lambda: RigidBody("p", 1.0, np.diag([1.0, 1.0, 1.0]), dofs=("q",)), "dofs"),
    (lambda: SpringDamper("s1", (0, 0, 0), None, None, (1, 1, 1)), "no attachment"),
    (lambda: Model.build([RigidBody("p", 1.0, np.eye(3))], [SpringDamper("s1", (0, 0, 0), "q", None, (1, 1, 1))]),
     "unknown body 'q'"),
    (lambda: SpringDamper("s1", (0, 0, 0), "p", None, (1, -1, 1)), "stiffness"),
])
def test_invalid_models_are_refused(make, match):
    with pytest.raises(ConfigError, match=match):
        make()


def test_inertia_tensor_convention():
    assert np.array_equal(inertia_tensor(1, 2, 3, 4, 5, 6), [[1, -4, -6], [-4, 2, -5], [-6, -5, 3]])


def _sdof():
    """One body moving along z on one spring-damper to the ground: (model, m, c, k, f, w)."""
    m, c, k = 2.0, 30.0, 8e5
    model = Model.build([RigidBody("m", m, np.eye(3), dofs=("z",))],
                        [SpringDamper("k", (0, 0, 0.1), "m", None, (0, 0, k), (0, 0, c))])
    f = np.array([5.0, 80.0, 100.7, 300.0])
    return model, m, c, k, f, 2 * np.pi * f


def test_base_translation_gives_sdof_transmissibility():
    model, m, c, k, f, w = _sdof()
    base = [Input.base_translation((0, 0, 1))]
    disp = model.transfer(base, [Output.at_point((0, 0, 0), (0, 0, 1), "displacement")], f)[:, 0, 0]
    vel = model.transfer(base, [Output.at_point((0, 0, 0), (0, 0, 1), "velocity")], f)[:, 0, 0]
    ref = (k + 1j * w * c) / (k - m * w * w + 1j * w * c)
    assert np.allclose(disp, ref, rtol=1e-12)
    assert np.allclose(vel, 1j * w * ref, rtol=1e-12)  # the D term of the damper path
    with pytest.raises(ConfigError, match="base-motion"):
        model.state_space(base, [Output.at_point((0, 0, 0), (0, 0, 1), "acceleration")])


def test_ground_acceleration_gives_sdof_transmissibility():
    """Relative coordinates driven by -M T a_g, absolute acceleration out: the 1-DOF closed form."""
    model, m, c, k, f, w = _sdof()
    acc = model.transfer([Input.ground_acceleration((0, 0, 1))],
                         [Output.at_point((0, 0, 0), (0, 0, 1), "acceleration")], f)[:, 0, 0]
    assert np.allclose(acc, (k + 1j * w * c) / (k - m * w * w + 1j * w * c), rtol=1e-12)
    with pytest.raises(ConfigError, match="only acceleration outputs"):
        model.state_space([Input.ground_acceleration((0, 0, 1))], [Output.at_point((0, 0, 0), (0, 0, 1), "velocity")])
    with pytest.raises(ConfigError, match="give one of them"):
        model.state_space([Input.ground_acceleration((0, 0, 1)), Input.base_translation((0, 0, 1))],
                          [Output.at_point((0, 0, 0), (0, 0, 1), "acceleration")])


def test_ground_acceleration_matches_the_absolute_base_motion_path():
    """The thesis rig (6 DOF, springs off its centre of mass) under the ground's translations and
    rotations about the rig origin: absolute acceleration per ground acceleration (relative
    coordinates, -M T a_g) equals absolute velocity per ground displacement / (i w) from the
    springs' and dampers' ground forces Kg u + Cg u' (absolute coordinates)."""
    model = thesis_dynamometer()
    f = np.array([20.0, 97.0, 150.0, 222.0, 400.0])
    w = 2 * np.pi * f
    axes = np.eye(3)
    points = [((0.03, 0.07, -0.01), (1, 1, 0.3)), ((-0.04, 0.02, 0.05), (0, 0, 1))]
    acc_out = [Output.at_point(p, d, "acceleration") for p, d in points]
    vel_out = [Output.at_point(p, d, "velocity") for p, d in points]
    rel = model.transfer([Input.ground_acceleration(a) for a in axes]
                         + [Input.ground_angular_acceleration(a) for a in axes], acc_out, f)
    absolute = model.transfer([Input.base_translation(a) for a in axes]
                              + [Input.base_rotation(a) for a in axes], vel_out, f)
    np.testing.assert_allclose(rel, absolute / (1j * w)[:, None, None], rtol=1e-9, atol=1e-12)
    # far below the modes the rig moves with the ground: the rigid acceleration at the point
    low = model.transfer([Input.ground_angular_acceleration((1, 0, 0))], acc_out, [0.01])[0, :, 0]
    rigid = [np.cross((1, 0, 0), p) @ (np.asarray(d) / np.linalg.norm(d)) for p, d in points]
    np.testing.assert_allclose(low, rigid, rtol=1e-6)
