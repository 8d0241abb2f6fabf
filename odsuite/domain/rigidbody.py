"""Rigid-body geometry: poses, homogeneous transforms, plate corners and sensor readings.

Convention (used everywhere in odsuite):

* Generalized coordinates ``d = [x, y, z, theta, phi, psi]`` (m, rad) are the DISPLACEMENT of a
  reference point of a body from its rest position and the body's rotation from rest, both in the
  rig frame (whose axes are the body axes at rest). ``d`` is zero at rest.
* ``R = Rz(psi) @ Ry(phi) @ Rx(theta)`` (thesis Eq. 4.16-4.18 and the order of Eq. 4.20 read as
  "yaw, then pitch about the new y, then roll about the newest x"). The homogeneous transform is
  ``T(d) = [[R, t], [0, 1]]`` with ``t = [x, y, z]``: the translation matrix of Eq. 4.19 is the
  identity with ``t`` in the last column (erratum 1 of the thesis, which prints a zero diagonal).
* A body point whose rest vector from the reference point is ``r`` (body axes) is at
  ``T(d) @ [r, 1]`` relative to the reference point's rest position, i.e. it moves by
  ``t + (R - I) r``; for small angles by ``t + Theta x r`` with ``Theta = [theta, phi, psi]``.
* Corner C <-> centre of mass G (Eq. 4.26-4.30): with ``r_cg`` the rest vector C -> G in body axes,
  ``T(d_C) @ [r_cg, 1]`` is where G is relative to C at rest (Eq. 4.26-4.27); subtracting ``r_cg``
  gives G's displacement. The way back uses ``-r_cg`` (Eq. 4.29), i.e. ``[-lG, -wG, -hG]`` — the
  thesis prints ``[-wG, -lG, -hG]`` in Eq. 4.30 (erratum 3).

Every function accepts one pose ``(6,)`` or a time series ``(n, 6)`` and is vectorised over time.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from odsuite.domain.errors import ConfigError, DimensionError
from odsuite.domain.rig import COORDINATES as COORDINATES  # the coordinates a body has, named here too
from odsuite.domain.rig import body_sensors as body_sensors  # a question to the rig, named here too
from odsuite.domain.rig import Body, Plate, Rig

#: SI units of the six generalized coordinates, in storage order.
COORDINATE_UNITS = ("m", "m", "m", "rad", "rad", "rad")

#: Table 4.1: corner name -> its vector from the plate's corner C, in units of the plate size
#: (l, w, h along body x, y, z). "Upper" is the face at z = h; in a z-down rig frame (the thesis
#: rig) that face is physically the lower one, but the names follow the table.
CORNERS: dict[str, tuple[int, int, int]] = {
    "FRU": (1, 0, 1), "FRL": (1, 0, 0), "FLU": (0, 0, 1), "FLL": (0, 0, 0),
    "RRU": (1, 1, 1), "RRL": (1, 1, 0), "RLU": (0, 1, 1), "RLL": (0, 1, 0),
}
CORNER_NAMES = tuple(CORNERS)

#: Table 4.2: one polyline through the corners that draws all 12 edges of the box.
PLOT_ORDER = ("FRL", "RRL", "RRU", "RRL", "RLL", "RLU", "RLL", "FLL",
              "FLU", "FLL", "FRL", "FRU", "RRU", "RLU", "FLU", "FRU")
#: PLOT_ORDER as indices into CORNER_NAMES (and into the rows of ``plate_corners``).
PLOT_INDEX = tuple(CORNER_NAMES.index(c) for c in PLOT_ORDER)

QUANTITIES = ("displacement", "velocity", "acceleration")


@dataclass(frozen=True)
class SolverResult:
    """Generalized coordinates of one body from a coordinate solver.

    ``at_c``: (n, 6) at the sensor corner C (None when the body has no corner);
    ``at_g``: (n, 6) at the centre of mass G; ``condition_number`` of the linear map from
    coordinates to sensor signals (None when the solver uses a closed formula);
    ``residual``: RMS of the part of the signals a rigid motion cannot explain, as a fraction of
    their RMS (None when the layout has no redundancy to measure it); ``sensors``: names used.
    """

    at_c: np.ndarray | None
    at_g: np.ndarray
    condition_number: float | None = None
    residual: float | None = None
    sensors: tuple[str, ...] = ()


@dataclass(frozen=True)
class Rigidity:
    """Disagreement of redundant measurements of the angular motion, per axis.

    ``fractions[axis]`` = RMS(estimate 1 - estimate 2) / RMS(their mean), axis in "x", "y", "z";
    ``flagged`` the axes above ``threshold``; ``worst`` says in words which pair disagrees most and
    which sensors could explain the flagged pattern.
    """

    fractions: dict[str, float]
    threshold: float
    flagged: tuple[str, ...]
    worst: str
    suspects: tuple[str, ...] = field(default=())

    @property
    def ok(self) -> bool:
        return not self.flagged


def _poses(d: np.ndarray, what: str = "d") -> np.ndarray:
    d = np.asarray(d, dtype=float)
    if d.shape[-1:] != (6,) or d.ndim not in (1, 2):
        raise DimensionError(f"{what}: expected generalized coordinates of shape (6,) or (n, 6), got {d.shape}")
    return d


def _skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices [v]x of shape (..., 3, 3)."""
    v = np.asarray(v, dtype=float)
    z = np.zeros(v.shape[:-1])
    return np.stack([np.stack([z, -v[..., 2], v[..., 1]], -1),
                     np.stack([v[..., 2], z, -v[..., 0]], -1),
                     np.stack([-v[..., 1], v[..., 0], z], -1)], -2)


_GENERATORS = _skew(np.eye(3))  # Kx, Ky, Kz: d/dq R_i(q) = R_i(q) K_i


def _elementary(q: np.ndarray, axis: int) -> np.ndarray:
    c, s = np.cos(q), np.sin(q)
    o, z = np.ones_like(q), np.zeros_like(q)
    rows = {
        0: [[o, z, z], [z, c, -s], [z, s, c]],   # Eq. 4.18
        1: [[c, z, s], [z, o, z], [-s, z, c]],   # Eq. 4.17
        2: [[c, -s, z], [s, c, z], [z, z, o]],   # Eq. 4.16
    }[axis]
    return np.stack([np.stack(r, -1) for r in rows], -2)


def rotation_matrix(angles: np.ndarray) -> np.ndarray:
    """``Rz(psi) Ry(phi) Rx(theta)`` for angles ``[theta, phi, psi]`` of shape (..., 3)."""
    a = np.asarray(angles, dtype=float)
    return _elementary(a[..., 2], 2) @ _elementary(a[..., 1], 1) @ _elementary(a[..., 0], 0)


def transform(d: np.ndarray) -> np.ndarray:
    """Homogeneous transform(s) ``[[R, t], [0, 1]]``: (6,) -> (4, 4), (n, 6) -> (n, 4, 4)."""
    d = _poses(d)
    out = np.zeros(d.shape[:-1] + (4, 4))
    out[..., :3, :3] = rotation_matrix(d[..., 3:])
    out[..., :3, 3] = d[..., :3]
    out[..., 3, 3] = 1.0
    return out


def inverse_transform(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid homogeneous transform(s) (..., 4, 4), using R^T rather than a solve."""
    T = np.asarray(T, dtype=float)
    out = np.zeros_like(T)
    rt = np.swapaxes(T[..., :3, :3], -1, -2)
    out[..., :3, :3] = rt
    out[..., :3, 3] = -(rt @ T[..., :3, 3, None])[..., 0]
    out[..., 3, 3] = 1.0
    return out


def pose_from_transform(T: np.ndarray) -> np.ndarray:
    """Generalized coordinates of rigid transform(s) (..., 4, 4); unique for |phi| < pi/2."""
    T = np.asarray(T, dtype=float)
    R = T[..., :3, :3]
    theta = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    phi = np.arctan2(-R[..., 2, 0], np.hypot(R[..., 2, 1], R[..., 2, 2]))
    psi = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    return np.concatenate([T[..., :3, 3], np.stack([theta, phi, psi], -1)], -1)


def transform_points(d: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Positions ``t + R p`` of body points ``p`` (k, 3) given relative to the reference point.

    d (6,) -> (k, 3); d (n, 6) -> (n, k, 3). Positions are relative to the reference point's
    rest position.
    """
    d = _poses(d)
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise DimensionError(f"points: expected shape (k, 3), got {p.shape}")
    R = rotation_matrix(d[..., 3:])
    return np.einsum("...ij,kj->...ki", R, p) + d[..., None, :3]


def point_displacements(d: np.ndarray, r: np.ndarray, *, linear: bool = False) -> np.ndarray:
    """Displacements of body points with rest vectors ``r`` (k, 3) from the reference point.

    Finite rotation: ``t + (R - I) r``; ``linear=True``: the small-angle form ``t + Theta x r``.
    Shapes as :func:`transform_points`.
    """
    d = _poses(d)
    r = np.asarray(r, dtype=float)
    if linear:
        if r.ndim != 2 or r.shape[1] != 3:
            raise DimensionError(f"r: expected shape (k, 3), got {r.shape}")
        return d[..., None, :3] + np.cross(d[..., None, 3:], r)
    return transform_points(d, r) - r


def _move_reference(d: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Pose at point A -> pose at point B, with ``r`` the rest vector A -> B (body axes)."""
    d = _poses(d)
    r = np.asarray(r, dtype=float)
    if r.shape != (3,):
        raise DimensionError(f"reference vector: expected shape (3,), got {r.shape}")
    out = d.copy()
    # Eq. 4.26: T(d_A) [r, 1] is B relative to A's rest position; minus r: B's displacement
    out[..., :3] = (transform(d) @ np.append(r, 1.0))[..., :3] - r
    return out


def corner_to_com(d_c: np.ndarray, r_cg: np.ndarray) -> np.ndarray:
    """Generalized coordinates at G from those at corner C (Eq. 4.26-4.28); r_cg = C -> G at rest."""
    return _move_reference(d_c, r_cg)


def com_to_corner(d_g: np.ndarray, r_cg: np.ndarray) -> np.ndarray:
    """Generalized coordinates at corner C from those at G (Eq. 4.29-4.30 with l, w in order)."""
    return _move_reference(d_g, -np.asarray(r_cg, dtype=float))


def plate_corners(plate: Plate) -> np.ndarray:
    """The 8 rest corners (8, 3) of a plate in the rig frame, rows in CORNER_NAMES order."""
    return plate.corner + np.array(list(CORNERS.values()), dtype=float) * plate.size


def body_corners(body: Body, d_g: np.ndarray) -> np.ndarray:
    """Rig-frame corners of a body's plate in pose(s) ``d_g`` at G: (8, 3) or (n, 8, 3)."""
    if body.plate is None:
        raise ConfigError(f"body {body.name!r} has no plate to draw")
    rest = plate_corners(body.plate)
    return body.com + transform_points(d_g, rest - body.com)


def harmonic_motion(t: np.ndarray, amplitude: np.ndarray, frequency: np.ndarray,
                    phase: np.ndarray | float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sums of sinusoids in each coordinate and their exact first and second time derivatives.

    ``amplitude`` (6, k) in m / rad, ``frequency`` (k,) or (6, k) in Hz, ``phase`` scalar or
    broadcastable to (6, k) in rad; ``t`` (n,) in s. Returns ``d, d_dot, d_ddot``, each (n, 6):
    ``d_j(t) = sum_k A_jk sin(2 pi f_jk t + p_jk)``.
    """
    t = np.asarray(t, dtype=float)[:, None, None]
    A = np.asarray(amplitude, dtype=float)
    if A.ndim != 2 or A.shape[0] != 6:
        raise DimensionError(f"amplitude: expected shape (6, k), got {A.shape}")
    w = 2 * np.pi * np.broadcast_to(np.asarray(frequency, dtype=float), A.shape)
    arg = w * t + np.broadcast_to(phase, A.shape)
    return ((A * np.sin(arg)).sum(-1), (A * w * np.cos(arg)).sum(-1),
            (-A * w**2 * np.sin(arg)).sum(-1))


def _rotation_derivatives(angles, rates, accels):
    """R, dR/dt and d2R/dt2 for angle time series (n, 3) with their first and second derivatives."""
    mats, firsts, seconds = [], [], []
    for axis in (2, 1, 0):  # R = Rz(psi) Ry(phi) Rx(theta)
        M = _elementary(angles[:, axis], axis)
        K = _GENERATORS[axis]
        q1, q2 = rates[:, axis, None, None], accels[:, axis, None, None]
        mats.append(M)
        firsts.append(M @ K * q1)
        seconds.append(M @ K @ K * q1**2 + M @ K * q2)
    (A, B, C), (dA, dB, dC), (ddA, ddB, ddC) = mats, firsts, seconds
    R = A @ B @ C
    dR = dA @ B @ C + A @ dB @ C + A @ B @ dC
    ddR = (ddA @ B @ C + A @ ddB @ C + A @ B @ ddC
           + 2 * (dA @ dB @ C + dA @ B @ dC + A @ dB @ dC))
    return R, dR, ddR


def sensor_signals(rig: Rig, body: Body, d_g: np.ndarray, quantity: str = "displacement", *,
                   d_g_dot: np.ndarray | None = None,
                   d_g_ddot: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Exact single-axis sensor signals of a body moving with generalized coordinates ``d_g`` at G.

    ``d_g`` (n, 6); ``d_g_dot``, ``d_g_ddot`` are its time derivatives (the Euler-angle rates, not
    the body angular velocity), needed for ``velocity`` and ``acceleration``. Returns
    ``{sensor name: (n,)}`` in SI units along each sensor's axis, with the positive sense of the
    axis (the rig's ``sign`` is not applied: these are the sign-corrected physical signals).

    * ``acceleration``: what a body-fixed accelerometer reads (gravity excluded): the point's
      acceleration ``t'' + R'' r`` projected on the axis as carried by the body, ``R a``. This
      contains the omega x (omega x r) terms of Eq. 4.11 exactly.
    * ``displacement`` and ``velocity``: the point's motion projected on the rest axis ``a`` (what
      the linear theory and the double integration of the reading approximate; they differ from
      the integrated reading by terms of order angle x displacement).
    """
    if quantity not in QUANTITIES:
        raise ConfigError(f"quantity: expected one of {', '.join(QUANTITIES)}, got {quantity!r}")
    d = _poses(d_g, "d_g")
    if d.ndim == 1:
        d = d[None]
    sensors = body_sensors(rig, body)
    if not sensors:
        raise ConfigError(f"rig {rig.name!r}: body {body.name!r} carries no sensors")
    r = np.array([s.position for s in sensors]) - body.com
    axes = np.array([s.axis for s in sensors])
    if quantity == "displacement":
        values = np.einsum("nki,ki->nk", point_displacements(d, r), axes)
    else:
        if d_g_dot is None or (quantity == "acceleration" and d_g_ddot is None):
            need = "d_g_dot" if quantity == "velocity" else "d_g_dot and d_g_ddot"
            raise ConfigError(f"sensor_signals: quantity {quantity!r} needs {need}")
        dot = _poses(d_g_dot, "d_g_dot").reshape(d.shape)
        ddot = np.zeros_like(d) if d_g_ddot is None else _poses(d_g_ddot, "d_g_ddot").reshape(d.shape)
        R, dR, ddR = _rotation_derivatives(d[:, 3:], dot[:, 3:], ddot[:, 3:])
        if quantity == "velocity":
            v = dot[:, None, :3] + np.einsum("nij,kj->nki", dR, r)
            values = np.einsum("nki,ki->nk", v, axes)
        else:
            a = ddot[:, None, :3] + np.einsum("nij,kj->nki", ddR, r)
            values = np.einsum("nki,nij,kj->nk", a, R, axes)
    return {s.name: values[:, i] for i, s in enumerate(sensors)}


def stack_signals(signals: Mapping[str, np.ndarray], names: tuple[str, ...], where: str) -> np.ndarray:
    """Columns (n, len(names)) of named 1-D signals of equal length; errors name what is missing."""
    missing = [n for n in names if n not in signals]
    if missing:
        raise ConfigError(f"{where}: no signal for sensor(s) {', '.join(missing)}")
    cols = [np.asarray(signals[n], dtype=float) for n in names]
    lengths = {c.shape for c in cols}
    if len(lengths) != 1 or cols[0].ndim != 1:
        shapes = ", ".join(f"{n}: {c.shape}" for n, c in zip(names, cols))
        raise DimensionError(f"{where}: sensor signals must be 1-D of equal length, got {shapes}")
    return np.stack(cols, axis=1)
