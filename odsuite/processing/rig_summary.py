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
                "damping_n_s_per_m": np.asarray(s.damping).tolist(),
                "rot_stiffness_n_m_per_rad": np.asarray(s.rot_stiffness).tolist(),
                "rot_damping_n_m_s_per_rad": np.asarray(s.rot_damping).tolist()} for s in rig.springs]
    return {"name": rig.name, "bodies": bodies, "springs": springs,
            "force_channel": rig.force_channel, "channel_count": rig.channel_count}


def undamped(rig: Rig) -> str | None:
    """A line where ``rig`` has springs and none of them damping (the rig format's default): its
    modes then ring without end, and every hit's response far outlasts a damped structure's."""
    if not rig.springs or any(np.any(np.asarray(s.damping, float)) or np.any(np.asarray(s.rot_damping, float))
                              for s in rig.springs):
        return None
    where = f"rig {rig.name!r}" + (f" ({rig.source})" if rig.source else "")
    return (f"{where}: no spring has damping (the rig format's default is none), so the model's modes ring "
            "without end; give each spring's `damping` (N s/m), or let `diagnose` fit the `damping` effect, "
            "which gives an undamped model a damping ratio per axis")


def far_from_bodies(rig: Rig) -> list[str]:
    """Points of ``rig`` farther from their body's plate than the plate's largest size (a centre of
    mass, a sensor, a spring): one line each, since positions given in mm instead of m load without
    an error and move the physics by a factor of a thousand."""
    plates = {b.name: b.plate for b in rig.bodies if b.plate is not None}

    def gap(body: str, point) -> float | None:
        plate = plates.get(body)
        if plate is None:
            return None
        lo, hi = np.asarray(plate.corner, float), np.asarray(plate.corner, float) + np.asarray(plate.size, float)
        d = float(np.linalg.norm(np.maximum(0.0, np.maximum(lo - point, point - hi))))
        return d if d > float(np.max(plate.size)) else None

    where = f"rig {rig.name!r}" + (f" ({rig.source})" if rig.source else "")

    def line(what: str, body: str, point, d: float) -> str:
        p = ", ".join(f"{1e3 * v:.6g}" for v in np.asarray(point, float))
        return f"{where}: {what} at ({p}) mm is {d:.3g} m from the plate of body {body!r}: positions are in m"

    out = []
    for b in rig.bodies:
        if (d := gap(b.name, np.asarray(b.com, float))) is not None:
            out.append(line(f"body {b.name!r} field 'com'", b.name, b.com, d))
    entries: dict[str, list] = {}  # a triaxial accelerometer's axes share one [[sensors]] entry: one line
    for s in rig.sensors:
        if s.body is not None and s.position is not None and (d := gap(s.body, np.asarray(s.position, float))):
            entries.setdefault(s.group or s.name, []).append((s, d))
    for entry, axes in entries.items():
        s, d = axes[0]
        named = repr(s.name) if len(axes) == 1 else f"{entry!r} ({', '.join(a.name for a, _ in axes)})"
        out.append(line(f"sensor {named} field 'position'", s.body, s.position, d))
    for sp in rig.springs:
        gaps = [gap(b, np.asarray(sp.position, float)) for b in (sp.body, sp.other) if b is not None]
        if gaps and all(g is not None for g in gaps):  # near one of its two bodies is enough
            out.append(line(f"spring {sp.name!r} field 'position'", sp.body, sp.position, min(gaps)))
    return out
