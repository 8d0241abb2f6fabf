"""Effects of the beam model family: what a slender Euler-Bernoulli beam on its ends may lack.

Each effect applies to a model whose structure is a :class:`~.fe.BeamStructure` (``structures``), so
the diagnosis of a rigid-body rig never screens them.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from odsuite.contracts.effects import Effect, Parameter
from odsuite.api import Model

from .fe import BeamStructure, PointMass
from .model import describe, range_of

#: bending modes whose damping ratios are fitted one by one; higher modes keep the last one
DAMPED_MODES = 4
#: (r/L)^2 up to a stubby beam (L = 3 h): past that a beam model says little
MAX_GYRATION_RATIO_SQ = 1 / 108


def _spec(model: Model):
    st = model.structure
    return st.spec if isinstance(st, BeamStructure) else None


def _with_spec(model: Model, **changes) -> Model:
    out = model.replace(structure=model.structure.with_spec(**changes))
    out.info = {**model.info, **describe(out.structure.spec)}
    return out


def _accelerometers(model: Model) -> list:
    return [s for s in model.sensors if s.quantity == "acceleration" and s.body == _spec(model).body]


class ShearRotaryInertia(Effect):
    name = "beam-shear-rotary"
    target = "model"
    structures = (BeamStructure,)
    description = ("Timoshenko beam: shear deformation and rotary inertia of the section lower the higher "
                   "bending modes, set by the section's (radius of gyration / length)^2.")

    def parameters(self, model):
        spec = _spec(model)
        if spec is None or spec.theory == "timoshenko":
            return []
        return [Parameter("gyration_ratio_sq", "1", 0.0, 0.0, MAX_GYRATION_RATIO_SQ,
                          description="(r/L)^2, r = radius of gyration of the section (h/sqrt(12) for a rectangle)")]

    def _apply(self, model, v):
        return _with_spec(model, theory="timoshenko", gyration_ratio_sq=v["gyration_ratio_sq"])

    def physical(self, model, v):
        L = _spec(model).length
        return [("radius of gyration / length", float(np.sqrt(v["gyration_ratio_sq"])), "1"),
                (f"height of a rectangular section {1e3 * L:g} mm long", 1e3 * L * float(np.sqrt(12 * v["gyration_ratio_sq"])), "mm")]


class SensorMass(Effect):
    name = "beam-sensor-mass"
    target = "model"
    structures = (BeamStructure,)
    description = "The accelerometer's own mass rides on the beam at the sensor (mass loading)."

    def parameters(self, model):
        spec = _spec(model)
        if spec is None or not _accelerometers(model):
            return []
        beam = spec.mass_per_length * spec.length
        return [Parameter("mass", "kg", 0.0, 0.0, 0.2 * beam,
                          description="mass of each accelerometer and its mounting (up to 20 % of the beam)")]

    def _apply(self, model, v):
        st = model.structure
        masses = tuple(m for m in st.spec.masses if not m.name.startswith("sensor:"))
        for s in _accelerometers(model):
            x = st.position(np.asarray(s.position, float) + model.chain.offset.get(s.name, 0.0), f"sensor {s.name!r}")
            masses += (PointMass(f"sensor:{s.name}", x, v["mass"]),)
        return _with_spec(model, masses=masses)

    def physical(self, model, v):
        return [("mass of each accelerometer", 1e3 * v["mass"], "g")]


class SupportStiffness(Effect):
    """Elastic supports at the rig file's points: each its own stiffness, or (``alike``) one
    stiffness for all, as for blocks cut from the same foam."""

    target = "model"
    structures = (BeamStructure,)

    def __init__(self, alike: bool = False) -> None:
        self.alike = alike
        if alike:
            self.name = "beam-supports-alike"
            self.description = "Alike elastic supports (blocks of one foam) at the rig file's points: one stiffness for all."
        else:
            self.name = "beam-supports"
            self.description = "Elastic supports (foam blocks, mounts) at the rig file's given points, each with its own stiffness."

    def parameters(self, model):
        spec = _spec(model)
        if spec is None or not spec.supports:
            return []
        mass = spec.mass_per_length * spec.length
        # up to the stiffness that would hold the whole beam at 1 kHz, above any beam's first bending mode here
        ceiling = mass * (2 * np.pi * 1000.0) ** 2
        # plausible: each support carrying its share of the beam bounces between 1 Hz and a tenth of the
        # first bending mode (the free-free test practice: rigid-body modes well below the elastic ones)
        f1 = BeamStructure(replace(spec, supports=())).bending_frequencies_hz()[0]
        share = mass / len(spec.supports)
        plausible = (share * (2 * np.pi) ** 2, share * (2 * np.pi * 0.1 * f1) ** 2)
        if self.alike:
            nominal = float(np.mean([s.stiffness for s in spec.supports]))
            return [Parameter("stiffness", "N/m", nominal, 0.0, max(ceiling, 10 * nominal), plausible=plausible,
                              description="stiffness of every support (" + ", ".join(
                                  f"{s.name} at {s.position:g} m" for s in spec.supports) + ")")]
        return [Parameter(f"{s.name}_stiffness", "N/m", s.stiffness, 0.0, max(ceiling, 10 * s.stiffness),
                          plausible=plausible, description=f"stiffness of support {s.name} at {s.position:g} m")
                for s in spec.supports]

    def _apply(self, model, v):
        spec = model.structure.spec
        stiffness = {s.name: v["stiffness"] if self.alike else v[f"{s.name}_stiffness"] for s in spec.supports}
        return _with_spec(model, supports=tuple(replace(s, stiffness=stiffness[s.name]) for s in spec.supports))

    def physical(self, model, v):
        return [(f"stiffness of {s.name}", s.stiffness, "N/m") for s in self._apply(model, v).structure.spec.supports]


class _Scale(Effect):
    structures = (BeamStructure,)
    field = ""
    unit_bounds = (0.5, 2.0)

    def parameters(self, model):
        if _spec(model) is None:
            return []
        return [Parameter("scale", "1", 1.0, *self.unit_bounds, description=f"{self.field} / its value in the model")]

    def _apply(self, model, v):
        return _with_spec(model, **{self.field: getattr(model.structure.spec, self.field) * v["scale"]})

    def physical(self, model, v):
        spec = model.structure.spec
        label, unit, per = self.quantity
        length = spec.length if per else 1.0
        return [(label, getattr(spec, self.field) * v["scale"] * length, unit)]


class StiffnessScale(_Scale):
    name = "beam-stiffness-scale"
    target = "model"
    field = "bending_stiffness"
    quantity = ("bending stiffness EI", "N m^2", False)
    description = "The beam's bending stiffness EI differs from the rig file's (every bending mode moves by its square root)."


class MassScale(_Scale):
    name = "beam-mass-scale"
    target = "model"
    field = "mass_per_length"
    quantity = ("mass of the beam", "kg", True)
    description = "The beam's mass per length differs from the rig file's (response amplitudes and frequencies change)."


class ModalDamping(Effect):
    name = "beam-modal-damping"
    target = "model"
    structures = (BeamStructure,)
    description = f"Each of the first {DAMPED_MODES} bending modes has its own modal damping ratio."

    def parameters(self, model):
        spec = _spec(model)
        if spec is None:
            return []
        given = spec.damping_ratio
        return [Parameter(f"zeta_{i + 1}", "1", float(given[min(i, len(given) - 1)]), 1e-4, 0.1,
                          description=f"damping ratio of bending mode {i + 1}") for i in range(DAMPED_MODES)]

    def _apply(self, model, v):
        return _with_spec(model, damping_ratio=tuple(v[f"zeta_{i + 1}"] for i in range(DAMPED_MODES)))

    def physical(self, model, v):
        return [(f"damping ratio of bending mode {i + 1}", 100 * v[f"zeta_{i + 1}"], "%") for i in range(DAMPED_MODES)]


class Positions(Effect):
    name = "beam-positions"
    target = "chain"
    structures = (BeamStructure,)
    description = ("The accelerometer and the hammer sit elsewhere along the beam than recorded, within the "
                   "rig file's ranges (shared by every record of the setup).")

    def parameters(self, model):
        spec = _spec(model)
        sensors = _accelerometers(model) if spec is not None else []
        if not sensors:
            return []
        lo, hi = range_of(model.rig, "sensor_position_range", (0.0, spec.length))
        out = []
        for s in sensors:
            x = float(s.position[0] - spec.origin[0])
            out.append(Parameter(f"{s.name}_shift", "m", 0.0, min(lo - x, 0.0), max(hi - x, 0.0),
                                 description=f"sensor {s.name} along the beam, from {x:g} m (range {lo:g}..{hi:g} m)"))
        hlo, hhi = range_of(model.rig, "hammer_offset_range", (-0.1 * spec.length, 0.1 * spec.length))
        out.append(Parameter("hammer_shift", "m", 0.0, min(hlo, 0.0), max(hhi, 0.0),
                             description="hammer point along the beam from the recorded one"))
        return out

    def _apply(self, model, v):
        shifts = {s.name: np.array([v[f"{s.name}_shift"], 0.0, 0.0]) for s in _accelerometers(model)}
        chain = model.chain.with_items("offset", shifts)
        return model.replace(chain=replace(chain, force_offset=model.chain.force_offset + [v["hammer_shift"], 0.0, 0.0]))

    def physical(self, model, v):
        x0 = _spec(model).origin[0]
        return ([(f"sensor {s.name} from the beam's left end", 1e3 * (s.position[0] - x0 + v[f"{s.name}_shift"]), "mm")
                 for s in _accelerometers(model)]
                + [("hammer from its recorded point", 1e3 * v["hammer_shift"], "mm")])


def beam_effects() -> list[Effect]:
    return [ShearRotaryInertia(), SensorMass(), SupportStiffness(), SupportStiffness(alike=True), StiffnessScale(), MassScale(), ModalDamping(),
            Positions()]
