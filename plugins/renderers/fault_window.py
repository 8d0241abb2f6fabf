"""Where a picture of a fault should look: the stretch of a record in which the residual of the band
that fails most rings, so that movies and overlays show the fault rather than the hit alone.

The band is the resolved residual's strongest cell (experiment, channel, octave band above its noise
floor; ``odsuite.analysis.resolved``). Its residual, band-passed, decays after the hit; the window
runs from a quarter of the band's period before the hit until the band's residual energy has reached
``ENERGY_SHARE`` of its total, and lasts at least ``MIN_PERIODS`` periods of the band's centre
frequency (a 9 Hz suspension mode is not seen in 60 ms)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

#: share of the band's residual energy (after the hit) that the window holds
ENERGY_SHARE = 0.95
#: the window lasts at least this many periods of the band's centre frequency
MIN_PERIODS = 3.0
#: the window starts this many periods before the hit
BEFORE_PERIODS = 0.25


@dataclass(frozen=True)
class FaultBand:
    """The strongest resolved cell: where the model fails most, as amplitude ratio to its floor."""

    experiment: str
    channel: str
    band_hz: tuple[float, float]
    residual_to_floor: float

    @property
    def centre_hz(self) -> float:
        return float(np.sqrt(self.band_hz[0] * self.band_hz[1]))

    def words(self) -> str:
        return (f"the band {self.band_hz[0]:.0f}-{self.band_hz[1]:.0f} Hz of {self.channel} in {self.experiment}, "
                f"whose residual is {self.residual_to_floor:.1f} times its noise floor (amplitude)")


def strongest_band(resolved) -> FaultBand | None:
    """The resolved residual's strongest cell above its floor (None: no cell is above)."""
    cells = resolved.cells(top=1) if resolved is not None else []
    if not cells:
        return None
    c = cells[0]
    return FaultBand(c["experiment"], c["channel"], (float(c["band_hz"][0]), float(c["band_hz"][1])),
                     float(c["residual_to_floor"]))


def band_passed(x: np.ndarray, fs: float, band_hz: tuple[float, float]) -> np.ndarray:
    """``x`` (n, ...) band-passed to ``band_hz``: a 4th-order Butterworth run forwards and backwards
    (zero phase, so no delay; a brick-wall filter's sinc tails would spread a short residual over
    the whole record)."""
    import scipy.signal

    sos = scipy.signal.butter(4, (band_hz[0], min(band_hz[1], 0.49 * fs)), "bandpass", fs=fs, output="sos")
    return scipy.signal.sosfiltfilt(sos, x, axis=0)


def band_window(residual: np.ndarray, fs: float, band_hz: tuple[float, float], contact: int, *,
                energy: float = ENERGY_SHARE, periods: float = MIN_PERIODS,
                before: float = BEFORE_PERIODS) -> tuple[float, float]:
    """(start, stop) in s from the record's start: from ``before`` periods of the band's centre ahead
    of ``contact`` (sample) until the band-passed ``residual`` (n, channels) after the contact has
    released ``energy`` of its energy, at least ``periods`` periods long; clipped to the record."""
    n = residual.shape[0]
    period = 1.0 / np.sqrt(band_hz[0] * band_hz[1])
    r = band_passed(np.asarray(residual, dtype=float).reshape(n, -1), fs, band_hz)
    power = np.sum(r[contact:] ** 2, axis=1)
    cumulative = np.cumsum(power)
    end = contact + (int(np.searchsorted(cumulative, energy * cumulative[-1])) if cumulative[-1] > 0 else 0)
    end = max(end, contact + int(round(periods * period * fs)))
    start = max(0, contact - int(round(before * period * fs)))
    return start / fs, min(n - 1, end) / fs


def fault_windows(exps: Sequence, predictions: Mapping[str, np.ndarray], band: FaultBand | None
                  ) -> dict[str, tuple[float, float]]:
    """Per experiment, the window of ``band``'s residual (all its channels: the fault's band rings
    wherever the model misses it); empty when no band is above its floor."""
    if band is None:
        return {}
    return {e.name: band_window(e.measured - predictions[e.name], e.fs, band.band_hz, int(e.trigger))
            for e in exps if e.name in predictions}
