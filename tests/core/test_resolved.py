"""The resolved residual (odsuite.analysis.resolved) on white noise whose spectrum is known in
closed form: the chi-square limits hold their false-alarm rate, a sinusoid in one band of one
channel is found there while the pooled error hides it, and the gain statistic of removing it is
its whitened excess."""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.stats

from odsuite.analysis import resolved
from odsuite.analysis.noise_floor import NoiseFloor, band_dof, band_edges, in_band

FS, N, CHANNELS, EXPERIMENTS = 2048.0, 2048, 4, 3


@dataclass
class _Exp:
    name: str
    measured: np.ndarray
    fs: float = FS

    @property
    def n_samples(self) -> int:
        return self.measured.shape[0]

    @property
    def sensors(self):
        return [SimpleNamespace(name=f"c{j}") for j in range(self.measured.shape[1])]


def _white_floor(sigma: np.ndarray) -> NoiseFloor:
    """The floor of white noise of standard deviation ``sigma`` per channel: its expected energy per
    FFT line is sigma^2 at 0 and Nyquist and 2 sigma^2 between (Parseval)."""
    lines = np.full((N // 2 + 1, CHANNELS), 2.0) * sigma**2
    lines[0] = lines[-1] = sigma**2
    edges = band_edges(FS, N)
    masks = in_band(FS, N, edges)
    energy = np.array([lines[m].sum(axis=0) for m in masks])
    bands = {f"e{i}": (edges, energy, band_dof(lines, masks)) for i in range(EXPERIMENTS)}
    total = {f"e{i}": {f"c{j}": N * float(sigma[j] ** 2) for j in range(CHANNELS)} for i in range(EXPERIMENTS)}
    return NoiseFloor(total, total, bands=bands)


SIGMA = np.array([1.0, 0.1, 0.1, 3.0])


def _null(rng):
    return [_Exp(f"e{i}", rng.standard_normal((N, CHANNELS)) * SIGMA) for i in range(EXPERIMENTS)]


def test_flat_noise_has_two_degrees_of_freedom_per_line():
    floor = _white_floor(SIGMA)
    edges, _, dof = floor.bands["e0"]
    lines_per_band = np.array([m.sum() for m in in_band(FS, N, edges)])
    assert np.allclose(dof[:, 0], 2 * lines_per_band, rtol=0.02)


def test_the_chi_square_limits_hold_their_false_alarm_rate(monkeypatch):
    # without the calibration tolerance the limits are chi-square quantiles at DETECTION_FALSE_ALARM
    # shared over the cells: white noise at its exact floor crosses them at about that rate
    monkeypatch.setattr(resolved, "DETECTION_TOLERANCE", 1.0)
    rng = np.random.default_rng(1)
    floor = _white_floor(SIGMA)
    zeros = [np.zeros((N, CHANNELS))] * EXPERIMENTS
    draws = 600
    alarms = sum(resolved.resolve(exps, zeros, floor).detected() for exps in (_null(rng) for _ in range(draws)))
    lo, hi = scipy.stats.binom.ppf([0.001, 0.999], draws, resolved.DETECTION_FALSE_ALARM)
    assert lo <= alarms <= hi


@pytest.mark.parametrize("lines", [4, 16])
def test_a_floor_measured_on_few_lines_keeps_the_false_alarm_rate(monkeypatch, lines):
    # the floor's density in each band estimated from ``lines`` lines of noise (two degrees of
    # freedom each), one estimate per band shared by every channel and record, as the samples
    # before the hits give it; white noise at the true floor against that estimate crosses the
    # limits at no more than DETECTION_FALSE_ALARM (binomial bound at 0.999), where a limit that
    # took the estimate as exact crossed them in 98 % of 1000 draws at 4 lines (0.1 % with it)
    monkeypatch.setattr(resolved, "DETECTION_TOLERANCE", 1.0)
    rng = np.random.default_rng(4)
    zeros = [np.zeros((N, CHANNELS))] * EXPERIMENTS
    true = _white_floor(SIGMA)
    n_bands = len(true.bands["e0"][0])
    draws = 600

    def alarms(witnessed: bool) -> int:
        count = 0
        for _ in range(draws):
            estimate = rng.chisquare(2 * lines, n_bands) / (2 * lines)
            floor = _white_floor(SIGMA)
            floor.bands = {k: (edges, energy * estimate[:, None], dof)
                           for k, (edges, energy, dof) in true.bands.items()}
            if witnessed:  # the whole floor is the colour those lines measure
                floor.witness_lines = {k: np.full(n_bands, lines) for k in true.bands}
                floor.coloured = {k: energy for k, (_, energy, _) in floor.bands.items()}
            count += resolved.resolve(_null(rng), zeros, floor).detected()
        return count

    hi = scipy.stats.binom.ppf(0.999, draws, resolved.DETECTION_FALSE_ALARM)
    assert alarms(True) <= hi
    if lines == 4:
        assert alarms(False) > 0.2 * draws


def test_a_floor_without_colour_keeps_its_limits():
    # the white level is measured on every sample before the hits: where the floor has no colour,
    # few lines in a band do not raise its limits (a weak softer mount shows there)
    floor = _white_floor(SIGMA)
    exps = _null(np.random.default_rng(6))
    zeros = [np.zeros((N, CHANNELS))] * EXPERIMENTS
    plain = resolved.resolve(exps, zeros, floor)
    n_bands = len(floor.bands["e0"][0])
    floor.witness_lines = {k: np.full(n_bands, 4) for k in floor.bands}
    floor.coloured = {k: np.zeros_like(energy) for k, (_, energy, _) in floor.bands.items()}
    assert all(np.array_equal(a, b) for a, b in zip(plain.limit, resolved.resolve(exps, zeros, floor).limit))
    # all of it coloured: every limit higher
    floor.coloured = {k: energy for k, (_, energy, _) in floor.bands.items()}
    assert all(np.all(b > a) for a, b in zip(plain.limit, resolved.resolve(exps, zeros, floor).limit))


def test_a_model_error_in_one_band_is_found_there_however_quiet_the_rest():
    rng = np.random.default_rng(2)
    exps = _null(rng)
    floor = _white_floor(SIGMA)
    t = np.arange(N) / FS
    edges = band_edges(FS, N)
    band = next(i for i, (lo, hi) in enumerate(edges) if lo <= 20.0 < hi)
    # a 20 Hz misfit on a weak channel, 5x the noise's rms in its band; the loud channel 3 hides it
    # in the pooled error
    band_energy = floor.bands["e0"][1][band, 1]
    amp = np.sqrt(2 * 25 * band_energy / N)
    for e in exps:
        e.measured[:, 1] += amp * np.sin(2 * np.pi * 20.0 * t)
    zeros = [np.zeros((N, CHANNELS))] * EXPERIMENTS
    res = resolved.resolve(exps, zeros, floor)
    pooled = np.sqrt(sum(np.sum(e.measured**2) for e in exps) / sum(sum(v.values()) for v in floor.energy.values()))
    assert pooled < 1.01  # the pooled error cannot see it
    assert res.detected()
    top = res.cells()[0]
    assert top["channel"] == "c1" and top["band_hz"][0] <= 20.0 < top["band_hz"][1]
    assert top["residual_to_floor"] == pytest.approx(np.sqrt(26.0), rel=0.25)
    # the model that has the misfit removes the whole excess: its likelihood ratio passes the test
    # for one parameter, and nothing is left above the floor
    fixed = [np.column_stack([np.zeros(N), amp * np.sin(2 * np.pi * 20.0 * t), np.zeros(N), np.zeros(N)])] * EXPERIMENTS
    after = resolved.resolve(exps, fixed, floor)
    assert not after.detected()
    assert resolved.gain(res, after) == pytest.approx(res.excess(res.residual_dof))
    assert resolved.gain(res, after) > resolved.gain_threshold(1)


def test_the_residual_energies_alone_are_resolves_and_parsevals():
    # residual_energies (held_out's spread) is resolve's residual to the bit, and each band's
    # energy is the residual's FFT lines in that band (Parseval: they add up to sum r^2)
    rng = np.random.default_rng(3)
    exps = _null(rng)
    floor = _white_floor(SIGMA)
    preds = [0.5 * e.measured + 0.01 * rng.standard_normal((N, CHANNELS)) for e in exps]
    fast = resolved.residual_energies(exps, preds, floor)
    full = resolved.resolve(exps, preds, floor)
    edges = band_edges(FS, N)
    masks = in_band(FS, N, edges)
    for e, p, a, b in zip(exps, preds, fast, full.residual):
        assert np.array_equal(a, b)
        r = e.measured - p
        spec = np.abs(np.fft.rfft(r, axis=0)) ** 2 / N
        spec[1:N // 2] *= 2.0
        assert np.allclose(a, [spec[m].sum(axis=0) for m in masks], rtol=1e-12)
        assert a.sum(axis=0) == pytest.approx(np.sum(r**2, axis=0) - spec[0], rel=1e-12)
    assert resolved.residual_energies(exps, preds, NoiseFloor({}, {})) is None



def test_a_band_no_single_stretch_holds_two_lines_of_is_not_judged_on_one_stretch():
    # a sinusoid at 15 Hz in one channel: found in its band; stretches of 0.05 s (lines every 20 Hz)
    # hold one line of 12.5-25 Hz each, so there it moves to the unjudged cells, limit and all; a
    # stretch of 0.2 s (5 Hz lines) holds three, and keeps it judged
    floor = _white_floor(SIGMA)
    exps = _null(np.random.default_rng(7))
    t = np.arange(N) / FS
    for e in exps:
        e.measured[:, 1] += 0.2 * np.sin(2 * np.pi * 15.0 * t)
    zeros = [np.zeros((N, CHANNELS))] * EXPERIMENTS
    res = resolved.resolve(exps, zeros, floor)
    band = [i for i, (lo, hi) in enumerate(res.bands[0]) if lo <= 15.0 < hi][0]
    assert res.detected() and {(c["channel"], c["band_hz"][0]) for c in res.cells()} == {("c1", res.bands[0][band][0])}
    short = [np.arange(1, 10) * 20.0] * 4  # four tails of 0.05 s: 20, 40, ... Hz
    moved = resolved.judged_on_one_stretch(res, short)
    assert not moved.detected()
    assert [c["channel"] for c in moved.unjudged()] == ["c1"] * EXPERIMENTS
    for before, after, gone in zip(res.limit, moved.limit, moved.unjudged_limit):
        assert np.all(np.isinf(after[band])) and np.array_equal(gone[band], before[band])
        keep = np.arange(len(before)) != band
        shown = np.array([np.count_nonzero((short[0] >= lo) & (short[0] < hi)) >= 2 for lo, hi in res.bands[0]])
        assert np.array_equal(np.isfinite(after[:, 0]), shown) and np.array_equal(after[keep & shown], before[keep & shown])
    long = [np.arange(1, 40) * 5.0]
    assert resolved.judged_on_one_stretch(res, long).detected()
