"""Frequency response functions from hammer hits: H1, H2 and Hv with coherence, averaged over hits
(and over experiments with the same force point: pass all their hits together).

Spectra are one-sided ``numpy.fft.rfft`` of each record; the FRF of response o to the force is
complex, in (response unit)/(force unit), e.g. ``(m/s^2)/N``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from odsuite.domain import arguments
from odsuite.domain.display import ascii_unit
from odsuite.domain.errors import ConfigError, DimensionError
from odsuite.domain.systeminfo import SENSOR_UNITS

ESTIMATORS = ("H1", "H2", "Hv")
#: units a force record may be in (the FRF's unit is the response's over it)
FORCE_UNITS = ("N", "kN", "mN", "lbf")
#: SI units a response record may be in: a sensor type's (the trend correction needs m/s^2 as
#: such, and a g or mm/s would be stored as if SI)
RESPONSE_UNITS = tuple(dict.fromkeys(unit for _, unit in SENSOR_UNITS.values()))
#: power of (i omega) that turns a receptance (displacement/force) into each FRF form
FORM_POWER = {"receptance": 0, "mobility": 1, "accelerance": 2}
#: an FRF line counts as determined by the record where the records' straight-line trends leak
#: at most this share of its magnitude into it (see ``FrfSet.trend``)
TREND_SHARE = 1 / 3
#: with the records' straight lines removed, the first line kept: a sine of k cycles in the record
#: correlates 0.78/k with a straight line, so from 3 cycles on the removal takes below TREND_SHARE
TREND_FREE_LINE = 3


@dataclass(frozen=True)
class FrfSet:
    """FRFs of several responses to one force: ``H`` and ``coherence`` are outputs x frequencies."""

    frequency: np.ndarray  # Hz
    H: np.ndarray  # complex
    coherence: np.ndarray
    estimator: str
    units: list[str]  # per output, e.g. "(m/s^2)/N"
    output_names: list[str]
    n_averages: int
    force_autospectrum: np.ndarray | None = None  # |F|^2 per hit, averaged (N^2); None when unknown
    #: the part of H the acceleration records' least-squares straight lines make (outputs x f; 0 for
    #: other responses): a structure back at rest where it started has acceleration integrating to
    #: zero velocity and displacement change, so no straight-line part, and an offset or a drift of
    #: the sensor leaks through a record that does not end where it began as 1/f into the lowest
    #: lines; None when unknown
    trend: np.ndarray | None = None

    def detrended(self) -> FrfSet:
        """H1 of the records with their straight lines removed: ``H - trend`` (H1 is linear in the
        response). Determined from line ``TREND_FREE_LINE`` up; the coherence is the estimate's."""
        if self.trend is None or self.estimator != "H1":
            raise ConfigError(f"{self.estimator} FRFs: the straight-line trend is known only for H1 with its records")
        return FrfSet(self.frequency, self.H - self.trend, self.coherence, self.estimator, self.units,
                      self.output_names, self.n_averages, self.force_autospectrum, np.zeros_like(self.trend))

    def determined_from(self, outputs: Sequence[str] | None = None, runs: int = 3) -> float:
        """The lowest frequency (Hz) from which the trend leaks at most ``TREND_SHARE`` of |H| into
        ``runs`` lines in a row, for every one of ``outputs`` (default all): below it the lowest
        lines show the drift, not the structure. The first line above 0 Hz when the trend is unknown."""
        pos = np.flatnonzero(self.frequency > 0)
        if self.trend is None or not pos.size:
            return float(self.frequency[pos[0]]) if pos.size else 0.0
        rows = [self.output_names.index(n) for n in (outputs if outputs is not None else self.output_names)]
        with np.errstate(divide="ignore", invalid="ignore"):
            ok = np.all(np.abs(self.trend[rows][:, pos]) <= TREND_SHARE * np.abs(self.H[rows][:, pos]), axis=0)
        run = np.convolve(ok.astype(int), np.ones(runs, int), mode="valid") == runs
        first = int(np.argmax(run)) if run.any() else pos.size - 1
        return float(self.frequency[pos[first]])

    def band(self, f_low: float, f_high: float) -> FrfSet:
        """The lines with f_low <= f <= f_high."""
        keep = (self.frequency >= f_low) & (self.frequency <= f_high)
        if keep.sum() < 2:
            raise ConfigError(f"band {f_low}..{f_high} Hz holds fewer than 2 frequency lines")
        gff = None if self.force_autospectrum is None else self.force_autospectrum[keep]
        trend = None if self.trend is None else self.trend[:, keep]
        return FrfSet(
            self.frequency[keep], self.H[:, keep], self.coherence[:, keep], self.estimator,
            self.units, self.output_names, self.n_averages, gff, trend,
        )


def spectra(
    forces: Sequence[np.ndarray], responses: Sequence[np.ndarray], window: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Averaged auto and cross spectra over hits: Gff (f), Gxx (o x f), Gfx = sum conj(F) X
    (o x f) and the number of hits. ``window`` (samples, or samples x (1 + outputs) with the force
    window first) multiplies each record before the FFT."""
    if len(forces) != len(responses) or len(forces) == 0:  # an array of hits has no truth value
        raise DimensionError(f"{len(forces)} force records but {len(responses)} response records")
    n = np.asarray(forces[0]).shape[0]
    gff = 0.0
    gxx = 0.0
    gfx = 0.0
    for k, (f, x) in enumerate(zip(forces, responses, strict=True)):
        f = np.asarray(f, dtype=float)
        x = np.asarray(x, dtype=float)
        x = x[:, None] if x.ndim == 1 else x
        if f.shape != (n,) or x.shape[0] != n:
            raise DimensionError(
                f"hit {k}: force {f.shape} and response {x.shape} records must all have {n} samples"
            )
        if window is not None:
            w = np.asarray(window, dtype=float)
            wf, wx = (w, w[:, None]) if w.ndim == 1 else (w[:, 0], w[:, 1:])
            f, x = f * wf, x * wx
        F = np.fft.rfft(f)
        X = np.fft.rfft(x, axis=0).T
        gff = gff + np.abs(F) ** 2
        gxx = gxx + np.abs(X) ** 2
        gfx = gfx + np.conj(F) * X
    return np.asarray(gff), np.asarray(gxx), np.asarray(gfx), np.asarray(len(forces))


def _trend_cross(forces: Sequence[np.ndarray], responses: Sequence[np.ndarray], window: np.ndarray | None,
                 acceleration: np.ndarray) -> np.ndarray:
    """sum conj(F) T over hits (o x f), T the spectrum of each acceleration record's least-squares
    straight line (windowed like the record); 0 for the other responses."""
    lines = []
    for x in responses:
        x = np.asarray(x, dtype=float)
        x = x[:, None] if x.ndim == 1 else x
        t = np.linspace(-1.0, 1.0, x.shape[0])
        basis = np.column_stack([np.ones_like(t), t])
        lines.append(basis @ np.linalg.lstsq(basis, x, rcond=None)[0] * acceleration[None, :])
    return spectra(forces, lines, window)[2]


def estimate_frf(
    forces: Sequence[np.ndarray],
    responses: Sequence[np.ndarray],
    fs: float,
    *,
    estimator: str = "H1",
    window: np.ndarray | None = None,
    force_unit: str = "N",
    response_units: Sequence[str] | None = None,
    output_names: Sequence[str] | None = None,
) -> FrfSet:
    """FRFs of every response to the force, averaged over the given hits (equal-length records;
    as arrays, one hit's 1-D force or a 2-D array of hits: ``_hits``).

    H1 = Gfx/Gff (noise on the response), H2 = Gxx/Gxf (noise on the force), Hv the total-least-
    squares estimate between them; coherence = |Gfx|^2/(Gff Gxx). ``response_units``: one of
    ``RESPONSE_UNITS`` per output, in any spelling ``display.ascii_unit`` reads (m/s2, m/s²)."""
    if estimator not in ESTIMATORS:
        raise ConfigError(f"FRF estimator {estimator!r} is not one of {', '.join(ESTIMATORS)}")
    forces, responses = _hits(forces, responses)
    response_units = _check_arguments(forces, responses, fs, window, force_unit, response_units)
    gff, gxx, gfx, count = spectra(forces, responses, window)
    n = np.asarray(forces[0]).shape[0]
    tiny = np.finfo(float).tiny
    with np.errstate(divide="ignore", invalid="ignore"):
        if estimator == "H1":
            H = gfx / np.maximum(gff, tiny)
        elif estimator == "H2":
            H = gxx / np.conj(gfx)
        else:
            H = (gxx - gff + np.sqrt((gff - gxx) ** 2 + 4 * np.abs(gfx) ** 2)) / (2 * np.conj(gfx))
        coh = np.abs(gfx) ** 2 / (gff * gxx)
    H = np.where(np.isfinite(H), H, 0)
    coh = np.where(np.isfinite(coh), coh, 0)
    n_out = gxx.shape[0]
    runits = list(response_units) if response_units is not None else ["m/s^2"] * n_out
    acceleration = np.array([u == "m/s^2" for u in runits], dtype=float) if len(runits) == n_out else None
    trend = None
    if acceleration is not None and acceleration.any():
        trend = _trend_cross(forces, responses, window, acceleration) / np.maximum(gff, tiny)
    names = list(output_names) if output_names is not None else [f"response {k}" for k in range(n_out)]
    if len(runits) != n_out or len(names) != n_out:
        raise DimensionError(f"{n_out} responses but {len(runits)} units and {len(names)} names")
    return FrfSet(
        frequency=np.fft.rfftfreq(n, 1.0 / fs),
        H=H,
        coherence=coh,
        estimator=estimator,
        units=[f"{_group(u)}/{_group(force_unit)}" for u in runits],
        output_names=names,
        n_averages=int(count),
        force_autospectrum=gff / count,
        trend=trend,
    )


def _hits(forces: Any, responses: Any) -> tuple[Any, Any]:
    """estimate_frf's records as lists of hits where they come as arrays: a 1-D force is one hit
    (its response: samples, or samples x outputs), a 2-D one hits x samples (responses: hits x
    samples, or hits x samples x outputs). Lists pass as they are."""
    if not isinstance(forces, np.ndarray):
        return forces, responses
    if forces.ndim not in (1, 2):
        raise ConfigError(f"estimate_frf: 'forces' must be a list of records, one per hit (or an array: samples, "
                          f"or hits x samples), got an array of shape {forces.shape}")
    one = forces.ndim == 1
    expected = "samples (x outputs)" if one else "hits x samples (x outputs)"
    if not isinstance(responses, np.ndarray) or responses.ndim not in ((1, 2) if one else (2, 3)):
        got = f"an array of shape {responses.shape}" if isinstance(responses, np.ndarray) else arguments.shown(responses)
        raise ConfigError(f"estimate_frf: 'responses' must be an array of {expected}, as 'forces' is an array of "
                          f"{'samples' if one else 'hits x samples'}, got {got}")
    return ([forces], [responses]) if one else (list(forces), list(responses))


def _check_arguments(forces: Any, responses: Any, fs: Any, window: Any, force_unit: Any,
                     response_units: Any = None) -> list[str] | None:
    """estimate_frf's arguments before any spectrum: a rate of 0 divided by zero, a NaN one gave NaN
    frequencies, a window of another length a broadcast error, any text was taken for a force unit,
    a text of response units was split into letters and a number raised a TypeError. Returns the
    response units in their stored spelling (``display.ascii_unit``: m/s2, m/s**2, m/s² are m/s^2)."""
    for name, value in (("forces", forces), ("responses", responses)):
        if isinstance(value, str | bytes | Mapping) or not isinstance(value, Sequence | np.ndarray):
            arguments.refuse("estimate_frf", name, value, "a list of records, one per hit")
    arguments.real("estimate_frf", "fs", fs, positive=True)
    if not len(forces):
        arguments.refuse("estimate_frf", "forces", forces, "a list of records, one per hit")
    if len(responses) != len(forces):
        raise ConfigError(f"estimate_frf: 'responses' must be one record per hit, as 'forces' ({len(forces)}), "
                          f"got {len(responses)}")
    for k, f in enumerate(forces):  # an empty record reached numpy's FFT
        if np.ndim(f) != 1 or np.shape(f)[0] < 2:
            raise ConfigError(f"estimate_frf: 'forces' must be records of 2 or more samples each, got hit {k} of "
                              f"shape {np.shape(f)}")
    if force_unit not in FORCE_UNITS:
        arguments.refuse("estimate_frf", "force_unit", force_unit, f"a force unit ({', '.join(FORCE_UNITS)})")
    outputs = np.shape(responses[0])[1] if np.ndim(responses[0]) == 2 else 1
    units = None
    if response_units is not None:
        what = f"{outputs} SI units, one per response ({', '.join(RESPONSE_UNITS)})"
        listed = arguments.listed("estimate_frf", "response_units", response_units, what)
        units = [ascii_unit(u) if isinstance(u, str) else u for u in listed]
        if len(units) != outputs or not all(u in RESPONSE_UNITS for u in units):
            arguments.refuse("estimate_frf", "response_units", response_units, f"a list of {what}")
    if window is None:
        return units
    n = np.shape(forces[0])[0] if np.ndim(forces[0]) else 0
    try:
        shape = np.asarray(window, dtype=float).shape
    except (TypeError, ValueError):
        shape = None
    if shape not in ((n,), (n, 1 + outputs)):
        raise ConfigError(f"estimate_frf: 'window' must be {n} samples (or {n} x {1 + outputs}: the force's, then "
                          f"each response's), got {arguments.shown(window) if shape is None else f'shape {shape}'}")
    return units


#: The band ends where the hammer's force autospectrum has fallen this far below its low-frequency
#: level: the usual impact-testing rule is 10-20 dB; 10 dB (a third of the force amplitude) keeps
#: the response at least 10 dB above what the same noise would give at low frequency.
FORCE_DROP_DB = 10.0
#: Largest normalised random error of |H1| a line may have to count as usable, Bendat & Piersol
#: eps = sqrt(1 - coh) / (sqrt(coh) sqrt(2 n)) for n averages: 10 % keeps peak heights (and so
#: residues) within 10 % at one standard deviation.
MAX_RANDOM_ERROR = 0.1


def usable_band(
    frequency: np.ndarray,
    force_autospectrum: np.ndarray | None = None,
    coherence: np.ndarray | None = None,
    n_averages: int = 1,
) -> tuple[float, float]:
    """The band (Hz) where the measurement supports a modal fit: from the first line above 0 Hz up
    to where the force autospectrum (smoothed over 1 % of the lines) has dropped ``FORCE_DROP_DB``
    below its low-frequency level (median over the lowest 5 % of the lines); a spectrum that drops
    within fewer lines (seen first with 3-line smoothing against the lowest 4 lines) is smoothed
    over at most a tenth of them and its level taken over at most the lowest half. Narrowed to the
    lines whose coherence over ``n_averages`` hits gives a random error of at most
    ``MAX_RANDOM_ERROR`` (coherence of one hit is 1 by construction and says nothing)."""
    import scipy.ndimage

    f = np.asarray(frequency, dtype=float)
    pos = np.flatnonzero(f > 0)
    if pos.size < 4:
        raise DimensionError(f"FRFs have {pos.size} lines above 0 Hz; a band needs at least 4")
    lo_i, hi_i = int(pos[0]), int(f.size - 1)
    width = max(3, f.size // 100) | 1  # odd, so the median filter is centred
    if force_autospectrum is not None:
        gff = np.asarray(force_autospectrum, dtype=float)
        # a broad blow's spectrum can fall within the lowest 5 % of the lines (a 5 ms blow at 1 MHz:
        # 10 dB down at 200 Hz of 500 kHz), and its level there and 1 % smoothing were the noise
        # floor's: the band ran to 500 kHz. A first look on the finest windows finds the spectrum's
        # own extent, and neither window spans more than a tenth (smoothing) or a half (level) of it
        extent = _force_drop(f, gff, pos, 3, 4) - lo_i + 1
        width = min(width, max(3, extent // 10) | 1)
        hi_i = min(hi_i, _force_drop(f, gff, pos, width, min(max(4, f.size // 20), max(4, extent // 2))))
    if coherence is not None and n_averages > 1:
        coh = np.clip(np.asarray(coherence, dtype=float), 1e-12, 1.0)
        coh = coh[None, :] if coh.ndim == 1 else coh
        # a line is usable when any output measures it well (several outputs: the best one)
        eps = np.sqrt(1 - coh) / (np.sqrt(coh) * np.sqrt(2 * n_averages))
        eps = scipy.ndimage.median_filter(eps.min(axis=0), width, mode="nearest")
        good = np.flatnonzero((eps <= MAX_RANDOM_ERROR) & (f > 0))
        if good.size:
            lo_i, hi_i = max(lo_i, int(good[0])), min(hi_i, int(good[-1]))
        else:
            hi_i = lo_i
    if hi_i - lo_i < 4:
        raise ConfigError(
            f"no usable band: the force spectrum falls {FORCE_DROP_DB:g} dB or the coherence drops "
            f"below a {100 * MAX_RANDOM_ERROR:g} % random error within the first lines; give --fmin/--fmax")
    return float(f[lo_i]), float(f[hi_i])


def _force_drop(frequency: np.ndarray, gff: np.ndarray, pos: np.ndarray, width: int, lowest: int) -> int:
    """The last line before the force autospectrum, median-filtered over ``width`` lines, falls
    ``FORCE_DROP_DB`` below its median over the ``lowest`` lines above 0 Hz (``pos``); the last
    line when it never does."""
    import scipy.ndimage

    smooth = scipy.ndimage.median_filter(gff, width, mode="nearest")
    ref = np.median(smooth[pos[:lowest]])
    low = np.flatnonzero((smooth < ref * 10 ** (-FORCE_DROP_DB / 10)) & (frequency > 0))
    return int(low[0]) - 1 if low.size and ref > 0 else frequency.size - 1


def _group(unit: str) -> str:
    """Parenthesise a compound unit so it can be divided: m/s^2 -> (m/s^2), N stays N."""
    return f"({unit})" if any(c in unit for c in "/^* ") else unit


def convert_form(frequency: np.ndarray, H: np.ndarray, source: str, target: str) -> np.ndarray:
    """Convert FRFs between receptance, mobility and accelerance (multiply by (i omega)^k). Lines
    at 0 Hz become 0 when dividing."""
    for name in (source, target):
        if name not in FORM_POWER:
            raise ConfigError(f"FRF form {name!r} is not one of {', '.join(FORM_POWER)}")
    k = FORM_POWER[target] - FORM_POWER[source]
    iw = 2j * np.pi * np.asarray(frequency, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.asarray(H) * iw**k
    return np.where(np.isfinite(out), out, 0)
