"""Physical effects: named, parametrised changes of a model that a fitting loop can try.

Each effect lists its parameters for a given model (``parameters(model)``: name, unit, nominal
value that leaves the model unchanged, bounds, scope "shared" or "per_experiment") and applies
itself (``apply(model, values) -> Model``; missing values take their nominal). ``target`` says
whether it changes the structure ("model": M, C, K, modes) or only the measurement chain ("chain":
sensor and force-gauge signals; the structure and its cached matrices are reused). Apply is cheap
enough to call in a fitting loop: nothing is recomputed that the effect does not change.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import replace

import numpy as np
import scipy  # scipy.signal loads on first use: registration stays light

from odsuite.contracts.effects import Effect, Parameter
from odsuite.api import ConfigError
from odsuite.api import FlexibleMode, Model, RigidBody, SensorDynamics, SpringDamper, Structure
from odsuite.api import cross, rotated

#: density used where a rig gives a plate but no mass (steel, as App. C's inertia listing)
STEEL_DENSITY = 7841.0


def _with_structure(model: Model, **changes) -> Model:
    st = model.structure
    kw = {"bodies": st.bodies, "springs": st.springs, "flexible_modes": st.flexible_modes}
    kw.update(changes)
    return model.replace(structure=Structure(**kw))


def _sensors(model: Model) -> tuple:
    """The accelerometers of the model's rig: the sensors the comparison predicts."""
    return tuple(s for s in model.sensors if s.quantity == "acceleration")


AXES = ("x", "y", "z")


class _SpringScale(Effect):
    """Scale spring coefficients per axis (all springs) and per spring group (all axes); a spring
    without a group is its own group."""

    structures = (Structure,)  # rigid bodies on springs
    field = ""
    unit_bounds = (0.05, 20.0)
    plausible = (0.05, 20.0)
    #: each spring scaled on its own, whatever its group
    per_spring = False

    def _key(self, spring) -> str:
        return spring.name if self.per_spring else (spring.group or spring.name)

    def parameters(self, model):
        lo, hi = self.unit_bounds
        groups: dict[str, list[str]] = {}
        for s in model.springs:
            groups.setdefault(self._key(s), []).append(s.name)
        alike = Counter(s.group for s in model.springs if s.group)
        if self.per_spring and not any(n > 1 for n in alike.values()):
            return []  # no group of like springs: the group scales are the springs' already
        return ([Parameter(f"scale_{a}", "1", 1.0, lo, hi, description=f"{self.field} along {a}, every spring",
                           plausible=self.plausible)
                 for a in AXES]
                + [Parameter(f"scale_{g}", "1", 1.0, lo, hi, plausible=self.plausible,
                             description=f"{self.field} of {g}" + (f" ({', '.join(n)})" if n != [g] else "")
                             + ", every axis")
                   for g, n in groups.items()])

    def _apply(self, model, v):
        axis = np.array([v[f"scale_{a}"] for a in AXES])
        springs = []
        for s in model.springs:
            # rotational terms follow the spring's overall scale
            rf = v[f"scale_{self._key(s)}"]
            if self.field == "stiffness":
                springs.append(replace(s, stiffness=s.scaled("stiffness", axis * rf), rot_stiffness=s.rot_stiffness * rf))
            else:
                springs.append(replace(s, damping=s.scaled("damping", axis * rf), rot_damping=s.rot_damping * rf))
        return _with_structure(model, springs=tuple(springs))

    def physical(self, model, v):
        """Each spring group's coefficient along each rig axis (of one of its springs), the
        determined product of the axis and group factors."""
        unit = "N/m" if self.field == "stiffness" else "N s/m"
        out, seen = [], set()
        changed = {s.name: s for s in self._apply(model, v).structure.springs}
        for s in model.springs:
            g = self._key(s)
            if g in seen:
                continue
            seen.add(g)
            k = np.diag(changed[s.name].matrix(self.field))
            who = g if g == s.name else f"{g} (each, e.g. {s.name})"
            out += [(f"{self.field} of {who} along {a}", float(k[i]), unit)
                    for i, a in enumerate(AXES) if np.diag(s.matrix(self.field))[i] > 0 or k[i] > 0]
        return out


class Stiffness(_SpringScale):
    name = "stiffness"
    field = "stiffness"
    unit_bounds = (0.25, 4.0)
    # springs and mounts as built lie within a factor of two of their data-sheet stiffness
    plausible = (0.5, 2.0)
    description = "Spring stiffness scaled per axis (all springs) and per spring group (all axes)."


class SpringStiffness(Stiffness):
    """One spring of a group of like springs differs from the rest (a worn or softer mount among
    four): the stiffness scaled per axis and per spring. It refines ``stiffness``, which scales a
    group together as the rig file declares it, from that fit (each spring at its group's scale),
    and counts only when the springs' own scales earn their place."""

    name = "spring_stiffness"
    refines = "stiffness"
    per_spring = True
    description = "Spring stiffness scaled per axis (all springs) and per spring, a spring of a group on its own."

    def refined_start(self, model, values):
        return {f"scale_{s.name}": values[f"scale_{s.group}"] for s in model.springs
                if s.group and f"scale_{s.group}" in values}


#: the largest damping ratio an undamped model's suspension may be given (rubber mounts: 5-15 %)
UNDAMPED_ZETA_MAX = 0.5


class Damping(_SpringScale):
    """Spring damping scaled per axis and per spring group. A model whose springs have no damping
    at all (the rig format's default) has nothing to scale: there the effect gives every spring,
    along each axis, the damping of a ratio ``zeta`` of its share of the body it carries,
    ``c = 2 zeta sqrt(k m)`` (m: the body's mass over the springs on it)."""

    name = "damping"
    field = "damping"
    unit_bounds = (0.0, 20.0)
    # damping is known to within an order of magnitude at best
    plausible = (0.1, 10.0)
    description = ("Spring damping scaled per axis (all springs) and per spring group (all axes); on an "
                   "undamped model, a damping ratio per axis.")

    @staticmethod
    def _undamped(model) -> bool:
        return not any(np.any(s.matrix("damping")) or np.any(s.rot_damping) for s in model.springs)

    def parameters(self, model):
        if not self._undamped(model):
            return super().parameters(model)
        return [Parameter(f"zeta_{a}", "1", 0.0, 0.0, UNDAMPED_ZETA_MAX, plausible=(0.0, 0.2),
                          description=f"damping ratio of every spring along {a} (the model had none)")
                for a in AXES]

    def _apply(self, model, v):
        if not self._undamped(model):
            return super()._apply(model, v)
        st = model.structure
        carried = Counter(b for s in model.springs for b in (s.body, s.other) if b)
        springs = []
        for s in model.springs:
            # the share of the lightest body it holds: a spring between two bodies damps their
            # relative motion, which the lighter one mostly makes
            m = min(st.body(b).mass / carried[b] for b in (s.body, s.other) if b)
            k = np.clip(np.diag(s.matrix("stiffness")), 0.0, None)
            zeta = np.array([v[f"zeta_{a}"] for a in AXES])
            springs.append(replace(s, damping=2.0 * zeta * np.sqrt(k * m)))
        return _with_structure(model, springs=tuple(springs))


#: deflection at which a hardening parameter is stated: hammer tests move suspensions by
#: micrometres (a 45 N hit on the thesis rig: ~1 um) to tens of micrometres
HARDENING_REFERENCE_M = 1e-6
#: hardening starts: decades, as the deflections a rig's hits reach span decades (the fit then
#: moves within a decade; each start costs a nonlinear simulation)
HARDENING_STARTS = (1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0)


class NonlinearStiffness(Effect):
    """A cubic hardening term per spring group: ``k3 = hardening x k / d_ref^2`` along each rig
    axis (``d_ref`` = 1 um), so the group's stiffness rises by ``hardening`` at a deflection of
    1 um. The response then depends on the force's level; the model is integrated in time."""

    structures = (Structure,)  # rigid bodies on springs
    name = "nonlinear_stiffness"
    target = "model"
    description = "Amplitude-dependent (cubic hardening) stiffness per spring group."

    @staticmethod
    def _groups(model) -> dict[str, list[str]]:
        groups: dict[str, list[str]] = {}
        for s in model.springs:
            groups.setdefault(s.group or s.name, []).append(s.name)
        return groups

    def parameters(self, model):
        return [Parameter(f"hardening_{g}", "1", 0.0, 0.0, 1000.0, starts=HARDENING_STARTS, ladder=True,
                          description=f"relative stiffness rise of {g} at a {1e6 * HARDENING_REFERENCE_M:g} um deflection"
                          + (f" ({', '.join(n)})" if n != [g] else ""))
                for g, n in self._groups(model).items()]

    def _apply(self, model, v):
        springs = []
        for s in model.springs:
            h = v[f"hardening_{s.group or s.name}"]
            k = np.diag(s.matrix("stiffness"))
            springs.append(replace(s, cubic=s.cubic + h * k / HARDENING_REFERENCE_M**2) if h else s)
        return _with_structure(model, springs=tuple(springs))


class MassProperties(Effect):
    """Mass, inertia and centre of mass of every moving body; springs, sensors and force points keep
    their places (they are rig-frame points), so only their arms about the centre of mass change.
    With several moving bodies each parameter is named after its body ("machine_mass_scale")."""

    structures = (Structure,)  # rigid bodies on springs
    name = "mass_properties"
    description = "Body mass and inertia scales, added products of inertia, centre-of-mass offset, per body."

    @staticmethod
    def _prefix(model, body: RigidBody) -> str:
        return "" if len(model.bodies) == 1 else f"{body.name}_"

    def parameters(self, model):
        out = []
        for b in model.bodies:
            pre = self._prefix(model, b)
            prod = 0.5 * float(np.sqrt(np.min(np.diag(b.inertia)) * np.max(np.diag(b.inertia))))
            # the centre of mass moves at most as far as a part as heavy as the body (mass_scale 2)
            # put at its far corner moves it: half the half-diagonal of the uniform box of this
            # inertia (trace I = m (L^2 + W^2 + H^2) / 6); a fixed 20 mm cut off a 3 kg part at
            # 0.3 m on a 40 kg base
            reach = 0.5 * float(np.sqrt(1.5 * np.trace(b.inertia) / b.mass))
            # a body gains at most its own mass (an added part) and loses little (a mis-weighed
            # body): mass and moments within 0.8-2 times their values
            out += ([Parameter(f"{pre}mass_scale", "1", 1.0, 0.5, 2.0, description=f"mass of {b.name}",
                               plausible=(0.8, 2.0))]
                    + [Parameter(f"{pre}{n}_scale", "1", 1.0, 0.5, 2.0, description=f"moment of inertia {n} of {b.name}",
                                 plausible=(0.8, 2.0))
                       for n in ("Ixx", "Iyy", "Izz")]
                    + [Parameter(f"{pre}{n}", "kg m^2", 0.0, -prod, prod, description=f"added product of inertia {n} of {b.name}")
                       for n in ("Ixy", "Iyz", "Ixz")]
                    + [Parameter(f"{pre}com_d{a}", "m", 0.0, -reach, reach,
                                 description=f"centre of mass offset of {b.name} along {a}")
                       for a in AXES])
        return out

    def _apply(self, model, v):
        bodies = []
        for b in model.bodies:
            pre = self._prefix(model, b)
            scale = np.sqrt([v[f"{pre}Ixx_scale"], v[f"{pre}Iyy_scale"], v[f"{pre}Izz_scale"]])
            inertia = b.inertia * np.outer(scale, scale)  # scales moments, keeps the products' proportion
            inertia = inertia - np.array([[0, v[f"{pre}Ixy"], v[f"{pre}Ixz"]], [v[f"{pre}Ixy"], 0, v[f"{pre}Iyz"]],
                                          [v[f"{pre}Ixz"], v[f"{pre}Iyz"], 0]])
            bodies.append(RigidBody(b.name, b.mass * v[f"{pre}mass_scale"], inertia,
                                    b.com + np.array([v[f"{pre}com_d{a}"] for a in AXES]), b.dofs))
        return _with_structure(model, bodies=tuple(bodies))

    def physical(self, model, v):
        """Each body's mass (kg), moments of inertia (kg m^2) and centre of mass (mm, rig frame)."""
        out = []
        for b in self._apply(model, v).structure.bodies:
            if b.name not in {m.name for m in model.bodies}:
                continue
            out.append((f"mass of {b.name}", float(b.mass), "kg"))
            out += [(f"{n} of {b.name}", float(b.inertia[i, i]), "kg m^2") for i, n in enumerate(("Ixx", "Iyy", "Izz"))]
            out += [(f"centre of mass of {b.name}, {a}", 1e3 * float(b.com[i]), "mm") for i, a in enumerate(AXES)]
        return out


class PlateFlexibility(Effect):
    """An added flexible mode of the platform (the rigid model lacks it; thesis §5.4.2, Fig. 5.12).

    ``shape="kirchhoff"``: out-of-plane deflection ``w = twist xi eta + bend_x (xi^2 - 1/3) +
    bend_y (eta^2 - 1/3)`` over the plate (xi, eta in [-1, 1] from its centre), the lowest
    free-plate shapes of Kirchhoff theory in polynomial (Rayleigh-Ritz) form, orthogonal to the
    rigid motions; in-plane motion ``-(z - z_mid) grad w`` (normals stay normal). ``shape="free"``:
    one participation value per sensor (along its axis) and one for the force points.
    Participations are per unit mass-normalised modal coordinate (1/sqrt(kg)); all zero = no mode.
    """

    target = "model"
    structures = (Structure,)  # a mode of a rigid body's plate
    breaks_rigidity = True  # a flexible mode makes the redundant angular estimates disagree

    def __init__(self, shape: str = "kirchhoff") -> None:
        if shape not in ("kirchhoff", "free"):
            raise ConfigError(f"plate flexibility shape: expected 'kirchhoff' or 'free', got {shape!r}")
        self.shape = shape
        self.name = "plate_flexibility" if shape == "kirchhoff" else "plate_flexibility_free"
        self.description = ("A flexible platform mode with a Kirchhoff-plate twist/bending shape."
                            if shape == "kirchhoff" else
                            "A flexible platform mode with free participation at each sensor and force point.")

    @staticmethod
    def _plated(model) -> list[str]:
        """The moving bodies with a plate: the ones that can bend."""
        if model.rig is None:
            return []
        moving = {b.name for b in model.bodies}
        return [b.name for b in model.rig.bodies if b.name in moving and b.plate is not None]

    def parameters(self, model):
        plated = self._plated(model)
        if not plated:  # nothing to bend: the effect does not apply to this model
            return []
        # an elastic mode of a body lies above its rigid modes on the suspension, and a bare metal
        # structure damps it lightly
        top = float(np.max(model.modes().frequency_hz, initial=20.0))
        common = [Parameter("frequency_hz", "Hz", 400.0, 20.0, 5000.0, description="natural frequency as mounted",
                            plausible=(min(top, 5000.0), 5000.0), below_nyquist=True),
                  Parameter("damping_ratio", "1", 0.02, 0.0, 0.5, description="modal damping ratio",
                            plausible=(0.0, 0.1))]
        if len(plated) > 1:
            common.append(Parameter("body", "1", 0.0, 0.0, len(plated) - 1, choices=tuple(map(float, range(len(plated)))),
                                    description="which plated body bends: " + ", ".join(
                                        f"{i} = {n}" for i, n in enumerate(plated))))
        if self.shape == "kirchhoff":
            return common + [Parameter(n, "kg^-1/2", 0.0, -5.0, 5.0, description=f"{n} amplitude")
                             for n in ("twist", "bend_x", "bend_y")]
        # a sensor's participation changes its own output row alone
        return common + [Parameter(f"phi_{s.name}", "kg^-1/2", 0.0, -5.0, 5.0,
                                   description=f"participation at sensor {s.name} along its axis", sensor=s.name)
                         for s in _sensors(model)] + [
            Parameter("phi_force", "kg^-1/2", 0.0, -5.0, 5.0, description="participation at the force points")]

    def _apply(self, model, v):
        mode = self.added_mode(model, v)
        if mode is None:
            return model
        return _with_structure(model, flexible_modes=model.structure.flexible_modes + (mode,))

    def added_mode(self, model, v) -> FlexibleMode | None:
        """The uncoupled flexible mode ``apply`` adds to ``model``'s structure at the values ``v``
        and nothing else: None where it adds none (every amplitude zero)."""
        amps = {k: val for k, val in v.items() if k not in ("frequency_hz", "damping_ratio", "body")}
        if not any(amps.values()):
            return None
        body = self._plated(model)[int(v.get("body", 0.0))]
        if self.shape == "kirchhoff":
            plate = model.rig.body(body).plate
            centre = plate.corner + plate.size / 2
            half = plate.size[:2] / 2
            t, bx, by = amps["twist"], amps["bend_x"], amps["bend_y"]

            def shape(point, direction, tag):
                xi, eta = (point[:2] - centre[:2]) / half
                w = t * xi * eta + bx * (xi * xi - 1 / 3) + by * (eta * eta - 1 / 3)
                dw = np.array([t * eta + 2 * bx * xi, t * xi + 2 * by * eta]) / half
                dz = point[2] - centre[2]
                return float(direction @ np.array([-dz * dw[0], -dz * dw[1], w]))
        else:
            table = {s.name: amps[f"phi_{s.name}"] for s in _sensors(model)}
            table["force"] = amps["phi_force"]

            def shape(point, direction, tag):
                return table.get(tag, 0.0)

        return FlexibleMode(f"{self.name}{len(model.structure.flexible_modes) + 1}", body,
                            v["frequency_hz"], v["damping_ratio"], shape)


def _scaled(signals, factors: dict[str, float]) -> dict:
    """``signals`` with the named sensors' samples divided by their factor (1: left as they are)."""
    return {n: (x / factors[n] if factors.get(n, 1.0) != 1.0 else x) for n, x in signals.items()}


def _remounted(rig, change) -> object:
    """``rig`` with each sensor replaced by ``change(sensor)`` (the sensor as mounted)."""
    return replace(rig, sensors=tuple(change(s) for s in rig.sensors))


class _PerSensor(Effect):
    target = "chain"
    breaks_rigidity = True  # one faulty sensor makes the redundant angular estimates disagree
    per_sensor: tuple[tuple[str, str, float, float, float, str], ...] = ()  # suffix, unit, nominal, lo, hi, text
    plausible: tuple[float, float] | None = None

    def parameters(self, model):
        # each changes its sensor's output row alone
        return [Parameter(f"{s.name}_{suffix}" if suffix else s.name, unit, nom, lo, hi,
                          description=f"{text} of sensor {s.name} (channel {s.channel})", plausible=self.plausible,
                          sensor=s.name)
                for s in _sensors(model) for suffix, unit, nom, lo, hi, text in self.per_sensor]


class SensorGain(_PerSensor):
    name = "sensor_gain"
    description = "A sensor's sensitivity differs from its calibration: its signal is scaled."
    per_sensor = (("gain", "1", 1.0, 0.5, 2.0, "gain error"),)
    # a calibrated accelerometer is off by a few per cent; 30 % is a wrong sensor or setting
    plausible = (0.7, 1.4)

    def _apply(self, model, v):
        g = {s.name: model.chain.gain.get(s.name, 1.0) * v[f"{s.name}_gain"] for s in _sensors(model)}
        return model.replace(chain=model.chain.with_items("gain", g))

    def correct(self, rig, signals, fs, v):
        """The recorded signal over the gain: what a calibrated sensor would have given."""
        return rig, _scaled(signals, {s.name: v.get(f"{s.name}_gain", 1.0) for s in rig.accelerometers})


class SensorPolarity(_PerSensor):
    name = "sensor_polarity"
    description = "A sensor is mounted or wired backwards: its signal is negated."

    def parameters(self, model):
        return [Parameter(f"{s.name}_polarity", "1", 1.0, -1.0, 1.0, choices=(1.0, -1.0),
                          description=f"polarity of sensor {s.name} (channel {s.channel})", sensor=s.name)
                for s in _sensors(model)]

    def _apply(self, model, v):
        g = {s.name: model.chain.gain.get(s.name, 1.0) * v[f"{s.name}_polarity"] for s in _sensors(model)}
        return model.replace(chain=model.chain.with_items("gain", g))

    def correct(self, rig, signals, fs, v):
        """A reversed sensor's signal negated."""
        return rig, _scaled(signals, {s.name: v.get(f"{s.name}_polarity", 1.0) for s in rig.accelerometers})


def _perpendicular(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.eye(3)[np.argmin(np.abs(axis))]
    e1 = cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    return e1, cross(axis, e1)


#: tilts the screening starts from (rad, each component): a mount turned by tens of degrees sits
#: beyond the reach of a step from zero (a 25 degree tilt stopped at 4.9 degrees)
TILT_STARTS = tuple(float(np.radians(d)) for d in (-30, -15, 15, 30))


class SensorOrientation(_PerSensor):
    name = "sensor_orientation"
    description = "A sensor's axis is tilted: a rotation about two axes perpendicular to it."
    # up to 60 degrees (a tilt is a rotation vector, exact at any angle): beyond that the sensor
    # measures another axis more than its own
    per_sensor = (("tilt_a", "rad", 0.0, -1.05, 1.05, "tilt about the first perpendicular axis"),
                  ("tilt_b", "rad", 0.0, -1.05, 1.05, "tilt about the second perpendicular axis"))
    plausible = (-np.pi / 4, np.pi / 4)  # a sensor mounted more than 45 degrees off is on another axis

    def parameters(self, model):
        return [replace(p, starts=TILT_STARTS) for p in super().parameters(model)]

    def _apply(self, model, v):
        tilts = {}
        for s in _sensors(model):
            e1, e2 = _perpendicular(s.axis)
            tilts[s.name] = (model.chain.tilt.get(s.name, np.zeros(3))
                             + v[f"{s.name}_tilt_a"] * e1 + v[f"{s.name}_tilt_b"] * e2)
        return model.replace(chain=model.chain.with_items("tilt", tilts))

    def correct(self, rig, signals, fs, v):
        """The rig with each tilted sensor's axis as mounted; the signals as they are (a tilted
        sensor's own signal cannot be undone alone: the correction re-expresses it along the nominal
        axis from its body's motion)."""
        def change(s):
            a, b = v.get(f"{s.name}_tilt_a", 0.0), v.get(f"{s.name}_tilt_b", 0.0)
            if s.quantity != "acceleration" or not (a or b):
                return s
            e1, e2 = _perpendicular(s.axis)
            return replace(s, axis=rotated(np.asarray(s.axis, float), a * e1 + b * e2))
        return _remounted(rig, change), dict(signals)


class SensorPosition(_PerSensor):
    name = "sensor_position"
    description = "A sensor sits elsewhere on the plate than the rig file says."
    per_sensor = tuple((f"d{a}", "m", 0.0, -0.02, 0.02, f"position offset along {a}") for a in AXES)
    plausible = (-0.01, 0.01)  # a sensor sits within a centimetre of where the drawing puts it

    def _apply(self, model, v):
        off = {s.name: model.chain.offset.get(s.name, np.zeros(3))
               + np.array([v[f"{s.name}_d{a}"] for a in AXES]) for s in _sensors(model)}
        return model.replace(chain=model.chain.with_items("offset", off))

    def correct(self, rig, signals, fs, v):
        """The rig with each moved sensor where it sits; the signals as they are (re-expressed at
        the nominal place from the body's motion, as a tilt)."""
        def change(s):
            d = np.array([v.get(f"{s.name}_d{a}", 0.0) for a in AXES])
            return replace(s, position=s.position + d) if s.quantity == "acceleration" and d.any() else s
        return _remounted(rig, change), dict(signals)


class SensorDynamicsEffect(Effect):
    """Thesis Eq. 2.2 for every accelerometer: ICP high-passes (amplifier TC and coupler TC1, as
    corner frequencies; 0 = none) and the sensor's resonance (as its period 1/fn; 0 = none)."""

    name = "sensor_dynamics"
    target = "chain"
    breaks_rigidity = True
    description = "Accelerometer dynamics (Eq. 2.2): ICP high-pass time constants and sensor resonance."

    #: an accelerometer's mounted resonance lies above this when the rig does not rate it (Hz):
    #: general-purpose piezoelectric accelerometers resonate at 10-60 kHz
    RATED_RESONANCE_HZ = 10_000.0

    def parameters(self, model):
        acq = getattr(model.rig, "acquisition", None) if model.rig is not None else None
        rated = getattr(acq, "sensor_resonance_hz", None)
        # near the rated band: above half a stated resonance, else above the usual minimum (0: none)
        period = (0.0, 2 / rated) if rated else (0.0, 1 / self.RATED_RESONANCE_HZ)
        return [Parameter("highpass_hz", "Hz", 0.0, 0.0, 50.0, description="1/(2 pi TC), built-in amplifier",
                          plausible=(0.0, 5.0)),
                Parameter("coupler_highpass_hz", "Hz", 0.0, 0.0, 50.0, description="1/(2 pi TC1), coupler",
                          plausible=(0.0, 5.0)),
                Parameter("resonance_period_s", "s", 0.0, 0.0, 2e-3, description="1/fn of the sensor resonance",
                          plausible=period),
                Parameter("resonance_damping", "1", 0.05, 0.001, 0.7, description="damping ratio of the resonance",
                          plausible=(0.001, 0.1))]

    def _apply(self, model, v):
        dyn = SensorDynamics(v["highpass_hz"], v["coupler_highpass_hz"], v["resonance_period_s"],
                             v["resonance_damping"])
        return model.replace(chain=model.chain.with_items("dynamics", {"*": dyn}))

    correction_stage = "channel"

    def correct(self, rig, signals, fs, v):
        """Every accelerometer's signal through the inverse of the sensors' dynamics as the model
        discretises them: the high-passes by their inverse recursion (an integrator: the drift the
        correction removes afterwards grows from it), the resonance by division of the spectrum
        (zero-padded to twice the length; its discrete zeros may lie outside the unit circle)."""
        from odsuite.api import sensor_filter  # the prediction's module: scipy.signal

        dyn = SensorDynamics(v["highpass_hz"], v["coupler_highpass_hz"], v["resonance_period_s"],
                             v["resonance_damping"])
        if dyn.is_identity():
            return rig, dict(signals)
        names = [s.name for s in rig.accelerometers if s.name in signals]
        y = np.column_stack([signals[n] for n in names]).astype(float)
        highpass = replace(dyn, resonance_period_s=0.0)
        if not highpass.is_identity():
            num, den = sensor_filter(highpass, fs)
            y = scipy.signal.lfilter(den, num, y, axis=0)
        resonance = replace(dyn, highpass_hz=0.0, coupler_highpass_hz=0.0)
        if not resonance.is_identity():
            num, den = sensor_filter(resonance, fs)
            n = y.shape[0]
            _, h = scipy.signal.freqz(num, den, worN=n + 1, include_nyquist=True)  # rfft bins of 2n
            y = np.fft.irfft(np.fft.rfft(y, n=2 * n, axis=0) / h[:, None], n=2 * n, axis=0)[:n]
        return rig, {**signals, **{nm: y[:, j] for j, nm in enumerate(names)}}


class ImpactLocation(Effect):
    name = "impact_location"
    target = "chain"
    description = "The hammer hit elsewhere than recorded (one offset per experiment)."

    def parameters(self, model):
        # a hammer lands within a centimetre of the marked point
        return [Parameter(f"d{a}", "m", 0.0, -0.03, 0.03, scope="per_experiment",
                          description=f"force point offset along {a}", plausible=(-0.01, 0.01)) for a in AXES]

    def _apply(self, model, v):
        off = model.chain.force_offset + np.array([v[f"d{a}"] for a in AXES])
        return model.replace(chain=replace(model.chain, force_offset=off))


class ForceGain(Effect):
    name = "force_gain"
    target = "chain"
    description = "The force gauge's sensitivity differs from its calibration."

    def parameters(self, model):
        return [Parameter("gain", "1", 1.0, 0.5, 2.0, description="true force / recorded force",
                          plausible=(0.8, 1.25))]  # a calibrated load cell is off by a few per cent

    def _apply(self, model, v):
        return model.replace(chain=replace(model.chain, force_gain=model.chain.force_gain * v["gain"]))


class BaseMotion(Effect):
    """The base is not rigid ground: it is a rigid body on four mounts at its bottom corners, and
    the springs that held the moving bodies to the ground hold them to the base. Compliance 0 =
    ground. It applies to rigs with a body named "base" that has a plate and no mass (a base
    with a mass already moves in the model)."""

    structures = (Structure,)  # rigid bodies on springs
    name = "base_motion"
    target = "model"
    adds_body = True  # the base, once compliant, is a moving body of its own
    description = "The base moves on its own mounts (compliance per mount, base mass, mount damping)."

    def __init__(self, body: str = "base") -> None:
        self.body = body

    def _rig_base(self, model):
        """The rig's fixed, plated base body, or None when the rig has none."""
        if model.rig is None or self.body in {b.name for b in model.bodies}:
            return None
        base = next((b for b in model.rig.bodies if b.name == self.body), None)
        return base if base is not None and base.plate is not None else None

    def parameters(self, model):
        base = self._rig_base(model)
        if base is None:
            return []
        mass = base.mass if base.mass is not None else float(np.prod(base.plate.size)) * STEEL_DENSITY
        return [Parameter("compliance", "m/N", 0.0, 0.0, 1e-5, description="compliance of each mount, every axis"),
                Parameter("base_mass", "kg", mass, 0.1 * mass, 100 * mass, description="mass of the base"),
                Parameter("mount_damping_ratio", "1", 0.05, 0.0, 1.0, description="damping ratio of the mounts")]

    def _apply(self, model, v):
        if v["compliance"] == 0:
            return model
        base = self._rig_base(model)
        size, corner = base.plate.size, base.plate.corner
        m = v["base_mass"]
        if base.mass is not None and base.inertia is not None and v["base_mass"] == base.mass:
            inertia = base.inertia
        else:  # uniform box
            L, W, H = size
            inertia = m / 12 * np.diag([W * W + H * H, L * L + H * H, L * L + W * W])
        body = RigidBody(self.body, m, inertia, base.com)
        k = 1.0 / v["compliance"]
        c = 2 * v["mount_damping_ratio"] * np.sqrt(k * m / 4)
        bottom = corner[2] + size[2]  # z points down: the bottom face has the largest z
        mounts = [SpringDamper(f"mount{i + 1}", (corner[0] + fx * size[0], corner[1] + fy * size[1], bottom),
                               self.body, None, (k, k, k), (c, c, c))
                  for i, (fx, fy) in enumerate(((0, 0), (1, 0), (0, 1), (1, 1)))]
        springs = [replace(s, other=self.body) if s.other is None and s.body is not None else s
                   for s in model.springs]
        return _with_structure(model, bodies=model.bodies + (body,), springs=tuple(springs) + tuple(mounts))


def builtin_effects() -> list[Effect]:
    from .data_effects import data_effects
    from .modal_damping import modal_damping_effects

    return [Stiffness(), SpringStiffness(), Damping(), NonlinearStiffness(), MassProperties(), PlateFlexibility("kirchhoff"), PlateFlexibility("free"),
            SensorGain(), SensorPolarity(), SensorOrientation(), SensorPosition(), SensorDynamicsEffect(),
            ImpactLocation(), ForceGain(), BaseMotion()] + data_effects() + modal_damping_effects()
