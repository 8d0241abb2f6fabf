"""The prediction engine of the comparison: each experiment read and put through its own chain
(the measured side), the model driven by the measured force at the recorded point and direction,
its prediction at every accelerometer turned into the volts that sensor would have given (nominal
sensitivity, DAQ gain and inversion from the Systeminfo) and put through the very same chain, and
both turned into generalized coordinates by the same solvers. Like is compared with like.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.fft
import scipy.signal
import scipy.special
from threadpoolctl import threadpool_limits

from odsuite.processing.chain_spec import chain_for_channel, stage_names
from odsuite.processing.executor import run_array
from odsuite.analysis.hammer import held_range, is_clipped
from odsuite.domain.errors import ConfigError, NoSignalError
from odsuite.analysis.disturbances import disturbance_basis
from odsuite.analysis.noise_floor import (
    FEWEST_BEFORE,
    HIT_GUARD_S,
    active_var,
    moving_samples,
    split_noise,
)
from odsuite.domain.rig import Rig, Sensor
from odsuite.domain.systeminfo import SensorType

#: Hits are found where |force| first exceeds this fraction of its peak.
TRIGGER_FRACTION = 0.05
#: The force window keeps samples within this fraction of the peak force, widened by the times
#: below (the anti-aliasing filter smears a hammer pulse over a few milliseconds).
WINDOW_FRACTION = 0.02
WINDOW_BEFORE_S = 0.5e-3
#: a resting head keeps this much before the force acts: the band-limited force rings into it
REST_MARGIN_S = 5e-3
WINDOW_AFTER_S = 3e-3
NOISE_MULTIPLE = 5.0
#: structures with up to this many coordinates keep every coordinate's simulated acceleration, so
#: effects on the sensors alone reuse it; beyond it (a finite-element model's dozens of nodal
#: coordinates) every coordinate's signal costs more than simulating the few sensors again
CACHED_COORDINATES = 36
#: how the model sees the sampled force: as the band-limited signal the record implies (the
#: recorder's anti-aliasing filter made it one); a first-order hold would lose sinc^2(f/fs) of it,
#: 7 % at 300 Hz at 2048 samples/s, which a correct model then shows as a model error
HOLD = "band"


#: signals that one chain filters side by side (recursions.chain_columns_wide) from this many on:
#: 2x faster on a linearised Jacobian's 31, slower on two
WIDE_CHAIN_COLUMNS = 8


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
            if zero_phase:
                y = scipy.signal.sosfiltfilt(sos, y, axis=0)
            else:  # sosfilt's arithmetic in place, without its checks and copies (many calls per fit)
                from odsuite.domain.recursions import sections_in_place

                y = np.ascontiguousarray(y, dtype=float)
                sections_in_place(sos, y)
        return y

    @functools.cached_property
    def _fused(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The columns and the filters' sections in one cascade, where every filter is causal."""
        if any(zero_phase for _, zero_phase in self.filters):
            return None
        sos = np.concatenate([s for s, _ in self.filters]) if self.filters else np.zeros((0, 6))
        return np.asarray(self.columns, dtype=np.int64), np.ascontiguousarray(sos, dtype=float)

    def apply_into(self, x: np.ndarray, out: np.ndarray, wide: bool = False) -> None:
        """``out[:, columns] = apply(x[:, columns])``, in one compiled pass where the filters are
        causal (the same numbers: recursions.chain_columns; ``wide``: chain_columns_wide, for
        many signals through one chain)."""
        # (apply's offset of a scaled copy is summed in that copy's memory order: left to it)
        if self._fused is None or x.dtype != float or (self.offset is not None and self.factor != 1.0):
            cols = list(self.columns)
            out[:, cols] = self.apply(x[:, cols])
            return
        from odsuite.domain.recursions import chain_columns, chain_columns_wide

        if wide and len(self.columns) >= WIDE_CHAIN_COLUMNS:
            chain_columns = chain_columns_wide

        cols, sos = self._fused
        offsets = np.zeros(len(cols))
        if self.offset is not None:
            a, n = self.offset
            # as apply's copy holds it (C order: numpy sums a column in that order)
            offsets = np.ascontiguousarray(x[a:a + n][:, cols]).mean(axis=0)
        chain_columns(x, cols, self.factor, offsets, sos, out)

    @property
    def min_samples(self) -> int:
        n = 1 if self.offset is None else self.offset[0] + self.offset[1]
        for sos, zero_phase in self.filters:
            if zero_phase:  # sosfiltfilt's odd padding needs 3 * (taps) + 1 samples
                n = max(n, 3 * (2 * len(sos) + 1) + 1)
        return n


def stage_operators(channels: Sequence[Any], volts_per_unit: Sequence[float], steps) -> list[StageOperator] | None:
    """Operators for the acceleration stage of these ChannelInfos (grouped), taking predictions in
    physical units (``volts_per_unit`` turns them into the volts the chain expects), or None when a
    chain holds a step without a linear form (then the chains themselves run). ``steps``: the
    processing-step registry the chains were built from."""
    from odsuite.processing.chain_spec import channel_chain_spec
    from odsuite.contracts.steps import Filter, Gain, WindowMean

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
                    sos = np.ascontiguousarray(op.sos, dtype=float)
                    if sos.ndim != 2 or sos.shape[1] != 6 or not np.all(sos[:, 3] == 1.0):
                        return None  # not normalised sections: the chains themselves run
                    filters.append((sos, op.zero_phase))
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
    chains: list  # per sensor, the channel's processing chain (odsuite.processing.executor.Chain)
    trigger: int  # first sample of the hit
    noise_var: np.ndarray  # per sensor, variance of the noise at the acceleration stage
    units: list[str] = field(default_factory=list)
    operators: list[StageOperator] | None = None  # fast form of the chains' acceleration stage
    # the noise model's ingredients (odsuite.analysis.noise_floor): the ADC step per sensor (physical
    # units), the fitted mains hum and trend (samples x sensors), the force window's noise energy (N^2)
    lsb: np.ndarray | None = None
    adc_step_v: np.ndarray | None = None
    disturbance: np.ndarray | None = None
    # the same disturbances as recorded (samples x sensors, volts): the converter rounds them too
    volts_disturbance: np.ndarray | None = None
    force_noise_energy: float = 0.0
    # the first sample of the quiet tail after the response (-1: not known; n_samples: none)
    quiet_tail: int = -1
    # the samples before the hit the noise is measured on (0 to this; 0: none)
    quiet_before: int = 0
    # the mains frequency (Hz) and how many of its harmonics ``volts_disturbance`` fits as hum
    hum_hz: float = 0.0
    hum_harmonics: int = 0
    # the last structure simulated and its coordinate accelerations: effects that only change the
    # sensors (gain, tilt, position) reuse them (a strong reference, so identity is safe)
    _cache: tuple | None = field(default=None, repr=False)
    # the chains' filtering of those coordinates (prediction.predict_sharing): (_cache, {chain: signals},
    # operators, {chain: last prediction, "delayed": the undelayed signals and their spectra})
    _filtered: tuple | None = field(default=None, repr=False)
    force_body: str | None = None  # the body hit, when the experiment says (else: from the point)
    # the record's sample this one starts at (a head cut after the samples at rest: resting_head)
    first: int = 0
    notes: list[str] = field(default_factory=list)  # what the record says against the rig file
    registries: Any = field(default=None, repr=False)  # the project's providers (solvers for coordinates)

    @property
    def n_samples(self) -> int:
        return self.measured.shape[0]

    @property
    def span(self) -> tuple[str, int, int]:
        """Which samples of which record this is: what a prediction's or residual's key names."""
        return self.name, self.first, self.n_samples

    def resting_head(self, n: int, align: int = 1) -> PreparedExperiment:
        """``head(n)`` without its samples before the force acts, less REST_MARGIN_S. The model is at
        rest there (the force window is zero before the hit; its band-limited form rings into
        them at 1e-6 of the response), so the predictions of the samples kept are the head's to a
        few 1e-5 of their peak, and the residual's rows cut are the measured noise alone, the same
        at every parameter value: a screening's steps on the head are the same for a fraction of
        the samples (0.01 s after a hit with 512 samples before it: a half or a fifth of them). A
        chain's offset over samples at rest is nil on a prediction and left out. The cut is at a
        multiple of ``align``: a residual of every ``align``-th sample keeps the head's own. The
        head itself where a chain runs as it is recorded, filters both ways, or takes an offset
        over samples cut and samples the force acts in."""
        head = self.head(n)
        acting = np.flatnonzero(np.any(np.reshape(head.force, (head.n_samples, -1)) != 0, axis=1))
        if not acting.size or head.operators is None:
            return head
        first = max(0, int(acting[0]) - int(round(REST_MARGIN_S * self.fs)))
        first -= first % max(1, align)
        operators = []
        for op in head.operators:
            if any(zero_phase for _, zero_phase in op.filters):
                return head
            if op.offset is None:
                operators.append(op)
            elif sum(op.offset) <= acting[0]:  # an offset over samples at rest: the prediction's is nil
                operators.append(replace(op, offset=None))
            elif op.offset[0] >= first:
                operators.append(replace(op, offset=(op.offset[0] - first, op.offset[1])))
            else:
                return head
        if first == 0:
            return head

        def cut(x):
            return None if x is None else x[first:]

        return replace(head, force=head.force[first:], volts=head.volts[first:], measured=head.measured[first:],
                       disturbance=cut(head.disturbance), volts_disturbance=cut(head.volts_disturbance),
                       trigger=head.trigger - first, first=head.first + first, operators=operators,
                       quiet_tail=head.quiet_tail - first if head.quiet_tail >= first else -1, quiet_before=0,
                       _cache=None, _filtered=None)

    def head(self, n: int) -> PreparedExperiment:
        """The first ``n`` samples (a causal chain gives the same predictions there; fits use short
        heads first, where a frequency error has not yet turned into a phase error)."""
        if self.operators is not None:
            n = max(n, *(op.min_samples for op in self.operators))
        if n >= self.n_samples:
            return self
        return replace(self, force=self.force[:n], volts=self.volts[:n], measured=self.measured[:n],
                       disturbance=None if self.disturbance is None else self.disturbance[:n],
                       volts_disturbance=None if self.volts_disturbance is None else self.volts_disturbance[:n])


def find_trigger(force: np.ndarray) -> int:
    """Index of the first sample where |force| exceeds TRIGGER_FRACTION of its peak."""
    a = np.abs(force - np.median(force[: max(1, len(force) // 100)]))
    peak = a.max()
    if not np.isfinite(peak) or peak == 0:
        return 0
    return int(np.argmax(a >= TRIGGER_FRACTION * peak))


@dataclass
class ForceWindow:
    """The force that drives the model: the hits with everything between them set to zero, and
    the noise energy left inside the window (N^2 summed over its samples, weighted by the window)."""

    force: np.ndarray
    weights: np.ndarray
    noise_energy: float
    # N: at most the force the record missed before its first sample, where it starts inside a hit
    # (counted in noise_energy as an impulse of that size, sample by sample as the force is)
    missed: float = 0.0


def _hot(dev: np.ndarray, fs: float) -> np.ndarray:
    """Mask of the samples around the hits: within WINDOW_FRACTION of the peak and beyond
    NOISE_MULTIPLE times the noise, widened by WINDOW_BEFORE_S / WINDOW_AFTER_S."""
    peak = dev.max()
    # noise level from the quietest 90 % of samples (hits are a small part of a record); a
    # quantised force channel toggles between codes, which a fixed fraction of the peak would take
    # for hits
    quiet = dev[dev <= np.quantile(dev, 0.9)]
    sigma = 1.6 * float(np.sqrt(np.mean(quiet**2))) if quiet.size else 0.0
    before, after = int(round(WINDOW_BEFORE_S * fs)), int(round(WINDOW_AFTER_S * fs))
    hot = np.flatnonzero(dev >= max(WINDOW_FRACTION * peak, NOISE_MULTIPLE * sigma))
    mask = np.zeros(len(dev))
    for i in hot:  # few samples per hit: a loop over them is cheap
        mask[max(0, i - before):i + after + 1] = 1.0
    return mask


def force_window(force: np.ndarray, fs: float, lsb: float = 0.0) -> ForceWindow:
    """The force with everything outside the hits set to zero (a force window per hit, with
    half-cosine tapers): the force channel's noise between hits would otherwise drive the model
    and put the load cell's noise, through the model, into every predicted channel. The baseline
    under the hits (an offset, a drift, mains hum) is fitted on the samples outside the windows
    and removed: a hit lasts milliseconds, over which a drifting or humming baseline is no force.
    ``lsb``: the channel's quantisation step (N), for the noise left inside the window."""
    base = np.median(force)
    dev = np.abs(force - base)
    peak = dev.max()
    if not np.isfinite(peak) or peak == 0:
        return ForceWindow(np.zeros_like(force), np.zeros_like(force), 0.0)
    mask = _hot(dev, fs)
    outside = mask == 0
    noise_var = 0.0
    if outside.sum() > 64:
        basis = disturbance_basis(len(force), fs)
        coef, *_ = np.linalg.lstsq(basis[outside], force[outside], rcond=None)
        baseline = basis @ coef
        rest = force[outside] - baseline[outside]
        noise_var = float(rest @ rest) / max(1, int(outside.sum()) - basis.shape[1])
        mask = _hot(np.abs(force - baseline), fs)  # the hits again, on the clean baseline
    else:
        baseline = np.full_like(force, base)
    before = int(round(WINDOW_BEFORE_S * fs))
    taper = max(1, before)
    if len(force) <= 2 * taper + 1:  # a record shorter than the tapers: the window without them
        w = mask
    else:
        ramp = 0.5 - 0.5 * np.cos(np.pi * np.arange(1, taper + 1) / (taper + 1))
        w = np.convolve(mask, np.concatenate([ramp, [1.0], ramp[::-1]]) / (ramp.sum() * 2 + 1), mode="same")
        w = np.maximum(mask, np.clip(w * (ramp.sum() * 2 + 1) / (taper + 1), 0, 1))
    clean = force - baseline
    # inside the window the noise is the quiet one, or the rounding error where the force moves
    # through the codes
    per_sample = np.where(moving_samples(clean * w, lsb, fs)[:, 0], active_var(np.array(noise_var), np.array(lsb)),
                          noise_var)
    missed = _missed_before(clean, mask, noise_var)
    return ForceWindow(clean * w, w, float(np.sum(w**2 * per_sample)) + missed**2, missed)


def _missed_before(clean: np.ndarray, mask: np.ndarray, noise_var: float) -> float:
    """The most force (N, as one sample's value) a record that starts inside a hit (its first sample
    beyond NOISE_MULTIPLE times the noise) missed before that sample: the first sample's force for
    the time the rising edge, extrapolated back to zero, took (at most a sample; a whole one where
    the force does not rise). The model starts from rest with the force the record holds, so the
    structure's response to that part is missing from every prediction (the simulated bracket's
    null, recorded from its trigger at 4 % of the peak, read 3.4x its floor at its 306 Hz mode)."""
    first = float(clean[0]) if clean.size else 0.0
    if not (clean.size > 1 and mask[0] and abs(first) > NOISE_MULTIPLE * np.sqrt(noise_var)):
        return 0.0
    rise = float(clean[1]) - first
    span = min(1.0, first / rise) if rise * first > 0 else 1.0
    return abs(first) * span


def windowed_force(force: np.ndarray, fs: float) -> np.ndarray:
    """The force as it drives the model (see :func:`force_window`)."""
    return force_window(force, fs).force


def quantisation_step(volts: np.ndarray) -> np.ndarray:
    """Per column, the smallest step between distinct recorded values (the ADC's LSB when the record
    is quantised; tiny for float data)."""
    steps = []
    for col in np.atleast_2d(volts.T):
        d = np.diff(np.unique(col))
        steps.append(float(d.min()) if d.size else 0.0)
    return np.asarray(steps)


#: a recorded value within this share of a step from the grid of the smallest step lies on it
#: (codes written in full lie on it to round-off; float data has thousands of values, each on it
#: by chance with probability 0.02). Codes rounded by a text file to fewer digits miss it: the
#: declared step stands then
GRID_TOLERANCE = 0.01
#: distinct values that make a grid: a small signal on a coarse converter may use only three codes
GRID_VALUES = 3
#: codes a converter resolves at most (32 bits): a smaller step across a record's span is float
#: data's, whose codes would be too many to tell from integers (beyond 2**53 every float is one;
#: a record ringing down to subnormal numbers overflows)
GRID_CODES = 2**32


def adc_steps(volts: np.ndarray, declared: float | None) -> tuple[np.ndarray, list[int]]:
    """Per column, the converter's step: the grid the recorded values lie on when they lie on one
    (a quantised record shows its converter, whatever a rig file declares: a 12-bit card on a rig
    that declares 16 bits rounds 16 times coarser), else the declared step, else the smallest step
    between values (float data: tiny). And the columns whose grid differs from the declared step
    by more than 1.5x."""
    observed = quantisation_step(volts)
    steps, differ = [], []
    for j, (col, s) in enumerate(zip(np.atleast_2d(volts.T), observed)):
        span = col.max() - col.min() if col.size else 0.0
        codes = (np.unique(col) - col.min()) / s if s > 0 and span <= GRID_CODES * s else np.zeros(0)
        on_grid = codes.size >= GRID_VALUES and bool(np.all(np.abs(codes - np.round(codes)) <= GRID_TOLERANCE))
        if declared and not on_grid:
            steps.append(declared)
            continue
        steps.append(float(s))
        if declared and not declared / 1.5 <= s <= 1.5 * declared:
            differ.append(j)
    return np.asarray(steps), differ


def _force(exp, raw: np.ndarray, where: str, steps, lsb_v: float | None = None) -> ForceWindow:
    fch = exp.excitation.force_channel
    # without the load cell's own filters: the predictions pass the accelerometers' chains, which
    # lack them (a 2 kHz low-pass on the force alone lagged every prediction)
    channel = replace(exp.systeminfo.channels[fch], filters_on=0)
    fchain = chain_for_channel(channel, registry=steps, where=f"{where} channel {fch}")
    per_newton = abs(channel.sensitivity * channel.daq_gain) or 1.0
    step = float(adc_steps(raw[:, [fch]], lsb_v)[0][0])
    return force_window(fchain.run(raw[:, fch])[stage_names(channel.quantity)[0]], exp.sampling_rate,
                        step / per_newton)


def experiment_force(project, name: str) -> np.ndarray:
    """The hammer force (N) of one experiment, as the model is driven with it."""
    exp = project.experiment(name)
    if exp.excitation is None:
        raise ConfigError(f"{project.path}: experiment {name!r}: no force point/direction recorded")
    return _force(exp, exp.raw(), f"{project.path}: experiment {name!r}", project.registries.processing_steps).force


def quiet_before(quiet: np.ndarray) -> int:
    """How many samples from a record's start are quiet (before its hit)."""
    loud = np.flatnonzero(~quiet)
    return int(loud[0]) if loud.size else len(quiet)


def quiet_tail(quiet: np.ndarray, trigger: int) -> int:
    """The first sample of the quiet stretch that runs to a record's end after its hit (the
    record's length where its last sample is not quiet)."""
    n = len(quiet)
    if n == 0 or not quiet[-1]:
        return n
    loud = np.flatnonzero(~quiet[trigger:])
    return trigger + int(loud[-1]) + 1 if loud.size else trigger


def prepare_experiment(project, name: str, exp=None) -> PreparedExperiment:
    """Read one experiment (``exp``: as already read from ``project``) and run the measured side
    of the comparison."""
    rig: Rig | None = project.rig
    where = f"{project.path}: experiment {name!r}"
    if rig is None:
        raise ConfigError(f"{where}: the project has no rig, so there is no model to compare with")
    exp = project.experiment(name) if exp is None else exp
    if exp.excitation is None:
        raise ConfigError(f"{where}: no force point/direction recorded; the model cannot be driven")
    si = exp.systeminfo
    si.validate(n_samples=exp.n_samples, source=f"{where} systeminfo")  # as process does
    raw = exp.raw()
    acquisition = getattr(rig, "acquisition", None)
    lsb_v = acquisition.lsb_v if acquisition is not None else None
    steps = project.registries.processing_steps
    fw = _force(exp, raw, where, steps, lsb_v)
    force = fw.force
    sensors, columns, vpu, chains, units, infos = [], [], [], [], [], []
    tap = stage_names("acceleration")[0]
    for k, ch in enumerate(si.channels):
        sensor = rig.sensor_on_channel(k)
        if ch.sensor_type != SensorType.ACCELEROMETER or sensor is None:
            continue
        chain = chain_for_channel(ch, registry=steps, where=f"{where} channel {k}")
        sensors.append(sensor)
        columns.append(k)
        chains.append(chain)
        infos.append(ch)
        vpu.append(ch.sensitivity * ch.daq_gain * (-1.0 if ch.invert else 1.0))
        units.append(("u" if ch.micro_units else "") + ch.unit)
    if not sensors:
        raise ConfigError(f"{where}: no accelerometer channel matches a sensor of rig {rig.name!r}")
    # responses that each read one value throughout: the error, over their energy, is 0/0 (one
    # such channel beside others is compared: a model that moves it is wrong)
    if all(np.ptp(raw[:, k]) == 0 for k in columns):
        raise NoSignalError(f"{where}: its responses hold no signal: {', '.join(s.name for s in sensors)} (channels "
                            f"{', '.join(str(k) for k in columns)}) read one value in every sample, so the model "
                            "has nothing to be compared with")
    clipped = [j for j, (k, ch) in enumerate(zip(columns, infos))
               if is_clipped(raw[:, k], limits=held_range(raw[:, k], ch.limit_low, ch.limit_high))]
    # a model cannot follow a signal the converter cut off: a clipped channel's residual is the
    # clipping, which no effect explains, so the channel is left out of this experiment; where every
    # channel is clipped (the real beam's camera record: its one accelerometer for a few samples at
    # a time in the first 10 ms) it is compared anyway, and the note says so
    if len(clipped) == len(sensors):
        clip_notes = [f"{where}: every response channel is clipped at its converter's limits (channels "
                      f"{', '.join(str(k) for k in columns)}): compared anyway, and part of its error is the "
                      "clipping"]
        clipped = []
    else:
        clip_notes = [f"{where}: channel {columns[j]} ({sensors[j].name}) is clipped at its converter's limits: "
                      "left out of this experiment's comparison" for j in clipped]
    kept = [j for j in range(len(sensors)) if j not in clipped]
    sensors, columns, vpu, chains, units, infos = ([x[j] for j in kept] for x in (sensors, columns, vpu, chains,
                                                                                    units, infos))
    to_tap = [chain.through(tap) for chain in chains]  # the integrals after it are not needed here
    volts = raw[:, columns]
    measured = np.column_stack([r[tap] for r in run_each(to_tap, volts)])
    trigger = exp.pretrigger if exp.pretrigger > 0 else find_trigger(force)
    micro = np.array([1e6 if si.channels[k].micro_units else 1.0 for k in columns])
    step, differ = adc_steps(volts, lsb_v)
    notes = clip_notes + [
        f"{where}: channel {columns[j]} ({sensors[j].name}) is recorded on a {1e3 * step[j]:.4g} mV grid, "
        f"{step[j] / lsb_v:.3g}x the {1e3 * lsb_v:.4g} mV step the rig's [acquisition] declares: the noise "
        "floor uses the recorded grid" for j in differ]
    lsb = step / np.abs(np.asarray(vpu)) * micro
    quiet = split_noise(volts, trigger, exp.sampling_rate)
    disturbance = np.column_stack([r[tap] for r in run_each(to_tap, quiet.disturbance)])
    drift = (None if quiet.local_drift is None else
             np.column_stack([r[tap] for r in run_each(to_tap, quiet.local_drift)]))
    before = quiet_before(quiet.quiet)
    if before < FEWEST_BEFORE:
        # the samples just before the hit are left out (zero-phase filters ring backwards from it):
        # a record needs that many more before its trigger than it counts quiet
        guard = int(round(HIT_GUARD_S * exp.sampling_rate))
        guarded = f"the last {1e3 * HIT_GUARD_S:g} ms are left out"
        if exp.pretrigger > 0:
            counted = f"of {trigger} before the trigger, {guarded}"
        else:  # the hit is found in the force, often a sample or two in: not samples recorded before the trigger
            counted = "the record starts at its trigger, 0 samples before it" + (
                f"; of the {trigger} before the hit the force shows, {guarded}" if trigger > guard else "")
        counted = f"{before} quiet samples before the hit (fewer than {FEWEST_BEFORE}; {counted})"
        more = f"(record {FEWEST_BEFORE + guard} or more samples before the trigger)"
        notes.append(f"{where}: {counted}: the noise is measured on them alone, less surely, as the record's last "
                     f"samples still ring ({quiet.ringing_tail:.3g}x their variance) {more}"
                     if quiet.ringing_tail is not None else
                     f"{where}: {counted}: the noise is measured on the record's last samples, where the response "
                     f"may still ring, and the floor may read high {more}")
    reaching = [j for j, ch in enumerate(infos) if ch.offset_length > 0 and before < ch.offset_start + ch.offset_length]
    offset_error = None
    if reaching:
        # an offset window that reaches into the hit removes a mean that holds part of the response;
        # the filters' response to that error runs through the samples before the hit (a decay from
        # 4 m/s^2 on a thesis rig record with 48 samples before it: its noise read 100x too high),
        # and, with none before it, through the last samples the noise is measured on (a thesis
        # rig null's floor 3.8x its error). A model's signal passes the same window, so the
        # residual keeps no such error; the noise's estimate takes the chain's response to a
        # constant out
        offset_error = np.zeros_like(measured)
        for j in reaching:
            no_offset = chain_for_channel(replace(infos[j], offset_length=0), registry=steps,
                                          where=f"{where} channel {columns[j]}").through(tap)
            offset_error[:, j] = no_offset.run(np.ones(len(volts)))[tap]
        # (a window that ends in the guard before the trigger holds at most the hit's first rise; with
        # no samples before the hit no window avoids it, and the note above says so)
        past = [j for j in reaching if before > 0 and infos[j].offset_start + infos[j].offset_length > trigger]
        windows: dict[tuple[int, int], list[str]] = {}
        for j in past:
            windows.setdefault((infos[j].offset_start, infos[j].offset_length), []).append(sensors[j].name)
        for (start, length), names in windows.items():
            notes.append(f"{where}: the offset window (samples {start}-{start + length - 1}) of {', '.join(names)} "
                         f"reaches into the hit at sample {trigger}: the mean it removes holds part of the response "
                         f"(set the rig's [processing] offset_samples = [0, {before}] and import again)")
    if fw.missed > 0:
        notes.append(f"{where}: the record starts inside its hit (its first sample reads "
                     f"{abs(force[0]):.3g} N of the {np.max(np.abs(force)):.3g} N peak): the force before it, and "
                     f"the structure's response to it, are not in the model's input; the noise floor counts up to "
                     f"{fw.missed:.3g} N at that sample (record samples before the trigger)")
    white = quiet.white(measured, disturbance, drift, offset_error)
    return PreparedExperiment(
        name=name, fs=exp.sampling_rate, force=force, point=np.asarray(exp.excitation.point, float),
        direction=np.asarray(exp.excitation.direction, float), sensors=sensors, columns=columns,
        volts=volts, measured=measured, volts_per_unit=np.asarray(vpu), chains=chains, trigger=trigger,
        noise_var=white, units=units, operators=stage_operators(infos, vpu, steps), lsb=lsb, adc_step_v=step,
        disturbance=disturbance, volts_disturbance=quiet.disturbance,
        quiet_tail=quiet_tail(quiet.quiet, trigger), quiet_before=quiet_before(quiet.quiet),
        hum_hz=quiet.mains_hz, hum_harmonics=quiet.harmonics,
        force_noise_energy=fw.noise_energy, force_body=exp.excitation.body,
        notes=notes, registries=project.registries,
    )


def prepare(project, experiments: Sequence[str] | None = None, left_out: list[str] | None = None
            ) -> list[PreparedExperiment]:
    """The named experiments, or every record with a hammer blow: operating records (no force
    channel) cannot drive a model and are left out unless named, as are records without a signal
    (``NoSignalError``, whose lines are added to ``left_out``) unless every one is such."""
    if experiments:
        return [prepare_experiment(project, n) for n in experiments]
    read = {n: project.experiment(n) for n in project.experiment_names()}
    names = [n for n, e in read.items() if e.excitation is not None]
    if not names:
        raise ConfigError(f"{project.path}: no hammer records to compare (import or acquire some first; "
                          "operating records have no force to drive a model)")
    exps, silent = [], []
    for n in names:
        try:
            exps.append(prepare_experiment(project, n, read[n]))
        except NoSignalError as exc:
            silent.append(exc)
    if not exps:
        raise silent[0]
    if left_out is not None:
        left_out.extend(str(exc) for exc in silent)
    return exps


def _force_inputs(model, exp: PreparedExperiment) -> list:
    from odsuite.domain.model import Input

    # kept on the experiment for its model's rig (the body hit: a search over the rig's plates;
    # every evaluation asks again), not copied to its heads
    kept = exp.__dict__.get("_force_inputs")
    if kept is not None and kept[0] is model.rig:
        return kept[1]
    body = model.rig.force_body(exp.point, exp.force_body) if model.rig is not None else None
    inputs = [Input.force(exp.point, exp.direction, body=body)]
    exp.__dict__["_force_inputs"] = (model.rig, inputs)
    return inputs


def _cache_key(model, exp: PreparedExperiment, hold: str = HOLD) -> tuple:
    """What besides the structure the cached coordinate accelerations depend on."""
    return (model.chain.force_gain, tuple(model.chain.force_offset), exp.force.shape[0], hold)


def simulate_together(models: Mapping[str, Any], exps: Sequence[PreparedExperiment]) -> None:
    """Fill the simulation caches of the experiments whose models share one nonlinear structure in
    one time loop (a nonlinear simulation costs a Python step per sample; run together, once)."""
    from odsuite.domain.simulation import simulate_nonlinear_many

    todo = [(models[e.name], e) for e in exps if not models[e.name].structure.is_linear]
    if len(todo) < 2:
        return
    st, fs = todo[0][0].structure, todo[0][1].fs
    todo = [(m, e) for m, e in todo if m.structure is st and e.fs == fs
            and (e._cache is None or e._cache[0] is not st or e._cache[1] != _cache_key(m, e))]
    if len(todo) < 2:
        return
    qdds = simulate_nonlinear_many(st, [(m.input_matrices(_force_inputs(m, e))[0], e.force) for m, e in todo], fs,
                                   HOLD)
    for (m, e), qdd in zip(todo, qdds):
        e._cache = (st, _cache_key(m, e), qdd)


def simulate_sensors(model, exp: PreparedExperiment, quantity: str = "acceleration", hold: str | None = None
                     ) -> np.ndarray:
    """The model's physical signal at each sensor of ``exp`` (samples x sensors), from rest; the
    force seen with ``hold`` (default HOLD)."""
    from odsuite.domain.model import Output, StateSpace
    from odsuite.domain.simulation import simulate_state_space

    hold = hold or HOLD

    inputs = _force_inputs(model, exp)
    if quantity != "acceleration":
        outputs = [Output.sensor(s, quantity) for s in exp.sensors]
        return simulate_state_space(model.state_space(inputs, outputs), exp.force, exp.fs, hold=hold)
    # a sensor's acceleration is its output row times the coordinates' accelerations q''
    st = model.structure
    rows = _sensor_rows(model, exp.sensors)
    n = st.n_dof
    if n > CACHED_COORDINATES and st.is_linear:  # many coordinates (finite elements): the sensors alone
        bf, _ = model.input_matrices(inputs)
        minv_bf = st.Minv @ bf
        ss = StateSpace(st.A, np.vstack([np.zeros_like(bf), minv_bf]), rows @ st.A[n:], rows @ minv_bf)
        y = simulate_state_space(ss, exp.force, exp.fs, hold=hold)
    else:
        y = _coordinates(model, exp, hold) @ rows.T
    return _analog_chain(model, exp, y)


def _coordinate_system(model, exp: PreparedExperiment):
    """The linear structure's state space from the hit's force to its coordinates' accelerations."""
    from odsuite.domain.model import StateSpace

    st = model.structure
    bf, _ = model.input_matrices(_force_inputs(model, exp))
    minv_bf = st.Minv @ bf
    return StateSpace(st.A, np.vstack([np.zeros_like(bf), minv_bf]), st.A[st.n_dof:], minv_bf)


#: linear simulations kept by their system, record and hold while a diagnosis runs
#: (kept_simulations): its candidates and stages simulate one structure on one record again and
#: again, each from a new model (the thesis bench: 239 of 907); None: none kept
_SIMULATIONS: dict[tuple, np.ndarray] | None = None
#: the repeats are mostly of short heads: 4 MB keeps 214 of the thesis bench's 239 (48 MB: all),
#: and more memory held costs a first diagnosis page faults (42,000 against 31,500 at 48 MB)
SIMULATIONS_BYTES_KEPT = 4e6
_simulations_held = 0


@contextlib.contextmanager
def kept_simulations() -> Iterator[None]:
    """Within it, _simulated keeps its simulations (read-only), the oldest going first beyond
    SIMULATIONS_BYTES_KEPT, and predict_kept the predictions made from them: the same numbers as
    simulating and predicting again."""
    global _SIMULATIONS, _simulations_held, _predictions_held
    outer = _SIMULATIONS
    if outer is None:
        _SIMULATIONS, _simulations_held = {}, 0
    try:
        yield
    finally:
        if outer is None:
            _SIMULATIONS, _simulations_held, _predictions_held = None, 0, 0
            _PREDICTIONS.clear()


def _simulated(ss, exp: PreparedExperiment, hold: str) -> np.ndarray:
    """``simulate_state_space(ss, exp.force, exp.fs, hold)``, kept within kept_simulations
    (read-only there: its callers read it)."""
    from odsuite.domain.simulation import simulate_state_space

    global _simulations_held
    kept = _SIMULATIONS
    if kept is None:
        return simulate_state_space(ss, exp.force, exp.fs, hold=hold)
    u = exp.force
    # the record's bytes kept on ``exp`` (it asks again and again): their hash is then kept too
    record = exp.__dict__.get("_force_bytes")
    if record is None or record[0] is not u:
        record = exp.__dict__["_force_bytes"] = (u, u.tobytes())
    key = (ss.A.shape, ss.A.tobytes(), ss.B.shape, ss.B.tobytes(), ss.C.shape, ss.C.tobytes(), ss.D.shape,
           ss.D.tobytes(), u.shape, u.dtype.str, record[1], exp.fs, hold)
    got = kept.pop(key, None)
    if got is None:
        got = simulate_state_space(ss, u, exp.fs, hold=hold)
        got.flags.writeable = False
        _simulations_held += got.nbytes
        while kept and _simulations_held > SIMULATIONS_BYTES_KEPT:
            _simulations_held -= kept.pop(next(iter(kept))).nbytes
    kept[key] = got  # the most recent last
    return got


def _coordinates(model, exp: PreparedExperiment, hold: str) -> np.ndarray:
    """The coordinates' accelerations (samples x coordinates), kept on ``exp`` for its structure."""
    from odsuite.domain.simulation import simulate_nonlinear

    st = model.structure
    key = _cache_key(model, exp, hold)
    if exp._cache is None or exp._cache[0] is not st or exp._cache[1] != key:
        if st.is_linear:
            exp._cache = (st, key, _simulated(_coordinate_system(model, exp), exp, hold))
        else:  # cubic springs: the response depends on the force's level
            bf, _ = model.input_matrices(_force_inputs(model, exp))
            exp._cache = (st, key, simulate_nonlinear(st, bf, exp.force, exp.fs, hold))
    return exp._cache[2]


def linearised_changes(model0, models: Sequence[Any], exp: PreparedExperiment, every: int = 1,
                       scales: np.ndarray | None = None, out: np.ndarray | None = None) -> np.ndarray | None:
    """The change of ``predict(m, exp)`` from ``model0``'s for each of ``models`` (linear
    structures of ``model0``'s size near it, with its chain; samples x sensors x models, every
    ``every``-th sample), the structure's response to first order in its poles and residues about
    ``model0``'s (simulation.linearised_band), the sensors' rows exact: a Jacobian's columns for
    one simulation. The chain is linear and the same for every model: it filters the response's
    basis signals once per distinct channel chain, and every model's change is one product of
    those with its weights, not a prediction of its own. Each sensor's change of each model times
    ``scales`` (sensors x models; a Jacobian's channel weight over its step), written into ``out``
    where given (C-ordered, that shape). None where that does not apply."""
    from odsuite.domain.simulation import linearised_band

    st0 = model0.structure
    if (HOLD != "band" or not st0.is_linear or st0.n_dof > CACHED_COORDINATES or exp.operators is None
            or any(not m.structure.is_linear or m.structure.n_dof != st0.n_dof or m.chain is not model0.chain
                   for m in models)):
        return None
    lin = linearised_band(_coordinate_system(model0, exp), [_coordinate_system(m, exp) for m in models],
                          exp.force, exp.fs)
    if lin is None:
        return None
    basis, matrices = lin
    q0 = _coordinates(model0, exp, HOLD)
    rows0 = _sensor_rows(model0, exp.sensors)
    signals = np.hstack([q0, basis])
    # sensors whose chains are alike (dynamics, delay, processing) filter the signals once
    chain = model0.chain
    groups: dict[tuple, list[int]] = {}
    for op in exp.operators:
        for j in op.columns:
            s = exp.sensors[j]
            groups.setdefault((id(op), chain.sensor_dynamics(s.name), chain.delay.get(s.name, 0.0)), []).append(j)
    n_sensors, n_models = len(exp.sensors), len(models)
    n = len(range(0, exp.n_samples, every))
    if out is None:
        out = np.empty((n, n_sensors, n_models))
    whole = (len(groups) == 1 and next(iter(groups.values())) == list(range(n_sensors))
             and out.flags.c_contiguous)
    if not whole:
        out[...] = 0.0  # a sensor no operator processes is not changed
    rows = [_sensor_rows(m, exp.sensors) for m in models]
    for cols in groups.values():
        j = cols[0]
        op = next(o for o in exp.operators if j in o.columns)
        one = replace(exp, sensors=[exp.sensors[j]] * signals.shape[1],
                      operators=[replace(op, columns=tuple(range(signals.shape[1])))])
        filtered = _digital_chain(one, _analog_chain(model0, one, signals.copy(), wide=True), wide=True)[::every]
        # every model's change in one product, sensor by sensor: the nominal coordinates through
        # the rows' change, the coordinates' change through the rows
        weights = np.stack([np.vstack([(r[cols] - rows0[cols]).T, mat @ r[cols].T]) for r, mat in zip(rows, matrices)],
                           axis=2)  # signals x sensors x models
        if scales is not None:
            weights *= scales[cols][None]
        weights = weights.reshape(len(weights), -1)
        if whole:
            np.matmul(filtered, weights, out=out.reshape(n, n_sensors * n_models))
        else:
            out[:, cols] = (filtered @ weights).reshape(n, len(cols), n_models)
    return out


def cubic_change_predictions(model0, models: Sequence[Any], exp: PreparedExperiment, every: int = 1
                             ) -> list[np.ndarray] | None:
    """The change of ``predict(m, exp)`` from ``model0``'s for each of ``models`` (``model0``'s
    linear structure with cubic springs added, its chain) to first order in the cubic
    coefficients: the linear structure's response to the springs' cubic force along ``model0``'s
    motion, a linear simulation where each model would need a nonlinear one. None where that does
    not apply. Every ``every``-th sample."""
    from odsuite.domain.model import StateSpace
    from odsuite.domain.simulation import simulate_many_inputs, simulate_state_space

    st0 = model0.structure
    if not st0.is_linear or st0.n_dof > CACHED_COORDINATES or any(
            m.structure.is_linear or m.structure.n_dof != st0.n_dof or m.chain is not model0.chain
            or not np.array_equal(m.structure.A, st0.A) for m in models):
        return None
    n = st0.n_dof
    ss = _coordinate_system(model0, exp)
    moving = replace(ss, C=np.hstack([np.eye(n), np.zeros((n, n))]), D=np.zeros((n, ss.B.shape[1])))
    q0 = simulate_state_space(moving, exp.force, exp.fs, hold=HOLD)  # the coordinates' displacements
    # the cubic force enters as an acceleration (M^-1 f), linear between samples as in the
    # nonlinear integrator; its response's accelerations include that input directly
    pushed = StateSpace(st0.A, np.vstack([np.zeros((n, n)), np.eye(n)]), st0.A[n:], np.eye(n))
    out = []
    for m in models:
        E, c = m.structure.cubic_rows()
        d = q0 @ E.T
        w = -((c * d * d * d) @ E) @ st0.Minv.T
        dq = simulate_many_inputs(pushed, w, exp.fs)
        if dq is None:
            return None
        out.append(_digital_chain(exp, _analog_chain(m, exp, dq @ _sensor_rows(m, exp.sensors).T))[::every])
    return out


def _analog_chain(model, exp: PreparedExperiment, y: np.ndarray, wide: bool = False) -> np.ndarray:
    """The chain's parts between the structure and the converter on the sensors' accelerations
    ``y`` (samples x sensors, changed in place): sensor dynamics, front end, sampling delays
    (``wide``: many signals through one chain, as _digital_chain's)."""
    from odsuite.domain.simulation import sampled_later

    y = _sensor_side(model, exp, y, wide)
    delays = [model.chain.delay.get(s.name, 0.0) for s in exp.sensors]
    if any(delays):
        y = sampled_later(y, exp.fs, delays)
    return y


def _sensor_side(model, exp: PreparedExperiment, y: np.ndarray, wide: bool = False) -> np.ndarray:
    """The analog chain before the sampling delays (sensor dynamics, front end) on ``y`` (changed
    in place; ``wide``: as _analog_chain's)."""
    chain = model.chain
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
    if chain.front_end is not None:
        from odsuite.domain.recursions import sections_in_place

        slow, fast = _split_front_end(chain.front_end, exp.fs)
        y = np.array(y, dtype=float, order="F")  # the order sosfilt(..., axis=0) returns
        if slow is not None:
            sections_in_place(_analog_sos(slow, exp.fs), y, wide and y.shape[1] >= WIDE_CHAIN_COLUMNS)
        if fast is not None:
            y = _in_band(fast, exp.fs, y)
    return y


#: a front end's poles below this fraction of the sampling rate (Hz) are discretised by the
#: bilinear map (its frequency warping under 1 % there); the others act through their exact
#: in-band response
BILINEAR_BELOW = 1.0 / 20.0


@functools.lru_cache(maxsize=64)
def _split_front_end(analog, fs: float):
    """``analog`` (AnalogFilter) as a slow part (its high-passes: poles below BILINEAR_BELOW x fs,
    with as many zeros at 0, unit gain above them) and the rest (the anti-aliasing filter, a
    mounted resonance: every other pole and zero and the whole gain); None for a part without
    poles. The bilinear map would put a 30 kHz mounted resonance at 2472 Hz on a 5120 Hz record
    (it folds the whole axis into the band): a null read 118x its floor there."""
    from odsuite.domain.model import AnalogFilter

    poles = list(analog.poles)
    slow_p = [p for p in poles if abs(p) < 2 * np.pi * BILINEAR_BELOW * fs]
    zeros = list(analog.zeros)
    slow_z = [z for z in zeros if z == 0][:len(slow_p)]
    fast_z = list(zeros)
    for z in slow_z:
        fast_z.remove(z)
    fast_p = [p for p in poles if abs(p) >= 2 * np.pi * BILINEAR_BELOW * fs]
    if not fast_p and not fast_z:
        return analog, None  # as one part: the same sections as before the split
    slow = AnalogFilter(tuple(slow_z), tuple(slow_p), 1.0) if slow_p else None
    return slow, AnalogFilter(tuple(fast_z), tuple(fast_p), analog.gain)


def _in_band(analog, fs: float, y: np.ndarray) -> np.ndarray:
    """``y`` (samples x columns) through ``analog``'s exact response at each frequency of the band,
    by the FFT over twice the record (no wrap: such a filter's response lasts milliseconds). The
    sampled signal of a filtered band-limited signal: what a front end's fast part does to the
    record, aliasing nothing into it and warping nothing."""
    n = y.shape[0]
    nfft = scipy.fft.next_fast_len(2 * n, real=True)
    h = _response_lines(analog, fs, nfft)
    return np.asfortranarray(scipy.fft.irfft(scipy.fft.rfft(y, nfft, axis=0) * h[:, None], nfft, axis=0)[:n])


@functools.lru_cache(maxsize=16)
def _response_lines(analog, fs: float, nfft: int) -> np.ndarray:
    """``analog``'s response at the lines of an ``nfft``-point real FFT: the same for every
    evaluation of a fit, so kept."""
    z, p, k = analog.zpk()
    h = scipy.signal.freqs_zpk(z, p, k, worN=2 * np.pi * np.fft.rfftfreq(nfft, 1.0 / fs))[1]
    h.flags.writeable = False
    return h


def _sensor_rows(model, sensors: Sequence[Sensor]) -> np.ndarray:
    """The sensors' acceleration rows of ``model`` (Model.output_rows), kept on the model: every
    experiment of a fit evaluates one model, and the rows cost a few small products per sensor.
    Keyed by the sensors' identities (the rig's objects, kept alive with the entry)."""
    key = tuple(map(id, sensors))
    cache = model.__dict__.setdefault("_sensor_rows", {})
    if key not in cache:
        cache[key] = (tuple(sensors), model.output_rows(_sensor_outputs(sensors))[1])
    return cache[key][1]


#: the outputs of sets of sensors (rig objects, frozen), by the sensors' identities (kept alive
#: with the entry): every new model asks for its sensors' rows, and building an output normalises
#: its axis, a third of the rows' cost
_OUTPUTS: dict[tuple[int, ...], tuple[tuple[Sensor, ...], list]] = {}
OUTPUTS_KEPT = 64


def _sensor_outputs(sensors: Sequence[Sensor]) -> list:
    from odsuite.domain.model import Output

    key = tuple(map(id, sensors))
    got = _OUTPUTS.get(key)
    if got is None or any(a is not b for a, b in zip(got[0], sensors)):
        if len(_OUTPUTS) >= OUTPUTS_KEPT:
            _OUTPUTS.clear()
        got = _OUTPUTS[key] = (tuple(sensors), [Output.sensor(s) for s in sensors])
    return got[1]


@functools.lru_cache(maxsize=256)
def _sensor_filter(dyn, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """First-order-hold discretisation of a sensor's dynamics in transfer-function form (a few
    states, run by lfilter); cached, as scipy's matrix exponential dominates a fitting loop.

    The high-passes and the resonance are discretised apart and put in series: in one system, a
    resonance far above the sampling rate (a fit passing a period near 0, "no resonance") next to
    the high-passes' slow poles loses every digit (a 1e15 Hz resonance changed the signal by
    17 %); alone, each is exact to 1e-12 and tends to 1 as the period goes to 0."""
    num, den = np.ones(1), np.ones(1)
    resonance = replace(dyn, highpass_hz=0.0, coupler_highpass_hz=0.0)
    for part in (replace(dyn, resonance_period_s=0.0), resonance):
        if part.is_identity():
            continue
        ad, bd, cd, dd, _ = scipy.signal.cont2discrete(scipy.signal.zpk2ss(*part.zpk()), 1 / fs, method="foh")
        b, a = scipy.signal.ss2tf(ad, bd, cd, dd)
        num, den = np.convolve(num, b[0]), np.convolve(den, a)
    return num, den


#: public name of the sensors' discretised dynamics (a measurement effect undoes them with it)
sensor_filter = _sensor_filter


@functools.lru_cache(maxsize=64)
def _analog_sos(analog, fs: float) -> np.ndarray:
    """An analog filter (zeros, poles, gain) as digital second-order sections by the bilinear
    transform: for a front end's slow part (_split_front_end), whose frequency warping is under
    1 % below fs / 20; a hold-equivalent discretisation would alias what lies above."""
    z, p, k = (np.asarray(v, complex) for v in analog.zpk())
    zd, pd, kd = scipy.signal.bilinear_zpk(z, p, float(np.real(k)), fs)
    return scipy.signal.zpk2sos(zd, pd, kd)


#: the force window's samples whose unit responses carry its noise to the floor (impulse_responses):
#: each of them up to this many, else this many spread evenly over them
NOISE_UNITS = 32
#: ... and no more of them than hold this many values (units x samples x sensors): a long record's
#: floor takes fewer
NOISE_UNIT_VALUES = 2**23


def noise_units(exp: PreparedExperiment, spread: bool = True) -> np.ndarray:
    """The samples of the force window (where the windowed force is not zero; the trigger without
    one) whose unit responses stand for the window's noise: each sample, or the middles of
    NOISE_UNITS equal runs of them; without ``spread``, the trigger alone (a record with quiet
    samples before its hit, whose window's unit responses are the trigger's shifted)."""
    window = np.flatnonzero(exp.force)
    if not window.size or not spread:
        return np.array([min(max(exp.trigger, 0), exp.n_samples - 1)])
    most = max(1, min(NOISE_UNITS, NOISE_UNIT_VALUES // max(1, exp.n_samples * len(exp.sensors))))
    if window.size <= most:
        return window
    return window[((np.arange(most) + 0.5) * window.size / most).astype(int)]


def impulse_responses(model, exp: PreparedExperiment, spread: bool = True) -> np.ndarray:
    """The model's predictions (acceleration stage), units x samples x sensors, for a unit force
    sample at each of noise_units' samples: how the force channel's noise in the window reaches
    each channel (odsuite.analysis.noise_floor averages their energies). One unit at the trigger
    stood for them all, as if the prediction were the same shifted, which it is not where the record
    starts at its hit: the model starts from rest at the first sample, and a unit there drives it
    with half its band-limited form (the half before the record is not in the record), and a
    channel's offset window that holds the hit removes a mean that depends on where in it the unit
    sits. Thesis rig records taken from their hit had the floor's force noise 2.6-3.1x too small
    in the band of the platform's modes (156-312 Hz) and 3-5x too large at 10-78 Hz, and a perfect
    model's residual read as a missing mode."""
    out = []
    for k in noise_units(exp, spread):
        unit = np.zeros(exp.n_samples)
        unit[k] = 1.0
        out.append(predict(model, replace(exp, force=unit, _cache=None)))
    return np.stack(out)


#: realisations of the sensors' noise that the floor averages (its energy is a sum over thousands
#: of samples: two realisations differ by a few per cent)
NOISE_REALISATIONS = 2
#: converter offsets tried (fractions of a code) when the record tells where its signal sits
#: between the codes
OFFSET_GRID = 32
#: share of samples whose code the model may miss for reasons other than noise and offset
OUTLIERS = 0.01
#: a line through the samples before the hit that rises by this many codes is drift: it moves the
#: signal through the codes (the offset is then immaterial) and would pass for noise. White noise
#: of a third of a code over 200 samples tilts a fitted line by 0.1 code (one standard deviation)
DRIFT_CODES = 0.25
#: samples the offset's likelihood is evaluated on (evenly spread): beyond a few thousand the
#: posterior is a point already, and the floor is computed on every comparison
OFFSET_SAMPLES = 2048
#: codes within which a sample tells the offset: farther out the model's own error (a share of the
#: signal) blurs which code it lands on
OFFSET_CODES = 3.0


def _code_loglik(codes: np.ndarray, x: np.ndarray, blur: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Log-likelihood per offset (codes) that signal ``x`` (codes) with Gaussian ``blur`` rounds to
    ``codes``."""
    z = codes[None, :] - x[None, :] - offsets[:, None]
    p = scipy.special.ndtr((z + 0.5) / blur) - scipy.special.ndtr((z - 0.5) / blur)
    # a sample the model misses (the response's onset before the detected hit) is an outlier, not
    # a verdict on the offset
    return np.sum(np.log((1 - OUTLIERS) * p + OUTLIERS / (2 * OFFSET_CODES + 1)), axis=1)


def converter_offsets(v: np.ndarray, volts: np.ndarray, step: float, trigger: int,
                      count: int, disturbance: np.ndarray | None = None, tail: int = -1
                      ) -> tuple[np.ndarray, np.ndarray] | None:
    """``count`` offsets (volts) of a signal against its converter's codes, drawn evenly from
    what the record allows, and with each the white noise (volts) before rounding. The samples
    before the hit tell the noise and, when it spreads them over a few codes, the offset; a
    perfect model's signal ``v`` (volts) then tells the offset further: a small oscillation that
    never leaves its code puts it near the code's middle, one that flips codes near a threshold.
    The rounding error of a signal that spans few codes depends on that offset (zero for a signal
    within half a code of a code's middle). None: the record does not lie on the step's grid, or
    drifts through the codes before the hit (offsets are then uniform over a code).

    The model's own error blurs each sample by its share of the signal, that share measured where
    the signal spans many codes (there rounding hardly matters). ``disturbance`` (volts): the hum
    and drift fitted on the record, which the converter rounds with the signal: a hum of a code or
    two moves the samples through the codes, and taken for noise it would hide how small the noise
    is (and with it how white the rounding is). ``tail``: the first sample of the quiet stretch
    that ends the record (PreparedExperiment.quiet_tail), which tells the noise where fewer than two
    samples before the hit do (a record that starts at its hit)."""
    signal = v / step
    x = signal if disturbance is None else signal + disturbance / step
    # the noise before rounding: the most likely over the first half of the samples before the hit
    # (the hammer's contact and the response start before the detected hit) where the model's
    # signal is still; offsets free; a hundredth of a code at least (the model's discretisation)
    quiet = np.flatnonzero(np.abs(signal[: max(trigger, 1) // 2]) < 0.01)
    stretch = slice(0, max(trigger, 1))
    if quiet.size < 2 and 0 <= tail < len(v):
        # a tail rings on below a code: its samples all tell the noise about the signal, unless hum
        # or drift moves them through the codes there (the offset is then immaterial)
        if np.ptp(x[tail:] - signal[tail:]) >= DRIFT_CODES:
            return None
        quiet = tail + np.flatnonzero(np.abs(signal[tail:]) <= OFFSET_CODES)
        stretch = slice(tail, len(v))
    if quiet.size < 2:
        return None
    pre = volts[stretch]
    ref = volts[int(np.argmin(np.abs(volts - np.median(pre))))]
    codes = (volts - ref) / step
    if not np.all(np.abs(codes - np.round(codes)) <= GRID_TOLERANCE):
        return None
    codes = np.round(codes)
    grid = (np.arange(OFFSET_GRID) + 0.5) / OFFSET_GRID - 0.5
    line = np.polyval(np.polyfit(quiet, codes[quiet] - x[quiet], 1), quiet[[0, -1]])
    if abs(line[1] - line[0]) >= DRIFT_CODES:
        return None  # drift moves the signal through the codes: the offset is immaterial
    spread = float(np.std(codes[quiet]))
    sigmas = np.unique(np.concatenate([[0.01], np.linspace(0.05, 1.0, 20), [max(spread, 0.01)]]))
    # the samples before the hit tie noise and offset together (one share of flipped codes fits a
    # small noise near a threshold or a larger one farther in): the most likely noise per offset
    quiet_loglik = np.array([_code_loglik(codes[quiet], x[quiet], np.full(quiet.size, s), grid) for s in sigmas])
    noise = sigmas[np.argmax(quiet_loglik, axis=0)]
    if np.ptp(codes[quiet] - np.round(x[quiet])) == 0:
        # no sample left its code: the samples bound the noise from above only, and the most likely
        # is the grid's least (a twelve-bit slab's quiet channels read 0.01 code for 0.19, their
        # floor a quarter of a null's error); the mean square over what they allow instead
        w = np.exp(quiet_loglik - quiet_loglik.max(axis=0))
        noise = np.sqrt((sigmas[:, None] ** 2 * w).sum(axis=0) / w.sum(axis=0))
    # the signal's small oscillations then tell the offset
    big = np.abs(signal) > 2 * OFFSET_CODES
    share2 = float(np.sum((codes[big] - x[big]) ** 2) / np.sum(signal[big] ** 2)) if big.any() else 0.0
    small = np.flatnonzero(np.abs(signal) <= OFFSET_CODES)
    small = small[:: max(1, small.size // OFFSET_SAMPLES)]
    loglik = np.array([_code_loglik(codes[small], x[small], np.sqrt(s**2 + share2 * signal[small] ** 2), grid[[k]])[0]
                       for k, s in enumerate(noise)])
    w = np.exp(loglik - loglik.max())
    cdf = np.cumsum(w) / w.sum()
    picks = np.minimum(np.searchsorted(cdf, (np.arange(count) + 0.5) / count), OFFSET_GRID - 1)
    return grid[picks] * step, noise[picks] * step


@functools.lru_cache(maxsize=8)
def _record_basis(n: int, fs: float) -> np.ndarray:
    """disturbance_basis over a record, kept: every channel's floor of every comparison fits it."""
    basis = disturbance_basis(n, fs)
    basis.flags.writeable = False
    return basis


def carried_disturbance(v: np.ndarray, volts: np.ndarray, step: float, trigger: int, fs: float,
                        disturbance: np.ndarray) -> np.ndarray:
    """The hum and drift (volts, level with the codes before the hit) that a perfect model's signal
    ``v`` leaves in the record ``volts``: ``disturbance`` (fitted on the quiet samples alone) plus
    the same disturbances' basis (odsuite.analysis.disturbances.disturbance_basis, its constant
    left to the converter offset) fitted to what it leaves wherever the signal lies within
    OFFSET_CODES of zero, over the whole record. Fitted on 12 ms of quiet samples, under one mains
    period, a drift's line and the hum's sinusoid share its ramp, and the pair carried over the
    record missed a 16-bit drift record's codes by up to 26 codes: the converter rounds the drift
    itself, and a miss taken for noise read it as 0.45-0.95 code for 0.33."""
    small = np.abs(v) <= OFFSET_CODES * step
    basis = _record_basis(len(v), fs)
    if small.sum() <= 2 * basis.shape[1]:
        return disturbance
    coef, *_ = np.linalg.lstsq(basis[small], (volts - v - disturbance)[small], rcond=None)
    carried = disturbance + basis[:, 1:] @ coef[1:]
    return carried - np.median(carried[: max(trigger, 1)])


def sensor_noise(model, exp: PreparedExperiment, realisations: int = NOISE_REALISATIONS) -> list[np.ndarray]:
    """Realisations of what a perfect model leaves of the sensors' own noise at the acceleration
    stage: the model's signals in volts with the record's fitted hum and drift, plus white noise
    (measured on the raw codes where the record tells it, else the quiet samples' level less its
    rounding share, Sheppard) at an offset on the ADC's codes (where the record tells it:
    converter_offsets; else at random), rounded to them, minus signals and disturbances, through
    each channel's chain. The rounding error of a signal that moves through few codes is not white
    (it repeats the signal's own frequencies, and the hum's) and depends on that offset and on how
    much noise dithers it: simulated, it is right."""
    if exp.operators is None or exp.adc_step_v is None:
        return []
    rng = np.random.default_rng(0)  # reproducible floors
    physical = simulate_sensors(model, exp)
    vpu = np.asarray(exp.volts_per_unit, float)
    micro = np.array([1e6 if u.startswith("u") else 1.0 for u in exp.units]) if exp.units else np.ones(len(vpu))
    step = np.asarray(exp.adc_step_v, float)
    volts_per_stage = np.abs(vpu) / micro
    rounding = np.where(step > 0, exp.lsb**2 / 12.0, 0.0)
    # the quiet level less the rounding's share (Sheppard); where the level is at most that share
    # the rounding was not uniform (a still signal on few codes) and the level is the noise's bound:
    # taken whole (it left no noise at all, and a still channel of a 12-bit card read 4.3x its floor)
    noise_var = np.asarray(exp.noise_var, float)
    sigma_v = np.sqrt(np.where(noise_var > rounding, noise_var - rounding, noise_var)) * volts_per_stage
    v = physical * vpu
    # the hum and drift, level with the codes before the hit (the offset places them on the codes)
    hum = np.zeros_like(v)
    if exp.volts_disturbance is not None:
        hum = exp.volts_disturbance - np.median(exp.volts_disturbance[: max(exp.trigger, 1)], axis=0)
    # the codes tell a noise below a code (there it decides how white the rounding is); a wider
    # one is the quiet samples' level less the rounding's share, which the likelihood's grid of
    # noises up to a code would misread
    narrow = np.sqrt(np.asarray(exp.noise_var, float)) * volts_per_stage < step
    for j in np.flatnonzero((step > 0) & narrow):
        hum[:, j] = carried_disturbance(v[:, j], exp.volts[:, j], step[j], exp.trigger, exp.fs, hum[:, j])
    told = {j: converter_offsets(v[:, j], exp.volts[:, j], step[j], exp.trigger, realisations, hum[:, j], exp.quiet_tail)
            for j in np.flatnonzero((step > 0) & narrow)}
    told = {j: t for j, t in told.items() if t is not None}
    out = []
    for i in range(realisations):
        offset = rng.uniform(0.0, 1.0, len(step)) * step
        sigma = sigma_v.copy()
        for j, (picks, noise) in told.items():
            # the noise measured on the raw codes: the acceleration stage's is filtered
            offset[j], sigma[j] = picks[i], noise[i]
        x = v + hum + offset + rng.standard_normal(v.shape) * sigma
        q = np.where(step > 0, np.round(x / np.where(step > 0, step, 1.0)) * step, x)
        err = (q - offset - v - hum) / vpu
        stage = np.empty_like(err)
        for op in exp.operators:
            cols = list(op.columns)
            stage[:, cols] = op.apply(err[:, cols])
        out.append(stage)
    return out


def through_chain(exp: PreparedExperiment, physical: np.ndarray, taps: Sequence[str] | None = None
                  ) -> dict[str, np.ndarray]:
    """Put predicted physical signals through each sensor's own chain, as volts, like the data."""
    taps = taps or (stage_names("acceleration")[0],)
    out = {t: np.empty_like(physical) for t in taps}
    for j, res in enumerate(run_each(exp.chains, physical * exp.volts_per_unit[None, :])):
        for t in taps:
            out[t][:, j] = res[t]
    return out


def run_each(chains: Sequence, x: np.ndarray) -> list[dict[str, np.ndarray]]:
    """Chain j over column j of ``x`` (samples x chains), every tap, as ``chain.run`` gives it (the
    whole record as one chunk), in one call of the executor: called per channel, its overhead
    was a third of ``prepare``'s time."""
    return run_array(chains, x, chunk=max(x.shape[0], 1))


def predict(model, exp: PreparedExperiment) -> np.ndarray:
    """Predicted signals at the acceleration stage, samples x sensors."""
    return _digital_chain(exp, simulate_sensors(model, exp))


#: predict_sharing filters new chains (each: every coordinate's signal) beside the ones it keeps
#: while their signals are at most this fraction of the sensors predict would filter
NEW_CHAIN_SHARE = 0.5
#: ... and at first (none kept yet) at most this many chains
FIRST_CHAINS = 3


def predict_sharing(model, exp: PreparedExperiment) -> np.ndarray:
    """``predict(model, exp)`` for a model whose structure's response ``exp`` keeps (a candidate
    that changes the sensors alone: gain, tilt, position, cables): the chain is linear, so its
    filtering of the coordinates, done once per distinct channel chain and kept, combines by each
    model's sensor rows (as linearised_changes; equal to predict but for rounding); a channel whose
    row the last such prediction had takes that prediction's column (exchanged cables: a swap
    moves two rows). Where the new chains cost more than predict's filtering (delays or dynamics
    that move each evaluation: NEW_CHAIN_SHARE), predict's own numbers: with delays, from the
    undelayed signals' spectra, kept (_predict_delayed). Otherwise predict."""
    st = model.structure
    if (not st.is_linear or st.n_dof > CACHED_COORDINATES or exp.operators is None or exp._cache is None
            or exp._cache[0] is not st or exp._cache[1] != _cache_key(model, exp)):
        return predict_kept(model, exp)
    chain = model.chain
    groups: dict[tuple, list[int]] = {}
    for op in exp.operators:
        for j in op.columns:
            s = exp.sensors[j]
            groups.setdefault((id(op), chain.sensor_dynamics(s.name), chain.delay.get(s.name, 0.0),
                               chain.front_end), []).append(j)
    if exp._filtered is None or exp._filtered[0] is not exp._cache:
        exp._filtered = (exp._cache, {}, exp.operators, {})
    kept, last = exp._filtered[1], exp._filtered[3]
    new = sum(k not in kept for k in groups)
    # the first few chains of these coordinates are filtered though they cost more than predict's
    # filtering (the sensors' candidates evaluate them again and again); later ones only while
    # they cost less (a delay per channel makes every channel's chain new)
    if new > FIRST_CHAINS if not kept else new * exp._cache[2].shape[1] > NEW_CHAIN_SHARE * len(exp.sensors):
        return _predict_delayed(model, exp, last) if any(k[2] for k in groups) else predict(model, exp)
    q = exp._cache[2]
    rows = _sensor_rows(model, exp.sensors)
    out = np.empty((exp.n_samples, len(exp.sensors)))
    for key, cols in groups.items():
        if key not in kept:
            op = next(o for o in exp.operators if cols[0] in o.columns)
            one = replace(exp, sensors=[exp.sensors[cols[0]]] * q.shape[1],
                          operators=[replace(op, columns=tuple(range(q.shape[1])))])
            kept[key] = _digital_chain(one, _analog_chain(model, one, q.copy(), wide=True), wide=True)
        _combined(kept[key], rows, cols, out, last.get(key))
        last[key] = (out, {rows[j].tobytes(): j for j in cols}, len(cols))
    out.flags.writeable = False  # its columns are taken again (last)
    return out


#: predict's numbers (read-only) by their simulation (kept_simulations'), sensor rows, analog
#: chain and operators, while simulations are kept: a structure simulated again is put through
#: the same chain again (a leave-one-out fold's first residual, a candidate's nominal point)
_PREDICTIONS: dict[tuple, tuple] = {}
PREDICTIONS_BYTES_KEPT = 4e6
_predictions_held = 0


def predict_kept(model, exp: PreparedExperiment) -> np.ndarray:
    """``predict(model, exp)`` (read-only), kept within kept_simulations for a linear structure of
    few coordinates. Its simulation is asked for as predict asks (leaving ``exp`` as predict
    leaves it), then its numbers are taken where the same simulation went through the same rows
    and chain before."""
    global _predictions_held
    st = model.structure
    if _SIMULATIONS is None or not st.is_linear or st.n_dof > CACHED_COORDINATES or exp.operators is None:
        return predict(model, exp)
    _force_inputs(model, exp)  # as simulate_sensors
    rows = _sensor_rows(model, exp.sensors)
    q = _coordinates(model, exp, HOLD)
    chain = model.chain
    key = (id(q), rows.shape, rows.tobytes(), chain.front_end, tuple(map(id, exp.operators)),
           tuple((chain.sensor_dynamics(s.name), chain.delay.get(s.name, 0.0)) for s in exp.sensors))
    got = _PREDICTIONS.pop(key, None)
    if got is None or got[0] is not q or any(a is not b for a, b in zip(got[1], exp.operators)):
        out = _digital_chain(exp, _analog_chain(model, exp, q @ rows.T))
        out.flags.writeable = False
        got = (q, tuple(exp.operators), out)
        _predictions_held += out.nbytes
        while _PREDICTIONS and _predictions_held > PREDICTIONS_BYTES_KEPT:
            _predictions_held -= _PREDICTIONS.pop(next(iter(_PREDICTIONS)))[2].nbytes
    _PREDICTIONS[key] = got  # the most recent last
    return got[2]


def _combined(filtered: np.ndarray, rows: np.ndarray, cols: list[int], out: np.ndarray, last) -> None:
    """``out[:, cols] = filtered @ rows[cols].T``, each column whose row ``last`` (a prediction,
    its columns by their rows' bytes, how many it combined) had copied from it. A product of two
    or more columns gives each column the numbers it has in any other (matrix-matrix: each entry
    the same sum); of one (matrix-vector) a sum in another order: a single column left to compute
    is computed with another beside it."""
    if last is None or len(cols) < 2 or last[2] < 2:
        out[:, cols] = filtered @ rows[cols].T
        return
    prior, where, _ = last
    found = {j: where.get(rows[j].tobytes()) for j in cols}
    have = [(j, k) for j, k in found.items() if k is not None]
    todo = [j for j, k in found.items() if k is None]
    if len(cols) == out.shape[1] and prior.shape == out.shape:
        out[...] = prior  # one copy, then the columns that moved (a swap: two)
        have = [(j, k) for j, k in have if j != k]
    if have:
        out[:, [j for j, _ in have]] = prior[:, [k for _, k in have]]
    if len(todo) == 1:
        beside = next(j for j in cols if j != todo[0])
        out[:, todo] = (filtered @ rows[[todo[0], beside]].T)[:, :1]
    elif todo:
        out[:, todo] = filtered @ rows[todo].T


def _predict_delayed(model, exp: PreparedExperiment, last: dict) -> np.ndarray:
    """``predict(model, exp)`` (its numbers) for delayed channels of a structure ``exp`` keeps: the
    sensors' signals before their delays and their spectra kept in ``last`` for the model's rows
    and analog chain (a search over delays shifts the same signals again and again)."""
    from odsuite.domain.simulation import delay_length, sampled_later

    chain = model.chain
    rows = _sensor_rows(model, exp.sensors)
    key = (rows.tobytes(), tuple(chain.sensor_dynamics(s.name) for s in exp.sensors), chain.front_end)
    got = last.get("delayed")
    if got is None or got[0] != key:
        y = _sensor_side(model, exp, exp._cache[2] @ rows.T)  # as simulate_sensors
        got = last["delayed"] = (key, y, np.fft.rfft(y, n=delay_length(y.shape[0]), axis=0))
    delays = [chain.delay.get(s.name, 0.0) for s in exp.sensors]
    return _digital_chain(exp, sampled_later(got[1], exp.fs, delays, spectrum=got[2]))


def flexible_mode_change(model, exp: PreparedExperiment, mode,
                         unit: Callable[[], np.ndarray] | None = None) -> np.ndarray:
    """What adding the flexible ``mode`` to ``model``'s structure changes in ``predict(model, exp)``
    (samples x sensors). The mode's coordinate is uncoupled from the others (its own rows of M, C
    and K), so its response adds to theirs: one 1-degree-of-freedom simulation through the chain,
    instead of the whole structure's again (a search over a mode's frequency and damping). The
    response is linear in the mode's participations: ``unit`` (where given) returns
    flexible_mode_unit's for the mode's frequency and damping, kept by a caller that asks again
    for other participations."""
    b, c = model.flexible_participation(mode, _force_inputs(model, exp)[0], _sensor_outputs(exp.sensors))
    if b == 0.0 or not c.any():
        return np.zeros((exp.n_samples, len(exp.sensors)))
    g = unit() if unit is not None else flexible_mode_unit(model, exp, mode.frequency_hz, mode.damping_ratio)
    return g * (b * c)[None, :]


def flexible_mode_unit(model, exp: PreparedExperiment, frequency_hz: float, damping_ratio: float) -> np.ndarray:
    """flexible_mode_change of an uncoupled mode at ``frequency_hz`` and ``damping_ratio`` whose
    participation is 1 at the force and at every sensor (samples x sensors)."""
    from odsuite.domain.model import StateSpace

    w = 2 * np.pi * frequency_hz
    rate = np.array([-w * w, -2 * damping_ratio * w])
    # q'' + 2 zeta w q' + w^2 q = F, its acceleration out
    sdof = StateSpace(np.array([[0.0, 1.0], rate]), np.array([[0.0], [1.0]]), rate[None, :], np.array([[1.0]]))
    accel = _simulated(sdof, exp, HOLD)
    return _digital_chain(exp, _analog_chain(model, exp, accel * np.ones((1, len(exp.sensors))), wide=True),
                          wide=True)


def _digital_chain(exp: PreparedExperiment, physical: np.ndarray, wide: bool = False) -> np.ndarray:
    """Physical signals at the sensors through each channel's processing to the acceleration stage
    (``wide``: many signals through one chain, a diagnosis's basis: StageOperator.apply_into)."""
    if exp.operators is None:
        return through_chain(exp, physical)[stage_names("acceleration")[0]]
    out = np.empty_like(physical)  # its memory order too: later sums over it add in that order
    for op in exp.operators:
        op.apply_into(physical, out, wide)
    return out


def _integrates(exp: PreparedExperiment) -> bool:
    """Every channel's chain carries acceleration through to displacement."""
    return all(t in chain.taps for chain in exp.chains for t in stage_names("acceleration"))


def solved_bodies(rig: Rig, exp: PreparedExperiment) -> list[tuple[Any, dict[str, int]]]:
    """The bodies whose motion ``exp``'s sensors determine (contracts.solvers.body_solvers' choice
    for each), each with its sensors' columns in ``exp``; none when some channel is not integrated
    twice (no displacements)."""
    from odsuite.contracts.solvers import body_solvers

    if not _integrates(exp):
        return []
    column = {s.name: j for j, s in enumerate(exp.sensors)}
    return [(c, {n: column[n] for n in c.sensors})
            for c in body_solvers(rig, column, exp.registries.coordinate_solvers)[0]]


def coordinate_series(rig: Rig, exp: PreparedExperiment, model) -> dict[str, tuple[np.ndarray, np.ndarray, list[int]]]:
    """Per body whose motion its sensors determine: measured and model generalized coordinates at
    its G (samples x 6; m, rad), both from displacements after the full chain and the body's
    solver, and the body's columns in ``exp``. Empty when some channel is not integrated twice (no
    displacements)."""
    taps = stage_names("acceleration")
    out: dict[str, tuple[np.ndarray, np.ndarray, list[int]]] = {}
    bodies = solved_bodies(rig, exp)
    if not bodies:
        return out
    predicted = through_chain(exp, simulate_sensors(model, exp), taps)
    measured = {t: np.empty_like(exp.measured) for t in taps}
    for j, res in enumerate(run_each(exp.chains, exp.volts)):
        for t in taps:
            measured[t][:, j] = res[t]
    for c, idx in bodies:
        gm = c.solver.solve(rig, c.body, {n: measured["displacement"][:, j] for n, j in idx.items()}).at_g
        gp = c.solver.solve(rig, c.body, {n: predicted["displacement"][:, j] for n, j in idx.items()}).at_g
        out[c.body.name] = (gm, gp, list(idx.values()))
    return out


def experiment_coordinates(project, name: str, revision: Mapping[str, Any] | None = None
                           ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Measured and model generalized coordinates of one experiment per nine-sensor body, for the
    current model revision (or ``revision``): the model driven by the measured force, predicted at
    the sensors and put through the experiment's chain and solver like the measurement."""
    from odsuite.analysis.modelrev import check_revision, current_revision, revision_model

    check_revision("experiment_coordinates", revision)
    exp = prepare_experiment(project, name)
    model = revision_model(project, revision or current_revision(project)).for_experiment(name)
    # one BLAS thread, as compare runs: two threads summed the 4096-sample solves in another order
    # and the drawn motion's errors left compare's by 1e-10 relative
    with threadpool_limits(1):
        series = coordinate_series(project.rig, exp, model)
    if not series and _integrates(exp):  # the chains are whole: the sensor layout is why
        from odsuite.contracts.solvers import body_solvers

        notes = body_solvers(project.rig, [s.name for s in exp.sensors], exp.registries.coordinate_solvers)[1]
        raise ConfigError(f"{project.path}: experiment {name!r}: no body's motion can be solved from its sensors, "
                          f"so there are no generalized coordinates ({'; '.join(notes)})")
    if not series:
        raise ConfigError(f"{project.path}: experiment {name!r}: the chains do not integrate every "
                          "accelerometer to displacement, so there are no generalized coordinates")
    return {body: (gm, gp) for body, (gm, gp, _) in series.items()}
