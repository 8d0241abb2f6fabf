"""Linear rigid-multibody models: bodies on spring-damper elements (thesis Ch. 3, Eq. 3.3-3.18).

Coordinates of each body: ``d = [x y z theta phi psi]`` at its centre of mass, small angles, rig
frame; a point at ``p`` moves by ``d_t + Theta x (p - com)``. Every point (springs, sensors, force
points) is given in the rig frame, so moving a centre of mass leaves them where they are on the body.

A :class:`Model` is a structure (:class:`LinearStructure`: M, C, K and modes, cached; rigid bodies,
springs and added flexible modes are the :class:`Structure` family, a plugin may bring others)
plus a :class:`MeasurementChain` (what happens between the structure and the recorded signals: force gauge gain and impact offset, sensor gain, polarity, tilt, position, dynamics). Effects that
change only the chain reuse the structure and its cached matrices.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from types import MappingProxyType

import numpy as np
import scipy  # scipy.signal and scipy.linalg load on first use: fast `odsuite plugins`

from odsuite.domain.errors import ConfigError, NonPhysicalError
from odsuite.domain.rig import COORDINATES, Body, Rig, Sensor

#: Generalized coordinates of one body, in order.
COORDS = COORDINATES
QUANTITIES = ("displacement", "velocity", "acceleration")
_UNITS = {"displacement": ("m", "rad"), "velocity": ("m/s", "rad/s"),
          "acceleration": ("m/s^2", "rad/s^2")}


def skew(r: np.ndarray) -> np.ndarray:
    """The cross-product matrix: ``skew(r) @ v == np.cross(r, v)``."""
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross(a, b)``: of two 3-vectors the same products and differences without its axis
    handling (a diagnosis turns and tilts sensors thousands of times: 17 us a call against 2);
    stacked vectors are left to np.cross."""
    if np.ndim(a) != 1 or np.ndim(b) != 1:
        return np.cross(a, b)
    a0, a1, a2 = a
    b0, b1, b2 = b
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def rotated(v: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """``v`` turned by the rotation vector ``rotation`` (axis times angle, rad; Rodrigues): exact
    for large angles, where a small-angle tilt ``v + rotation x v`` would shorten the angle."""
    angle = float(np.linalg.norm(rotation))
    if angle == 0:
        return v
    k = rotation / angle
    return v * np.cos(angle) + cross(k, v) * np.sin(angle) + k * (k @ v) * (1 - np.cos(angle))


def point_map(r: np.ndarray) -> np.ndarray:
    """``T(r) = [I | -[r]x]`` (3x6): displacement of the point at offset ``r`` from ``d``. Written
    out (``-skew(r)``'s entries, its zeros negative as there): every model's springs and sensors
    ask for it, and the stacked form cost four array constructions each time."""
    x, y, z = np.asarray(r, dtype=float)
    return np.array([[1.0, 0.0, 0.0, -0.0, z, -y], [0.0, 1.0, 0.0, -z, -0.0, x], [0.0, 0.0, 1.0, y, -x, -0.0]])


def _vec3(where: str, value) -> np.ndarray:
    # a model's own vectors (an effect's scaled springs, moved centres) are float arrays already:
    # taken as they are, without np.all's dispatch (every new model validates its springs again)
    arr = value if type(value) is np.ndarray and value.shape == (3,) and value.dtype == float else \
        np.asarray(value, dtype=float).reshape(-1)
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise ConfigError(f"{where}: expected 3 finite numbers, got {value!r}")
    return arr


def _unit(where: str, value) -> np.ndarray:
    arr = _vec3(where, value)
    norm = np.linalg.norm(arr)
    if norm == 0:
        raise ConfigError(f"{where}: zero direction vector")
    return arr / norm


@dataclass(frozen=True, eq=False)
class RigidBody:
    """A rigid body: mass (kg), inertia tensor about its centre of mass (kg m^2, rig axes, the
    tensor itself: off-diagonal entries are minus the products of inertia), centre of mass (m).

    ``dofs`` lists the coordinates that may move (e.g. ``("z", "phi")`` for a planar model).
    """

    name: str
    mass: float
    inertia: np.ndarray
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    dofs: tuple[str, ...] = COORDS

    def __post_init__(self) -> None:
        w = f"body {self.name!r}"
        if not (isinstance(self.mass, (int, float)) and np.isfinite(self.mass)) or self.mass <= 0:
            raise ConfigError(f"{w} field 'mass': must be a finite number > 0 kg, got {self.mass!r}")
        inertia = np.asarray(self.inertia, dtype=float)
        if inertia.shape != (3, 3) or not np.all(np.isfinite(inertia)):
            raise ConfigError(f"{w} field 'inertia': expected a finite 3x3 matrix, got {self.inertia!r}")
        # np.allclose(inertia, inertia.T, rtol=1e-12, atol=0) on finite entries, without its
        # dispatch (a mass candidate builds its bodies at every evaluation)
        if not (np.abs(inertia - inertia.T) <= 1e-12 * np.abs(inertia.T)).all():
            raise ConfigError(f"{w} field 'inertia': not symmetric: {inertia.tolist()}")
        eig = np.linalg.eigvalsh(inertia)
        if eig.min() <= 0:
            raise NonPhysicalError(f"{w} field 'inertia': not positive definite (eigenvalues {eig.tolist()} kg m^2)")
        unknown = [d for d in self.dofs if d not in COORDS]
        if unknown or not self.dofs or len(set(self.dofs)) != len(self.dofs):
            raise ConfigError(f"{w} field 'dofs': expected distinct names from {COORDS}, got {self.dofs!r}")
        object.__setattr__(self, "mass", float(self.mass))
        object.__setattr__(self, "inertia", inertia)
        object.__setattr__(self, "com", _vec3(f"{w} field 'com'", self.com))
        object.__setattr__(self, "dofs", tuple(d for d in COORDS if d in self.dofs))

    @classmethod
    def from_rig(cls, body: Body, dofs: tuple[str, ...] | None = None) -> RigidBody:
        """The moving body of a rig file (bodies without a mass do not move); ``dofs`` default to
        the rig file's."""
        if body.mass is None:
            raise ConfigError(f"rig body {body.name!r} has no mass: it is not a moving body")
        return cls(body.name, body.mass, body.inertia, body.com, body.dofs if dofs is None else dofs)

    @property
    def mass_matrix(self) -> np.ndarray:
        """6x6 mass matrix about the centre of mass (App. B's ``m``)."""
        m = np.zeros((6, 6))
        m[:3, :3] = self.mass * np.eye(3)
        m[3:, 3:] = self.inertia
        return m


@dataclass(frozen=True, eq=False)
class SpringDamper:
    """A 3-D spring-damper at ``point`` between ``body`` and ``other`` (None: the ground/base).

    Stiffness (N/m) and damping (N s/m) act on the relative displacement of the point, along the rig
    axes (3 coefficients) or as symmetric 3x3 matrices; ``rot_stiffness`` (N m/rad) and
    ``rot_damping`` (N m s/rad) on the relative rotation. ``group``: springs that effects scale
    together (e.g. four identical isolators); empty: the spring is its own group. ``cubic``
    (N/m^3, per rig axis): a hardening force ``cubic * d**3`` added to the linear one (the model
    is then simulated by :func:`odsuite.domain.simulation.simulate_nonlinear`).
    """

    name: str
    point: np.ndarray
    body: str | None
    other: str | None = None
    stiffness: np.ndarray = field(default_factory=lambda: np.zeros(3))
    damping: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rot_stiffness: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rot_damping: np.ndarray = field(default_factory=lambda: np.zeros(3))
    group: str = ""  # springs scaled together by effects; "" = its own group
    cubic: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        w = f"spring {self.name!r}"
        if self.body is None and self.other is None:
            raise ConfigError(f"{w}: no attachment (field 'body' is None and field 'other' is None)")
        if self.body == self.other:
            raise ConfigError(f"{w}: attached to body {self.body!r} at both ends")
        object.__setattr__(self, "point", _vec3(f"{w} field 'point'", self.point))
        for f in ("stiffness", "damping", "rot_stiffness", "rot_damping"):
            raw = getattr(self, f)
            v = np.asarray(raw, dtype=float)
            if f in ("stiffness", "damping") and v.shape == (3, 3):
                if not np.all(np.isfinite(v)) or not np.allclose(v, v.T, rtol=1e-12, atol=0):
                    raise ConfigError(f"{w} field {f!r}: a 3x3 matrix must be finite and symmetric, got {v.tolist()}")
                eig = np.linalg.eigvalsh(v)
                # an eigenvalue zero but for eigvalsh's round-off (a mount's matrix with one axis
                # scaled to 0 gave -1.5e-28) is zero
                low = eig.min() if eig.min() < -16 * np.finfo(float).eps * np.abs(eig).max() else 0.0
            else:
                v = _vec3(f"{w} field {f!r}", raw)
                low = v.min()
            if low < 0:
                raise ConfigError(f"{w} field {f!r}: must be >= 0, got {v.tolist()}")
            object.__setattr__(self, f, v)
        object.__setattr__(self, "cubic", _vec3(f"{w} field 'cubic'", self.cubic))

    def matrix(self, name: str) -> np.ndarray:
        """``stiffness``, ``damping``, ... as a 3x3 matrix."""
        v = getattr(self, name)
        return v if v.ndim == 2 else np.diag(v)

    def scaled(self, name: str, factors) -> np.ndarray:
        """``name`` scaled by ``factors`` along the rig axes: f_i k_i, or S K S with S = diag(sqrt f)
        for a matrix (symmetric, and equal to f_i k_ii on its diagonal)."""
        v, f = getattr(self, name), np.broadcast_to(np.asarray(factors, dtype=float), (3,))
        if v.ndim == 1:
            return v * f
        root = np.sqrt(f)
        return root[:, None] * v * root[None, :]


#: A flexible mode's participation: (point, unit direction, tag) -> displacement per unit modal
#: coordinate along the direction (1/sqrt(kg)). ``tag`` is the sensor name for sensor outputs,
#: "force" for force inputs, None otherwise.
ShapeFunction = Callable[[np.ndarray, np.ndarray, "str | None"], float]


@dataclass(frozen=True, eq=False)
class FlexibleMode:
    """An added, mass-normalised flexible mode of one body: ``q'' + 2 zeta w q' + w^2 q = phi_F . F``.

    Uncoupled (``at_springs`` False), ``frequency_hz`` is its frequency as mounted. With
    ``at_springs`` the shape also moves the body's spring ends (the shape function is asked at
    each spring's point along each rig axis, tag ``"<spring>.x"`` etc.): the springs
    and their dampers then couple it to the rigid motion, and ``frequency_hz`` and
    ``damping_ratio`` are the mode's with the rigid coordinates held still (its spring ends'
    stiffness and damping included). Its shape shares no mass with the rigid coordinates unless
    ``parts`` are given: (tag, point, mass kg) of parts mounted on the body whose motion is the
    body's at ``point`` plus the mode's shape there (asked along each rig axis, tag ``"<tag>.x"``
    etc.), e.g. a loose bracket carrying sensors. Their kinetic energy couples the mode to the rigid
    motion through the mass matrix; the modal mass stays 1 kg (the parts' own share included), so
    a part's mass times the shape's square at its point must not exceed 1.
    """

    name: str
    body: str
    frequency_hz: float
    damping_ratio: float
    shape: ShapeFunction
    at_springs: bool = False
    parts: tuple = ()

    def __post_init__(self) -> None:
        if not np.isfinite(self.frequency_hz) or self.frequency_hz <= 0:
            raise ConfigError(f"flexible mode {self.name!r} field 'frequency_hz': must be > 0, got {self.frequency_hz!r}")
        if not np.isfinite(self.damping_ratio) or self.damping_ratio < 0:
            raise ConfigError(f"flexible mode {self.name!r} field 'damping_ratio': must be >= 0, got {self.damping_ratio!r}")


@dataclass(frozen=True, eq=False)
class Input:
    """One input channel of a model.

    kinds: "force" (N, at ``point`` along ``direction``), "moment" (N m about ``direction``),
    "base_translation" (m, ground displacement along ``direction``), "base_rotation" (rad, ground
    rotation about ``direction`` through the rig origin), "ground_acceleration" (m/s^2) and
    "ground_angular_acceleration" (rad/s^2, about ``direction`` through the rig origin): the
    ground's acceleration, with the coordinates taken relative to the ground (see
    :meth:`Model.state_space`). ``body`` None: the model's first body.
    """

    kind: str
    direction: np.ndarray
    point: np.ndarray | None = None
    body: str | None = None
    name: str = ""

    @classmethod
    def force(cls, point, direction, body: str | None = None, name: str = "force") -> Input:
        return cls("force", _unit("force direction", direction), _vec3("force point", point), body, name)

    @classmethod
    def moment(cls, direction, body: str | None = None, name: str = "moment") -> Input:
        return cls("moment", _unit("moment direction", direction), None, body, name)

    @classmethod
    def base_translation(cls, direction, name: str = "base translation") -> Input:
        return cls("base_translation", _unit("base translation direction", direction), None, None, name)

    @classmethod
    def base_rotation(cls, direction, name: str = "base rotation") -> Input:
        return cls("base_rotation", _unit("base rotation direction", direction), None, None, name)

    @classmethod
    def ground_acceleration(cls, direction, name: str = "ground acceleration") -> Input:
        return cls("ground_acceleration", _unit("ground acceleration direction", direction), None, None, name)

    @classmethod
    def ground_angular_acceleration(cls, direction, name: str = "ground angular acceleration") -> Input:
        return cls("ground_angular_acceleration", _unit("ground angular acceleration direction", direction),
                   None, None, name)

    @property
    def unit(self) -> str:
        return {"force": "N", "moment": "N m", "base_translation": "m", "base_rotation": "rad",
                "ground_acceleration": "m/s^2", "ground_angular_acceleration": "rad/s^2"}[self.kind]


@dataclass(frozen=True, eq=False)
class Output:
    """One output channel: a point's motion along a direction, or one generalized coordinate.

    kinds: "point" (``point``, ``direction``, on ``body``) and "coordinate" (coordinate ``index``
    of ``body`` referred to ``point``, by default the body's centre of mass). ``sensor_name`` names the rig
    sensor so measurement-chain effects find it.
    """

    kind: str
    quantity: str
    body: str | None
    point: np.ndarray | None = None
    direction: np.ndarray | None = None
    index: int | None = None
    sensor_name: str | None = None
    name: str = ""

    def __post_init__(self) -> None:
        if self.quantity not in QUANTITIES:
            raise ConfigError(f"output {self.name!r} field 'quantity': expected one of {QUANTITIES}, got {self.quantity!r}")

    @classmethod
    def at_point(cls, point, direction, quantity: str = "acceleration", body: str | None = None,
                 name: str = "") -> Output:
        return cls("point", quantity, body, _vec3("output point", point),
                   _unit("output direction", direction), name=name or "point")

    @classmethod
    def sensor(cls, sensor: Sensor, quantity: str = "acceleration") -> Output:
        """The physical quantity at the sensor's position along its axis (its sign and sensitivity
        belong to the acquisition, not to the structure)."""
        return cls("point", quantity, sensor.body, np.asarray(sensor.position, float),
                   _unit(f"sensor {sensor.name!r} axis", sensor.axis), sensor_name=sensor.name, name=sensor.name)

    @classmethod
    def coordinates(cls, body: Body | RigidBody | str, quantity: str = "displacement",
                    at=None) -> tuple[Output, ...]:
        """The six coordinates ``[x y z theta phi psi]`` of ``body`` referred to ``at`` (default:
        the body's centre of mass as given, so an effect that moves the mass centre does not move
        the reference point)."""
        name = body if isinstance(body, str) else body.name
        if at is None and not isinstance(body, str):
            at = body.com
        point = None if at is None else _vec3("coordinate reference point", at)
        return tuple(cls("coordinate", quantity, name, point, None, i, name=f"{name}.{c}")
                     for i, c in enumerate(COORDS))

    @property
    def unit(self) -> str:
        lin, ang = _UNITS[self.quantity]
        return ang if self.kind == "coordinate" and self.index >= 3 else lin


#: input kinds of the ground's acceleration (coordinates relative to the ground)
GROUND_ACCELERATIONS = ("ground_acceleration", "ground_angular_acceleration")


def _flatten(items) -> list:
    out = []
    for it in ([items] if isinstance(items, (Input, Output)) else items):
        if isinstance(it, (Input, Output)):
            out.append(it)
        elif isinstance(it, Iterable) and not isinstance(it, (str, bytes)):
            out.extend(_flatten(it))
        else:
            raise ConfigError(f"expected Input/Output objects, got {it!r}")
    return out


@dataclass(frozen=True)
class StateSpace:
    """``x' = A x + B u``, ``y = C x + D u`` (Eq. 3.13-3.16, with the D term of acceleration outputs)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    input_names: tuple[str, ...] = ()
    output_names: tuple[str, ...] = ()
    output_units: tuple[str, ...] = ()


@dataclass(frozen=True)
class Modes:
    """Modes sorted by ascending frequency: f = |lambda|/2pi (Hz), zeta = -Re(lambda)/|lambda|,
    shapes (n_dof x n_modes, complex, largest entry 1)."""

    eigenvalues: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    dof_names: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.frequency_hz)

    def as_list(self) -> list[dict[str, float]]:
        return [{"frequency_hz": float(f), "damping_ratio": float(z)}
                for f, z in zip(self.frequency_hz, self.damping_ratio)]


class LinearStructure:
    """The structure contract: any linear structure ``M q'' + C q' + K q = Bf u`` that a
    :class:`Model` can drive, predict and simulate; rigid bodies on springs (:class:`Structure`)
    are one family, a plugin may bring others (a finite-element beam, a plate).

    A subclass gives ``dof_names`` (tuple of str), the cached properties ``M``, ``K``, ``C``
    (n_dof x n_dof, symmetric) and ``point_rows(body, point) -> 3 x n_dof`` (the displacement of a
    point of ``body`` along the rig axes per unit coordinate; ``body`` is a rig body's name or None).
    ``Minv``, ``A`` and ``modes`` follow from them here; ``is_linear`` (True) and ``cubic_rows()``
    say whether it has cubic terms; ``damped_modes_hz()`` and ``with_mode_damping(zeta)`` (optional)
    let an effect set its modal damping mode by mode. A structure without rigid coordinates or
    ground springs keeps the defaults below: no rotation rows, no body coordinates, no base input,
    no flexible modes.
    """

    bodies: tuple = ()
    springs: tuple = ()
    flexible_modes: tuple = ()
    dof_names: tuple[str, ...] = ()

    @property
    def n_dof(self) -> int:
        return len(self.dof_names)

    #: a structure with cubic (hardening) terms sets this False and gives ``cubic_rows()``
    is_linear: bool = True

    def damped_modes_hz(self) -> np.ndarray:
        """Natural frequencies (Hz, ascending) of the modes whose damping ratios
        ``with_mode_damping`` sets one by one: none here (a structure with modal damping, such as
        a finite-element beam, lists its elastic modes)."""
        return np.zeros(0)

    def with_mode_damping(self, zeta: Mapping[int, float]) -> LinearStructure:
        """The structure with mode ``k`` of ``damped_modes_hz()`` damped at ratio ``zeta[k]``."""
        raise ConfigError(f"{type(self).__name__}: has no modal damping to set mode by mode")

    def point_rows(self, body: str | None, point: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def flex_row(self, body: str | None, point, direction, tag: str | None) -> np.ndarray:
        """Participation (n_dof) of added flexible modes at a point along a direction: none here."""
        return np.zeros(self.n_dof)

    def rotation_rows(self, body: str | None) -> np.ndarray:
        raise ConfigError(f"{type(self).__name__}: has no rigid-body rotation coordinates (a moment input "
                          "needs a rigid body)")

    def body_coordinates(self, name: str | None, at=None) -> np.ndarray:
        raise ConfigError(f"{type(self).__name__}: has no rigid-body coordinates for body {name!r}")

    def base_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        raise ConfigError(f"{type(self).__name__}: has no springs to the ground, so no base-motion input")

    @functools.cached_property
    def ground_map(self) -> np.ndarray:
        """n_dof x 6: the coordinates of everything following a rigid ground motion [translation,
        rotation about the rig origin]. Such a motion strains no spring, so it is the static
        deflection ``K^-1 Kg`` under that ground motion (any structure with base matrices)."""
        kg, _ = self.base_matrices()
        try:
            return np.linalg.solve(self.K, kg)
        except np.linalg.LinAlgError:
            raise ConfigError(f"{type(self).__name__}: a body is not held by springs (K is singular), so it does "
                              "not follow the ground") from None

    @functools.cached_property
    def Minv(self) -> np.ndarray:
        return np.linalg.inv(self.M)

    @functools.cached_property
    def A(self) -> np.ndarray:
        """First-order system matrix of Eq. 3.13: ``[[0, I], [-M^-1 K, -M^-1 C]]``."""
        n = self.n_dof
        return np.block([[np.zeros((n, n)), np.eye(n)], [-self.Minv @ self.K, -self.Minv @ self.C]])

    @functools.cached_property
    def modes(self) -> Modes:
        lam, vec = np.linalg.eig(self.A)
        n = self.n_dof
        # one of each conjugate pair (Im > 0) and every real eigenvalue
        keep = (lam.imag > 1e-9 * np.abs(lam)) | (np.abs(lam.imag) <= 1e-9 * np.abs(lam))
        lam, vec = lam[keep], vec[:n, keep]
        absl = np.abs(lam)
        order = np.argsort(absl, kind="stable")
        lam, vec, absl = lam[order], vec[:, order], absl[order]
        with np.errstate(invalid="ignore", divide="ignore"):
            zeta = np.where(absl > 0, -lam.real / absl, 1.0) + 0.0  # an undamped mode: 0, not -0.0
        big = vec[np.argmax(np.abs(vec), axis=0), np.arange(vec.shape[1])]
        shapes = vec / big
        return Modes(lam, absl / (2 * np.pi), zeta, shapes, self.dof_names)


class Structure(LinearStructure):
    """Bodies, springs and added flexible modes; M, C, K and modes are computed once and cached."""

    def __init__(self, bodies: Sequence[RigidBody], springs: Sequence[SpringDamper] = (),
                 flexible_modes: Sequence[FlexibleMode] = ()) -> None:
        self.bodies = tuple(bodies)
        self.springs = tuple(springs)
        self.flexible_modes = tuple(flexible_modes)
        if not self.bodies:
            raise ConfigError("model: no moving body")
        names = [b.name for b in self.bodies]
        if len(set(names)) != len(names):
            raise ConfigError(f"model: duplicate body names {names}")
        self._body = {b.name: b for b in self.bodies}
        for s in self.springs:
            for end in (s.body, s.other):
                if end is not None and end not in self._body:
                    raise ConfigError(f"spring {s.name!r}: attached to unknown body {end!r} (bodies: {names})")
        for f in self.flexible_modes:
            self.body(f.body)
        # dof layout: each body's active coordinates, then one coordinate per flexible mode
        self.dof_names: tuple[str, ...] = tuple(
            [f"{b.name}.{c}" for b in self.bodies for c in b.dofs] + [f"flex.{f.name}" for f in self.flexible_modes])
        self._select: dict[str, np.ndarray] = {}
        start = 0
        for b in self.bodies:
            sel = np.zeros((6, self.n_dof))
            for j, c in enumerate(b.dofs):
                sel[COORDS.index(c), start + j] = 1.0
            self._select[b.name] = sel
            start += len(b.dofs)
        self._flex_start = start
        # what follows from the bodies and flexible modes alone (M, M^-1) is shared with the
        # structures built from the same ones (a stiffness or damping change), what follows from
        # their geometry (the sensors' rows, the springs' ends) with those of the same centres of
        # mass too (a mass or inertia change)
        self._frame = _frame(self.bodies, self.flexible_modes)
        self._unit_rows, self._ends = _geometry(self.bodies, self.flexible_modes)

    def body(self, name: str | None) -> RigidBody:
        if name is None:  # the first body is the main one (effects append bodies after it)
            return self.bodies[0]
        try:
            return self._body[name]
        except KeyError:
            raise ConfigError(f"model: no moving body {name!r} (bodies: {list(self._body)})") from None

    def body_coordinates(self, name: str | None, at=None) -> np.ndarray:
        """6 x n_dof: coordinates of a body referred to point ``at`` (default its centre of mass)."""
        b = self.body(name)
        sel = self._select[b.name]
        if at is None:
            return sel
        # translation of the reference point, rotation unchanged
        shift = np.eye(6)
        shift[:3, :] = point_map(np.asarray(at, float) - b.com)
        return shift @ sel

    def point_rows(self, body: str | None, point: np.ndarray) -> np.ndarray:
        """3 x n_dof: rigid displacement of a point of ``body`` (flexible modes not included)."""
        b = self.body(body)
        return point_map(point - b.com) @ self._select[b.name]

    def rotation_rows(self, body: str | None) -> np.ndarray:
        return self._select[self.body(body).name][3:]

    def flex_row(self, body: str | None, point, direction, tag: str | None) -> np.ndarray:
        """Flexible-mode participation (n_dof) of a point along a direction."""
        row = np.zeros(self.n_dof)
        name = self.body(body).name
        for i, f in enumerate(self.flexible_modes):
            if f.body == name and point is not None:
                row[self._flex_start + i] = f.shape(np.asarray(point, float), np.asarray(direction, float), tag)
        return row

    def _spring_ends(self, s: SpringDamper) -> tuple[np.ndarray, np.ndarray]:
        """Relative translation (3 x n) and rotation (3 x n) of a spring's ends, kept per spring
        (K, C and the base matrices each ask for them)."""
        key = (s.name, s.body, s.other, np.asarray(s.point, float).tobytes())  # all the ends read of s
        got = self._ends.get(key)
        if got is None:
            P, R = self._new_spring_ends(s)
            P.flags.writeable = R.flags.writeable = False
            got = self._ends[key] = (P, R)
        return got

    def _new_spring_ends(self, s: SpringDamper) -> tuple[np.ndarray, np.ndarray]:
        P = np.zeros((3, self.n_dof))
        R = np.zeros((3, self.n_dof))
        if s.body is not None:
            P += self.point_rows(s.body, s.point)
            R += self.rotation_rows(s.body)
        if s.other is not None:
            P -= self.point_rows(s.other, s.point)
            R -= self.rotation_rows(s.other)
        for i, f in enumerate(self.flexible_modes):
            if f.at_springs and f.body in (s.body, s.other):
                sign = 1.0 if f.body == s.body else -1.0
                P[:, self._flex_start + i] += sign * np.array(
                    [f.shape(s.point, axis, f"{s.name}.{'xyz'[k]}") for k, axis in enumerate(np.eye(3))])
        return P, R

    @functools.cached_property
    def M(self) -> np.ndarray:
        return self._framed("M", self._mass_matrix)

    @functools.cached_property
    def Minv(self) -> np.ndarray:
        return self._framed("Minv", lambda: np.linalg.inv(self.M))

    def _framed(self, name: str, make: Callable[[], np.ndarray]) -> np.ndarray:
        """``make()``, kept (read-only) for the structures of the same bodies and flexible modes."""
        value = self._frame.get(name)
        if value is None:
            value = self._frame[name] = make()
            value.flags.writeable = False
        return value

    def _mass_matrix(self) -> np.ndarray:
        m = np.zeros((self.n_dof, self.n_dof))
        for b in self.bodies:
            sel = self._select[b.name]
            m += sel.T @ b.mass_matrix @ sel
        for i, f in enumerate(self.flexible_modes):
            j = self._flex_start + i
            m[j, j] = 1.0
            for tag, point, mass in f.parts:
                # the part moves with the body at its point plus the mode's shape there
                B = self.point_rows(f.body, point)
                phi = np.array([f.shape(point, axis, f"{tag}.{'xyz'[k]}") for k, axis in enumerate(np.eye(3))])
                pull = mass * (B.T @ phi)
                m += mass * (B.T @ B)
                m[:, j] += pull
                m[j, :] += pull
        return m

    def _assemble(self, lin: str, rot: str, flex: Callable[[FlexibleMode], float]) -> np.ndarray:
        """The springs' ``lin`` and ``rot`` coefficients assembled, kept (read-only) with the springs'
        ends for the structures of the same geometry and the same coefficients: a stiffness
        candidate's every evaluation assembles the damping its base had, a damping candidate's the
        stiffness, a hardening's both."""
        key = (lin, rot, *((s.name, s.body, s.other, s.point.tobytes(), getattr(s, lin).tobytes(),
                            getattr(s, rot).tobytes()) for s in self.springs))
        kept = self._ends.setdefault(_ASSEMBLED, {})
        got = kept.get(key)
        if got is None:
            if len(kept) >= ASSEMBLED_KEPT:  # a search over coefficients: each trial a new key
                kept.clear()
            got = kept[key] = self._assembled(lin, rot, flex)
            got.flags.writeable = False
        return got

    def _assembled(self, lin: str, rot: str, flex: Callable[[FlexibleMode], float]) -> np.ndarray:
        k = np.zeros((self.n_dof, self.n_dof))
        for s in self.springs:
            P, R = self._spring_ends(s)
            k += P.T @ s.matrix(lin) @ P + R.T @ s.matrix(rot) @ R
        for i, f in enumerate(self.flexible_modes):
            # the mode's own coefficient, its spring ends included (at_springs: the mode's frequency
            # with the rigid coordinates held; the free body's would trade against the spring ends'
            # participations, a curved valley the fit crawls along)
            k[self._flex_start + i, self._flex_start + i] = flex(f)
        return k

    @functools.cached_property
    def K(self) -> np.ndarray:
        return self._assemble("stiffness", "rot_stiffness", lambda f: (2 * np.pi * f.frequency_hz) ** 2)

    @functools.cached_property
    def C(self) -> np.ndarray:
        return self._assemble("damping", "rot_damping",
                              lambda f: 2 * f.damping_ratio * 2 * np.pi * f.frequency_hz)

    @functools.cached_property
    def is_linear(self) -> bool:
        return not any(s.cubic.any() for s in self.springs)

    def cubic_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """(E, c): the relative displacements along the rig axes of the springs with a cubic term
        (rows of E, n_dof columns) and their coefficients (N/m^3)."""
        rows, coef = [], []
        for s in self.springs:
            if s.cubic.any():
                rows.append(self._spring_ends(s)[0])
                coef.append(s.cubic)
        if not rows:
            return np.zeros((0, self.n_dof)), np.zeros(0)
        return np.vstack(rows), np.concatenate(coef)

    def base_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """(Kg, Cg), n_dof x 6: generalized forces per unit ground [translation, rotation] about the
        rig origin, through the springs attached to the ground."""
        kg = np.zeros((self.n_dof, 6))
        cg = np.zeros((self.n_dof, 6))
        for s in self.springs:
            if s.body is not None and s.other is not None:
                continue
            P, R = self._spring_ends(s)
            sign = 1.0 if s.other is None else -1.0  # ground at the "other" end or at the "body" end
            G = point_map(s.point)
            Gr = np.hstack([np.zeros((3, 3)), np.eye(3)])
            kg += sign * (P.T @ s.matrix("stiffness") @ G + R.T @ s.matrix("rot_stiffness") @ Gr)
            cg += sign * (P.T @ s.matrix("damping") @ G + R.T @ s.matrix("rot_damping") @ Gr)
        return kg, cg


@dataclass(frozen=True)
class SensorDynamics:
    """Thesis Eq. 2.2: two first-order high-passes (coupler/power supply TC1 and the built-in
    amplifier TC, as corner frequencies 1/(2 pi TC), Hz; 0 = absent) and a second-order resonance
    (natural period 1/fn in s, 0 = absent; damping ratio)."""

    highpass_hz: float = 0.0
    coupler_highpass_hz: float = 0.0
    resonance_period_s: float = 0.0
    resonance_damping: float = 0.05

    def is_identity(self) -> bool:
        return self.highpass_hz == 0 and self.coupler_highpass_hz == 0 and self.resonance_period_s == 0

    def zpk(self) -> tuple[list, list, float]:
        zeros, poles, gain = [], [], 1.0
        for f in (self.highpass_hz, self.coupler_highpass_hz):
            if f > 0:
                zeros.append(0.0)
                poles.append(-2 * np.pi * f)
        if self.resonance_period_s > 0:
            wn = 2 * np.pi / self.resonance_period_s
            z = self.resonance_damping
            poles.extend(np.roots([1.0, 2 * z * wn, wn * wn]).tolist())
            gain *= wn * wn
        return zeros, poles, gain


@dataclass(frozen=True)
class AnalogFilter:
    """Analog dynamics in zero-pole-gain form (rad/s), hashable: declared front-end dynamics of the
    accelerometer channels (IEPE coupling, mounted resonance, an anti-aliasing filter the force
    channel does not share)."""

    zeros: tuple[complex, ...]
    poles: tuple[complex, ...]
    gain: float

    def zpk(self) -> tuple[list, list, float]:
        return list(self.zeros), list(self.poles), self.gain

    @classmethod
    def series(cls, parts: Sequence[tuple]) -> AnalogFilter | None:
        """The product of (zeros, poles, gain) blocks; None when there are none."""
        if not parts:
            return None
        zeros, poles, gain = [], [], 1.0
        for z, p, k in parts:
            zeros += [complex(v) for v in np.atleast_1d(z)]
            poles += [complex(v) for v in np.atleast_1d(p)]
            gain *= float(np.real(k))
        return cls(tuple(zeros), tuple(poles), gain)

    @classmethod
    def front_end(cls, acquisition) -> AnalogFilter | None:
        """The accelerometer channels' dynamics relative to the force channel's, from a rig's
        ``[acquisition]`` (odsuite.domain.rig.Acquisition): the IEPE coupling high-pass and the
        mounted resonance (the load cell is taken as flat), and the anti-aliasing filter only when
        the force channel bypasses it (a filter on every channel is in the measured force already,
        so the model driven by it carries the filter once, as the measurement does)."""
        if acquisition is None:
            return None
        parts = []
        if acquisition.iepe_corner_hz:
            parts.append(([0.0], [-2 * np.pi * acquisition.iepe_corner_hz], 1.0))
        if acquisition.sensor_resonance_hz:
            wn, z = 2 * np.pi * acquisition.sensor_resonance_hz, acquisition.sensor_resonance_damping
            parts.append(([], np.roots([1.0, 2 * z * wn, wn * wn]), wn * wn))
        aa = acquisition.anti_aliasing
        if aa is not None and not aa.force_channel:
            parts.append(aa.zpk())
        return cls.series(parts)


@dataclass(frozen=True)
class MeasurementChain:
    """Measurement-chain changes between the structure and the recorded signals.

    ``force_gain`` multiplies force inputs (the structure feels gain x recorded force);
    ``force_offset`` (m) moves force points; per sensor: ``gain`` (polarity is a gain of -1),
    ``offset`` (m, position), ``tilt`` (rotation vector of the axis, rad), ``dynamics``
    (the key "*" applies to every sensor without its own entry), ``delay`` (s: the channel is
    sampled this long after the force channel, e.g. a multiplexer's scan), ``swap`` (the
    sensor whose motion the named sensor's channel records: two cables exchanged); ``front_end``: the
    accelerometer channels' analog dynamics the rig declares (its ``[acquisition]`` table), in series
    with all of them and kept apart from the effects' ``dynamics``.
    """

    force_gain: float = 1.0
    force_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    gain: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    offset: Mapping[str, np.ndarray] = field(default_factory=lambda: MappingProxyType({}))
    tilt: Mapping[str, np.ndarray] = field(default_factory=lambda: MappingProxyType({}))
    dynamics: Mapping[str, SensorDynamics] = field(default_factory=lambda: MappingProxyType({}))
    front_end: AnalogFilter | None = None
    delay: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    swap: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))

    def with_items(self, name: str, items: Mapping) -> MeasurementChain:
        merged = dict(getattr(self, name))
        merged.update(items)
        return replace(self, **{name: MappingProxyType(merged)})

    def sensor_dynamics(self, sensor: str | None) -> SensorDynamics | None:
        if sensor is None:
            return None
        dyn = self.dynamics.get(sensor, self.dynamics.get("*"))
        return None if dyn is None or dyn.is_identity() else dyn


#: sensor rows kept per structure (Model._unit_row)
UNIT_ROWS_KEPT = 4096
#: the keys of a model's rows and force columns among them (Model._on_geometry)
_OUTPUTS, _INPUTS = object(), object()
#: the key of the assembled K and C among a geometry's spring ends (Structure._assemble), and how
#: many of them are kept
_ASSEMBLED = object()
ASSEMBLED_KEPT = 64

#: what structures of the same bodies and flexible modes share (Structure._frame: M, M^-1), by their
#: identities (kept alive with the entry): the candidates that change springs alone build a new
#: structure per evaluation, and each assembled M, inverted it and built its sensors' rows again
_FRAMES: dict[tuple[int, int], tuple[tuple, tuple, dict]] = {}
FRAMES_KEPT = 64


def _frame(bodies: tuple, flexible_modes: tuple) -> dict:
    key = (id(bodies), id(flexible_modes))
    got = _FRAMES.get(key)
    if got is None or got[0] is not bodies or got[1] is not flexible_modes:
        if len(_FRAMES) >= FRAMES_KEPT:
            _FRAMES.clear()
        got = _FRAMES[key] = (bodies, flexible_modes, {})
    return got[2]


#: the sensors' rows and the springs' ends of structures of the same geometry (bodies' names,
#: centres of mass and coordinates; the same flexible modes, kept alive with the entry)
_GEOMETRIES: dict[tuple, tuple[tuple, dict, dict]] = {}


def _geometry(bodies: tuple, flexible_modes: tuple) -> tuple[dict, dict]:
    key = (tuple((b.name, np.asarray(b.com, float).tobytes(), tuple(b.dofs)) for b in bodies), id(flexible_modes))
    got = _GEOMETRIES.get(key)
    if got is None or got[0] is not flexible_modes:
        if len(_GEOMETRIES) >= FRAMES_KEPT:
            _GEOMETRIES.clear()
        got = _GEOMETRIES[key] = (flexible_modes, {}, {})
    return got[1], got[2]


class Model:
    """A linear model: a structure plus a measurement chain.

    ``name`` says which factory built it, ``effects`` which effects were applied (in order) and
    ``parameters`` their values; ``info`` holds the factory's physical parameters (for display);
    ``rig`` is the rig it describes (sensors and plates for the effects), if any.
    """

    def __init__(self, structure: LinearStructure, chain: MeasurementChain | None = None, *, name: str = "",
                 effects: tuple[str, ...] = (), parameters: Mapping[str, Mapping[str, float]] | None = None,
                 info: Mapping | None = None, rig: Rig | None = None) -> None:
        self.structure = structure
        self.chain = chain or MeasurementChain()
        self.name = name
        self.rig = rig
        self.effects = tuple(effects)
        self.parameters = dict(parameters or {})
        self.info = dict(info or {})

    @classmethod
    def build(cls, bodies: Sequence[RigidBody], springs: Sequence[SpringDamper] = (),
              flexible_modes: Sequence[FlexibleMode] = (), **kwargs) -> Model:
        return cls(Structure(bodies, springs, flexible_modes), **kwargs)

    def replace(self, *, structure: LinearStructure | None = None, chain: MeasurementChain | None = None,
                effect: str | None = None, values: Mapping[str, float] | None = None) -> Model:
        """A copy with a new structure and/or chain, recording ``effect`` and its ``values``."""
        params = dict(self.parameters)
        effects = self.effects
        if effect is not None:
            effects = effects + (effect,)
            params[effect] = dict(values or {})
        return Model(structure or self.structure, chain or self.chain, name=self.name,
                     effects=effects, parameters=params, info=self.info, rig=self.rig)

    @property
    def sensors(self) -> tuple[Sensor, ...]:
        """The rig's sensors (empty without a rig)."""
        return self.rig.sensors if self.rig is not None else ()

    # -- structure shortcuts -------------------------------------------------------------------
    @property
    def bodies(self) -> tuple[RigidBody, ...]:
        return self.structure.bodies

    @property
    def springs(self) -> tuple[SpringDamper, ...]:
        return self.structure.springs

    @property
    def M(self) -> np.ndarray:
        return self.structure.M

    @property
    def K(self) -> np.ndarray:
        return self.structure.K

    @property
    def C(self) -> np.ndarray:
        return self.structure.C

    def modes(self) -> Modes:
        """Modes of the structure, ascending (the chain's sensor dynamics are not modes)."""
        return self.structure.modes

    # -- inputs and outputs --------------------------------------------------------------------
    def input_matrices(self, inputs) -> tuple[np.ndarray, np.ndarray]:
        """(Bf, Bv), n_dof x n_in: generalized force per unit input and, for base inputs, per unit
        input rate (the ground's velocity through the dampers). For forces this is Eq. 3.6-3.10's
        Cu (moments M = r x F about the centre of mass)."""
        inputs = _flatten(inputs)
        if any(inp.kind not in ("force", "moment") for inp in inputs):  # the base's read the springs and M
            return self._input_matrices(inputs)
        # a force's and a moment's columns follow from the geometry and the chain's force gain and offset
        chain = self.chain
        key = (_INPUTS, float(chain.force_gain).hex(), np.asarray(chain.force_offset, float).tobytes(), *map(id, inputs))
        return self._on_geometry(key, tuple(inputs), lambda: self._input_matrices(inputs))

    def _input_matrices(self, inputs: list) -> tuple[np.ndarray, np.ndarray]:
        st = self.structure
        bf = np.zeros((st.n_dof, len(inputs)))
        bv = np.zeros_like(bf)
        kg = cg = None
        for j, inp in enumerate(inputs):
            if inp.kind == "force":
                p = self._force_point(inp)
                g = self.chain.force_gain
                bf[:, j] = g * (st.point_rows(inp.body, p).T @ inp.direction
                                + st.flex_row(inp.body, p, inp.direction, "force"))
            elif inp.kind == "moment":
                bf[:, j] = st.rotation_rows(inp.body).T @ inp.direction
            elif inp.kind in ("base_translation", "base_rotation"):
                if kg is None:
                    kg, cg = st.base_matrices()
                cols = slice(0, 3) if inp.kind == "base_translation" else slice(3, 6)
                bf[:, j] = kg[:, cols] @ inp.direction
                bv[:, j] = cg[:, cols] @ inp.direction
            elif inp.kind in GROUND_ACCELERATIONS:  # the inertial load -M T a_g in relative coordinates
                bf[:, j] = -st.M @ self.ground_follow([inp])[:, 0]
            else:
                raise ConfigError(f"input {inp.name!r}: unknown kind {inp.kind!r}")
        bf.flags.writeable = bv.flags.writeable = False
        return bf, bv

    def _on_geometry(self, key: tuple, keep: tuple, make: Callable[[], object]):
        """``make()``, kept with the sensors' unit rows (what follows from the structure's geometry:
        shared by the structures of the same bodies' centres and flexible modes, Structure) under
        ``key``, which holds the identities of ``keep`` (the chain's parts, rig and outputs it reads;
        kept alive with the entry): a stiffness or damping candidate's every evaluation is a new model
        of the same geometry and chain, whose sensor rows and force columns are the last ones'."""
        kept = self.structure.__dict__.setdefault("_unit_rows", {})
        got = kept.get(key)
        if got is None or any(a is not b for a, b in zip(got[0], keep)):
            if len(kept) >= UNIT_ROWS_KEPT:
                kept.clear()
            got = kept[key] = (keep, make())
        return got[1]

    def ground_follow(self, inputs) -> np.ndarray:
        """n_dof x n_in: the coordinates' rigid motion with the ground per unit input (the ground's
        acceleration inputs; zero for the others)."""
        inputs = _flatten(inputs)
        out = np.zeros((self.structure.n_dof, len(inputs)))
        for j, inp in enumerate(inputs):
            if inp.kind in GROUND_ACCELERATIONS:
                cols = slice(0, 3) if inp.kind == "ground_acceleration" else slice(3, 6)
                out[:, j] = self.structure.ground_map[:, cols] @ inp.direction
        return out

    def output_rows(self, outputs) -> tuple[list[Output], np.ndarray]:
        """(outputs, rows n_out x n_dof): each output's coordinate combination (chain's sensor
        position, tilt and gain included; dynamics not)."""
        outputs = _flatten(outputs)
        # the rows read the chain's sensor gains, offsets, tilts and exchanged cables (each a mapping an
        # effect replaces as a whole: a delay's or a dynamics' candidate keeps them) and the rig
        c = self.chain
        read = (c.gain, c.offset, c.tilt, c.swap, self.rig, *outputs)
        return outputs, self._on_geometry((_OUTPUTS, *map(id, read)), read, lambda: self._output_rows(outputs))

    def _output_rows(self, outputs: list) -> np.ndarray:
        st = self.structure
        rows = np.zeros((len(outputs), st.n_dof))
        for i, out in enumerate(outputs):
            if out.kind == "coordinate":
                rows[i] = st.body_coordinates(out.body, out.point)[out.index]
                continue
            rec = self._recorded(out)
            p, n, gain = self._sensed_along(rec)
            rows[i] = gain * self._unit_row(rec, p, n)
        rows.flags.writeable = False
        return rows

    def _unit_row(self, rec, p, n) -> np.ndarray:
        """A sensor's coordinate combination at point ``p`` along ``n`` before its gain, kept on the
        structure (a diagnosis's candidates that change gains or cables ask for the same rows again
        and again; a few small products per sensor each time)."""
        st = self.structure
        key = (rec.body, rec.sensor_name, np.asarray(p, float).tobytes(), np.asarray(n, float).tobytes())
        kept = st.__dict__.setdefault("_unit_rows", {})
        row = kept.get(key)
        if row is None:
            if len(kept) >= UNIT_ROWS_KEPT:  # positions and tilts searched: each trial a new key
                kept.clear()
            row = kept[key] = n @ st.point_rows(rec.body, p) + st.flex_row(rec.body, p, n, rec.sensor_name)
            row.flags.writeable = False
        return row

    def _recorded(self, out):
        """The output whose motion ``out``'s channel records: another sensor's when the chain swaps
        their cables (with that sensor's position, tilt and gain)."""
        other = self.chain.swap.get(out.sensor_name) if out.sensor_name is not None else None
        if other is None or self.rig is None:
            return out
        return Output.sensor(self.rig.sensor(other), out.quantity)

    def _force_point(self, inp) -> np.ndarray:
        return inp.point + self.chain.force_offset

    def _sensed_along(self, out) -> tuple[np.ndarray, np.ndarray, float]:
        """An output's point and direction as mounted, and its gain (the chain's sensor position,
        tilt and gain; none for an output that is not a sensor)."""
        p, n = out.point, out.direction
        if out.sensor_name is None:
            return p, n, 1.0
        tilt = self.chain.tilt.get(out.sensor_name)
        return (p + self.chain.offset.get(out.sensor_name, 0.0), n if tilt is None else rotated(n, tilt),
                self.chain.gain.get(out.sensor_name, 1.0))

    def flexible_participation(self, mode: FlexibleMode, force: Input, outputs) -> tuple[float, np.ndarray]:
        """How an uncoupled flexible ``mode`` (not in the structure) would be driven by ``force`` and
        seen by ``outputs``: the entries its coordinate would take in :meth:`input_matrices` and
        :meth:`output_rows`, without assembling a structure that holds it."""
        st = self.structure
        name = st.body(mode.body).name

        def on_mode_body(body: str | None) -> bool:
            return st.body(body).name == name

        p = np.asarray(self._force_point(force), float)
        b = (self.chain.force_gain * mode.shape(p, np.asarray(force.direction, float), "force")
             if on_mode_body(force.body) else 0.0)
        c = np.zeros(len(_flatten(outputs)))
        for i, out in enumerate(_flatten(outputs)):
            out = self._recorded(out) if out.kind != "coordinate" else out
            if out.kind != "coordinate" and on_mode_body(out.body):
                q, n, gain = self._sensed_along(out)
                c[i] = gain * mode.shape(np.asarray(q, float), np.asarray(n, float), out.sensor_name)
        return float(b), c

    def state_space(self, inputs, outputs) -> StateSpace:
        """State space of Eq. 3.13-3.16 for these inputs and outputs.

        State ``x = [q, q' - M^-1 Bv u]`` (equal to ``[q, q']`` without base inputs), so base
        motion through the dampers needs no input derivative. Velocity and acceleration outputs
        carry a D term. Sensor dynamics of the chain are appended in series.

        With the ground's acceleration a_g as input, q is relative to the ground (q = q_abs - T u_g,
        T = ``ground_map``: rigid motion strains no spring), ``M q'' + C q' + K q = -M T a_g``, and
        acceleration outputs are absolute: the relative one plus the ground's rigid acceleration at
        the point along the output's direction (displacement and velocity would need the ground's
        integrated motion and are refused).
        """
        st = self.structure
        inputs = _flatten(inputs)
        outputs, rows = self.output_rows(outputs)
        bf, bv = self.input_matrices(inputs)
        follow = self.ground_follow(inputs)
        if follow.any():
            kinds = {i.kind for i in inputs}
            if kinds & {"base_translation", "base_rotation"}:
                raise ConfigError("inputs: the ground's displacement and its acceleration need different "
                                  "coordinates; give one of them")
            if any(o.quantity != "acceleration" for o in outputs):
                raise ConfigError("outputs: with the ground's acceleration as input only acceleration outputs are "
                                  "absolute; give acceleration outputs")
        n = st.n_dof
        minv = st.Minv
        mbv = minv @ bv
        A = st.A
        B = np.vstack([mbv, minv @ (bf - st.C @ mbv)])
        C = np.zeros((len(outputs), 2 * n))
        D = np.zeros((len(outputs), len(inputs)))
        has_rate = np.any(bv != 0)
        for i, (out, r) in enumerate(zip(outputs, rows)):
            if out.quantity == "displacement":
                C[i, :n] = r
            elif out.quantity == "velocity":
                C[i, n:] = r
                D[i] = r @ mbv
            else:
                if has_rate:
                    raise ConfigError(
                        f"output {out.name!r}: acceleration with a base-motion input through dampers "
                        "needs the base velocity's derivative; use displacement or velocity outputs, "
                        "or model the base as a body driven by forces")
                C[i] = r @ A[n:]
                D[i] = r @ (minv @ bf + follow)
        A, B, C, D = self._append_sensor_dynamics(outputs, A, B, C, D)
        return StateSpace(A, B, C, D, tuple(i.name for i in inputs), tuple(o.name for o in outputs),
                          tuple(o.unit for o in outputs))

    def _append_sensor_dynamics(self, outputs, A, B, C, D):
        blocks = []
        for i, out in enumerate(outputs):
            if out.sensor_name is None:
                continue
            dyn = self.chain.sensor_dynamics(out.sensor_name)
            parts = ([dyn.zpk()] if dyn is not None else []) + (
                [self.chain.front_end.zpk()] if self.chain.front_end is not None else [])
            if parts:
                blocks.append((i, scipy.signal.zpk2ss(*AnalogFilter.series(parts).zpk())))
        if not blocks:
            return A, B, C, D
        nx = A.shape[0]
        nf = sum(b[1][0].shape[0] for b in blocks)
        A2 = np.zeros((nx + nf, nx + nf))
        A2[:nx, :nx] = A
        B2 = np.vstack([B, np.zeros((nf, B.shape[1]))])
        C2 = np.hstack([C, np.zeros((C.shape[0], nf))])
        D2 = D.copy()
        k = nx
        for i, (af, bf, cf, df) in blocks:
            m = af.shape[0]
            bf, cf, df = bf[:, 0], cf[0], df[0, 0]
            A2[k:k + m, k:k + m] = af
            A2[k:k + m, :nx] = np.outer(bf, C[i])
            B2[k:k + m] = np.outer(bf, D[i])
            C2[i, :] = 0.0
            C2[i, :nx] = df * C[i]
            C2[i, k:k + m] = cf
            D2[i] = df * D[i]
            k += m
        return A2, B2, C2, D2

    def transfer(self, inputs, outputs, frequency_hz) -> np.ndarray:
        """Transfer matrix ``H(j 2 pi f)`` (Eq. 3.18), shape (n_freq, n_out, n_in), complex."""
        ss = self.state_space(inputs, outputs)
        s = 2j * np.pi * np.atleast_1d(np.asarray(frequency_hz, float))
        eye = np.eye(ss.A.shape[0])
        x = np.linalg.solve(s[:, None, None] * eye - ss.A, np.broadcast_to(ss.B, (len(s),) + ss.B.shape))
        return ss.C @ x + ss.D

    def describe(self) -> dict:
        """Physical parameters for display (SI)."""
        return {
            "name": self.name,
            "bodies": [{"name": b.name, "mass_kg": b.mass, "com_m": b.com.tolist(),
                        "inertia_kg_m2": b.inertia.tolist(), "dofs": list(b.dofs)} for b in self.bodies],
            "springs": [{"name": s.name, "point_m": s.point.tolist(), "body": s.body, "other": s.other,
                         "stiffness_n_per_m": s.stiffness.tolist(), "damping_n_s_per_m": s.damping.tolist()}
                        for s in self.springs],
            "flexible_modes": [{"name": f.name, "body": f.body, "frequency_hz": f.frequency_hz,
                                "damping_ratio": f.damping_ratio} for f in self.structure.flexible_modes],
            **self.info,
        }

