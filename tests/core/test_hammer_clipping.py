"""Clipping decided from the converter's range and codes, in each record's own units: constructed
hammer pulses quantised to a few ADC codes pass, saturated ones do not."""

from __future__ import annotations

import numpy as np
import pytest

from odsuite.domain.errors import ConfigError, DimensionError
from odsuite.analysis.hammer import assess_hits, is_clipped, quantisation_step

FS = 20_000.0


def _adc(volts: np.ndarray, bits: int = 12, low: float = -5.0, high: float = 5.0) -> np.ndarray:
    """An n-bit converter on [low, high): nearest code, clipped to codes 0 .. 2**bits - 1."""
    lsb = (high - low) / 2**bits
    return low + np.clip(np.round((volts - low) / lsb), 0, 2**bits - 1) * lsb


def _hit(n: int = 4096, at: int = 500, width_s: float = 5e-4, peak: float = 1.0) -> np.ndarray:
    """A half-sine hammer pulse followed by nothing."""
    t = (np.arange(n) - at) / FS
    return np.where((t >= 0) & (t <= width_s), peak * np.sin(np.pi * np.clip(t, 0, width_s) / width_s), 0.0)


def _ring(n: int = 4096, at: int = 500, f_hz: float = 180.0, zeta: float = 0.02, peak: float = 1.0) -> np.ndarray:
    t = (np.arange(n) - at) / FS
    return np.where(t >= 0, peak * np.exp(-zeta * 2 * np.pi * f_hz * t) * np.sin(2 * np.pi * f_hz * t), 0.0)


def test_quantised_force_of_17_codes_is_not_clipped():
    # the simulated thesis T1/T5 force: about 2 N through a 2.248 mV/N load cell and a gain of 10
    # on a 12-bit +-5 V card, 17 codes tall
    lsb = 10.0 / 4096
    volts = _adc(_hit(width_s=2e-3, peak=17.2 * lsb))  # widened by the 1 kHz anti-aliasing filter
    codes = (volts.max() - volts.min()) / quantisation_step(volts)
    assert codes == pytest.approx(17)
    held = np.flatnonzero(volts == volts.max())
    assert held.size >= 3  # the peak does sit on its top code for several samples
    assert not is_clipped(volts)
    assert not is_clipped(volts, limits=(-5.0, 5.0))


def test_quantised_slow_response_is_not_clipped():
    # a 180 Hz decay sampled at 20 kHz spans 12 codes: each crest lingers on its code
    volts = _adc(_ring(peak=0.015))
    assert np.unique(volts).size < 20
    assert not is_clipped(volts)


def test_amplifier_saturation_below_the_converter_range_is_clipped():
    # an amplifier that saturates at 1.2 V: a steep flat top at the record's extreme code
    volts = _adc(np.clip(_ring(peak=2.0), -1.2, 1.2))
    assert is_clipped(volts)
    assert is_clipped(volts, limits=(-5.0, 5.0))


def test_a_constant_channel_is_not_clipped_but_one_at_a_limit_is():
    # a channel that sees no response (a sensor across the blow's line) holds one value throughout
    assert not is_clipped(np.zeros(4096))
    assert not is_clipped(np.full(4096, 0.3), limits=(-5.0, 5.0))
    assert is_clipped(np.full(4096, 5.0), limits=(-5.0, 5.0))


def test_converter_range_end_is_clipped_even_without_a_flat_top():
    volts = _adc(_hit(peak=5.02))  # beyond +5 V - 1/2 lsb: the top code (5 V - 1 lsb), held 2 samples
    assert np.count_nonzero(volts == volts.max()) < 3
    assert not is_clipped(volts)  # no flat top of 3 samples ...
    assert is_clipped(volts, limits=(-5.0, 5.0))  # ... but at the converter's top code


def test_limits_apply_in_the_records_units():
    # 40 m/s^2 of clean response must not be judged against a +-10 V range
    accel = _ring(peak=40.0)
    assert not is_clipped(accel)
    assert is_clipped(accel, limits=(-10.0, 10.0))  # what a volt range in m/s^2 would wrongly say


def test_flat_top_at_the_data_end_counts_as_steep():
    x = _adc(_ring(peak=1.0))
    lsb = 10.0 / 4096
    top = x.max() + 20 * lsb  # jumps 20 codes up and stays there until the record ends
    assert is_clipped(np.concatenate([x, np.full(3, top)]))
    assert not is_clipped(np.concatenate([x, np.full(2, top)]))  # 2 samples: not a flat top
    with pytest.raises(ConfigError, match="at least 3 samples"):
        is_clipped(x, run=2)


def test_per_channel_response_limits_in_assess_hits():
    force = _hit(peak=100.0)
    resp = np.column_stack([_ring(peak=40.0), _ring(peak=0.8)])
    hits = assess_hits(force, resp, FS, response_limits=[None, (-1.0, 1.0)], decay_limit=None)
    assert [h.accepted for h in hits] == [True]
    hits = assess_hits(force, resp, FS, response_limits=[None, (-0.5, 0.5)], decay_limit=None)
    assert hits[0].reasons == ("response channel 1 clipped/overloaded",)
    with pytest.raises(DimensionError, match="1 response limits for 2 response channels"):
        assess_hits(force, resp, FS, response_limits=[(-1.0, 1.0)])


def test_a_filtered_pulses_opposite_lobe_is_no_second_hit():
    # a 0.5 ms blow through an 8th-order 1 kHz low-pass recorded at 1 MHz rings for over a
    # thousand samples: its negative lobe (40 % of the peak) was taken as a second, accepted hit,
    # which cut both records to 863 samples (FRF lines 1.16 kHz apart)
    import scipy.signal

    from odsuite.analysis.hammer import find_hits

    fs, n = 1e6, 65536
    t = (np.arange(n) - 800) / fs
    pulse = np.where((t >= 0) & (t <= 5e-4), np.sin(np.pi * np.clip(t, 0, 5e-4) / 5e-4), 0.0)
    force = scipy.signal.sosfilt(scipy.signal.butter(8, 1000.0, fs=fs, output="sos"), pulse)
    assert -force.min() > 0.2 * force.max()  # the lobe the threshold met
    assert len(find_hits(force, min_gap=n // 64)) == 1
    assert len(find_hits(-force, min_gap=n // 64)) == 1  # a load cell wired the other way
