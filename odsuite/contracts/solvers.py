"""The coordinate-solver contract, and the choice of a solver for each body of a rig.

A provider registered through ``odsuite_register_coordinate_solvers`` has:

- ``name`` (str) and ``description`` (str);
- ``suitability(rig, body, sensors) -> float | None``: how well it can solve ``body`` from the
  named sensors (a subset of the body's sensors that a record holds); None when it cannot. When
  the rig file names no solver for a body, the most suitable one is used (the built-ins: 2 for the
  nine-accelerometer set, 1 for least squares over six or more independent directions);
- ``solve(rig, body, signals) -> SolverResult``: generalized coordinates of the body (m, rad, rig
  axes) from ``signals`` (sensor name -> samples along the sensor's positive axis, in one physical
  quantity: displacement, velocity or acceleration; solvers are linear in them). Raises
  :class:`~odsuite.domain.errors.ConfigError` naming the rig, body and sensors when it cannot.

Optional: ``rigidity_check(rig, body, accelerations) -> Rigidity`` where the layout measures some
motion twice (a rigid body gives equal estimates).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from odsuite.domain.errors import ConfigError
from odsuite.domain.rig import Body, Rig, body_sensors



class CoordinateSolver(Protocol):
    """What every registered coordinate solver has (checked when a plugin registers one)."""

    name: str
    description: str

    def suitability(self, rig: Rig, body: Body, sensors: Sequence[str]) -> float | None: ...

    def solve(self, rig: Rig, body: Body, signals: Mapping[str, np.ndarray]) -> Any: ...


PROTOCOL = CoordinateSolver
#: optional members that, where given, must be methods
OPTIONAL_METHODS = ("rigidity_check",)


@dataclass(frozen=True)
class BodySolver:
    """The solver chosen for one body, with the sensors it reads."""

    body: Body
    name: str
    solver: Any
    sensors: tuple[str, ...]


def _directions(rig: Rig, body: Body, sensors: Iterable[str]) -> str:
    return "; ".join(f"{s.name} along {np.round(s.axis, 3).tolist()} at {np.round(s.position * 1e3, 1).tolist()} mm"
                     for s in body_sensors(rig, body) if s.name in set(sensors)) or "no sensors"


def choose_solver(rig: Rig, body: Body, sensors: Iterable[str], registry) -> BodySolver:
    """The solver for ``body`` from the named sensors (``registry``: the coordinate solvers): the
    rig's choice, else the most suitable."""
    on_body = {s.name for s in body_sensors(rig, body)}
    names = tuple(s for s in sensors if s in on_body)
    where = f"rig {rig.name!r}" + (f" ({rig.source})" if rig.source else "")
    if body.solver is not None:
        if body.solver not in registry:
            raise ConfigError(f"{where}: body {body.name!r} field 'solver': unknown coordinate solver "
                              f"{body.solver!r} (known: {', '.join(registry.names())})")
        solver = registry.get(body.solver)
        if solver.suitability(rig, body, names) is None:
            raise ConfigError(f"{where}: body {body.name!r} field 'solver': {body.solver!r} cannot solve the "
                              f"body from its sensors ({_directions(rig, body, names)})")
        return BodySolver(body, body.solver, solver, names)
    scored = [(score, name) for name, solver in registry.items()
              if (score := solver.suitability(rig, body, names)) is not None]
    if not scored:
        raise ConfigError(f"{where}: body {body.name!r}: its motion cannot be solved from its sensors "
                          f"({_directions(rig, body, names)}): six independent directions are needed")
    score, name = max(scored, key=lambda t: (t[0], t[1]))
    return BodySolver(body, name, registry.get(name), names)


def body_solvers(rig: Rig, available: Iterable[str], registry) -> tuple[list[BodySolver], list[str]]:
    """A solver for every body with sensors among ``available``, and one note per body whose
    motion those sensors cannot determine."""
    available = set(available)
    chosen, notes = [], []
    for body in rig.bodies:
        names = [s.name for s in body_sensors(rig, body) if s.name in available]
        if not names:
            continue
        if body.solver is not None:  # the rig file's own choice: a failure is the file's error
            chosen.append(choose_solver(rig, body, names, registry))
            continue
        try:
            chosen.append(choose_solver(rig, body, names, registry))
        except ConfigError as exc:
            notes.append(str(exc))
    return chosen, notes


def harmonic_shapes(rig: Rig, displacements: dict[str, complex], registry, where: str) -> dict[str, np.ndarray]:
    """Per body whose motion the sensors determine: its six complex generalized coordinates at G
    (m, rad) from complex sensor displacements (amplitude and phase along each sensor's axis). The
    solvers are linear in their input, so the real and imaginary parts go through as a two-sample
    record."""
    signals = {n: np.array([complex(d).real, complex(d).imag]) for n, d in displacements.items()}
    chosen, notes = body_solvers(rig, signals, registry)
    shapes = {}
    for c in chosen:
        at_g = c.solver.solve(rig, c.body, {n: signals[n] for n in c.sensors}).at_g
        shapes[c.body.name] = at_g[0] + 1j * at_g[1]
    if not shapes:
        raise ConfigError(f"{where}: rig {rig.name!r}: no body's motion can be solved from the recorded sensors "
                          f"({'; '.join(notes) or 'no sensors'})")
    return shapes
