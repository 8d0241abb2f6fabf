"""What a rig holds, for `odsuite info`: bodies (mass, sensors, the coordinate solver each gets),
springs (where, between what, how stiff)."""

from __future__ import annotations

from typing import Any

import numpy as np

from odsuite.domain.errors import ConfigError
from odsuite.domain.rig import Rig, body_sensors
from odsuite.contracts.solvers import choose_solver


def rig_layout(rig: Rig, solvers) -> dict[str, Any]:
    """Bodies and springs of ``rig`` as plain data (SI units). Per body its sensors and solver: the
    rig file's or the most suitable one among ``solvers`` (the registry), or why none can solve it."""
    bodies = []
    for body in rig.bodies:
        sensors = [s.name for s in body_sensors(rig, body)]
        solver, reason = None, None
        if sensors:
            try:
                solver = choose_solver(rig, body, sensors, solvers).name
            except ConfigError as exc:
                reason = str(exc)
        bodies.append({"name": body.name, "moving": body.mass is not None, "mass_kg": body.mass,
                       "com_m": np.asarray(body.com).tolist(), "dofs": list(body.dofs), "sensors": sensors,
                       "solver": solver, "solver_problem": reason})
    springs = [{"name": s.name, "body": s.body, "other": s.other or "ground", "group": s.group,
                "position_m": np.asarray(s.position).tolist(),
                "stiffness_n_per_m": np.asarray(s.stiffness).tolist(),
                "damping_n_s_per_m": np.asarray(s.damping).tolist()} for s in rig.springs]
    return {"name": rig.name, "bodies": bodies, "springs": springs,
            "force_channel": rig.force_channel, "channel_count": rig.channel_count}
