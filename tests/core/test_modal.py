"""Modal identification (LSCF + LSFD) on real impact data with published results and on a 3-DOF
system with exact modes; MAC, pairing tables and ODS."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.io import loadmat

import mck_threedof as mck
from odsuite.domain.errors import ConfigError, DimensionError
from odsuite.analysis.frf import MAX_RANDOM_ERROR, convert_form, estimate_frf, usable_band
from odsuite.analysis.hammer import assess_hits, exponential_window
from odsuite_plugins.importers.lvm import read_lvm
from odsuite.analysis.modal import (
    MIN_PROMINENCE,
    check_poles,
    identify_modes,
    lscf,
    mac,
    ods,
    pair_modes,
    select_poles,
)

G = 9.81  # the tutorial's g -> m/s^2 factor
# LADISK tutorial, pyEMA LSCF on the H1 receptance, < 4000 Hz (README "Reference results")
LADISK_F = np.array([695.0, 1897.6, 2777.3, 3671.2])
LADISK_ZETA = np.array([0.0047, 0.0031, 0.0024, 0.0020])


def _ladisk_frf(path, accept=True):
    d = read_lvm(path)
    acc = d.channel("Acceleration (Trigger)") * G
    force = d.channel("Force (Trigger)")
    hits = assess_hits(force, acc, d.sampling_rate)
    assert len(hits) == 1 and hits[0].accepted == accept, hits
    assert hits[0].notes == ()  # decayed within the record: no window needed
    # the tutorial drops the last 30 samples: 50 000 samples, 1 Hz lines
    rec = slice(0, 50000)
    return estimate_frf([force[rec]], [acc[rec]], d.sampling_rate, force_unit="N"), hits[0]


@pytest.mark.parametrize("form", ["accelerance", "receptance"])
def test_ladisk_beam_published_modes(real_data, form):
    frf, _ = _ladisk_frf(real_data / "ladisk_beam_impact" / "acceleration.lvm")
    assert frf.frequency[1] == pytest.approx(1.0)
    H = convert_form(frf.frequency, frf.H, "accelerance", form)
    res = identify_modes(frf.frequency, H, f_band=(1.0, 4000.0), max_order=50, form=form)
    assert res.poles.size == 4
    np.testing.assert_allclose(res.frequency_hz, LADISK_F, rtol=0.005)
    np.testing.assert_allclose(res.damping_ratio, LADISK_ZETA, rtol=0.25)
    assert res.residues.shape == (1, 4)


def test_ladisk_second_hit_agrees(real_data):
    """camera.lvm is a harder hit (422 N) on the same beam: its accelerometer saturates at
    +-54.7 g (the same extreme value held over several samples), so the hit is rejected; the
    bending-mode frequencies still agree, damping only roughly; the weak 2777 Hz mode is lost."""
    frf, hit = _ladisk_frf(real_data / "ladisk_beam_impact" / "camera.lvm", accept=False)
    assert hit.reasons == ("response channel 0 clipped/overloaded",)
    res = identify_modes(frf.frequency, frf.H, force_autospectrum=frf.force_autospectrum)
    assert 4000 < res.band_hz[1] < 6000
    rows = pair_modes(LADISK_F, LADISK_ZETA, res.frequency_hz, res.damping_ratio)
    assert [(r["mode_a"], r["mode_b"]) for r in rows] == [(0, 0), (1, 1), (3, 2)]
    assert max(abs(r["frequency_difference"]) for r in rows) < 0.005
    assert max(abs(r["damping_difference"]) for r in rows) < 0.3


def test_ladisk_default_band_finds_the_published_modes(real_data):
    """The band from the hammer's spectrum (10 dB drop: about 4.9 kHz for this 0.2 ms blow) and
    automatic, checked pole selection: the four published modes (f within 0.5 %, damping within
    10 %), stable over many orders, and nothing at the 1.1-1.2 kHz anti-resonance."""
    frf, _ = _ladisk_frf(real_data / "ladisk_beam_impact" / "acceleration.lvm")
    res = identify_modes(frf.frequency, frf.H, force_autospectrum=frf.force_autospectrum)
    assert res.band_hz[0] == pytest.approx(1.0) and 4500 < res.band_hz[1] < 5500
    np.testing.assert_allclose(res.frequency_hz, LADISK_F, rtol=0.005)
    np.testing.assert_allclose(res.damping_ratio, LADISK_ZETA, rtol=0.10)
    assert not ((res.frequency_hz > 1000) & (res.frequency_hz < 1500)).any()
    # stable in at least 30 % of the 49 orders (select_poles' rule), the bending modes in most
    assert (res.stable_orders >= 15).all() and (res.stable_orders[[0, 1, 3]] >= 30).all()
    doc = res.to_dict()
    assert doc["band_hz"] == [pytest.approx(res.band_hz[0]), pytest.approx(res.band_hz[1])]
    assert [m["stable_orders"] for m in doc["modes"]] == list(res.stable_orders)


def test_ladisk_anti_resonance_pole_is_rejected(real_data):
    """On 50-2000 Hz the LSCF diagram holds a stable pole at 1202 Hz where |H| is 0.06 against
    34-76 at the peaks (the FRF rises away from it): it is named, not reported."""
    frf, _ = _ladisk_frf(real_data / "ladisk_beam_impact" / "acceleration.lvm")
    band = frf.band(50.0, 2000.0)
    diag = lscf(band.frequency, band.H, 50)
    poles, _ = select_poles(diag)
    assert np.any(np.abs(np.abs(poles) / (2 * np.pi) - 1202.0) < 5.0)  # the diagram alone keeps it
    res = identify_modes(frf.frequency, frf.H, f_band=(50.0, 2000.0))
    np.testing.assert_allclose(res.frequency_hz, LADISK_F[:2], rtol=0.005)
    assert len(res.rejected) == 1
    assert re.match(r"120[12]\.\d\d Hz: \|H\| there is 0\.3\d x its level", res.rejected[0])


def test_user_can_pick_poles_by_frequency(real_data):
    frf, _ = _ladisk_frf(real_data / "ladisk_beam_impact" / "acceleration.lvm")
    res = identify_modes(frf.frequency, frf.H, f_band=(1.0, 4000.0), frequencies=[3671.0, 695.0])
    np.testing.assert_allclose(res.frequency_hz, LADISK_F[[0, 3]], rtol=0.005)
    with pytest.raises(ConfigError, match="no stable pole within 2 % of 4500.0 Hz"):
        identify_modes(frf.frequency, frf.H, f_band=(1.0, 4000.0), frequencies=[4500.0])


def test_vibration_toolbox_case1_published_frequency(real_data):
    # vibration_toolbox doctest: sdof_cf on case1 lines 500..1000 -> 212.0925 Hz
    d = loadmat(real_data / "vibration_toolbox_frf" / "case1.mat")
    f, H = d["Freq_domain"].ravel(), d["Hf_chan_2"].ravel()
    res = identify_modes(f, H, f_band=(f[500], f[1000]), max_order=30, frequencies=[212.0])
    assert res.frequency_hz[0] == pytest.approx(212.0925, abs=0.3)


def test_vibration_toolbox_case1_default_band(real_data):
    """The analyser's force autospectrum sets the band (10 dB down at about 300 Hz); automatic
    selection finds the published 212.09 Hz mode (and the 34 Hz peak below it)."""
    d = loadmat(real_data / "vibration_toolbox_frf" / "case1.mat")
    f, H = d["Freq_domain"].ravel(), d["Hf_chan_2"].ravel()
    res = identify_modes(f, H, force_autospectrum=d["PSD_chan_1"].ravel())
    assert 280 < res.band_hz[1] < 320
    near = res.frequency_hz[np.argmin(np.abs(res.frequency_hz - 212.0))]
    assert near == pytest.approx(212.0925, abs=0.3)
    assert not ((res.frequency_hz > 40) & (res.frequency_hz < 200)).any()


def _half_sine_edge(T: float) -> float:
    """Where the spectrum of a half-sine of duration T is 10 dB below its level at 0 Hz, from
    |F(f)| = (2T/pi) |cos(pi f T)| / |1 - (2 f T)^2| (closed form), below its first zero."""
    import scipy.optimize

    def level_db(fr):
        x = 2 * fr * T
        return 20 * np.log10(abs(np.cos(np.pi * fr * T)) / abs(1 - x * x)) if x != 1 else 20 * np.log10(np.pi / 4)

    return scipy.optimize.brentq(lambda fr: level_db(fr) + 10.0, 1.0, 1.5 / T * 0.999)


def test_usable_band_from_a_half_sine_force():
    """The band ends where the force spectrum is 10 dB below its low-frequency level (closed form,
    ``_half_sine_edge``)."""
    fs, n, T = 10_000.0, 10_000, 2e-3
    t = np.arange(n) / fs
    force = np.where(t < T, np.sin(np.pi * t / T), 0.0)
    gff = np.abs(np.fft.rfft(force)) ** 2
    freq = np.fft.rfftfreq(n, 1 / fs)
    edge = _half_sine_edge(T)
    lo, hi = usable_band(freq, gff)
    assert lo == freq[1]
    assert hi == pytest.approx(edge, abs=2 * (freq[1] + 0.01 * freq[-1]))  # the 1 % smoothing
    assert 505 < edge < 515  # 1.02/T for a half-sine of duration T


@pytest.mark.parametrize(("fs", "T"), [(1e6, 5e-3), (1e6, 2e-3), (1e5, 5e-3), (2e4, 5e-3)])
def test_usable_band_of_a_broad_blow_at_a_high_rate(fs, T):
    """A soft tip's 2-5 ms blow in a 65536-sample record: its spectrum falls 10 dB within the
    lowest 5 % of the lines (at 204 Hz for 5 ms; 5 % of the lines reach 25 kHz at 1 MHz), and the
    level over them and the 1 % smoothing were the noise floor's: the 5 ms blow's band ran to
    67.7 kHz at 1 MHz, 2.26 kHz at 100 kHz and 443 Hz at 20 kHz."""
    n = 65536
    t = np.arange(n) / fs - 0.01
    force = 20.0 * np.where((t >= 0) & (t <= T), np.sin(np.pi * np.clip(t, 0, T) / T), 0.0)
    force += 0.02 * np.random.default_rng(7).standard_normal(n)  # 0.1 % of the peak
    (hit,) = assess_hits(force, np.zeros(n), fs, decay_limit=None)
    frf = estimate_frf([force[hit.start : hit.stop]], [np.zeros(hit.stop - hit.start)], fs)
    lo, hi = usable_band(frf.frequency, frf.force_autospectrum)
    assert lo == frf.frequency[1]
    # within 2 lines, or 3 %: the level is the median over the band's lower half, where a
    # half-sine's spectrum falls by up to 2 dB (the edge then lies some 2 % late)
    edge = _half_sine_edge(T)
    assert hi == pytest.approx(edge, abs=max(2 * frf.frequency[1], 0.03 * edge))


def test_usable_band_from_coherence():
    """Lines count where the random error of |H1| from coherence over n averages,
    sqrt(1 - coh) / (sqrt(coh) sqrt(2 n)), is at most 10 %: coh >= 0.909 for 5 averages."""
    freq = np.linspace(0, 500, 1001)
    coh = np.where((freq >= 50) & (freq <= 300), 0.92, 0.88)
    assert usable_band(freq, coherence=coh, n_averages=5) == (50.0, 300.0)
    # a single hit's coherence is 1 by construction: it narrows nothing
    assert usable_band(freq, coherence=coh, n_averages=1) == (0.5, 500.0)
    eps = np.sqrt(1 - 0.909) / (np.sqrt(0.909) * np.sqrt(10))
    assert eps == pytest.approx(MAX_RANDOM_ERROR, rel=1e-2)
    with pytest.raises(ConfigError, match="no usable band"):
        usable_band(freq, coherence=np.full(freq.size, 0.5), n_averages=5)


def test_pole_at_an_anti_resonance_fails_the_synthesis_check():
    """Exact 3-DOF accelerances; the true poles plus one placed at the first anti-resonance of
    output 0 (52.7 Hz): the true ones explain their peaks, the extra one has no peak under it."""
    lam, _ = mck.modes()
    f = np.linspace(5.0, 200.0, 4000)
    H = mck.accelerance(f)
    fake = -0.01 * 2 * np.pi * 52.70 + 2j * np.pi * 52.70
    poles = np.append(lam, fake)
    dominance, error, prominence = check_poles(f, H, poles)
    assert (dominance[:3] > 0.9).all() and (error[:3] < 1e-6).all() and (prominence[:3] > 3).all()
    assert prominence[3] < MIN_PROMINENCE


@pytest.fixture(scope="module")
def threedof_frf():
    amps = [100.0, 70.0, 130.0, 90.0]
    f, a = mck.simulate(1024.0, 8 * len(amps) + 0.1, [(0.1 + 8 * k, 0.004, v) for k, v in enumerate(amps)])
    rng = np.random.default_rng(0)
    a = a + 1e-5 * np.abs(a).max(axis=0) * rng.standard_normal(a.shape)
    f = f + 1e-5 * f.max() * rng.standard_normal(f.shape)
    hits = [h for h in assess_hits(f, a, 1024.0, record_length=8192, pretrigger=50) if h.accepted]
    return estimate_frf([f[h.start : h.stop] for h in hits], [a[h.start : h.stop] for h in hits], 1024.0)


def test_threedof_modes_and_shapes(threedof_frf):
    lam, phi = mck.modes()
    res = identify_modes(threedof_frf.frequency, threedof_frf.H, f_band=(5.0, 200.0), max_order=30)
    assert res.poles.size == 3 and res.rejected == []
    np.testing.assert_allclose(res.frequency_hz, np.abs(lam) / (2 * np.pi), rtol=1e-4)
    np.testing.assert_allclose(res.damping_ratio, -lam.real / np.abs(lam), rtol=0.01)
    m = mac(res.shapes, phi)
    assert np.diag(m).min() > 0.99
    assert (m - np.diag(np.diag(m))).max() < 0.5
    # identified vs true table: paired by MAC, differences tiny
    rows = pair_modes(res.frequency_hz, res.damping_ratio, np.abs(lam) / (2 * np.pi),
                      -lam.real / np.abs(lam), shapes_a=res.shapes, shapes_b=phi)
    assert [(r["mode_a"], r["mode_b"]) for r in rows] == [(0, 0), (1, 1), (2, 2)]
    assert all(abs(r["frequency_difference"]) < 1e-4 and r["mac"] > 0.99 for r in rows)
    # shapes are normalised to a largest entry of 1
    np.testing.assert_allclose(np.abs(res.shapes).max(axis=0), 1.0)
    doc = res.to_dict()
    assert [m["frequency_hz"] for m in doc["modes"]] == pytest.approx(list(res.frequency_hz))


def test_exponential_window_damping_is_corrected():
    """1 s records (response not decayed): the exponential window plus its correction returns the
    true damping; without the correction damping is far too high."""
    lam = mck.modes()[0]
    f, a = mck.simulate(1024.0, 1.0, [(0.02, 0.004, 100.0)])
    w, tau = exponential_window(f.size, 1024.0, trigger=20, end_value=1e-3)
    frf = estimate_frf([f], [a], 1024.0, window=w)
    raw = identify_modes(frf.frequency, frf.H, f_band=(5.0, 200.0), max_order=30)
    fixed = identify_modes(frf.frequency, frf.H, f_band=(5.0, 200.0), max_order=30, window_tau=tau)
    true_zeta = -lam.real / np.abs(lam)
    np.testing.assert_allclose(fixed.damping_ratio, true_zeta, rtol=1e-3)
    np.testing.assert_allclose(fixed.frequency_hz, np.abs(lam) / (2 * np.pi), rtol=1e-5)
    assert (raw.damping_ratio > 1.5 * true_zeta).all()


def test_stabilisation_diagram_flags(threedof_frf):
    band = threedof_frf.band(5.0, 200.0)
    diag = lscf(band.frequency, band.H, 20)
    assert diag.orders == list(range(2, 21))
    assert not diag.stable[0].any()  # nothing to compare the first order with
    # from order 8 on, the three true modes are stable at every order
    true_f = np.abs(mck.modes()[0]) / (2 * np.pi)
    for poles, st in zip(diag.poles[6:], diag.stable[6:]):
        fs = np.abs(poles[st]) / (2 * np.pi)
        for fr in true_f:
            assert np.min(np.abs(fs - fr)) < 1e-3 * fr
    poles, stable_orders = select_poles(diag)
    assert poles.size == 3
    # stable from order 8 on: orders 8..20 at least (13 of the 19)
    assert (stable_orders >= 13).all() and (stable_orders <= 18).all()


def test_ods_is_the_frf_times_force(threedof_frf):
    f0 = 50.0  # between modes 1 and 2
    shape = ods(threedof_frf.frequency, threedof_frf.H, f0, force_amplitude=10.0)
    exact = 10.0 * mck.accelerance(np.array([f0]))[:, 0]
    np.testing.assert_allclose(shape, exact, rtol=2e-3)


def test_mac_properties():
    rng = np.random.default_rng(5)
    a = rng.standard_normal((6, 3)) + 1j * rng.standard_normal((6, 3))
    m = mac(a, a * (2 - 3j))  # MAC ignores complex scaling
    np.testing.assert_allclose(np.diag(m), 1.0)
    assert np.all((m >= 0) & (m <= 1 + 1e-12))
    np.testing.assert_allclose(mac(np.array([1.0, 0, 0]), np.array([0, 1.0, 0])), [[0.0]])
    # against the textbook formula computed term by term
    x, y = a[:, 0], a[:, 1]
    ref = abs(np.vdot(x, y)) ** 2 / (np.vdot(x, x).real * np.vdot(y, y).real)
    assert m[0, 1] == pytest.approx(ref)
    with pytest.raises(DimensionError, match="6 and 5 entries"):
        mac(a, a[:5])


def test_pairing_by_frequency_without_shapes():
    rows = pair_modes([10.0, 20.0, 30.0], [0.01, 0.02, 0.03], [31.0, 9.5], [0.03, 0.012])
    assert [(r["mode_a"], r["mode_b"]) for r in rows] == [(0, 1), (2, 0)]
    assert rows[0]["frequency_difference"] == pytest.approx(-0.05)
    assert rows[0]["damping_difference"] == pytest.approx(0.2)
    assert rows[1]["mac"] is None


def test_lscf_normal_matrices_equal_the_direct_products():
    """The Toeplitz form of LSCF's normal matrices against X^H diag(w) X written out."""
    from odsuite.analysis.modal import normal_matrices

    rng = np.random.default_rng(3)
    f = np.sort(rng.uniform(10.0, 400.0, 300))
    X = np.exp(1j * 2 * np.pi * f[:, None] / (2 * f[-1]) * np.arange(25)[None, :])
    H = rng.standard_normal((4, f.size)) + 1j * rng.standard_normal((4, f.size))
    R, S, T = normal_matrices(X, H)
    assert R == pytest.approx((X.conj().T @ X).real, abs=1e-9)
    for s, h in zip(S, H):
        assert s == pytest.approx(-(X.conj().T @ (h[:, None] * X)).real, abs=1e-9)
    assert T == pytest.approx(sum((X.conj().T @ ((np.abs(h) ** 2)[:, None] * X)).real for h in H), abs=1e-9)


def test_a_band_without_modes_is_named_in_readable_hertz():
    """The band of a refusal reads as an engineer writes it (it printed 1.31993..1878.26 Hz)."""
    f = np.linspace(0, 1000.0, 2001)
    rng = np.random.default_rng(0)
    noise = rng.normal(size=(3, f.size)) + 1j * rng.normal(size=(3, f.size))
    with pytest.raises(ConfigError, match=r"^no stable poles found in 1\.235-876\.5 Hz up to model order 20$"):
        identify_modes(f, noise, f_band=(1.23456, 876.54321), max_order=20)
    with pytest.raises(ConfigError, match=r"^band 1\.235-5\.432 Hz holds 8 lines; model order 20 needs more$"):
        identify_modes(f, noise, f_band=(1.23456, 5.4321), max_order=20)


def test_a_record_whose_stable_poles_all_fail_their_checks_says_so(monkeypatch):
    """Stable poles found and every one rejected is not "no stable poles found" (the demo's T2
    read as if its record held nothing): the line names the rejected poles and the line spacing."""
    import odsuite.analysis.modal as modal

    f = np.linspace(0.0, 1000.0, 2001)
    w = 2 * np.pi * f
    h = -(w**2) / (8e5 - 2.0 * w**2 + 2j * 0.02 * np.sqrt(8e5 * 2.0) * w)
    assert len(identify_modes(f, h[None, :], f_band=(20.0, 600.0), max_order=20).frequency_hz) == 1
    monkeypatch.setattr(modal, "MAX_SYNTHESIS_ERROR", 1e-12)  # no fit is that good: every pole fails
    with pytest.raises(ConfigError, match=r"^no mode passed its checks in 20-600 Hz \(lines 0\.5 Hz apart: .*\); "
                                          r"stable poles rejected: 100\.[0-9]{2} Hz: synthesis misfit"):
        identify_modes(f, h[None, :], f_band=(20.0, 600.0), max_order=20)


def test_pairing_by_shape_keeps_within_the_frequency_window():
    # measured 154.3 Hz is the model's 154.9 Hz mode; a model mode at 210 Hz alike in shape (MAC
    # 0.99 against 0.95) took it, and the table showed "-" beside a model mode 0.4 % away
    shapes_a = np.array([[1.0], [0.0], [0.3]])
    shapes_b = np.array([[1.0, 1.0], [0.3, 0.05], [0.3, 0.3]])
    loose = pair_modes([154.3], [0.01], [154.9, 210.0], [0.01, 0.01], shapes_a=shapes_a, shapes_b=shapes_b)
    assert [r["mode_b"] for r in loose] == [1]
    rows = pair_modes([154.3], [0.01], [154.9, 210.0], [0.01, 0.01], shapes_a=shapes_a, shapes_b=shapes_b,
                      within=0.10)
    assert [r["mode_b"] for r in rows] == [0] and rows[0]["frequency_b_hz"] == 154.9
    assert pair_modes([154.3], [0.01], [210.0], [0.01], within=0.10) == []
