"""Operating loads of the simulated rig: a running machine drives the rig at the force point with
a random or swept force, or with the rotating force of an unbalanced rotor, or the ground under
the rig moves at random in all six rigid directions. No hammer, no trigger, no load cell: what is
recorded is the responses alone (operational modal analysis, ODS).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy  # scipy.signal loads on first use: fast `odsuite plugins`

from odsuite.api import ConfigError
# DEFAULT_BASE_RMS: this module's default, defined beside the option
from odsuite_plugins.daq_sim.options import DEFAULT_BASE_RMS, MAX_PEAK_N, MIN_PEAK_N  # noqa: F401

KINDS = ("random", "sweep", "unbalance", "base-random")
#: kinds where the ground moves instead of a force acting at the force point
GROUND_KINDS = ("base-random",)
#: default rms force (N): the thesis rig's accelerometers then stay inside their ranges (a rotor at
#: a corner at 100 Hz peaks at 0.7 of the most loaded one's), far above their noise
DEFAULT_FORCE_RMS = 0.5
#: a sweep runs linearly from this fraction of the rate up to SWEEP_TOP of it (below the 1 kHz
#: anti-aliasing filter's corner at the thesis's rates, so the sweep's top is still measured)
SWEEP_BOTTOM = 0.0005
SWEEP_TOP = 0.4


@dataclass(frozen=True)
class OperatingLoad:
    """What drives the rig: ``kind`` random, sweep or unbalance (then ``frequency_hz``, the
    rotor's speed in revolutions per second)."""

    kind: str
    frequency_hz: float | None = None

    def __str__(self) -> str:
        return self.kind if self.frequency_hz is None else f"{self.kind}:{self.frequency_hz:g}"


def parse_operating(text: str, sampling_rate: float) -> OperatingLoad:
    """``random``, ``sweep`` or ``unbalance:HZ`` (HZ below the record's Nyquist frequency)."""
    kind, colon, value = str(text).strip().lower().partition(":")
    if kind not in KINDS:
        raise ConfigError(f"--operating: expected random, sweep, unbalance:HZ or base-random, got {text!r}")
    if kind != "unbalance":
        if colon:
            raise ConfigError(f"--operating {kind}: takes no value, got {text!r}")
        return OperatingLoad(kind)
    try:
        hz = float(value)
    except ValueError:
        raise ConfigError(f"--operating unbalance:HZ: HZ must be the rotor's speed in Hz, got {value!r}") from None
    if not (np.isfinite(hz) and 0 < hz < sampling_rate / 2):
        raise ConfigError(f"--operating unbalance:{value}: the speed must lie between 0 and the Nyquist "
                          f"frequency {sampling_rate / 2:g} Hz")
    return OperatingLoad(kind, hz)


def rotation_length(positions: np.ndarray) -> float:
    """The length (m) that turns the ground's translational rms into its angular rms: the farthest
    accelerometer's distance from the rig origin, so that the ground's rotation accelerates that
    sensor as much as its translation does and both drive the rig's rocking and sliding alike."""
    length = float(np.max(np.linalg.norm(np.atleast_2d(positions), axis=1), initial=0.0))
    if not length > 0:
        raise ConfigError("--operating base-random: the rig's accelerometers all sit at its origin; the ground's "
                          "rotation needs a length to scale it")
    return length


#: the strongest ground motion simulated (m/s^2 rms, about 1000 g): beyond any floor or vehicle,
#: and every sample of the record would clip
BASE_RMS_MAX = 1e4


def ground_accelerations(n: int, base_rms: float, length_m: float, rng: np.random.Generator) -> np.ndarray:
    """Independent white Gaussian accelerations of the ground (n x 6, at the simulator's rate):
    ``base_rms`` m/s^2 along x, y, z, then ``base_rms / length_m`` rad/s^2 about them through the
    rig origin."""
    if not (np.isfinite(base_rms) and 0 < base_rms <= BASE_RMS_MAX):
        raise ConfigError(f"--base-rms: must be > 0 and at most {BASE_RMS_MAX:g} m/s^2, got {base_rms!r}")
    scale = np.r_[np.full(3, base_rms), np.full(3, base_rms / length_m)]
    return rng.standard_normal((n, 6)) * scale


def perpendicular_axes(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing ``axis`` to a right-handed frame (the rotor's plane of rotation)."""
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    helper = np.eye(3)[int(np.argmin(np.abs(a)))]
    u = np.cross(a, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(a, u)


def operating_forces(load: OperatingLoad, n: int, fs: float, record_rate: float, direction: np.ndarray,
                     force_rms: float, rng: np.random.Generator) -> list[tuple[np.ndarray, np.ndarray]]:
    """The load as (force record in N at the simulator's rate ``fs``, unit direction) pairs acting
    at the force point; ``direction`` is the force's line for random and sweep, the rotor's axis
    for unbalance. A sweep spans the band of a record at ``record_rate``."""
    if not MIN_PEAK_N <= force_rms <= MAX_PEAK_N:  # NaN fails too
        raise ConfigError(f"--force-rms: an operating load's rms force, {MIN_PEAK_N:g} to {MAX_PEAK_N:g} N, "
                          f"got {force_rms!r}")
    t = np.arange(n) / fs
    d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    if load.kind == "random":  # white Gaussian at the simulator's rate: flat far beyond the record's band
        return [(force_rms * rng.standard_normal(n), d)]
    if load.kind == "sweep":
        f0, f1 = SWEEP_BOTTOM * record_rate, SWEEP_TOP * record_rate
        return [(np.sqrt(2) * force_rms * scipy.signal.chirp(t, f0, t[-1], f1, method="linear"), d)]
    # unbalance: a force of constant magnitude turning with the rotor in the plane normal to its axis
    u, v = perpendicular_axes(d)
    phase = 2 * np.pi * load.frequency_hz * t + rng.uniform(0, 2 * np.pi)
    return [(force_rms * np.cos(phase), u), (force_rms * np.sin(phase), v)]
