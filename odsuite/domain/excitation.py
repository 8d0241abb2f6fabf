"""The excitation of an experiment: where and how the hammer hit."""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from odsuite.domain import arguments
from odsuite.domain.errors import ConfigError
from odsuite.domain.textfiles import plain_number


#: a force point farther than this from the rig's origin (m) is no lab's: 1e300 m ran through every
#: analysis as overflow warnings (read from a project or given on the command line)
MAX_POINT_M = 1e4


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


def _mm(point) -> str:
    return ", ".join(f"{1e3 * v:.4g}" for v in np.asarray(point, dtype=float))


def _boxes(rig) -> dict:
    from odsuite.domain.rigidbody import plate_corners

    boxes = {}
    for body in rig.bodies:
        if body.plate is not None:
            c = plate_corners(body.plate)
            boxes[body.name] = (c.min(axis=0), c.max(axis=0), body.mass is not None)
    return boxes


def check_force_point(rig, point, where: str = "force point") -> None:
    """Refuse a force point (m, rig frame) outside every plate of ``rig``, or on a fixed body's plate
    only (no mass: a hit there drives nothing), in one line naming the nearest body and how far off
    it is. A rig without plates cannot be checked."""
    from odsuite.domain.rig import FORCE_POINT_SLACK

    p = np.asarray(point, dtype=float)
    boxes = _boxes(rig)
    gaps = {name: float(np.linalg.norm(np.maximum(0.0, np.maximum(lo - p, p - hi))))
            for name, (lo, hi, _) in boxes.items()}
    if not gaps:
        return
    nearest = min(gaps, key=gaps.get)
    if gaps[nearest] > FORCE_POINT_SLACK:
        # the body a hammer can hit: the nearest moving one (the floor's plate is nearer under a frame)
        moving = {name: gap for name, gap in gaps.items() if boxes[name][2]}
        near = min(moving, key=moving.get) if moving else nearest
        raise ConfigError(f"{where} ({_mm(p)}) mm is outside every body of rig {rig.name!r}: the nearest "
                          f"{'moving body' if moving else 'body'}, {near!r}, is {1e3 * gaps[near]:.1f} mm away")
    if not any(moving and gaps[name] <= FORCE_POINT_SLACK for name, (_, _, moving) in boxes.items()):
        moving = [name for name, (_, _, m) in boxes.items() if m]
        raise ConfigError(f"{where} ({_mm(p)}) mm lies on {nearest!r}, which has no mass and does not move: "
                          f"hit a moving body ({', '.join(moving) or 'none has a plate'})")


def surface_point(rig, point, direction=None) -> tuple[np.ndarray, str | None]:
    """A force point (m, rig frame) inside a moving body's plate, deeper than FORCE_POINT_SLACK,
    moved onto that plate's nearest face that a blow along ``direction`` strikes (a hammer hits a
    surface from outside), with a line saying so; any other point unchanged, with None."""
    from odsuite.domain.rig import FORCE_POINT_SLACK

    p = np.asarray(point, dtype=float)
    for name, (lo, hi, moving) in _boxes(rig).items():
        depths = np.concatenate([p - lo, hi - p])  # to the low faces, then the high faces
        if not moving or depths.min() <= FORCE_POINT_SLACK:
            continue
        if direction is not None:  # outward normals -e (low faces), +e (high): struck when against the blow
            normals = np.concatenate([-np.eye(3), np.eye(3)])
            depths = np.where(normals @ np.asarray(direction, dtype=float) < 0, depths, np.inf)
        k = int(np.argmin(depths))
        axis = k % 3
        snapped = p.copy()
        snapped[axis] = (lo if k < 3 else hi)[axis]
        return snapped, (f"force point ({_mm(p)}) mm is {1e3 * depths[k]:.1f} mm inside body {name!r}; moved onto "
                         f"the nearest face the blow strikes, {'xyz'[axis]} = {1e3 * snapped[axis]:.4g} mm: ({_mm(snapped)}) mm")
    return p, None


_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def _three_numbers(value: str | Sequence[float], option: str, expected: str = "three numbers X,Y,Z",
                   shown: str | None = None) -> np.ndarray:
    parts = value.split(",") if isinstance(value, str) else list(value)
    value = value if shown is None else shown
    try:
        numbers = np.array([plain_number(p.strip()) if isinstance(p, str) else float(p) for p in parts], dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{option}: expected {expected}, got {value!r}") from None
    if numbers.shape != (3,):
        raise ConfigError(f"{option}: expected {expected}, got {value!r}")
    if not np.all(np.isfinite(numbers)):
        raise ConfigError(f"{option}: expected finite numbers, got {value!r}")
    return numbers


#: lengths a position may be written in; a bare number is in POINT_UNIT
LENGTH_UNITS = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}
POINT_UNIT = "mm"
_LENGTH = re.compile(r"\s*(.*?)\s*(mm|cm|m)?\s*", re.IGNORECASE)


def read_force_point(value: str | Sequence[float], option: str = "--force-point") -> tuple[np.ndarray, bool]:
    """``"X,Y,Z"`` -> metres, and whether the numbers were bare (read as mm, the thesis's Table 5.3
    unit). Each number may carry its unit (``200mm,150mm,75mm``); a unit on the last number only
    applies to all three (``0.2,0.15,0.075m``)."""
    if not isinstance(value, str):
        return _near_origin(_three_numbers(value, option) * LENGTH_UNITS[POINT_UNIT], option, value), True
    parts = value.split(",")
    matches = [_LENGTH.fullmatch(part) for part in parts]
    if len(parts) != 3:
        raise ConfigError(f"{option}: expected three numbers X,Y,Z, got {value!r}")
    units = [m.group(2).lower() if m.group(2) else None for m in matches]
    if units[0] is None and units[1] is None and units[2] is not None:
        units = [units[2]] * 3
    given = [u for u in units if u]
    if given:  # a bare 0 is 0 in every unit
        units = [u or (given[0] if _zero(m.group(1)) else None) for u, m in zip(units, matches)]
    if None in units and any(units):
        raise ConfigError(f"{option}: give a unit on every number other than 0 or on none (bare numbers are mm), "
                          f"got {value!r}")
    numbers = _three_numbers([m.group(1) for m in matches], option, shown=value)
    scale = np.array([LENGTH_UNITS[u or POINT_UNIT] for u in units])
    return _near_origin(numbers * scale, option, value), not given


def _near_origin(point: np.ndarray, option: str, value) -> np.ndarray:
    if np.any(np.abs(point) > MAX_POINT_M):  # 1e308m overflowed to inf in the distance to the bodies
        raise ConfigError(f"{option}: expected a point within {MAX_POINT_M:g} m of the rig's origin, got {value!r}")
    return point + 0.0  # no -0.0 shown


def _zero(text: str) -> bool:
    try:
        return plain_number(text.strip()) == 0
    except ValueError:
        return False


def parse_force_point(value: str | Sequence[float]) -> np.ndarray:
    """``"X,Y,Z"`` -> metres: numbers with units (``200mm``, ``0.2m``) or bare numbers in mm (for the
    thesis rig from the platform's centre of mass, platform axes, as Table 5.3)."""
    if not isinstance(value, str | Sequence | np.ndarray):  # None raised "not iterable"
        arguments.refuse("parse_force_point", "value", value, "three numbers 'X,Y,Z' (text or a list)")
    return read_force_point(value)[0]


def parse_force_direction(value: str | Sequence[float]) -> np.ndarray:
    """``+x``, ``-x``, ``+y``, ``-y``, ``+z``, ``-z`` or a vector ``"dx,dy,dz"`` -> a unit vector."""
    if not isinstance(value, str | Sequence | np.ndarray):  # 5 raised "not iterable"
        arguments.refuse("parse_force_direction", "value", value, "an axis (+x, -x, +y, -y, +z, -z) or three "
                         "numbers 'dx,dy,dz'")
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
