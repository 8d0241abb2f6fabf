"""The impact hammer: half-sine force pulses at one point and direction of the platform."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from odsuite.api import ConfigError
from odsuite_plugins.daq_sim.options import MAX_PEAK_N, MIN_PEAK_N


#: contact times of real blows: a steel tip on steel 0.05 ms, a rubber-tipped sledge on a vehicle or
#: a drop weight 50 ms
MIN_CONTACT_S, MAX_CONTACT_S = 0.05e-3, 50e-3


@dataclass(frozen=True)
class Hit:
    """One impact: starts ``time`` s after the first hit, ``peak`` N, ``width`` s (contact time)."""

    time: float = 0.0
    peak: float = 20.0
    width: float = 0.5e-3

    def validate(self, where: str) -> None:
        if not (np.isfinite(self.time) and self.time >= 0):
            raise ConfigError(f"{where}: hit field 'time' must be >= 0 s, got {self.time!r}")
        if not MIN_PEAK_N <= self.peak <= MAX_PEAK_N:  # NaN fails too
            raise ConfigError(f"{where}: hit field 'peak' must be {MIN_PEAK_N:g}-{MAX_PEAK_N:g} N (a hammer's peak "
                              f"force), got {self.peak!r}")
        if not MIN_CONTACT_S <= self.width <= MAX_CONTACT_S:
            raise ConfigError(f"{where}: hit field 'width' must be {1e3 * MIN_CONTACT_S:g}-{1e3 * MAX_CONTACT_S:g} ms "
                              f"(a blow's contact time), got {self.width!r} s")


def half_sine_force(t: np.ndarray, hits: list[Hit], t0: float = 0.0) -> np.ndarray:
    """Force (N) at times ``t``: the sum of half-sine pulses, the first starting at ``t0``."""
    f = np.zeros_like(np.asarray(t, dtype=float))
    for h in hits:
        tau = t - t0 - h.time
        on = (tau >= 0) & (tau <= h.width)
        f[on] += h.peak * np.sin(np.pi * tau[on] / h.width)
    return f


def impulse(hits: list[Hit]) -> float:
    """Total impulse (N s): a half-sine pulse carries 2 peak width / pi."""
    return sum(2.0 * h.peak * h.width / np.pi for h in hits)
