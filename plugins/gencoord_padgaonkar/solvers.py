"""Coordinate solvers: processed sensor signals -> generalized coordinates of one rigid body.

Both solvers take signals already in physical units along each sensor's positive axis (the
Systeminfo chain has undone the sign the raw volts carry) and treat them as displacements; being
linear in the signals, the angle formulas apply unchanged to velocities and accelerations.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from odsuite.api import ConfigError
from odsuite.api import COORDINATES, NINE_ROLES, Body, NineSensorSet, Rig, body_sensors

# the kinematics (SolverResult, Rigidity, the transforms) are imported by the functions that solve:
# choosing a solver (``suitability``, which `odsuite info` asks) needs the rig alone

#: How far (m) a sensor may sit from its corner of the nine-sensor set.
POSITION_TOLERANCE = 1e-3

# role -> (corner offset in units of (rx, ry, rz), body axis index)
_ROLE_GEOMETRY = {
    "xC": ((0, 0, 0), 0), "yC": ((0, 0, 0), 1), "zC": ((0, 0, 0), 2),
    "x1": ((0, 1, 0), 0), "z1": ((0, 1, 0), 2),
    "y2": ((1, 0, 0), 1), "z2": ((1, 0, 0), 2),
    "x3": ((0, 0, 1), 0), "y3": ((0, 0, 1), 1),
}

# Eq. 4.12: the two estimates of each angular component, as (sign, far role, corner-C role, spacing)
_PAIRS = {
    "x": ((+1, "z1", "zC", "ry", "4.12a"), (-1, "y3", "yC", "rz", "4.12d")),
    "y": ((-1, "z2", "zC", "rx", "4.12b"), (+1, "x3", "xC", "rz", "4.12e")),
    "z": ((+1, "y2", "yC", "rx", "4.12c"), (-1, "x1", "xC", "ry", "4.12f")),
}


def _term(sign: int, far: str, near: str, spacing: str) -> str:
    return f"{'-' if sign < 0 else ''}({far} - {near})/{spacing}"


def _nine_set(rig: Rig, body: Body) -> NineSensorSet:
    nine = body.nine_sensor_set
    if nine is None:
        raise ConfigError(
            f"rig {rig.name!r}: body {body.name!r} has no nine_sensor_set; "
            "use the 'least-squares' solver for other sensor layouts"
        )
    return nine


def _role_columns(rig: Rig, body: Body, nine: NineSensorSet,
                  signals: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Signals of the nine roles along the body's +x, +y or +z axis, after checking the layout."""
    from odsuite.api import stack_signals

    names = tuple(nine.sensors[r] for r in NINE_ROLES)
    where = f"rig {rig.name!r} body {body.name!r} nine_sensor_set"
    columns = stack_signals(signals, names, where)
    spacing = np.array([nine.rx, nine.ry, nine.rz])
    out = {}
    for i, role in enumerate(NINE_ROLES):
        sensor = rig.sensor(names[i])
        offset, axis = _ROLE_GEOMETRY[role]
        if sensor.body != body.name:
            raise ConfigError(f"{where}: role {role} sensor {sensor.name!r} is on body {sensor.body!r}")
        expected = nine.corner + np.array(offset) * spacing
        miss = np.linalg.norm(sensor.position - expected)
        if miss > POSITION_TOLERANCE:
            raise ConfigError(
                f"{where}: role {role} sensor {sensor.name!r} at {np.round(sensor.position * 1e3, 2).tolist()} mm "
                f"is {miss * 1e3:.2f} mm from where the set puts it ({np.round(expected * 1e3, 2).tolist()} mm); "
                "fix the rig file or use the 'least-squares' solver"
            )
        along = sensor.axis[axis]
        if abs(along) < 0.999:
            raise ConfigError(
                f"{where}: role {role} sensor {sensor.name!r} axis {sensor.axis.tolist()} is not along "
                f"body {'xyz'[axis]}; fix the rig file or use the 'least-squares' solver"
            )
        out[role] = columns[:, i] * np.sign(along)
    return out


def _estimates(cols: Mapping[str, np.ndarray], nine: NineSensorSet) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Eq. 4.12 without the omega terms: two estimates of each angular component."""
    spacing = {"rx": nine.rx, "ry": nine.ry, "rz": nine.rz}
    return {axis: tuple(sign * (cols[far] - cols[near]) / spacing[r] for sign, far, near, r, _ in pair)
            for axis, pair in _PAIRS.items()}


class PadgaonkarNine:
    """Nine-accelerometer solver (Padgaonkar et al. 1975; thesis Eq. 4.13-4.14, 4.26-4.28).

    x, y, z at corner C are the corner-C signals xC, yC, zC; theta, phi, psi follow Eq. 4.13
    applied to displacements (Eq. 4.14), i.e. the mean of the two Eq. 4.12 estimates of each angle,
    which cancels the omega products exactly for accelerations. The pose at C is moved to G by the
    finite homogeneous transform with r_CG = G - C at rest.
    """

    name = "padgaonkar-nine"
    description = "nine single-axis accelerometers on three corners (thesis Eq. 4.13-4.14)"

    def suitability(self, rig: Rig, body: Body, sensors) -> float | None:
        """2 (preferred: exact angular terms and a rigidity check) when every sensor of the body's
        nine-sensor set is among ``sensors``."""
        nine = body.nine_sensor_set
        if nine is None or not set(nine.sensors.values()) <= set(sensors):
            return None
        return 2.0

    def solve(self, rig: Rig, body: Body, signals: Mapping[str, np.ndarray]) -> SolverResult:
        """Generalized coordinates at C and G from the nine sensors' processed signals."""
        from odsuite.api import SolverResult, corner_to_com

        nine = _nine_set(rig, body)
        cols = _role_columns(rig, body, nine, signals)
        est = _estimates(cols, nine)
        angles = [0.5 * (est[a][0] + est[a][1]) for a in "xyz"]
        at_c = np.stack([cols["xC"], cols["yC"], cols["zC"], *angles], axis=1)
        at_g = corner_to_com(at_c, body.com - nine.corner)
        return SolverResult(at_c=at_c, at_g=at_g, condition_number=None,
                            sensors=tuple(nine.sensors[r] for r in NINE_ROLES))

    def rigidity_check(self, rig: Rig, body: Body, accelerations: Mapping[str, np.ndarray],
                       threshold: float = 0.1) -> Rigidity:
        """See :func:`rigidity_check`."""
        return rigidity_check(rig, body, accelerations, threshold)


def rigidity_check(rig: Rig, body: Body, accelerations: Mapping[str, np.ndarray],
                   threshold: float = 0.1) -> Rigidity:
    """Compare the two measurements of each angular acceleration (Eq. 4.12 a/d, b/e, c/f).

    For a rigid body the two estimates differ only by 2 omega_i omega_j, which this check
    neglects: for vibrations of 1e-5 rad at 500 Hz that is about 1e-5 of the angular acceleration.
    Per axis it reports RMS(difference) / RMS of the angular acceleration vector (all three axes'
    mean estimates), and flags axes above ``threshold``: an axis the test hardly excites (yaw
    under a vertical blow) would otherwise divide its sensors' noise by almost nothing.
    The same combination works on displacements. A faulty or sign-flipped sensor shows on the axes
    whose pairs use it; the sensors used by exactly the flagged axes are named as suspects.
    """
    from odsuite.api import Rigidity

    if not (isinstance(threshold, (int, float)) and threshold > 0):
        raise ConfigError(f"rigidity_check: threshold must be > 0, got {threshold!r}")
    nine = _nine_set(rig, body)
    est = _estimates(_role_columns(rig, body, nine, accelerations), nine)
    fractions = {}
    scale = np.sqrt(sum(np.mean((0.5 * (e1 + e2)) ** 2) for e1, e2 in est.values()))
    for axis, (e1, e2) in est.items():
        diff = np.sqrt(np.mean((e1 - e2) ** 2))
        fractions[axis] = float(diff / scale) if scale > 0 else (0.0 if diff == 0 else float("inf"))
    flagged = tuple(a for a in "xyz" if fractions[a] > threshold)
    worst_axis = max(fractions, key=fractions.get)
    (s1, f1, n1, r1, eq1), (s2, f2, n2, r2, eq2) = _PAIRS[worst_axis]
    worst = (f"angular acceleration about {worst_axis}: Eq. {eq1} {_term(s1, f1, n1, r1)} and Eq. {eq2} "
             f"{_term(s2, f2, n2, r2)} disagree by {fractions[worst_axis]:.1%} of the angular acceleration's RMS")
    suspects: tuple[str, ...] = ()
    if flagged:
        uses = {role: {a for a, pair in _PAIRS.items() for p in pair if role in p[1:3]} for role in NINE_ROLES}
        suspects = tuple(nine.sensors[r] for r in NINE_ROLES if uses[r] == set(flagged))
        worst += (f"; flagged: {', '.join(flagged)} (threshold {threshold:.0%}); sensor(s) that explain "
                  f"this pattern: {', '.join(suspects) or 'none alone (several sensors or a flexible body)'}")
    return Rigidity(fractions=fractions, threshold=float(threshold), flagged=flagged, worst=worst,
                    suspects=suspects)


class LeastSquares:
    """General solver: any single-axis sensors with known positions and axes on one body that
    determine its coordinates (six, or the body's ``dofs``: a planar car body needs two).

    Linearised rigid-body relation per sensor i (rest vector r_i from G, unit axis a_i):
    ``s_i = a_i . (t + Theta x r_i) = [a_i, r_i x a_i] . d_G``. One pseudo-inverse of that
    (m, 6) matrix (its columns of the body's coordinates) solves all samples; coordinates the body
    does not have stay zero. The condition number is that of the matrix with lengths in
    metres. ``at_c`` is also given where the body has a corner (nine-sensor corner, else plate
    corner), by the finite transform.
    """

    name = "least-squares"
    description = "single-axis sensors with independent directions on one body, as many as it has coordinates"

    def suitability(self, rig: Rig, body: Body, sensors) -> float | None:
        """1 when the named sensors of ``body`` determine all its coordinates."""
        wanted = set(sensors)  # built once: inside the loop it made 4,000 sensors quadratic
        names = tuple(s.name for s in body_sensors(rig, body) if s.name in wanted)
        try:
            self.matrix(rig, body, names)
        except ConfigError:
            return None
        return 1.0

    def matrix(self, rig: Rig, body: Body, names: tuple[str, ...]) -> np.ndarray:
        """The (m, k) matrix mapping the body's k coordinates (its ``dofs`` of d_G) to the named
        sensors' signals; refuses a degenerate layout."""
        sensors = [rig.sensor(n) for n in names]
        if not sensors:
            raise ConfigError(f"rig {rig.name!r}: body {body.name!r} has no sensors")
        r = np.array([s.position for s in sensors]) - body.com
        a = np.array([s.axis for s in sensors])
        dofs = [COORDINATES.index(d) for d in body.dofs]
        A = np.hstack([a, np.cross(r, a)])[:, dofs]
        k = len(dofs)
        sv = np.linalg.svd(A, compute_uv=False) if len(names) >= k else np.zeros(k)
        rank = int(np.sum(sv > sv[0] * 1e-9)) if sv[0] > 0 else 0
        if rank < k:
            unseen = ""
            if len(names) >= k:
                null = np.linalg.svd(A)[2][-1]
                unseen = "; it cannot see motion along " + " + ".join(
                    f"{v:.2g} {c}" for v, c in zip(null, body.dofs) if abs(v) > 0.1)
            raise ConfigError(
                f"rig {rig.name!r}: body {body.name!r} sensors {', '.join(names)} determine only "
                f"{rank} of {k} generalized coordinates{unseen}"
            )
        return A

    def solve(self, rig: Rig, body: Body, signals: Mapping[str, np.ndarray]) -> SolverResult:
        """Generalized coordinates at G (and C) from every signal of a sensor on ``body``."""
        from odsuite.api import SolverResult, com_to_corner, stack_signals

        names = tuple(s.name for s in body_sensors(rig, body) if s.name in signals)
        k = len(body.dofs)
        if len(names) < k:
            have = ", ".join(names) or "none"
            raise ConfigError(
                f"rig {rig.name!r}: body {body.name!r} needs signals of at least {k} of its sensors, got {have}"
            )
        A = self.matrix(rig, body, names)
        S = stack_signals(signals, names, f"rig {rig.name!r} body {body.name!r}")
        solved = S @ np.linalg.pinv(A).T
        at_g = np.zeros((S.shape[0], 6))
        at_g[:, [COORDINATES.index(d) for d in body.dofs]] = solved
        residual = None
        if len(names) > k:
            total = np.sqrt(np.mean(S**2))
            residual = float(np.sqrt(np.mean((S - solved @ A.T) ** 2)) / total) if total > 0 else 0.0
        corner = (body.nine_sensor_set.corner if body.nine_sensor_set is not None
                  else body.plate.corner if body.plate is not None else None)
        at_c = None if corner is None else com_to_corner(at_g, body.com - corner)
        return SolverResult(at_c=at_c, at_g=at_g, condition_number=float(np.linalg.cond(A)),
                            residual=residual, sensors=names)
