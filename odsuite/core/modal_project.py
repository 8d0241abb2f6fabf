"""Hammer-test workflow on a project: import LabVIEW records, FRFs per experiment, identified modes
(from the FRFs, or from the responses alone for operating records).

Experiments imported from engineering-unit files store those values as the raw column with a
sensitivity that converts them to SI (1 V per unit, g -> m/s^2 through 1/9.81 V per m/s^2).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from odsuite.core.errors import ConfigError
from odsuite.core.frf import FrfSet, estimate_frf
from odsuite.core.hammer import assess_hits
from odsuite.core.lvm import read_lvm
from odsuite.core.modal import ModalResult, identify_modes
from odsuite.core.project import DerivedArray, Excitation, open_project
from odsuite.core.rig_import import names_the_rig, onto_rig
from odsuite.core.systeminfo import ChannelInfo, SensorType, Systeminfo
from odsuite.core.version import __version__

G = 9.80665
#: LabVIEW unit labels -> (sensor type, volts per SI unit of the stored value)
_UNITS = {
    "n": (SensorType.LOADCELL, 1.0), "newtons": (SensorType.LOADCELL, 1.0),
    "m/s^2": (SensorType.ACCELEROMETER, 1.0), "m/s2": (SensorType.ACCELEROMETER, 1.0),
    "g": (SensorType.ACCELEROMETER, 1.0 / G), "volts": (SensorType.VOLTAGE, 1.0), "v": (SensorType.VOLTAGE, 1.0),
}


def _force_index(names: list[str], units: list[str], force_channel: str | None, where: str) -> int:
    if force_channel is not None:
        if force_channel not in names:
            raise ConfigError(f"{where}: no channel {force_channel!r}; channels are {', '.join(names)}")
        return names.index(force_channel)
    cand = [i for i, (n, u) in enumerate(zip(names, units)) if u.lower() in ("n", "newtons") or "force" in n.lower()]
    if len(cand) != 1:
        raise ConfigError(f"{where}: cannot tell the force channel among {', '.join(names)}; give --force-channel")
    return cand[0]


def import_lvm(project: str | Path, lvm_path: str | Path, name: str, force_channel: str | None = None, *,
               force_point: np.ndarray | None = None, force_dir: np.ndarray | None = None,
               force_body: str | None = None) -> tuple[str, ...]:
    """Add a LabVIEW ``.lvm`` record to a project as experiment ``name``; returns notes for the user.

    On a project with a rig the columns are laid onto the rig's channels (by sensor name, else in
    order; :mod:`odsuite.core.rig_import`) and the hammer's ``force_point`` (m, rig frame) and
    ``force_dir`` are required (``force_body`` when the point lies on two bodies); without a rig, or when the columns are not the rig's channels and
    no force point is given (a single-point test kept beside the rig's records, said in a note),
    the columns are stored as they are."""
    d = read_lvm(lvm_path)
    d.check_complete()
    with open_project(project, "a") as p:
        on_rig = p.rig is not None and (force_point is not None or force_dir is not None
                                        or names_the_rig(p.rig, d.channel_names))
        if on_rig:
            rec = onto_rig(p.rig, d.channel_names, d.units, d.data, d.sampling_rate, str(lvm_path), force_point,
                           force_dir, force_channel, force_body)
            p.add_experiment(name, rec.raw, sampling_rate=d.sampling_rate, systeminfo=rec.systeminfo,
                             excitation=rec.excitation, source=str(Path(lvm_path).name),
                             channel_names=rec.channel_names)
            return rec.notes
        if force_point is not None or force_dir is not None or force_body is not None:
            raise ConfigError(f"{lvm_path}: --force-point/--force-dir/--force-body need a project with a rig geometry")
        notes: tuple[str, ...] = ()
        if p.rig is not None:  # e.g. a single-point beam test kept beside the rig's records
            notes = (f"{lvm_path}: its columns ({', '.join(d.channel_names)}) are not rig {p.rig.name!r}'s channels: "
                     "stored as they are, without the rig's geometry",)
        fidx = _force_index(d.channel_names, d.units, force_channel, str(lvm_path))
        # a .lvm in engineering units holds no converter range: limits well above the peaks, so that
        # volt limits are never applied to g or N (clipping is then told by flat tops alone)
        limits = np.maximum(10.0, np.ceil(2 * np.abs(d.data).max(axis=0)))
        channels = []
        for k, (n, u) in enumerate(zip(d.channel_names, d.units)):
            stype, sens = _UNITS.get(u.strip().lower(), (SensorType.NONE, 1.0))
            if k == fidx:
                stype, sens = SensorType.LOADCELL, 1.0  # force values are newtons whatever the label says
            channels.append(ChannelInfo(sensor_type=stype, location=n, sensitivity=sens, sampling_rate=d.sampling_rate,
                                        limit_high=float(limits[k]), limit_low=-float(limits[k])))
        p.add_experiment(
            name, d.data, sampling_rate=d.sampling_rate, systeminfo=Systeminfo(channels),
            # a .lvm file holds no geometry: point at the origin, direction +z by convention
            excitation=Excitation(fidx, np.zeros(3), np.array([0.0, 0.0, 1.0])), source=str(Path(lvm_path).name),
            channel_names=list(d.channel_names),
        )
    return notes


def _scale(exp) -> np.ndarray:
    """Per channel: SI units per stored raw unit."""
    return np.array([(-1 if c.invert else 1) / (c.sensitivity * c.daq_gain) for c in exp.systeminfo.channels])


def _physical(exp) -> np.ndarray:
    return exp.raw() * _scale(exp)


def _converter_ranges(exp, data: np.ndarray) -> list[tuple[float, float] | None]:
    """Each channel's converter range in the channel's SI units, None where unknown. The Systeminfo
    DAQ limits are what the operator asked for; a card then picks the smallest hardware range
    holding them (NI: 0.05..10 V), so samples beyond the limits show the real range is wider and
    not known here (clipping is then told by flat tops alone, see ``hammer.is_clipped``)."""
    out: list[tuple[float, float] | None] = []
    for k, (c, s) in enumerate(zip(exp.systeminfo.channels, _scale(exp))):
        lo, hi = sorted((c.limit_low * s, c.limit_high * s))
        inside = data[:, k].min() >= lo and data[:, k].max() <= hi
        out.append((lo, hi) if inside else None)
    return out


def experiment_frf(
    project: str | Path, experiment: str, *, estimator: str = "H1", record_length: int | None = None,
    before_store: Callable[[FrfSet], object] | None = None,
) -> tuple[FrfSet, list]:
    """FRFs of every channel to the force channel over the experiment's accepted hits; stored as
    the derived group ``frf`` (H real/imag, coherence). Returns the FRFs and the hit list.
    ``before_store(frf)`` runs first: when it fails (a fit on these FRFs), nothing is stored."""
    with open_project(project, "a") as p:
        exp = p.experiment(experiment)
        if exp.excitation is None:
            raise ConfigError(f"{project}: experiment {experiment!r} has no force channel")
        data = _physical(exp)
        limits = _converter_ranges(exp, data)
        fidx = exp.excitation.force_channel
        outs = [k for k in range(exp.n_channels) if k != fidx]
        hits = assess_hits(data[:, fidx], data[:, outs], exp.sampling_rate, record_length=record_length,
                           force_limits=limits[fidx], response_limits=[limits[k] for k in outs])
        good = [h for h in hits if h.accepted]
        if not good:
            reasons = "; ".join(f"hit at sample {h.peak_index}: {', '.join(h.reasons)}" for h in hits) or "no hits found"
            raise ConfigError(f"{project}: experiment {experiment!r} has no acceptable hit ({reasons})")
        units = [exp.systeminfo.channels[k].unit for k in outs]
        frf = estimate_frf(
            [data[h.start : h.stop, fidx] for h in good], [data[h.start : h.stop, outs] for h in good],
            exp.sampling_rate, estimator=estimator, response_units=units,
            output_names=[exp.channel_names[k] for k in outs],
        )
        if before_store is not None:
            before_store(frf)
        dims = ("output", "frequency")
        p.write_derived(
            experiment, "frf",
            {
                "frequency": DerivedArray(frf.frequency, "Hz", ("frequency",)),
                "H_real": DerivedArray(frf.H.real, ";".join(frf.units), dims),
                "H_imag": DerivedArray(frf.H.imag, ";".join(frf.units), dims),
                "coherence": DerivedArray(frf.coherence, "1", dims),
            },
            provenance={"plugin": "odsuite.frf", "version": __version__,
                        "parameters": json.dumps({"estimator": estimator, "record_length": record_length}),
                        "inputs": experiment},
            attrs={"outputs": json.dumps(frf.output_names), "n_averages": frf.n_averages,
                   "hits": json.dumps([{"peak": h.peak_index, "accepted": h.accepted, "reasons": list(h.reasons)}
                                       for h in hits])},
        )
    return frf, hits


def experiment_modes(
    project: str | Path, experiment: str, *, f_band: tuple[float, float] | None = None,
    max_order: int = 50, frequencies: list[float] | None = None,
) -> tuple[ModalResult, FrfSet]:
    """Modes identified from the experiment's FRFs, and those FRFs; the default band (or a
    missing edge of ``f_band``) is where the hammer's force spectrum and the coherence are usable
    (``frf.usable_band``)."""
    found: list[ModalResult] = []
    frf, _ = experiment_frf(project, experiment, before_store=lambda frf: found.append(identify_modes(
        frf.frequency, frf.H, f_band=f_band, max_order=max_order, frequencies=frequencies,
        output_names=frf.output_names, force_autospectrum=frf.force_autospectrum, coherence=frf.coherence,
        n_averages=frf.n_averages)))
    return found[0], frf


def experiment_output_only_modes(
    project: str | Path, experiment: str, *, f_band: tuple[float | None, float | None] | None = None,
    max_order: int = 40,
) -> tuple[ModalResult, np.ndarray, np.ndarray]:
    """Modes from the experiment's responses alone (SSI-cov, ``oma.identify_output_only``): every
    channel but the force channel, in SI units. Returns the modes and the responses' rms power
    spectral density (frequencies in Hz, PSD in unit^2/Hz) for the stabilisation figure."""
    import scipy.signal

    from odsuite.core.oma import identify_output_only

    with open_project(project) as p:
        exp = p.experiment(experiment)
        data = _physical(exp)
        force = exp.excitation.force_channel if exp.excitation is not None else None
        outs = [k for k in range(exp.n_channels) if k != force]
        names = [exp.channel_names[k] for k in outs]
        fs = exp.sampling_rate
    res = identify_output_only(data[:, outs], fs, f_band=f_band, max_order=max_order, output_names=names)
    freq, psd = scipy.signal.welch(data[:, outs], fs, nperseg=min(4096, data.shape[0]), axis=0)
    return res, freq, np.sqrt(psd.T)


def ods_coordinates(project, experiment: str, frequency_hz: float) -> dict[str, np.ndarray]:
    """Operating deflection shape at ``frequency_hz`` as rigid-body motion: per nine-sensor body,
    complex generalized coordinates at G (m and rad per newton of a harmonic force at the
    experiment's force point), from the measured accelerance FRFs (H1 over the windowed force,
    with the channels' own filters divided out) divided by -omega^2 and solved like any
    displacement record."""
    import scipy.signal

    from odsuite.core.prediction import prepare_experiment
    from odsuite.core.modal import ods
    from odsuite.core.plugins import registries
    from odsuite.core.solvers import body_solvers

    if not (np.isfinite(frequency_hz) and frequency_hz > 0):
        raise ConfigError(f"ODS frequency: must be > 0 Hz, got {frequency_hz!r}")
    exp = prepare_experiment(project, experiment)
    frf = estimate_frf([exp.force], [exp.measured], exp.fs)
    accel = ods(frf.frequency, frf.H, frequency_hz)
    for op in exp.operators or ():
        # the chain's filter 1 shaped the measured stage: take its response out (a zero-phase pair
        # acts as |H|^2)
        response = 1.0 / op.factor
        for sos, zero_phase in op.filters:
            h = scipy.signal.sosfreqz(sos, worN=[frequency_hz], fs=exp.fs)[1][0]
            response *= abs(h) ** 2 if zero_phase else h
        accel[list(op.columns)] /= response
    disp = -accel / (2 * np.pi * frequency_hz) ** 2
    shapes = {}
    # the solvers are linear in their input: real and imaginary parts as a two-sample record
    signals = {s.name: np.array([d.real, d.imag]) for s, d in zip(exp.sensors, disp)}
    chosen, notes = body_solvers(project.rig, signals, registries().coordinate_solvers)
    for c in chosen:
        at_g = c.solver.solve(project.rig, c.body, {n: signals[n] for n in c.sensors}).at_g
        shapes[c.body.name] = at_g[0] + 1j * at_g[1]
    if not shapes:
        raise ConfigError(f"{project.path}: rig {project.rig.name!r}: no body's motion can be solved from the "
                          f"recorded sensors for an ODS ({'; '.join(notes) or 'no sensors'})")
    return shapes


def ods_motion(shapes: dict[str, np.ndarray], frequency_hz: float, *, cycles: int = 3,
               frames_per_cycle: int = 40) -> tuple[dict[str, np.ndarray], float]:
    """Time histories Re(D e^{i omega t}) of ODS shapes over a few cycles, and their sample rate."""
    fs = frames_per_cycle * frequency_hz
    t = np.arange(cycles * frames_per_cycle) / fs
    phasor = np.exp(2j * np.pi * frequency_hz * t)
    return {b: np.real(phasor[:, None] * d[None, :]) for b, d in shapes.items()}, fs
