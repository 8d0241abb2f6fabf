"""Rigid-body transforms against closed forms, scipy's rotations and rigid invariants."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from odsuite.domain import rigidbody as rb
from odsuite.domain.errors import ConfigError, DimensionError

finite = st.floats(-1.0, 1.0, allow_nan=False)
lengths = st.floats(-0.5, 0.5, allow_nan=False)


@st.composite
def poses(draw, max_angle=3.0):
    t = draw(arrays(float, 3, elements=lengths))
    theta, psi = draw(st.floats(-max_angle, max_angle)), draw(st.floats(-max_angle, max_angle))
    phi = draw(st.floats(-min(max_angle, 1.5), min(max_angle, 1.5)))  # |phi| < pi/2: unique angles
    return np.concatenate([t, [theta, phi, psi]])


points = arrays(float, (5, 3), elements=lengths)


def test_rotation_is_intrinsic_zyx_as_scipy():
    rng = np.random.default_rng(0)
    angles = rng.uniform(-3, 3, (50, 3))
    ref = Rotation.from_euler("ZYX", angles[:, ::-1]).as_matrix()  # intrinsic: Rz(psi) Ry(phi) Rx(theta)
    np.testing.assert_allclose(rb.rotation_matrix(angles), ref, atol=1e-14)


def test_elementary_rotations_turn_axes_the_right_hand_way():
    q = np.pi / 2
    # Eq. 4.16-4.18: psi about z takes x to y, phi about y takes z to x, theta about x takes y to z
    np.testing.assert_allclose(rb.rotation_matrix([0, 0, q]) @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(rb.rotation_matrix([0, q, 0]) @ [0, 0, 1], [1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(rb.rotation_matrix([q, 0, 0]) @ [0, 1, 0], [0, 0, 1], atol=1e-15)


def test_translation_matrix_is_identity_plus_offset():
    # erratum 1: Eq. 4.19 printed a zero diagonal, which would send every point to (x, y, z)
    T = rb.transform([0.1, -0.2, 0.3, 0, 0, 0])
    np.testing.assert_array_equal(T[:3, :3], np.eye(3))
    np.testing.assert_allclose(T @ [1.0, 2.0, 3.0, 1.0], [1.1, 1.8, 3.3, 1.0])


def test_vectorised_over_time_equals_one_pose_at_a_time():
    rng = np.random.default_rng(1)
    d = rng.uniform(-1, 1, (7, 6))
    p = rng.uniform(-1, 1, (4, 3))
    T = rb.transform(d)
    assert T.shape == (7, 4, 4)
    moved = rb.transform_points(d, p)
    assert moved.shape == (7, 4, 3)
    for i in range(7):
        np.testing.assert_allclose(T[i], rb.transform(d[i]))
        np.testing.assert_allclose(moved[i], (T[i] @ np.c_[p, np.ones(4)].T).T[:, :3])


@settings(max_examples=60, deadline=None)
@given(poses(), points)
def test_distances_between_points_preserved(d, p):
    moved = rb.transform_points(d, p)
    before = np.linalg.norm(p[:, None] - p[None], axis=-1)
    after = np.linalg.norm(moved[:, None] - moved[None], axis=-1)
    np.testing.assert_allclose(after, before, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(poses())
def test_inverse_and_pose_round_trip(d):
    T = rb.transform(d)
    np.testing.assert_allclose(rb.inverse_transform(T) @ T, np.eye(4), atol=1e-12)
    np.testing.assert_allclose(rb.inverse_transform(T), np.linalg.inv(T), atol=1e-12)
    np.testing.assert_allclose(rb.transform(rb.pose_from_transform(T)), T, atol=1e-12)
    if abs(d[4]) < 1.4 and np.all(np.abs(d[[3, 5]]) < 3.1):
        np.testing.assert_allclose(rb.pose_from_transform(T), d, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(poses(), arrays(float, 3, elements=lengths))
def test_corner_com_round_trip(d, r_cg):
    d_g = rb.corner_to_com(d, r_cg)
    np.testing.assert_allclose(d_g[3:], d[3:])
    np.testing.assert_allclose(rb.com_to_corner(d_g, r_cg), d, atol=1e-12)


def test_corner_to_com_closed_form_quarter_turn():
    # yaw 90 deg about C: G at (a, b, c) from C goes to (-b, a, c), so it moves by (-b - a, a - b, 0)
    a, b, c = 0.05003, 0.08084, 0.0114  # lG, wG, hG of App. C
    d_c = np.array([1e-3, 2e-3, 3e-3, 0, 0, np.pi / 2])
    d_g = rb.corner_to_com(d_c, [a, b, c])
    np.testing.assert_allclose(d_g[:3], [1e-3 - b - a, 2e-3 + a - b, 3e-3], atol=1e-15)
    # erratum 3: Eq. 4.30 prints [-wG, -lG, -hG]; swapping l and w does not return to C
    assert not np.allclose(rb._move_reference(d_g, [-b, -a, -c]), d_c)


@settings(max_examples=60, deadline=None)
@given(st.floats(1e-4, 1e-1), arrays(float, 6, elements=finite), points)
def test_small_angle_form_is_second_order(scale, direction, r):
    d = np.r_[direction[:3] * 1e-3, direction[3:] * scale]
    err = np.linalg.norm(rb.point_displacements(d, r) - rb.point_displacements(d, r, linear=True), axis=-1)
    # expanding Rz Ry Rx to second order: |R - I - [Theta]x| <= |Theta|^2 (half from [Theta]x^2,
    # at most half from the non-commuting products); 20 % margin for third-order terms
    assert np.all(err <= 1.2 * np.sum(d[3:] ** 2) * np.linalg.norm(r, axis=-1) + 1e-15)


def test_small_angle_error_shrinks_with_the_square_of_the_angle():
    r = np.array([[0.1, 0.2, 0.03]])
    errs = [np.abs(rb.point_displacements(d, r) - rb.point_displacements(d, r, linear=True)).max()
            for d in (np.r_[0, 0, 0, 1e-2, -2e-2, 3e-2], np.r_[0, 0, 0, 1e-3, -2e-3, 3e-3])]
    assert errs[0] > 1e-6 and errs[0] / errs[1] == pytest.approx(100, rel=0.05)


def test_plate_corners_and_plot_order(thesis_rig):
    plate = thesis_rig.body("platform").plate
    corners = rb.plate_corners(plate)
    named = dict(zip(rb.CORNER_NAMES, corners))
    l, w, h = plate.size
    np.testing.assert_allclose(named["FLL"], plate.corner)  # Table 4.1: FLL = C
    np.testing.assert_allclose(named["RRU"] - named["FLL"], [l, w, h])
    np.testing.assert_allclose(named["FRU"] - named["FLL"], [l, 0, h])
    # the thesis platform's corner C sits at -(lG, wG, hG) from G and the box is centred on G
    np.testing.assert_allclose(corners.mean(axis=0), [l / 2 - 0.0500253, w / 2 - 0.08084058, h / 2 - 0.01139952])
    # Table 4.2 traces all 12 box edges and only edges
    box_edges = {frozenset(pair) for pair in itertools.combinations(rb.CORNER_NAMES, 2)
                 if sum(a != b for a, b in zip(rb.CORNERS[pair[0]], rb.CORNERS[pair[1]])) == 1}
    traced = {frozenset(pair) for pair in zip(rb.PLOT_ORDER, rb.PLOT_ORDER[1:])}
    assert len(box_edges) == 12 and traced == box_edges
    assert [rb.CORNER_NAMES[i] for i in rb.PLOT_INDEX] == list(rb.PLOT_ORDER)


def test_body_corners_follow_the_pose(thesis_rig):
    body = thesis_rig.body("platform")
    rest = rb.plate_corners(body.plate)
    np.testing.assert_allclose(rb.body_corners(body, np.zeros(6)), rest)
    d = np.array([[1e-3, 0, 0, 0, 0, 0], [0, 0, 0, 0.2, -0.1, 0.3]])
    moved = rb.body_corners(body, d)
    np.testing.assert_allclose(moved[0], rest + [1e-3, 0, 0])
    # the centre of mass does not move under a rotation about it
    np.testing.assert_allclose(moved[1].mean(axis=0) - rest.mean(axis=0),
                               rb.rotation_matrix(d[1, 3:]) @ (rest.mean(0) - body.com) - (rest.mean(0) - body.com),
                               atol=1e-15)
    with pytest.raises(ConfigError, match="no plate"):
        rb.body_corners(type(body)(name="bare", com=np.zeros(3)), np.zeros(6))


def _large_motion(t):
    amp = np.array([[2e-3, 1e-3], [1e-3, 3e-3], [2e-3, 2e-3], [0.3, 0.2], [0.2, 0.3], [0.4, 0.1]])
    return rb.harmonic_motion(t, amp, [3.0, 7.0], [[0.1, 1.0]] * 6)


def test_harmonic_motion_derivatives_match_finite_differences():
    h = 1e-5
    t = np.linspace(0, 0.5, 11)
    d, dd, ddd = _large_motion(t)
    dp, ddp, _ = _large_motion(t + h)
    dm, ddm, _ = _large_motion(t - h)
    # central differences err by h^2 w^3 A / 6 ~ 1e-6 here
    np.testing.assert_allclose(dd, (dp - dm) / (2 * h), atol=2e-6)
    np.testing.assert_allclose(ddd, (ddp - ddm) / (2 * h), atol=1e-4)


def test_sensor_signals_match_finite_differences_at_large_angles(thesis_rig):
    """Exact kinematics, including omega x (omega x r), checked by differencing positions."""
    body = thesis_rig.body("platform")
    sensors = rb.body_sensors(thesis_rig, body)
    r = np.array([s.position for s in sensors]) - body.com
    axes = np.array([s.axis for s in sensors])
    t = np.linspace(0.01, 0.4, 9)
    h = 1e-4
    d, dd, ddd = _large_motion(t)
    # five-point stencils: truncation O(h^4 w^4) ~ 1e-12 relative
    m2, m1, p0, p1, p2 = (rb.transform_points(_large_motion(t + k * h)[0], r) for k in (-2, -1, 0, 1, 2))
    vel_fd = (m2 - 8 * m1 + 8 * p1 - p2) / (12 * h)
    acc_fd = (-m2 + 16 * m1 - 30 * p0 + 16 * p1 - p2) / (12 * h**2)
    R = rb.rotation_matrix(d[:, 3:])
    disp = rb.sensor_signals(thesis_rig, body, d)
    vel = rb.sensor_signals(thesis_rig, body, d, "velocity", d_g_dot=dd)
    acc = rb.sensor_signals(thesis_rig, body, d, "acceleration", d_g_dot=dd, d_g_ddot=ddd)
    for i, s in enumerate(sensors):
        np.testing.assert_allclose(disp[s.name], (p0[:, i] - r[i]) @ axes[i], atol=1e-15)
        np.testing.assert_allclose(vel[s.name], vel_fd[:, i] @ axes[i], rtol=1e-8, atol=1e-10)
        body_axis = R @ axes[i]
        np.testing.assert_allclose(acc[s.name], np.einsum("ni,ni->n", acc_fd[:, i], body_axis),
                                   rtol=1e-6, atol=1e-6)


def test_sensor_signals_errors(thesis_rig):
    body = thesis_rig.body("platform")
    with pytest.raises(ConfigError, match="needs d_g_dot and d_g_ddot"):
        rb.sensor_signals(thesis_rig, body, np.zeros((3, 6)), "acceleration")
    with pytest.raises(ConfigError, match="quantity"):
        rb.sensor_signals(thesis_rig, body, np.zeros((3, 6)), "jerk")
    with pytest.raises(ConfigError, match="body 'base' carries no sensors"):
        rb.sensor_signals(thesis_rig, thesis_rig.body("base"), np.zeros((3, 6)))
    with pytest.raises(DimensionError, match=r"\(6,\) or \(n, 6\)"):
        rb.transform(np.zeros((3, 5)))
