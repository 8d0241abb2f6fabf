"""The excitation of an experiment: where and how the hammer hit."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Excitation:
    """Where and how the hammer hit: force channel, point (m, rig frame; for the thesis rig from the
    platform's centre of mass, platform axes) and unit direction."""

    force_channel: int
    point: np.ndarray
    direction: np.ndarray
    #: the moving body hit, given when the point lies on two bodies' plates (``--force-body``);
    #: None: the rig's ``force_body`` of the point
    body: str | None = None


def check_force_point(rig, point, where: str = "force point") -> None:
    """Refuse a force point (m, rig frame) outside every plate of ``rig`` in one line naming the
    nearest body and how far off it is. A rig without plates cannot be checked."""
    from odsuite.core.errors import ConfigError
    from odsuite.core.rig import FORCE_POINT_SLACK
    from odsuite.core.rigidbody import plate_corners

    p = np.asarray(point, dtype=float)
    gaps = {}
    for body in rig.bodies:
        if body.plate is None:
            continue
        c = plate_corners(body.plate)
        lo, hi = c.min(axis=0), c.max(axis=0)
        gaps[body.name] = float(np.linalg.norm(np.maximum(0.0, np.maximum(lo - p, p - hi))))
    if not gaps or min(gaps.values()) <= FORCE_POINT_SLACK:
        return
    nearest = min(gaps, key=gaps.get)
    mm = ", ".join(f"{1e3 * v:g}" for v in p)
    raise ConfigError(f"{where} ({mm}) mm is outside every body of rig {rig.name!r}: the nearest, "
                      f"{nearest!r}, is {1e3 * gaps[nearest]:.1f} mm away")
