"""A hit's peak is the top of its own pulse, found by the pulse's shape whatever the sample rate:
half-sine blows of 0.2-5 ms from 10 kHz to 1 MHz, bounces, slow rises and a real record."""

from __future__ import annotations

import numpy as np
import pytest

from odsuite.analysis.hammer import assess_hits, find_hits
from odsuite_plugins.importers.lvm import read_lvm


def _half_sine(fs: float, n: int, at_s: float, width_s: float, peak: float = 1.0) -> np.ndarray:
    t = np.arange(n) / fs - at_s
    return np.where((t >= 0) & (t <= width_s), peak * np.sin(np.pi * np.clip(t, 0, width_s) / width_s), 0.0)


@pytest.mark.parametrize("fs", [1e4, 5e4, 2e5, 1e6])
@pytest.mark.parametrize("width_s", [2e-4, 5e-4, 1e-3, 2e-3, 5e-3])
def test_a_blows_peak_is_the_top_of_its_pulse_at_any_rate(fs, width_s):
    # at 1 MHz a 1 ms blow peaks 436 samples after it crosses a fifth of its peak, past the quarter
    # of the 1024-sample gap that was searched (0.84 of the peak was read), and a 2-5 ms one stays
    # above the threshold longer than the gap and was split into 2-5 hits
    n = 65536
    at = 0.3 * n / fs
    clean = _half_sine(fs, n, at, width_s, 12.5)
    force = clean + 0.125 * np.random.default_rng(int(fs * width_s)).standard_normal(n)  # 1 % noise
    (peak,) = find_hits(force, min_gap=n // 64)
    top = round((at + width_s / 2) * fs)
    # the largest sample of the blow, where the noiseless half-sine is within 4 noise sigmas of 12.5 N
    assert force[peak] == force.max()
    assert clean[peak] > max(clean[top - 1 : top + 2]) - 0.5
    assert len(find_hits(-force, min_gap=n // 64)) == 1  # a load cell wired the other way


def test_a_filtered_blows_peak_at_1_mhz():
    # a 12.5 N blow of 0.5 ms through an 8th-order 1 kHz low-pass (7.66 N at its top) crosses a
    # fifth of its peak more than 256 samples before its peak
    import scipy.signal

    fs, n = 1e6, 65536
    force = 12.5 * scipy.signal.sosfilt(scipy.signal.butter(8, 1000.0, fs=fs, output="sos"),
                                        _half_sine(fs, n, 8e-4, 5e-4))
    (hit,) = assess_hits(force, np.zeros(n), fs, decay_limit=None)
    assert hit.peak_index == int(np.argmax(force))
    assert hit.peak_force == force.max()


@pytest.mark.parametrize("fs", [1e4, 1e6])
@pytest.mark.parametrize("apart_s", [1e-3, 3e-3, 10e-3])
@pytest.mark.parametrize("bounce", [0.4, 1.5])
def test_a_bounce_is_a_double_hit_of_the_first_blow(fs, apart_s, bounce):
    # a rebound 1-10 ms after a 1 ms blow, within the gap that merges hits: the hit's peak is the
    # first blow's, and the rebound after it rejects the hit. A rebound harder than the blow was
    # taken for the peak, with the blow before it, and the hit was accepted
    n = 2**20 if fs > 1e5 else 65536
    width = 1e-3
    force = _half_sine(fs, n, 0.2, width, 100.0) + _half_sine(fs, n, 0.2 + width + apart_s, width, 100.0 * bounce)
    (hit,) = assess_hits(force, np.zeros(n), fs, decay_limit=None)
    assert hit.peak_index == round((0.2 + width / 2) * fs)
    assert hit.peak_force == pytest.approx(100.0, rel=1e-3)
    # said in ms from peak to peak, as a user reads it (the samples apart were not said)
    assert hit.double_hit_after == pytest.approx(width + apart_s, abs=0.5 / fs)
    assert hit.reasons == (f"double hit {1e3 * (width + apart_s):.3g} ms after its peak",)


def test_a_quick_blow_close_behind_a_broad_one_leaves_each_record_its_pulse():
    # at 1 MHz a 1.1 ms blow peaks 550 samples after it starts, and a 0.1 ms one starts 20 us after
    # it ends: the peaks lie 620 samples apart, closer than the 655-sample pretrigger, and records
    # that short ended before their peaks (IndexError)
    fs, n = 1e6, 65536
    force = _half_sine(fs, n, 0.02, 1.1e-3, 10.0) + _half_sine(fs, n, 0.02 + 1.12e-3, 1e-4, 8.0)
    first, second = assess_hits(force, np.zeros(n), fs, decay_limit=None)
    assert (first.peak_index, second.peak_index) == (20550, 21170)
    assert (first.peak_force, second.peak_force) == pytest.approx((10.0, 8.0))
    # each record holds its pulse above 5 % of the largest blow: [20018, 21083) and [21122, 21219)
    edges = np.flatnonzero(np.diff((force > 0.5).astype(int)))
    for hit, (begin, end) in zip((first, second), edges.reshape(2, 2) + 1):
        assert hit.trigger == 655 and hit.start <= begin and end <= hit.stop
    assert first.stop == edges[1] + 1  # the first record ends where its pulse does


def test_slow_rises_are_one_hit_each_peaking_at_their_top():
    # a force rising over 5 ms and then let go, four times at 1 MHz: each rise stayed above the
    # threshold past the 1024-sample gap and was split into several hits peaking on the rise
    fs, n = 1e6, 65536
    t = np.arange(n) / fs
    force = np.zeros(n)
    for k, start in enumerate((0.005, 0.02, 0.035, 0.05)):
        rise = (t >= start) & (t < start + 5e-3)
        force[rise] = (10.0 + k) * (t[rise] - start) / 5e-3
    hits = assess_hits(force, np.zeros(n), fs, decay_limit=None)
    assert [h.peak_index for h in hits] == [9999, 24999, 39999, 54999]
    assert [h.peak_force for h in hits] == pytest.approx([10.0, 11.0, 12.0, 13.0], rel=1e-3)
    assert all(0 <= h.trigger < h.stop - h.start for h in hits)


def test_real_triggered_records_cut_to_their_own_length(real_data):
    # two 8192-sample triggered records of 1024 Hz, hits 8191 samples apart: with records of 8192
    # samples the second hit's crossing falls within the merging gap, and its peak was searched from
    # the sample after its largest one (-4.78 N read for -17.27 N)
    d = read_lvm(real_data / "lvm_read_impacts" / "long_single_header_multi_ch.lvm")
    force = d.channel("F")
    responses = np.column_stack([d.channel("m_1"), d.channel("m_2")])
    default = assess_hits(force, responses, d.sampling_rate)
    given = assess_hits(force, responses, d.sampling_rate, record_length=8192)
    assert [h.peak_index for h in default] == [h.peak_index for h in given] == [85, 8276]
    assert [h.peak_force for h in given] == [force[85], force[8276]] == pytest.approx([-18.032922, -17.268434])
    assert [(h.start, h.stop) for h in given] == [(4, 8196), (8192, 16384)]


@pytest.mark.parametrize(("width_s", "record_length"), [(5e-3, None), (2e-3, None), (1e-3, 8192)])
def test_a_record_holds_its_blows_whole_rise(width_s, record_length):
    # at 1 MHz a 5 ms blow rises over 2500 samples, and 1 % of a 65536-sample record (655) began
    # the record on its rising edge, at 0.92 of the peak: its force summed to 0.70 of the blow's
    # impulse. Cut to 8192 samples, 1 % (81) began a 1 ms blow's record at 0.97 of its peak (0.63)
    fs, n = 1e6, 65536
    force = _half_sine(fs, n, 0.01, width_s, 20.0)
    (hit,) = assess_hits(force, np.zeros(n), fs, record_length=record_length, decay_limit=None)
    # from the last sample within 5 % of the peak: the foot below it carries 0.06 % of the impulse
    assert force[hit.start] <= 1.0 < force[hit.start + 1]
    impulse = 2 * 20.0 * width_s / np.pi  # N s of a half-sine
    assert force[hit.start : hit.stop].sum() / fs == pytest.approx(impulse, rel=1e-3)
