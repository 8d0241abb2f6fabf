"""The prediction engine of the comparison: each experiment read and put through its own chain
(the measured side), the model driven by the measured force at the recorded point and direction,
its prediction at every accelerometer turned into the volts that sensor would have given (nominal
sensitivity, DAQ gain and inversion from the Systeminfo) and put through the very same chain, and
both turned into generalized coordinates by the same solvers. Like is compared with like.
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

#: Hits are found where |force| first exceeds this fraction of its peak.
TRIGGER_FRACTION = 0.05
#: The force window keeps samples within this fraction of the peak force, widened by the times
#: below (the anti-aliasing filter smears a hammer pulse over a few milliseconds).
WINDOW_FRACTION = 0.02
WINDOW_BEFORE_S = 0.5e-3
WINDOW_AFTER_S = 3e-3
NOISE_MULTIPLE = 5.0
#: structures with up to this many coordinates keep every coordinate's simulated acceleration, so
#: effects on the sensors alone reuse it; beyond it (a finite-element model's dozens of nodal
#: coordinates) every coordinate's signal costs more than simulating the few sensors again
CACHED_COORDINATES = 36


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
    if len(force) <= 2 * taper + 1:  # a record shorter than the tapers: the window without them
        return (force - base) * mask
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


def _force(exp, raw: np.ndarray, where: str) -> np.ndarray:
    fch = exp.excitation.force_channel
    channel = exp.systeminfo.channels[fch]
    fchain = chain_for_channel(channel, where=f"{where} channel {fch}")
    return windowed_force(fchain.run(raw[:, fch])[stage_names(channel.quantity)[0]], exp.sampling_rate)


def experiment_force(project, name: str) -> np.ndarray:
    """The hammer force (N) of one experiment, as the model is driven with it."""
    exp = project.experiment(name)
    if exp.excitation is None:
        raise ConfigError(f"{project.path}: experiment {name!r}: no force point/direction recorded")
    return _force(exp, exp.raw(), f"{project.path}: experiment {name!r}")


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
    force = _force(exp, raw, where)
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

    body = model.rig.force_body(exp.point) if model.rig is not None else None
    inputs = [Input.force(exp.point, exp.direction, body=body)]
    outputs = [Output.sensor(s, quantity) for s in exp.sensors]
    if quantity != "acceleration":
        return simulate_state_space(model.state_space(inputs, outputs), exp.force, exp.fs, hold="foh")
    # a sensor's acceleration is its output row times the coordinates' accelerations q''
    st, chain = model.structure, model.chain
    _, rows = model.output_rows(outputs)
    n = st.n_dof
    if n > CACHED_COORDINATES:  # many coordinates (finite elements): simulate the sensors alone
        bf, _ = model.input_matrices(inputs)
        minv_bf = st.Minv @ bf
        ss = StateSpace(st.A, np.vstack([np.zeros_like(bf), minv_bf]), rows @ st.A[n:], rows @ minv_bf)
        y = simulate_state_space(ss, exp.force, exp.fs, hold="foh")
    else:
        key = (chain.force_gain, tuple(chain.force_offset), exp.force.shape[0])
        if exp._cache is None or exp._cache[0] is not st or exp._cache[1] != key:
            bf, _ = model.input_matrices(inputs)
            minv_bf = st.Minv @ bf
            ss = StateSpace(st.A, np.vstack([np.zeros_like(bf), minv_bf]), st.A[n:], minv_bf)
            exp._cache = (st, key, simulate_state_space(ss, exp.force, exp.fs, hold="foh"))
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
