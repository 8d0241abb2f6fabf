"""Measured against model modes, record by record: the modes ``odsuite modes`` identifies from a
record's hammer FRFs (its data-driven band, stable poles) paired with the modes of the model that
predicts that record; MAC where the record has two or more rig sensors (single-point tests have
no shape to compare)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from odsuite.domain.errors import ConfigError
from odsuite.analysis.frf import FrfSet
from odsuite.analysis.modal import mac, pair_modes
from odsuite.analysis.modal_project import all_flagged, flagged_note, hit_notes, hits_frf
from odsuite.analysis.stored_modes import IDENTIFICATION_ERRORS, identified_modes, stored_modes

#: a model mode further than this (relative) from a measured one is not its partner: the model
#: lacks that mode (a torsional mode seen by a bending model), and the row says so with nulls
PAIR_TOLERANCE = 0.10
#: model modes this far outside the measured band (factor) cannot pair with a measured mode
BAND_MARGIN = 1.5


@dataclass(frozen=True)
class RecordModes:
    """What the modal table of one record rests on, for its figures: the FRFs of every channel
    over the hits used (None where only the table was asked for), the fit band (None where no usable band was found), the measured modes
    (none where they could not be identified), the model modes that could pair with them and the
    MAC matrix between the two (measured x model; None for a single-point record or no modes)."""

    experiment: str
    frf: FrfSet | None
    band_hz: tuple[float, float] | None
    measured_hz: np.ndarray
    model_hz: np.ndarray
    mac: np.ndarray | None
    modes: object | None = None  # the measured modes (modal.ModalResult) where identified


def _usable_band(frf) -> tuple[float, float] | None:
    from odsuite.analysis.frf import usable_band

    try:
        lo, hi = usable_band(frf.frequency, frf.force_autospectrum, frf.coherence, frf.n_averages)
    except ConfigError:
        return None
    return float(lo), float(hi)


def _shapes(model, rig, res, channel_of: dict[str, int], modes) -> tuple[np.ndarray, np.ndarray] | None:
    """Measured and model mode shapes (sensors x modes) at the record's rig accelerometers, or None
    when fewer than two of its outputs are rig accelerometers (no shape to compare)."""
    from odsuite.domain.model import Output

    sensors = [rig.sensor_on_channel(channel_of[n]) for n in res.output_names]
    keep = [k for k, s in enumerate(sensors) if s is not None and s.quantity == "acceleration"]
    if len(keep) < 2:
        return None
    _, rows = model.output_rows([Output.sensor(sensors[k]) for k in keep])
    return res.shapes[keep], rows @ modes.shapes


def identified_record(project, name: str, *, frfs: bool = True) -> tuple[FrfSet | None, object | None, list[str]]:
    """Record ``name``'s hammer FRFs over its hits (every hit, with a note, where all are flagged)
    and the modes identified from them as ``odsuite modes`` identifies them (the stored ones while
    they hold), with notes (what its hits are told, ``modal_project.hit_notes``, as `frf`, `modes`
    and `process` tell them); the modes None where they could not be identified (the note says why).
    ``frfs=False``: a record with stored modes has no FRFs estimated (None)."""
    exp = project.experiment(name)
    notes: list[str] = []
    frf = None
    stored = None if frfs else stored_modes(project, exp)
    try:
        if stored is None:
            frf, hits = hits_frf(exp, f"{project.path}: experiment {name!r}", flagged_too=True)
            flagged, said = all_flagged(hits), hit_notes(hits, frf)
        else:
            flagged, said = stored.flagged, stored.hit_notes
        notes += [f"{name}: {note}" for note in said]
        if flagged:
            notes.append(f"{name}: {flagged_note(flagged)}")
        # stored by `process` while the record is unchanged
        return frf, (stored.modes() if stored is not None else identified_modes(project, exp, frf)), notes
    except IDENTIFICATION_ERRORS as exc:  # ConfigError covers a record without a clean hit
        return frf, None, notes + [f"{name}: measured modes not identified: {exc}"]


def modal_records(project, experiments: Sequence[str], model_for, *, frfs: bool = True
                  ) -> tuple[list[dict[str, Any]], list[str], list[RecordModes]]:
    """Rows ``{"experiment", "measured_hz", "model_hz", "measured_zeta", "model_zeta", "mac"}`` for
    every measured mode of every record (model values None where the model has no mode within
    PAIR_TOLERANCE), notes for records whose modes could not be identified, and the
    :class:`RecordModes` of each record whose modes were (the report's FRF and MAC figures draw
    them). ``model_for(name)`` is the model that predicts record ``name``. ``frfs=False``: the
    table alone; a record with stored modes (``stored_modes``) then has no FRFs estimated
    (``RecordModes.frf`` None)."""
    rows: list[dict[str, Any]] = []
    notes: list[str] = []
    records: list[RecordModes] = []
    rig = project.rig
    for name in experiments:
        exp = project.experiment(name)
        frf, res, said = identified_record(project, name, frfs=frfs)
        notes += said
        if res is None:
            if frf is not None:  # the FRFs are there to look at all the same
                records.append(RecordModes(name, frf, _usable_band(frf), np.empty(0), np.empty(0), None))
            continue
        if res.poles.size == 0:
            notes.append(f"{name}: no measured mode in {res.band_hz} Hz")
            records.append(RecordModes(name, frf, res.band_hz, np.empty(0), np.empty(0), None, res))
            continue
        model = model_for(name)
        modes = model.modes()
        lo, hi = res.band_hz
        keep = np.flatnonzero((modes.frequency_hz >= lo / BAND_MARGIN) & (modes.frequency_hz <= hi * BAND_MARGIN)
                              & (modes.damping_ratio < 1.0))
        channel_of = {n: k for k, n in enumerate(exp.channel_names)}
        shapes = _shapes(model, rig, res, channel_of, modes) if rig is not None else None
        pairs = pair_modes(res.frequency_hz, res.damping_ratio, modes.frequency_hz[keep], modes.damping_ratio[keep],
                           shapes_a=shapes[0] if shapes is not None else None,
                           shapes_b=shapes[1][:, keep] if shapes is not None else None,
                           within=PAIR_TOLERANCE) if keep.size else []
        partner = {p["mode_a"]: p for p in pairs if abs(p["frequency_difference"]) <= PAIR_TOLERANCE}
        for i, (f, z) in enumerate(zip(res.frequency_hz, res.damping_ratio)):
            p = partner.get(i)
            rows.append({"experiment": name, "measured_hz": float(f), "measured_zeta": float(z),
                         "model_hz": p["frequency_b_hz"] if p else None, "model_zeta": p["damping_b"] if p else None,
                         "mac": p["mac"] if p else None})
        records.append(RecordModes(
            name, frf, (float(lo), float(hi)), np.asarray(res.frequency_hz, dtype=float),
            np.asarray(modes.frequency_hz[keep], dtype=float),
            mac(shapes[0], shapes[1][:, keep]) if shapes is not None and keep.size else None, res))
    return rows, notes, records
