"""Where the model fails, resolved: the residual's energy per experiment, channel and frequency band
(noise_floor.band_edges: octaves) against the noise floor's own energy there, so that a model error
in one band shows however quiet the rest of the record is.

A cell's ratio rho = residual energy / floor energy; with nu the floor's degrees of freedom there
(noise_floor.band_dof), nu rho is chi-square with nu degrees of freedom for a perfect model. A cell
is *above the floor* when rho exceeds its limit: ``DETECTION_TOLERANCE`` (the floor's calibration)
times the chi-square quantile at ``DETECTION_FALSE_ALARM`` shared over all cells (Bonferroni). The
model fails somewhere when any cell is above. A band the samples before the hit do not resolve
(noise_floor.witnesses, resolves_band) is not judged: its floor is the broadband level carried down to where
the noise was not seen.

A change of the model (a candidate effect) is tested by the likelihood ratio of the whitened
residual, counted only above the limits: ``excess`` = sum over cells of nu max(0, rho - limit), and
the gain excess(before) - excess(after) against chi-square with k degrees of freedom (k fitted
parameters). Below the limits a residual cannot be told from noise at the floor's calibration, so
the part there is no evidence for any change; a residual that is correlated (a few lines carry it)
counts with the fewer degrees of freedom its own spectrum has (2 (sum R)^2 / sum R^2 over the
band's lines) when they are fewer than the floor's.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.special
import scipy.stats

from odsuite.analysis.noise_floor import FLOOR_TOLERANCE, RESOLVING_LINES, NoiseFloor, band_slices, line_energies

#: probability that noise at the floor puts any cell of a comparison above its limit
DETECTION_FALSE_ALARM = 0.01
#: the floor's calibration per cell, in energy: measured on correct models of independent records
#: (thesis rig nulls with drift at 200 N and hum plus drift at 500 uV; the demo's model after both of
#: its fixes), whose cells reached up to 2.8x the chi-square limit at the pooled tolerance
#: FLOOR_TOLERANCE^2 = 1.69: three times that
DETECTION_TOLERANCE = 3.0 * FLOOR_TOLERANCE**2
#: probability that fitting a candidate's parameters to noise passes the gain test
GAIN_FALSE_ALARM = 1e-3


@dataclass
class Resolved:
    """Residual and floor energies per experiment (lists), band and channel (arrays bands x channels)."""

    experiments: list[str]
    channels: list[list[str]]
    bands: list[list[tuple[float, float]]]
    residual: list[np.ndarray]
    floor: list[np.ndarray]
    dof: list[np.ndarray]  # the floor's
    residual_dof: list[np.ndarray]  # the residual's own (its spectrum's flatness)
    limit: list[np.ndarray]  # per cell, the ratio above which it is above the floor
    # per experiment and band, the lines of the samples before the hits that measure its noise
    # (noise_floor.band_lines; None: not known)
    noise_lines: list[np.ndarray | None] | None = None
    # per cell, the limit a band no quiet sample shows would have if it were judged (inf where judged)
    unjudged_limit: list[np.ndarray] | None = None

    def ratios(self) -> list[np.ndarray]:
        return [r / np.where(f > 0, f, np.inf) for r, f in zip(self.residual, self.floor)]

    def detected(self) -> bool:
        return any(np.any(q > lim) for q, lim in zip(self.ratios(), self.limit))

    def excess(self, dof: Sequence[np.ndarray] | None = None) -> float:
        """Whitened residual above the limits: sum of nu max(0, rho - limit)."""
        dof = dof if dof is not None else self.dof
        return float(sum(np.sum(n * np.maximum(q - lim, 0.0)) for q, lim, n in zip(self.ratios(), self.limit, dof)))

    def cells(self, top: int = 8) -> list[dict[str, Any]]:
        """The cells above the floor, strongest (whitened excess) first."""
        rows = []
        lines = self.noise_lines or [None] * len(self.experiments)
        for e, chans, bands, q, lim, n, counts in zip(self.experiments, self.channels, self.bands, self.ratios(),
                                                     self.limit, self.dof, lines):
            for b, c in zip(*np.nonzero(q > lim)):
                rows.append({"experiment": e, "channel": chans[c],
                             "band_hz": [round(bands[b][0], 1), round(bands[b][1], 1)],
                             "residual_to_floor": float(np.sqrt(q[b, c])),
                             "limit": float(np.sqrt(lim[b, c])),
                             **({} if counts is None else {"noise_lines": int(counts[b])}),
                             "_excess": float(n[b, c] * (q[b, c] - lim[b, c]))})
        rows.sort(key=lambda r: -r["_excess"])
        for r in rows:
            r.pop("_excess")
        return rows[:top]

    def unjudged(self, top: int = 3) -> list[dict[str, Any]]:
        """The cells of bands no quiet sample shows (not judged: a floor's vibration or a noise
        rising there would read as a misfit) whose residual exceeds the limit they would have
        against a white floor, strongest first: what records that start at their hit cannot tell."""
        rows = []
        for e, chans, bands, q, lim in zip(self.experiments, self.channels, self.bands, self.ratios(),
                                           self.unjudged_limit or []):
            for b, c in zip(*np.nonzero(q > lim)):
                rows.append({"experiment": e, "channel": chans[c],
                             "band_hz": [round(bands[b][0], 1), round(bands[b][1], 1)],
                             "residual_to_floor": float(np.sqrt(q[b, c])), "limit": float(np.sqrt(lim[b, c]))})
        rows.sort(key=lambda r: -r["residual_to_floor"] / r["limit"])
        return rows[:top]

    def strongest(self) -> float:
        """The largest sqrt(residual / floor) energy ratio of any judged cell (a finite limit)."""
        judged = [q[np.isfinite(lim)] for q, lim in zip(self.ratios(), self.limit)]
        return float(max((np.sqrt(np.max(q)) for q in judged if q.size), default=0.0))


def judged_on_one_stretch(res: Resolved, stretches: Sequence[np.ndarray]) -> Resolved:
    """``res`` with the bands no single quiet stretch resolves (``stretches``: each one's usable
    lines, Hz, noise_floor.witnesses) not judged: their limits move to the unjudged ones. Lines
    pooled over the records' tails judge a band none of them holds a period of: 0.05 s tails at
    5120 Hz, one 20 Hz line each, measured a floor's vibration at 12.5-25 Hz as 5-20x weaker than
    the 0.4 s records hold it (their first line takes most of a slow wave as a trend)."""
    limit, unjudged = [], []
    for bands, lim, was in zip(res.bands, res.limit, res.unjudged_limit or [None] * len(res.limit)):
        shown = np.array([any(np.count_nonzero((lines >= lo) & (lines < hi)) >= RESOLVING_LINES
                              for lines in stretches) for lo, hi in bands])
        limit.append(np.where(shown[:, None], lim, np.inf))
        moved = np.where(shown[:, None], np.inf, lim)
        unjudged.append(moved if was is None else np.minimum(was, moved))
    return dataclasses.replace(res, limit=limit, unjudged_limit=unjudged)


def _per_band(e, prediction: np.ndarray, edges: Sequence[tuple[float, float]]) -> list[np.ndarray]:
    """The residual's energy per line of its spectrum (lines x channels), band by band."""
    lines = line_energies(e.measured - prediction)
    return [lines[b] for b in band_slices(e.fs, e.n_samples, edges)]


def residual_energies(exps: Sequence, predictions: Sequence[np.ndarray], floor: NoiseFloor
                      ) -> list[np.ndarray] | None:
    """``resolve(exps, predictions, floor).residual`` alone (bands x channels per experiment),
    without the degrees of freedom and limits; None where ``resolve`` is."""
    if not all(e.name in floor.bands for e in exps):
        return None
    return [np.array([b.sum(axis=0) for b in _per_band(e, p, floor.bands[e.name][0])])
            for e, p in zip(exps, predictions)]


def resolve(exps: Sequence, predictions: Sequence[np.ndarray], floor: NoiseFloor) -> Resolved | None:
    """The residual of ``predictions`` resolved against ``floor`` (estimated with ``spectra=True``);
    None when the floor has no bands for these experiments."""
    if not all(e.name in floor.bands for e in exps):
        return None
    names, chans, bands, res, flo, dof, rdof = [], [], [], [], [], [], []
    for e, p in zip(exps, predictions):
        edges, f_energy, f_dof = floor.bands[e.name]
        per_band = _per_band(e, p, edges)
        r = np.array([b.sum(axis=0) for b in per_band])
        own = np.array([2.0 * b.sum(axis=0) ** 2 / np.maximum(np.sum(b**2, axis=0), 1e-300) for b in per_band])
        names.append(e.name)
        chans.append([s.name for s in e.sensors])
        bands.append(list(edges))
        res.append(r)
        flo.append(f_energy)
        dof.append(f_dof)
        rdof.append(np.clip(own, 1.0, f_dof))
    # a band the quiet samples do not resolve has its floor carried down unseen: it is not judged
    seen = [np.broadcast_to(floor.judged(e.name, len(d))[:, None], d.shape) for e, d in zip(exps, dof)]
    n_cells = sum(int(s.sum()) for s in seen)
    alpha = DETECTION_FALSE_ALARM / max(n_cells, 1)
    witnessed = [floor.witness_lines.get(e.name) for e in exps]
    n_bands = max((int(s[:, 0].sum()) for s in seen if s.size), default=1)
    limit, unjudged = [], []
    for e, s, d, f, lines in zip(exps, seen, dof, flo, witnessed):
        # chi2.isf(alpha, d) as scipy.stats computes it, without its argument handling on every comparison
        lim = DETECTION_TOLERANCE * scipy.special.chdtri(d, alpha) / d
        coloured = floor.coloured.get(e.name)
        if lines is not None and coloured is not None:
            share = np.clip(coloured / np.where(f > 0, f, np.inf), 0.0, 1.0)
            low_by = 1.0 + (floor_error(lines, n_bands)[:, None] - 1.0) * share
            lim = np.maximum(lim, low_by * scipy.special.chdtri(d, alpha / 2) / d)
        limit.append(np.where(s, lim, np.inf))
        unjudged.append(np.where(s, np.inf, lim))
    return Resolved(names, chans, bands, res, flo, dof, rdof, limit, witnessed, unjudged)


def floor_error(lines: np.ndarray, n_bands: int) -> np.ndarray:
    """Per band, the factor by which the noise's colour there (its rise or excess over the white
    level, NoiseFloor.coloured) may be too low, measured on ``lines`` lines of the samples before
    the hits (two degrees of freedom each): an estimate, exact only as the lines grow many. The
    white level is measured on every sample before the hits, the hum and the force channel's noise
    are fitted and simulated: their share is taken as known. The colour's error is shared by every
    cell of the band, so half of DETECTION_FALSE_ALARM is spread over the ``n_bands`` judged bands,
    the other half over the cells as the residual's own chi-square. Measured: a floor's vibration
    (8-40 Hz) before hits of 130 samples at 2 kHz shows on 4 lines of the 25-50 Hz band, and a
    perfect model's cells there read 1.03-1.07x their limit without this factor (3.4x amplitude;
    4.7x with it). With 8 lines or more the calibrated tolerance covers it (the limit as before);
    where no colour is found the limit is as before (taking every band's whole floor as measured
    on its few lines hid a two-body softer mount at 10 N, 8.1x its noise at 12.5-50 Hz)."""
    nu = 2.0 * np.maximum(np.asarray(lines, float), 1.0)
    low = scipy.special.chdtri(nu, 1.0 - DETECTION_FALSE_ALARM / (2.0 * max(n_bands, 1)))
    return nu / low


def gain_threshold(k: int) -> float:
    """The whitened gain that fitting ``k`` parameters to noise exceeds with probability
    GAIN_FALSE_ALARM."""
    return float(scipy.stats.chi2.isf(GAIN_FALSE_ALARM, max(k, 1)))


def gain(before: Resolved, after: Resolved) -> float:
    """The likelihood-ratio statistic of a change from ``before`` to ``after``: the whitened excess
    it removes, each cell with the fewer degrees of freedom of the floor's and the residual's
    before the change (a residual a few lines carry is one of few independent values)."""
    dof = before.residual_dof
    return before.excess(dof) - after.excess(dof)
