"""Processing steps of the thesis's Signal Processor (Ch. 4.3, Eq. 4.2-4.8, Table E.2).

Each provider is called as ``provider(fs=<Hz>, **params)`` and returns a step (or, for zero-phase
filtering, a list of steps and markers). All steps are float64 and run along the last axis: one
channel (1-D samples) or several channels with the same settings at once (channels x samples).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
import scipy  # scipy.signal and scipy.linalg load on first use: fast `odsuite plugins`

from odsuite.api import ConfigError
from odsuite.contracts.steps import Filter, Gain, Reverse, Step, StepProvider, WindowMean


@functools.cache
def _sosfilt_inplace():
    """The in-place kernel behind scipy.signal.sosfilt (releases the GIL): no copy of the input.
    None in a SciPy that moved it: the public function, one copy more."""
    try:
        from scipy.signal._sosfilt import _sosfilt
    except ImportError:
        return None
    return _sosfilt


def _none(x: np.ndarray) -> np.ndarray:
    """No samples, with the channel axes of ``x``."""
    return x[..., :0]


def _sosfilt_owned(sos: np.ndarray, x: np.ndarray, zi: np.ndarray) -> np.ndarray:
    """``scipy.signal.sosfilt`` of ``x`` (channels x samples, C-contiguous float64) overwriting
    ``x``; ``zi`` (channels x sections x 2) is updated in place."""
    kernel = _sosfilt_inplace()
    if kernel is None:
        y, zf = scipy.signal.sosfilt(sos, x, axis=-1, zi=zi.transpose(1, 0, 2))
        x[...] = y
        zi[...] = zf.transpose(1, 0, 2)
        return x
    kernel(sos, x, zi)
    return x


def _positive(step: str, name: str, value, *, integer: bool = False) -> float:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value) and value > 0
    if ok and integer and float(value) != int(value):
        ok = False
    if not ok:
        kind = "a positive integer" if integer else "a finite number > 0"
        raise ConfigError(f"step {step!r} parameter {name!r}: expected {kind}, got {value!r}")
    return float(value)


# ------------------------------------------------------------------------------------ scaling


@dataclass(frozen=True)
class Scale(Step):
    """y = factor * x (unit conversion, sign inversion, micro-units)."""

    factor: float
    batched = True

    def process(self, chunk, state):
        return chunk * self.factor, state

    def process_owned(self, chunk, state):
        chunk *= self.factor
        return chunk, state

    def fuse(self, following):
        if isinstance(following, Scale):
            return Scale(self.factor * following.factor)
        if isinstance(following, (WindowOffset, MovingAverageOffset)):
            # the mean of a scaled window is the scaled mean: the offset step scales as it goes
            return following.scaled(self.factor)
        if isinstance(following, Sos):
            return following.scaled(self.factor)
        return None


def convert(fs: float, sensitivity: float, daq_gain: float = 1.0) -> Scale:
    """Volts to physical units, Eq. 4.3 in SI: value = volts / (sensitivity [V/unit] * daq_gain)."""
    s = _positive("convert", "sensitivity", sensitivity)
    g = _positive("convert", "daq_gain", daq_gain)
    return Scale(1.0 / (s * g))


def invert(fs: float) -> Scale:
    """Sign inversion (Table E.2 row 14)."""
    return Scale(-1.0)


def micro(fs: float) -> Scale:
    """Micro-units, x1e6 (Table E.2 row 13)."""
    return Scale(1e6)


def scale(fs: float, factor: float) -> Scale:
    """Multiply by a constant."""
    if not (isinstance(factor, (int, float)) and np.isfinite(factor)):
        raise ConfigError(f"step 'scale' parameter 'factor': expected a finite number, got {factor!r}")
    return Scale(float(factor))


# ------------------------------------------------------------------------------------ offsets


@dataclass
class _OffsetState:
    held: list = field(default_factory=list)
    seen: int = 0
    mean: np.ndarray | None = None


@dataclass(frozen=True)
class WindowOffset(Step):
    """Subtract the mean of samples [start, start + length) (Table E.2 rows 15-16).

    Streaming holds samples back until the window is complete. ``factor`` scales the input first
    (a fused unit conversion)."""

    start: int
    length: int
    factor: float = 1.0
    batched = True

    def scaled(self, k: float) -> WindowOffset:
        return WindowOffset(self.start, self.length, self.factor * k)

    def init_state(self):
        return _OffsetState()

    def process(self, chunk, state):
        return self.process_owned(np.array(chunk, dtype=np.float64), state)

    def process_owned(self, chunk, state):
        x = chunk
        if self.factor != 1.0:
            x *= self.factor
        if state.mean is not None:
            x -= state.mean
            return x, state
        state.held.append(x)
        state.seen += x.shape[-1]
        if state.seen < self.start + self.length:
            return _none(x), state
        held = np.concatenate(state.held, axis=-1) if len(state.held) > 1 else x
        state.held = []
        state.mean = np.mean(held[..., self.start:self.start + self.length], axis=-1, keepdims=True)
        held -= state.mean
        return held, state

    def finish(self, state):
        if state.mean is None:
            raise ConfigError(f"step 'offset': window samples {self.start}..{self.start + self.length - 1} "
                              f"lies outside the record of {state.seen} samples")
        return _none(state.mean)


def offset(fs: float, start: int = 0, length: int = 0) -> WindowOffset:
    """Subtract the mean of the window [start, start + length)."""
    if not (isinstance(start, int) and start >= 0):
        raise ConfigError(f"step 'offset' parameter 'start': expected an integer >= 0, got {start!r}")
    _positive("offset", "length", length, integer=True)
    return WindowOffset(int(start), int(length))


@dataclass
class _MovingState:
    history: np.ndarray | None = None


@dataclass(frozen=True)
class MovingAverageOffset(Step):
    """Subtract the trailing moving average of ``length`` samples (fewer at the record's start)."""

    length: int
    factor: float = 1.0
    batched = True

    def scaled(self, k: float) -> MovingAverageOffset:
        return MovingAverageOffset(self.length, self.factor * k)

    def init_state(self):
        return _MovingState()

    def process(self, chunk, state):
        if not chunk.shape[-1]:
            return chunk, state
        x = chunk * self.factor if self.factor != 1.0 else chunk
        h = _none(x) if state.history is None else state.history
        full = np.concatenate([h, x], axis=-1)
        csum = np.cumsum(full, axis=-1)
        csum = np.concatenate([np.zeros_like(csum[..., :1]), csum], axis=-1)
        idx = np.arange(h.shape[-1], full.shape[-1]) + 1  # window ends (exclusive) in csum
        lo = np.maximum(idx - self.length, 0)
        out = x - (csum[..., idx] - csum[..., lo]) / (idx - lo)
        state.history = full[..., max(full.shape[-1] - (self.length - 1), 0):]
        return out, state


def moving_average(fs: float, length: int) -> MovingAverageOffset:
    """Subtract a trailing moving average (the thesis's "moving average" offset, §3.2)."""
    return MovingAverageOffset(int(_positive("moving-average", "length", length, integer=True)))


# ------------------------------------------------------------------------------------ IIR


@dataclass
class _SosState:
    zi: np.ndarray | None = None  # channels x sections x 2
    skip: int = 0
    channels: tuple = ()  # the leading axes of the input: () for one channel, (k,) for k


@dataclass(frozen=True, eq=False)
class Sos(Step):
    """A cascade of second-order sections run with ``scipy.signal.sosfilt``.

    ``delay``: the output lags the input by this many samples (one per Eq. 4.5 integrator); the
    first ``delay`` outputs are dropped and ``finish`` feeds ``delay`` zeros (x[m] = 0).
    ``zi_x0``: initial state per unit first input sample (sosfiltfilt's steady-state start, or an
    integrator's start at zero), or None for a zero initial state (causal, as in the thesis).
    ``zero_lead``: the dropped outputs are zero by construction, so later sections may share the
    cascade (they then see those zeros first, which leaves them at rest).
    """

    sos: np.ndarray
    delay: int = 0
    zi_x0: np.ndarray | None = None
    zero_lead: bool = False
    batched = True

    def scaled(self, k: float) -> Sos:
        sos = self.sos.copy()
        sos[0, :3] *= k
        return Sos(sos, self.delay, None if self.zi_x0 is None else self.zi_x0 * k, self.zero_lead)

    def fuse(self, following):
        # a delayed section must come first: its closing zero (x[m] = 0) is fed at the cascade input
        if not isinstance(following, Sos) or following.delay or (self.delay and not self.zero_lead):
            return None
        n1, n2 = len(self.sos), len(following.sos)
        if following.zi_x0 is None:
            zi = None if self.zi_x0 is None else np.vstack([self.zi_x0, np.zeros((n2, 2))])
        elif self.zi_x0 is None and not self.delay:
            # at rest, the cascade's first output is the product of the sections' b0 times x[0]
            zi = np.vstack([np.zeros((n1, 2)), following.zi_x0 * np.prod(self.sos[:, 0])])
        else:
            return None
        return Sos(np.vstack([self.sos, following.sos]), self.delay, zi, self.zero_lead)

    def init_state(self):
        return _SosState(skip=self.delay)

    def process(self, chunk, state):
        return self.process_owned(np.array(chunk, dtype=np.float64, order="C"), state)

    def process_owned(self, chunk, state):
        if not chunk.shape[-1]:
            return chunk, state
        if state.zi is None:
            state.channels = chunk.shape[:-1]
            first = chunk[..., 0].reshape(-1, 1, 1)
            state.zi = (np.zeros((first.shape[0], len(self.sos), 2)) if self.zi_x0 is None
                        else np.ascontiguousarray(self.zi_x0 * first))
        x = chunk if chunk.flags.c_contiguous and chunk.dtype == np.float64 else np.ascontiguousarray(chunk, np.float64)
        y = _sosfilt_owned(self.sos, x.reshape(-1, x.shape[-1]), state.zi).reshape(x.shape)
        if state.skip:
            drop = min(state.skip, y.shape[-1])
            state.skip -= drop
            y = y[..., drop:]
        return y, state

    def finish(self, state):
        if not self.delay or state.zi is None:
            return np.empty(state.channels + (0,))
        y, state = self.process_owned(np.zeros(state.channels + (self.delay,)), state)
        return y


FAMILIES = ("elliptic", "butterworth")
TYPES = {"lowpass": "lowpass", "highpass": "highpass", "bandpass": "bandpass", "bandstop": "bandstop"}


def design_sos(*, fs: float, family: str = "elliptic", type: str = "highpass", order: int = 8,
               cutoff_low: float | None = None, cutoff_high: float | None = None,
               ripple_db: float = 0.1, attenuation_db: float = 60.0) -> np.ndarray:
    """Second-order sections of the Table E.2 filter: ``scipy.signal.ellip`` or ``butter``.

    Low-pass uses ``cutoff_high`` (row 8), high-pass ``cutoff_low`` (row 9), band filters both;
    the cut-off a type does not use is ignored (Table E.3 leaves row 8 at Nyquist under high-pass).
    """
    fam = str(family).lower()
    if fam not in FAMILIES:
        raise ConfigError(f"step 'iir' parameter 'family': expected one of {', '.join(FAMILIES)}, got {family!r}")
    btype = TYPES.get(str(type).lower())
    if btype is None:
        raise ConfigError(f"step 'iir' parameter 'type': expected one of {', '.join(TYPES)}, got {type!r}")
    n = int(_positive("iir", "order", order, integer=True))
    nyq = fs / 2
    need = {"lowpass": ("cutoff_high",), "highpass": ("cutoff_low",)}.get(btype, ("cutoff_low", "cutoff_high"))
    values = {"cutoff_low": cutoff_low, "cutoff_high": cutoff_high}
    for name in need:
        v = values[name]
        if not (isinstance(v, (int, float)) and not isinstance(v, bool) and 0 < v < nyq):
            raise ConfigError(f"step 'iir' parameter {name!r}: a {btype} filter needs a cut-off in "
                              f"(0, {nyq:g}) Hz (Nyquist at fs = {fs:g} Hz), got {v!r}")
    wn = values[need[0]] if len(need) == 1 else [cutoff_low, cutoff_high]
    if len(need) == 2 and cutoff_low >= cutoff_high:
        raise ConfigError(f"step 'iir': cutoff_low {cutoff_low!r} Hz must be below cutoff_high {cutoff_high!r} Hz")
    if fam == "elliptic":
        rp = _positive("iir", "ripple_db", ripple_db)
        rs = _positive("iir", "attenuation_db", attenuation_db)
        return _designed(fam, n, rp, rs, tuple(np.atleast_1d(wn).tolist()), btype, float(fs)).copy()
    return _designed(fam, n, None, None, tuple(np.atleast_1d(wn).tolist()), btype, float(fs)).copy()


@functools.lru_cache(maxsize=256)
def _designed(fam: str, n: int, rp, rs, wn: tuple, btype: str, fs: float) -> np.ndarray:
    """One filter design, computed once for every channel that asks for it (4,000 channels of
    one Systeminfo designed the same two filters 8,000 times)."""
    band = wn[0] if len(wn) == 1 else list(wn)
    if fam == "elliptic":
        return scipy.signal.ellip(n, rp, rs, band, btype=btype, fs=fs, output="sos")
    return scipy.signal.butter(n, band, btype=btype, fs=fs, output="sos")


@dataclass(frozen=True)
class _OddPad(Step):
    """sosfiltfilt's odd extension: ``edge`` reflected samples before and after the record."""

    edge: int
    batched = True

    def init_state(self):
        return {"head": [], "seen": 0, "started": False, "tail": None}

    def process(self, chunk, state):
        e = self.edge
        if state["started"]:
            state["tail"] = np.concatenate([state["tail"], chunk], axis=-1)[..., -(e + 1):]
            return chunk, state
        state["head"].append(chunk)
        state["seen"] += chunk.shape[-1]
        if state["seen"] <= e:
            return _none(chunk), state
        x = np.concatenate(state["head"], axis=-1)
        state["head"], state["started"], state["tail"] = [], True, x[..., -(e + 1):]
        return np.concatenate([2 * x[..., :1] - x[..., e:0:-1], x], axis=-1), state

    def finish(self, state):
        if not state["started"]:
            raise ConfigError(f"zero-phase filter: the record ({state['seen']} samples) must be longer "
                              f"than its edge padding of {self.edge} samples")
        t = state["tail"]
        return 2 * t[..., -1:] - t[..., -2::-1]


@dataclass(frozen=True)
class _DropHead(Step):
    """Drop the first ``count`` samples."""

    count: int
    batched = True

    def init_state(self):
        return self.count

    def process(self, chunk, state):
        drop = min(state, chunk.shape[-1])
        return chunk[..., drop:], state - drop


def zero_phase_steps(sos: np.ndarray) -> list:
    """Forward-backward filtering equal to ``scipy.signal.sosfiltfilt(sos, x)`` (odd padding,
    steady-state initial conditions), as streaming steps around two time reversals."""
    ntaps = 2 * len(sos) + 1 - min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
    edge = 3 * ntaps
    zi = scipy.signal.sosfilt_zi(sos)
    # the forward outputs over the leading pad never reach the kept backward outputs: drop them
    return [_OddPad(edge), Sos(sos, zi_x0=zi), _DropHead(edge), Reverse(),
            Sos(sos, zi_x0=zi), _DropHead(edge), Reverse()]


def iir(fs: float, family: str = "elliptic", type: str = "highpass", order: int = 8,
        cutoff_low: float | None = None, cutoff_high: float | None = None, ripple_db: float = 0.1,
        attenuation_db: float = 60.0, zero_phase: bool = False) -> Step | list:
    """An IIR filter (Eq. 4.4): causal ``sosfilt`` from rest as in the thesis, or zero-phase."""
    sos = design_sos(fs=fs, family=family, type=type, order=order, cutoff_low=cutoff_low,
                     cutoff_high=cutoff_high, ripple_db=ripple_db, attenuation_db=attenuation_db)
    return zero_phase_steps(sos) if zero_phase else Sos(sos)


# ------------------------------------------------------------------------------------ integration

RULES = ("thesis", "trapezoid")


def integrator_sos(rule: str, fs: float) -> tuple[np.ndarray, int, np.ndarray]:
    """The integrator as one second-order section, and its output delay in samples.

    ``"thesis"``: Eq. 4.5 (LabVIEW's Integral x(t)), y[i] = sum_{j<=i} (x[j-1] + 4x[j] + x[j+1]) dt/6
    with x[-1] = x[m] = 0, i.e. y[i] = y[i-1] + (x[i-1] + 4x[i] + x[i+1]) dt/6: a section with
    b = dt/6 [1, 4, 1], a = [1, -1], delayed one sample (it reads x[i+1]). Its sum runs to
    t_i + dt/2, so the result LEADS the true integral by half a sample; two integrations advance the
    signal by one sample, a phase error of 2 pi f dt (0.16 rad at 500 Hz, 20 kHz). The sum starts at
    j = 0, so the section starts from the state that makes its (dropped) first output zero.
    ``"trapezoid"``: y[0] = 0, y[i] = y[i-1] + (x[i-1] + x[i]) dt/2, i.e.
    ``scipy.integrate.cumulative_trapezoid(x, dx=dt, initial=0)``: centred on the sample times.
    Returns (sos, delay, zi_x0).
    """
    dt = 1.0 / fs
    if rule == "thesis":
        return np.array([[dt / 6, 4 * dt / 6, dt / 6, 1.0, -1.0, 0.0]]), 1, np.array([[-dt / 6, 0.0]])
    if rule == "trapezoid":
        return np.array([[dt / 2, dt / 2, 0.0, 1.0, -1.0, 0.0]]), 0, np.array([[-dt / 2, 0.0]])
    raise ConfigError(f"step 'integrate' parameter 'rule': expected one of {', '.join(RULES)}, got {rule!r}")


def integrate(fs: float, rule: str = "thesis") -> Sos:
    """Numerical integration: the thesis's Eq. 4.5 rule (default) or the centred trapezoid rule."""
    sos, delay, zi = integrator_sos(rule, fs)
    return Sos(sos, delay, zi, zero_lead=True)


#: name -> provider, registered by the plugin; the linear forms let the comparison run a model's
#: prediction through the same operators (odsuite.contracts.steps)
PROVIDERS = {
    "convert": StepProvider(convert, lambda fs, **p: (Gain(convert(fs, **p).factor),)),
    "invert": StepProvider(invert, lambda fs: (Gain(-1.0),)),
    "micro": StepProvider(micro, lambda fs: (Gain(1e6),)),
    "scale": StepProvider(scale, lambda fs, **p: (Gain(scale(fs, **p).factor),)),
    "offset": StepProvider(offset, lambda fs, **p: (WindowMean((o := offset(fs, **p)).start, o.length),)),
    "moving-average": StepProvider(moving_average),
    "iir": StepProvider(iir, lambda fs, zero_phase=False, **p: (
        Filter(np.ascontiguousarray(design_sos(fs=fs, **p)), bool(zero_phase)),)),
    "integrate": StepProvider(integrate),
}
