"""A point mass clamped to the first moving body (a cable clamp, an extra sensor, a bolt)."""

import numpy as np

from odsuite.contracts.effects import Effect, Parameter
from odsuite.api import RigidBody, Structure


def _about(offset: np.ndarray) -> np.ndarray:
    """Inertia tensor of a unit point mass at ``offset`` (m) about the origin (kg m^2 per kg)."""
    return float(offset @ offset) * np.eye(3) - np.outer(offset, offset)


class AddedPointMass(Effect):
    name = "lab_added_mass"
    target = "model"
    description = "A point mass fixed to the first moving body at a point of its plate."

    def parameters(self, model):
        body = model.bodies[0]
        # the mass sits within the body's plate (or 5 cm of its centre of mass without one)
        half = 0.05 * np.ones(3)
        centre = body.com
        if model.rig is not None:
            plate = model.rig.body(body.name).plate
            if plate is not None:
                half, centre = plate.size / 2, plate.corner + plate.size / 2
        return ([Parameter("added_mass", "kg", 0.0, 0.0, 0.5 * body.mass,
                           description=f"point mass added to {body.name}")]
                + [Parameter(f"at_{a}", "m", float(c), float(c - h), float(c + h),
                             description=f"where the mass sits, rig {a}")
                   for a, c, h in zip("xyz", centre, half)])

    def _apply(self, model, v):
        body = model.bodies[0]
        dm = v["added_mass"]
        if dm == 0.0:
            return model
        point = np.array([v["at_x"], v["at_y"], v["at_z"]])
        mass = body.mass + dm
        com = (body.mass * body.com + dm * point) / mass
        # parallel-axis theorem: the body's and the point's inertia about the new centre of mass
        inertia = body.inertia + body.mass * _about(body.com - com) + dm * _about(point - com)
        moved = RigidBody(body.name, mass, inertia, com, body.dofs)
        st = model.structure
        bodies = tuple(moved if b is body else b for b in st.bodies)
        return model.replace(structure=Structure(bodies, st.springs, st.flexible_modes))
