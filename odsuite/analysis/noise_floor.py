"""The calibrated noise floor: the residual a perfect model would leave, per channel and experiment.

Four parts, each estimated from the record itself:

- broadband noise: the variance of the quiet samples (before the hit, and after the response has
  died into the noise) at the acceleration stage, once mains lines and a trend are fitted out;
  white, or rising at low frequency where the samples before the hit show it
  (odsuite.analysis.noise_colour);
- mains hum and trend: sinusoids at 50 and 60 Hz and their harmonics plus a line, fitted on the
  quiet samples and extended over the whole record (they persist through the response); a line
  fitted at one end only where its slope is beyond three standard errors, shrunk to its expected
  energy (not the fitted one's);
- quantisation: while the signal moves through the ADC's codes its rounding error is uniform
  (lsb^2 / 12), which a quiet stretch sitting on one code does not show; with the model's signals
  and the fitted hum and drift (odsuite.analysis.prediction.sensor_noise) it is simulated at the
  converter's offset and noise the record tells;
- the force channel's noise through the model: the model is driven by the measured force, so the
  load cell's noise inside the force window reaches every predicted channel. Its expected energy is
  the window's noise energy times the mean energy of the model's responses to unit force samples
  over the window (prediction.impulse_responses; exact for white noise spread evenly over it): not
  one unit's, as the prediction is not the same shifted where a record starts at its hit (with
  quiet samples before the hit it is, and the unit at the trigger stands for them all). A record
  that starts inside its hit adds the force it missed before its first sample
  (prediction.force_window).

``NoiseFloor.error`` is then the contract's ``error`` of a perfect model; its spectrum (per channel
and experiment) lets the residual's peaks and bands be tested against what noise alone gives.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.ndimage
import scipy.signal
import scipy.stats

from odsuite.analysis import noise_colour
from odsuite.analysis.disturbances import MAINS_HARMONICS, MAINS_HZ, disturbance_basis

#: samples kept clear of the hit (s): zero-phase filters ring backwards from it
HIT_GUARD_S = 1e-3
#: fewest quiet samples before the hit the noise is measured on; with fewer, the record's last eighth
FEWEST_BEFORE = 32
#: the response has died into the noise where the excess energy left in the record is below this
#: fraction of the record's noise energy (as the fit windows)
QUIET_FRACTION = 0.05
#: a perfect model's error lies within this factor of the floor (measured on independent nominal
#: data at 12 and 16 bits, with drift and with mains hum, two rigs, four seeds each: 0.89-1.06): a
#: residual within it cannot be told from noise
FLOOR_TOLERANCE = 1.3
#: a drift fitted on quiet samples at one end of a record is carried over it when its slope lies
#: beyond this many standard errors (noise alone: 0.3 % of records); a hum's sinusoid pair where
#: its amplitude does, at the same probability (chi-square with two degrees of freedom)
DRIFT_SLOPE_Z = 3.0
#: Welch segment length of residual and floor spectra (samples; halved for short records)
NFFT = 2048
#: an edge of the resolved residual's bands (Hz): octaves run from it up to Nyquist and down
LOWEST_BAND_HZ = 12.5
#: the lowest band holds at least this many lines of the record's spectrum
LOWEST_BAND_LINES = 4
#: lines averaged over to take the expected spectrum of the simulated sensor noise
SMOOTH_LINES = 17
#: a band is judged where the samples before the hit (of every record, pooled; witnesses) show at least this many
#: lines in it: one line of one short tail is one noisy value, and may hold a mode still ringing
RESOLVING_LINES = 2


def band_edges(fs: float, n_samples: int) -> list[tuple[float, float]]:
    """Frequency bands of the resolved residual (Hz): octaves from the record's first line to
    Nyquist, the lowest holding at least ``LOWEST_BAND_LINES`` lines. Below ``LOWEST_BAND_HZ`` they
    are octaves too, not one band: a band is judged where the quiet samples show it
    (resolves_band), and a noise that rises at low frequency holds its energy at a band's bottom,
    which a line at its top does not witness. The zero-frequency line is left out: the chains'
    offsets and high-passes shape it."""
    first = fs / n_samples
    lowest = max(LOWEST_BAND_HZ, LOWEST_BAND_LINES * first)
    low = [lowest]
    while low[0] / 2 > LOWEST_BAND_LINES * first:
        low.insert(0, low[0] / 2)
    edges = [first, *low[:-1]]
    f = lowest
    while f < fs / 2:
        edges.append(f)
        f *= 2
    edges.append(fs / 2)
    return list(zip(edges[:-1], edges[1:]))


def resolves_band(stretches: Sequence[np.ndarray] | None, bands: Sequence[tuple[float, float]],
                  least: int = RESOLVING_LINES) -> np.ndarray:
    """Per band, whether the quiet stretches (each the frequencies of the lines of its own spectrum
    that tell the noise's density, Hz; the records' of one sensor pooled, its noise is the same in
    each) resolve it: at least ``least`` of those lines lie in the band. Below a stretch's first
    line it shows no spectrum at all: a noise that rises there (1/f-like, a slow wander) is not
    seen in it; and a stretch before the hit and one after the response, apart, see no lower
    (0.05 s and 0.06 s of them judged a null's 2.5-12.5 Hz as if they were one of 0.11 s). None:
    not known, every band counts as resolved."""
    if stretches is None:
        return np.ones(len(bands), bool)
    return band_lines(stretches, bands) >= least


def band_lines(stretches: Sequence[np.ndarray], bands: Sequence[tuple[float, float]]) -> np.ndarray:
    """Per band, how many of the quiet stretches' lines (resolves_band) lie in it."""
    count = np.zeros(len(bands), int)
    for lines in stretches:
        lines = np.asarray(lines, float)
        for i, (lo, hi) in enumerate(bands):
            count[i] += int(np.count_nonzero((lines >= lo) & (lines < hi)))
    return count


def witnesses(exps: Sequence) -> list[np.ndarray]:
    """The lines (Hz, per quiet stretch) that decide which bands are judged (resolves_band): those
    of the samples before the hit that the noise's colour is measured from (noise_colour.MIN_SAMPLES
    or more), since the floor's spectrum is known only where they show it, less the lines the
    disturbances fitted on them take (noise_colour.usable_lines: on 240 samples at 20 kHz a 60 Hz
    sinusoid takes 99 % of the 83 Hz line, and a noise band's flank put 78-156 Hz cells of nulls at
    3.7x their limit). A tail witnesses the noise's level but may hold a mode still ringing, so
    the floor's colour is not taken from it (noise_colour), and a band only a tail shows is not
    judged: with 1/f noise on a 70 kg cabinet, tails of 0.16-0.29 s put 1.5-6.25 Hz cells of nulls
    at 1.2-1.5x their limit. Where no record has such samples before its hit, its quiet stretches
    (the tail after the response, and the few samples before the hit) witness it, by the lines their own disturbances' fit leaves (noise_colour.usable_stretch_lines:
    on 256 samples at 5120 Hz the hum's fit took the 40 Hz line, and counted, a floor's vibration
    at 25-50 Hz put plate-and-motor nulls recorded from their hit at 2.5-5x their limit there)."""
    before = [lines for lines in (noise_colour.usable_lines(e) for e in exps) if lines is not None]
    return before or [noise_colour.usable_stretch_lines(e, a, b) for e in exps
                      for a, b in noise_colour.quiet_stretches(e, shortest=2)]


def line_energies(x: np.ndarray) -> np.ndarray:
    """Energy of each column of ``x`` (samples x columns) per line of its real FFT: they add up to
    sum(x^2) (Parseval)."""
    x = np.atleast_2d(np.asarray(x, float).T).T
    n = x.shape[0]
    spec = np.abs(np.fft.rfft(x, axis=0)) ** 2 / n
    spec[1: (n + 1) // 2] *= 2.0
    return spec


def in_band(fs: float, n_samples: int, bands: Sequence[tuple[float, float]]) -> list[np.ndarray]:
    """Per band, the mask of the real FFT's lines inside it (the top band includes Nyquist)."""
    f = np.fft.rfftfreq(n_samples, 1.0 / fs)
    return [(f >= lo) & ((f < hi) if hi < fs / 2 else (f <= hi)) & (f > 0) for lo, hi in bands]


def band_slices(fs: float, n_samples: int, bands: Sequence[tuple[float, float]]) -> tuple[slice, ...]:
    """``in_band``'s masks as the runs of lines they are: indexing by one gives a view, not a copy."""
    return _band_slices(float(fs), int(n_samples), tuple((float(lo), float(hi)) for lo, hi in bands))


@functools.lru_cache(maxsize=64)
def _band_slices(fs: float, n_samples: int, bands: tuple[tuple[float, float], ...]) -> tuple[slice, ...]:
    # kept: a diagnosis resolves the same records' residuals dozens of times
    out = []
    for m in in_band(fs, n_samples, bands):
        idx = np.flatnonzero(m)
        out.append(slice(int(idx[0]), int(idx[-1]) + 1) if idx.size else slice(0, 0))
    return tuple(out)


def band_dof(lines: np.ndarray, masks: Sequence[np.ndarray], smooth: int = 5) -> np.ndarray:
    """Degrees of freedom of a noise's energy per band (bands x columns) from its expected line
    energies: 2 (sum S)^2 / sum S^2 over the band's lines (2 per line when flat, fewer where a
    resonance carries the force channel's noise). The lines are averaged over ``smooth``
    neighbours first: a few realisations' periodogram scatters, which would read as colour."""
    kernel = np.ones(smooth) / smooth
    s = np.apply_along_axis(lambda c: np.convolve(c, kernel, mode="same"), 0, lines)
    out = []
    for m in masks:
        b = s[m]
        out.append(2.0 * np.sum(b, axis=0) ** 2 / np.maximum(np.sum(b**2, axis=0), 1e-300))
    return np.maximum(np.array(out), 1.0)


def _fit(x: np.ndarray, basis: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least squares of the columns of ``x`` on ``basis`` over ``mask``: broadband variance per
    column, the fit over the whole record (mean removed), and the pooled residual sum of squares."""
    coef, *_ = np.linalg.lstsq(basis[mask], x[mask], rcond=None)
    resid = x[mask] - basis[mask] @ coef
    rss = np.sum(resid**2, axis=0)
    dof = max(1, int(mask.sum()) - basis.shape[1])
    fitted = basis @ coef
    return rss / dof, fitted - fitted.mean(axis=0), float(rss.sum())


@dataclass
class QuietFit:
    """The quiet samples of a raw record and the disturbances fitted on them."""

    quiet: np.ndarray  # mask over the samples
    disturbance: np.ndarray  # samples x columns (volts): offset, drift where both ends are quiet, hum
    mains_hz: float
    harmonics: int
    # samples x columns (volts): the part of a drift and a hum fitted on quiet samples at one end
    # only that their uncertainty leaves out of ``disturbance``; not noise either
    local_drift: np.ndarray | None = None
    # the record's last eighth was louder than its few samples before the hit (still ringing) and
    # was left out of the noise's estimate: how many times, in the loudest channel's variance
    ringing_tail: float | None = None

    def white(self, stage: np.ndarray, stage_disturbance: np.ndarray,
              stage_drift: np.ndarray | None = None, offset_error: np.ndarray | None = None) -> np.ndarray:
        """Per column, the broadband variance of the quiet samples of a signal after the chain once
        the disturbances and a local drift (through the same chain) are taken out, and, in the
        columns where ``offset_error`` (the chain's response to a constant) is not zero, that
        response's multiple that fits them best (an offset removed with an error)."""
        rest = (stage - stage_disturbance - (0.0 if stage_drift is None else stage_drift))[self.quiet]
        if offset_error is not None and len(rest) > 2:
            shape = offset_error[self.quiet]
            norm = np.einsum("ij,ij->j", shape, shape)
            fit = np.divide(np.einsum("ij,ij->j", shape, rest), norm, out=np.zeros_like(norm), where=norm > 0)
            rest = rest - shape * fit
        return np.var(rest, axis=0) if len(rest) > 1 else np.zeros(stage.shape[1])


def split_noise(raw: np.ndarray, trigger: int, fs: float) -> QuietFit:
    """The quiet samples of a raw record (volts, before the chain: no filter transients) and its
    disturbances fitted on them: an offset, a line (drift) and the mains hum (where quiet samples
    lie at one end only, each extended over the record where it is seen, shrunk by its
    uncertainty, the rest kept as ``local_drift`` for the noise's estimate only).
    Put through a channel's chain, the disturbances reach the acceleration stage as they do in the
    measurement, the high-pass's ringing on a drift included.

    Quiet samples: before the hit (less a guard) and after the response has died into the noise.
    The mains frequency (50 or 60 Hz) is the one whose sinusoid holds more of the samples before
    the hit where they hold two of its periods, else of the record (hum persists through it, a
    hit's response does not); its harmonics are fitted only when the quiet
    samples, before the hit and after the response, hold two of its periods (on fewer the
    sinusoids are nearly collinear with the constant)."""
    x = np.atleast_2d(raw.T).T
    n = x.shape[0]
    guard = int(round(HIT_GUARD_S * fs))
    pre = np.zeros(n, bool)
    pre[: max(0, trigger - guard)] = True
    ringing = None
    if pre.sum() < FEWEST_BEFORE:  # no pre-trigger: the last eighth (a lightly damped rig has died away there)
        last = np.zeros(n, bool)
        last[-max(FEWEST_BEFORE, n // 8):] = True
        ringing = _still_ringing(x, pre, last)
        if ringing is None:
            pre |= last
    # the mains frequency is the one whose fit leaves the least of the samples before the hit where
    # they hold two periods of each, else of the record: a response still ringing at the record's
    # end leaks into either sinusoid (a 30 Hz ring at 500x the noise chose 60 Hz under a 50 Hz
    # hum of 7x the noise)
    seen = pre if pre.sum() >= 2.0 * fs / min(MAINS_HZ) else np.ones(n, bool)
    mains = min((_fit(x, disturbance_basis(n, fs, (f0,), 1), seen)[2], f0) for f0 in MAINS_HZ)[1]
    # the response has died into the noise where the excess energy left (beyond the broadband
    # noise and the disturbances fitted before the hit) is below QUIET_FRACTION of the record's
    # noise energy
    white, dist, _ = _fit(x, disturbance_basis(n, fs, (mains,), 1, line=False), pre)
    var = float(np.sum(white))
    power = np.sum((x - x[pre].mean(axis=0) - dist) ** 2, axis=1)
    tail = np.cumsum(power[::-1])[::-1] - (n - np.arange(n)) * var
    above = np.flatnonzero(tail > QUIET_FRACTION * n * var)
    end = int(above[-1]) + 1 if above.size else trigger
    end = min(n, end + int(0.25 * max(end - trigger, 0)))  # a margin, as the fit windows
    quiet = pre.copy()
    quiet[end:] = True
    harmonics = MAINS_HARMONICS if int(quiet.sum()) >= 2 * fs / mains else 1
    # the line is fitted always (else the hum's sinusoid takes a drift's ramp and carries it over
    # the record), and extended over the record where quiet samples lie at both ends
    basis = disturbance_basis(n, fs, (mains,), harmonics, line=True)
    coef, *_ = np.linalg.lstsq(basis[quiet], x[quiet], rcond=None)
    if bool(quiet[0]) and bool(quiet[-1]):
        fitted = basis @ coef
        return QuietFit(quiet, fitted - fitted.mean(axis=0), mains, harmonics, ringing_tail=ringing)
    # quiet samples at one end only (a record shorter than the response): drift goes on through the
    # response, so the line belongs to what a perfect model leaves; so does the hum. Extended over
    # the record, a component fitted to noise alone adds its variance times the record's length
    # (a line's grows as that length cubed): each component (the line, each sinusoid pair) is kept
    # where it lies beyond DRIFT_SLOPE_Z standard errors (its coefficients' covariance given the
    # others'), shrunk to its unbiased energy. A few milliseconds before the hit (96 samples at
    # 20 kHz) hold a quarter period of the mains, nearly a line: fitted to white noise alone, the
    # hum's amplitude came out 20x the noise, and carried over the record it set the floor at 5x
    # a perfect model's error
    resid = x[quiet] - basis[quiet] @ coef
    noise = np.sum(resid**2, axis=0) / max(1, int(quiet.sum()) - basis.shape[1])
    cov = np.linalg.pinv(basis[quiet].T @ basis[quiet])
    kept = coef.copy()  # the offset is kept as fitted
    for cols in [[1]] + [[k, k + 1] for k in range(2, basis.shape[1], 2)]:
        c = coef[cols]
        stat = np.einsum("ik,ij,jk->k", c, np.linalg.pinv(cov[np.ix_(cols, cols)]), c) / np.where(noise > 0, noise, np.inf)
        limit = _seen_limit(len(cols))
        kept[cols] = c * np.where(stat > limit, np.sqrt(np.maximum(0.0, 1.0 - len(cols) / np.maximum(stat, 1e-300))), 0.0)
    fitted = basis @ kept
    return QuietFit(quiet, fitted - fitted.mean(axis=0), mains, harmonics, basis @ (coef - kept), ringing)


#: fewest samples before the hit that can tell the last eighth of a record still rings
FEWEST_TO_COMPARE = 8
#: the chance that noise alone makes the last eighth read as still ringing (an F test per channel)
RINGING_ALARM = 1e-3


def _still_ringing(x: np.ndarray, pre: np.ndarray, last: np.ndarray) -> float | None:
    """How many times louder (variance, the loudest channel) the samples ``last`` are than ``pre``,
    where that exceeds what noise of one level allows (F test at RINGING_ALARM, Bonferroni over the
    channels); None where it does not, or where ``pre`` holds too few samples to tell. An undamped
    rig's last eighth held its ringing at 400x the noise of the 31 samples before the hit, and
    taken for noise it set the floor at 13x the model's error."""
    k, m = int(pre.sum()), int(last.sum())
    if k < FEWEST_TO_COMPARE or m < 3:
        return None
    before = np.var(x[pre], axis=0, ddof=1)
    t = np.arange(m)
    after = x[last] - np.polyval(np.polyfit(t, x[last], 1), t[:, None])
    after = np.sum(after**2, axis=0) / (m - 2)  # a drift over the tail is no ringing
    ratio = after / np.where(before > 0, before, np.finfo(float).tiny)
    limit = float(scipy.stats.f.isf(RINGING_ALARM / x.shape[1], m - 2, k - 1))
    loudest = float(np.max(ratio))
    return loudest if loudest > limit else None


@functools.cache
def _seen_limit(dof: int) -> float:
    """The chi-square quantile a component of ``dof`` coefficients must pass to be carried over a
    record: the probability of DRIFT_SLOPE_Z standard errors (two-sided) for one."""
    return float(scipy.stats.chi2.isf(2.0 * scipy.stats.norm.sf(DRIFT_SLOPE_Z), dof))


def moving_samples(x: np.ndarray, lsb: np.ndarray | float, fs: float) -> np.ndarray:
    """Mask (samples x columns) of samples where the signal moves through the ADC's codes: within
    half a period (at the signal's spectral centroid) of a sample at least half a code from zero.
    There the rounding error is uniform; where a decaying signal stays within half a code of zero
    it reads zero and the error is the (small) signal itself."""
    x = np.atleast_2d(np.asarray(x, float).T).T
    lsb = np.broadcast_to(np.asarray(lsb, float), (x.shape[1],))
    spec = np.abs(np.fft.rfft(x, axis=0)) ** 2
    f = np.fft.rfftfreq(x.shape[0], 1 / fs)
    total = spec.sum(axis=0)
    centroid = np.where(total > 0, (f[:, None] * spec).sum(axis=0) / np.where(total > 0, total, 1), fs / 4)
    out = np.zeros(x.shape, bool)
    for j in range(x.shape[1]):
        if lsb[j] <= 0:
            continue
        half = int(np.ceil(fs / (2 * max(centroid[j], fs / x.shape[0]))))
        out[:, j] = scipy.ndimage.maximum_filter1d(np.abs(x[:, j]), 2 * half + 1) >= lsb[j] / 2
    return out


def active_var(white: np.ndarray, lsb: np.ndarray) -> np.ndarray:
    """Per-sample noise variance while the signal moves through the codes: the broadband part
    and a uniform rounding error, at least lsb^2/12 (Sheppard: a quiet noise wider than an lsb
    already holds it)."""
    return np.maximum(white, np.asarray(lsb) ** 2 / 12.0)


@dataclass
class NoiseFloor:
    """Expected residual energy of a perfect model, per experiment and sensor (sum of squares at
    the acceleration stage, physical units squared), beside the measured energy."""

    energy: dict[str, dict[str, float]]
    measured: dict[str, dict[str, float]]
    parts: dict[str, dict[str, dict[str, float]]] = field(default_factory=dict)
    # per experiment: the floor's Welch spectrum per sensor (frequencies, PSD samples x sensors)
    spectra: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict, repr=False)
    # per experiment: the floor's energy and its degrees of freedom per band (band_edges) and sensor
    # (bands x sensors), from the expected line energies of its parts
    bands: dict[str, tuple[list[tuple[float, float]], np.ndarray, np.ndarray]] = field(
        default_factory=dict, repr=False)
    # per experiment: per band, how many lines of the samples the noise's spectrum is measured on
    # lie in it (witnesses, band_lines); absent: not known
    witness_lines: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    # per sensor, its noise's colour (noise_colour.by_sensor): the records' alone, so a floor of the
    # same records for another model takes it from here
    colours: dict[str, Any] = field(default_factory=dict, repr=False)
    # per experiment: the part of ``bands``' energy (bands x sensors) the colour adds to the sensors'
    # white noise, which only the few lines before the hits measure (resolved.floor_error)
    coloured: dict[str, np.ndarray] = field(default_factory=dict, repr=False)

    def judged(self, experiment: str, n_bands: int) -> np.ndarray:
        """Per band of ``experiment``, whether those samples resolve it (resolves_band); where not,
        the floor there is carried down unseen. Every band where the lines are not known."""
        lines = self.witness_lines.get(experiment)
        return np.ones(n_bands, bool) if lines is None else lines >= RESOLVING_LINES

    def total(self, experiments: Sequence[str] | None = None, channels: Sequence[str] | None = None
              ) -> tuple[float, float]:
        """(floor energy, measured energy) summed over the selection."""
        num = den = 0.0
        for e, chans in self.energy.items():
            if experiments is not None and e not in experiments:
                continue
            for c, v in chans.items():
                if channels is not None and c not in channels:
                    continue
                num += v
                den += self.measured[e][c]
        return num, den

    def error(self, experiments: Sequence[str] | None = None, channels: Sequence[str] | None = None) -> float:
        """The contract's error of a perfect model: sqrt(floor energy / measured energy)."""
        num, den = self.total(experiments, channels)
        return float(np.sqrt(min(num, den) / den)) if den > 0 else float("nan")

    def as_dict(self) -> dict[str, Any]:
        return {"error": self.error(),
                "experiments": {e: {"error": self.error([e]),
                                    "channels": {c: self.error([e], [c]) for c in chans}}
                                for e, chans in self.energy.items()},
                "parts": self.parts}


def _segment(n_samples: int) -> int:
    """The Welch segment length all spectra here share: NFFT, halved for short records."""
    nfft = NFFT
    while nfft > n_samples:
        nfft //= 2
    return nfft


def welch(x: np.ndarray, fs: float, n_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Welch spectrum (Hann, half overlap) with the segment length all spectra here share."""
    return scipy.signal.welch(x, fs=fs, nperseg=_segment(n_samples), axis=0)


def on_grid(f_ref: np.ndarray, f: np.ndarray, psd: np.ndarray) -> np.ndarray:
    """A spectrum (frequencies x channels) at the frequencies ``f_ref``: spectra of records of
    other rates or lengths pool on one grid (a density, so interpolated; equal grids unchanged)."""
    if len(f) == len(f_ref) and np.array_equal(f, f_ref):
        return psd
    return np.column_stack([np.interp(f_ref, f, col) for col in psd.reshape(len(f), -1).T]).reshape(
        len(f_ref), *psd.shape[1:])


def pooled_grid(grids: Sequence[np.ndarray]) -> np.ndarray:
    """The grid spectra of several records pool on: the first record's, up to the lowest Nyquist
    frequency among them (above it a slower record holds nothing)."""
    top = min(float(g[-1]) for g in grids)
    return grids[0][grids[0] <= top]


def welch_frequencies(fs: float, n_samples: int) -> np.ndarray:
    """The frequencies of ``welch``'s spectra (Hz)."""
    return np.fft.rfftfreq(_segment(n_samples), 1.0 / fs)


def _coloured(flat: np.ndarray, colour: np.ndarray) -> np.ndarray:
    """A flat density coloured, each column keeping its integral (its per-sample variance)."""
    out = flat * colour
    return out * flat.sum(axis=0) / np.where(out.sum(axis=0) > 0, out.sum(axis=0), np.inf)


def _units(impulses: np.ndarray) -> np.ndarray:
    """An experiment's unit responses (prediction.impulse_responses) as units x samples x sensors: a
    single response (samples x sensors) is one unit."""
    h = np.asarray(impulses, float)
    return h[None] if h.ndim == 2 else h


def _tail_colours(exps: Sequence, residuals: Mapping[str, np.ndarray],
                  impulses: Mapping[str, np.ndarray] | None,
                  sensor_noise: Mapping[str, Sequence[np.ndarray]] | None) -> dict[str, Any]:
    """noise_colour.tail_excess of a model's ``residuals`` (experiment name -> samples x sensors) on
    the records' quiet tails, against what the floor expects on them: the simulated sensors' noise
    (else white at the quiet level), the fitted hum and drift, and the force channel's noise
    through the model's unit responses."""
    pooled: dict[str, list[list[np.ndarray]]] = {}
    for e in exps:
        a, b = int(e.quiet_tail), int(e.n_samples)
        if not 0 <= a or b - a < 2 * RESOLVING_LINES + 1:
            continue
        f = np.fft.rfftfreq(b - a, 1.0 / e.fs)
        got = line_energies(residuals[e.name][a:b])
        simulated = (sensor_noise or {}).get(e.name) or []
        if simulated:
            noise = np.mean([line_energies(r[a:b]) for r in simulated], axis=0)
        else:  # white at the quiet level: line_energies' expectation, 2 var inside, var at the ends
            noise = np.tile(2.0 * np.asarray(e.noise_var, float), (len(f), 1))
            noise[0] /= 2.0
            if (b - a) % 2 == 0:
                noise[-1] /= 2.0
        rest = np.zeros_like(noise)
        if e.disturbance is not None:
            rest += line_energies(e.disturbance[a:b])
        if impulses is not None and e.force_noise_energy > 0:
            rest += e.force_noise_energy * np.mean([line_energies(h[a:b]) for h in _units(impulses[e.name])], axis=0)
        for j, s in enumerate(e.sensors):
            parts = pooled.setdefault(s.name, [[], [], [], []])
            for k, v in enumerate((f[1:], got[1:, j], noise[1:, j], rest[1:, j])):
                parts[k].append(v)
    sensors = {name: tuple(np.concatenate(v) for v in parts) for name, parts in pooled.items()}
    return noise_colour.tail_excess(sensors, band_edges(exps[0].fs, exps[0].n_samples)) if sensors else {}


def estimate(exps: Sequence, impulses: Mapping[str, np.ndarray] | None = None,
             sensor_noise: Mapping[str, Sequence[np.ndarray]] | None = None, *, spectra: bool = False,
             colours: Mapping[str, Any] | None = None,
             tail_residuals: Mapping[str, np.ndarray] | None = None) -> NoiseFloor:
    """The noise floor of ``exps`` (PreparedExperiments); ``impulses`` maps an experiment's name to
    its model's responses to unit force samples over the force window (units x samples x sensors,
    odsuite.analysis.prediction.impulse_responses; one response: samples x sensors), whose mean
    energies carry the force channel's noise to every channel (without them that part is left out);
    ``sensor_noise`` to simulated realisations of the sensors' noise and rounding
    (odsuite.analysis.prediction.sensor_noise; without them: white noise and a uniform rounding error
    where the signal moves through the codes). ``spectra``: also the floor's Welch spectra, for
    peak and band tests. ``colours``: the sensors' noise colours of these records (a floor's of
    the same records for another model: NoiseFloor.colours), found again where absent from the
    samples before the hit. ``tail_residuals``: a model's residual (experiment name -> samples x
    sensors) whose excess over the floor on the records' quiet tails is taken as the colour
    instead (_tail_colours; for records with too few samples before their hit to tell it, where a
    model error lasting into the tails reads alike: diagnose's verdict weighs it, no test does)."""
    energy: dict[str, dict[str, float]] = {}
    measured: dict[str, dict[str, float]] = {}
    parts: dict[str, dict[str, dict[str, float]]] = {}
    specs: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    banded: dict[str, tuple[list[tuple[float, float]], np.ndarray, np.ndarray]] = {}
    counted: dict[str, np.ndarray] = {}
    coloured: dict[str, np.ndarray] = {}
    # the colour's excess is tested in the bands the residual is judged in
    if tail_residuals is not None and exps:
        colours = _tail_colours(exps, tail_residuals, impulses, sensor_noise)
    elif colours is None:
        colours = noise_colour.by_sensor(exps, band_edges(exps[0].fs, exps[0].n_samples) if exps else ())
    known = all(getattr(e, "quiet_tail", -1) >= 0 for e in exps)
    stretches = witnesses(exps) if known else None
    # records that start at their hit: the colour is their tails' pooled (_tail_colours) and their
    # bands are judged on every record's stretches (witnesses), so it is carried down as far in
    # each record (else a 0.013 s tail left a 0.06 s one's 10-40 Hz colour unused beside it)
    longest = None if any(noise_colour.has_pre_hit_lines(e) for e in exps) else max(
        (b - a for e in exps for a, b in noise_colour.quiet_stretches(e)), default=None)
    for e in exps:
        n = e.n_samples
        white = np.asarray(e.noise_var, float)
        lsb = np.asarray(e.lsb if e.lsb is not None else np.zeros(len(e.sensors)), float)
        simulated = (sensor_noise or {}).get(e.name) or []
        if simulated:
            broadband = np.mean([np.sum(r**2, axis=0) for r in simulated], axis=0)
        else:
            n_active = moving_samples(e.measured, lsb, e.fs).sum(axis=0)
            broadband = white * n + n_active * (active_var(white, lsb) - white)
        # the sensors' noise rises at low frequency where the samples before the hit say so
        # (noise_colour): its expected energy per line, coloured, and the broadband energy with it
        colour = noise_colour.gains(colours, e, np.fft.rfftfreq(n, 1.0 / e.fs), longest)
        sensor_lines = None
        if spectra or colour is not None:
            if simulated:
                # a few realisations scatter line by line; the sensors' noise is smooth in frequency
                sensor_lines = scipy.ndimage.uniform_filter1d(np.mean([line_energies(r) for r in simulated], axis=0),
                                                              SMOOTH_LINES, axis=0, mode="nearest")
            else:
                sensor_lines = np.tile(broadband / (n // 2 + 1), (n // 2 + 1, 1))
            excess_lines = None
            if colour is not None:
                white_sum = sensor_lines.sum(axis=0)
                excess_lines = sensor_lines * (colour - 1.0)
                sensor_lines = sensor_lines * colour
                broadband = broadband * sensor_lines.sum(axis=0) / np.where(white_sum > 0, white_sum, np.inf)
        hum = (np.sum(e.disturbance**2, axis=0) if e.disturbance is not None else np.zeros(len(e.sensors)))
        force_part = np.zeros(len(e.sensors))
        h = None
        if impulses is not None and e.force_noise_energy > 0:
            h = _units(impulses[e.name])
            force_part = e.force_noise_energy * np.mean(np.sum(h**2, axis=1), axis=0)
        total = broadband + hum + force_part
        energy[e.name] = {s.name: float(v) for s, v in zip(e.sensors, total)}
        measured[e.name] = {s.name: float(v) for s, v in zip(e.sensors, np.sum(e.measured**2, axis=0))}
        parts[e.name] = {"broadband": float(broadband.sum()), "hum_and_trend": float(hum.sum()),
                         "force_noise": float(force_part.sum())}
        if spectra:
            f = welch_frequencies(e.fs, n)
            # every part's spectrum in one call: Welch transforms each column alone
            blocks = [*simulated, *([] if e.disturbance is None else [e.disturbance]), *([] if h is None else h)]
            spectra_of = iter(np.split(welch(np.concatenate(blocks, axis=1), e.fs, n)[1],
                                       np.cumsum([b.shape[1] for b in blocks])[:-1], axis=1) if blocks else [])
            if simulated:
                psd = np.mean([next(spectra_of) for _ in simulated], axis=0)
                if colour is not None:
                    psd = psd * noise_colour.gains(colours, e, f, longest)
            else:  # one-sided density whose integral is the per-sample variance
                flat = np.tile(broadband / n * 2.0 / e.fs, (len(f), 1))
                psd = flat if colour is None else _coloured(flat, noise_colour.gains(colours, e, f, longest))
            if e.disturbance is not None:
                psd = psd + next(spectra_of)
            if h is not None:
                psd = psd + e.force_noise_energy * np.mean([next(spectra_of) for _ in h], axis=0)
            specs[e.name] = (f, psd)
            # the expected energy per line of every part, scaled so that each sensor's lines add up
            # to its floor energy (the rounding's share where no realisation simulates it)
            lines = sensor_lines
            if e.disturbance is not None:
                lines = lines + line_energies(e.disturbance)
            if h is not None:
                lines = lines + e.force_noise_energy * np.mean([line_energies(u) for u in h], axis=0)
            sums = lines.sum(axis=0)
            to_total = np.where(sums > 0, total / np.where(sums > 0, sums, 1.0), 1.0)
            lines = lines * to_total
            bands = band_edges(e.fs, n)
            masks = in_band(e.fs, n, bands)
            banded[e.name] = (bands, np.array([lines[m].sum(axis=0) for m in masks]), band_dof(lines, masks))
            if excess_lines is not None:
                coloured[e.name] = np.array([(excess_lines * to_total)[m].sum(axis=0) for m in masks])
            if stretches is not None:
                counted[e.name] = band_lines(stretches, bands)
    return NoiseFloor(energy, measured, parts, specs, banded, counted, dict(colours), coloured)
