"""The pictures' time window follows the residual's strongest band: its period and its decay."""

from __future__ import annotations

import numpy as np
import pytest

from odsuite_plugins.renderers.fault_window import ENERGY_SHARE, MIN_PERIODS, band_window, strongest_band

FS = 2048.0


def _residual(n=8192, contact=256, f_low=15.0, tau=0.3, burst_hz=300.0, seed=0):
    """A decaying 15 Hz residual (energy time constant tau/2) from the contact, a strong short
    300 Hz burst at the contact and white noise far below both."""
    t = np.arange(n) / FS
    after = np.clip(t - contact / FS, 0.0, None)
    on = t >= contact / FS
    low = on * np.exp(-after / tau) * np.sin(2 * np.pi * f_low * after)
    burst = on * 20.0 * np.exp(-after / 0.005) * np.sin(2 * np.pi * burst_hz * after)
    noise = 1e-4 * np.random.default_rng(seed).standard_normal(n)
    return np.column_stack([low + burst + noise, 0.5 * low + noise]), contact, low


def test_window_holds_the_bands_decay_by_its_closed_form():
    """The amplitude decays as exp(-t/tau), the energy as exp(-2t/tau): 95 % of it is released by
    t = tau ln(20) / 2 after the contact (0.449 s for tau = 0.3 s), far beyond the hit's 60 ms; a
    band's time resolution is about its centre's period, so the window ends within one."""
    tau, band = 0.3, (11.3, 22.6)
    r, contact, low = _residual(tau=tau)
    start, stop = band_window(r, FS, band, contact)
    expected = tau * np.log(1.0 / (1.0 - ENERGY_SHARE)) / 2.0
    assert stop - contact / FS == pytest.approx(expected, abs=1.0 / np.sqrt(band[0] * band[1]))
    assert start < contact / FS < stop
    # the window holds the share of the 15 Hz residual's energy it promises
    inside = slice(int(round(start * FS)), int(round(stop * FS)) + 1)
    assert np.sum(low[inside] ** 2) >= ENERGY_SHARE * np.sum(low**2)
    # the 300 Hz burst, outside the band, does not decide the window: its own band's is short
    start_hi, stop_hi = band_window(r, FS, (181.0, 362.0), contact)
    assert stop_hi - contact / FS < 0.05


def test_window_lasts_at_least_some_periods_of_the_band():
    """A residual that dies at once (a 12 Hz cycle damped in 10 ms) still gets MIN_PERIODS
    periods of its band's centre."""
    n, contact = 4096, 256
    after = np.arange(n - contact) / FS
    r = np.zeros((n, 1))
    r[contact:, 0] = np.exp(-after / 0.01) * np.sin(2 * np.pi * 12.0 * after)
    start, stop = band_window(r, FS, (8.0, 16.0), contact)
    assert stop - contact / FS == pytest.approx(MIN_PERIODS / np.sqrt(8.0 * 16.0), abs=2 / FS)


def test_window_is_clipped_to_the_record():
    """Three periods of a 2-4 Hz band (1.06 s) do not fit in a 0.5 s record."""
    r, contact, _ = _residual(n=1024)
    start, stop = band_window(r, FS, (2.0, 4.0), contact)
    assert 0.0 <= start and stop == pytest.approx((1024 - 1) / FS)


def test_strongest_band_is_the_first_cell_above_its_floor():
    class Resolved:
        def __init__(self, cells):
            self._cells = cells

        def cells(self, top=8):
            return self._cells[:top]

    assert strongest_band(Resolved([])) is None and strongest_band(None) is None
    band = strongest_band(Resolved([{"experiment": "H2", "channel": "P1_z", "band_hz": [11.3, 22.6],
                                     "residual_to_floor": 7.5, "limit": 2.0}]))
    assert (band.experiment, band.channel, band.band_hz) == ("H2", "P1_z", (11.3, 22.6))
    assert band.centre_hz == pytest.approx(np.sqrt(11.3 * 22.6))
