"""The excitation of an experiment: where and how the hammer hit."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from odsuite.domain.errors import ConfigError


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
    from odsuite.domain.errors import ConfigError
    from odsuite.domain.rig import FORCE_POINT_SLACK
    from odsuite.domain.rigidbody import plate_corners

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


_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def _three_numbers(value: str | Sequence[float], option: str, expected: str = "three numbers X,Y,Z") -> np.ndarray:
    parts = value.split(",") if isinstance(value, str) else list(value)
    try:
        numbers = np.array([float(p) for p in parts], dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{option}: expected {expected}, got {value!r}") from None
    if numbers.shape != (3,):
        raise ConfigError(f"{option}: expected {expected}, got {value!r}")
    if not np.all(np.isfinite(numbers)):
        raise ConfigError(f"{option}: expected finite numbers, got {value!r}")
    return numbers


def parse_force_point(value: str | Sequence[float]) -> np.ndarray:
    """``"X,Y,Z"`` in mm from the platform's centre of mass, platform axes (as Table 5.3) -> metres."""
    return _three_numbers(value, "--force-point") / 1000.0


def parse_force_direction(value: str | Sequence[float]) -> np.ndarray:
    """``+x``, ``-x``, ``+y``, ``-y``, ``+z``, ``-z`` or a vector ``"dx,dy,dz"`` -> a unit vector."""
    if isinstance(value, str):
        text = value.strip().lower()
        sign, axis = (text[0], text[1:]) if text[:1] in "+-" and len(text) == 2 else ("+", text)
        if axis in _AXES:
            return np.array(_AXES[axis]) * (-1.0 if sign == "-" else 1.0) + 0.0  # no -0.0
    vector = _three_numbers(value, "--force-dir",
                            "an axis +x, -x, +y, -y, +z, -z or three numbers dx,dy,dz")
    norm = math.hypot(*vector)
    if norm == 0:
        raise ConfigError(f"--force-dir: the zero vector {value!r} has no direction")
    return vector / norm
