"""Frequency domain decomposition of output-only records (FDD, Brincker, Zhang & Andersen 2001)
and its enhanced form (EFDD): the responses' cross-spectral matrix G(f) is decomposed line by line
(G = U S U^H); near a lightly damped mode its first singular value is that mode's spectral bell
and its first singular vector the mode's shape. EFDD takes the bell (the lines around the peak
whose first singular vector stays within ``BELL_MAC`` of the peak's), transforms it back to a
correlation function of one degree of freedom and reads the frequency from its zero crossings and
the damping from the logarithmic decay of its extremes.

It shares nothing with SSI-cov (``oma.py``) but the record, so the two check each other.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal

from odsuite.domain import arguments
from odsuite.domain.errors import ConfigError

#: a peak of the first singular value (log10) must stand this far above the higher of its two
#: surrounding minima to be taken as a mode (0.6: a factor 4 in power)
PEAK_PROMINENCE = 0.6
#: the bell holds the lines around a peak whose first singular vector has at least this MAC with
#: the peak's (Brincker's EFDD uses 0.8)
BELL_MAC = 0.8
#: the SDOF correlation function's extremes between these fractions of its value at lag 0 are fitted
#: (above: the bell's truncation still shapes it; below: noise)
ENVELOPE = (0.1, 0.9)
#: segments of the record each analysed alike: the scatter gives the standard errors
SEGMENTS = 4


#: lines per frequency of the lowest mode: the spectrum's resolution is f1 / this (a bell of 1 %
#: damping, 2 zeta f1 wide, then spans 4 lines)
LINES_PER_F1 = 200


def resolution_segment(f1: float, fs: float, n: int) -> int:
    """Welch segment length (a power of 2) for lines f1 / ``LINES_PER_F1`` apart, but at least 15
    half-overlapping segments in the record's ``n`` samples (the spectrum's own scatter)."""
    want = 2 ** int(np.round(np.log2(LINES_PER_F1 * fs / f1)))
    return int(max(64, min(want, 2 ** int(np.floor(np.log2(n / 8))))))


def spectral_matrix(y: np.ndarray, fs: float, nperseg: int) -> tuple[np.ndarray, np.ndarray]:
    """One-sided cross-spectral density matrix (lines x outputs x outputs, unit^2/Hz) by Welch's
    method: Hann windows, half overlapping, each segment's mean removed. ``y``: samples x outputs
    (a 1-D signal is one output)."""
    # 0 was a slice step of zero, 1 a segment without a window
    nperseg = arguments.whole("spectral_matrix", "nperseg", nperseg, low=2)
    fs = arguments.real("spectral_matrix", "fs", fs, positive=True)
    try:
        y = np.asarray(y, dtype=float)
    except (TypeError, ValueError):
        arguments.refuse("spectral_matrix", "y", y, "numbers, samples x outputs")
    shape = y.shape
    y = y[:, None] if y.ndim == 1 else y  # a 1-D signal gave numpy's AxisError
    if y.ndim != 2 or y.shape[0] < 2 or y.shape[1] < 1:
        raise ConfigError(f"spectral_matrix: 'y' must be samples x outputs (2 or more samples), got an array of "
                          f"shape {shape}")
    nperseg = int(min(nperseg, y.shape[0]))
    step = nperseg // 2
    seg = np.lib.stride_tricks.sliding_window_view(y, nperseg, axis=0)[::step]  # segs x outputs x nperseg
    w = scipy.signal.get_window("hann", nperseg)
    X = np.fft.rfft((seg - seg.mean(axis=2, keepdims=True)) * w, axis=2)  # segs x outputs x lines
    Xf = X.transpose(2, 1, 0)  # lines x outputs x segs
    G = Xf @ Xf.conj().transpose(0, 2, 1) / (fs * (w @ w) * seg.shape[0])
    G[1:] *= 2  # one-sided: all but 0 Hz (and Nyquist, for an even length) carry both signs
    if nperseg % 2 == 0:
        G[-1] /= 2
    return np.fft.rfftfreq(nperseg, 1 / fs), G


def first_singular(G: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per line the largest singular value of the Hermitian G and its singular vector."""
    s, u = np.linalg.eigh(G)
    return s[:, -1], u[:, :, -1]


def _mac_vec(a: np.ndarray, U: np.ndarray) -> np.ndarray:
    """MAC of vector a with each row of U."""
    return np.abs(U.conj() @ a) ** 2 / (np.sum(np.abs(U) ** 2, axis=1) * np.vdot(a, a).real)


def spectral_peaks(freq: np.ndarray, s1: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    """Indices of the first singular value's peaks inside ``band`` that stand ``PEAK_PROMINENCE``
    (log10) above their surroundings."""
    inside = np.flatnonzero((freq >= band[0]) & (freq <= band[1]) & (freq > 0))
    if inside.size < 3:
        return np.array([], dtype=int)
    level = np.log10(np.maximum(s1[inside], np.finfo(float).tiny))
    idx, _ = scipy.signal.find_peaks(level, prominence=PEAK_PROMINENCE)
    return inside[idx]


def efdd_peak(freq: np.ndarray, s1: np.ndarray, u1: np.ndarray, ip: int) -> tuple[float, float, np.ndarray, int, int]:
    """Frequency (Hz), damping ratio and shape (first singular vector at the peak) of the mode
    whose bell peaks at line ``ip``, and the bell's first and last line; nan where the
    correlation function has fewer than 3 extremes to fit."""
    lo = hi = ip
    while lo > 1 and _mac_vec(u1[ip], u1[lo - 1:lo])[0] >= BELL_MAC:
        lo -= 1
    while hi < freq.size - 2 and _mac_vec(u1[ip], u1[hi + 1:hi + 2])[0] >= BELL_MAC:
        hi += 1
    bell = np.zeros_like(s1)
    bell[lo:hi + 1] = s1[lo:hi + 1]
    r = np.fft.irfft(bell)
    r = r[: r.size // 2] / r[0]
    dt = 1.0 / (2 * (freq.size - 1) * (freq[1] - freq[0]))
    # zero crossings (linear interpolation); an extreme's size is the largest |r| between two
    k = np.flatnonzero(np.sign(r[:-1]) * np.sign(r[1:]) < 0)
    nan = (float("nan"), float("nan"), u1[ip], lo, hi)
    if k.size < 4:
        return nan
    t0 = (k + r[k] / (r[k] - r[k + 1])) * dt
    amp = np.maximum.reduceat(np.abs(r), k + 1)[:-1]
    t_ext = 0.5 * (t0[:-1] + t0[1:])
    low = np.flatnonzero(amp < ENVELOPE[0])
    n_use = low[0] if low.size else amp.size  # up to the first extreme in the noise
    use = np.flatnonzero(amp[:n_use] <= ENVELOPE[1])
    if use.size < 3:
        return nan
    crossings = t0[: use[-1] + 2]
    wd = np.pi / np.polyfit(np.arange(crossings.size), crossings, 1)[0]
    sigma = -np.polyfit(t_ext[use], np.log(amp[use]), 1)[0]
    wn = np.hypot(wd, sigma)
    return float(wn / (2 * np.pi)), float(sigma / wn), u1[ip], lo, hi


def _modes(freq: np.ndarray, s1: np.ndarray, u1: np.ndarray, band: tuple[float, float]) -> list[tuple]:
    """EFDD of every prominent peak, highest first; a peak inside a higher one's bell is that
    mode's, not another."""
    taken: list[tuple] = []
    for ip in sorted(spectral_peaks(freq, s1, band), key=lambda i: -s1[i]):
        if any(m[3] <= ip <= m[4] for m in taken):
            continue
        taken.append(efdd_peak(freq, s1, u1, ip))
    return sorted((m for m in taken if np.isfinite(m[0])), key=lambda m: m[0])


@dataclass(frozen=True)
class FddResult:
    """EFDD modes, ascending: frequencies (Hz), damping ratios, their standard errors from the
    scatter over ``SEGMENTS`` segments (inf when fewer than two segments show the peak), shapes
    (outputs x modes, complex, in the data's units, largest entry 1), the line spacing and the
    first singular value spectrum they came from."""

    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    frequency_std_hz: np.ndarray
    damping_std: np.ndarray
    shapes: np.ndarray
    resolution_hz: float
    freq: np.ndarray
    s1: np.ndarray


def efdd(y: np.ndarray, fs: float, band: tuple[float, float], nperseg: int) -> FddResult:
    """EFDD modes of the responses ``y`` (samples x outputs) on ``band`` (Hz): every prominent peak
    of the first singular value (``spectral_peaks``) is a mode, identified by ``efdd_peak``."""
    from odsuite.analysis.modal import normalise_shapes

    y = np.asarray(y, dtype=float)
    if y.shape[0] < 2 * nperseg:
        raise ConfigError(f"FDD: the record's {y.shape[0]} samples hold fewer than two segments of {nperseg}")
    freq, G = spectral_matrix(y, fs, nperseg)
    s1, u1 = first_singular(G)
    found = _modes(freq, s1, u1, band)
    f = np.array([m[0] for m in found])
    z = np.array([m[1] for m in found])
    shapes = np.array([m[2] for m in found]).T.reshape(y.shape[1], len(found))
    # the same modes in each segment (nearest within 5 %): batch-means standard errors
    n = y.shape[0] // SEGMENTS
    per_f = [[] for _ in f]
    per_z = [[] for _ in f]
    if n >= 2 * nperseg:
        for s in range(SEGMENTS):
            fq, Gs = spectral_matrix(y[s * n:(s + 1) * n], fs, nperseg)
            seg = _modes(fq, *first_singular(Gs), band)
            fseg = np.array([m[0] for m in seg])
            for r, f0 in enumerate(f):
                if fseg.size and np.min(np.abs(fseg - f0)) <= 0.05 * f0:
                    j = int(np.argmin(np.abs(fseg - f0)))
                    per_f[r].append(seg[j][0])
                    per_z[r].append(seg[j][1])
    f_std = np.array([np.std(v, ddof=1) / np.sqrt(len(v)) if len(v) > 1 else np.inf for v in per_f])
    z_std = np.array([np.std(v, ddof=1) / np.sqrt(len(v)) if len(v) > 1 else np.inf for v in per_z])
    return FddResult(f, z, f_std, z_std, normalise_shapes(shapes) if f.size else shapes,
                     float(freq[1] - freq[0]), freq, s1)
