"""Hammer-test quality and FRF estimators against a simulated 3-DOF system with exact FRFs."""

from __future__ import annotations

import numpy as np
import pytest

import mck_threedof as mck
from odsuite.domain.errors import ConfigError, DimensionError
from odsuite.analysis.frf import convert_form, estimate_frf
from odsuite.analysis.hammer import (
    assess_hits,
    correct_exponential_window,
    exponential_window,
    force_window,
    is_clipped,
)

FS = 1024.0
REC = 8192
AMPS = [100.0, 70.0, 130.0, 90.0, 110.0, 80.0, 120.0, 95.0]


@pytest.fixture(scope="module")
def record():
    """Eight clean hits 8 s apart, then a double hit (rebound 8 ms later)."""
    pulses = [(0.1 + 8 * k, 0.004, a) for k, a in enumerate(AMPS)]
    t_double = 0.1 + 8 * len(AMPS)
    pulses += [(t_double, 0.004, 100.0), (t_double + 0.008, 0.004, 40.0)]
    return mck.simulate(FS, 8 * len(AMPS) + 8.1, pulses)


def _noisy(record, level, seed, force_level=None):
    f, a = record
    rng = np.random.default_rng(seed)
    fl = level if force_level is None else force_level
    return (
        f + fl * f.max() * rng.standard_normal(f.shape),
        a + level * np.abs(a).max(axis=0) * rng.standard_normal(a.shape),
    )


def test_hits_split_and_double_hit_rejected(record):
    f, a = _noisy(record, 1e-5, 0)
    hits = assess_hits(f, a, FS, record_length=REC, pretrigger=50)
    assert len(hits) == 9
    assert [h.accepted for h in hits] == [True] * 8 + [False]
    # the rebound 8 ms after the blow: their top samples lie 9 samples apart at 1024 Hz (the peaks
    # fall at 65640.4 and 65648.6 samples)
    assert hits[-1].double_hit_after == 9 / FS
    assert hits[-1].reasons == ("double hit 8.79 ms after its peak",)
    peaks = [h.peak_index for h in hits[:8]]
    np.testing.assert_allclose(np.diff(peaks), 8 * FS, atol=1)
    assert all(h.trigger == 50 and h.stop - h.start == REC for h in hits)
    # the hammer pulse is 4 ms wide: about 4 samples above 5 % of its peak at 1024 Hz
    assert all(3 <= h.pulse_width <= 6 for h in hits)


def test_clipped_force_and_response_rejected(record):
    f, a = _noisy(record, 1e-5, 1)
    f = f.copy()
    a = a.copy()
    f[:REC] = np.clip(f[:REC], -150.0, 150.0) * 2  # hit 0 drives the force input to its range end
    a[REC : 2 * REC, 1] = np.clip(a[REC : 2 * REC, 1], -5.0, 5.0)  # response 1 flat-tops on hit 1
    hits = assess_hits(f, a, FS, record_length=REC, pretrigger=50, force_limits=(-150.0, 150.0))
    assert "force clipped/overloaded" in hits[0].reasons
    assert hits[1].reasons == ("response channel 1 clipped/overloaded",)
    assert hits[2].accepted
    assert is_clipped(np.array([0.0, 1.0, 2.0]), limits=(-2.0, 2.0))
    assert not is_clipped(np.sin(np.linspace(0, 6, 500)))


def test_h1_matches_exact_frf_where_coherence_is_high(record):
    f, a = _noisy(record, 1e-5, 2)
    hits = [h for h in assess_hits(f, a, FS, record_length=REC, pretrigger=50) if h.accepted]
    frf = estimate_frf(
        [f[h.start : h.stop] for h in hits], [a[h.start : h.stop] for h in hits], FS,
        response_units=["m/s^2"] * 3,
    )
    assert frf.units == ["(m/s^2)/N"] * 3 and frf.n_averages == 8
    exact = mck.accelerance(frf.frequency)
    band = (frf.frequency > 2) & (frf.frequency < 300)
    # Bendat & Piersol random error of |H1| from coherence and number of averages
    rel = np.abs(frf.H[:, band] - exact[:, band]) / np.abs(exact[:, band])
    g = frf.coherence[:, band]
    eps = np.sqrt((1 - g) / g / (2 * frf.n_averages))
    high = eps < 2e-4  # 5 sigma below 1e-3
    assert high.sum() > 100
    assert rel[high].max() < 1e-3
    # the high-coherence lines include each resonance peak of every output
    true_f = np.abs(mck.modes()[0]) / (2 * np.pi)
    for fr in true_f:
        k = np.argmin(np.abs(frf.frequency[band] - fr))
        assert high[:, k].all()
        assert rel[:, k].max() < 1e-3
    # the error stays within a few times the coherence-predicted random error wherever gamma^2 > 0.99
    ok = g > 0.99
    assert np.percentile(rel[ok] / eps[ok], 99) < 6


def test_noise_free_h1_is_exact():
    f, a = mck.simulate(FS, 8.0, [(0.1, 0.004, 100.0)])
    frf = estimate_frf([f], [a], FS)
    exact = mck.accelerance(frf.frequency)
    band = (frf.frequency > 5) & (frf.frequency < 200)
    # away from antiresonances (|H| > 1 % of its peak) the error is the simulation's own hold error
    big = band[None, :] & (np.abs(exact) > 0.01 * np.abs(exact).max(axis=1, keepdims=True))
    assert (np.abs(frf.H - exact) / np.abs(exact))[big].max() < 1e-3
    assert (np.abs(frf.H - exact)[:, band] / np.abs(exact).max(axis=1, keepdims=True)).max() < 2e-4
    np.testing.assert_allclose(frf.coherence[:, band], 1.0, atol=1e-12)  # one average


def test_force_noise_biases_h1_low_but_not_h2(record):
    f, a = _noisy(record, 1e-6, 3, force_level=4e-3)
    hits = [h for h in assess_hits(f, a, FS, record_length=REC, pretrigger=50) if h.accepted]
    fs_, rs_ = [f[h.start : h.stop] for h in hits], [a[h.start : h.stop] for h in hits]
    est = {e: estimate_frf(fs_, rs_, FS, estimator=e) for e in ("H1", "H2", "Hv")}
    freq = est["H1"].frequency
    # expected H1 bias: Gff/(Gff + Gnn), with the noise power known from how it was added
    f_clean = record[0]
    gff = np.mean([np.abs(np.fft.rfft(f_clean[h.start : h.stop])) ** 2 for h in hits], axis=0)
    gnn = REC * (4e-3 * f_clean.max()) ** 2
    exact = mck.accelerance(freq)
    lines = ((freq > 5) & (freq < 200))[None, :] & (
        np.abs(exact) > 0.05 * np.abs(exact).max(axis=1, keepdims=True)
    )
    r = {e: np.abs(est[e].H / exact)[lines] for e in est}
    bias = np.broadcast_to(gff / (gff + gnn), exact.shape)[lines]
    # H1 carries the predicted bias; H2 scatters (finite averages) around 1 without it
    assert np.median(r["H1"]) < 0.97
    np.testing.assert_allclose(np.median(r["H1"] / bias), 1.0, atol=0.01)
    assert abs(np.median(r["H2"]) - 1) < 0.01
    assert np.median(r["H1"]) < np.median(r["Hv"]) < np.median(r["H2"])


def test_exponential_window_shifts_poles_exactly():
    """A record cut before the response has decayed: with the exponential window on force and
    response, the FRF is the exact FRF of the system with poles shifted by -1/tau."""
    f, a = mck.simulate(FS, 1.0, [(0.02, 0.004, 100.0)])
    w, tau = exponential_window(f.size, FS, trigger=20, end_value=1e-4)
    assert w[-1] == pytest.approx(1e-4) and w[20] == pytest.approx(1.0)
    frf = estimate_frf([f], [a], FS, window=w)
    # exact windowed FRF: evaluate the accelerance at s = i omega - 1/tau
    s = 2j * np.pi * frf.frequency + 1.0 / tau
    exact = np.empty((3, s.size), dtype=complex)
    for i, sk in enumerate(s):
        exact[:, i] = sk**2 * np.linalg.solve(mck.K + sk * mck.C + sk**2 * mck.M, np.eye(3)[:, mck.INPUT])
    band = (frf.frequency > 5) & (frf.frequency < 200)
    rel = np.abs(frf.H[:, band] - exact[:, band]) / np.abs(exact[:, band])
    assert rel.max() < 2e-3
    lam = mck.modes()[0]
    np.testing.assert_allclose(correct_exponential_window(lam - 1 / tau, tau), lam)


def test_force_window_and_form_conversion():
    w = force_window(100, 10, 20, taper=4)
    assert w[10:20].tolist() == [1.0] * 10 and w[:5].sum() == 0 and w[25:].sum() == 0
    assert 0 < w[21] < 1 and w[21] > w[23] and w[6:10].tolist() == w[20:24][::-1].tolist()
    with pytest.raises(ConfigError, match="does not fit"):
        force_window(100, 90, 120)
    freq = np.array([0.0, 10.0, 20.0])
    H = np.array([[1.0, 2.0 + 1j, -3.0]])
    acc = convert_form(freq, H, "receptance", "accelerance")
    np.testing.assert_allclose(acc, H * (2j * np.pi * freq) ** 2)
    np.testing.assert_allclose(convert_form(freq, acc, "accelerance", "receptance")[:, 1:], H[:, 1:])


def test_bad_inputs_raise_one_line_errors():
    with pytest.raises(ConfigError, match="estimator 'H3'"):
        estimate_frf([np.ones(8)], [np.ones(8)], 100.0, estimator="H3")
    with pytest.raises(DimensionError, match="hit 1"):
        estimate_frf([np.ones(8), np.ones(7)], [np.ones(8), np.ones(7)], 100.0)
    with pytest.raises(DimensionError, match="responses have shape"):
        assess_hits(np.ones(10), np.ones((9, 2)), 100.0)


def test_a_pretrigger_that_leaves_no_peak_in_the_record_is_refused_in_one_line(record):
    # a pretrigger as long as the record cut each record before its peak: an IndexError in
    # pulse_width; a negative one cut the record after the peak and read its force from the far end
    f, a = record
    with pytest.raises(ConfigError) as info:
        assess_hits(f, a, FS, record_length=REC, pretrigger=REC)
    assert str(info.value) == ("assess_hits: pretrigger 8192 samples leaves nothing of the 8192-sample record "
                               "after the hit's peak")
    with pytest.raises(ConfigError, match="'pretrigger' must be an integer of at least 0, got -5"):
        assess_hits(f, a, FS, record_length=REC, pretrigger=-5)
    assert [h.trigger for h in assess_hits(f, a, FS, record_length=REC, pretrigger=REC - 1)][:8] == [REC - 1] * 8


def test_response_units_are_checked_in_one_line():
    """A text was split into letters (five outputs took 'm/s^2' as five units), a number raised a
    TypeError and a g was stored as if SI: each is refused naming estimate_frf and the value."""
    one, three = [np.ones(8)], [np.ones((8, 3))]
    expected = "a list of {} SI units, one per response (V, N, m, m/s^2, m/s, Pa)"
    for responses, units, n in ((three, 5, 3), ([np.ones((8, 5))], "m/s^2", 5), (three, ["g"] * 3, 3),
                                (three, ["m/s^2"] * 2, 3), (one, [None], 1), (one, {"a": "m"}, 1)):
        with pytest.raises(ConfigError) as info:
            estimate_frf(one, responses, 100.0, response_units=units)
        assert str(info.value) == f"estimate_frf: 'response_units' must be {expected.format(n)}, got {units!r}"
    frf = estimate_frf(one, three, 100.0, response_units=("m", "m/s", np.str_("V")))
    assert frf.units == ["m/N", "(m/s)/N", "V/N"]


@pytest.mark.parametrize("spelled", ["m/s2", "m/s**2", "m/s²", " m/s^2 "])
def test_acceleration_units_are_read_in_their_usual_spellings(spelled):
    """'m/s2' was refused (only 'm/s^2' passed); each spelling now gives the FRF and the
    straight-line trend (kept for accelerations alone) that 'm/s^2' gives."""
    t = np.arange(512) / 512.0
    force = np.where(t < 0.009, 50.0, 0.0)  # 5 samples: no line of its spectrum is 0
    acc = np.column_stack([np.exp(-4 * t) * np.sin(2 * np.pi * 30 * t) + 0.01 * t, np.zeros_like(t)])
    want = estimate_frf([force], [acc], 512.0, response_units=["m/s^2", "m"])
    frf = estimate_frf([force], [acc], 512.0, response_units=[spelled, "m"])
    assert frf.units == ["(m/s^2)/N", "m/N"]
    np.testing.assert_allclose(frf.H[0], np.fft.rfft(acc[:, 0]) / np.fft.rfft(force), rtol=1e-12)  # one hit: X/F
    np.testing.assert_array_equal(frf.H, want.H)
    assert np.abs(frf.trend[0]).max() > 0 and np.array_equal(frf.trend, want.trend)


def test_reference_simulation_agrees_with_scipy_lsim():
    from scipy import signal

    t = np.arange(4000) / 16384.0
    u = mck.hann_pulse(t, 0.01, 0.004, 100.0)
    _, ref, _ = signal.lsim(mck.state_space(), u, t)
    np.testing.assert_allclose(mck.lsim_exact(u, t[1]), ref, atol=1e-10 * np.abs(ref).max())


def test_anti_alias_ringing_is_not_a_double_hit():
    """A 0.5 ms blow through the thesis's 8th-order 1 kHz anti-aliasing low-pass rings ~30 % the
    other way and ~15 % the same way after the pulse; only a second push is a double hit."""
    import scipy.signal

    from odsuite.analysis.hammer import is_double_hit

    fs = 20000.0
    t = np.arange(4096) / fs
    blow = np.where((t >= 0.01) & (t <= 0.0105), np.sin(np.pi * (t - 0.01) / 0.0005), 0.0)
    sos = scipy.signal.butter(8, 1000.0, fs=fs, output="sos")
    ringing = scipy.signal.sosfilt(sos, blow)
    peak = int(np.argmax(ringing))
    assert not is_double_hit(ringing, peak)
    rebound = ringing + 0.5 * np.roll(ringing, 160)  # a second blow 8 ms later, half as hard
    assert is_double_hit(rebound, peak)


def _sdof_hit(fn: float, zeta: float, fs: float, n: int, drift: tuple[float, float], m: float = 47.0):
    """A body of mass m on a suspension at fn (damping ratio zeta) hit with a 4 ms, 200 N pulse:
    force (N) and acceleration (m/s^2) by scipy.signal.lsim, the accelerometer with an offset and
    a drift (m/s^2, m/s^2 per s) added; and the exact accelerance a/F = s^2 / (m s^2 + c s + k)."""
    from scipy import signal

    k = m * (2 * np.pi * fn) ** 2
    c = 2 * zeta * np.sqrt(k * m)
    t = np.arange(n) / fs
    force = mck.hann_pulse(t, 0.1, 0.004, 200.0)
    _, acc, _ = signal.lsim(signal.lti([1.0, 0.0, 0.0], [m, c, k]), force, t)

    def exact(f):
        s = 2j * np.pi * np.asarray(f)
        return s**2 / (m * s**2 + c * s + k)

    return force, acc + drift[0] + drift[1] * t, exact


def test_a_drifting_accelerometer_leaks_into_the_lowest_lines_and_its_straight_line_is_the_leak():
    """The bench rig's case: a 47 kg body on a 9.5 Hz suspension, 2 s at 2048 Hz, an accelerometer
    drifting 0.009 m/s^2 per second from 0.05 m/s^2. Single-hit H1 at 0.5 Hz is the drift's, not the
    body's; ``trend`` is that leak, and H - trend is H1 of scipy's detrended records and the
    exact accelerance from the third line up."""
    import scipy.signal

    from odsuite.analysis.frf import TREND_FREE_LINE, TREND_SHARE

    fs, n = 2048.0, 4096
    force, acc, exact = _sdof_hit(9.5, 0.05, fs, n, (0.05, 0.009))
    frf = estimate_frf([force], [acc], fs)
    f = frf.frequency
    h, ex = frf.H[0], exact(f)
    assert np.abs(h[1]) > 50 * np.abs(ex[1])  # the symptom: 0.5 Hz shows the drift
    # the trend is the drift's part: what is left is the body's (within 1 % of the low lines' |H|)
    _, clean, _ = _sdof_hit(9.5, 0.05, fs, n, (0.0, 0.0))
    h_clean = estimate_frf([force], [clean], fs).H[0]
    assert np.abs(h - frf.trend[0] - h_clean)[1:20].max() < 0.01 * np.abs(h[1:20]).max()
    detrended = frf.detrended()
    ref = estimate_frf([force], [scipy.signal.detrend(acc)], fs)
    np.testing.assert_allclose(detrended.H, ref.H, rtol=1e-9, atol=1e-12 * np.abs(ref.H).max())
    # from 3 cycles per record to 100 Hz: within 5 % of the drift-free record's H1 (4.6 % at 1.5 Hz,
    # where |H| is 5e-4 (m/s^2)/N), and within 15 % of the exact accelerance, as the drift-free
    # record is (its ringing cut at the record end); with the drift it was 8.8 times off
    lines = slice(TREND_FREE_LINE, int(100 * n / fs))
    assert (np.abs(detrended.H[0, lines] / h_clean[lines] - 1)).max() < 0.05
    assert (np.abs(detrended.H[0, lines] / ex[lines] - 1)).max() < 0.15
    assert (np.abs(h[lines] / ex[lines] - 1)).max() > 5
    # without removing it, the drift leaks more than a third of |H| up to the suspension's region
    lowest = frf.determined_from()
    assert 3.0 < lowest < 9.5
    above = f >= lowest
    assert (np.abs(frf.trend[0, above][:3]) <= TREND_SHARE * np.abs(h[above][:3])).all()


def test_a_real_low_suspension_mode_stays_after_the_straight_line_is_removed():
    """A 2 Hz suspension mode (3 % damping) over a 16 s record with the same drift: H - trend keeps
    the resonance at its exact height, and it lies above the lowest line drawn."""
    from odsuite.analysis.frf import TREND_FREE_LINE

    fs, n = 256.0, 4096
    force, acc, exact = _sdof_hit(2.0, 0.03, fs, n, (0.05, 0.009))
    frf = estimate_frf([force], [acc], fs).detrended()
    f = frf.frequency
    peak = int(np.argmax(np.abs(frf.H[0, 1 : int(10 * n / fs)]))) + 1
    assert abs(f[peak] - 2.0) <= fs / n
    assert np.abs(frf.H[0, peak]) == pytest.approx(np.abs(exact(f[peak])), rel=0.03)
    assert f[TREND_FREE_LINE] < 0.2 < 2.0


def test_the_responding_channels_keep_their_own_trend():
    """A record that leaves one channel empty (H = 0 there): the FRFs of the channels that respond
    keep each channel's own straight-line trend, so their detrended H1 is that of the records with
    scipy.signal.detrend applied (a drifting accelerometer on either side of the empty channel)."""
    import scipy.signal

    from odsuite.analysis.stored_modes import responding

    fs, n = 1024.0, 2048
    t = np.arange(n) / fs
    rng = np.random.default_rng(3)
    force = np.where(t < 0.004, 100.0, 0.0)
    live = np.exp(-3 * t) * np.sin(2 * np.pi * 40 * t)
    records = np.column_stack([live + 0.02 + 0.01 * t, np.zeros(n), 2 * live - 0.03 * t])
    records[:, [0, 2]] += 1e-4 * rng.standard_normal((n, 2))
    frf = estimate_frf([force], [records], fs, output_names=["a", "empty", "b"])
    kept = responding(frf)
    assert kept.output_names == ["a", "b"]
    want = estimate_frf([force], [scipy.signal.detrend(records[:, [0, 2]], axis=0)], fs).H
    np.testing.assert_allclose(kept.detrended().H, want, rtol=1e-9, atol=1e-12 * np.abs(want).max())


def test_a_given_length_the_last_hit_misses_by_a_few_samples_starts_earlier():
    """Records made equal across experiments: a length one sample shorter than the hit's own default
    (from 40 samples before the peak to the data's end) makes its 1 % pretrigger 36, which would end
    the record 3 samples past the data; the record starts 1 sample later than the default instead,
    and its FRF is the exact one. A pretrigger the caller chose is kept, and the record refused."""
    f, a = mck.simulate(FS, 4.0, [(0.5, 0.004, 100.0)])
    n = f.size
    peak = int(np.argmax(f))
    default = assess_hits(f, a, FS)[0]
    assert default.accepted and (default.start, default.stop) == (peak - 40, n)
    hit = assess_hits(f, a, FS, record_length=default.stop - default.start - 1)[0]
    assert hit.accepted and (hit.start, hit.stop) == (peak - 39, n)
    frf = estimate_frf([f[hit.start:hit.stop]], [a[hit.start:hit.stop]], FS)
    exact = mck.accelerance(frf.frequency)
    band = (frf.frequency > 5) & (frf.frequency < 200)
    big = band[None, :] & (np.abs(exact) > 0.01 * np.abs(exact).max(axis=1, keepdims=True))
    with np.errstate(divide="ignore", invalid="ignore"):
        assert (np.abs(frf.H - exact) / np.abs(exact))[big].max() < 1e-2
    kept = assess_hits(f, a, FS, record_length=default.stop - default.start - 1, pretrigger=36)[0]
    assert not kept.accepted and "runs past the data" in kept.reasons[0]


def _exact_within(frf, tolerance):
    """|H - exact| / |exact| below ``tolerance`` on 5-200 Hz where |exact| > 1 % of its peak."""
    exact = mck.accelerance(frf.frequency)
    band = (frf.frequency > 5) & (frf.frequency < 200)
    big = band[None, :] & (np.abs(exact) > 0.01 * np.abs(exact).max(axis=1, keepdims=True))
    with np.errstate(divide="ignore", invalid="ignore"):
        return (np.abs(frf.H - exact) / np.abs(exact))[big].max() < tolerance


def test_a_hit_whose_blow_the_data_end_cuts_is_left_out_and_the_records_keep_their_length():
    """Two blows 8 s apart and a third whose peak lies on the data's last samples: its record set
    the length of all three (its pretrigger and a sample or two), 0.08 s records with lines 13 Hz
    apart and no note. It is left out, and the others keep the 8 s their spacing allows."""
    f, a = mck.simulate(FS, 16.5, [(0.5, 0.004, 100.0), (8.5, 0.004, 80.0), (16.5 - 0.003, 0.004, 90.0)])
    hits = assess_hits(f, a, FS)
    assert [h.accepted for h in hits] == [True, True, False] and hits[2].left_out
    assert hits[2].peak_index >= f.size - 2
    spacing = hits[2].peak_index - hits[1].peak_index  # a hair under 8 s: the closer pair
    assert all(h.stop - h.start == spacing for h in hits[:2]) and spacing > 7.99 * FS
    assert hits[2].data_end.startswith(f"hit at {hits[2].peak_index / FS:.4g} s: left out: ")
    assert not hits[0].data_end and not hits[1].data_end
    frf = estimate_frf([f[h.start:h.stop] for h in hits[:2]], [a[h.start:h.stop] for h in hits[:2]], FS)
    assert frf.n_averages == 2 and _exact_within(frf, 1e-2)


def test_a_last_hit_the_data_end_soon_after_cuts_every_record_short_and_says_so():
    """Blows at 0.5, 8.5 and 14.5 s of 19 s: the last one's data reach 4.5 s, over half the 6 s its
    spacing allows, so every record is cut to that (and its pretrigger) and the note gives the
    lines' spacing."""
    f, a = mck.simulate(FS, 19.0, [(0.5, 0.004, 100.0), (8.5, 0.004, 80.0), (14.5, 0.004, 90.0)])
    hits = assess_hits(f, a, FS)
    assert all(h.accepted and not h.left_out for h in hits) and hits[-1].stop == f.size
    length = hits[-1].stop - hits[-1].start
    assert all(h.stop - h.start == length for h in hits) and length == f.size - hits[-1].peak_index + hits[-1].trigger
    assert hits[-1].data_end == (f"hit at {hits[-1].peak_index / FS:.4g} s: every hit's record cut short to "
                                 f"{length / FS:.4g} s by the data's end after it (FRF lines {FS / length:.4g} Hz "
                                 f"apart, not {FS / (hits[2].peak_index - hits[1].peak_index):.4g} Hz)")
    assert not hits[0].data_end and not hits[1].data_end


def test_a_single_hit_on_the_last_sample_is_left_out_and_one_near_it_cut_short():
    f, a = mck.simulate(FS, 4.0, [(4.0 - 0.002, 0.004, 100.0)])  # its peak falls 1 ms after the last sample
    (hit,) = assess_hits(f, a, FS)
    assert hit.left_out and not hit.accepted and hit.peak_index == f.size - 1
    assert hit.reasons == ("left out: its peak is the data's last sample (its blow is cut)",)
    assert hit.data_end == f"hit at {(f.size - 1) / FS:.4g} s: {hit.reasons[0]}"
    f, a = mck.simulate(FS, 4.0, [(4.0 - 0.01, 0.004, 100.0)])  # 8 ms of ringing after the blow
    (hit,) = assess_hits(f, a, FS)
    length = hit.stop - hit.start
    assert hit.accepted and not hit.left_out and hit.stop == f.size and length < f.size // 64
    assert hit.data_end == (f"hit at {hit.peak_index / FS:.4g} s: its record cut short to {length / FS:.4g} s by "
                            f"the data's end (FRF lines {FS / length:.4g} Hz apart)")


def test_leakage_is_a_tail_above_the_noise():
    """A blow 0.5 s into a record, its responses' noise 3 % of their peaks: over 8 s they decay into
    the noise, which the 1 % rule alone took for ringing at the record's end, as it took a sensor's
    drift; cut at 0.8 s they still ring at 10-23 % of their peaks (12-20 % without the noise), and
    are noted, drifting or not."""
    for seconds, ringing in ((8.0, []), (0.8, [0, 1, 2])):
        f, a = mck.simulate(FS, seconds, [(0.5, 0.004, 100.0)])
        (clean,) = assess_hits(f, a, FS)
        assert [c for c, _ in clean.undecayed] == ringing
        for seed in range(5):
            noisy = a + 0.03 * np.abs(a).max(axis=0) * np.random.default_rng(seed).standard_normal(a.shape)
            (hit,) = assess_hits(f, noisy, FS)
            assert [c for c, _ in hit.undecayed] == ringing, (seconds, seed, hit.undecayed)
            assert all(0.10 < ratio < 0.24 for _, ratio in hit.undecayed)
            assert len(hit.notes) == len(ringing)  # one per channel, as before
            # a drift to 20 % of the peaks by the record's end
            drift = np.linspace(0.0, 0.2, f.size)[:, None] * np.abs(a).max(axis=0)
            (hit,) = assess_hits(f, noisy + drift, FS)
            assert [c for c, _ in hit.undecayed] == ringing, (seconds, seed, hit.undecayed)
