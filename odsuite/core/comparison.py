"""Model against measurement, like with like (thesis Ch. 3.3, Fig. 3.7).

For every experiment the current model revision is driven by the measured force at the recorded
force point and direction; its prediction at each accelerometer is turned into the volts that
sensor would have given (its nominal sensitivity, DAQ gain and inversion from the Systeminfo) and
then goes through the very chain the measurement went through. Both then meet before integration
(the contract's ``error``) and, after the full chain, as generalized coordinates.

``error`` = sqrt(sum (measured - model)^2 / sum measured^2) over all accelerometer channels of all
experiments, at the chain's "acceleration" stage (after filter 1). The noise floor is the same
quantity for a perfect model: the noise variance, estimated from samples before the hammer hit,
over the measured energy.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.signal

from odsuite.core.chain_spec import chain_for_channel, stage_names
from odsuite.core.errors import ConfigError
from odsuite.core.rig import Rig, Sensor
from odsuite.core.systeminfo import SensorType

#: Frequency bands (Hz) of the per-band metrics; the last band runs to Nyquist.
BAND_EDGES_HZ = (0.0, 50.0, 100.0, 200.0, 400.0, 800.0, 1600.0)
COORDINATE_NAMES = ("x", "y", "z", "theta", "phi", "psi")
#: Hits are found where |force| first exceeds this fraction of its peak.
TRIGGER_FRACTION = 0.05
#: The force window keeps samples within this fraction of the peak force, widened by the times
#: below (the anti-aliasing filter smears a hammer pulse over a few milliseconds).
WINDOW_FRACTION = 0.02
WINDOW_BEFORE_S = 0.5e-3
WINDOW_AFTER_S = 3e-3
NOISE_MULTIPLE = 5.0


@dataclass(frozen=True)
class StageOperator:
    """A channel chain up to its first tap as one linear operator on physical signals: micro-units,
    offset window, IIR filters. Columns sharing an operator are filtered in one call, which is far
    faster than running each channel's streaming chain in a fitting loop (equal to it: tested)."""

    columns: tuple[int, ...]
    factor: float
    offset: tuple[int, int] | None
    filters: tuple[tuple[np.ndarray, bool], ...]  # (second-order sections, zero-phase)

    def apply(self, x: np.ndarray) -> np.ndarray:
        y = x * self.factor if self.factor != 1.0 else x.copy()
        if self.offset is not None:
            a, n = self.offset
            y -= y[a:a + n].mean(axis=0)
        for sos, zero_phase in self.filters:
            y = scipy.signal.sosfiltfilt(sos, y, axis=0) if zero_phase else scipy.signal.sosfilt(sos, y, axis=0)
        return y

    @property
    def min_samples(self) -> int:
        n = 1 if self.offset is None else self.offset[0] + self.offset[1]
        for sos, zero_phase in self.filters:
            if zero_phase:  # sosfiltfilt's odd padding needs 3 * (taps) + 1 samples
                n = max(n, 3 * (2 * len(sos) + 1) + 1)
        return n


def stage_operators(channels: Sequence[Any], volts_per_unit: Sequence[float]) -> list[StageOperator] | None:
    """Operators for the acceleration stage of these ChannelInfos (grouped), taking predictions in
    physical units (``volts_per_unit`` turns them into the volts the chain expects), or None when a
    chain holds a step without a linear form (then the chains themselves run)."""
    from odsuite.core.chain_spec import channel_chain_spec
    from odsuite.core.plugins import registries
    from odsuite.core.steps import Filter, Gain, WindowMean

    steps = registries().processing_steps
    groups: dict[tuple, tuple] = {}
    for j, ch in enumerate(channels):
        factor, offset, filters = float(volts_per_unit[j]), None, []
        for step in channel_chain_spec(ch):
            if "tap" in step:
                break
            provider = steps.get(step["step"])
            form = getattr(provider, "linear_form", None)
            ops = form(fs=ch.sampling_rate, **{k: v for k, v in step.items() if k != "step"}) if form else None
            if ops is None:
                return None
            for op in ops:
                if isinstance(op, Gain):
                    factor *= op.factor
                elif isinstance(op, WindowMean) and offset is None and not filters:
                    offset = (op.start, op.length)
                elif isinstance(op, Filter):
                    filters.append((np.ascontiguousarray(op.sos), op.zero_phase))
                else:  # a window mean after a filter: not an operator of this form
                    return None
        # conversion times volts per unit is 1 (or 1e6) up to rounding: equal chains share a group
        factor = float(f"{factor:.12g}")
        key = (factor, offset, tuple((sos.tobytes(), zp) for sos, zp in filters))
        groups.setdefault(key, ([], factor, offset, tuple(filters)))[0].append(j)
    return [StageOperator(tuple(cols), f, o, fl) for cols, f, o, fl in groups.values()]


@dataclass
class PreparedExperiment:
    """One experiment ready for comparison: measured signals at the acceleration stage, the force
    that drives the model, and what is needed to put a prediction through the same chain."""

    name: str
    fs: float
    force: np.ndarray  # N, the force channel through its own chain
    point: np.ndarray  # m, rig frame
    direction: np.ndarray
    sensors: list[Sensor]  # the rig's accelerometers recorded in this experiment, in column order
    columns: list[int]  # their columns in the raw record
    volts: np.ndarray  # samples x sensors, the raw record of those columns
    measured: np.ndarray  # samples x sensors, acceleration stage (physical units)
    volts_per_unit: np.ndarray  # per sensor: physical unit -> volts as the chain expects them
    chains: list  # per sensor, the channel's processing chain (odsuite.core.executor.Chain)
    trigger: int  # first sample of the hit
    noise_var: np.ndarray  # per sensor, variance of the noise at the acceleration stage
    units: list[str] = field(default_factory=list)
    operators: list[StageOperator] | None = None  # fast form of the chains' acceleration stage
    # the last structure simulated and its coordinate accelerations: effects that only change the
    # sensors (gain, tilt, position) reuse them (a strong reference, so identity is safe)
    _cache: tuple | None = field(default=None, repr=False)

    @property
    def n_samples(self) -> int:
        return self.measured.shape[0]

    def head(self, n: int) -> PreparedExperiment:
        """The first ``n`` samples (a causal chain gives the same predictions there; fits use short
        heads first, where a frequency error has not yet turned into a phase error)."""
        if self.operators is not None:
            n = max(n, *(op.min_samples for op in self.operators))
        if n >= self.n_samples:
            return self
        return replace(self, force=self.force[:n], volts=self.volts[:n], measured=self.measured[:n])


def find_trigger(force: np.ndarray) -> int:
    """Index of the first sample where |force| exceeds TRIGGER_FRACTION of its peak."""
    a = np.abs(force - np.median(force[: max(1, len(force) // 100)]))
    peak = a.max()
    if not np.isfinite(peak) or peak == 0:
        return 0
    return int(np.argmax(a >= TRIGGER_FRACTION * peak))


def windowed_force(force: np.ndarray, fs: float) -> np.ndarray:
    """The force with everything outside the hits set to zero (a force window per hit, with
    half-cosine tapers): the force channel's noise between hits would otherwise drive the model
    and put the load cell's noise, through the model, into every predicted channel."""
    base = np.median(force)
    dev = np.abs(force - base)
    peak = dev.max()
    if not np.isfinite(peak) or peak == 0:
        return np.zeros_like(force)
    # noise level from the quietest 90 % of samples (hits are a small part of a record); a
    # quantised force channel toggles between codes, which a fixed fraction of the peak would take
    # for hits
    quiet = dev[dev <= np.quantile(dev, 0.9)]
    sigma = 1.6 * float(np.sqrt(np.mean(quiet**2))) if quiet.size else 0.0
    before, after = int(round(WINDOW_BEFORE_S * fs)), int(round(WINDOW_AFTER_S * fs))
    hot = np.flatnonzero(dev >= max(WINDOW_FRACTION * peak, NOISE_MULTIPLE * sigma))
    mask = np.zeros(len(force))
    for i in hot:  # few samples per hit: a loop over them is cheap
        mask[max(0, i - before):i + after + 1] = 1.0
    taper = max(1, before)
    ramp = 0.5 - 0.5 * np.cos(np.pi * np.arange(1, taper + 1) / (taper + 1))
    w = np.convolve(mask, np.concatenate([ramp, [1.0], ramp[::-1]]) / (ramp.sum() * 2 + 1), mode="same")
    w = np.maximum(mask, np.clip(w * (ramp.sum() * 2 + 1) / (taper + 1), 0, 1))
    return (force - base) * w


def quantisation_step(volts: np.ndarray) -> np.ndarray:
    """Per column, the smallest step between distinct recorded values (the ADC's LSB when the record
    is quantised; tiny for float data)."""
    steps = []
    for col in np.atleast_2d(volts.T):
        d = np.diff(np.unique(col))
        steps.append(float(d.min()) if d.size else 0.0)
    return np.asarray(steps)


def _noise_variance(measured: np.ndarray, trigger: int, fs: float, lsb: np.ndarray) -> np.ndarray:
    """Noise variance per column: before the hit when there are enough samples (keeping clear of
    the hit by 1 ms, as zero-phase filters ring backwards), otherwise the last eighth of the record
    with its trend removed (the response has died away there on a lightly damped rig); never below
    the quantisation noise lsb^2/12, which a quiet pre-trigger stretch on one code hides."""
    guard = int(round(1e-3 * fs))
    pre = measured[: max(0, trigger - guard)]
    if len(pre) >= 32:
        var = pre.var(axis=0)
    else:
        var = scipy.signal.detrend(measured[-max(32, len(measured) // 8):], axis=0).var(axis=0)
    return np.maximum(var, lsb**2 / 12)


def prepare_experiment(project, name: str) -> PreparedExperiment:
    """Read one experiment and run the measured side of the comparison."""
    rig: Rig | None = project.rig
    where = f"{project.path}: experiment {name!r}"
    if rig is None:
        raise ConfigError(f"{where}: the project has no rig, so there is no model to compare with")
    exp = project.experiment(name)
    if exp.excitation is None:
        raise ConfigError(f"{where}: no force point/direction recorded; the model cannot be driven")
    si = exp.systeminfo
    raw = exp.raw()
    fch = exp.excitation.force_channel
    fchain = chain_for_channel(si.channels[fch], where=f"{where} channel {fch}")
    force = windowed_force(fchain.run(raw[:, fch])[stage_names(si.channels[fch].quantity)[0]],
                           exp.sampling_rate)
    sensors, columns, measured, vpu, chains, units, infos = [], [], [], [], [], [], []
    tap = stage_names("acceleration")[0]
    for k, ch in enumerate(si.channels):
        sensor = rig.sensor_on_channel(k)
        if ch.sensor_type != SensorType.ACCELEROMETER or sensor is None:
            continue
        chain = chain_for_channel(ch, where=f"{where} channel {k}")
        sensors.append(sensor)
        columns.append(k)
        chains.append(chain)
        infos.append(ch)
        measured.append(chain.run(raw[:, k])[tap])
        vpu.append(ch.sensitivity * ch.daq_gain * (-1.0 if ch.invert else 1.0))
        units.append(("u" if ch.micro_units else "") + ch.unit)
    if not sensors:
        raise ConfigError(f"{where}: no accelerometer channel matches a sensor of rig {rig.name!r}")
    measured = np.column_stack(measured)
    volts = raw[:, columns]
    trigger = exp.pretrigger if exp.pretrigger > 0 else find_trigger(force)
    micro = np.array([1e6 if si.channels[k].micro_units else 1.0 for k in columns])
    lsb = quantisation_step(volts) / np.abs(np.asarray(vpu)) * micro
    return PreparedExperiment(
        name=name, fs=exp.sampling_rate, force=force, point=np.asarray(exp.excitation.point, float),
        direction=np.asarray(exp.excitation.direction, float), sensors=sensors, columns=columns,
        volts=volts, measured=measured, volts_per_unit=np.asarray(vpu), chains=chains, trigger=trigger,
        noise_var=_noise_variance(measured, trigger, exp.sampling_rate, lsb), units=units,
        operators=stage_operators(infos, vpu),
    )


def prepare(project, experiments: Sequence[str] | None = None) -> list[PreparedExperiment]:
    names = list(experiments) if experiments else project.experiment_names()
    if not names:
        raise ConfigError(f"{project.path}: no experiments to compare (import or acquire some first)")
    return [prepare_experiment(project, n) for n in names]


def simulate_sensors(model, exp: PreparedExperiment, quantity: str = "acceleration") -> np.ndarray:
    """The model's physical signal at each sensor of ``exp`` (samples x sensors), from rest."""
    from odsuite.core.model import Input, Output, StateSpace
    from odsuite.core.simulation import simulate_state_space

    body = model.rig.sensors[0].body if model.rig is not None and model.rig.sensors else None
    inputs = [Input.force(exp.point, exp.direction, body=body)]
    outputs = [Output.sensor(s, quantity) for s in exp.sensors]
    if quantity != "acceleration":
        return simulate_state_space(model.state_space(inputs, outputs), exp.force, exp.fs, hold="foh")
    # a sensor's acceleration is its output row times the coordinates' accelerations q''
    st, chain = model.structure, model.chain
    key = (chain.force_gain, tuple(chain.force_offset), exp.force.shape[0])
    if exp._cache is None or exp._cache[0] is not st or exp._cache[1] != key:
        bf, _ = model.input_matrices(inputs)
        n = st.n_dof
        minv_bf = st.Minv @ bf
        ss = StateSpace(st.A, np.vstack([np.zeros_like(bf), minv_bf]), st.A[n:], minv_bf)
        exp._cache = (st, key, simulate_state_space(ss, exp.force, exp.fs, hold="foh"))
    _, rows = model.output_rows(outputs)
    y = exp._cache[2] @ rows.T
    # the sensors' own dynamics in series, on their sampled signals (one small system per sensor:
    # identical sensors would make one big system's modes repeated and defective); sensors with
    # equal dynamics are filtered in one call
    groups: dict[Any, list[int]] = {}
    for j, s in enumerate(exp.sensors):
        dyn = chain.sensor_dynamics(s.name)
        if dyn is not None:
            groups.setdefault(dyn, []).append(j)
    for dyn, cols in groups.items():
        num, den = _sensor_filter(dyn, exp.fs)
        y[:, cols] = scipy.signal.lfilter(num, den, y[:, cols], axis=0)
    return y


@functools.lru_cache(maxsize=256)
def _sensor_filter(dyn, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """First-order-hold discretisation of a sensor's dynamics in transfer-function form (a few
    states, run by lfilter); cached, as scipy's matrix exponential dominates a fitting loop."""
    ad, bd, cd, dd, _ = scipy.signal.cont2discrete(scipy.signal.zpk2ss(*dyn.zpk()), 1 / fs, method="foh")
    num, den = scipy.signal.ss2tf(ad, bd, cd, dd)
    return num[0], den


def through_chain(exp: PreparedExperiment, physical: np.ndarray, taps: Sequence[str] | None = None
                  ) -> dict[str, np.ndarray]:
    """Put predicted physical signals through each sensor's own chain, as volts, like the data."""
    taps = taps or (stage_names("acceleration")[0],)
    out = {t: np.empty_like(physical) for t in taps}
    for j, chain in enumerate(exp.chains):
        res = chain.run(physical[:, j] * exp.volts_per_unit[j])
        for t in taps:
            out[t][:, j] = res[t]
    return out


def predict(model, exp: PreparedExperiment) -> np.ndarray:
    """Predicted signals at the acceleration stage, samples x sensors."""
    physical = simulate_sensors(model, exp)
    if exp.operators is None:
        return through_chain(exp, physical)[stage_names("acceleration")[0]]
    out = np.empty_like(physical)
    for op in exp.operators:
        cols = list(op.columns)
        out[:, cols] = op.apply(physical[:, cols])
    return out


def nrmse(measured: np.ndarray, predicted: np.ndarray, axis=None) -> np.ndarray | float:
    """sqrt(sum (m - p)^2 / sum m^2); 0 is perfect."""
    num = np.sum((measured - predicted) ** 2, axis=axis)
    den = np.sum(measured**2, axis=axis)
    return np.sqrt(num / np.where(den > 0, den, np.nan))


def band_errors(measured: np.ndarray, predicted: np.ndarray, fs: float,
                edges: Sequence[float] = BAND_EDGES_HZ) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Per band and column: residual energy over measured energy (NRMSE in the band), and the band's
    share of the measured energy. Parseval on the real FFT."""
    n = measured.shape[0]
    f = np.fft.rfftfreq(n, 1 / fs)
    M = np.abs(np.fft.rfft(measured, axis=0)) ** 2
    R = np.abs(np.fft.rfft(measured - predicted, axis=0)) ** 2
    edges = [e for e in edges if e < fs / 2] + [fs / 2]
    labels, err, share = [], [], []
    total = M.sum(axis=0)
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (f >= lo) & (f < hi) if hi < fs / 2 else (f >= lo)
        m, r = M[sel].sum(axis=0), R[sel].sum(axis=0)
        labels.append(f"{lo:g}-{hi:g} Hz")
        err.append(np.sqrt(r / np.where(m > 0, m, np.nan)))
        share.append(m / np.where(total > 0, total, np.nan))
    return labels, np.array(err), np.array(share)


def residual_peaks(exps: Sequence[PreparedExperiment], predictions: Sequence[np.ndarray],
                   model_modes_hz: Sequence[float] = (), *, max_peaks: int = 5) -> list[dict[str, Any]]:
    """Peaks of the pooled residual spectrum, each with the channels where it is strongest and
    whether a model mode lies within 5 % of it ("lacking" when none does)."""
    fs = exps[0].fs
    nfft = 2048
    while nfft > min(e.n_samples for e in exps):
        nfft //= 2
    psd_sum = None
    per_channel: dict[str, np.ndarray] = {}
    for e, p in zip(exps, predictions):
        f, pxx = scipy.signal.welch(e.measured - p, fs=fs, nperseg=nfft, axis=0)
        psd_sum = pxx.sum(axis=1) if psd_sum is None else psd_sum + pxx.sum(axis=1)
        for j, s in enumerate(e.sensors):
            per_channel[s.name] = per_channel.get(s.name, 0) + pxx[:, j]
    if psd_sum is None or not np.any(psd_sum > 0):
        return []
    idx, props = scipy.signal.find_peaks(psd_sum, prominence=0.05 * psd_sum.max())
    order = np.argsort(props["prominences"])[::-1][:max_peaks]
    peaks = []
    for i in sorted(idx[order], key=lambda i: -psd_sum[i]):
        freq = float(f[i])
        strength = {name: float(v[i]) for name, v in per_channel.items()}
        top = max(strength.values())
        channels = sorted((n for n, v in strength.items() if v >= 0.25 * top), key=lambda n: -strength[n])
        near = [m for m in model_modes_hz if abs(m - freq) <= 0.05 * freq + f[1]]
        peaks.append({"frequency_hz": freq, "share": float(psd_sum[i] / psd_sum.sum()),
                      "channels": channels, "model_mode_hz": float(near[0]) if near else None,
                      "lacking": not near})
    return peaks


@dataclass
class Comparison:
    """Everything ``compare`` reports; ``as_dict`` is the JSON contract."""

    error: float
    noise_floor_error: float
    revision: int | None
    experiments: dict[str, dict[str, Any]]
    channels: dict[str, float]
    coordinates: dict[str, dict[str, dict[str, float]]]
    bands: dict[str, Any]
    rigidity: dict[str, dict[str, Any]]
    modes: dict[str, list[dict[str, float]]]
    residual_peaks: list[dict[str, Any]]
    worst: list[dict[str, Any]]

    def as_dict(self) -> dict[str, Any]:
        return {"error": self.error, "noise_floor_error": self.noise_floor_error,
                "revision": self.revision, "experiments": self.experiments, "channels": self.channels,
                "coordinates": self.coordinates, "bands": self.bands, "rigidity": self.rigidity,
                "modes": self.modes, "residual_peaks": self.residual_peaks, "worst": self.worst}


#: band of the FRF comparison and of the modes identified from measured FRFs (Hz)
FRF_BAND_HZ = (20.0, 1000.0)


def frf_comparison(exps: Sequence[PreparedExperiment], predictions: Sequence[np.ndarray],
                   model_modes) -> dict[str, Any]:
    """Measured and model FRFs (acceleration stage over the windowed force, so both include the
    channel's filters) compared per channel, and resonances identified from both by the same LSCF
    method (odsuite.core.modal), paired with each other and with the model's exact modes.

    Each record holds one force point, so an FRF is one average: coherence needs repeated hits
    (``odsuite frf``) and is not reported here."""
    from odsuite.core.frf import estimate_frf
    from odsuite.core.modal import identify_modes, pair_modes

    lo, hi = FRF_BAND_HZ[0], min(FRF_BAND_HZ[1], 0.45 * exps[0].fs)
    errors: dict[str, dict[str, float]] = {}
    stacks: dict[str, list[np.ndarray]] = {"measured": [], "model": []}
    freq = None
    for e, p in zip(exps, predictions):
        fm = estimate_frf([e.force], [e.measured], e.fs)
        fp = estimate_frf([e.force], [p], e.fs)
        keep = (fm.frequency >= lo) & (fm.frequency <= hi)
        if freq is None:
            freq = fm.frequency[keep]
        elif len(fm.frequency[keep]) != len(freq) or not np.allclose(fm.frequency[keep], freq):
            continue  # records of another length: their lines do not stack
        hm, hp = fm.H[:, keep], fp.H[:, keep]
        # lines where a channel barely responds (a z hit seen by an x sensor on the symmetry line)
        # carry no information: they are left out, and a silent channel gets no value
        seen = np.abs(hm) > 1e-6 * np.abs(hm).max()
        with np.errstate(divide="ignore", invalid="ignore"):
            db = np.where(seen, 20 * np.log10(np.abs(hp) / np.abs(hm)), np.nan)
        errors[e.name] = {s.name: (float(np.sqrt(np.nanmean(row**2))) if np.isfinite(row).any() else None)
                          for s, row in zip(e.sensors, db)}
        stacks["measured"].append(hm)
        stacks["model"].append(hp)
    identified: dict[str, list[dict[str, float]]] = {}
    notes = []
    for side, parts in stacks.items():
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


def noise_floor_error(exps: Sequence[PreparedExperiment]) -> float:
    """The error a perfect model would have: expected noise energy over measured energy."""
    num = sum(float(np.sum(e.noise_var) * e.n_samples) for e in exps)
    den = sum(float(np.sum(e.measured**2)) for e in exps)
    return float(np.sqrt(min(num, den) / den)) if den > 0 else float("nan")


def coordinate_series(rig: Rig, exp: PreparedExperiment, model) -> dict[str, tuple[np.ndarray, np.ndarray, list[int]]]:
    """Per body whose motion its sensors determine: measured and model generalized coordinates at
    its G (samples x 6; m, rad), both from displacements after the full chain and the body's
    solver, and the body's columns in ``exp``. Empty when some channel is not integrated twice (no
    displacements)."""
    from odsuite.core.plugins import registries
    from odsuite.core.solvers import body_solvers

    taps = stage_names("acceleration")
    out: dict[str, tuple[np.ndarray, np.ndarray, list[int]]] = {}
    if not all(t in chain.taps for chain in exp.chains for t in taps):
        return out
    predicted = through_chain(exp, simulate_sensors(model, exp), taps)
    measured = {t: np.empty_like(exp.measured) for t in taps}
    for j, chain in enumerate(exp.chains):
        res = chain.run(exp.volts[:, j])
        for t in taps:
            measured[t][:, j] = res[t]
    column = {s.name: j for j, s in enumerate(exp.sensors)}
    for c in body_solvers(rig, column, registries().coordinate_solvers)[0]:
        idx = {n: column[n] for n in c.sensors}
        gm = c.solver.solve(rig, c.body, {n: measured["displacement"][:, j] for n, j in idx.items()}).at_g
        gp = c.solver.solve(rig, c.body, {n: predicted["displacement"][:, j] for n, j in idx.items()}).at_g
        out[c.body.name] = (gm, gp, list(idx.values()))
    return out


def experiment_coordinates(project, name: str, revision: Mapping[str, Any] | None = None
                           ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Measured and model generalized coordinates of one experiment per nine-sensor body, for the
    current model revision (or ``revision``): the model driven by the measured force, predicted at
    the sensors and put through the experiment's chain and solver like the measurement."""
    from odsuite.core.modelrev import current_revision, revision_model

    exp = prepare_experiment(project, name)
    model = revision_model(project, revision or current_revision(project)).for_experiment(name)
    series = coordinate_series(project.rig, exp, model)
    if not series:
        raise ConfigError(f"{project.path}: experiment {name!r}: the chains do not integrate every "
                          "accelerometer to displacement, so there are no generalized coordinates")
    return {body: (gm, gp) for body, (gm, gp, _) in series.items()}


def _coordinates(rig: Rig, exp: PreparedExperiment, model) -> tuple[dict, dict]:
    """Per-coordinate errors of the generalized coordinates, for every body whose motion its sensors
    determine, and the rigidity check on the measured accelerations where the body's solver has one."""
    from odsuite.core.plugins import registries
    from odsuite.core.solvers import choose_solver

    coords, rigidity = {}, {}
    for name, (gm, gp, cols) in coordinate_series(rig, exp, model).items():
        coords[name] = {c: float(nrmse(gm[:, i], gp[:, i])) for i, c in enumerate(COORDINATE_NAMES)}
        signals = {exp.sensors[j].name: exp.measured[:, j] for j in cols}
        solver = choose_solver(rig, rig.body(name), signals, registries().coordinate_solvers).solver
        if not hasattr(solver, "rigidity_check"):
            continue
        rig_check = solver.rigidity_check(rig, rig.body(name), signals)
        rigidity[name] = {"fractions": {k: float(v) for k, v in rig_check.fractions.items()},
                          "flagged": list(rig_check.flagged), "worst": rig_check.worst}
    return coords, rigidity


def compare(project, *, experiments: Sequence[str] | None = None, revision: Mapping[str, Any] | None = None,
            prepared: Sequence[PreparedExperiment] | None = None, resonances: bool = True) -> Comparison:
    """Compare the current model revision (or ``revision``) with every experiment. ``resonances``:
    also identify measured and model resonances from FRFs (a few seconds; the fitting loop, which
    needs only the errors, leaves it out)."""
    from odsuite.core.modelrev import current_revision, revision_model

    rev = revision or current_revision(project)
    rmodel = revision_model(project, rev)
    exps = list(prepared) if prepared is not None else prepare(project, experiments)
    preds = [predict(rmodel.for_experiment(e.name), e) for e in exps]
    model_modes = rmodel.shared.modes()
    modes_hz = [float(f) for f in model_modes.frequency_hz]

    per_exp, coords, rigidity = {}, {}, {}
    chan_num: dict[str, float] = {}
    chan_den: dict[str, float] = {}
    band_num = band_den = None
    labels: list[str] = []
    for e, p in zip(exps, preds):
        per_ch = nrmse(e.measured, p, axis=0)
        per_exp[e.name] = {
            "error": float(nrmse(e.measured, p)),
            "noise_floor_error": noise_floor_error([e]),
            "channels": {s.name: float(v) for s, v in zip(e.sensors, per_ch)},
            "trigger_sample": int(e.trigger),
        }
        for j, s in enumerate(e.sensors):
            chan_num[s.name] = chan_num.get(s.name, 0.0) + float(np.sum((e.measured[:, j] - p[:, j]) ** 2))
            chan_den[s.name] = chan_den.get(s.name, 0.0) + float(np.sum(e.measured[:, j] ** 2))
        labels, berr, bshare = band_errors(e.measured, p, e.fs)
        energy = np.sum(e.measured**2, axis=0)
        num = (berr**2) * bshare * energy  # residual energy per band and channel
        den = bshare * energy
        band_num = num if band_num is None else band_num + num
        band_den = den if band_den is None else band_den + den
        coords[e.name], rigidity[e.name] = _coordinates(project.rig, e, rmodel.for_experiment(e.name))
    channels = {n: float(np.sqrt(chan_num[n] / chan_den[n])) if chan_den[n] > 0 else float("nan")
                for n in chan_num}
    sensor_names = [s.name for s in exps[0].sensors]
    band_table = np.sqrt(band_num / np.where(band_den > 0, band_den, np.nan))
    band_share = band_den / np.nansum(band_den)
    bands = {"labels": labels, "channels": sensor_names,
             "error": [[None if not np.isfinite(v) else float(v) for v in row] for row in band_table],
             "energy_share": [[float(v) for v in row] for row in band_share]}
    worst: list[dict[str, Any]] = []
    for n, v in sorted(channels.items(), key=lambda kv: -kv[1])[:3]:
        worst.append({"kind": "channel", "name": n, "error": v})
    flat_coords = [(f"{en}/{b}/{c}", v) for en, bd in coords.items() for b, cd in bd.items() for c, v in cd.items()]
    for n, v in sorted(flat_coords, key=lambda kv: -kv[1])[:3]:
        worst.append({"kind": "coordinate", "name": n, "error": v})
    weighted = [(labels[i], float(np.nansum(band_num[i]) / np.nansum(band_den[i])) ** 0.5,
                 float(np.nansum(band_num[i]) / np.nansum(band_num))) for i in range(len(labels))]
    for n, v, share in sorted(weighted, key=lambda t: -t[2])[:3]:
        worst.append({"kind": "band", "name": n, "error": v, "residual_share": share})
    return Comparison(
        error=pooled_error(exps, preds), noise_floor_error=noise_floor_error(exps),
        revision=rev.get("revision"), experiments=per_exp, channels=channels, coordinates=coords,
        bands=bands, rigidity=rigidity,
        modes={"model": model_modes.as_list(),
               **(frf_comparison(exps, preds, model_modes) if resonances else {})},
        residual_peaks=residual_peaks(exps, preds, modes_hz), worst=worst,
    )
