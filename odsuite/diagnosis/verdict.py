"""The verdict of a diagnosis, in words and JSON: what the residual left by the model is (its
signature against the calibrated noise floor: bands, channels, experiments, peaks, amplitude
dependence), whether a candidate explains it, and one paragraph a vibration engineer can act on.

Where the floor has bands, the residual resolved by experiment, channel and band decides
(odsuite.analysis.resolved: a cell is above the floor beyond its chi-square limit); the pooled error
stays the number reported. Without bands the pooled error within ``FLOOR_TOLERANCE`` decides.

- "nothing to explain": no cell above the floor;
- "explained": a significant, plausible candidate leaves no cell above it, with parameters that
  agree across experiments (or that make the model amplitude dependent, whose per-experiment
  values then follow the force level by design), and its fit to the records' early (large) part
  predicts their late (small) part at the floor (else it stands in for an amplitude-dependent
  cause: checks.held_out);
- "partly explained": a significant candidate helps, but cells stay above the floor or its
  parameters are inconsistent or implausible; where it passes its own tests and only cells are
  left, the message says something else is left (a second effect, or one it partly stands in for;
  the held-out test is not run then: the late part's own fit would take up some of what is left);
- "unexplained": nothing significant while cells are above the floor.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from odsuite.analysis.comparison import BAND_EDGES_HZ
from odsuite.analysis.noise_floor import FLOOR_TOLERANCE, NoiseFloor, on_grid, pooled_grid, welch

VERDICTS = ("nothing to explain", "explained", "partly explained", "unexplained")


@dataclass
class Signature:
    bands: list[dict[str, Any]] = field(default_factory=list)
    channels: list[dict[str, Any]] = field(default_factory=list)
    experiments: list[dict[str, Any]] = field(default_factory=list)
    peaks_hz: list[float] = field(default_factory=list)
    amplitude_dependent: bool = False
    # the resolved cells above the floor (experiment, channel, band), strongest first
    cells: list[dict[str, Any]] = field(default_factory=list)
    strongest_cell: float | None = None  # the largest sqrt(residual / floor) of any cell
    # cells of bands no quiet sample shows, above the limit they would have were the noise white
    # there (Resolved.unjudged): not judged, and named
    unjudged: list[dict[str, Any]] = field(default_factory=list)
    # the unjudged cells are above a white floor, and within the noise the records' quiet tails show
    # (records that start at their hit: no samples before it tell the noise's colour)
    tails_hold: bool = False
    # ... and the unjudged cells lie in bands no single quiet tail holds two lines of: the tails
    # cannot show the noise there (they hold less than a period of it)
    tails_short: bool = False

    def as_dict(self) -> dict[str, Any]:
        return {"bands": self.bands, "channels": self.channels, "experiments": self.experiments,
                "peaks_hz": self.peaks_hz, "amplitude_dependent": self.amplitude_dependent,
                "cells": self.cells, "strongest_cell_to_floor": self.strongest_cell,
                "unjudged_cells": self.unjudged, "unjudged_as_the_tails_hold": self.tails_hold,
                "unjudged_as_the_tails_are_short": self.tails_short}


def signature(exps: Sequence, predictions: Sequence[np.ndarray], floor: NoiseFloor,
              peaks: Sequence[dict[str, Any]], amplitude_dependent: bool, resolved=None,
              spectra: Sequence[tuple[np.ndarray, np.ndarray]] | None = None) -> Signature:
    """Where a residual exceeds the floor by more than FLOOR_TOLERANCE (amplitude): per band (Welch
    spectra of residual and floor), per channel and per experiment (energies), strongest first;
    with the residual's peaks above the floor and the ``resolved`` cells above it. ``spectra``:
    the residuals' Welch spectra at each record's own rate, where the caller has them."""
    sig = Signature(peaks_hz=[round(float(p["frequency_hz"]), 1) for p in peaks],
                    amplitude_dependent=amplitude_dependent)
    if resolved is not None:
        sig.cells = resolved.cells()
        sig.strongest_cell = resolved.strongest()
        sig.unjudged = resolved.unjudged()
    res_e: dict[str, float] = {}
    res_c: dict[str, float] = {}
    flo_c: dict[str, float] = {}
    band_r = band_f = None
    banded = []
    for i, (e, p) in enumerate(zip(exps, predictions)):
        r = e.measured - p
        res_e[e.name] = float(np.sum(r**2))
        for j, s in enumerate(e.sensors):
            res_c[s.name] = res_c.get(s.name, 0.0) + float(np.sum(r[:, j] ** 2))
            flo_c[s.name] = flo_c.get(s.name, 0.0) + floor.energy[e.name][s.name]
        if e.name in floor.spectra:
            fe, pr = spectra[i] if spectra is not None else welch(r, e.fs, e.n_samples)
            banded.append((fe, pr.sum(axis=1), on_grid(fe, *floor.spectra[e.name]).sum(axis=1)))
    if banded:  # records of other rates or lengths pool on one grid
        f = pooled_grid([fe for fe, _, _ in banded])
        band_r = sum(on_grid(f, fe, pr) for fe, pr, _ in banded)
        band_f = sum(on_grid(f, fe, fl) for fe, _, fl in banded)

    def ranked(res: dict[str, float], flo: dict[str, float], key: str) -> list[dict[str, Any]]:
        rows = [{key: n, "residual_to_floor": float(np.sqrt(res[n] / flo[n])), "excess_share": res[n] - flo[n]}
                for n in res if flo.get(n, 0) > 0 and res[n] > FLOOR_TOLERANCE**2 * flo[n]]
        total = sum(r["excess_share"] for r in rows) or 1.0
        for r in rows:
            r["excess_share"] = float(r["excess_share"] / total)
        return sorted(rows, key=lambda r: -r["excess_share"])

    sig.channels = ranked(res_c, flo_c, "channel")
    sig.experiments = ranked(res_e, {n: sum(floor.energy[n].values()) for n in res_e}, "experiment")
    if band_r is not None:
        edges = [b for b in BAND_EDGES_HZ if b < f[-1]] + [float(f[-1])]
        res_b, flo_b = {}, {}
        for lo, hi in zip(edges[:-1], edges[1:]):
            sel = (f >= lo) & (f < hi) if hi < f[-1] else (f >= lo)
            label = f"{lo:g}-{hi:g} Hz"
            res_b[label], flo_b[label] = float(band_r[sel].sum()), float(band_f[sel].sum())
        sig.bands = ranked(res_b, flo_b, "band")
    return sig


def decide(baseline: float, floor: float, best, *, before=None, after=None, amplitude_cause: bool = False) -> str:
    """The verdict from the baseline error, the floor and the best significant candidate (None);
    with ``before`` and ``after`` (the resolved residual of the model and of the model with the best
    candidate, odsuite.analysis.resolved) from them instead of the pooled errors. ``amplitude_cause``:
    the candidate makes the model amplitude dependent."""
    if before is not None:
        if not before.detected():
            return "nothing to explain"
        if best is None:
            return "unexplained"
        # a fit to the records' early part that mispredicts their late part stands in (checks.held_out)
        # (None: not tested, as where cells are left: no disagreement, and the cells decide)
        agrees = (best.consistent or amplitude_cause) and getattr(best, "early_late_agree", True) is not False
        if agrees and best.plausible and after is not None and not after.detected():
            return "explained"
        return "partly explained"
    if not baseline > FLOOR_TOLERANCE * floor:
        return "nothing to explain"
    if best is None:
        return "unexplained"
    if best.consistent and best.plausible and best.error_after <= FLOOR_TOLERANCE * floor:
        return "explained"
    return "partly explained"


def _where(sig: Signature) -> str:
    parts = []
    if sig.cells:
        c = sig.cells[0]
        parts.append(f"{len(sig.cells)} cell{'s' if len(sig.cells) > 1 else ''} above the floor, the strongest "
                     f"{c['channel']} in {c['experiment']} at {c['band_hz'][0]:g}-{c['band_hz'][1]:g} Hz "
                     f"({c['residual_to_floor']:.3g}x its floor)")
    if sig.channels:
        parts.append("channels " + ", ".join(c["channel"] for c in sig.channels[:4]))
    if sig.experiments:
        parts.append("experiments " + ", ".join(x["experiment"] for x in sig.experiments[:3]))
    if sig.bands:
        parts.append("the " + ", ".join(b["band"] for b in sig.bands[:2]) + " band" + ("s" if len(sig.bands) > 1 else ""))
    if sig.peaks_hz:
        parts.append("peaks at " + ", ".join(f"{p:.0f}" for p in sig.peaks_hz[:4]) + " Hz")
    return "; ".join(parts) if parts else "no single channel, band or experiment"


#: a band's noise measured on fewer lines of the samples before the hits than this is named in the
#: verdict: a band of noise there (a floor's vibration under one line) reads as a misfit (the skid
#: rig's 0.0625 s before each hit sees 25-50 Hz in its 32 Hz line alone: 2 of 8 nulls with a floor
#: vibration at 24-37 Hz read "unexplained")
FEW_NOISE_LINES = 8


def _few_noise_lines(sig: Signature) -> str:
    """Words on the strongest cell's band when few lines before the hits measure its noise."""
    if not sig.cells or sig.cells[0].get("noise_lines", FEW_NOISE_LINES) >= FEW_NOISE_LINES:
        return ""
    c = sig.cells[0]
    return (f" The noise at {_band(c)} Hz is measured on only {c['noise_lines']} lines of the quiet samples "
            f"(before the hits, or the records' tails where none precede them), so a band of noise there (a "
            f"floor's vibration, a sensor's noise rising at low frequency) would read the same: "
            f"{_record_before(c, 'tell')}")


def _unjudged(sig: Signature) -> str:
    """Words on the strongest cell of a band no quiet sample shows, where it is above the limit it
    would have were the noise white there: these data cannot tell it from a floor's vibration."""
    c = sig.unjudged[0]
    return (f" But no quiet samples show the noise at {_band(c)} Hz, where {c['channel']} in {c['experiment']} "
            f"is {c['residual_to_floor']:.3g}x the floor a white noise would leave (limit {c['limit']:.3g}x): a "
            f"model error there cannot be told from a floor's vibration or a noise rising at low frequency, so "
            f"that band is not judged. {_record_before(c, 'judge it').capitalize()}")


def _tails_decided(head: str, sig: Signature) -> str:
    """The words where the records' quiet tails decided "nothing to explain" (records that start
    at their hit: diagnose._held_by_tails), on the strongest cell they left unjudged."""
    c = sig.unjudged[0]
    cell = f"{head}; by channel and band, {c['channel']} in {c['experiment']} at {_band(c)} Hz is {c['residual_to_floor']:.3g}x"
    if sig.tails_short:
        why = (f"{cell} the floor the records' quiet tails show there (limit {c['limit']:.3g}x), and no candidate "
               f"effect removes more of it than that noise allows. But no tail holds two lines of that band, so the "
               f"tails cannot show the noise there: a band of noise (a floor's vibration, a sensor's noise rising at "
               f"low frequency) and a model error read the same in records that start at their hit, and that band "
               f"is not judged. Elsewhere no band of any channel exceeds the floor the tails show")
        bands = "judge that band"
    else:
        why = (f"{cell} the floor a white noise would leave there (limit {c['limit']:.3g}x), and no candidate effect "
               f"removes a significant part of it. But the model's residual on the records' quiet tails holds as "
               f"much there: a band of noise (a sensor's noise rising at low frequency, a floor's vibration) or a "
               f"model error that lasts into the tails, which records that start at their hit cannot tell apart. "
               f"Against the noise the tails show, no band of any channel exceeds its floor")
        bands = "judge those bands"
    return (f"{why} (the strongest is {sig.strongest_cell:.2f}x), so these data show nothing the model lacks that "
            f"they can tell. {_record_before(c, bands).capitalize()}")


def _band(cell: dict[str, Any]) -> str:
    lo, hi = cell["band_hz"]
    return f"{lo:g}-{hi:g}"


def _record_before(cell: dict[str, Any], to: str) -> str:
    """How long to record before each hit for a cell's band to hold two periods of its lowest line."""
    return f"record {2.0 / max(cell['band_hz'][0], 1e-9):.2g} s or more before each hit to {to}."


def message(verdict: str, baseline: float, floor: float, best, sig: Signature, rest: Signature | None) -> str:
    """One paragraph a vibration engineer can act on."""
    ratio = baseline / floor if floor > 0 else float("inf")
    head = f"The model's error is {baseline:.3g}, {ratio:.2f} times the noise floor of {floor:.3g}"
    if sig.cells:  # the resolved residual decides: say where it is above its floor
        c = sig.cells[0]
        head += (f"; by channel and band, {c['channel']} in {c['experiment']} at {c['band_hz'][0]:g}-"
                 f"{c['band_hz'][1]:g} Hz is {c['residual_to_floor']:.3g}x the floor there")
    if verdict == "nothing to explain" and sig.tails_hold and sig.unjudged:
        return _tails_decided(head, sig)
    if verdict == "nothing to explain" and sig.strongest_cell is not None:
        if sig.unjudged:
            return (f"{head}; no band the noise is measured in exceeds what noise, hum and quantisation leave "
                    f"there (the strongest is {sig.strongest_cell:.2f}x its floor).{_unjudged(sig)}")
        return (f"{head}; no band of any channel exceeds what noise, hum and quantisation leave there (the "
                f"strongest is {sig.strongest_cell:.2f}x its floor), so these data show nothing the model "
                "lacks. Record more or stronger hits (or quieter channels) to look for smaller effects.")
    if verdict == "nothing to explain":
        if best is None:
            return (f"{head}: within what noise, hum and quantisation leave ({FLOOR_TOLERANCE:g}x), so these "
                    "data show nothing the model lacks. Record more or stronger hits (or quieter channels) to "
                    "look for smaller effects.")
        # a gain beyond chance within the floor's tolerance: something small is there, too small to
        # call the model wrong at this noise
        also = f" (or {', '.join(best.confounded_with)})" if best.confounded_with else ""
        return (f"{head}: within what noise, hum and quantisation leave ({FLOOR_TOLERANCE:g}x), so the model "
                f"fits these data. {best.effect}{also} still removes more of the error than chance would "
                f"(to {best.error_after:.3g}): a small effect at this noise. Record stronger hits (or quieter "
                f"channels) to tell whether it matters.")
    amp = (" The misfit changes with the force level: the structure is amplitude dependent (a nonlinear "
           "stiffness, friction or a contact); test at several force levels and fit each level alone."
           if sig.amplitude_dependent else "")
    if verdict == "unexplained":
        return (f"{head}, and no candidate effect removes a significant part of it. The residual lies in "
                f"{_where(sig)}.{amp}{_few_noise_lines(sig)} The missing physics is not in the effect library: "
                "inspect those channels' spectra and the rig there (loose parts, contacts, friction, a sensor or "
                "cable), or add an effect of your own.")
    name = best.effect
    also = f" (it cannot be told apart from {', '.join(best.confounded_with)} with these data)" if best.confounded_with else ""
    if verdict == "explained":
        amp_words = (" Its effect depends on the force level, as the records do." if sig.amplitude_dependent
                     else "")
        if getattr(best, "early_late_agree", True) is False:
            # measured: a rattle's stand-in and two true added masses alike, so it does not decide
            amp_words += (f" Caution: its parameters fitted to the early (large) and the late (small) part of "
                          f"the records differ ({', '.join(best.early_late_differ[:3])}) and their models "
                          f"predict apart beyond the noise: it may stand in for an amplitude-dependent cause "
                          f"(a contact, friction, a loose part); record hits at other force levels to tell.")
        return (f"{head}; adding {name}{also} brings it to {best.error_after:.3g}, at the floor in every band "
                f"of every channel, with parameters that agree across the experiments (or follow the force "
                f"level as the effect does) and lie in their physical range.{amp_words} Run "
                f"`odsuite add-effect PROJECT {name}` to keep it.")
    why = []
    if rest is not None and rest.cells:
        why.append(f"the error stays at {best.error_after:.3g}, {best.error_after / floor:.2f} times the floor, "
                   f"with {len(rest.cells)} band{'s' if len(rest.cells) > 1 else ''} of some channel above it")
    elif rest is None and best.error_after > FLOOR_TOLERANCE * floor:
        why.append(f"the error stays at {best.error_after:.3g}, {best.error_after / floor:.2f} times the floor")
    if not best.consistent:
        why.append("its parameters differ between experiments beyond their uncertainties")
    cells = getattr(best, "early_late_cells", None)
    left_cells = rest is not None and bool(rest.cells)  # then the parts' tests see what is left, not it
    if cells:
        c = cells[0]
        why.append(f"its fit to the early (large) part of the records mispredicts their late (small) part "
                   f"({c['channel']} in {c['experiment']} at {c['band_hz'][0]:g}-{c['band_hz'][1]:g} Hz, "
                   f"{c['residual_to_floor']:.3g}x its floor for a limit of {c['limit']:.3g}): the residual it "
                   "takes up changes with the amplitude within each record, as a contact, friction or a loose "
                   "part's does")
    elif getattr(best, "early_late_agree", True) is False and not left_cells:
        why.append("its parameters fitted to the early (large) and the late (small) part of the records differ "
                   f"beyond their uncertainties ({', '.join(best.early_late_differ[:3])}): the residual it takes up "
                   "changes with the amplitude within each record, as a contact, friction or a loose part's does")
    edge = getattr(best, "at_records_edge", [])
    if edge:
        why.append("its fit stopped at the records' Nyquist frequency (" + ", ".join(edge[:3]) + "): the top of "
                   "what they resolve")
    outside = [n for n in best.implausible if n not in edge] if not best.plausible else []
    if outside:
        why.append("its fitted values lie outside their physical range (" + ", ".join(outside[:3]) + ")")
    left = f" What is left lies in {_where(rest)}." if rest is not None else ""
    if why and len(why) == 1 and rest is not None and rest.cells and best.consistent and best.plausible:
        # it passes its own tests and only leaves cells above the floor: something else is there
        return (f"{head}; {name}{also} explains part of it and passes its own tests (parameters that agree "
                f"across the experiments and lie in their physical range), but {why[0]}: something else is left, "
                f"a second effect or one that {name} partly stands in for.{left}{amp} To look for it, keep {name} "
                f"(`odsuite add-effect PROJECT {name}`) and diagnose again.")
    return (f"{head}; {name}{also} explains part of it, but " + "; ".join(why) + f". It may stand in for "
            f"physics the library lacks.{left}{amp} Add it only as a stopgap, and look for the cause there.")
