"""Effects that presuppose no shape: what the data say is missing, fitted from the data.

``missing_mode``: a resonance of one body whose frequency and damping are searched and whose
participation at every sensor and at each experiment's force point is solved by linear least
squares at every step of the search (variable projection): bending with in-plane parts, torsion, a
loose bracket, whatever shape the sensors see. ``channel_delay`` and ``scan_skew``: channels
sampled later than the force channel (a time offset per channel; a multiplexer that reads channel
k a fixed time after channel k-1). ``channel_swap``: two channels of one kind carrying each
other's sensor. The last three describe the measurement and undo themselves on records
(``correct``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import scipy  # scipy.interpolate loads on first use: registration stays light

from odsuite.contracts.effects import Effect, Parameter
from odsuite.api import FlexibleMode, Model, Structure
from odsuite.api import sampled_later

#: participations (1/sqrt(kg), per unit mass-normalised modal coordinate) beyond this are a mode of
#: a part lighter than 0.1 g: no physical mode of a rig
MAX_PARTICIPATION = 100.0
#: frequency starts: a geometric grid 10 % apart (a mode's error valley on the shortest fitted head
#: is about that wide) between the slowest suspension and the sensors' usual band
FREQUENCY_STARTS = tuple(float(f) for f in np.geomspace(5.0, 5000.0, 73))
DAMPING_STARTS = (0.005, 0.02, 0.06, 0.15)
#: alternating least squares of the rank-one participation table converges in a few sweeps; this
#: many leave it at round-off on every case tried
RANK_ONE_SWEEPS = 30


def _accelerometers(model: Model) -> tuple:
    return tuple(s for s in model.sensors if s.quantity == "acceleration")


class MissingMode(Effect):
    """A mode the model lacks: ``q'' + 2 zeta w q' + w^2 q = phi_force F``, seen at sensor j as
    ``phi_j q''``, uncoupled from the rigid motion (mass-normalised, modal mass 1 kg)."""

    name = "missing_mode"
    structures = (Structure,)  # a flexible mode of a rigid body
    target = "model"
    breaks_rigidity = True  # a mode of any shape makes a rigid body's redundant sensors disagree
    data_driven = True
    repeatable = True  # a structure may lack several modes: each addition is one more
    description = ("A resonance of one body of any shape: frequency and damping fitted, participation at "
                   "every sensor and force point solved linearly.")

    def _bodies(self, model: Model) -> list[str]:
        return [b.name for b in model.bodies]

    def parameters(self, model):
        sensors = _accelerometers(model)
        if not sensors:
            return []
        out = [Parameter("frequency_hz", "Hz", 500.0, 1.0, 20000.0, starts=FREQUENCY_STARTS,
                         description="natural frequency of the mode", below_nyquist=True),
               Parameter("damping_ratio", "1", 0.02, 0.0005, 0.5, starts=DAMPING_STARTS,
                         description="modal damping ratio")]
        bodies = self._bodies(model)
        if len(bodies) > 1:
            out.append(Parameter("body", "1", 0.0, 0.0, len(bodies) - 1, choices=tuple(map(float, range(len(bodies)))),
                                 description="the body the mode belongs to: " + ", ".join(
                                     f"{i} = {n}" for i, n in enumerate(bodies))))
        out += [Parameter(f"phi_{s.name}", "kg^-1/2", 0.0, -MAX_PARTICIPATION, MAX_PARTICIPATION,
                          description=f"participation at sensor {s.name} along its axis", sensor=s.name)
                for s in sensors]
        out.append(Parameter("phi_force", "kg^-1/2", 0.0, -MAX_PARTICIPATION, MAX_PARTICIPATION,
                             scope="per_experiment", description="participation at the force point along the force"))
        return out

    def linear_parameters(self, model) -> list[str]:
        return [f"phi_{s.name}" for s in _accelerometers(model)] + ["phi_force"]

    def physical(self, model, v):
        """The mode's frequency (Hz) and damping (%), named by its body; none without the mode (every
        participation zero)."""
        if not any(v.get(f"phi_{s.name}") for s in _accelerometers(model)):
            return []
        body = self._bodies(model)[int(v.get("body", 0.0))]
        return [(f"frequency of a mode of {body}", v["frequency_hz"], "Hz"),
                (f"damping ratio of that mode", 100 * v["damping_ratio"], "%")]

    def _springs(self, model, v) -> dict[str, float]:
        """The mode's participation at spring ends (shape-function tags ``<spring>.<axis>``): none,
        the mode is uncoupled."""
        return {}

    def _parts(self, model, v, table, body) -> tuple[tuple, dict[str, float]]:
        """Parts the mode moves that carry mass of the rigid motion (FlexibleMode.parts) and the
        shape's values at them: none, the mode is uncoupled."""
        return (), {}

    def _apply(self, model, v):
        sensors = _accelerometers(model)
        table = {s.name: v[f"phi_{s.name}"] for s in sensors}
        flex = model.structure.flexible_modes
        ours = [i for i, f in enumerate(flex) if f.name == self.name]
        if not any(table.values()):
            if not v["phi_force"] or not ours:
                return model
            # one experiment's force participation on the mode the shared values added
            old = flex[ours[-1]]
            table = dict(old.shape.table)
            table["force"] = v["phi_force"]
            mode = FlexibleMode(self.name, old.body, old.frequency_hz, old.damping_ratio, _Participation(table),
                                at_springs=old.at_springs, parts=old.parts)
            return _with_modes(model, flex[:ours[-1]] + (mode,) + flex[ours[-1] + 1:])
        table["force"] = v["phi_force"]
        springs = self._springs(model, v)
        table.update(springs)
        body = self._bodies(model)[int(v.get("body", 0.0))]
        parts, at_parts = self._parts(model, v, table, body)
        table.update(at_parts)
        mode = FlexibleMode(self.name, body, v["frequency_hz"], v["damping_ratio"], _Participation(table),
                            at_springs=any(springs.values()), parts=parts)
        same = [i for i in ours if (flex[i].body, flex[i].frequency_hz, flex[i].damping_ratio)
                == (body, v["frequency_hz"], v["damping_ratio"])
                and all(flex[i].shape.table.get(k, 0.0) == x for k, x in {**springs, **at_parts}.items())
                and [p[2] for p in flex[i].parts] == [p[2] for p in parts]]
        if same:  # the same mode with an experiment's force participation: replace, do not add
            return _with_modes(model, flex[:same[-1]] + (mode,) + flex[same[-1] + 1:])
        return _with_modes(model, flex + (mode,))

    #: ``project`` takes ``unit_response``: the caller's kept responses (see project)
    projects_added_mode = True

    def project(self, models: Mapping[str, Model], values: Mapping[str, float], exps: Sequence,
                base: Sequence[np.ndarray], weights: Sequence[np.ndarray] | None,
                unit_response: Callable[[Any, float, float], np.ndarray] | None = None
                ) -> tuple[dict[str, float], dict[str, dict[str, float]], list[np.ndarray]]:
        """Participations by weighted least squares: the response at sensor j of experiment e is
        ``phi_j c_e G_ej(t)`` (``G``: the prediction's change with every participation 1), a
        rank-one table fitted by alternating least squares from its SVD. ``unit_response(experiment,
        frequency_hz, damping_ratio)``, where given, returns flexible_mode_unit's response on
        ``models[experiment.name]``, kept by the caller (a search over the mode's body asks again
        for the same frequencies)."""
        from odsuite.api import flexible_mode_change, predict

        first = next(iter(models.values()))
        sensors = _accelerometers(first)
        unit = {**values, **{f"phi_{s.name}": 1.0 for s in sensors}, "phi_force": 1.0}
        mode = FlexibleMode(self.name, self._bodies(first)[int(values.get("body", 0.0))], values["frequency_hz"],
                            values["damping_ratio"], _Participation({**{s.name: 1.0 for s in sensors}, "force": 1.0}))
        col = {s.name: j for j, s in enumerate(sensors)}
        R = np.zeros((len(exps), len(sensors)))  # <r, G> per experiment and sensor
        N = np.zeros_like(R)  # <G, G>
        G = []
        for i, (e, b) in enumerate(zip(exps, base)):
            model = models[e.name]
            if any((f.name, f.body, f.frequency_hz, f.damping_ratio) == (mode.name, mode.body, mode.frequency_hz,
                                                                         mode.damping_ratio)
                   for f in model.structure.flexible_modes):  # _apply replaces that mode: predict the whole
                g = predict(self.apply(model, unit), e) - b
            else:  # the mode is added: its response alone
                g = flexible_mode_change(model, e, mode, None if unit_response is None else
                                         lambda e=e: unit_response(e, mode.frequency_hz, mode.damping_ratio))
            w = np.ones(e.n_samples) if weights is None else weights[i]
            r = e.measured - b
            cols = [col[s.name] for s in e.sensors]
            R[i, cols] = np.einsum("t,tj,tj->j", w, r, g)
            N[i, cols] = np.einsum("t,tj->j", w, g * g)
            G.append((g, cols))
        phi, c = _rank_one(R, N)
        if phi.any():
            balance = np.sqrt(np.max(np.abs(c)) / np.max(np.abs(phi)))  # equal largest |phi| and |c|
            phi, c = phi * balance, c / balance
        phi = np.clip(phi, -MAX_PARTICIPATION, MAX_PARTICIPATION)
        c = np.clip(c, -MAX_PARTICIPATION, MAX_PARTICIPATION)
        deltas = [g * (phi[cols] * c[i])[None, :] for i, (g, cols) in enumerate(G)]
        shared = {f"phi_{s.name}": float(phi[j]) for j, s in enumerate(sensors)}
        per = {e.name: {"phi_force": float(c[i])} for i, e in enumerate(exps)}
        return shared, per, deltas


class CoupledMode(MissingMode):
    """A missing mode whose shape also moves its body's spring ends: the springs and dampers then
    couple it to the rigid motion (a plate mode near the suspension's modes shifts them and is
    driven by them; its frequency and damping are the mode's with the rigid bodies held still).
    Participation at each spring end along each
    rig axis is searched with the rest. It refines ``missing_mode`` (``refines``): the diagnosis
    fits it from that fit when it leaves the residual above the noise floor, and counts it only
    when the spring participations earn their place."""

    name = "coupled_mode"
    refines = "missing_mode"
    description = ("A resonance of one body of any shape that also moves the body's spring ends, so the "
                   "suspension couples it to the rigid motion.")

    def _spring_keys(self, model) -> list[tuple[str, str]]:
        bodies = set(self._bodies(model))
        return [(s.name, axis) for s in model.springs if {s.body, s.other} & bodies for axis in "xyz"]

    def parameters(self, model):
        out = super().parameters(model)
        if not out:
            return out
        return out + [Parameter(f"phi_{spring}_{axis}", "kg^-1/2", 0.0, -MAX_PARTICIPATION, MAX_PARTICIPATION,
                                description=f"participation at spring {spring}'s end along {axis}")
                      for spring, axis in self._spring_keys(model)]

    def held_when(self, model, fixed: Mapping[str, float]) -> dict[str, float]:
        """Spring participations the refined mode's body cannot have (springs not attached to
        it), held at 0 so the search spends no evaluations on them."""
        body = self._bodies(model)[int(fixed.get("body", 0.0))]
        on = {s.name for s in model.springs if body in (s.body, s.other)}
        return {f"phi_{spring}_{axis}": 0.0 for spring, axis in self._spring_keys(model) if spring not in on}

    def _springs(self, model, v):
        return {f"{spring}.{axis}": v[f"phi_{spring}_{axis}"] for spring, axis in self._spring_keys(model)}

    def linear_parameters(self, model) -> list[str]:
        # searched with the rest: solved apart at every step (as missing_mode does), the sensors'
        # and hits' participations jump between the bilinear problem's local solutions and the
        # search stalls (measured: 4.2x the floor where the joint search reaches 1.0x)
        return []


#: mounted_mode's start: the part's mass as a share of the body's (a bracket or sensor block)
START_PART_FRACTION = 0.01


class MountedMode(MissingMode):
    """A missing mode that is a part mounted where some sensors sit (a loose bracket, a sensor
    block on a soft mount): the part moves with the body there plus the mode's shape, so its mass
    couples the mode to the rigid motion (the body's motion drives it and it pulls back on the
    body). Per sensor mount point, the share of the mode's modal mass the part carries (0: none; 1:
    the mode is the part moving on its mount alone) is searched with the rest; the part's mass is
    that share over the shape's square there (the shape along unsensed axes taken as 0). It refines
    ``missing_mode``: fitted from that fit, counted only when the shares earn their place."""

    name = "mounted_mode"
    refines = "missing_mode"
    description = ("A resonance of a part mounted where sensors sit (a loose bracket): its mass couples it "
                   "to the rigid motion of the body it is on.")

    def _mounts(self, model) -> list[tuple[str, str, np.ndarray, list]]:
        """(tag, body, point, sensors) of each point where accelerometers sit."""
        out = []
        for s in _accelerometers(model):
            if s.body is None or s.position is None:
                continue
            here = next((m for m in out if m[1] == s.body and np.allclose(m[2], s.position, atol=1e-6)), None)
            if here is None:
                out.append([s.name, s.body, np.asarray(s.position, float), [s]])
            else:
                here[0] += f"_{s.name}"
                here[3].append(s)
        return [tuple(m) for m in out]

    def parameters(self, model):
        out = super().parameters(model)
        if not out:
            return out
        return out + [Parameter(f"part_{tag}", "1", 0.0, 0.0, 1.0, description=(
            f"share of the mode's modal mass on a part mounted where {', '.join(s.name for s in group)} sit"))
            for tag, _, _, group in self._mounts(model)]

    def held_when(self, model, fixed: Mapping[str, float]) -> dict[str, float]:
        """Mount points on other bodies than the refined mode's, held at 0."""
        body = self._bodies(model)[int(fixed.get("body", 0.0))]
        return {f"part_{tag}": 0.0 for tag, on, _, _ in self._mounts(model) if on != body}

    def linear_parameters(self, model) -> list[str]:
        return []  # the participations set the parts' masses: searched with the rest (as coupled_mode)

    def refined_start(self, model, values: Mapping[str, float]) -> dict[str, float]:
        """From missing_mode's fit: the mode is the part where the sensors see most of it (share 1).
        The hammer's participations stay missing_mode's (per experiment): started at 0, a second
        mounted_mode for a bracket's rocking started worse and a loop ended above the floor."""
        body = self._bodies(model)[int(values.get("body", 0.0))]
        seen = {tag: sum(values.get(f"phi_{s.name}", 0.0) ** 2 for s in group)
                for tag, on, _, group in self._mounts(model) if on == body}
        if not seen or not max(seen.values()):
            return {}
        # with share 1 the response through the mount does not depend on the participations' scale
        # (the part's mass is their inverse square): scale them to a part of a hundredth of the body
        part = max(seen, key=seen.get)
        scale = 1.0 / np.sqrt(seen[part] * START_PART_FRACTION * model.structure.body(body).mass)
        out = {name: float(np.clip(x * scale, -MAX_PARTICIPATION, MAX_PARTICIPATION))
               for name, x in values.items() if name.startswith("phi_") and name != "phi_force"}
        return {**out, f"part_{part}": 1.0}

    def _parts(self, model, v, table, body):
        parts, at = [], {}
        for tag, on, point, group in self._mounts(model):
            share = v[f"part_{tag}"]
            if not share or on != body:
                continue
            # the shape at the point from the sensors there (least squares over their axes)
            axes = np.array([np.asarray(s.axis, float) / np.linalg.norm(s.axis) for s in group])
            phi = np.linalg.lstsq(axes, np.array([table[s.name] for s in group]), rcond=None)[0]
            square = float(phi @ phi)
            if square == 0:
                continue
            # a part cannot outweigh the body it is mounted on
            mass = min(share / square, model.structure.body(on).mass)
            parts.append((tag, point, mass))
            at.update({f"{tag}.{axis}": float(x) for axis, x in zip("xyz", phi)})
        return tuple(parts), at


class _Participation:
    """A mode's participation per sensor name and at the force points ("force"); a table, so an
    experiment's force participation can replace the shared one."""

    def __init__(self, table: Mapping[str, float]) -> None:
        self.table = dict(table)

    def __call__(self, point, direction, tag) -> float:
        return self.table.get(tag, 0.0)


def _with_modes(model: Model, modes) -> Model:
    st = model.structure
    return model.replace(structure=Structure(st.bodies, st.springs, tuple(modes)))


def _rank_one(R: np.ndarray, N: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """phi (sensors), c (experiments) minimising sum N_ej (phi_j c_e)^2 - 2 R_ej phi_j c_e."""
    # a sensor or hit the mode cannot reach differs from the model only by round-off
    seen = N > 1e-12 * float(np.max(N, initial=0.0))
    if not seen.any():
        return np.zeros(R.shape[1]), np.zeros(R.shape[0])
    R, N = np.where(seen, R, 0.0), np.where(seen, N, 0.0)
    a = np.where(seen, R / np.where(seen, N, 1.0), 0.0)  # each entry alone
    u, s, vt = np.linalg.svd(a * np.sqrt(N))
    c, phi = u[:, 0] * np.sqrt(s[0]), vt[0] * np.sqrt(s[0])
    for _ in range(RANK_ONE_SWEEPS):
        last, (phi, c) = c, _rank_one_sweep(R, N, c)
        if c.tobytes() == last.tobytes():  # a sweep is a function of c alone: the rest would repeat it
            break
    return phi, c


def _rank_one_sweep(R: np.ndarray, N: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One alternating least-squares sweep of _rank_one from ``c``: phi given c, then c given phi."""
    den = (c * c) @ N
    phi = np.where(den > 0, (c @ R) / np.where(den > 0, den, 1.0), 0.0)
    den = N @ (phi * phi)
    return phi, np.where(den > 0, (R @ phi) / np.where(den > 0, den, 1.0), 0.0)


class ChannelDelay(Effect):
    """Channels sampled later than the force channel: ``per_channel`` gives every accelerometer its
    own offset, ``scan`` one skew per scanned channel (channel k is read (k - force channel) x
    skew after the force)."""

    target = "chain"
    breaks_rigidity = True  # time-shifted channels disagree about one rigid motion

    def __init__(self, kind: str = "per_channel") -> None:
        self.kind = kind
        if kind == "scan":
            self.name = "scan_skew"
            self.description = "A multiplexed DAQ reads channel k a fixed time after channel k-1."
        else:
            self.name = "channel_delay"
            self.description = "A channel is sampled later (or earlier) than the force channel."

    def parameters(self, model):
        sensors = _accelerometers(model)
        if not sensors:
            return []
        if self.kind == "scan":
            # a multiplexer's scan step: up to 100 us (a 10 kHz-per-channel converter)
            steps = (2e-6, 5e-6, 10e-6, 20e-6, 40e-6)
            return [Parameter("skew_s", "s", 0.0, -100e-6, 100e-6, starts=steps + tuple(-t for t in steps),
                              description="delay of each scanned channel after the previous one")]
        steps = (5e-6, 20e-6, 60e-6)
        return [Parameter(f"{s.name}_delay", "s", 0.0, -500e-6, 500e-6, starts=steps + tuple(-t for t in steps),
                          description=f"sampling delay of sensor {s.name} (channel {s.channel}) after the force",
                          sensor=s.name)  # it shifts that channel alone
                for s in sensors]

    def _apply(self, model, v):
        sensors = _accelerometers(model)
        if self.kind == "scan":
            first = model.rig.force_channel if model.rig.force_channel is not None else 0
            delay = {s.name: (s.channel - first) * v["skew_s"] for s in sensors}
        else:
            delay = {s.name: v[f"{s.name}_delay"] for s in sensors}
        merged = {n: model.chain.delay.get(n, 0.0) + d for n, d in delay.items()}
        return model.replace(chain=model.chain.with_items("delay", merged))

    correction_stage = "channel"

    def correct(self, rig, signals, fs, v):
        """Each late channel moved back by its delay (the model's own phase shift, negated)."""
        sensors = [s for s in rig.accelerometers if s.name in signals]
        if self.kind == "scan":
            first = rig.force_channel if rig.force_channel is not None else 0
            delay = [(s.channel - first) * v["skew_s"] for s in sensors]
        else:
            delay = [v.get(f"{s.name}_delay", 0.0) for s in sensors]
        if not any(delay):
            return rig, dict(signals)
        x = np.column_stack([signals[s.name] for s in sensors])
        # a record that does not end at rest (a drifting displacement) would ring through the whole
        # shift from the step at its end: the cubic through both ends' values and slopes is shifted
        # exactly, the rest (at rest at both ends) by the spectrum's phase
        t = np.arange(x.shape[0]) / fs
        ends = scipy.interpolate.CubicHermiteSpline([t[0], t[-1]], x[[0, -1]], fs * (x[[1, -1]] - x[[0, -2]]), axis=0)
        y = sampled_later(x - ends(t), fs, -np.asarray(delay))
        y += np.column_stack([ends(t - d)[:, j] for j, d in enumerate(delay)])
        return rig, {**signals, **{s.name: y[:, j] for j, s in enumerate(sensors)}}


#: ChannelSwap's pairs and their description per set of sensors (frozen rig objects), by the
#: sensors' identities (kept alive with the entry): a screening builds a problem per pair, each
#: asking for the parameters (a rig of 18 accelerometers: 153 pairs named in one string)
_PAIRS: dict[tuple[int, ...], tuple[tuple, tuple[tuple[str, str], ...], str]] = {}


def _swap_pairs(sensors: tuple) -> tuple[tuple[tuple[str, str], ...], str]:
    key = tuple(map(id, sensors))
    got = _PAIRS.get(key)
    if got is None or any(a is not b for a, b in zip(got[0], sensors)):
        pairs = tuple((a.name, b.name) for i, a in enumerate(sensors) for b in sensors[i + 1:]
                      if (a.kind, a.quantity) == (b.kind, b.quantity))
        if len(_PAIRS) >= 16:
            _PAIRS.clear()
        got = _PAIRS[key] = (sensors, pairs, "the exchanged pair: 0 = none, " + ", ".join(
            f"{k + 1} = {a}/{b}" for k, (a, b) in enumerate(pairs)))
    return got[1], got[2]


class ChannelSwap(Effect):
    """Two channels of one kind (two accelerometers, say) carry each other's sensor: their cables
    were exchanged. A discrete parameter, the pair (0: none; the diagnosis tries every pair on the
    current model), and the ratio of the two sensors' sensitivities (the channel set up for the
    first reads the second sensor ``ratio`` times too large, the other channel the first sensor
    ``ratio`` times too small), fitted with the best pair."""

    name = "channel_swap"
    target = "chain"
    breaks_rigidity = True  # a swapped pair makes a rigid body's redundant sensors disagree
    correction_stage = "wiring"
    description = "Two sensors' cables are exchanged: each channel records the other sensor."

    @staticmethod
    def pairs(sensors) -> list[tuple[str, str]]:
        """Every pair of sensors of one kind and quantity, in rig order (choice k is pair k - 1)."""
        return list(_swap_pairs(tuple(sensors))[0])

    def parameters(self, model):
        pairs, described = _swap_pairs(_accelerometers(model))
        if not pairs or model.rig is None:
            return []
        return [Parameter("pair", "1", 0.0, 0.0, float(len(pairs)), choices=tuple(map(float, range(len(pairs) + 1))),
                          description=described),
                # sensors of one type differ by a few per cent in sensitivity
                Parameter("ratio", "1", 1.0, 0.5, 2.0, plausible=(0.8, 1.25),
                          description="second sensor's sensitivity / first sensor's, of the exchanged pair")]

    def pair(self, sensors, v) -> tuple[str, str] | None:
        k = int(v.get("pair", 0.0))
        return _swap_pairs(tuple(sensors))[0][k - 1] if k else None

    def _apply(self, model, v):
        pair = self.pair(_accelerometers(model), v)
        if pair is None:
            return model
        a, b = pair
        r = v.get("ratio", 1.0)
        # a channel's row is the recorded sensor's, with that sensor's gain: channel a reads b
        gains = {a: model.chain.gain.get(a, 1.0) / r, b: model.chain.gain.get(b, 1.0) * r}
        return model.replace(chain=model.chain.with_items("swap", {a: b, b: a}).with_items("gain", gains))

    def correct(self, rig, signals, fs, v):
        """The two channels' signals exchanged back."""
        pair = self.pair(rig.accelerometers, v)
        if pair is None or not set(pair) <= set(signals):
            return rig, dict(signals)
        a, b = pair
        r = v.get("ratio", 1.0)
        return rig, {**signals, a: signals[b] * r, b: signals[a] / r}


def data_effects() -> list[Effect]:
    return [MissingMode(), CoupledMode(), MountedMode(), ChannelDelay("per_channel"), ChannelDelay("scan"),
            ChannelSwap()]
