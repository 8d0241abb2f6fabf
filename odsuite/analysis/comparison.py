"""Model against measurement, like with like (thesis Ch. 3.3, Fig. 3.7).

The metrics of the comparison, on the predictions of :mod:`odsuite.analysis.prediction`: measured and
predicted signals meet before integration (the contract's ``error``) and, after the full chain, as
generalized coordinates; errors per experiment, channel, band and coordinate, residual peaks
without a model mode, and measured against model resonances.

``error`` = sqrt(sum (measured - model)^2 / sum measured^2) over all accelerometer channels of all
experiments, at the chain's "acceleration" stage (after filter 1). The noise floor is the same
quantity for a perfect model: the noise variance, estimated from samples before the hammer hit,
over the measured energy.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.signal
import scipy.stats
from threadpoolctl import threadpool_limits

from odsuite.analysis import noise_colour
from odsuite.analysis.noise_floor import FLOOR_TOLERANCE, NoiseFloor, estimate, on_grid, pooled_grid, welch
from odsuite.analysis.prediction import (
    PreparedExperiment,
    coordinate_series,
    impulse_responses,
    predict,
    prepare,
    sensor_noise,
    solved_bodies,
)
from odsuite.domain.rig import Rig

#: Frequency bands (Hz) of the per-band metrics; the last band runs to Nyquist.
BAND_EDGES_HZ = (0.0, 50.0, 100.0, 200.0, 400.0, 800.0, 1600.0)
COORDINATE_NAMES = ("x", "y", "z", "theta", "phi", "psi")


def nrmse(measured: np.ndarray, predicted: np.ndarray, axis=None) -> np.ndarray | float:
    """sqrt(sum (m - p)^2 / sum m^2); 0 is perfect."""
    num = np.sum((measured - predicted) ** 2, axis=axis)
    den = np.sum(measured**2, axis=axis)
    return np.sqrt(num / np.where(den > 0, den, np.nan))


def band_energies(measured: np.ndarray, predicted: np.ndarray, fs: float,
                  edges: Sequence[float] = BAND_EDGES_HZ) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Per band and column: the measured energy and the residual's (Parseval on the real FFT),
    bands x columns each. A column that never moves has a residual and no measured energy."""
    n = measured.shape[0]
    f = np.fft.rfftfreq(n, 1 / fs)
    M = np.abs(np.fft.rfft(measured, axis=0)) ** 2
    R = np.abs(np.fft.rfft(measured - predicted, axis=0)) ** 2
    edges = [e for e in edges if e < fs / 2] + [fs / 2]
    labels, measured_e, residual_e = [], [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (f >= lo) & (f < hi) if hi < fs / 2 else (f >= lo)
        labels.append(f"{lo:g}-{hi:g} Hz")
        measured_e.append(M[sel].sum(axis=0))
        residual_e.append(R[sel].sum(axis=0))
    return labels, np.array(measured_e), np.array(residual_e)


#: a residual peak is one the noise alone would reach with this probability over the whole spectrum
PEAK_FALSE_ALARM = 0.01
#: ... and that holds at least this share of the residual's energy (a smaller one moves the error
#: by under 1 %)
PEAK_MIN_SHARE = 0.02


def residual_spectra(exps: Sequence[PreparedExperiment], predictions: Sequence[np.ndarray]
                     ) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each record's residual Welch spectrum (frequencies, PSD samples x sensors) at its own
    sampling rate, as ``residual_peaks`` takes them."""
    return [welch(e.measured - p, e.fs, e.n_samples) for e, p in zip(exps, predictions)]


def residual_peaks(exps: Sequence[PreparedExperiment], predictions: Sequence[np.ndarray],
                   model_modes_hz: Sequence[float] = (), floor: NoiseFloor | None = None, *,
                   max_peaks: int = 5, spectra: Sequence[tuple[np.ndarray, np.ndarray]] | None = None
                   ) -> list[dict[str, Any]]:
    """Peaks of the pooled residual spectrum that the noise floor does not explain, each with the
    channels where it is strongest and whether a model mode lies within 5 % of it ("lacking" when
    none does). A frequency counts when the residual's Welch spectrum exceeds the floor's by more
    than its chi-square spread allows (``PEAK_FALSE_ALARM`` over all frequencies: Bonferroni);
    without a floor, every prominent peak is listed. ``spectra``: ``residual_spectra``'s, where
    the caller has them."""
    psd_sum = floor_sum = None
    per_channel: dict[str, np.ndarray] = {}
    floor_var = 0.0  # sum over records of floor^2 / degrees of freedom (Satterthwaite)
    spectra = spectra if spectra is not None else residual_spectra(exps, predictions)
    if not spectra:
        return []
    # records of other rates or lengths pool on one frequency grid
    f = pooled_grid([fe for fe, _ in spectra])
    for e, (fe, pxx) in zip(exps, spectra):
        nfft = 2 * (len(fe) - 1)
        segments = max(1, 1 + (e.n_samples - nfft) // (nfft // 2))
        pxx = on_grid(f, fe, pxx)
        psd_sum = pxx.sum(axis=1) if psd_sum is None else psd_sum + pxx.sum(axis=1)
        if floor is not None and e.name in floor.spectra:
            fl = on_grid(f, *floor.spectra[e.name]).sum(axis=1)
            floor_sum = fl if floor_sum is None else floor_sum + fl
            # Welch with a Hann window and half overlap: about 1.8 degrees of freedom per segment
            # (Welch 1967); a rig's channels share the force's noise and disturbances, so they
            # are not counted as independent
            floor_var = floor_var + fl**2 / (1.8 * segments)
        for j, s in enumerate(e.sensors):
            per_channel[s.name] = per_channel.get(s.name, 0) + pxx[:, j]
    if psd_sum is None or not np.any(psd_sum > 0):
        return []
    if floor_sum is not None:
        # records pooled per frequency as a sum of scaled chi-squares: Satterthwaite's degrees of
        # freedom (sum F)^2 / sum (F^2 / dof), each record's floor F and Welch segments its own
        # (records of other lengths or noise levels count less than a plain count of records)
        dof = floor_sum**2 / np.maximum(floor_var, 1e-300)
        dof = np.where(floor_sum > 0, dof, 1.8)
        limit = scipy.stats.chi2.isf(PEAK_FALSE_ALARM / len(f), dof) / dof
        # most frequencies of a residual hold noise alone: their median ratio to the floor takes
        # out the floor's overall calibration (within its tolerance) before single lines are tested
        scale = float(np.clip(np.median(psd_sum / np.maximum(floor_sum, 1e-300)), 1.0, FLOOR_TOLERANCE**2))
        floor_sum = floor_sum * scale
        excess = np.where(psd_sum > limit * floor_sum, psd_sum - floor_sum, 0.0)
        if not np.any(excess > 0):
            return []
        idx, props = scipy.signal.find_peaks(np.concatenate([[0.0], excess, [0.0]]), prominence=0.0)
        idx = idx - 1
        # a peak's share: its excess over the floor, summed over the bins around it above the limit
        lo = np.flatnonzero(np.diff(np.concatenate([[0.0], (excess > 0).astype(float)])) > 0)
        kept = []
        for i in idx:
            a = lo[lo <= i].max()
            b = a + int(np.argmax(excess[a:] == 0)) if np.any(excess[a:] == 0) else len(excess)
            kept.append(excess[a:b].sum() >= PEAK_MIN_SHARE * psd_sum.sum())
        keep = np.asarray(kept, bool)
        idx, props = idx[keep], {k: v[keep] for k, v in props.items()}
        strength = excess
    else:
        idx, props = scipy.signal.find_peaks(psd_sum, prominence=0.05 * psd_sum.max())
        strength = psd_sum
    # the zero-frequency bin holds the record's mean and trend, which the chains' offsets and
    # high-passes shape: it is not a resonance the model could lack
    not_dc = idx > 0
    idx, props = idx[not_dc], {k: v[not_dc] for k, v in props.items()}
    order = np.argsort(props["prominences"])[::-1][:max_peaks]
    peaks = []
    for i in sorted(idx[order], key=lambda i: -strength[i]):
        freq = float(f[i])
        at = {name: float(v[i]) for name, v in per_channel.items()}
        top = max(at.values())
        channels = sorted((n for n, v in at.items() if v >= 0.25 * top), key=lambda n: -at[n])
        near = [m for m in model_modes_hz if abs(m - freq) <= 0.05 * freq + f[1]]
        peaks.append({"frequency_hz": freq, "share": float(strength[i] / psd_sum.sum()),
                      "channels": channels, "model_mode_hz": float(near[0]) if near else None,
                      "lacking": not near,
                      **({"to_floor": float(psd_sum[i] / floor_sum[i])} if floor_sum is not None else {})})
    return peaks


@dataclass
class Comparison:
    """Everything ``compare`` reports; ``as_dict`` is the JSON contract."""

    error: float
    noise_floor_error: float
    revision: int | None
    experiments: dict[str, dict[str, Any]]
    channels: dict[str, float | None]  # None: the channel never moved in any record (no error of its own)
    coordinates: dict[str, dict[str, dict[str, float]]]
    bands: dict[str, Any]
    rigidity: dict[str, dict[str, Any]]
    modes: dict[str, list[dict[str, float]]]
    residual_peaks: list[dict[str, Any]]
    worst: list[dict[str, Any]]
    modal: list[dict[str, Any]] | None = None  # measured against model modes, per record
    modal_notes: list[str] | None = None
    notes: list[str] = field(default_factory=list)  # the records against the rig file
    floor: NoiseFloor | None = None
    # what the modal table rests on (FRFs, MAC matrices) for figures; not part of the JSON
    modal_records: list | None = None
    # the model's predictions of the records (samples x sensors each); not part of the JSON
    predictions: list[np.ndarray] | None = field(default=None, repr=False)
    # their residuals' Welch spectra (residual_spectra); not part of the JSON
    residual_spectra: list[tuple[np.ndarray, np.ndarray]] | None = field(default=None, repr=False)

    @property
    def residual_to_floor(self) -> float:
        return self.error / self.noise_floor_error if self.noise_floor_error > 0 else float("inf")

    def as_dict(self) -> dict[str, Any]:
        return {"error": self.error, "noise_floor": self.noise_floor_error,
                "noise_floor_error": self.noise_floor_error, "residual_to_floor": self.residual_to_floor,
                "revision": self.revision, "experiments": self.experiments, "channels": self.channels,
                "coordinates": self.coordinates, "bands": self.bands, "rigidity": self.rigidity,
                "modes": self.modes, "residual_peaks": self.residual_peaks, "worst": self.worst,
                "modal": self.modal, "modal_notes": self.modal_notes, "notes": self.notes}


#: band of the FRF comparison and of the modes identified from measured FRFs (Hz)
FRF_BAND_HZ = (20.0, 1000.0)


def frf_comparison(exps: Sequence[PreparedExperiment], predictions: Sequence[np.ndarray],
                   model_modes) -> dict[str, Any]:
    """Measured and model FRFs (acceleration stage over the windowed force, so both include the
    channel's filters) compared per channel, and resonances identified from both by the same LSCF
    method (odsuite.analysis.modal), paired with each other and with the model's exact modes.

    Each record holds one force point, so an FRF is one average: coherence needs repeated hits
    (``odsuite frf``) and is not reported here."""
    from odsuite.analysis.frf import estimate_frf
    from odsuite.analysis.modal import identify_modes, pair_modes

    lo, hi = FRF_BAND_HZ[0], min(FRF_BAND_HZ[1], 0.45 * exps[0].fs)
    errors: dict[str, dict[str, float]] = {}
    stacks: dict[str, list[np.ndarray]] = {"measured": [], "model": []}
    freq = None
    for e, p in zip(exps, predictions):
        fm = estimate_frf([e.force], [e.measured], e.fs)
        fp = estimate_frf([e.force], [p], e.fs)
        keep = (fm.frequency >= lo) & (fm.frequency <= hi)
        if np.count_nonzero(keep) < 2:  # a record too short for its rate: its lines step over the band
            continue
        if freq is None:
            freq = fm.frequency[keep]
        elif len(fm.frequency[keep]) != len(freq) or not np.allclose(fm.frequency[keep], freq):
            continue  # records of another length: their lines do not stack
        hm, hp = fm.H[:, keep], fp.H[:, keep]
        # lines where a channel barely responds (a z hit seen by an x sensor on the symmetry line),
        # measured or in the model (whose zero there would read as -300 dB), carry no information:
        # they are left out, and a silent channel gets no value
        seen = (np.abs(hm) > 1e-6 * np.abs(hm).max()) & (np.abs(hp) > 1e-6 * np.abs(hp).max())
        with np.errstate(divide="ignore", invalid="ignore"):
            db = np.where(seen, 20 * np.log10(np.abs(hp) / np.abs(hm)), np.nan)
        errors[e.name] = {s.name: (float(np.sqrt(np.nanmean(row**2))) if np.isfinite(row).any() else None)
                          for s, row in zip(e.sensors, db)}
        stacks["measured"].append(hm)
        stacks["model"].append(hp)
    identified: dict[str, list[dict[str, float]]] = {}
    notes = []
    if not stacks["measured"]:
        notes.append(f"no record has two FRF lines within {lo:g}-{hi:g} Hz (lines {exps[0].fs / exps[0].n_samples:.4g} Hz "
                     "apart): no FRFs compared")
    for side, parts in stacks.items():
        if not parts:
            identified[side] = []
            continue
        try:
            res = identify_modes(freq, np.vstack(parts), f_band=(lo, hi), max_order=40)
            identified[side] = [{"frequency_hz": float(f), "damping_ratio": float(z)}
                                for f, z in zip(res.frequency_hz, res.damping_ratio)]
        except (ValueError, np.linalg.LinAlgError) as exc:  # ConfigError is a ValueError
            identified[side] = []
            notes.append(f"{side} modes not identified: {exc}")
    exact = [m for m in model_modes.as_list() if lo <= m["frequency_hz"] <= hi]

    def pairs(a, b):
        if not a or not b:
            return []
        rows = pair_modes([m["frequency_hz"] for m in a], [m["damping_ratio"] for m in a],
                          [m["frequency_hz"] for m in b], [m["damping_ratio"] for m in b])
        return [{k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in r.items()}
                for r in rows]

    return {"band_hz": [lo, hi], "magnitude_error_db": errors, "measured_modes": identified["measured"],
            "model_identified_modes": identified["model"],
            "measured_vs_model": pairs(identified["measured"], exact),
            "measured_vs_model_identified": pairs(identified["measured"], identified["model"]),
            "notes": notes}


def pooled_error(exps: Sequence[PreparedExperiment], predictions: Sequence[np.ndarray]) -> float:
    num = sum(float(np.sum((e.measured - p) ** 2)) for e, p in zip(exps, predictions))
    den = sum(float(np.sum(e.measured**2)) for e in exps)
    return float(np.sqrt(num / den)) if den > 0 else float("nan")


def noise_floor(exps: Sequence[PreparedExperiment], model=None, *, spectra: bool = False,
                colours: Mapping[str, Any] | None = None,
                tail_predictions: Sequence[np.ndarray] | None = None) -> NoiseFloor:
    """The calibrated noise floor (odsuite.analysis.noise_floor) of ``exps`` if ``model`` were
    right: it carries the force channel's noise to the sensors and its signals set the rounding
    error (without it, those parts are estimated from the records alone). ``model``: a
    RevisionModel, or a mapping of experiment name to that experiment's model. ``colours``: the
    sensors' noise colours of these records where known (another floor's: NoiseFloor.colours).
    ``tail_predictions``: a model's predictions whose residual on the records' quiet tails tells
    the colour instead (noise_floor.estimate's ``tail_residuals``), where no record has samples
    before its hit to tell it."""
    if model is None:
        return estimate(exps, spectra=spectra, colours=colours)
    models = model if isinstance(model, Mapping) else {e.name: model.for_experiment(e.name) for e in exps}
    # where quiet samples precede the hit, a unit at the trigger stands for the window (its units'
    # responses agree within 0.9-1.05 in every band) at a 32nd of the cost: diagnose takes two floors
    impulses = {e.name: impulse_responses(models[e.name], e, spread=not noise_colour.has_pre_hit_lines(e))
                for e in exps}
    noise = {e.name: sensor_noise(models[e.name], e) for e in exps}
    residuals = None
    if tail_predictions is not None and not any(noise_colour.has_pre_hit_lines(e) for e in exps):
        residuals = {e.name: e.measured - p for e, p in zip(exps, tail_predictions)}
    return estimate(exps, impulses, noise, spectra=spectra, colours=colours, tail_residuals=residuals)


def noise_floor_error(exps: Sequence[PreparedExperiment], model=None) -> float:
    """The error a perfect model would have: expected noise energy over measured energy."""
    return noise_floor(exps, model).error()


def _coordinates(rig: Rig, exp: PreparedExperiment, model, errors: bool = True) -> tuple[dict, dict]:
    """Per-coordinate errors of the generalized coordinates (``errors``), for every body whose motion
    its sensors determine, and the rigidity check on the measured accelerations where the body's
    solver has one."""
    from odsuite.contracts.solvers import choose_solver

    coords, rigidity = {}, {}
    # without the errors, no coordinates are solved: the rigidity check reads the measured signals alone
    series = coordinate_series(rig, exp, model) if errors else {
        c.body.name: (None, None, list(idx.values())) for c, idx in solved_bodies(rig, exp)}
    for name, (gm, gp, cols) in series.items():
        if errors:
            # a coordinate outside the body's dofs is held still by the model: no error to rank
            dofs = rig.body(name).dofs
            coords[name] = {c: float(nrmse(gm[:, i], gp[:, i])) for i, c in enumerate(COORDINATE_NAMES) if c in dofs}
        signals = {exp.sensors[j].name: exp.measured[:, j] for j in cols}
        solver = choose_solver(rig, rig.body(name), signals, exp.registries.coordinate_solvers).solver
        if not hasattr(solver, "rigidity_check"):
            continue
        rig_check = solver.rigidity_check(rig, rig.body(name), signals)
        rigidity[name] = {"fractions": {k: float(v) for k, v in rig_check.fractions.items()},
                          "flagged": list(rig_check.flagged), "worst": rig_check.worst}
    return coords, rigidity


def _worst_channels(channels: Mapping[str, float | None], floor: NoiseFloor, count: int = 3) -> list[dict[str, Any]]:
    """The ``count`` channels whose error stands highest over their noise floor, each with its floor
    (a perfect model's error) and that ratio. A channel holding noise alone (a y channel under a
    blow along x) reads an error near 1 at a floor near 1: it says nothing of the model."""
    rows = []
    for n, v in channels.items():
        if v is None:  # it never moved: no error to rank
            continue
        fl = floor.error(channels=[n])
        ratio = v / fl if fl > 0 else (float("inf") if v > 0 else float("nan"))
        rows.append({"kind": "channel", "name": n, "error": v, "noise_floor": fl, "to_floor": ratio})
    # NaN: no measured energy, nothing to rank (last); among equal ratios (no floor) the larger error first
    rows.sort(key=lambda r: (bool(np.isnan(r["to_floor"])), -np.nan_to_num(r["to_floor"], nan=0.0, posinf=np.inf),
                             -np.nan_to_num(r["error"], nan=-np.inf)))
    return rows[:count]


def _tables(labels, sensor_names, band_num, band_den, channels, coords, floor: NoiseFloor
            ) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The band table (each band's and channel's error and share of the measured energy) and the
    worst channels (by their error over their noise floor), coordinates and bands."""
    band_table = np.sqrt(band_num / np.where(band_den > 0, band_den, np.nan))
    band_share = band_den / np.nansum(band_den)
    bands = {"labels": labels, "channels": sensor_names,
             "error": [[None if not np.isfinite(v) else float(v) for v in row] for row in band_table],
             "energy_share": [[float(v) for v in row] for row in band_share]}
    worst = _worst_channels(channels, floor)
    # NaN: the coordinate neither moved nor was predicted to (no error to rank)
    flat_coords = [(f"{en}/{b}/{c}", v) for en, bd in coords.items() for b, cd in bd.items() for c, v in cd.items()
                   if np.isfinite(v)]
    for n, v in sorted(flat_coords, key=lambda kv: -kv[1])[:3]:
        worst.append({"kind": "coordinate", "name": n, "error": v})
    with np.errstate(invalid="ignore", divide="ignore"):  # a band no record has energy in (a record of 10 MHz)
        weighted = [(labels[i], float(np.nansum(band_num[i]) / np.nansum(band_den[i])) ** 0.5,
                     float(np.nansum(band_num[i]) / np.nansum(band_num))) for i in range(len(labels))]
    weighted = [w for w in weighted if np.isfinite(w[1]) and np.isfinite(w[2])]
    for n, v, share in sorted(weighted, key=lambda t: -t[2])[:3]:
        worst.append({"kind": "band", "name": n, "error": v, "residual_share": share})
    return bands, worst


def compare(project, *, experiments: Sequence[str] | None = None, revision: Mapping[str, Any] | None = None,
            prepared: Sequence[PreparedExperiment] | None = None, resonances: bool = True,
            figures: bool = True, progress: Callable[[str], None] | None = None,
            coordinates: bool = True, tables: bool = True) -> Comparison:
    """Compare the current model revision (or ``revision``) with every experiment. ``resonances``:
    also identify measured and model resonances from FRFs (a few seconds; the fitting loop, which
    needs only the errors, leaves it out). ``figures=False``: the modal table without what only
    its figures draw (the records' FRFs where their modes are stored; ``modal_records``' FRFs
    None). ``coordinates=False``: no generalized coordinates' errors (the rigidity check stays).
    ``tables=False``: no errors per experiment, channel and band nor the worst of them (left empty:
    the fitting loop reads the pooled error, the floor, the residual peaks and the rigidity check).
    ``progress(stage)`` is told each stage as it starts."""
    from odsuite.analysis.modelrev import check_revision

    check_revision("compare", revision)
    # one BLAS thread: the matrices are small, and a second thread spinning for a busy core cost
    # 5.0 s CPU against 3.1 s (plate-and-motor bench project, loaded two-core machine)
    with threadpool_limits(1):
        return _compare(project, experiments=experiments, revision=revision, prepared=prepared,
                        resonances=resonances, figures=figures, say=progress or (lambda stage: None),
                        coordinates=coordinates, tables=tables)


def _compare(project, *, experiments, revision, prepared, resonances, figures, say, coordinates,
             tables) -> Comparison:
    from odsuite.analysis.modelrev import current_revision, revision_model

    rev = revision or current_revision(project)
    rmodel = revision_model(project, rev)
    say("reading the experiments")
    silent: list[str] = []  # records without a signal, left out
    exps = list(prepared) if prepared is not None else prepare(project, experiments, silent)
    say("predicting")
    preds = [predict(rmodel.for_experiment(e.name), e) for e in exps]
    model_modes = rmodel.shared.modes()
    modes_hz = [float(f) for f in model_modes.frequency_hz]
    # the floor a perfect model would leave is set by that model's own signals (a slow swing
    # through few ADC codes rounds to low-frequency error) and response (the force channel's
    # noise): the revision that claims to be right sets it; the rig's nominal model put 6x too
    # little rounding error below 12 Hz under a car's correctly refitted rear spring
    say("the noise floor")
    floor = noise_floor(exps, rmodel, spectra=True)

    per_exp, coords, rigidity = {}, {}, {}
    chan_num: dict[str, float] = {}
    chan_den: dict[str, float] = {}
    band_num = band_den = None
    labels: list[str] = []
    sensor_names: list[str] = []
    still: list[str] = []  # channels that never move beside live ones: compared, without an error of their own
    for e, p in zip(exps, preds):
        coords[e.name], rigidity[e.name] = _coordinates(project.rig, e, rmodel.for_experiment(e.name), coordinates)
        still += [f"{project.path}: experiment {e.name!r}: channel {e.columns[j]} ({e.sensors[j].name}) never moves "
                  "(one value in every sample): it has no error of its own (nothing measured to divide by), and the "
                  "model's motion there counts in the record's error" for j in np.flatnonzero(~e.measured.any(axis=0))]
        if not tables:
            continue
        per_ch = nrmse(e.measured, p, axis=0)
        per_exp[e.name] = {
            "error": float(nrmse(e.measured, p)),
            "noise_floor_error": floor.error([e.name]),
            "channels": {s.name: float(v) if np.isfinite(v) else None for s, v in zip(e.sensors, per_ch)},
            "trigger_sample": int(e.trigger),
        }
        for j, s in enumerate(e.sensors):
            chan_num[s.name] = chan_num.get(s.name, 0.0) + float(np.sum((e.measured[:, j] - p[:, j]) ** 2))
            chan_den[s.name] = chan_den.get(s.name, 0.0) + float(np.sum(e.measured[:, j] ** 2))
        # residual and measured energy per band and channel, summed by sensor (an experiment may
        # leave one out); a channel that never moves adds its residual to the bands' pooled errors
        labels, measured_e, residual_e = band_energies(e.measured, p, e.fs)
        if band_num is None:
            sensor_names = list(dict.fromkeys(s.name for x in exps for s in x.sensors))
            band_num = np.zeros((len(labels), len(sensor_names)))
            band_den = np.zeros_like(band_num)
        at = [sensor_names.index(s.name) for s in e.sensors]
        band_num[:, at] += residual_e
        band_den[:, at] += measured_e
    channels = {n: float(np.sqrt(chan_num[n] / chan_den[n])) if chan_den[n] > 0 else None for n in chan_num}
    bands, worst = _tables(labels, sensor_names, band_num, band_den, channels, coords, floor) if tables else ({}, [])
    modal = modal_notes = records = None
    if resonances:  # imported here: the fitting loop's comparisons (resonances=False) never load it
        from odsuite.analysis.modal_comparison import modal_records

        say("identifying modes")
        modal, modal_notes, records = modal_records(project, [e.name for e in exps], rmodel.for_experiment,
                                                    frfs=figures)
    spectra = residual_spectra(exps, preds)
    left_out = (project.rig.left_out_note({k for e in exps for k in e.columns}, "the comparison")
                if project.rig is not None else None)
    return Comparison(
        error=pooled_error(exps, preds), noise_floor_error=floor.error(),
        revision=rev.get("revision"), experiments=per_exp, channels=channels, coordinates=coords,
        bands=bands, rigidity=rigidity,
        modes={"model": model_modes.as_list(),
               **(frf_comparison(exps, preds, model_modes) if resonances else {})},
        residual_peaks=residual_peaks(exps, preds, modes_hz, floor, spectra=spectra), worst=worst, floor=floor,
        modal=modal, modal_notes=modal_notes, modal_records=records,
        notes=silent + [n for e in exps for n in e.notes] + still + ([left_out] if left_out else []),
        predictions=preds,
        residual_spectra=spectra,
    )
