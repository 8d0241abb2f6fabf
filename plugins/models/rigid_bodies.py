"""The ``rigid-bodies`` model: a rig file's moving bodies on its springs, built from geometry.

Every body with a mass moves (in the coordinates its ``dofs`` allow); every ``[[springs]]`` entry
joins a body to the ground or to another body at its position (thesis Eq. 3.3-3.16 generalised:
``K = sum T(r)^T k T(r)`` over the springs, ``T(r) = [I | -[r]x]``).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from odsuite.api import ConfigError
from odsuite.api import Model, RigidBody, SpringDamper
from odsuite.api import Rig

#: a stiffness eigenvalue below this fraction of the largest is a motion no spring resists (the
#: matrices are assembled from positive coefficients, so rounding is ~1e-16 of the largest)
UNRESTRAINED = 1e-10
#: a motion whose undamped natural frequency is below this (Hz) is one no spring holds in any
#: measurement (a period of over a quarter of an hour): springs all equally soft pass the relative
#: test above (1e-300 N/m gave modes of 0 Hz and damping ratios of -1)
SLOWEST_HZ = 1e-3


def rigid_bodies(rig: Rig | None) -> Model:
    """The model of ``rig``: its moving bodies on its springs; refuses a body no spring holds."""
    if rig is None:
        raise ConfigError("the 'rigid-bodies' model is built from a rig's bodies and springs, and the project has no rig")
    where = f"rig {rig.name!r}" + (f" ({rig.source})" if rig.source else "")
    moving = rig.moving_bodies
    if not moving:
        raise ConfigError(f"{where}: no body has a 'mass', so nothing moves in the 'rigid-bodies' model")
    held = {s.body for s in rig.springs} | {s.other for s in rig.springs}
    loose = [b.name for b in moving if b.name not in held]
    if loose:
        raise ConfigError(f"{where}: body {loose[0]!r} is held by no [[springs]] entry, so nothing restores its motion")
    bodies = [RigidBody.from_rig(b) for b in moving]
    springs = [SpringDamper(s.name, s.position, s.body, s.other, s.stiffness, s.damping, s.rot_stiffness,
                            s.rot_damping, group=s.group if s.group != s.name else "") for s in rig.springs]
    model = Model.build(bodies, springs, name="rigid-bodies", rig=rig,
                        info={"source": str(rig.source) if rig.source else rig.name})
    k = model.K
    names = [f"{b.name}.{d}" for b in bodies for d in b.dofs]
    eig, vec = np.linalg.eigh(k)
    if eig[0] <= UNRESTRAINED * eig[-1]:
        motion = _motion(vec[:, 0], names)
        raise ConfigError(f"{where}: the springs do not resist the motion {motion}: add or reorient springs")
    w2, shapes = scipy.linalg.eigh(k, model.M)
    if w2[0] < (2 * np.pi * SLOWEST_HZ) ** 2:
        motion = _motion(shapes[:, 0] / shapes[np.argmax(np.abs(shapes[:, 0])), 0], names)  # its largest part +1
        hz = np.sqrt(max(w2[0], 0.0)) / (2 * np.pi)
        raise ConfigError(f"{where}: the springs hardly resist the motion {motion}: its natural frequency is "
                          f"{hz:.3g} Hz (below {SLOWEST_HZ:g} Hz); check the springs' 'stiffness' (N/m)")
    return model


def _motion(shape: np.ndarray, names: list[str]) -> str:
    """A motion's larger parts as a sum of its coordinates ("0.44 base.theta - 0.22 machine.y")."""
    parts = [(v, n) for v, n in zip(shape, names) if abs(v) > 0.1]
    return "".join(f"{'' if i == 0 else (' - ' if v < 0 else ' + ')}{v if i == 0 else abs(v):.2g} {n}"
                   for i, (v, n) in enumerate(parts))
