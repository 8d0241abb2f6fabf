"""The ``beam`` model family: a rig's moving body as a finite-element beam, read from the rig
file's ``[beam]`` table (docs/rig-format.md)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from odsuite.api import ConfigError
from odsuite.api import Model

from .fe import END_CONSTRAINTS, THEORIES, BeamSpec, BeamStructure, Support

#: fields of the rig file's [beam] table
FIELDS = {"body", "first_mode_hz", "bending_stiffness", "theory", "gyration_ratio_sq", "poisson_ratio",
          "shear_coefficient", "ends", "elements", "damping_ratio", "support_damping_ratio", "supports",
          "sensor_position_range", "hammer_offset_range"}


#: the largest bending stiffness (N m^2) a rig file may give
BENDING_STIFFNESS_MAX = 1e15


def _number(where: str, value: Any, low: float = 0.0, *, strict: bool = True) -> float:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value)
    if not ok or (value <= low if strict else value < low):
        raise ConfigError(f"{where}: expected a number {'>' if strict else '>='} {low:g}, got {value!r}")
    return float(value)


def _elements(where: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 2 <= value <= 2000:
        raise ConfigError(f"{where} field 'elements': expected an integer in 2..2000, got {value!r}")
    return value


def range_of(rig, key: str, default: tuple[float, float]) -> tuple[float, float]:
    """A [lower, upper] pair (m) of the rig's [beam] table."""
    table = rig.extra.get("beam", {}) if rig is not None else {}
    value = table.get(key, list(default))
    where = (f"{rig.source or 'rig ' + repr(rig.name)} [beam] field {key!r}") if rig is not None else key
    if not (isinstance(value, list) and len(value) == 2
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in value)
            and value[0] <= value[1]):
        raise ConfigError(f"{where}: expected [lower, upper] in m, got {value!r}")
    return float(value[0]), float(value[1])


def spec_from_rig(rig) -> BeamSpec:
    """The beam a rig file describes: geometry and mass from its body (the plate's length along x,
    thickness along z; the body's mass), the rest from its ``[beam]`` table."""
    if rig is None or not isinstance(rig.extra.get("beam"), Mapping):
        raise ConfigError("the beam model needs a rig file with a [beam] table (docs/rig-format.md)")
    where = f"{rig.source or 'rig ' + repr(rig.name)} [beam]"
    table = dict(rig.extra["beam"])
    unknown = sorted(set(table) - FIELDS)
    if unknown:
        raise ConfigError(f"{where}: unknown field(s) {unknown} (known: {sorted(FIELDS)})")
    moving = rig.moving_bodies
    name = table.get("body", moving[0].name if moving else None)
    body = next((b for b in moving if b.name == name), None)
    if body is None or body.plate is None:
        raise ConfigError(f"{where} field 'body': {name!r} is not a moving body with a [bodies.plate] "
                          "(the beam's length along x, width and thickness)")
    length = float(body.plate.size[0])
    origin = body.plate.corner + np.array([0.0, body.plate.size[1] / 2, body.plate.size[2] / 2])
    theory = table.get("theory", "euler-bernoulli")
    if theory not in THEORIES:
        raise ConfigError(f"{where} field 'theory': expected one of {THEORIES}, got {theory!r}")
    ends = table.get("ends", ["free", "free"])
    if not (isinstance(ends, list) and len(ends) == 2 and all(e in END_CONSTRAINTS for e in ends)):
        raise ConfigError(f"{where} field 'ends': expected two of {list(END_CONSTRAINTS)}, got {ends!r}")
    nu = _number(f"{where} field 'poisson_ratio'", table.get("poisson_ratio", 0.3), -1.0)
    kappa = _number(f"{where} field 'shear_coefficient'", table.get("shear_coefficient", 5 / 6))
    zeta = table.get("damping_ratio", 0.005)
    zeta = tuple(zeta) if isinstance(zeta, list) else (zeta,)
    if not zeta or any(isinstance(z, bool) or not isinstance(z, (int, float)) or not 0 <= z < 1 for z in zeta):
        raise ConfigError(f"{where} field 'damping_ratio': expected ratios in [0, 1), got {table.get('damping_ratio')!r}")
    support_zeta = table.get("support_damping_ratio", 0.1)
    if isinstance(support_zeta, bool) or not isinstance(support_zeta, (int, float)) or not 0 <= support_zeta < 1:
        raise ConfigError(f"{where} field 'support_damping_ratio': expected a ratio in [0, 1), got {support_zeta!r}")
    supports = []
    for i, s in enumerate(table.get("supports", [])):
        w = f"{where} supports[{i}]"
        if not isinstance(s, Mapping):
            raise ConfigError(f"{w}: expected a table with name, position and stiffness, got {s!r}")
        name = str(s.get("name", f"support{i + 1}"))
        if any(x.name == name for x in supports):
            # each support is fitted by its name: two of one name would be one parameter
            raise ConfigError(f"{w} field 'name': a second support named {name!r}")
        supports.append(Support(name,
                                _number(f"{w} field 'position'", s.get("position"), 0.0, strict=False),
                                _number(f"{w} field 'stiffness'", s.get("stiffness"), 0.0, strict=False)))
    spec = BeamSpec(body=body.name, origin=origin, length=length, mass_per_length=body.mass / length,
                    bending_stiffness=1.0, theory=theory,
                    gyration_ratio_sq=float(table.get("gyration_ratio_sq",
                                                      body.plate.size[2] ** 2 / 12 / length**2 if theory == "timoshenko" else 0.0)),
                    shear_flexibility=2 * (1 + nu) / kappa, ends=tuple(ends),
                    elements=_elements(where, table.get("elements", 40)), damping_ratio=zeta,
                    support_damping_ratio=float(support_zeta), supports=tuple(supports))
    # the ranges the positions' effect searches, refused now rather than when it runs
    range_of(rig, "sensor_position_range", (0.0, length))
    range_of(rig, "hammer_offset_range", (-0.1 * length, 0.1 * length))
    if "bending_stiffness" in table and "first_mode_hz" in table:
        raise ConfigError(f"{where}: give 'first_mode_hz' or 'bending_stiffness', not both (each sets the beam's "
                          "bending stiffness)")
    if "bending_stiffness" in table:
        ei = _number(f"{where} field 'bending_stiffness'", table["bending_stiffness"])
        if ei > BENDING_STIFFNESS_MAX:  # its element matrices overflow long before 1e300
            raise ConfigError(f"{where} field 'bending_stiffness': expected at most {BENDING_STIFFNESS_MAX:g} N m^2 "
                              f"(a bridge girder's is 1e12), got {ei:g}")
        return replace(spec, bending_stiffness=ei)
    if "first_mode_hz" not in table:
        raise ConfigError(f"{where}: give 'first_mode_hz' (the data's first bending mode) or 'bending_stiffness' (N m^2)")
    f1 = _number(f"{where} field 'first_mode_hz'", table["first_mode_hz"])
    # EI from the first bending mode of the bare beam on its ends (no supports): f scales with sqrt(EI)
    bare = BeamStructure(replace(spec, supports=(), theory="euler-bernoulli", gyration_ratio_sq=0.0))
    with np.errstate(over="ignore", under="ignore"):
        ei = (f1 / bare.bending_frequencies_hz()[0]) ** 2
    if not 0 < ei <= BENDING_STIFFNESS_MAX:  # its element matrices overflow long before 1e300
        raise ConfigError(f"{where} field 'first_mode_hz': {f1:g} Hz needs a bending stiffness of {ei:.3g} N m^2, "
                          f"outside (0, {BENDING_STIFFNESS_MAX:g}] (a bridge girder's is 1e12)")
    return replace(spec, bending_stiffness=ei)


def beam_model(rig) -> Model:
    """The beam of a rig file as a finite-element model (docs/beam.md)."""
    spec = spec_from_rig(rig)
    return Model(BeamStructure(spec), name="beam", rig=rig, info=describe(spec))


def describe(spec: BeamSpec) -> dict[str, Any]:
    return {"beam": {"body": spec.body, "length_m": spec.length, "mass_per_length_kg_per_m": spec.mass_per_length,
                     "bending_stiffness_n_m2": spec.bending_stiffness, "theory": spec.theory,
                     "gyration_ratio_sq": spec.gyration_ratio_sq, "ends": list(spec.ends),
                     "elements": spec.elements,
                     "supports": [{"name": s.name, "position_m": s.position, "stiffness_n_per_m": s.stiffness}
                                  for s in spec.supports],
                     "point_masses": [{"name": m.name, "position_m": m.position, "mass_kg": m.mass}
                                      for m in spec.masses]}}
