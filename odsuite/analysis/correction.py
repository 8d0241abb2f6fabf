"""Model-based correction of the measured motion (thesis Fig. 3.7, Ch. 6.2).

The signal-based processing (Table E.2) high-pass filters the accelerations twice to stop drift
from growing through the double integration. On a rig on springs that removes real motion: a hit's
displacement has a spectrum flat from DC up to the first resonance, so a causal 20 Hz high-pass
throws away the quasi-static part and leaves a slow baseline ringing as long as the record.

Here the measurement is integrated WITHOUT high-pass filters (conversion, inversion and the
offset window only, centred trapezoid rule) and the current model revision, driven by the measured
force, fills in what the measurement cannot carry:

1. Each sensor's measured displacement ``d_m`` and the model's ``d_p`` (predicted acceleration
   through the same chain) differ by ``r = drift + integrated noise + model error``.
2. Drift model: a cubic in time fitted to ``r`` by least squares, i.e. an acceleration offset and a
   linear acceleration drift (what the offset window leaves and what the amplifier adds) plus
   initial displacement and velocity errors.
3. What remains of ``r`` below ``cutoff_hz`` (the double-integrated noise, a random walk) is
   taken by a zero-phase Butterworth low-pass; above ``cutoff_hz`` the measurement is kept.

Before the drift is estimated, the distortions the loop diagnosed in the measurement itself are
removed (thesis Ch. 3: "the measured (actual) signals are corrected by removing estimated
distortions"): every effect of the current revision that describes the measurement chain and
says how to undo it (``correct``, :mod:`odsuite.contracts.effects`) is undone on the measured
displacements, from the converter back (channel, wiring, sensor stage); a tilted or moved sensor
is re-expressed along its nominal axis at its nominal place from the motion its body's sensors
record together (least squares over the body's sensors as mounted). The model the drift is
estimated against is the revision without those effects: the structure as fitted, seen by an
ideal chain. Each correction's uncertainty is the change of the corrected coordinates when its
fitted values move by their standard errors (one at a time, added in quadrature).

The corrected displacement ``d_m - drift`` is the model below ``cutoff_hz`` and the measurement
above it (a complementary blend without phase shift); the same solver as the signal-based
processing turns it into generalized coordinates. The default cutoff is half the model's lowest
natural frequency: below it the response is quasi-static, set by the stiffness the model was
fitted for; the resonances above it come from the measurement.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.signal

from odsuite.domain.errors import ConfigError
from odsuite.domain.systeminfo import ChannelInfo, Integration

#: Derived kind of the corrected coordinates (same datasets as "gencoords", plus "drift").
KIND = "gencoords_corrected"
#: Default cutoff as a fraction of the model's lowest natural frequency.
CUTOFF_MODE_FRACTION = 0.5
#: Order of the Butterworth low-pass (run forwards and backwards: twice this order, zero phase).
LOWPASS_ORDER = 4
#: Degree of the drift polynomial of the displacement residual (3: acceleration offset and slope).
DRIFT_DEGREE = 3
#: Odd-extension padding of the zero-phase low-pass, in periods of the cutoff: it must outlast the
#: filter's transient, or the ends of the record (where the random walk has a slope) are distorted.
PAD_PERIODS = 3.0


def corrected_chain_spec(ch: ChannelInfo, *, where: str = "channel") -> list[dict]:
    """The channel's Table E.2 chain without its high-pass filters and micro-units (SI out), with
    the centred trapezoid rule for both integrations: taps acceleration, velocity, displacement."""
    from odsuite.processing.chain_spec import channel_chain_spec

    if Integration(ch.integration) is not Integration.DOUBLE:
        raise ConfigError(f"{where}: Systeminfo field 'integration' is {Integration(ch.integration).name}; "
                          "the correction needs double integration (displacements)")
    spec = []
    for step in channel_chain_spec(ch):
        kind = step.get("step")
        if kind in ("iir", "micro"):
            continue
        spec.append(dict(step, rule="trapezoid") if kind == "integrate" else dict(step))
    return spec


def default_cutoff(model) -> float:
    """CUTOFF_MODE_FRACTION times the model's lowest natural frequency (Hz)."""
    freqs = [float(f) for f in model.modes().frequency_hz if f > 0]
    if not freqs:
        raise ConfigError(f"model {model.name!r} has no vibration mode to set the correction cutoff; give cutoff_hz")
    return CUTOFF_MODE_FRACTION * min(freqs)


def drift_estimate(residual: np.ndarray, fs: float, cutoff_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Low-frequency error in a displacement residual (samples x channels): the least-squares
    cubic plus the zero-phase low-pass of what the cubic leaves. Returns (estimate, polynomial
    coefficients, highest power first, one column per channel)."""
    r = np.asarray(residual, dtype=float)
    n = r.shape[0]
    t = np.arange(n) / fs
    basis = np.vander(t, DRIFT_DEGREE + 1)
    coef, *_ = np.linalg.lstsq(basis, r, rcond=None)
    trend = basis @ coef
    sos = scipy.signal.butter(LOWPASS_ORDER, cutoff_hz, fs=fs, output="sos")
    pad = min(n - 1, int(np.ceil(PAD_PERIODS * fs / cutoff_hz)))
    return trend + scipy.signal.sosfiltfilt(sos, r - trend, axis=0, padtype="odd", padlen=pad), coef


@dataclass
class MeasurementCorrection:
    """One measurement effect of the revision, undone on the records."""

    entry: str  # the revision entry's name ("sensor_gain", "missing_mode#2")
    effect: Any
    values: dict[str, float]  # shared values with the experiment's own
    uncertainties: dict[str, float]  # standard errors of the fitted values (where known)
    model: Any  # the revision's model: the effect's parameters and their nominals

    def complete(self, values: Mapping[str, float] | None = None) -> dict[str, float]:
        """``values`` (default: the fitted ones) with nominals where missing."""
        return self.effect.values(self.model, self.values if values is None else values)

    def as_dict(self) -> dict[str, Any]:
        nominal = {p.name: p.nominal for p in self.effect.parameters(self.model)}
        changed = {k: v for k, v in self.values.items() if nominal.get(k) != v}
        return {"effect": self.entry, "stage": getattr(self.effect, "correction_stage", "sensor"),
                "values": changed, "uncertainties": {k: self.uncertainties[k] for k in changed
                                                     if k in self.uncertainties}}


def measurement_corrections(revision: Mapping[str, Any], experiment: str, registry, model) -> list[MeasurementCorrection]:
    """The revision's effects that describe the measurement and undo themselves, in the order
    they are undone: stage by stage from the converter back, later additions first within one."""
    from odsuite.analysis.modelrev import instance_names
    from odsuite.contracts.effects import CORRECTION_STAGES, corrects

    entries = list(revision.get("effects", []))
    out = []
    for name, entry in zip(instance_names(entries), entries):
        effect = registry.get(entry["effect"])
        if not corrects(effect):
            continue
        values = {**(entry.get("values") or {}), **(entry.get("per_experiment") or {}).get(experiment, {})}
        unc = {k: float(v) for k, v in (entry.get("uncertainties") or {}).items()
               if isinstance(v, (int, float)) and np.isfinite(v) and v > 0}
        out.append(MeasurementCorrection(name, effect, values, unc, model))
    stage = {s: i for i, s in enumerate(CORRECTION_STAGES)}
    order = sorted(range(len(out)), key=lambda i: (stage.get(getattr(out[i].effect, "correction_stage", "sensor"), 2), -i))
    return [out[i] for i in order]


def undo_measurement(rig, sensors: Sequence[str], signals: np.ndarray, fs: float,
                     corrections: Sequence[MeasurementCorrection], solver_registry,
                     values: Mapping[int, Mapping[str, float]] | None = None) -> np.ndarray:
    """``signals`` (samples x ``sensors``, along each sensor's nominal axis as recorded) with the
    corrections undone in their order; ``values`` replaces the values of correction i (for the
    uncertainty). Sensors the corrections find tilted or moved are re-expressed at their nominal
    axis and place from the least-squares motion of their body's sensors as mounted."""
    from odsuite.domain.rigidbody import body_sensors

    mounted = rig
    sig = {n: signals[:, j] for j, n in enumerate(sensors)}
    for i, c in enumerate(corrections):
        mounted, sig = c.effect.correct(mounted, sig, fs, c.complete((values or {}).get(i)))
    out = np.column_stack([sig[n] for n in sensors])
    moved = [n for n in sensors if _geometry(mounted.sensor(n)) != _geometry(rig.sensor(n))]
    if moved:
        ls = solver_registry.get("least-squares")
        for body in rig.moving_bodies:
            names = tuple(s.name for s in body_sensors(rig, body) if s.name in sig)
            todo = [n for n in names if n in moved]
            if not todo:
                continue
            where = f"rig {rig.name!r} body {body.name!r}"
            try:
                a_mounted = ls.matrix(mounted, body, names)
            except ConfigError as exc:
                raise ConfigError(f"{where}: the sensors as mounted cannot re-express {', '.join(todo)}: {exc}") from None
            d = out[:, [sensors.index(n) for n in names]] @ np.linalg.pinv(a_mounted).T
            a_nominal = ls.matrix(rig, body, names)[[names.index(n) for n in todo]]
            out[:, [sensors.index(n) for n in todo]] = d @ a_nominal.T
    return out


def _geometry(sensor) -> tuple:
    return (tuple(np.round(np.asarray(sensor.axis, float), 12)) if sensor.axis is not None else None,
            tuple(np.round(np.asarray(sensor.position, float), 12)) if sensor.position is not None else None)


@dataclass
class Correction:
    """One experiment's model-corrected motion (SI: m, rad)."""

    experiment: str
    revision: int | None
    cutoff_hz: float
    sensors: list[str]
    channels: list[int]
    displacement: np.ndarray  # samples x sensors, corrected
    drift: np.ndarray  # samples x sensors, the estimate removed from the measured displacement
    drift_coefficients: np.ndarray  # (DRIFT_DEGREE + 1) x sensors, highest power first (m / s^k)
    coordinates: dict[str, Any]  # body -> SolverResult (at_g, at_c: samples x 6)
    solvers: dict[str, str]  # body -> the coordinate solver used
    #: the measurement corrections undone (MeasurementCorrection.as_dict), in their order
    corrections: list[dict[str, Any]] = None
    #: body -> per correction entry, the rms change (6 coordinates at G: m m m rad rad rad) of the
    #: corrected coordinates when its values move by their standard errors
    uncertainty: dict[str, dict[str, list[float]]] = None

    def acceleration_drift(self) -> dict[str, tuple[float, float]]:
        """Per sensor, the drift polynomial as an acceleration: (offset m/s^2, rate m/s^3)."""
        c = self.drift_coefficients
        return {s: (float(2 * c[-3, j]), float(6 * c[-4, j])) for j, s in enumerate(self.sensors)}


def correct_experiment(project, name: str, *, revision: dict | None = None,
                       cutoff_hz: float | None = None, prepared=None) -> Correction:
    """Model-corrected displacements and generalized coordinates of one experiment (nothing is
    stored). ``revision`` defaults to the current model revision, ``cutoff_hz`` to
    :func:`default_cutoff`; ``prepared`` reuses a :class:`~odsuite.analysis.comparison.PreparedExperiment`."""
    from odsuite.processing.chain_spec import build_chain
    from odsuite.analysis.modelrev import current_revision, revision_model
    from odsuite.analysis.prediction import prepare_experiment, simulate_sensors
    from odsuite.contracts.solvers import body_solvers

    regs = project.registries
    rev = revision or current_revision(project)
    rmodel = revision_model(project, rev)
    exp = prepared if prepared is not None else prepare_experiment(project, name)
    where = f"{project.path}: experiment {name!r}"
    corrections = measurement_corrections(rev, name, regs.effects, rmodel.shared)
    if corrections:  # the drift is estimated against the structure seen by an ideal chain
        rmodel = ideal_chain_model(project, rev)
    model = rmodel.for_experiment(name)
    cutoff = default_cutoff(model) if cutoff_hz is None else cutoff_hz
    if not (isinstance(cutoff, (int, float)) and np.isfinite(cutoff) and 0 < cutoff < exp.fs / 2):
        raise ConfigError(f"{where}: correction cutoff must be between 0 and {exp.fs / 2:g} Hz (Nyquist), "
                          f"got {cutoff!r}")
    if exp.n_samples < 2 * (DRIFT_DEGREE + 1):
        raise ConfigError(f"{where}: {exp.n_samples} samples are too few to fit a drift")
    si = project.experiment(name).systeminfo
    # the first-order hold conserves the hit's momentum within the record; the band-limited force's
    # interpolation tails past its ends leave a net velocity (1e-8 m/s on a 3 N hit), a ramp here
    predicted = simulate_sensors(model, exp, hold="foh")
    measured_d = np.empty_like(predicted)
    predicted_d = np.empty_like(predicted)
    for j, k in enumerate(exp.columns):
        chain = build_chain(corrected_chain_spec(si.channels[k], where=f"{where} channel {k}"),
                            fs=exp.fs, registry=regs.processing_steps, where=f"{where} channel {k}")
        measured_d[:, j] = chain.run(exp.volts[:, j])["displacement"]
        predicted_d[:, j] = chain.run(predicted[:, j] * exp.volts_per_unit[j])["displacement"]
    rig = project.rig
    names = [s.name for s in exp.sensors]
    column = {n: j for j, n in enumerate(names)}
    chosen = body_solvers(rig, column, regs.coordinate_solvers)[0]

    def corrected_motion(values=None):
        undone = (undo_measurement(rig, names, measured_d, exp.fs, corrections, regs.coordinate_solvers, values)
                  if corrections else measured_d)
        drift, coef = drift_estimate(undone - predicted_d, exp.fs, float(cutoff))
        corrected = undone - drift
        coords = {c.body.name: c.solver.solve(rig, c.body, {s: corrected[:, column[s]] for s in c.sensors})
                  for c in chosen}
        return corrected, drift, coef, coords

    corrected, drift, coef, coords = corrected_motion()
    uncertainty: dict[str, dict[str, list[float]]] = {}
    for i, c in enumerate(corrections):
        var = {b: np.zeros(6) for b in coords}
        for k, sd in c.uncertainties.items():
            moved_value = _within(c.effect, c.model, k, c.values.get(k), sd)
            if moved_value is None:
                continue
            moved = corrected_motion({i: {**c.values, k: moved_value}})[3]
            for b in coords:
                var[b] += np.mean((moved[b].at_g - coords[b].at_g) ** 2, axis=0)
        for b in coords:
            uncertainty.setdefault(b, {})[c.entry] = np.sqrt(var[b]).tolist()
    return Correction(experiment=name, revision=rev.get("revision"), cutoff_hz=float(cutoff),
                      sensors=names, channels=list(exp.columns),
                      displacement=corrected, drift=drift, drift_coefficients=coef, coordinates=coords,
                      solvers={c.body.name: c.name for c in chosen},
                      corrections=[c.as_dict() for c in corrections], uncertainty=uncertainty)


def _within(effect, model, name: str, value: float | None, sd: float) -> float | None:
    """``value + sd`` within the parameter's bounds (a standard error may reach past them); None
    for a discrete parameter or one without a value."""
    p = next((p for p in effect.parameters(model) if p.name == name), None)
    if p is None or p.choices is not None or value is None:
        return None
    return float(np.clip(value + sd, p.lower, p.upper))


def ideal_chain_model(project, revision: Mapping[str, Any] | None = None):
    """The revision's model without its measurement effects that undo themselves: the structure
    as fitted, seen by an ideal chain (a RevisionModel; what corrected records are compared with)."""
    from odsuite.analysis.modelrev import apply_effects, base_model, check_revision, current_revision
    from odsuite.contracts.effects import corrects

    check_revision("ideal_chain_model", revision)
    rev = revision or current_revision(project)
    regs = project.registries
    kept = [e for e in rev.get("effects", []) if not corrects(regs.effects.get(e["effect"]))]
    return apply_effects(base_model(project.rig, rev.get("model"), registries=regs), kept, registries=regs)


def stored_correction(project, experiment: str) -> tuple[dict[str, np.ndarray], dict[str, Any]] | None:
    """The corrected coordinates stored by :func:`store_correction` (body -> samples x 6 at G) and
    what was applied (revision, cutoff_hz, corrections), or None when there are none."""
    if KIND not in project.derived_kinds(experiment):
        return None
    arrays = project.read_derived(experiment, KIND)
    par = project.derived_info(experiment, KIND)["provenance"]["parameters"]
    coords = {k[:-len("_at_g")]: np.asarray(v) for k, v in arrays.items() if k.endswith("_at_g")}
    return coords, {"revision": par.get("revision"), "cutoff_hz": par.get("cutoff_hz"),
                    "corrections": par.get("measurement_corrections", []),
                    "uncertainty": par.get("correction_uncertainty", {})}


def store_correction(project, corr: Correction) -> None:
    """Write ``corr`` as derived kind "gencoords_corrected" of its experiment: "<body>_at_g",
    "<body>_at_c" (samples x 6, m m m rad rad rad, as "gencoords") and "drift" (samples x channel,
    m), with the model revision and cutoff in the provenance."""
    from odsuite.domain.version import __version__

    exp = project.experiment(corr.experiment)
    n = corr.displacement.shape[0]
    provenance = {"plugin": "correction", "version": __version__, "inputs": [exp.object_id],
                  "parameters": {"revision": corr.revision, "cutoff_hz": corr.cutoff_hz,
                                 "solvers": corr.solvers, "drift_degree": DRIFT_DEGREE,
                                 "lowpass": f"butterworth order {LOWPASS_ORDER}, zero phase",
                                 "chain": "Table E.2 without high-pass filters, trapezoid rule",
                                 "bodies": sorted(corr.coordinates),
                                 "measurement_corrections": corr.corrections or [],
                                 "correction_uncertainty": corr.uncertainty or {}}}
    with project.derived_writer(corr.experiment, KIND, provenance=provenance) as w:
        for body, res in corr.coordinates.items():
            for suffix, data in (("_at_g", res.at_g), ("_at_c", res.at_c)):
                if data is None:  # a body without a corner has no pose at C
                    continue
                w.create(f"{body}{suffix}", (n, 6), np.float64, "m m m rad rad rad",
                         ("sample", "coordinate"))[...] = data
        w.create("drift", corr.drift.shape, np.float64, "m", ("sample", "channel"))[...] = corr.drift
        rates = corr.acceleration_drift()
        w.attrs.update({"channels": np.asarray(corr.channels, dtype=np.int64),
                        "channel_names": ", ".join(corr.sensors),
                        "revision": -1 if corr.revision is None else int(corr.revision),
                        "cutoff_hz": corr.cutoff_hz,
                        "acceleration_offset": np.array([rates[s][0] for s in corr.sensors]),
                        "acceleration_drift_rate": np.array([rates[s][1] for s in corr.sensors])})


def process_corrected(project, experiments: Sequence[str] | None = None, *,
                      cutoff_hz: float | None = None) -> dict[str, dict[str, Any]]:
    """Correct and store every experiment (or those named) with the current model revision.
    Returns per experiment: revision, cutoff_hz and the acceleration drift per sensor."""
    from odsuite.analysis.modelrev import current_revision

    rev = current_revision(project)
    out = {}
    with project.transaction():
        for name in experiments or project.experiment_names():
            corr = correct_experiment(project, name, revision=rev, cutoff_hz=cutoff_hz)
            store_correction(project, corr)
            out[name] = {"revision": corr.revision, "cutoff_hz": corr.cutoff_hz,
                         "drift": corr.acceleration_drift(), "corrections": corr.corrections,
                         "uncertainty": corr.uncertainty}
    return out
