"""Which of a model's modes are suspension modes: the moving bodies swinging together as one rigid
body on their mounts, as opposed to modes that deform the assembly (a motor rocking on its mounts on
the plate). A reader reads the first kind off the mounts and the second off the bodies' joints."""

from __future__ import annotations

import numpy as np

#: a mode is a suspension mode when every body's motion differs from the first body's, carried
#: rigidly to it, by less than this share of its own motion (the plate-and-motor rig's six lowest
#: modes stay below 0.12, its mount modes above 1)
RIGID_TOLERANCE = 0.3
#: and the rigid bodies carry at least this share of its kinetic energy (a flexible plate's mode,
#: an effect's modal coordinate, carries none of it)
RIGID_ENERGY_SHARE = 0.5


def suspension_modes(model) -> np.ndarray | None:
    """Per mode of ``model.modes()``, whether it is a suspension mode; None when the model's
    structure has no rigid bodies to compare (finite elements)."""
    try:
        structure, bodies = model.structure, list(model.bodies)
        shapes = model.modes().shapes
        if not bodies:
            return None
        first = bodies[0].name
        flags = _rigid_energy_share(structure, bodies, shapes) >= RIGID_ENERGY_SHARE
        for b in bodies[1:]:
            own = structure.body_coordinates(b.name) @ shapes
            carried = structure.body_coordinates(first, at=b.com) @ shapes
            size = np.maximum(np.linalg.norm(np.abs(own), axis=0), 1e-300)
            flags &= np.linalg.norm(np.abs(own - carried), axis=0) / size < RIGID_TOLERANCE
    except (AttributeError, NotImplementedError, KeyError, ValueError):  # no rigid bodies (finite elements)
        return None
    return flags


def _rigid_energy_share(structure, bodies, shapes) -> np.ndarray:
    """Per mode, the share of its kinetic energy (shape^H M shape) in the rigid bodies' motion."""
    total = np.real(np.einsum("ik,ij,jk->k", np.conj(shapes), structure.M, shapes))
    rigid = np.zeros(shapes.shape[1])
    for b in bodies:
        q = structure.body_coordinates(b.name) @ shapes
        mb = np.zeros((6, 6))
        mb[:3, :3] = b.mass * np.eye(3)
        mb[3:, 3:] = b.inertia
        rigid += np.real(np.einsum("ik,ij,jk->k", np.conj(q), mb, q))
    return rigid / np.maximum(total, 1e-300)


def mode_words(frequency_hz, flags) -> str:
    """"9.5, 15.3 (suspension); 80.7, 94.1 (the bodies move against each other)" or the plain list."""
    f = [f"{v:.1f}" for v in frequency_hz]
    if flags is None or len(flags) != len(f):
        return ", ".join(f)
    sus = [v for v, s in zip(f, flags) if s]
    rest = [v for v, s in zip(f, flags) if not s]
    parts = ([", ".join(sus) + " (suspension: the bodies together on their mounts)"] if sus else []) + (
        [", ".join(rest) + " (the bodies move against each other)"] if rest else [])
    return "; ".join(parts)
