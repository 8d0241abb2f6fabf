"""Plain descriptions of what is simulated: bodies, springs, contacts, flexible modes, base motion,
sensors, DAQ and hammer hits. SI units throughout (m, kg, kg m^2, N/m, N s/m, V, s, Hz)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

GROUND = "ground"


def vec3(value) -> np.ndarray:
    return np.asarray(value, dtype=float).reshape(3)


def mat3(value) -> np.ndarray:
    """A 3x3 matrix from 3 diagonal values or a full 3x3."""
    arr = np.asarray(value, dtype=float)
    return np.diag(arr) if arr.shape == (3,) else arr.reshape(3, 3)


@dataclass
class RigidBody:
    name: str
    mass: float
    com: np.ndarray  # rig frame, at rest
    inertia: np.ndarray  # 3x3 tensor about the centre of mass, rig axes
    plate: dict | None = None  # {"size": [L, W, H], "corner": [x, y, z]} for drawing (rig TOML only)
    nine_sensor_set: dict | None = None  # copied to the rig TOML as is


@dataclass
class Spring:
    """A 3-axis spring/damper at ``position`` between ``body`` and ``other`` (a body or ground).
    The relative displacement is body's point minus other's point; its force on ``body`` is
    -K d - C v - cubic * d**3 - friction * tanh(v / friction_velocity) (per rig axis)."""

    name: str
    body: str
    position: np.ndarray
    stiffness: np.ndarray  # 3 values (rig axes) or 3x3
    damping: np.ndarray
    other: str = GROUND
    cubic: np.ndarray | None = None  # N/m^3 per rig axis (hardening)
    friction: np.ndarray | None = None  # Coulomb force level per rig axis, N
    # regularisation of sign(v): a Coulomb law needs an event-driven stick-slip solver; tanh with a
    # velocity far below the response velocities behaves the same and integrates with fixed steps
    friction_velocity: float = 1e-4


@dataclass
class GapContact:
    """A rattling contact: a stop on both sides at ``clearance`` along ``axis``; inside the gap no
    force, beyond it a penalty spring ``stiffness`` with damping ``damping`` (only while touching)."""

    name: str
    body: str
    position: np.ndarray
    axis: np.ndarray
    clearance: float
    stiffness: float
    damping: float = 0.0
    other: str = GROUND


@dataclass
class FlexibleMode:
    """An elastic mode of one body, mass-normalised (modal mass 1 kg) and taken as orthogonal to the
    body's rigid motions (true for the free-free modes of any body). ``shape(p)`` is the 3-D
    displacement (m per unit modal coordinate) at rig-frame point p, used at springs, hit points
    and sensors; ``sensor_shapes`` overrides it at named sensors (a mode given only per sensor is
    seen there but neither driven by the hammer nor held by the springs)."""

    name: str
    body: str
    frequency_hz: float
    damping_ratio: float
    shape: Callable[[np.ndarray], np.ndarray] | None = None
    sensor_shapes: dict[str, np.ndarray] = field(default_factory=dict)

    def at(self, point: np.ndarray, sensor: str | None = None) -> np.ndarray:
        if sensor is not None and sensor in self.sensor_shapes:
            return vec3(self.sensor_shapes[sensor])
        return np.zeros(3) if self.shape is None else vec3(self.shape(np.asarray(point, float)))


@dataclass
class BaseMotion:
    """Sinusoidal ground motion [x y z rx ry rz] (m, rad) about the rig origin, switched on at t = 0
    with a raised-cosine envelope over ``ramp_s`` so that it starts from rest."""

    amplitude: np.ndarray  # 6 values
    frequency_hz: float
    ramp_s: float = 0.05

    def motion(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Displacement, velocity, acceleration, each (len(t), 6)."""
        t = np.asarray(t, float)
        w = 2 * np.pi * self.frequency_hz
        r = np.clip(t / self.ramp_s, 0.0, 1.0)
        env = 0.5 - 0.5 * np.cos(np.pi * r)
        denv = np.where((t > 0) & (t < self.ramp_s), 0.5 * np.pi / self.ramp_s * np.sin(np.pi * r), 0.0)
        d2env = np.where((t > 0) & (t < self.ramp_s), 0.5 * (np.pi / self.ramp_s) ** 2 * np.cos(np.pi * r), 0.0)
        s, c = np.sin(w * t), np.cos(w * t)
        a = np.asarray(self.amplitude, float)[None, :]
        disp = (env * s)[:, None] * a
        vel = (denv * s + env * w * c)[:, None] * a
        acc = (d2env * s + 2 * denv * w * c - env * w * w * s)[:, None] * a
        return disp, vel, acc


@dataclass
class Structure:
    bodies: list[RigidBody]
    springs: list[Spring]
    modes: list[FlexibleMode] = field(default_factory=list)
    contacts: list[GapContact] = field(default_factory=list)
    base_motion: BaseMotion | None = None

    def body(self, name: str) -> RigidBody:
        return next(b for b in self.bodies if b.name == name)

    @property
    def is_linear(self) -> bool:
        return not self.contacts and all(s.cubic is None and s.friction is None for s in self.springs)


@dataclass
class Accelerometer:
    """One measuring axis. volts = sign * sensitivity * (1 + gain_error) * a_measured, where a_measured
    is the acceleration along ``axis`` through the sensor's own resonance and its IEPE high-pass."""

    name: str
    channel: int
    body: str  # a body name or "ground"
    position: np.ndarray
    axis: np.ndarray  # unit vector, rig frame (the true one: a tilt is already applied)
    sensitivity: float  # V/(m/s^2)
    sign: float = 1.0
    gain_error: float = 0.0  # fraction: the true sensitivity is sensitivity * (1 + gain_error)
    resonance_hz: float | None = None  # mounted resonance (2nd order, unit DC gain)
    resonance_damping: float = 0.03
    iepe_corner_hz: float | None = None  # first-order AC coupling of the IEPE supply
    triaxial: str | None = None  # name of the triaxial housing this axis belongs to
    serial: str = ""


@dataclass
class ForceSensor:
    """The hammer's load cell: volts = sign * sensitivity * (1 + gain_error) * hammer force."""

    name: str
    channel: int
    sensitivity: float  # V/N
    sign: float = 1.0
    gain_error: float = 0.0
    serial: str = ""


@dataclass
class Daq:
    sampling_rate: float = 20000.0
    n_samples: int = 4096
    pre_trigger: int = 256  # samples before the first hit
    adc_bits: int | None = 16  # None: no quantisation
    adc_range: tuple[float, float] = (-5.0, 5.0)  # V
    amplifier_gain: float = 1.0  # V/V ahead of the ADC (the thesis used 10)
    aa_family: str | None = "butter"  # "butter", "ellip" or None (no anti-aliasing filter)
    aa_order: int = 4
    aa_cutoff_hz: float = 1000.0
    aa_ripple_db: float = 0.1  # elliptic only
    aa_attenuation_db: float = 60.0  # elliptic only
    scan_skew_s: float = 0.0  # multiplexed: the k-th scanned channel is sampled k * skew late
    channel_delay_s: dict[int, float] = field(default_factory=dict)  # channel -> extra sampling delay
    noise_rms_v: float | np.ndarray = 0.0  # white, per channel
    # more white noise, this fraction of each channel's clean rms after the trigger (added in
    # quadrature to noise_rms_v): "3 % of the signal"
    noise_fraction: float = 0.0
    hum_v: float | np.ndarray = 0.0  # mains hum amplitude per channel
    hum_hz: float = 50.0
    drift_v_per_s: float | np.ndarray = 0.0  # linear drift per channel
    # 1/f (flicker) noise per channel, as an IEPE accelerometer's rises at low frequency: its
    # spectral density is flicker_v's white level's times flicker_corner_hz / f (equal at the corner)
    flicker_v: float | np.ndarray = 0.0  # V rms of the white noise whose density sets the 1/f level
    flicker_corner_hz: float | np.ndarray = 0.0
    # white noise every channel shares (V rms; a ground loop's or the DAQ's common-mode noise, the same
    # volts on every input)
    common_v: float = 0.0
    # ambient floor vibration as the sensors see it: a random noise band around ambient_hz (a
    # two-pole resonance of quality ambient_q), V rms per channel, in every record and before the hit
    ambient_v: float | np.ndarray = 0.0
    ambient_hz: float = 20.0
    ambient_q: float = 3.0
    # internal rate = oversample * sampling_rate: 64+ points per hammer pulse, and a cubic spline
    # between fine points is exact to ~1e-8 for the 1-2 kHz the anti-aliasing filter passes
    oversample: int = 8


@dataclass
class Hit:
    """A half-sine hammer pulse on ``body`` at ``point`` along unit ``direction``; ``delay_s`` after
    the trigger (the record's pre-trigger point)."""

    body: str
    point: np.ndarray
    direction: np.ndarray
    peak_n: float
    duration_s: float = 0.4e-3
    delay_s: float = 0.0

    def force(self, t: np.ndarray, trigger_s: float) -> np.ndarray:
        tau = np.asarray(t, float) - trigger_s - self.delay_s
        inside = (tau >= 0) & (tau <= self.duration_s)
        return np.where(inside, self.peak_n * np.sin(np.pi * np.clip(tau, 0, self.duration_s) / self.duration_s), 0.0)


@dataclass
class Setup:
    """Everything one simulated record needs."""

    structure: Structure
    accelerometers: list[Accelerometer]
    force_sensor: ForceSensor | None
    daq: Daq
    hits: list[Hit]
