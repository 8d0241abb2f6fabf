"""Hammer-test workflow on a project: FRFs per experiment, identified modes (from the FRFs, or
from the responses alone for operating records).

Experiments imported from engineering-unit files store those values as the raw column with a
sensitivity that converts them to SI (1 V per unit, g -> m/s^2 through 1/9.81 V per m/s^2).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from odsuite.domain import arguments
from odsuite.domain.errors import ConfigError, DimensionError
from odsuite.analysis.frf import FrfSet, estimate_frf
from odsuite.analysis.hammer import assess_hits, held_range, hit_name
from odsuite.analysis.modal import ModalResult, identify_modes
from odsuite.store.project import DerivedArray, open_project
from odsuite.domain.systeminfo import SensorType
from odsuite.domain.version import __version__

def _scale(exp) -> np.ndarray:
    """Per channel: SI units per stored raw unit."""
    return np.array([(-1 if c.invert else 1) / (c.sensitivity * c.daq_gain) for c in exp.systeminfo.channels])


def physical(exp) -> np.ndarray:
    return exp.raw() * _scale(exp)


#: sensor types whose channels are structural responses (an open input, an auxiliary signal, a
#: load cell or a sound pressure is not)
RESPONSE_TYPES = (SensorType.ACCELEROMETER, SensorType.PROXIMITY, SensorType.VOLTAGE, SensorType.VELOCITY)


def response_columns(exp) -> list[int]:
    """Columns holding responses: typed response channels other than the force channel; when a
    record types none (a file of unknown units), every column but the force channel."""
    force = exp.excitation.force_channel if exp.excitation is not None else None
    rest = [k for k in range(exp.n_channels) if k != force]
    typed = [k for k in rest if exp.systeminfo.channels[k].sensor_type in RESPONSE_TYPES]
    return typed or rest


def unrecorded_columns(exp, data: np.ndarray) -> list[int]:
    """Channels ``exp`` does not hold (``data``: its samples): no sensor and every sample zero, as
    an import stores the rig's channels its file has no column for."""
    return [k for k, c in enumerate(exp.systeminfo.channels)
            if c.sensor_type == SensorType.NONE and not np.any(data[:, k])]


def unrecorded_note(project, name: str, frf: FrfSet) -> str | None:
    """The line naming record ``name``'s channels its FRFs ``frf`` leave out as not recorded
    (``unrecorded_columns``), by the rig's sensor on each; None when they leave none out."""
    exp = project.experiment(name)
    force = exp.excitation.force_channel if exp.excitation is not None else None
    left = [k for k in range(exp.n_channels) if k != force and exp.channel_names[k] not in frf.output_names]
    if not left:
        return None
    sensors = [project.rig.sensor_on_channel(k) if project.rig is not None else None for k in left]
    named = ", ".join(s.name if s is not None else exp.channel_names[k] for k, s in zip(left, sensors))
    one = len(left) == 1
    return (f"{'channel' if one else 'channels'} {named} {'was' if one else 'were'} not recorded (the file imported has "
            f"no column for {'it' if one else 'them'}; stored as zeros): no FRF is estimated for {'it' if one else 'them'}")


def unrecorded_notes(project: str | Path, frfs: dict[str, FrfSet]) -> dict[str, str]:
    """``unrecorded_note`` of each experiment whose FRFs ``frfs`` leave channels out."""
    with open_project(project) as p:
        notes = {e: unrecorded_note(p, e, frf) for e, frf in frfs.items()}
    return {e: n for e, n in notes.items() if n}


def _converter_ranges(exp, data: np.ndarray) -> list[tuple[float, float] | None]:
    """Each channel's converter range in the channel's SI units, None where unknown
    (``hammer.held_range``: the Systeminfo DAQ limits where the samples stay inside them)."""
    return [held_range(data[:, k], c.limit_low * s, c.limit_high * s)
            for k, (c, s) in enumerate(zip(exp.systeminfo.channels, _scale(exp)))]


def record_hits(exp, where: str, *, record_length: int | None = None) -> tuple[np.ndarray, list[int], list]:
    """An experiment's data in SI units (samples x channels), its response columns (every channel
    but the force channel and those it does not hold: ``unrecorded_columns``) and its hits:
    ``assess_hits`` of those responses to the force, judged against the converters' ranges."""
    if exp.excitation is None:
        raise ConfigError(f"{where} has no force channel")
    data = physical(exp)
    limits = _converter_ranges(exp, data)
    fidx = exp.excitation.force_channel
    empty = unrecorded_columns(exp, data)
    outs = [k for k in range(exp.n_channels) if k != fidx and k not in empty]
    if not outs:  # 'H1 FRFs of 0 channels' were stored
        raise ConfigError(f"{where} holds its force channel {exp.channel_names[fidx]!r} alone: no response to "
                          "estimate FRFs of")
    hits = assess_hits(data[:, fidx], data[:, outs], exp.sampling_rate, record_length=record_length,
                       force_limits=limits[fidx], response_limits=[limits[k] for k in outs])
    return data, outs, hits


def hits_frf(exp, where: str, *, estimator: str = "H1", record_length: int | None = None,
             flagged_too: bool = False) -> tuple[FrfSet, list]:
    """FRFs of every channel of an experiment (as read from a project) to its force channel over
    its accepted hits, and the hit list; nothing is stored. ``flagged_too``: a record whose every
    hit is flagged (clipped, double) uses them all rather than failing (the caller says so)."""
    data, outs, hits = record_hits(exp, where, record_length=record_length)
    fidx = exp.excitation.force_channel
    good = averaged(hits, flagged_too)
    if not good:
        raise ConfigError(f"{where} has no acceptable hit ({hit_flags(hits) or 'no hits found'})")
    units = [exp.systeminfo.channels[k].unit for k in outs]
    frf = estimate_frf(
        [data[h.start : h.stop, fidx] for h in good], [data[h.start : h.stop, outs] for h in good],
        exp.sampling_rate, estimator=estimator, response_units=units,
        output_names=[exp.channel_names[k] for k in outs],
    )
    return frf, hits


def averaged(hits, flagged_too: bool = True) -> list:
    """The hits whose records the FRFs average: the accepted ones, else (``flagged_too``) every one
    whose record lies in the data and holds its whole blow (a left-out hit's is not one of the
    others' length, or lacks the end of its blow)."""
    return [h for h in hits if h.accepted] or ([h for h in hits if not h.left_out] if flagged_too else [])


def hit_flags(hits) -> str:
    """What the hammer checks found wrong with the rejected hits, in one line ("" when nothing)."""
    return "; ".join(f"{hit_name(h.time)}: {', '.join(h.reasons)}" for h in hits if not h.accepted)


def leakage_note(hits, output_names) -> str | None:
    """A line naming the responses (``output_names``, in the order ``assess_hits`` had them) that
    have not decayed by the end of the averaged hits' records (``Hit.undecayed``), each with the
    most of its peak it kept there and the hits' times; None when every one decayed."""
    worst: dict[int, float] = {}
    times = []
    for h in averaged(hits):
        for c, ratio in h.undecayed:
            worst[c] = max(worst.get(c, 0.0), ratio)
        if h.undecayed:
            times.append(f"{h.time:.4g}")
    if not worst:
        return None
    levels = ", ".join(f"{output_names[c]} at {100 * r:.1f} %" for c, r in sorted(worst.items()))
    several = len(times) > 1
    return (f"{'hits' if several else 'hit'} at {', '.join(times)} s: still ringing at the end of "
            f"{'their records' if several else 'its record'}: {levels} of {'its peak' if len(worst) == 1 else 'their peaks'} (leakage: the FRFs' peaks read wider, "
            "as if more damped; record longer after each hit, or hit less often)")


def hit_notes(hits, frf: FrfSet) -> list[str]:
    """What a record's hits are told beside its FRFs ``frf``, each once: what the data's ends did
    with them (``data_end_notes``) and its leakage (``leakage_note``)."""
    leakage = leakage_note(hits, frf.output_names)
    return data_end_notes(hits) + ([leakage] if leakage else [])


def data_end_notes(hits) -> list[str]:
    """What the data's ends did with the hits (``Hit.data_end``): left out, or every record cut short."""
    return [h.data_end for h in hits if h.data_end]


def all_flagged(hits) -> str:
    """``hit_flags`` when every hit is flagged (its FRFs then rest on flagged hits), else ""."""
    return "" if any(h.accepted for h in hits) else hit_flags(hits)


def flagged_note(flags: str, what: str = "modes are identified") -> str:
    """What a record whose every hit is flagged (``all_flagged``) is told when its modes (or, with
    ``what="FRFs are estimated"``, its FRFs) come from those hits all the same."""
    return f"every hit is flagged ({flags}): its {what} from them anyway and may be biased"


def experiment_frf(
    project: str | Path, experiment: str, *, estimator: str = "H1", record_length: int | None = None,
    before_store: Callable[[FrfSet], object] | None = None, flagged_too: bool = False,
) -> tuple[FrfSet, list]:
    """FRFs of every channel to the force channel over the experiment's accepted hits (``hits_frf``,
    ``flagged_too`` as there); stored as the derived group ``frf`` (H real/imag, coherence).
    Returns the FRFs and the hit list. ``before_store(frf)`` runs first: when it fails (a fit on
    these FRFs), nothing is stored."""
    with open_project(project, "a") as p:
        frf, hits = hits_frf(p.experiment(experiment), f"{project}: experiment {experiment!r}",
                             estimator=estimator, record_length=record_length, flagged_too=flagged_too)
        if before_store is not None:
            before_store(frf)
        _store_frf(p, experiment, frf, hits, estimator, record_length)
    return frf, hits


def _store_frf(p, experiment: str, frf: FrfSet, hits: list, estimator: str, record_length: int | None) -> None:
    """An experiment's FRFs as its derived group ``frf``, with the settings they were estimated with."""
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


@contextmanager
def said_of(where: str) -> Iterator[None]:
    """A fit's errors, which speak of the data alone, prefixed with the record they are about."""
    try:
        yield
    except (ConfigError, DimensionError) as exc:
        raise type(exc)(f"{where}: {exc}") from None


def frf_modes(frf: FrfSet, *, f_band: tuple[float, float] | None = None, max_order: int = 50,
              frequencies: list[float] | None = None) -> ModalResult:
    """Modes identified from hammer FRFs, on the band where the hammer's force spectrum and the
    coherence are usable (``frf.usable_band``) unless ``f_band`` (or one edge of it) is given."""
    if not isinstance(frf, FrfSet):
        arguments.refuse("frf_modes", "frf", frf, "an FrfSet (estimate_frf)")
    return identify_modes(frf.frequency, frf.H, f_band=f_band, max_order=max_order, frequencies=frequencies,
                          output_names=frf.output_names, force_autospectrum=frf.force_autospectrum,
                          coherence=frf.coherence, n_averages=frf.n_averages, where="frf_modes")


def experiment_modes(
    project: str | Path, experiment: str, *, f_band: tuple[float, float] | None = None,
    max_order: int = 50, frequencies: list[float] | None = None, flagged_too: bool = False,
) -> tuple[ModalResult, FrfSet, list]:
    """Modes identified from the experiment's FRFs (``frf_modes``), those FRFs, stored, and the
    hit list (``flagged_too`` as in ``hits_frf``)."""
    found: list[ModalResult] = []

    def fit(frf: FrfSet) -> None:
        with said_of(f"{project}: experiment {experiment!r}"):
            found.append(frf_modes(frf, f_band=f_band, max_order=max_order, frequencies=frequencies))

    frf, hits = experiment_frf(project, experiment, flagged_too=flagged_too, before_store=fit)
    return found[0], frf, hits


def experiments_modes(
    project: str | Path, experiments: list[str], *, f_band: tuple[float | None, float | None] | None = None,
    max_order: int = 50, frequencies: list[float] | None = None, flagged_too: bool = False,
) -> tuple[ModalResult, np.ndarray, np.ndarray, dict[str, dict], dict[str, list], dict[str, FrfSet]]:
    """Modes of an FRF matrix across experiments: a roving hammer (each experiment hits another
    point) or several references. Every experiment's FRFs (stored as its derived "frf" once the
    fit passed, all in one commit) on the same lines are stacked into one matrix whose rows are "output @ experiment", and fitted with
    one common denominator (LSCF, ``modal.identify_modes``); the default band is the overlap of the
    experiments' usable bands. Returns the modes (shapes per row), the frequency lines, the matrix
    (rows x lines), each experiment's reference (force point in m, direction), its hit list
    (``flagged_too`` as in ``hits_frf``) and its FRFs."""
    from odsuite.analysis.frf import usable_band

    if len(set(experiments)) != len(experiments):
        raise ConfigError(f"{project}: an experiment is named twice in {', '.join(experiments)}")
    # computed first and stored only when the fit succeeds: a failing command leaves the project as it was
    with open_project(project) as p:
        def estimated(record_length: int | None) -> list[tuple[FrfSet, list]]:
            return [hits_frf(p.experiment(e), f"{project}: experiment {e!r}", record_length=record_length,
                             flagged_too=flagged_too) for e in experiments]

        record_length = None
        found = estimated(record_length)
        # each hit's window ends where its record ends: one common length. Windows of 2m and 2m + 1
        # samples give the same count of lines on other frequencies, so the lines are compared
        lines = {(f.frequency.size, float(f.frequency[-1])) for f, _ in found}
        if len(lines) > 1:
            record_length = 2 * (min(size for size, _ in lines) - 1)
            found = estimated(record_length)
        references = {}
        for e in experiments:
            exc = p.experiment(e).excitation
            references[e] = {"point_m": [float(v) for v in exc.point], "direction": [float(v) for v in exc.direction]}
    frfs = [f for f, _ in found]
    first = frfs[0]
    for e, f in zip(experiments[1:], frfs[1:]):
        if f.frequency.shape != first.frequency.shape or not np.allclose(f.frequency, first.frequency):
            raise ConfigError(f"{project}: experiment {e!r} has other frequency lines ({f.frequency.size} up to "
                              f"{f.frequency[-1]:g} Hz) than {experiments[0]!r} ({first.frequency.size} up to "
                              f"{first.frequency[-1]:g} Hz): an FRF matrix needs one sampling rate and record length")
    bands = []
    for e, f in zip(experiments, frfs):
        with said_of(f"{project}: experiment {e!r}"):
            bands.append(usable_band(f.frequency, f.force_autospectrum, f.coherence, f.n_averages))
    lo, hi = f_band if f_band is not None else (None, None)
    lo = max(b[0] for b in bands) if lo is None else lo
    hi = min(b[1] for b in bands) if hi is None else hi
    if not lo < hi:
        raise ConfigError(f"{project}: the experiments' usable bands do not overlap "
                          f"({'; '.join(f'{e} {b[0]:g}-{b[1]:g} Hz' for e, b in zip(experiments, bands))})")
    H = np.vstack([f.H for f in frfs])
    rows = [f"{o} @ {e}" for e, f in zip(experiments, frfs) for o in f.output_names]
    with said_of(f"{project}: experiments {', '.join(map(repr, experiments))}"):
        res = identify_modes(first.frequency, H, f_band=(lo, hi), max_order=max_order, frequencies=frequencies,
                             output_names=rows)
    with open_project(project, "a") as p:  # one commit: every experiment's FRFs
        for e, (frf, hits) in zip(experiments, found):
            _store_frf(p, e, frf, hits, "H1", record_length)
    return (res, first.frequency, H, references, {e: hits for e, (_, hits) in zip(experiments, found)},
            dict(zip(experiments, frfs)))


def experiment_output_only_modes(
    project: str | Path, experiment: str, *, f_band: tuple[float | None, float | None] | None = None,
    max_order: int | None = None, block_rows: int | None = None, decimation: int | None = None,
) -> tuple[ModalResult, np.ndarray, np.ndarray, str]:
    """Modes from the experiment's responses alone (SSI-cov and EFDD, ``oma.identify_output_only``):
    the response channels (``response_columns``), in SI units. Returns the modes, the responses'
    rms amplitude spectral density (frequencies in Hz, amplitude in unit/√Hz) for the stabilisation
    figure, and that unit ("mixed units" when the channels differ)."""
    import scipy.signal

    from odsuite.analysis.oma import MAX_ORDER, identify_output_only

    max_order = MAX_ORDER if max_order is None else max_order
    with open_project(project) as p:
        exp = p.experiment(experiment)
        data = physical(exp)
        outs = response_columns(exp)
        names = [exp.channel_names[k] for k in outs]
        units = {exp.systeminfo.channels[k].unit for k in outs}
        fs = exp.sampling_rate
    with said_of(f"{project}: experiment {experiment!r}"):
        res = identify_output_only(data[:, outs], fs, f_band=f_band, max_order=max_order, block_rows=block_rows,
                                   decimation=decimation, output_names=names)
    freq, psd = scipy.signal.welch(data[:, outs], fs, nperseg=min(4096, data.shape[0]), axis=0)
    unit = f"{units.pop()}/√Hz" if len(units) == 1 else "mixed units"
    return res, freq, np.sqrt(psd.T), unit


def ods_coordinates(project, experiment: str, frequency_hz: float) -> dict[str, np.ndarray]:
    """Operating deflection shape at ``frequency_hz`` as rigid-body motion: per nine-sensor body,
    complex generalized coordinates at G (m and rad per newton of a harmonic force at the
    experiment's force point), from the measured accelerance FRFs (H1 over the windowed force,
    with the channels' own filters divided out) divided by -omega^2 and solved like any
    displacement record."""
    import scipy.signal

    from odsuite.analysis.prediction import prepare_experiment
    from odsuite.analysis.modal import ods
    from odsuite.contracts.solvers import harmonic_shapes

    frequency_hz = arguments.real("ods_coordinates", "frequency_hz", frequency_hz, positive=True)
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
    return harmonic_shapes(project.rig, {s.name: d for s, d in zip(exp.sensors, disp)},
                           project.registries.coordinate_solvers, f"{project.path}: ODS")


def ods_motion(shapes: dict[str, np.ndarray], frequency_hz: float, *, cycles: int = 3,
               frames_per_cycle: int = 40) -> tuple[dict[str, np.ndarray], float]:
    """Time histories Re(D e^{i omega t}) of ODS shapes over a few cycles, and their sample rate."""
    fs = frames_per_cycle * frequency_hz
    t = np.arange(cycles * frames_per_cycle) / fs
    phasor = np.exp(2j * np.pi * frequency_hz * t)
    return {b: np.real(phasor[:, None] * d[None, :]) for b, d in shapes.items()}, fs
