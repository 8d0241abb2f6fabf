"""The colour of the sensors' own noise: how its density rises at low frequency (an IEPE
accelerometer's noise rises as 1/f below 100-300 Hz), measured on the samples before the hit.

The noise floor simulates the sensors' noise white at the quiet samples' level. Where the noise
rises at low frequency, a perfect model's residual in the low bands is then many times its floor
there (and a little below it at high frequency). This module fits, per sensor and pooled over
the experiments, a density ``white + rise f^-exponent`` to the periodograms of the quiet samples
before the hit (raw volts, less an offset, hum and a line fitted on them: no filter has rung there), and
keeps the rise only where a likelihood-ratio test against white noise says it is there. Each line
is divided by the share of a white noise's energy the fitted disturbances and the detrend leave
there (white_share), and lines left with less than half of it are not used: on a short stretch the
hum's sinusoids take most of the lines beside 50, 100 and 150 Hz.

Only the samples before the hit: a quiet tail after the response may still hold a mode ringing,
which rises at low frequency too, and taken for noise it raised the floor where a softer mount
shows (on white-noise records hit at 5-10 N, a rise was found on 24 of 150 sensors from the
tails, 5 of 150 from their lines above 20 Hz, 2 in 1000 white sensors from samples before a hit;
a softer mount's 12.5-25 Hz cells at 1.46x their limit fell to 0.84x). Nor a band of noise the
tails show together: records with no samples before their hit have only their tails, and there
the modes still ringing raised the floor where a softer mount shows (two of 20 recorded so, hit at
10 N, 8.4-17.5x their noise, read "nothing to explain").

The floor's sensor-noise lines are multiplied by the fitted density over its mean (the quiet
samples' level is that mean), never by less than one: a colour the fit gets a little wrong
lowers no floor. Below the first line before the hit the fitted law is carried down, to the first
line of the longest quiet stretch (below it nothing is judged). A bump of noise (30-60 Hz) is
fitted as a rise too, and carried down it raises the floor below the bump where the noise is
white.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.signal
import scipy.stats

from odsuite.analysis.disturbances import disturbance_basis

#: exponents of the rise tried (density ~ f^-exponent): 1/f noise, and slower and faster rises
EXPONENTS = (0.5, 1.0, 1.5, 2.0)
#: lines fitted: up to this fraction of the sampling rate (above it the converter's anti-alias
#: filter shapes an analog noise, which the simulated noise does not follow)
TOP_FRACTION = 1.0 / 8.0
#: each record's lines are taken relative to their mean from this fraction of the sampling rate
#: to TOP_FRACTION (where a rise below 200 Hz has faded, at rates from 3 kHz)
REFERENCE = 1.0 / 16.0
#: fewest samples before the hit that count (8 lines from REFERENCE to TOP_FRACTION)
MIN_SAMPLES = 128
#: lines left out of the fit where the fitted disturbances and the detrend take more than half of a
#: white noise's energy there (the rest is divided by its share: see white_share)
LEAST_SHARE = 0.5
#: a rise is kept when the likelihood ratio against white noise exceeds chi-square with two degrees
#: of freedom (the rise and its exponent) at this probability
COLOUR_FALSE_ALARM = 0.01


@dataclass(frozen=True)
class Colour:
    """A sensor's noise density relative to its quiet level: white + rise f^-exponent, times
    ``excess`` in the bands (lo, hi, factor) where the lines before the hit hold more than that law
    (a noise band, such as a floor's vibration at 8-40 Hz, which no rise holds: shared_excess)."""

    white: float
    rise: float
    exponent: float
    excess: tuple[tuple[float, float, float], ...] = ()
    # measured against the floor's own level (tail_excess), not against the lines' mean
    floor_relative: bool = False

    def law(self, f: np.ndarray) -> np.ndarray:
        f = np.asarray(f, float)
        return self.white + self.rise * np.power(np.where(f > 0, f, np.inf), -self.exponent)

    def density(self, f: np.ndarray) -> np.ndarray:
        f = np.asarray(f, float)
        out = self.law(f)
        for lo, hi, factor in self.excess:
            out = np.where((f >= lo) & (f < hi), out * factor, out)
        return out


def quiet_stretches(exp, shortest: int = MIN_SAMPLES) -> list[tuple[int, int]]:
    """The quiet stretches of a PreparedExperiment that hold at least ``shortest`` samples: before
    the hit (less a guard) and the tail after the response has died into the noise (their
    lengths resolve the floor's bands: noise_floor.resolves_band)."""
    out = [(0, int(exp.quiet_before))]
    if 0 <= exp.quiet_tail < exp.n_samples:
        out.append((int(exp.quiet_tail), exp.n_samples))
    return [(a, b) for a, b in out if b - a >= shortest]


def has_pre_hit_lines(exp) -> bool:
    """Whether enough quiet samples precede the hit to tell the noise's colour (pre_hit_lines)."""
    return int(exp.quiet_before) >= MIN_SAMPLES


def pre_hit_lines(exp) -> tuple[np.ndarray, np.ndarray] | None:
    """Frequencies (Hz) and periodogram lines (lines x sensors) of the quiet samples before the
    hit of a PreparedExperiment (raw volts, less an offset, hum and a line fitted on them alone), over their
    mean between REFERENCE and TOP_FRACTION of the sampling rate (the same frequencies for every
    record, whatever its length; NaN where a sensor reads one code); None when fewer than
    MIN_SAMPLES precede the hit."""
    if not has_pre_hit_lines(exp):
        return None
    end = int(exp.quiet_before)
    share = white_share(exp)
    x = np.asarray(exp.volts[:end], float)
    # samples that read one converter code (the noise below a code) tell nothing of the colour:
    # they are left out (less the fitted disturbances their lines are rounding residue, and as
    # zeros they read as a density far below the other records')
    still = np.ptp(x, axis=0) == 0
    if exp.volts_disturbance is not None:
        # refitted on these samples alone: the record's fit weighs its quiet tail too, where a mode
        # still ringing near the mains frequency puts into these samples a sinusoid that is not
        # there (white two-body records: their 61 Hz line at 1.86x its neighbours; divided by its
        # share, a rise on 4 of 18 white sensors)
        basis = _stretch_basis(exp, 0, end)
        x = x - basis @ np.linalg.lstsq(basis, x, rcond=None)[0]
    x = scipy.signal.detrend(x, axis=0, type="linear")
    f = np.fft.rfftfreq(end, 1.0 / exp.fs)
    keep = (f > 0) & (f <= TOP_FRACTION * exp.fs) & (share >= LEAST_SHARE)
    spec = np.abs(np.fft.rfft(x, axis=0)) ** 2 / np.where(share > 0, share, 1.0)[:, None]
    ref = np.mean(spec[keep & (f > REFERENCE * exp.fs)], axis=0)
    return f[keep], spec[keep] / np.where(still | (ref <= 0), np.nan, ref)


def usable_lines(exp) -> np.ndarray | None:
    """The frequencies (Hz, above zero) of the lines of the periodogram of the samples before the
    hit that tell the noise's density (white_share at least LEAST_SHARE): the bands the floor's
    colour is known in (noise_floor.witnesses); None when fewer than MIN_SAMPLES precede the hit."""
    end = int(exp.quiet_before)
    return None if end < MIN_SAMPLES else usable_stretch_lines(exp, 0, end)


def usable_stretch_lines(exp, start: int, end: int) -> np.ndarray:
    """usable_lines of the quiet samples ``start:end`` (a record's tail after the response: the
    noise's witness where no record has samples before its hit)."""
    f = np.fft.rfftfreq(end - start, 1.0 / exp.fs)
    return f[(f > 0) & (white_share(exp, start, end) >= LEAST_SHARE)]


def _stretch_basis(exp, start: int, end: int) -> np.ndarray:
    """The disturbances split_noise fits (offset, line, the mains hum and its harmonics), on the
    samples ``start:end``."""
    basis = disturbance_basis(int(exp.n_samples), exp.fs, (exp.hum_hz,) if exp.hum_harmonics else (),
                              max(exp.hum_harmonics, 1))
    return basis[start:end]


def white_share(exp, start: int = 0, end: int | None = None) -> np.ndarray:
    """Per line of the periodogram of the samples ``start:end`` (default: those before the hit,
    pre_hit_lines), the share of a white noise's energy there that is left once the disturbances
    (offset, line, mains hum and harmonics, as split_noise fits them, on these samples alone) and
    the detrend are taken out.
    On 128 samples at 2048 Hz the hum's sinusoids at 50, 100 and 150 Hz took 95, 82 and 63 % of
    the 48, 96 and 144 Hz lines: read as the noise's own, a rise of 1/f with a 196 Hz corner was not
    found (likelihood ratio 5.1 for a limit of 9.2).
    For white noise the residual's covariance is sigma^2 D (I - B G B^T) D (B the basis on these
    samples, G the inverse of its Gram matrix, D the detrend), so the share of line k is
    (|D e_k|^2 - (B^T D e_k)^H G (B^T D e_k)) / samples, by FFTs."""
    end = int(exp.quiet_before) if end is None else end
    m = end - start
    t = np.arange(m, dtype=float)
    q, _ = np.linalg.qr(np.column_stack([np.ones(m), t - t.mean()]))
    qa = np.fft.rfft(q, axis=0)  # Q^T e_k, lines x 2
    left = m - np.sum(np.abs(qa) ** 2, axis=1)
    if getattr(exp, "volts_disturbance", None) is not None:
        bp = _stretch_basis(exp, start, end)
        gram = np.linalg.pinv(bp.T @ bp)
        bd = np.fft.rfft(bp, axis=0) - qa @ (q.T @ bp)  # B^T D e_k, lines x columns
        left = left - np.real(np.einsum("ki,ij,kj->k", bd.conj(), gram, bd))
    return np.maximum(left, 0.0) / m


def _nll(mu: np.ndarray, r: np.ndarray) -> float:
    # periodogram lines are exponential about their density
    return float(np.sum(np.log(mu) + r / mu))


def _fit_law(x: np.ndarray, r: np.ndarray, iterations: int = 40) -> tuple[float, float]:
    """Maximum likelihood of white + rise x for exponential lines ``r``: the score equations are
    least squares weighted by 1 / density^2, iterated (a few milliseconds where a general
    minimiser took a tenth of a second per sensor, on every floor)."""
    level = float(np.mean(r))
    white, rise = 0.5 * level, 0.5 * level / float(x.max())
    for _ in range(iterations):
        w = 1.0 / (white + rise * x) ** 2
        sw, sx, sxx, sr, sxr = np.sum(w), w @ x, w @ (x * x), w @ r, w @ (x * r)
        det = sw * sxx - sx * sx
        new_white, new_rise = (sxx * sr - sx * sxr) / det, (sw * sxr - sx * sr) / det
        if new_rise <= 0.0:  # no rise: white at the lines' mean
            return level, 0.0
        new_white = max(new_white, 1e-6 * level)
        done = abs(new_white - white) <= 1e-6 * level and abs(new_rise - rise) <= 1e-6 * abs(rise)
        white, rise = new_white, new_rise
        if done:
            break
    return white, rise


def fit(f: np.ndarray, r: np.ndarray) -> Colour | None:
    """The density white + rise f^-exponent that fits the lines ``r`` at ``f`` best (maximum
    likelihood); None unless it beats white noise by the likelihood-ratio test."""
    ok = np.isfinite(r) & (f > 0)
    f, r = f[ok], r[ok]
    if len(r) < 8 or np.mean(r) <= 0:
        return None
    flat = _nll(np.full(len(r), np.mean(r)), r)
    best, best_nll = None, flat
    for a in EXPONENTS:
        x = f ** -a
        white, rise = _fit_law(x, r)
        if rise <= 0.0:
            continue
        nll = _nll(white + rise * x, r)
        if nll < best_nll:
            best, best_nll = Colour(white, rise, a), nll
    if best is None or 2.0 * (flat - best_nll) <= scipy.stats.chi2.isf(COLOUR_FALSE_ALARM, 2):
        return None
    return best


def shared_excess(sensors: Mapping[str, tuple[np.ndarray, np.ndarray, Colour]],
                  bands: Sequence[tuple[float, float]]) -> dict[str, tuple[tuple[float, float, float], ...]]:
    """Per sensor, the bands (lo, hi, factor) where the lines before the hit hold more than its
    law (``sensors``: name -> lines' frequencies, lines, law) gives: a band of noise that no rise
    holds, such as a floor's vibration at 8-40 Hz, which every sensor feels. A band is tested on
    every sensor's lines pooled: 2 sum(r / law) beyond chi-square with two degrees of freedom per
    line at COLOUR_FALSE_ALARM shared over the bands that hold lines (one sensor's one or two lines
    in a band are too few: tested alone at that rate a band of 3-10x its law was missed on most
    sensors, and taken without a test their scatter lowered white-noise sensitivity: a softer
    mount's 20-40 Hz cell fell from 1.17x its limit to below it). Where the pooled lines hold it,
    each sensor's factor is its own lines' sum over its law's, at least the pooled one."""
    return {name: tuple(v) for name, v in _band_excess(
        {name: (f, r, law.law(f), np.zeros(len(f))) for name, (f, r, law) in sensors.items()}, bands).items()}


def _band_excess(sensors: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
                 bands: Sequence[tuple[float, float]]) -> dict[str, list[tuple[float, float, float]]]:
    """shared_excess's test and factors on lines ``got`` against an expectation in two parts, the
    sensor's noise and the rest (name -> frequencies, got, noise, rest): a band is held where
    2 sum(got / expected) over every sensor's lines in it passes chi-square at COLOUR_FALSE_ALARM
    shared over the bands that hold lines; each sensor's factor on its noise there is what its
    lines leave above the rest over its noise's part, at least the pooled ratio."""
    held = []
    for lo, hi in bands:
        stat = dof = got_all = expected_all = 0.0
        own = {}
        for name, (f, got, noise, rest) in sensors.items():
            m = (f >= lo) & (f < hi) & np.isfinite(got) & (noise + rest > 0)
            if not m.any():
                continue
            stat += 2.0 * float(np.sum(got[m] / (noise[m] + rest[m])))
            dof += 2.0 * int(m.sum())
            got_all += float(np.sum(got[m]))
            expected_all += float(np.sum(noise[m] + rest[m]))
            if np.sum(noise[m]) > 0:
                own[name] = float((np.sum(got[m]) - np.sum(rest[m])) / np.sum(noise[m]))
        if dof:
            held.append((lo, hi, stat, dof, got_all / expected_all, own))
    out: dict[str, list[tuple[float, float, float]]] = {}
    for lo, hi, stat, dof, pooled, own in held:
        if stat > scipy.stats.chi2.isf(COLOUR_FALSE_ALARM / len(held), dof):
            for name, ratio in own.items():
                factor = max(pooled, ratio)
                if factor > 1.0:
                    out.setdefault(name, []).append((float(lo), float(hi), factor))
    return out


def tail_excess(sensors: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
                bands: Sequence[tuple[float, float]]) -> dict[str, Colour]:
    """Per sensor, the bands where a model's residual on the records' quiet tails holds more than the
    floor expects there, as a colour measured against the floor's own level (``sensors``: name ->
    the tails' lines (Hz), the residual's energy on each, and the floor's expected energy there:
    its sensor-noise part and the rest, hum and the force channel's noise). For records with no
    samples before their hit: the residual, not the records, as a mode still ringing in a tail is
    the model's to predict; but a model error that lasts into the tails shows alike (a softer
    mount's ringing), so only diagnose's verdict weighs it, where nothing explains the cells. Each
    band is tested as shared_excess tests it (every sensor's lines pooled, residual over expected,
    chi-square at COLOUR_FALSE_ALARM shared over the bands); where held, a sensor's factor on its
    noise is what its lines leave above the rest over its noise's part, at least the pooled ratio."""
    return {name: Colour(1.0, 0.0, 0.0, tuple(v), floor_relative=True)
            for name, v in _band_excess(sensors, bands).items()}


def by_sensor(exps: Sequence, bands: Sequence[tuple[float, float]] = ()) -> dict[str, Colour]:
    """Per sensor name, its noise's colour from every experiment's samples before the hit (pooled:
    the colour is the sensor's), with the excess over it in ``bands`` that every sensor's lines
    together show (shared_excess); sensors whose noise is white are left out."""
    pooled: dict[str, tuple[list, list]] = {}
    for e in exps:
        lines = pre_hit_lines(e)
        if lines is None:
            continue
        f, r = lines
        for j, s in enumerate(e.sensors):
            fs_, rs = pooled.setdefault(s.name, ([], []))
            fs_.append(f)
            rs.append(r[:, j])
    laws = {}
    for name, (fs_, rs) in pooled.items():
        f, r = np.concatenate(fs_), np.concatenate(rs)
        ok = np.isfinite(r) & (f > 0)
        if ok.sum() < 8 or not np.mean(r[ok]) > 0:
            continue
        colour = fit(f, r)
        laws[name] = (f, r, colour if colour is not None else Colour(float(np.mean(r[ok])), 0.0, 0.0))
    excess = shared_excess(laws, bands)
    out = {}
    for name, (_, _, law) in laws.items():
        if law.rise > 0.0 or name in excess:
            out[name] = Colour(law.white, law.rise, law.exponent, excess.get(name, ()))
    return out


def gains(colours: Mapping[str, Colour], exp, f: np.ndarray, longest: int | None = None) -> np.ndarray | None:
    """Per frequency ``f`` (Hz) and sensor of ``exp``, the factor on its white noise's density:
    the fitted density over its mean between the first line its longest quiet stretch shows and
    Nyquist (the quiet samples' variance is about that mean), at least one; None when every
    sensor's noise is white. ``longest``: the longest quiet stretch (samples) of the records the
    colour was pooled over, where not ``exp``'s own."""
    if not any(s.name in colours for s in exp.sensors):
        return None
    if longest is None:
        longest = max((b - a for a, b in quiet_stretches(exp)), default=exp.n_samples)
    seen = np.fft.rfftfreq(longest, 1.0 / exp.fs)[1:]
    # below the first line any quiet stretch shows no band is judged: the law is not carried
    # there (a 1/f^2 law gave 2.5-5 Hz factors of 10-213, raising the floor's pooled energy,
    # the scale of every test, for nothing)
    at = np.maximum(np.asarray(f, float), seen[0] if seen.size else 0.0)
    out = np.ones((len(f), len(exp.sensors)))
    for j, s in enumerate(exp.sensors):
        c = colours.get(s.name)
        if c is not None:
            level = 1.0 if c.floor_relative else np.mean(c.density(seen))
            out[:, j] = np.maximum(1.0, c.density(at) / level)
    out[np.asarray(f) <= 0] = 1.0
    return out
