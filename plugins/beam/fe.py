"""A 1-D finite-element beam bending in one plane: Euler-Bernoulli or Timoshenko elements, free,
pinned, clamped or elastically supported ends, point masses; modal damping.

The beam lies along the rig's x axis from ``origin`` (its end at x = 0) and bends along z: each
node carries the deflection w (m, along +z) and the section's rotation about y (rad). Rotations
follow dw/dx, so a point's deflection between nodes is the cubic Hermite interpolation of its
element's nodal values (exact for Euler-Bernoulli, a fine approximation for the short elements of
a Timoshenko mesh).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import numpy as np
import scipy  # scipy.linalg loads on first use: fast `odsuite plugins`

from odsuite.api import ConfigError
from odsuite.api import LinearStructure

THEORIES = ("euler-bernoulli", "timoshenko")
#: constrained nodal dofs (deflection, rotation) of each end condition
END_CONSTRAINTS = {"free": (), "pinned": (0,), "clamped": (0, 1)}
#: a point this far (m) beyond an end still belongs to the beam (a sensor's centre above an end)
END_SLACK = 1e-3


@dataclass(frozen=True)
class Support:
    """A spring to the ground at ``position`` (m from the beam's x = 0 end), ``stiffness`` N/m."""

    name: str
    position: float
    stiffness: float


@dataclass(frozen=True)
class PointMass:
    """A rigid mass (kg) at ``position`` (m from the x = 0 end), e.g. an accelerometer."""

    name: str
    position: float
    mass: float


@dataclass(frozen=True)
class BeamSpec:
    """Everything that defines a beam model; effects change it with ``dataclasses.replace``.

    ``gyration_ratio_sq`` is (r / L)^2 with r the section's radius of gyration (h / sqrt(12) for a
    rectangle of height h): the rotary inertia and, with ``shear_flexibility`` = E / (kappa G),
    the shear deformation of Timoshenko elements depend on it alone. ``damping_ratio`` lists the
    bending modes' modal damping ratios (the last one holds for every higher mode);
    ``support_damping_ratio`` is that of the rigid-body (support) modes.
    """

    body: str
    origin: np.ndarray
    length: float
    mass_per_length: float
    bending_stiffness: float
    theory: str = "euler-bernoulli"
    gyration_ratio_sq: float = 0.0
    shear_flexibility: float = 2 * 1.3 / (5 / 6)  # E/(kappa G): nu = 0.3, rectangle kappa = 5/6
    ends: tuple[str, str] = ("free", "free")
    elements: int = 40
    damping_ratio: tuple[float, ...] = (0.005,)
    support_damping_ratio: float = 0.1
    supports: tuple[Support, ...] = ()
    masses: tuple[PointMass, ...] = ()

    def __post_init__(self) -> None:
        w = f"beam {self.body!r}"
        for name in ("length", "mass_per_length", "bending_stiffness"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ConfigError(f"{w} field {name!r}: must be a finite number > 0, got {v!r}")
        if self.theory not in THEORIES:
            raise ConfigError(f"{w} field 'theory': expected one of {THEORIES}, got {self.theory!r}")
        if len(self.ends) != 2 or any(e not in END_CONSTRAINTS for e in self.ends):
            raise ConfigError(f"{w} field 'ends': expected two of {tuple(END_CONSTRAINTS)}, got {self.ends!r}")
        if not (isinstance(self.elements, int) and 2 <= self.elements <= 2000):
            raise ConfigError(f"{w} field 'elements': expected an integer in 2..2000, got {self.elements!r}")
        if not (0 <= self.gyration_ratio_sq < 0.1 and self.shear_flexibility >= 0):
            raise ConfigError(f"{w} field 'gyration_ratio_sq': expected 0 <= (r/L)^2 < 0.1, got {self.gyration_ratio_sq!r}")
        if not self.damping_ratio or any(not 0 <= z < 1 for z in self.damping_ratio) or \
                not 0 <= self.support_damping_ratio < 1:
            raise ConfigError(f"{w} field 'damping_ratio': expected ratios in [0, 1), got "
                              f"{self.damping_ratio!r} (support modes {self.support_damping_ratio!r})")
        for kind, items in (("support", self.supports), ("point mass", self.masses)):
            for item in items:
                self.local(item.position, f"{w} {kind} {item.name!r} field 'position'")
        for s in self.supports:
            if not (np.isfinite(s.stiffness) and s.stiffness >= 0):
                raise ConfigError(f"{w} support {s.name!r} field 'stiffness': must be >= 0 N/m, got {s.stiffness!r}")
        for m in self.masses:
            if not (np.isfinite(m.mass) and m.mass >= 0):
                raise ConfigError(f"{w} point mass {m.name!r} field 'mass': must be >= 0 kg, got {m.mass!r}")

    def local(self, x: float, where: str) -> float:
        """``x`` (m along the beam) checked to lie on it."""
        if not (np.isfinite(x) and -END_SLACK <= x <= self.length + END_SLACK):
            raise ConfigError(f"{where}: {x!r} m is not on the beam (0..{self.length:g} m)")
        return float(min(max(x, 0.0), self.length))

    @property
    def n_rigid(self) -> int:
        """Rigid-body modes of the beam on its ends alone (2 free-free, 1 pinned-free, else 0)."""
        return max(0, 2 - sum(len(END_CONSTRAINTS[e]) for e in self.ends))


def element_matrices(spec: BeamSpec) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass matrices (4 x 4, dofs w1 r1 w2 r2) of one element of ``spec``.

    Euler-Bernoulli: cubic Hermite stiffness and consistent mass. Timoshenko: the shear-deformable
    element with interdependent interpolation, Phi = 12 EI / (kappa G A l^2) (Przemieniecki,
    Theory of Matrix Structural Analysis, 1968, Sec. 5.6 and 11.4), with the rotary inertia mu r^2."""
    l = spec.length / spec.elements
    ei, mu = spec.bending_stiffness, spec.mass_per_length
    timo = spec.theory == "timoshenko"
    r2 = spec.gyration_ratio_sq * spec.length**2 if timo else 0.0
    p = 12 * r2 * spec.shear_flexibility / l**2
    k = ei / ((1 + p) * l**3) * np.array([
        [12, 6 * l, -12, 6 * l],
        [6 * l, (4 + p) * l**2, -6 * l, (2 - p) * l**2],
        [-12, -6 * l, 12, -6 * l],
        [6 * l, (2 - p) * l**2, -6 * l, (4 + p) * l**2]])
    a11, a12 = 13 / 35 + 7 * p / 10 + p**2 / 3, (11 / 210 + 11 * p / 120 + p**2 / 24) * l
    a13, a14 = 9 / 70 + 3 * p / 10 + p**2 / 6, -(13 / 420 + 3 * p / 40 + p**2 / 24) * l
    a22, a24 = (1 / 105 + p / 60 + p**2 / 120) * l**2, -(1 / 140 + p / 60 + p**2 / 120) * l**2
    m = mu * l / (1 + p) ** 2 * np.array([
        [a11, a12, a13, a14],
        [a12, a22, -a14, a24],
        [a13, -a14, a11, -a12],
        [a14, a24, -a12, a22]])
    if r2 > 0:
        b12 = (1 / 10 - p / 2) * l
        b22, b24 = (2 / 15 + p / 6 + p**2 / 3) * l**2, (-1 / 30 - p / 6 + p**2 / 6) * l**2
        m = m + mu * r2 / ((1 + p) ** 2 * l) * np.array([
            [6 / 5, b12, -6 / 5, b12],
            [b12, b22, -b12, b24],
            [-6 / 5, -b12, 6 / 5, -b12],
            [b12, b24, -b12, b22]])
    return k, m


def hermite(spec: BeamSpec, x: float) -> np.ndarray:
    """Deflection at ``x`` (m along the beam) per unit nodal dof: 2 (elements + 1) entries."""
    l = spec.length / spec.elements
    e = min(int(x // l), spec.elements - 1)
    s = x / l - e
    row = np.zeros(2 * (spec.elements + 1))
    row[2 * e:2 * e + 4] = [1 - 3 * s**2 + 2 * s**3, l * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3, l * (s**3 - s**2)]
    return row


def assemble(spec: BeamSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(K, M, free): matrices over the unconstrained dofs, and those dofs' indices."""
    n = 2 * (spec.elements + 1)
    ke, me = element_matrices(spec)
    K, M = np.zeros((n, n)), np.zeros((n, n))
    for e in range(spec.elements):
        K[2 * e:2 * e + 4, 2 * e:2 * e + 4] += ke
        M[2 * e:2 * e + 4, 2 * e:2 * e + 4] += me
    for s in spec.supports:
        h = hermite(spec, s.position)
        K += s.stiffness * np.outer(h, h)
    for pm in spec.masses:
        h = hermite(spec, pm.position)
        M += pm.mass * np.outer(h, h)
    fixed = [d for d in END_CONSTRAINTS[spec.ends[0]]] + [n - 2 + d for d in END_CONSTRAINTS[spec.ends[1]]]
    free = np.array([i for i in range(n) if i not in fixed])
    return K[np.ix_(free, free)], M[np.ix_(free, free)], free


class BeamStructure(LinearStructure):
    """A :class:`~odsuite.domain.model.LinearStructure` built from a :class:`BeamSpec`."""

    def __init__(self, spec: BeamSpec) -> None:
        self.spec = spec
        self.K, self.M, self._free = assemble(spec)
        names = [f"{spec.body}.{kind}{i}" for i in range(spec.elements + 1) for kind in ("w", "ry")]
        self.dof_names = tuple(names[i] for i in self._free)

    def with_spec(self, **changes) -> BeamStructure:
        return BeamStructure(replace(self.spec, **changes))

    @functools.cached_property
    def normal_modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Undamped modes: angular frequencies (rad/s, ascending) and mass-normalised shapes."""
        w2, phi = scipy.linalg.eigh(self.K, self.M)
        return np.sqrt(np.clip(w2, 0.0, None)), phi

    def mode_damping(self) -> np.ndarray:
        """The modal damping ratio of every normal mode: support modes first, then bending modes."""
        n = len(self.dof_names)
        zeta = np.empty(n)
        nr = self.spec.n_rigid
        zeta[:nr] = self.spec.support_damping_ratio
        given = np.asarray(self.spec.damping_ratio, float)
        bend = np.arange(n - nr)
        zeta[nr:] = given[np.minimum(bend, len(given) - 1)]
        return zeta

    @functools.cached_property
    def C(self) -> np.ndarray:
        """Modal damping: C = M Phi diag(2 zeta w) Phi^T M, so each normal mode keeps its shape."""
        w, phi = self.normal_modes
        mp = self.M @ phi
        return (mp * (2 * self.mode_damping() * w)) @ mp.T

    def damped_modes_hz(self) -> np.ndarray:
        return self.bending_frequencies_hz()

    def with_mode_damping(self, zeta) -> BeamStructure:
        """Bending mode k (from 0) damped at ``zeta[k]``; the others keep their ratios."""
        given = list(self.spec.damping_ratio)
        # one entry beyond the last set mode keeps the higher modes' ratio
        n = max([len(given), *(k + 2 for k in zeta)])
        ratios = [given[min(k, len(given) - 1)] for k in range(n)]
        for k, z in zeta.items():
            ratios[k] = float(z)
        return self.with_spec(damping_ratio=tuple(ratios))

    def bending_frequencies_hz(self) -> np.ndarray:
        """Undamped natural frequencies (Hz) of the bending modes (support modes left out)."""
        return self.normal_modes[0][self.spec.n_rigid:] / (2 * np.pi)

    def position(self, point, where: str) -> float:
        """The coordinate along the beam of a rig-frame point (m)."""
        return self.spec.local(float(np.asarray(point, float)[0] - self.spec.origin[0]), where)

    def point_rows(self, body: str | None, point: np.ndarray) -> np.ndarray:
        if body is not None and body != self.spec.body:
            raise ConfigError(f"beam model: no body {body!r} (the beam is {self.spec.body!r})")
        x = self.position(point, f"beam {self.spec.body!r}: point {np.round(np.asarray(point, float), 6).tolist()} m")
        rows = np.zeros((3, len(self.dof_names)))
        rows[2] = hermite(self.spec, x)[self._free]
        return rows
