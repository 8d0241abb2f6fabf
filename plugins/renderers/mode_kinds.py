"""Which of a model's modes are suspension modes: the moving bodies swinging together as one rigid
body on their mounts, as opposed to modes that deform the assembly (a motor rocking on its mounts on
the plate). A reader reads the first kind off the mounts and the second off the bodies' joints."""

from __future__ import annotations

import numpy as np

#: a mode is a suspension mode when at least this share of it (mass-weighted) is the bodies moving
#: together as one rigid assembly: the plate-and-motor rig's six lowest modes 1.00, its mount modes
#: below 0.01; the three-body stand's stack rocking on its isolators 0.97-1.00 although its
#: compliant mounts let the bodies lag each other by 30-60 % of their motion (the earlier test on
#: that lag called them deforming); a flexible plate's mode, moving no rigid body, 0
RIGID_ASSEMBLY_SHARE = 0.5


def suspension_modes(model) -> np.ndarray | None:
    """Per mode of ``model.modes()``, whether it is a suspension mode; None when the model's
    structure has no rigid bodies to compare (finite elements). Two modes that share one of the
    assembly's rigid motions (0.44 and 0.57 of it) count by their shares: the larger is called one."""
    try:
        structure, bodies = model.structure, list(model.bodies)
        shapes = model.modes().shapes
        if not bodies:
            return None
        share = _rigid_assembly_share(structure, bodies, shapes)
    except (AttributeError, NotImplementedError, KeyError, ValueError):  # no rigid bodies (finite elements)
        return None
    return share >= RIGID_ASSEMBLY_SHARE


def _rigid_assembly_share(structure, bodies, shapes) -> np.ndarray:
    """Per mode, the share of its mass-weighted size in the six motions of every body moving rigidly
    with the first (an M-orthogonal projection onto them)."""
    ref = np.asarray(bodies[0].com, float)
    columns = []
    for e in np.eye(6):
        v = np.zeros(structure.n_dof)
        for b in bodies:
            translation = e[:3] + np.cross(e[3:], np.asarray(b.com, float) - ref)
            v += structure.body_coordinates(b.name).T @ np.concatenate([translation, e[3:]])
        columns.append(v)
    T, M = np.column_stack(columns), structure.M
    TM = T.T @ M
    keep = np.linalg.svd(TM @ T, compute_uv=False) > 1e-12 * np.trace(TM @ T)  # a planar body: fewer motions
    if not keep.all():
        u, _, _ = np.linalg.svd(T, full_matrices=False)
        T = u[:, :int(keep.sum())]
        TM = T.T @ M
    projected = T @ np.linalg.solve(TM @ T, TM @ shapes)
    size = np.real(np.einsum("ik,ij,jk->k", np.conj(shapes), M, shapes))
    return np.real(np.einsum("ik,ij,jk->k", np.conj(projected), M, projected)) / np.maximum(size, 1e-300)


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
