"""A catalogue of named, seeded random cases: a base rig (what the lab believes, written as the rig
TOML) and a hidden change drawn at random within a range (what is simulated, written to the
truth JSON). Usage:

    python -m tests.independent.cases OUT_DIR --case softer-axis --seed 3 [--rig two-body]
    python -m tests.independent.cases --list
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.polynomial import legendre

from . import writers
from .rigs import RIGS, RigBundle
from .rigsim import Model, Record, rigid_point_matrix, simulate, structure_response
from .structure import FlexibleMode, GapContact, Hit, RigidBody, Setup, Spring, mat3, vec3

FORMATS = ("lvm", "dat", "uff")  # .DAT comes with its .CTR
#: white noise of every channel in every case (V rms): a typical IEPE + ADC front-end floor
FLOOR_NOISE_V = 50e-6


@dataclass
class Case:
    name: str
    rig_name: str
    seed: int
    nominal: RigBundle  # the lab's belief: written as the rig TOML
    actual: RigBundle  # what is simulated
    records: list[list[Hit]]  # the hits of each record
    truth: dict = field(default_factory=dict)

    def nominal_scale(self) -> dict[str, float]:
        scale = {a.name: a.sign * a.sensitivity for a in self.nominal.accelerometers}
        f = self.nominal.force_sensor
        return scale | {f.name: f.sign * f.sensitivity}

    def simulate(self, progress: Callable[[int, int], None] | None = None) -> list[Record]:
        rng = np.random.default_rng([self.seed, 1])  # the noise stream, apart from the case draws
        out = []
        for i, hits in enumerate(self.records):
            a = self.actual
            rec = simulate(Setup(a.structure, a.accelerometers, a.force_sensor, a.daq, hits), rng,
                           self.nominal_scale())
            out.append(self._labelled(rec))
            if progress:
                progress(i + 1, len(self.records))
        return out

    def _labelled(self, rec: Record) -> Record:
        """Each channel named and scaled as the lab set it up (the nominal sensor on that channel),
        whichever sensor its cable actually carries (a channel swap)."""
        scale = self.nominal_scale()
        for s in self.nominal.accelerometers:
            if rec.names[s.channel] != s.name:
                rec.names[s.channel] = s.name
                rec.scale[s.channel] = scale[s.name] * self.actual.daq.amplifier_gain
        return rec

    def body_motion(self, records: list[Record]) -> dict[str, np.ndarray]:
        """The true motion of every body in each record: the six coordinates at its centre of mass
        (m m m rad rad rad, rig axes, small rotations) at the nominal sample instants."""
        n = 6 * len(self.actual.structure.bodies)
        return {f"r{i:02d}": rec.q[:, :n] for i, rec in enumerate(records)}

    def truth_document(self) -> dict:
        nominal_f = Model(self.nominal.structure).natural_frequencies()
        actual_f, actual_shapes = Model(self.actual.structure).mode_shapes()
        d = self.actual.daq
        return {
            "case": self.name, "rig": self.nominal.name, "seed": self.seed, **self.truth,
            "nominal_frequencies_hz": nominal_f, "actual_linear_frequencies_hz": actual_f,
            # columns: mass-normalised shapes over [x y z rx ry rz] at each body's centre of mass
            # (bodies in rig order), then the flexible modes' coordinates
            "actual_linear_mode_shapes": actual_shapes,
            "coordinates": [f"{b.name}.{c}" for b in self.actual.structure.bodies
                            for c in ("x", "y", "z", "rx", "ry", "rz")]
                           + [f"{m.body}.{m.name}" for m in self.actual.structure.modes],
            "daq": {"sampling_rate_hz": d.sampling_rate, "n_samples": d.n_samples, "pre_trigger": d.pre_trigger,
                    "adc_bits": d.adc_bits, "adc_range_v": list(d.adc_range), "amplifier_gain": d.amplifier_gain,
                    "anti_aliasing": {"family": d.aa_family, "order": d.aa_order, "cutoff_hz": d.aa_cutoff_hz},
                    "scan_skew_s": d.scan_skew_s, "noise_rms_v": d.noise_rms_v, "hum_v": d.hum_v,
                    "hum_hz": d.hum_hz, "drift_v_per_s": d.drift_v_per_s, "oversample": d.oversample},
            "records": [[{"body": h.body, "point_m": h.point, "direction": h.direction, "peak_n": h.peak_n,
                          "duration_s": h.duration_s, "delay_s": h.delay_s} for h in hits]
                        for hits in self.records],
        }

    def write(self, out_dir: str | Path, formats=FORMATS, *, decimal: str = ".",
              physical: bool = False, progress: Callable[[int, int], None] | None = None) -> list[Path]:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        stem = f"{self.rig_name}-{self.name}-s{self.seed}"
        files = [writers.write_rig_toml(out / f"{stem}-rig.toml", self.nominal)]
        records = self.simulate(progress)
        for i, rec in enumerate(records):
            base = out / f"{stem}-r{i:02d}"
            if "lvm" in formats:
                files.append(writers.write_lvm(base.with_suffix(".lvm"), rec, decimal=decimal, physical=physical))
            if "dat" in formats:
                files.append(writers.write_dat(base.with_suffix(".DAT"), rec))
                files.append(writers.write_ctr(base.with_suffix(".CTR"), rec, self.nominal, self.actual.daq))
            if "uff" in formats:
                files.append(writers.write_uff58(base.with_suffix(".uff"), rec, self.nominal))
        motion = out / f"{stem}-motion.npz"
        np.savez(motion, **self.body_motion(records))
        files.append(motion)
        truth = self.truth_document() | {"files": [f.name for f in files], "body_motion": {
            "file": motion.name, "arrays": "one per record (r00, r01, ...): samples x coordinates",
            "coordinates": [f"{b.name}.{c}" for b in self.actual.structure.bodies
                            for c in ("x", "y", "z", "rx", "ry", "rz")],
            "units": "m m m rad rad rad", "reference": "each body's centre of mass, rig axes"}}
        files.append(writers.write_truth(out / f"{stem}-truth.json", truth))
        return files


# ---------------------------------------------------------------------------------------------
# drawing helpers


def _jittered_hits(rig: RigBundle, rng: np.random.Generator) -> list[list[Hit]]:
    """The rig's default hits, one per record, each moved up to 5 mm within its face and its peak
    scaled by 0.7-1.3."""
    records = []
    for h in rig.hits:
        shift = rng.uniform(-0.005, 0.005, 3)
        shift -= np.dot(shift, h.direction) * np.asarray(h.direction)  # stay on the face
        records.append([replace(h, point=h.point + shift, peak_n=h.peak_n * rng.uniform(0.7, 1.3))])
    return records


def _random_unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.standard_normal(3)
    return v / np.linalg.norm(v)


def _rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' rotation of v about unit axis by angle (rad)."""
    return v * np.cos(angle) + np.cross(axis, v) * np.sin(angle) + axis * np.dot(axis, v) * (1 - np.cos(angle))


def _factor(rng: np.random.Generator, sign: int) -> float:
    return 1.0 + sign * rng.uniform(0.05, 0.40)


def _group(rig: RigBundle, rng: np.random.Generator) -> str:
    return str(rng.choice(sorted(rig.spring_groups)))


def peak_spring_motion(rig: RigBundle, hits: list[Hit]) -> dict[str, np.ndarray]:
    """Largest |relative displacement| per rig axis at every spring (m) of the linear rig under
    ``hits``: the scale that nonlinear elements are sized against."""
    d = rig.daq
    h = 1.0 / (d.sampling_rate * d.oversample)
    t = np.arange(int(d.n_samples * d.oversample)) * h
    model = Model(rig.structure)
    setup = Setup(rig.structure, [], None, d, hits)
    q, _, _ = structure_response(model, model.generalized_forces(setup, t, d.pre_trigger / d.sampling_rate), h)
    return {s.name: np.abs(q @ model.relative_matrix(s.body, s.other, s.position).T).max(axis=0)
            for s in rig.structure.springs}


# ---------------------------------------------------------------------------------------------
# the effects: each changes ``case.actual`` (and maybe the records) and fills ``case.truth``


def _suspension_axis(sign: int):
    def effect(case: Case, rng: np.random.Generator) -> None:
        group, axis, factor = _group(case.actual, rng), int(rng.integers(3)), _factor(rng, sign)
        names = case.actual.spring_groups[group]
        for s in case.actual.structure.springs:
            if s.name in names:
                k = mat3(s.stiffness)
                k[axis, axis] *= factor
                s.stiffness = k
        case.truth["effect"] = {"kind": "stiffness", "group": group, "springs": names, "axis": "xyz"[axis],
                                "factor": factor}
    return effect


def _one_spring(sign: int):
    def effect(case: Case, rng: np.random.Generator) -> None:
        s = case.actual.structure.springs[int(rng.integers(len(case.actual.structure.springs)))]
        factor = _factor(rng, sign)
        s.stiffness = mat3(s.stiffness) * factor
        case.truth["effect"] = {"kind": "stiffness", "springs": [s.name], "axis": "xyz", "factor": factor}
    return effect


def _top_face_point(rig: RigBundle, body_name: str, rng: np.random.Generator) -> np.ndarray:
    body = rig.structure.body(body_name)
    corner, size = np.asarray(body.plate["corner"], float), np.asarray(body.plate["size"], float)
    p = corner + rng.uniform(0.1, 0.9, 3) * size
    up = int(np.argmax(np.abs(rig.up)))
    p[up] = corner[up] + (size[up] if rig.up[up] > 0 else 0.0)
    return p


def added_mass(case: Case, rng: np.random.Generator) -> None:
    body = case.actual.structure.bodies[int(rng.integers(len(case.actual.structure.bodies)))]
    p = _top_face_point(case.actual, body.name, rng)
    dm = body.mass * rng.uniform(0.03, 0.15)
    m, G = body.mass, vec3(body.com)
    G_new = (m * G + dm * p) / (m + dm)

    def shift(mass, d):  # parallel-axis term of a point mass at offset d
        return mass * (np.dot(d, d) * np.eye(3) - np.outer(d, d))

    body.inertia = np.asarray(body.inertia, float) + shift(m, G - G_new) + shift(dm, p - G_new)
    body.mass, body.com = m + dm, G_new
    case.truth["effect"] = {"kind": "added_mass", "body": body.name, "mass_kg": dm, "point_m": p,
                            "new_mass_kg": body.mass, "new_com_m": G_new, "new_inertia_kg_m2": body.inertia}


def flexible_mode(case: Case, rng: np.random.Generator) -> None:
    """A plate bending mode of random shape (Kirchhoff: sections rotate, so points off the mid-plane
    move in-plane), made orthogonal to the body's rigid motions and mass-normalised over the
    plate's volume (uniform density), at a random frequency between the top rigid mode and 2 kHz."""
    rig = case.actual
    body = rig.structure.bodies[int(rng.integers(len(rig.structure.bodies)))]
    corner, size = np.asarray(body.plate["corner"], float), np.asarray(body.plate["size"], float)
    up = int(np.argmax(np.abs(rig.up)))
    a, b = [i for i in range(3) if i != up]
    mid = corner[up] + size[up] / 2
    # Legendre polynomials in the plate's two in-plane coordinates: unlike cosines their slopes do
    # not vanish at the edges, so sensors on the corners see the sections rotate
    terms = [(i, j) for i in range(4) for j in range(4) if 2 <= i + j <= 4]
    coef = rng.standard_normal(len(terms))

    def raw(p):
        p = np.atleast_2d(p)
        xi = 2 * (p[:, a] - corner[a]) / size[a] - 1
        eta = 2 * (p[:, b] - corner[b]) / size[b] - 1
        w = np.zeros(len(p))
        dw = np.zeros((len(p), 2))
        for c, (i, j) in zip(coef, terms):
            Pi, Pj = legendre.Legendre.basis(i), legendre.Legendre.basis(j)
            w += c * Pi(xi) * Pj(eta)
            dw[:, 0] += c * Pi.deriv()(xi) * Pj(eta) * 2 / size[a]
            dw[:, 1] += c * Pi(xi) * Pj.deriv()(eta) * 2 / size[b]
        out = np.zeros((len(p), 3))
        out[:, up] = w
        out[:, a] = -(p[:, up] - mid) * dw[:, 0]
        out[:, b] = -(p[:, up] - mid) * dw[:, 1]
        return out

    grid = np.stack(np.meshgrid(*[np.linspace(corner[k], corner[k] + size[k], 9 if k != up else 3)
                                  for k in range(3)], indexing="ij"), axis=-1).reshape(-1, 3)
    rigid = np.vstack([rigid_point_matrix(g - body.com) for g in grid])  # (3N, 6)
    coeff, *_ = np.linalg.lstsq(rigid, raw(grid).reshape(-1), rcond=None)
    flexible = raw(grid).reshape(-1) - rigid @ coeff
    norm = np.sqrt(body.mass / len(grid) * np.dot(flexible, flexible))  # modal mass before scaling

    def shape(p):
        p = np.asarray(p, float)
        return ((raw(p)[0] - rigid_point_matrix(p - body.com) @ coeff) / norm)

    top = Model(case.nominal.structure).natural_frequencies().max()
    f = rng.uniform(top * 1.1, 2000.0)
    zeta = rng.uniform(0.005, 0.03)
    rig.structure.modes.append(FlexibleMode("bending", body.name, f, zeta, shape))
    case.truth["effect"] = {
        "kind": "flexible_mode", "body": body.name, "frequency_hz": f, "damping_ratio": zeta,
        "shape_terms": [{"i": i, "j": j, "coefficient": c} for (i, j), c in zip(terms, coef)],
        "shape_at_sensors_m_per_unit": {s.name: shape(s.position) for s in rig.accelerometers if s.body == body.name},
        "shape_at_springs_m_per_unit": {s.name: shape(s.position) for s in rig.structure.springs
                                        if body.name in (s.body, s.other)},
        "shape_at_hits_m_per_unit": [[shape(h.point) if h.body == body.name else [0.0, 0.0, 0.0] for h in hits]
                                     for hits in case.records],
    }


def sensor_tilt(case: Case, rng: np.random.Generator) -> None:
    s = case.actual.accelerometers[int(rng.integers(len(case.actual.accelerometers)))]
    axis = vec3(s.axis)
    about = _random_unit(rng)
    about -= np.dot(about, axis) * axis  # perpendicular: the whole angle tilts the axis
    about /= np.linalg.norm(about)
    angle = np.radians(rng.uniform(5.0, 40.0))
    s.axis = _rotate(axis, about, angle)
    case.truth["effect"] = {"kind": "sensor_tilt", "sensor": s.name, "angle_deg": np.degrees(angle),
                            "about": about, "nominal_axis": axis, "true_axis": s.axis}


def sensor_gain(case: Case, rng: np.random.Generator) -> None:
    s = case.actual.accelerometers[int(rng.integers(len(case.actual.accelerometers)))]
    s.gain_error = float(rng.choice([-1, 1]) * rng.uniform(0.05, 0.30))
    case.truth["effect"] = {"kind": "sensor_gain", "sensor": s.name, "gain_error": s.gain_error}


def polarity_flip(case: Case, rng: np.random.Generator) -> None:
    s = case.actual.accelerometers[int(rng.integers(len(case.actual.accelerometers)))]
    s.sign = -s.sign
    case.truth["effect"] = {"kind": "polarity_flip", "sensor": s.name, "true_sign": s.sign}


def scan_skew(case: Case, rng: np.random.Generator) -> None:
    case.actual.daq.scan_skew_s = rng.uniform(2e-6, 20e-6)
    case.truth["effect"] = {"kind": "scan_skew", "skew_per_channel_s": case.actual.daq.scan_skew_s}


def channel_delay(case: Case, rng: np.random.Generator) -> None:
    """One accelerometer channel sampled late by 5-60 us (a slow channel of a simultaneous-sampling
    DAQ, a long cable to a separate input module)."""
    s = case.actual.accelerometers[int(rng.integers(len(case.actual.accelerometers)))]
    delay = rng.uniform(5e-6, 60e-6)
    case.actual.daq.channel_delay_s = {s.channel: delay}
    case.truth["effect"] = {"kind": "channel_delay", "sensor": s.name, "channel": s.channel, "delay_s": delay}


def torsion_mode(case: Case, rng: np.random.Generator) -> None:
    """The free plate's first elastic mode, torsion: w = twist xi eta about the plate's centre
    (xi, eta in [-1, 1]); Kirchhoff sections rotate, so a point at height z above the mid-plane
    moves in-plane by -z grad w. The shape is orthogonal to the rigid motions for a uniform plate
    (odd in each coordinate) and mass-normalised over the plate's volume; 1.2x the top rigid mode
    to 2 kHz, 0.5-3 % damping; the twist's sign is random."""
    rig = case.actual
    body = rig.structure.bodies[int(rng.integers(len(rig.structure.bodies)))]
    corner, size = np.asarray(body.plate["corner"], float), np.asarray(body.plate["size"], float)
    up = int(np.argmax(np.abs(rig.up)))
    a, b = [i for i in range(3) if i != up]
    centre = corner + size / 2
    sign = float(rng.choice([-1.0, 1.0]))
    # mass normalisation: <xi^2 eta^2> over the plate is 1/9, plus the in-plane parts' share
    # (rotatory inertia, small for a thin plate): the integral is taken on a grid below
    grid = np.stack(np.meshgrid(*[np.linspace(corner[k], corner[k] + size[k], 11) for k in range(3)],
                                indexing="ij"), axis=-1).reshape(-1, 3)

    def raw(p):
        p = np.atleast_2d(p)
        xi, eta = 2 * (p[:, a] - centre[a]) / size[a], 2 * (p[:, b] - centre[b]) / size[b]
        out = np.zeros((len(p), 3))
        out[:, up] = xi * eta
        out[:, a] = -(p[:, up] - centre[up]) * eta * 2 / size[a]
        out[:, b] = -(p[:, up] - centre[up]) * xi * 2 / size[b]
        return out

    norm = np.sqrt(body.mass / len(grid) * np.sum(raw(grid) ** 2))

    def shape(p):
        return sign * raw(np.asarray(p, float))[0] / norm

    top = Model(case.nominal.structure).natural_frequencies().max()
    f = rng.uniform(1.2 * top, 2000.0)
    zeta = rng.uniform(0.005, 0.03)
    rig.structure.modes.append(FlexibleMode("torsion", body.name, f, zeta, shape))
    case.truth["effect"] = {"kind": "flexible_mode", "shape": "torsion", "body": body.name, "frequency_hz": f,
                            "damping_ratio": zeta,
                            "shape_at_sensors_m_per_unit": {s.name: shape(s.position) for s in rig.accelerometers
                                                            if s.body == body.name}}


def loose_bracket(case: Case, rng: np.random.Generator) -> None:
    """The sensors at one mounting point sit on a loose bracket: a 10-50 g block on four small
    springs at its corners, soft along one random rig axis (its resonance there 1.5x the top rigid
    mode to 1.5 kHz), five times stiffer across, 1-5 % damping. The bracket is a body of its own:
    the hammer moves it only through the plate, and it pulls back on the plate."""
    rig = case.actual
    sensors = rig.accelerometers
    where = sensors[int(rng.integers(len(sensors)))]
    group = [s for s in sensors if s.body == where.body and np.allclose(s.position, where.position)]
    mass = rng.uniform(0.010, 0.050)
    edge = 0.02  # m, a small aluminium block
    axis = int(rng.integers(3))
    top = Model(case.nominal.structure).natural_frequencies().max()
    f = rng.uniform(1.5 * top, 1500.0)
    zeta = rng.uniform(0.01, 0.05)
    k_soft = mass * (2 * np.pi * f) ** 2 / 4  # four springs in parallel along the soft axis
    k = np.full(3, 5.0 * k_soft)
    k[axis] = k_soft
    c = np.full(3, 2 * zeta * np.sqrt(k_soft * mass / 4))
    centre = np.asarray(where.position, float)
    bracket = RigidBody("bracket", mass, centre.copy(), mass * edge**2 / 6 * np.eye(3))  # a cube's inertia
    rig.structure.bodies.append(bracket)
    half = edge / 2
    for i, (sx, sy) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)]):
        offset = np.zeros(3)
        plane = [j for j in range(3) if j != int(np.argmax(np.abs(rig.up)))]
        offset[plane[0]], offset[plane[1]] = sx * half, sy * half
        rig.structure.springs.append(Spring(f"bracket{i + 1}", "bracket", centre + offset, k.copy(), c.copy(),
                                            other=where.body))
    for s in group:
        s.body = "bracket"
    case.truth["effect"] = {"kind": "loose_bracket", "sensors": [s.name for s in group], "body": where.body,
                            "mass_kg": mass, "soft_axis": "xyz"[axis], "frequency_hz": f, "damping_ratio": zeta}


def _nonlinear_rate(case: Case) -> None:
    """RK4 runs a Python step per fine point: 4x the sampling rate keeps its error below 1e-6 for
    modes under 300 Hz (global error ~ (w h)^4) at half the cost of the default 8x."""
    case.actual.daq.oversample = 4


def hardening_series(case: Case, rng: np.random.Generator) -> None:
    """Cubic hardening on a spring group, sized so that the top level stiffens the group's
    springs by a random 3-15 % in frequency at their peak deflection; five levels 0.5-50 N."""
    rig = case.actual
    group = _group(rig, rng)
    levels = np.geomspace(rng.uniform(0.5, 1.0), rng.uniform(30.0, 50.0), 5)
    base_hit = replace(rig.hits[0], peak_n=float(levels[-1]))
    peaks = peak_spring_motion(case.nominal, [base_hit])
    shift = rng.uniform(0.03, 0.15)
    cubic = {}
    for s in rig.structure.springs:
        if s.name in rig.spring_groups[group]:
            amp = np.maximum(peaks[s.name], 1e-12)
            # Duffing backbone: w^2 = w0^2 (1 + 3/4 k3 A^2 / k)
            s.cubic = ((1 + shift) ** 2 - 1) * np.diag(mat3(s.stiffness)) / (0.75 * amp ** 2)
            cubic[s.name] = s.cubic
    case.records = [[replace(base_hit, peak_n=float(f))] for f in levels]
    _nonlinear_rate(case)
    case.truth["effect"] = {"kind": "cubic_hardening", "group": group, "cubic_n_per_m3": cubic,
                            "frequency_shift_at_top_level": shift, "force_levels_n": levels}


def coulomb_friction(case: Case, rng: np.random.Generator) -> None:
    """Coulomb friction at one spring, its level 2-10 % of the spring's peak elastic force."""
    rig = case.actual
    s = rig.structure.springs[int(rng.integers(len(rig.structure.springs)))]
    peaks = peak_spring_motion(case.nominal, case.records[0])
    fraction = rng.uniform(0.02, 0.10)
    s.friction = fraction * np.diag(mat3(s.stiffness)) * peaks[s.name]
    _nonlinear_rate(case)
    case.truth["effect"] = {"kind": "coulomb_friction", "spring": s.name, "force_n": s.friction,
                            "fraction_of_peak_spring_force": fraction,
                            "regularisation_velocity_m_per_s": s.friction_velocity}


def rattle(case: Case, rng: np.random.Generator) -> None:
    """A loose stop at a spring: contact along one axis beyond 20-60 % of that spring's peak
    deflection, 1-3 times the spring's stiffness."""
    rig = case.actual
    s = rig.structure.springs[int(rng.integers(len(rig.structure.springs)))]
    axis = int(rng.integers(3))
    peaks = peak_spring_motion(case.nominal, case.records[0])
    clearance = rng.uniform(0.2, 0.6) * peaks[s.name][axis]
    k = rng.uniform(1.0, 3.0) * mat3(s.stiffness)[axis, axis]
    direction = np.eye(3)[axis]
    c = 0.1 * mat3(s.damping)[axis, axis]  # a little contact damping: the stop is not perfectly elastic
    rig.structure.contacts.append(GapContact(f"{s.name}-stop", s.body, vec3(s.position), direction,
                                             clearance, k, c, other=s.other))
    _nonlinear_rate(case)
    case.truth["effect"] = {"kind": "rattle", "spring": s.name, "axis": "xyz"[axis], "clearance_m": clearance,
                            "contact_stiffness_n_per_m": k, "contact_damping_n_s_per_m": c}


def double_hit(case: Case, rng: np.random.Generator) -> None:
    """The hammer bounces: a second, weaker blow at the same point 2-10 ms after the first."""
    delay, fraction = rng.uniform(2e-3, 10e-3), rng.uniform(0.1, 0.5)
    case.records = [hits + [replace(hits[0], peak_n=hits[0].peak_n * fraction, delay_s=delay)]
                    for hits in case.records]
    case.truth["effect"] = {"kind": "double_hit", "delay_s": delay, "second_hit_fraction": fraction}


def _adc(bits: int):
    def effect(case: Case, rng: np.random.Generator) -> None:
        case.actual.daq.adc_bits = bits
        case.truth["effect"] = {"kind": "none", "adc_bits": bits}
    return effect


def drift(case: Case, rng: np.random.Generator) -> None:
    n = 1 + max(a.channel for a in case.actual.accelerometers)
    case.actual.daq.drift_v_per_s = rng.choice([-1, 1], n) * rng.uniform(2e-3, 20e-3, n)
    case.truth["effect"] = {"kind": "drift", "drift_v_per_s": case.actual.daq.drift_v_per_s}


def flicker(case: Case, rng: np.random.Generator) -> None:
    n = 1 + max(a.channel for a in case.actual.accelerometers)
    case.actual.daq.flicker_v = float(np.max(case.actual.daq.noise_rms_v))
    case.actual.daq.flicker_corner_hz = rng.uniform(20.0, 200.0, n)
    case.truth["effect"] = {"kind": "flicker", "flicker_v": case.actual.daq.flicker_v,
                            "flicker_corner_hz": case.actual.daq.flicker_corner_hz}


def common_noise(case: Case, rng: np.random.Generator) -> None:
    """A white noise every channel shares, as loud as each channel's own (a ground loop)."""
    case.actual.daq.common_v = float(np.max(case.actual.daq.noise_rms_v))
    case.truth["effect"] = {"kind": "common_noise", "common_v": case.actual.daq.common_v}


def ambient(case: Case, rng: np.random.Generator) -> None:
    """Floor vibration in every record: a noise band around 8-40 Hz (quality 2-5) on every
    accelerometer's channel, 3x as loud (rms) as its white noise (the hammer's load cell, in the
    hand, does not feel it)."""
    force = case.actual.force_sensor
    n = 1 + max([a.channel for a in case.actual.accelerometers] + ([force.channel] if force else []))
    level = 3.0 * float(np.max(case.actual.daq.noise_rms_v)) * np.ones(n)
    if force is not None:
        level[force.channel] = 0.0
    case.actual.daq.ambient_v = level
    case.actual.daq.ambient_hz = float(rng.uniform(8.0, 40.0))
    case.actual.daq.ambient_q = float(rng.uniform(2.0, 5.0))
    case.truth["effect"] = {"kind": "ambient", "ambient_v": case.actual.daq.ambient_v,
                            "ambient_hz": case.actual.daq.ambient_hz, "ambient_q": case.actual.daq.ambient_q}


def mains_hum(case: Case, rng: np.random.Generator) -> None:
    n = 1 + max(a.channel for a in case.actual.accelerometers)
    case.actual.daq.hum_hz = float(rng.choice([50.0, 60.0]))
    case.actual.daq.hum_v = rng.uniform(0.5e-3, 5e-3, n)
    case.truth["effect"] = {"kind": "mains_hum", "hum_hz": case.actual.daq.hum_hz, "hum_v": case.actual.daq.hum_v}


def channel_swap(case: Case, rng: np.random.Generator) -> None:
    """Two accelerometer channels' cables exchanged: each channel records the other sensor (with
    that sensor's sensitivity), named and scaled as the lab set the channel up."""
    accs = case.actual.accelerometers
    i, j = (int(k) for k in rng.choice(len(accs), size=2, replace=False))
    a, b = accs[i], accs[j]
    a.channel, b.channel = b.channel, a.channel
    case.truth["effect"] = {"kind": "channel_swap", "sensors": [a.name, b.name],
                            "channels": [b.channel, a.channel]}


CASES: dict[str, tuple[Callable[[Case, np.random.Generator], None], str]] = {
    "nominal-16bit": (_adc(16), "no hidden change, 16-bit ADC"),
    "nominal-12bit": (_adc(12), "no hidden change, 12-bit ADC"),
    "stiffer-axis": (_suspension_axis(+1), "one spring group 5-40 % stiffer along one axis"),
    "softer-axis": (_suspension_axis(-1), "one spring group 5-40 % softer along one axis"),
    "stiffer-spring": (_one_spring(+1), "one spring 5-40 % stiffer on all axes"),
    "softer-spring": (_one_spring(-1), "one spring 5-40 % softer on all axes"),
    "added-mass": (added_mass, "a point mass of 3-15 % of a body's mass on its top face"),
    "flexible-mode": (flexible_mode, "a plate bending mode of random shape between the top rigid mode and 2 kHz"),
    "sensor-tilt": (sensor_tilt, "one accelerometer tilted 5-40 degrees about a random axis"),
    "sensor-gain": (sensor_gain, "one accelerometer's sensitivity off by 5-30 %"),
    "polarity-flip": (polarity_flip, "one accelerometer wired with reversed polarity"),
    "scan-skew": (scan_skew, "multiplexed DAQ: channel k sampled k * (2-20 us) late"),
    "channel-delay": (channel_delay, "one accelerometer channel sampled 5-60 us late"),
    "channel-swap": (channel_swap, "two accelerometer channels' cables exchanged"),
    "torsion-mode": (torsion_mode, "the plate's torsion mode (sections rotate) between the top rigid mode and 2 kHz"),
    "loose-bracket": (loose_bracket, "the sensors at one point on a loose 10-50 g bracket, soft along one axis"),
    "hardening-series": (hardening_series, "cubic hardening springs, five force levels 0.5-50 N"),
    "coulomb-friction": (coulomb_friction, "Coulomb friction at one spring"),
    "rattle": (rattle, "a loose stop (gap contact) at one spring"),
    "double-hit": (double_hit, "every record holds a second, 10-50 % blow 2-10 ms after the first"),
    "drift": (drift, "no structural change; 2-20 mV/s drift per channel"),
    "mains-hum": (mains_hum, "no structural change; 0.5-5 mV of 50 or 60 Hz hum per channel"),
}


# ---------------------------------------------------------------------------------------------
# calibration cases: nulls, a softer mount, pairs of hidden changes (tests/independent/calibrate.py)


def null(case: Case, rng: np.random.Generator) -> None:
    case.truth["effect"] = {"kind": "none"}


def softer_mount(case: Case, rng: np.random.Generator) -> None:
    """One spring (any of the rig's mounts, isolators or springs) 20-40 % softer on all axes."""
    s = case.actual.structure.springs[int(rng.integers(len(case.actual.structure.springs)))]
    factor = 1.0 - rng.uniform(0.20, 0.40)
    s.stiffness = mat3(s.stiffness) * factor
    case.truth["effect"] = {"kind": "stiffness", "springs": [s.name], "axis": "xyz", "factor": factor}


def moved_com(case: Case, rng: np.random.Generator) -> None:
    """A body's centre of mass 10-25 mm away from where the lab believes, in a random horizontal
    direction (mass and inertia about the centre of mass unchanged)."""
    body = case.actual.structure.bodies[int(rng.integers(len(case.actual.structure.bodies)))]
    up = int(np.argmax(np.abs(case.actual.up)))
    d = rng.standard_normal(3)
    d[up] = 0.0
    d *= rng.uniform(0.010, 0.025) / np.linalg.norm(d)
    body.com = vec3(body.com) + d
    case.truth["effect"] = {"kind": "moved_com", "body": body.name, "shift_m": d, "new_com_m": body.com}


def _stiffer_vertical(case: Case, rng: np.random.Generator) -> None:
    """One spring group 20-40 % stiffer along the rig's vertical."""
    group = _group(case.actual, rng)
    up = int(np.argmax(np.abs(case.actual.up)))
    factor = 1.0 + rng.uniform(0.20, 0.40)
    for s in case.actual.structure.springs:
        if s.name in case.actual.spring_groups[group]:
            k = mat3(s.stiffness)
            k[up, up] *= factor
            s.stiffness = k
    case.truth["effect"] = {"kind": "stiffness", "group": group, "springs": case.actual.spring_groups[group],
                            "axis": "xyz"[up], "factor": factor}


def _strong_gain(case: Case, rng: np.random.Generator) -> None:
    """One accelerometer's sensitivity 15-30 % low (a gain of 0.70-0.85)."""
    s = case.actual.accelerometers[int(rng.integers(len(case.actual.accelerometers)))]
    s.gain_error = -float(rng.uniform(0.15, 0.30))
    case.truth["effect"] = {"kind": "sensor_gain", "sensor": s.name, "gain_error": s.gain_error}


def _pair(first, second):
    """Two hidden changes at once: truth["effects"] lists both, truth["effect"] says "pair"."""
    def effect(case: Case, rng: np.random.Generator) -> None:
        parts = []
        for one in (first, second):
            one(case, rng)
            parts.append(case.truth.pop("effect"))
        case.truth["effects"] = parts
        case.truth["effect"] = {"kind": "pair", "kinds": [e["kind"] for e in parts]}
    return effect


CASES.update({
    "null": (null, "no hidden change (for false-alarm counts with --force, --noise, drift, hum, double hits)"),
    "softer-mount": (softer_mount, "one spring (mount, isolator) 20-40 % softer on all axes"),
    "pair-gain-com": (_pair(_strong_gain, moved_com),
                      "two at once: one accelerometer's gain 0.70-0.85 and a centre of mass moved 10-25 mm"),
    "pair-bending-stiffer": (_pair(flexible_mode, _stiffer_vertical),
                             "two at once: a plate bending mode and one spring group 20-40 % stiffer vertically"),
    "pair-mount-gain": (_pair(softer_mount, _strong_gain),
                        "two at once: one spring 20-40 % softer and one accelerometer's gain 0.70-0.85"),
})

#: what may be laid over any case (its own random stream: the case's draws do not change)
DISTURBANCES = ("drift", "hum", "double-hit", "flicker", "common", "ambient")


def _disturb(case: Case, which, rng: np.random.Generator) -> None:
    effect = case.truth.get("effect")
    notes = {}
    for name in which:
        if name not in DISTURBANCES:
            raise KeyError(f"unknown disturbance {name!r}; known: {', '.join(DISTURBANCES)}")
        {"drift": drift, "hum": mains_hum, "double-hit": double_hit, "flicker": flicker,
         "common": common_noise, "ambient": ambient}[name](case, rng)
        notes[name] = case.truth.pop("effect")
    if effect is not None:
        case.truth["effect"] = effect
    if notes:
        case.truth["disturbances"] = notes


def build_case(name: str, seed: int, rig: str = "thesis", n_samples: int | None = None, *,
               force_n: float | None = None, noise_v: float | None = None, noise_fraction: float = 0.0,
               disturbances=(), pre_trigger: int | None = None) -> Case:
    """The case ``name`` on base rig ``rig`` ("thesis", "two-body" or "plate-motor"), drawn with
    ``seed``. Options (each left at its default keeps the case as it always was):
    ``force_n``: every record's (first) blow has this peak force, N (the hit points are still
    jittered); ``noise_v``: the white noise per channel, V rms (default 50 uV);
    ``noise_fraction``: more white noise, this fraction of each channel's clean rms;
    ``disturbances``: any of "drift", "hum", "double-hit", drawn from a stream of their own;
    ``pre_trigger``: samples before the first hit (default: the rig's).
    Names joined by "+" ("polarity-flip+channel-swap") draw each change in turn; the truth's
    "effects" lists them."""
    parts = name.split("+")
    if any(part not in CASES for part in parts):
        raise KeyError(f"unknown case {name!r}; cases: {', '.join(CASES)} (or several joined by '+')")
    if rig not in RIGS:
        raise KeyError(f"unknown rig {rig!r}; rigs: {', '.join(RIGS)}")
    nominal = RIGS[rig]()
    if n_samples is not None:
        nominal.daq.n_samples = n_samples
    if pre_trigger is not None:
        nominal.daq.pre_trigger = int(pre_trigger)
    rng = np.random.default_rng([seed, 0])
    case = Case(name, rig, seed, nominal, nominal.copy(), [])
    case.actual.daq.noise_rms_v = FLOOR_NOISE_V
    case.records = _jittered_hits(nominal, rng)
    if force_n is not None:
        case.records = [[replace(hits[0], peak_n=float(force_n))] + hits[1:] for hits in case.records]
    if len(parts) == 1:
        effect, description = CASES[name]
        case.truth["description"] = description
        effect(case, rng)
    else:
        effects = []
        for part in parts:
            CASES[part][0](case, rng)
            effects.append(case.truth.pop("effect", {"kind": part}))
        case.truth["description"] = "; ".join(CASES[part][1] for part in parts)
        case.truth["effects"] = effects
    if noise_v is not None:
        case.actual.daq.noise_rms_v = float(noise_v)
    case.actual.daq.noise_fraction = float(noise_fraction)
    _disturb(case, tuple(disturbances), np.random.default_rng([seed, 2]))
    if force_n is not None or noise_v is not None or noise_fraction or disturbances or pre_trigger is not None:
        case.truth["options"] = {"force_n": force_n, "noise_v": case.actual.daq.noise_rms_v,
                                 "noise_fraction": noise_fraction, "disturbances": list(disturbances)}
        if pre_trigger is not None:
            case.truth["options"]["pre_trigger"] = int(pre_trigger)
    return case


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tests.independent.cases", description=__doc__.split("\n")[0])
    parser.add_argument("out_dir", nargs="?", type=Path)
    parser.add_argument("--case", default="nominal-16bit")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--rig", default="thesis", choices=sorted(RIGS))
    parser.add_argument("--samples", type=int, default=None, help="samples per record (default: the rig's)")
    parser.add_argument("--formats", default="lvm,dat,uff", help="comma-separated: lvm, dat, uff")
    parser.add_argument("--decimal", default=".", choices=[".", ","], help="decimal separator of the .lvm")
    parser.add_argument("--physical", action="store_true", help=".lvm in m/s^2 and N instead of volts")
    parser.add_argument("--force", type=float, default=None, help="peak force of every blow, N")
    parser.add_argument("--noise", type=float, default=None, help="white noise per channel, V rms (default 50e-6)")
    parser.add_argument("--noise-fraction", type=float, default=0.0,
                        help="more white noise: this fraction of each channel's clean rms (0.03: 3 %%)")
    parser.add_argument("--disturb", default="", help=f"comma-separated: {', '.join(DISTURBANCES)}")
    parser.add_argument("--pre-trigger", type=int, default=None, help="samples before the first hit (default: the rig's)")
    parser.add_argument("--list", action="store_true", help="list the cases and exit")
    args = parser.parse_args(argv)
    if args.list:
        for name, (_, description) in CASES.items():
            print(f"{name:18s} {description}")
        return 0
    if args.out_dir is None:
        parser.error("OUT_DIR is required")
    formats = tuple(args.formats.split(","))
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        print(f"error: --formats: unknown {', '.join(unknown)}; known: {', '.join(FORMATS)}", file=sys.stderr)
        return 1
    try:
        case = build_case(args.case, args.seed, args.rig, args.samples, force_n=args.force, noise_v=args.noise,
                          noise_fraction=args.noise_fraction,
                          disturbances=[d for d in args.disturb.split(",") if d], pre_trigger=args.pre_trigger)
    except KeyError as exc:
        print(f"error: {exc.args[0]}", file=sys.stderr)
        return 1

    def progress(done, total):
        print(f"record {done}/{total} simulated", file=sys.stderr)

    files = case.write(args.out_dir, formats, decimal=args.decimal,
                       physical=args.physical, progress=progress)
    freqs = ", ".join(f"{f:.1f}" for f in Model(case.actual.structure).natural_frequencies())
    print(f"{case.name} (seed {case.seed}) on {case.nominal.name}: linear modes {freqs} Hz; "
          f"{len(files)} files in {args.out_dir}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
