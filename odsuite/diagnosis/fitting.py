"""The fitting engine of the diagnosis: one candidate effect's output-error problem over the
experiments, its screening from nominal and grid starts, the bounded least-squares fit, its
uncertainties and its validation on data the fit did not see.

Fits see each record only up to where its response has decayed into the noise (the rest is added
back to reported errors). Screening moves each parameter one small step from its nominal value
(finite differences) and takes one Gauss-Newton step, evaluated for real; parameters the residual
cannot see at their nominal value (a resonance frequency while its amplitude is zero) get a start
from a grid and from the peaks of the residual spectrum; amplitudes that only act in products get
one of them moved first; discrete parameters are tried one choice at a time. Shared parameters are
validated by leaving one experiment out; per-experiment parameters on held-out channels.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import scipy.fft
import scipy.linalg
import scipy.signal
from scipy.optimize import OptimizeResult
# scipy's trust-region reflective pieces (private, pinned with scipy <1.17 in pyproject.toml): _trf
# runs them on a small square root of J^T J instead of the whole Jacobian
from scipy.optimize._lsq.common import (CL_scaling_vector, check_termination, find_active_constraints,
                                        make_strictly_feasible, solve_lsq_trust_region, update_tr_radius)
from scipy.optimize._lsq.trf import select_step

from odsuite.domain.errors import DivergedError, NonPhysicalError
from odsuite.analysis.modelrev import RevisionModel
from odsuite.analysis.noise_colour import quiet_stretches
from odsuite.analysis.noise_floor import active_var
from odsuite.analysis.prediction import (PreparedExperiment, cubic_change_predictions, flexible_mode_change,
                                         flexible_mode_unit, linearised_changes, predict_kept, predict_sharing,
                                         simulate_together)

#: fits start on short heads of the records (s after the hit), then the whole record: a frequency
#: error makes the time-domain residual oscillate in the parameter, a short head keeps it convex
HEADS_S = (0.01, 0.04)


#: fits stop where the measured response has decayed into the noise: the record after that point
#: holds less excess energy (above the noise) than this fraction of the record's noise energy
TAIL_FRACTION = 0.05
#: ... plus a margin of this fraction of the response's length, and at least WINDOW_MIN_S
WINDOW_MARGIN = 0.25
WINDOW_MIN_S = 0.04
#: the largest residual a sample may have, in multiples of the record's largest value: beyond it
#: the model is unstable
UNSTABLE_RESIDUAL = 1e3
#: a search value this close to a bound (in natural steps, _scale, or relative beyond one) is the
#: bound: scipy's trf starts 1e-10 inside (make_strictly_feasible), its differences step 1e-4
AT_BOUND = 1e-8


def fit_windows(exps: Sequence[PreparedExperiment], stride: int = 1) -> list[PreparedExperiment]:
    """Each experiment cut where its response has died away into the noise (a hammer response
    decays within tens of milliseconds of records that last far longer), and without its samples
    at rest before the hit (PreparedExperiment.resting_head, cut at a multiple of ``stride``, the
    fits' residual's): fits and screening see the same information for a fraction of the cost.
    The sum of squares of the rest is added back where an error is reported; the rows at rest
    count in the checks' variance estimates as they did in the fits' residual (Problem.at_rest)."""
    out = []
    for e in exps:
        power = np.sum(e.measured**2, axis=1)
        var = float(np.sum(e.noise_var))
        n = len(power)
        tail = np.cumsum(power[::-1])[::-1] - (n - np.arange(n)) * var
        above = np.flatnonzero(tail > TAIL_FRACTION * n * var)
        last = int(above[-1]) if above.size else e.trigger
        end = last + max(WINDOW_MARGIN * max(last - e.trigger, 0), WINDOW_MIN_S * e.fs)
        out.append(e.resting_head(int(math.ceil(end)), stride))
    return out


def records_band(exps: Sequence[PreparedExperiment]) -> tuple[float, float]:
    """The records' Nyquist frequency and their widest frequency line (Hz)."""
    return min(e.fs for e in exps) / 2, max(e.fs / e.n_samples for e in exps)


def _channel_noise(exps: Sequence[PreparedExperiment]) -> dict[str, np.ndarray]:
    """Per experiment, each channel's noise variance while the signal moves (active_var): at least
    its quantisation's step^2/12, so a near-noiseless channel's weight is capped by its converter;
    nan where neither the noise nor the step is known (or both are zero)."""
    out = {}
    for e in exps:
        lsb = np.zeros(len(e.sensors)) if e.lsb is None else np.asarray(e.lsb, float)
        with np.errstate(invalid="ignore"):
            v = active_var(np.asarray(e.noise_var, float), np.nan_to_num(lsb, nan=0.0))
        out[e.name] = np.where(np.isfinite(v) & (v > 0), v, np.nan)
    return out


def channel_weights(exps: Sequence[PreparedExperiment]) -> dict[str, np.ndarray]:
    """Per experiment, each channel's weight in the fits' residual: the inverse of its noise's
    standard deviation (white noise and rounding while the signal moves; the rounding's step^2/12
    caps the weight), scaled so that noise keeps its pooled energy (the noise scale and the fits'
    stops stay as they are). The fit is then the maximum-likelihood one for independent channel
    noise. Unweighted, in physical units, channels of a small sensitivity (loud noise) outweigh a
    quiet, precise one: a cabinet's 1000 mV/g channel was left at 4.7x its noise in one band by a
    right added mass fitted to its 100 mV/g neighbours. A channel without a noise estimate weighs 1,
    as if its noise were the others' mean (weight_notes says which)."""
    var = _channel_noise(exps)
    pooled = np.concatenate(list(var.values())) if var else np.zeros(0)
    known = pooled[np.isfinite(pooled)]
    if known.size == 0:
        return {e.name: np.ones(len(e.sensors)) for e in exps}
    ref = float(np.mean(known))
    return {name: np.where(np.isfinite(v), np.sqrt(ref / v), 1.0) for name, v in var.items()}


def weight_notes(exps: Sequence[PreparedExperiment]) -> list[str]:
    """A note per experiment whose channels' noise is unknown (channel_weights weighs them 1)."""
    out = []
    for e in exps:
        unknown = [s.name for s, v in zip(e.sensors, _channel_noise([e])[e.name]) if not np.isfinite(v)]
        if unknown:
            out.append(f"experiment {e.name!r}: no noise estimate for channel(s) {', '.join(unknown)} (neither a "
                       "noise level nor a converter step): the fits weigh them as if their noise were the other "
                       "channels' mean")
    return out


#: records longer than this many periods of the model's slowest mode, where HEADS_S hold less than
#: HEAD_PERIODS of it, are reached through more heads, each HEAD_GROWTH times the one before, up to
#: half the longest record: from a head of a fifth of a tall cabinet's 5.4 Hz rocking period
#: straight to its 6 s of ringing (32 periods), the linearised steps of a one-foot-softer fit went
#: astray (its error 16.5 at the nominal model, 13.4 after screening, 0.13 at the truth). The
#: calibration's rigs (3-6 periods) and the thesis rig (4 periods of its slowest mode in 0.04 s)
#: keep the two heads. A mode damped out within LONG_RECORD_PERIODS periods (to RINGING_DECAY of
#: its amplitude) does not make a record long (ringing_mode_hz): the LADISK beam's bounce on its
#: foam blocks (16 Hz, 20 % damping: 5.5 periods) took its 0.01 s head, and its shear and rotary
#: inertia (+2.3 % at 3.7 kHz) was not found from a first head of 30 ms (error 0.7644 -> 0.7636
#: instead of 0.4850)
#: Where the first head holds more than HEAD_PERIODS periods of the lowest mode of all (a stiff
#: structure), shorter heads come first, from half its period: a 2 kg bracket on stiff pads (306 Hz)
#: with 1.5 kg added screened at mass scale 1.15 on its 0.01 s head (3 periods, the truth 1.75, the
#: residual a cycle out of phase) and was not named; from 1.6 ms it reached 1.66. A structure on soft
#: supports keeps its heads whatever rings above them (the LADISK beam's 695 Hz bending over its 16 Hz
#: bounce on foam; the thesis rig's 97-228 Hz, 15 % damped, with a 520 Hz plate mode fitted in)
LONG_RECORD_PERIODS = 8.0
HEAD_PERIODS = 2.0
HEAD_GROWTH = 4.0
#: the shortest head, in samples: a structure ringing near the Nyquist frequency gets no heads of a
#: few samples, which hold the hit's first rise alone
HEAD_SAMPLES = 16
RINGING_DECAY = 1e-3


def head_times(exps: Sequence[PreparedExperiment], slowest_hz: float | None = None,
               lowest_hz: float | None = None) -> list[float]:
    """The heads' lengths (s after the hit): HEADS_S, and more for records long in periods of the
    slowest ringing mode (``slowest_hz``; LONG_RECORD_PERIODS), or shorter ones first where
    HEADS_S[0] holds more than HEAD_PERIODS periods of the lowest mode of all (``lowest_hz``: a
    stiff structure)."""
    times = list(HEADS_S)
    if lowest_hz and lowest_hz * times[0] > HEAD_PERIODS:
        # a stiff structure: from half a period of its lowest mode, where a frequency error of a
        # quarter still leaves the residual linear in it, and never from fewer than HEAD_SAMPLES
        short = [max(0.5 / lowest_hz, max((HEAD_SAMPLES / e.fs for e in exps), default=0.0))]
        if short[0] * HEAD_GROWTH > times[0]:  # a head not much shorter than the first adds nothing
            return times
        while short[-1] * HEAD_GROWTH < times[0]:
            short.append(short[-1] * HEAD_GROWTH)
        return short + times
    if slowest_hz and slowest_hz > 0 and slowest_hz * times[-1] < HEAD_PERIODS and exps:
        longest = max((e.n_samples - e.trigger) / e.fs for e in exps)
        if slowest_hz * longest > LONG_RECORD_PERIODS:
            # from half a period of the slowest mode: shorter heads barely see it move
            times = [0.5 / slowest_hz]
            while times[-1] * HEAD_GROWTH < longest / 2:
                times.append(times[-1] * HEAD_GROWTH)
    return times


def slowest_mode_hz(problem: Problem) -> float | None:
    """The lowest non-zero natural frequency of the problem's base model (Hz), None without one."""
    f = np.asarray(problem.base.shared.modes().frequency_hz, float)
    f = f[f > 0]
    return float(f.min()) if f.size else None


def ringing_mode_hz(problem: Problem) -> float | None:
    """The lowest non-zero natural frequency of the problem's base model whose mode rings for more
    than LONG_RECORD_PERIODS periods before it decays to RINGING_DECAY of its amplitude (Hz; None
    without one): the mode head_times reads a record's length in."""
    modes = problem.base.shared.modes()
    f, zeta = np.asarray(modes.frequency_hz, float), np.asarray(modes.damping_ratio, float)
    with np.errstate(divide="ignore"):
        periods = np.where(zeta > 0, -np.log(RINGING_DECAY) / (2 * np.pi * zeta), np.inf)
    f = f[(f > 0) & ~(periods <= LONG_RECORD_PERIODS)]
    return float(f.min()) if f.size else None


def heads(exps: Sequence[PreparedExperiment], stride: int = 1, slowest_hz: float | None = None,
          lowest_hz: float | None = None) -> list[list[PreparedExperiment]]:
    """The experiments cut to each head_times after their hit, without their samples at rest before
    it (PreparedExperiment.resting_head: cut at a multiple of ``stride``, so a residual taken
    every ``stride`` samples keeps the whole head's samples), then whole."""
    stages = [[e.resting_head(e.trigger + int(round(t * e.fs)), stride) for e in exps]
              for t in head_times(exps, slowest_hz, lowest_hz)]
    return stages + [list(exps)]


# ---------------------------------------------------------------------------------------------
# the fitting problem of one candidate


@dataclass
class _Free:
    """One free scalar of a fit: an effect parameter, shared or of one experiment."""

    param: Any  # odsuite.contracts.effects.Parameter
    experiment: str | None
    scale: float

    @property
    def label(self) -> str:
        return self.param.name if self.experiment is None else f"{self.experiment}/{self.param.name}"

    def to_value(self, u: float) -> float:
        lo, hi = self.bounds
        # scipy's trf keeps its iterates a hair inside the bounds: there, the value is the bound
        # (a resonance period of 0 is "no resonance", not one at 1e15 Hz)
        if u - lo <= AT_BOUND * max(1.0, abs(lo)):
            return float(self.param.lower)
        if hi - u <= AT_BOUND * max(1.0, abs(hi)):
            return float(self.param.upper)
        # np.clip's numbers (a NaN stays NaN) without its dispatch: every evaluation maps each value
        return float(min(max(self.param.nominal + u * self.scale, self.param.lower), self.param.upper))

    @property
    def bounds(self) -> tuple[float, float]:
        p = self.param
        return (p.lower - p.nominal) / self.scale, (p.upper - p.nominal) / self.scale


def _prior_share(f: _Free) -> float:
    """The prior per search step squared, as a fraction of the prior per tenth of the range
    squared. Per step it would pull hardest on the parameters whose step is smallest against the
    values they take: a high-pass corner (step 0.25 Hz, nominal 0: none) found at 20 Hz paid 1.2x
    the noise floor's energy, which pulled it to 17.8 Hz and split it over two equal corners."""
    span = f.param.upper - f.param.lower
    tenth = span / 10.0 if np.isfinite(span) and span > 0 else f.scale / 0.05
    return (f.scale / tenth) ** 2


def _scale(p) -> float:
    """A natural step for a parameter: 5 % of its size or of a tenth of its range."""
    span = p.upper - p.lower
    size = max(abs(p.nominal), span / 10.0) if np.isfinite(span) else max(abs(p.nominal), 1.0)
    return 0.05 * min(size, span) if span > 0 else 1.0


#: Jacobians with at least this many structure-changing columns linearise the structure's
#: response (Problem._linearised): below it, the modes' signals cost about what the columns do
LINEARISED_FROM = 3
#: predictions a problem keeps (the latest), for the points it is asked about again
PREDICTIONS_KEPT = 3


#: the bytes of an added mode's responses to unit participations a problem and the problems derived
#: from it keep (each experiment's, per frequency and damping): a Jacobian's amplitude columns and
#: its point's share one, and each choice of the mode's body sweeps the same frequencies (a count
#: of 32 let one body's sweep push out what the next asked again for)
UNITS_BYTES_KEPT = 32e6


#: the records' peaks (the unstable residual's cap), by the arrays' identities (kept alive here)
_PEAKS: dict[int, tuple[np.ndarray, float]] = {}


def _peak(measured: np.ndarray) -> float:
    """max |measured|, kept per record: a residual is taken thousands of times per diagnosis."""
    got = _PEAKS.get(id(measured))
    if got is None or got[0] is not measured:
        if len(_PEAKS) >= 64:
            _PEAKS.clear()
        # the larger of the extremes: max |x| without an array of magnitudes (nan as nan)
        got = _PEAKS[id(measured)] = (measured, float(np.maximum(measured.max(), -measured.min())))
    return got[1]


class Problem:
    """Residuals of one candidate effect on top of the current revision, over all experiments."""

    def __init__(self, base: RevisionModel, effect, exps: Sequence[PreparedExperiment],
                 fixed: Mapping[str, float] | None = None, prior: float = 0.0, stride: int = 1,
                 full: Sequence[PreparedExperiment] | None = None, noise_scale: float = 0.0,
                 weights: Mapping[str, np.ndarray] | None = None) -> None:
        self.base = base
        # noise energy per independent sample (checks.noise_scale): gains far below it change no
        # test, so the search stops there (0: scipy's relative tolerances alone)
        self.noise_scale = noise_scale
        # ``exps`` are what the fit sees (usually fit windows); ``full`` the whole records they
        # were cut from, for reported errors
        self.full = list(full) if full is not None else list(exps)
        # fits see every stride-th sample: the signals are band-limited far below Nyquist, so the
        # sum of squares keeps its shape while the Jacobian shrinks
        self.stride = stride
        # a weak pull towards the nominal values (sum of squares per tenth of a parameter's range
        # squared, ``pull`` per search step squared): it decides directions the data cannot see and
        # keeps damped steps well posed; negligible elsewhere
        self.prior = prior
        self.effect = effect
        self.exps = list(exps)
        # the residual whitened channel by channel (channel_weights); sums reported as the
        # contract's error (sse) are not; ``weights``: those of the same records, where at hand
        self.weights = channel_weights(self.full) if weights is None else weights
        # a mode's frequency within what the records resolve (Parameter.within_records); its
        # steps and prior as declared, so a search that stays inside moves as before
        declared = {p.name: p for p in effect.parameters(base.shared)}
        nyquist, line = records_band(self.full)
        self.params = params = [p.within_records(nyquist, line) for p in declared.values()]
        self.discrete = [p for p in params if p.choices is not None]
        self.fixed = dict(fixed or {})  # discrete choices and parameters held at a value
        # parameters the effect solves by linear least squares at every evaluation (variable
        # projection): the search runs over the others only
        linear = getattr(effect, "linear_parameters", None)
        self.linear = [n for n in (linear(base.shared) if linear else []) if n not in self.fixed]
        self._base_predictions: dict[tuple[str, int], np.ndarray] = {}
        self._projection: tuple[Any, Any] | None = None  # (key, result) of the last projection
        self._predictions: list[tuple[Any, list[np.ndarray]]] = []  # (key, predictions), newest first
        self._models: tuple[bytes | None, dict] = (None, {})  # (point, models) last predicted
        self._batches: dict[tuple, tuple] = {}  # _sensor_batches per set of records
        # an added mode's responses to unit participations (_with_added_mode), oldest first
        self._units: dict[tuple, np.ndarray] = {}
        # _climb_grid's ranking of a grid on the residual without the effect, per grid and records
        self._gains: dict[tuple, np.ndarray] = {}
        self._at_rest: dict[tuple[str, int], np.ndarray] = {}
        self.free: list[_Free] = []
        for p in params:
            if p.choices is not None or p.name in self.fixed or p.name in self.linear:
                continue
            if p.scope == "per_experiment":
                self.free += [_Free(p, e.name, _scale(declared[p.name])) for e in self.exps]
            else:
                self.free.append(_Free(p, None, _scale(declared[p.name])))
        self.pull = np.array([prior * _prior_share(replace(f, param=declared[f.param.name])) for f in self.free])
        self.evaluations = 0

    # values ------------------------------------------------------------------------------------
    def _search_values(self, u: np.ndarray) -> tuple[dict[str, float], dict[str, dict[str, float]]]:
        shared = dict(self.fixed)
        per: dict[str, dict[str, float]] = {}
        for f, x in zip(self.free, u):
            if f.experiment is None:
                shared[f.param.name] = f.to_value(x)
            else:
                per.setdefault(f.experiment, {})[f.param.name] = f.to_value(x)
        return shared, per

    def searched_values(self, u: np.ndarray, projected: Mapping[str, float]) -> dict[str, float]:
        """The shared values at search point ``u``, the projected ones held at ``projected`` (a
        fit's): what a step along a direction the data cannot see changes (physical.mark_undetermined)."""
        return {**projected, **self._search_values(u)[0]}

    def values(self, u: np.ndarray, exps: Sequence[PreparedExperiment] | None = None
               ) -> tuple[dict[str, float], dict[str, dict[str, float]]]:
        """Shared and per-experiment values at ``u``, the projected ones fitted on ``exps``."""
        shared, per = self._search_values(u)
        if self.linear:
            lin_shared, lin_per, _ = self.project(u, exps)
            shared.update(lin_shared)
            for name, v in lin_per.items():
                per.setdefault(name, {}).update(v)
        return shared, per

    def base_prediction(self, e: PreparedExperiment) -> np.ndarray:
        """The prediction without this effect (cached per experiment and the samples it covers: span)."""
        key = e.span
        if key not in self._base_predictions:
            self._base_predictions[key] = predict_kept(self.base.for_experiment(e.name), e)
        return self._base_predictions[key]

    def project(self, u: np.ndarray, exps: Sequence[PreparedExperiment] | None = None,
                weights: Sequence[np.ndarray] | None = None) -> tuple[dict, dict, list[np.ndarray]]:
        """The effect's projected parameters at ``u`` fitted on ``exps`` (rows weighted by
        ``weights``), and each experiment's change of prediction."""
        exps = list(exps or self.exps)
        key = (u.tobytes(), tuple(e.span for e in exps),
               None if weights is None else tuple(w.tobytes() for w in weights))
        if self._projection is not None and self._projection[0] == key:
            return self._projection[1]
        self.evaluations += 1
        shared, _ = self._search_values(u)
        models = {e.name: self.base.for_experiment(e.name) for e in exps}
        base = [self.base_prediction(e) for e in exps]
        if getattr(self.effect, "projects_added_mode", False):  # its mode's unit responses kept here
            out = self.effect.project(models, shared, exps, base, weights, unit_response=self.unit_response)
        else:
            out = self.effect.project(models, shared, exps, base, weights)
        self._projection = (key, out)
        return out

    def revision(self, u: np.ndarray, exps: Sequence[PreparedExperiment] | None = None) -> RevisionModel:
        """The base with the effect applied at ``u``: what a second effect is fitted on top of."""
        shared, per = self.values(u, exps)
        has_shared = any(f.experiment is None for f in self.free) or self.fixed or not self.free or self.linear
        model = self.effect.apply(self.base.shared, shared) if has_shared else self.base.shared
        own = [(self.effect, {name: {**shared, **v} for name, v in per.items()})] if per else []
        return RevisionModel(model, list(self.base.per_experiment) + own)

    def models(self, u: np.ndarray, exps: Sequence[PreparedExperiment] | None = None) -> dict[str, Any]:
        rm = self.revision(u, exps)
        return {e.name: rm.for_experiment(e.name) for e in self.exps}

    def predictions(self, u: np.ndarray, exps: Sequence[PreparedExperiment] | None = None,
                    keep: bool = True) -> list[np.ndarray]:
        exps = list(exps or self.exps)
        if self.linear:  # the projection's change of prediction is the effect's whole change
            _, _, deltas = self.project(u, exps)
            return [self.base_prediction(e) + d for e, d in zip(exps, deltas)]
        # a fit asks again for predictions it has made (its sums of squares, the tail, validation,
        # the resolved test, the verdict's signature): the last few are kept
        kept = self.kept(u, exps)
        if kept is not None:
            return kept
        self.evaluations += 1
        out = self._with_added_mode(u, exps)
        if out is not None:
            for p in out:
                p.flags.writeable = False
            if keep:
                self.keep(u, out, exps)
            return list(out)
        models = self.models(u)
        self._models = (u.tobytes(), models)
        simulate_together(models, exps)
        out = [predict_sharing(models[e.name], e) for e in exps]
        for p in out:
            p.flags.writeable = False
        if keep:
            self.keep(u, out, exps)
        return list(out)

    def _with_added_mode(self, u: np.ndarray, exps: Sequence[PreparedExperiment]) -> list[np.ndarray] | None:
        """The predictions at ``u`` where the effect adds one uncoupled flexible mode to the base's
        linear structure and changes nothing else (its ``added_mode``): the base's predictions plus
        the mode's response alone (prediction.flexible_mode_change), the response to unit
        participations kept per frequency and damping (a step of an amplitude simulates nothing).
        None where that does not hold: the whole model is simulated."""
        got = self._added_mode(u, exps)
        if got is None:
            return None
        models, mode = got
        if mode is None:
            return [self.base_prediction(e).copy() for e in exps]
        out = []
        for e in exps:
            def unit(e=e) -> np.ndarray:
                return self.unit_response(e, mode.frequency_hz, mode.damping_ratio)

            out.append(self.base_prediction(e) + flexible_mode_change(models[e.name], e, mode, unit))
        return out

    def unit_response(self, e: PreparedExperiment, frequency_hz: float, damping_ratio: float) -> np.ndarray:
        """flexible_mode_unit on the base model of ``e``, kept per experiment, length, frequency
        and damping (UNITS_BYTES_KEPT, shared by the derived problems: the same base and records). It
        does not depend on the mode's body or participations: a search over a mode's body or its
        amplitudes asks again for the same frequencies."""
        key = (*e.span, frequency_hz, damping_ratio)
        kept = self._units.get(key)
        if kept is None:
            held = sum(a.nbytes for a in self._units.values())
            while self._units and held > UNITS_BYTES_KEPT:
                held -= self._units.pop(next(iter(self._units))).nbytes
            kept = self._units[key] = flexible_mode_unit(self.base.for_experiment(e.name), e, frequency_hz,
                                                         damping_ratio)
            kept.flags.writeable = False
        return kept

    def _added_mode(self, u: np.ndarray, exps: Sequence[PreparedExperiment]) -> tuple[dict, Any] | None:
        """Each experiment's base model and the uncoupled flexible mode the effect adds at ``u``
        (None: it adds none), where that is all it changes on a linear structure (``added_mode``);
        None elsewhere."""
        added = getattr(self.effect, "added_mode", None)
        if added is None or self.linear or any(f.experiment is not None for f in self.free):
            return None
        models = {e.name: self.base.for_experiment(e.name) for e in exps}
        if any(not m.structure.is_linear for m in models.values()):
            return None
        shared, _ = self._search_values(u)
        mode = added(self.base.shared, self.effect.values(self.base.shared, shared))
        if mode is not None and (mode.at_springs or mode.parts):
            return None
        return models, mode

    def kept(self, u: np.ndarray, exps: Sequence[PreparedExperiment] | None = None) -> list[np.ndarray] | None:
        """``predictions(u, exps)`` where they are kept, without evaluating; None where not."""
        key = (u.tobytes(), tuple(e.span for e in (exps or self.exps)))
        got = next((p for k, p in self._predictions if k == key), None)
        return None if got is None else list(got)

    def keep(self, u: np.ndarray, predictions: Sequence[np.ndarray],
             exps: Sequence[PreparedExperiment] | None = None) -> None:
        """Keep ``predictions`` (``predictions(u, exps)``'s) first among the kept ones: the last to go."""
        if self.linear:  # the projection keeps its own
            return
        key = (u.tobytes(), tuple(e.span for e in (exps or self.exps)))
        rest = [(k, p) for k, p in self._predictions if k != key]
        self._predictions = [(key, list(predictions))] + rest[:PREDICTIONS_KEPT - 1]

    # residuals ---------------------------------------------------------------------------------
    def residual(self, u: np.ndarray, exps: Sequence[PreparedExperiment] | None = None,
                 columns: Sequence[int] | None = None, stride: int | None = None, keep: bool = True,
                 weighted: bool = True) -> np.ndarray:
        exps = exps or self.exps
        with np.errstate(over="ignore", invalid="ignore"):
            try:
                preds = self.predictions(u, exps, keep)
            except (DivergedError, NonPhysicalError):  # trial values that blow the response up or
                # that no physical body has (an inertia not positive definite): as bad as can be
                preds = [np.full(e.measured.shape, np.inf) for e in exps]
        return self._residual_of(preds, exps, columns, self.stride if stride is None else stride,
                                 weighted=weighted)

    def _residual_of(self, preds: Sequence[np.ndarray], exps: Sequence[PreparedExperiment],
                     columns: Sequence[int] | None = None, k: int = 1, strided: bool = False,
                     weighted: bool = True) -> np.ndarray:
        """The residual of predictions of every sample (or of every k-th, ``strided``), each
        channel times its weight (``weighted``; channel_weights)."""
        parts = []
        if columns is None:  # each experiment's part written in place into the whole
            out = np.empty(sum(len(range(0, e.n_samples, k)) * e.measured.shape[1] for e in exps))
            at = 0
        for e, p in zip(exps, preds):
            measured = e.measured[::k]
            into = None
            if columns is None:
                into = out[at:at + measured.size].reshape(measured.shape)
                at += measured.size
            r = np.subtract(measured, p if strided else p[::k], out=into)
            cap = UNSTABLE_RESIDUAL * (_peak(e.measured) + 1e-300)
            # the largest magnitude from the extremes, without an array of magnitudes; nan fails too
            if not max(r.max(initial=0.0), -r.min(initial=0.0)) <= cap:
                # parameters that make the model unstable (its response grows without bound): a
                # residual far worse than predicting nothing keeps the fit away, where inf or nan
                # (or their finite differences) would stop it
                r[...] = np.clip(np.nan_to_num(r, nan=cap, posinf=cap, neginf=-cap), -cap, cap)
            if weighted:
                np.multiply(r, self.weights[e.name], out=r)
            if columns is not None:
                parts.append(r[:, columns].ravel())
        return out if columns is None else np.concatenate(parts)

    def at_rest(self, e: PreparedExperiment) -> np.ndarray:
        """The residual's rows (strided samples x channels, weighted) of ``e``'s record before its
        window's first sample (fit_windows: the samples at rest before the hit). The model is at
        rest there, so they are the measured noise at every parameter value: no fit simulates
        them, and the checks that read a variance off the residual (checks._local_fit, the
        sandwich of ``uncertainties``) count them as they counted them in a window that kept
        them. Empty where the window starts where the problem's whole record does."""
        got = self._at_rest.get((e.name, e.first))
        if got is None:
            got = self._at_rest[e.name, e.first] = self._rows_cut(e)[::self.stride] * self.weights[e.name]
        return got

    def _rows_cut(self, e: PreparedExperiment) -> np.ndarray:
        """The measured samples of ``e``'s whole record before its window (``full`` may be the
        windows themselves: none), at a multiple of the stride from the record's start."""
        whole = next((f for f in self.full if f.name == e.name), None)
        cut = e.first - whole.first if whole is not None else 0
        if cut > 0 and cut % self.stride:
            raise ValueError(f"record {e.name!r}: its window starts {cut} samples in, not at a multiple of the "
                             f"fit's stride {self.stride} (fit_windows(exps, stride))")
        return whole.measured[:cut] if cut > 0 else e.measured[:0]

    def noise_rows(self, e: PreparedExperiment) -> list[np.ndarray]:
        """The measured noise alone of ``e``'s whole record, strided and weighted as the fit's
        residual: its quiet stretches before the hit and after the response has died away
        (noise_colour.quiet_stretches), each a block of samples x channels. What the noise makes
        of an estimate is read there, where no misfit of the model adds to it (checks.linearity).
        Empty where the record tells none."""
        whole = next((f for f in self.full if f.name == e.name), None)
        if whole is None:
            return []
        return [whole.measured[a:b:self.stride] * self.weights[e.name]
                for a, b in quiet_stretches(whole) if len(range(a, b, self.stride)) >= 4]

    def rest_cost(self) -> float:
        """The rows at rest's part of the fits' cost (half their strided, weighted sum of squares):
        the constant a window that kept them adds to every cost. Tests on a ratio of two costs
        read it (diagnose._out_of_reach, _Stops' target), as they did on such windows."""
        return 0.5 * sum(float(np.sum(self.at_rest(e) ** 2)) for e in self.exps)

    def rest_sse(self) -> float:
        """The rows at rest's part of ``sse`` (every sample, unweighted), likewise."""
        return sum(float(np.sum(self._rows_cut(e) ** 2)) for e in self.exps)

    def row_weights(self, exps: Sequence[PreparedExperiment] | None = None, k: int = 1) -> np.ndarray:
        """Each row's channel weight in ``residual(..., stride=k)`` (channel_weights)."""
        return np.concatenate([np.tile(self.weights[e.name], len(range(0, e.n_samples, k)))
                               for e in (exps or self.exps)])

    def sse(self, u: np.ndarray, exps: Sequence[PreparedExperiment] | None = None) -> float:
        """Sum of squares over every sample (the contract's error: unweighted), not only the strided ones."""
        r = self.residual(u, exps, stride=1, weighted=False)
        return float(r @ r)

    def tail_sse(self, u: np.ndarray) -> float:
        """Sum of squares of the records outside the fit windows (nearly all noise)."""
        if all(f is e for f, e in zip(self.full, self.exps)):
            return 0.0
        return self.sse(u, self.full) - self.sse(u)

    def derived(self, fixed: Mapping[str, float]) -> Problem:
        """The same problem with other parameters fixed."""
        out = Problem(self.base, self.effect, self.exps, fixed, self.prior, self.stride, self.full,
                      self.noise_scale, self.weights)
        out._base_predictions = self._base_predictions  # the same base model: share its predictions
        out._units = self._units
        out._gains = self._gains
        return out

    def jacobian(self, u: np.ndarray, r0: np.ndarray, exps: Sequence[PreparedExperiment] | None = None,
                 step: float = 1.0, tangent: bool = False) -> np.ndarray:
        """Forward differences of the residual on ``exps`` (``step`` natural steps, backwards at an
        upper bound). Parameters that change one sensor's prediction alone (``Parameter.sensor``)
        are moved together with those of other sensors, each column taken from its own sensor's
        rows: the same numbers in fewer evaluations; so are parameters of one experiment each
        (scope ``per_experiment``) where no column is linearised. With ``tangent`` (screening), the derivative
        where it is cheaper than the difference: structure-changing columns linearised over
        DIFF_STEP natural steps (Problem._linearised), steps that add cubic springs to a linear
        structure to first order in them (Problem._cubic_tangent)."""
        steps = self._steps(u, step)
        batches, rows_of = self._sensor_batches(exps or self.exps)
        by_experiment = False  # a batched column's rows: its sensor's, or its experiment's
        added = self._added_mode(u, exps or self.exps) if tangent and rows_of is None else None
        if added is not None and added[1] is not None:
            # an added uncoupled mode's columns differenced over DIFF_STEP on its response alone
            # (_with_added_mode: two 1-degree-of-freedom simulations for the frequency and the
            # damping, the amplitudes' none), where the linearisation simulates the whole structure
            steps = steps * DIFF_STEP
        elif rows_of is None:
            # a tangent's columns are derivatives: taken over DIFF_STEP, where the poles move
            # little enough for the linearisation (over a natural step they move as far as their
            # gaps, and each column was simulated)
            J = self._linearised(u, steps * DIFF_STEP if tangent else steps, r0, exps or self.exps)
            if J is not None:
                return J
        linearised = None
        if tangent and rows_of is None:
            linearised = self._cubic_tangent(u, steps, r0, exps or self.exps)
            if linearised is None and self._own_cubic_at(u):
                # the effect's own cubic springs at ``u``: a derivative, over DIFF_STEP. Over a
                # natural step a hardening grows many-fold (thesis: 0.1-1 by 5), and the secant
                # sent every damped step on the longer heads uphill (8 of 8 on the thesis bench)
                steps = steps * DIFF_STEP
        if linearised is None and rows_of is None:
            own = self._experiment_batches(exps or self.exps)
            if own is not None:
                (batches, rows_of), by_experiment = own, True
        elif rows_of is not None:  # a sensor's rows written by strided slices, not index arrays
            rows_of = self._sensor_slices(exps or self.exps)
        # written by columns: whole ones into Fortran order (then copied), a sensor's rows alone
        # (a few per cent of each column) straight into C order, 4x faster than that copy
        J = np.zeros((r0.size, len(self.free)), order="F" if rows_of is None else "C")
        for batch in batches:
            batch = [i for i in batch if steps[i]]
            if not batch:
                continue
            du = np.zeros_like(u)
            du[batch] = steps[batch]
            if linearised is not None:
                diff = linearised[batch[0]] - r0
            else:  # a difference's point is not asked again
                diff = self.residual(u + du, exps, keep=False) - r0
            if len(batch) == 1:
                J[:, batch[0]] = -diff / steps[batch[0]]
                continue
            for i in batch:
                f = self.free[i]
                if by_experiment:
                    rows = rows_of[f.experiment]
                    J[rows, i] = -diff[rows] / steps[i]
                    continue
                for rows in rows_of[f.param.sensor]:
                    J[rows, i] = -diff[rows] / steps[i]
        return np.ascontiguousarray(J)

    def _steps(self, u: np.ndarray, step: float) -> np.ndarray:
        """Each free parameter's difference step at ``u`` (``step`` natural steps, backwards at an
        upper bound, half the room left where neither fits)."""
        steps = np.zeros(len(self.free))
        for i, f in enumerate(self.free):
            lo, hi = f.bounds
            h = step if u[i] + step <= hi else -step
            if not lo <= u[i] + h <= hi:
                h = 0.5 * (hi - u[i]) if hi - u[i] > u[i] - lo else -0.5 * (u[i] - lo)
            steps[i] = h
        return steps

    def tangent(self, u: np.ndarray, r0: np.ndarray, exps: Sequence[PreparedExperiment] | None = None
                ) -> Normal:
        """Screening's Jacobian at ``u`` (``jacobian(u, r0, exps, tangent=True)``) as the normal
        equations its damped steps read. Where every column is a sensor's parameter differenced
        with other sensors' (_sensor_batches), the Jacobian is not formed: each column is zero but
        on its sensor's rows, so J^T J is one small product per sensor and zero between sensors (a
        two-body sensor_position Jacobian on the fit windows: 54 columns of 221436 rows, 96 MB
        written and multiplied for 1.8 MB of values). The same sums of products as J^T J's over
        the whole columns, in another order."""
        exps = list(exps or self.exps)
        batches, rows_of = self._sensor_batches(exps)
        steps = self._steps(u, 1.0)
        moved = [b for b in ([i for i in b if steps[i]] for b in batches) if b]
        if rows_of is None or any(len(b) < 2 for b in moved):  # a whole column: the Jacobian itself
            return Normal.of(self.jacobian(u, r0, exps, tangent=True), r0)
        slices = self._sensor_slices(exps)

        def rows(x: np.ndarray, sensor: str) -> np.ndarray:
            return np.concatenate([x[s] for s in slices[sensor]])

        columns: dict[int, np.ndarray] = {}
        for batch in moved:
            du = np.zeros_like(u)
            du[batch] = steps[batch]
            diff = self.residual(u + du, exps, keep=False) - r0  # a difference's point is not asked again
            for i in batch:
                columns[i] = -rows(diff, self.free[i].param.sensor) / steps[i]
        G, g = np.zeros((len(u), len(u))), np.zeros(len(u))
        by_sensor: dict[str, list[int]] = {}
        for i in columns:
            by_sensor.setdefault(self.free[i].param.sensor, []).append(i)
        for sensor, ii in by_sensor.items():
            V = np.stack([columns[i] for i in ii])
            G[np.ix_(ii, ii)] = V @ V.T
            g[ii] = V @ rows(r0, sensor)
        return Normal(G, g)

    def _linearised(self, u: np.ndarray, steps: np.ndarray, r0: np.ndarray, exps: Sequence[PreparedExperiment]
                    ) -> np.ndarray | None:
        """The Jacobian (as ``jacobian``'s: minus the residual's change over each parameter's step
        from ``u``, whose residual is ``r0``) with the structure's response linearised in its poles
        and residues about ``u``'s (prediction.linearised_changes): one simulation for all, where
        the steps change the structure (a stiffness, a mass), at least LINEARISED_FROM of them and
        every experiment allows it. Each column is the change of the predictions times the
        channel's weight over the step, written straight into the Jacobian's rows: the same
        numbers as differencing residuals of the linearised predictions but for rounding (better:
        no difference of two nearly equal residuals), where no row of them reaches the unstable
        residual's cap (Problem._residual_of), which the bound max |r0| + max |change| rules out.
        Each column counts as an evaluation; None where the steps are best simulated."""
        moved = [i for i in range(len(u)) if steps[i]]
        if self.linear or len(moved) < LINEARISED_FROM:
            return None
        J = np.empty((r0.size, len(moved)))
        try:
            with np.errstate(over="ignore", invalid="ignore"):
                # the models the residual at ``u`` was just predicted with: their structure's
                # response is kept on the experiments
                models0 = self._models[1] if self._models[0] == u.tobytes() else self.models(u)
                # a step that leaves the structure: its own simulation is cheap. Known from the
                # first such step, before the other steps' models are built (a hit's point per
                # experiment: 15 models of 5 experiments each, all of them thrown away)
                points = self._stepped_models(u, steps, moved,
                                              lambda p: any(p[e.name].structure is models0[e.name].structure
                                                            for e in exps))
                if points is None:
                    return None
                at = 0
                for e in exps:
                    n, w = len(range(0, e.n_samples, self.stride)), self.weights[e.name]
                    size = n * len(w)
                    block = J[at:at + size].reshape(n, len(w), len(moved))
                    if linearised_changes(models0[e.name], [p[e.name] for p in points], e, self.stride,
                                          w[:, None] / steps[moved][None, :], block) is None:
                        return None
                    reach = (float(np.max(np.abs(r0[at:at + size].reshape(n, len(w)) / w)))
                             + max(float(block.max()), -float(block.min())) * float(np.max(np.abs(steps[moved])))
                             / float(np.min(w)))
                    if not reach <= UNSTABLE_RESIDUAL * _peak(e.measured):  # nan too: simulated instead
                        return None
                    at += size
        except (DivergedError, NonPhysicalError, np.linalg.LinAlgError):  # simulated column by column instead
            return None
        self.evaluations += len(moved)
        if len(moved) == len(u):
            return J
        out = np.zeros((r0.size, len(u)))
        out[:, moved] = J
        return out

    def _cubic_tangent(self, u: np.ndarray, steps: np.ndarray, r0: np.ndarray, exps: Sequence[PreparedExperiment]
                       ) -> dict[int, np.ndarray] | None:
        """The residual at each point ``u`` + a step of one parameter where ``u``'s structure is
        linear and every step adds cubic springs to it alone (a hardening from zero), to first
        order in their coefficients (prediction.cubic_change_predictions): a linear simulation per
        step instead of a nonlinear one. The steps' real effect is far from linear (a step is a
        hardening of several times the stiffness at a micrometre), so this is the tangent, what a
        Gauss-Newton step assumes, not the secant. Each counts as an evaluation; None elsewhere."""
        moved = [i for i in range(len(u)) if steps[i]]
        if self.linear or not moved:
            return None
        try:
            with np.errstate(over="ignore", invalid="ignore"):
                models0 = self._models[1] if self._models[0] == u.tobytes() else self.models(u)
                if any(not models0[e.name].structure.is_linear for e in exps):
                    return None
                # cubic_change_predictions declines a step whose structure stays linear: known
                # from the first one, before the others' models are built
                points = self._stepped_models(u, steps, moved,
                                              lambda p: any(p[e.name].structure.is_linear for e in exps))
                changes = None if points is None else self._each_experiment(cubic_change_predictions, models0,
                                                                            points, exps)
                if changes is None:
                    return None
        except (DivergedError, NonPhysicalError, np.linalg.LinAlgError):  # simulated column by column instead
            return None
        self.evaluations += len(moved)
        return {i: r0 - np.concatenate([(c[k] * self.weights[e.name]).ravel() for c, e in zip(changes, exps)])
                for k, i in enumerate(moved)}

    def _own_cubic_at(self, u: np.ndarray) -> bool:
        """Whether the structure at ``u`` has cubic springs that the base's has not."""
        if self.linear:
            return False
        models0 = self._models[1] if self._models[0] == u.tobytes() else self.models(u)
        return (any(not m.structure.is_linear for m in models0.values())
                and self.base.shared.structure.is_linear)

    def _stepped_models(self, u: np.ndarray, steps: np.ndarray, moved: Sequence[int],
                        declined: Callable[[dict[str, Any]], bool] | None = None) -> list[dict[str, Any]] | None:
        """The models at ``u`` + a step of each ``moved`` parameter in turn; None as soon as one
        step's models are ``declined``."""
        points = []
        for i in moved:
            du = np.zeros_like(u)
            du[i] = steps[i]
            points.append(self.models(u + du))
            if declined is not None and declined(points[-1]):
                return None
        return points

    def _each_experiment(self, predicted, models0: Mapping[str, Any], points: Sequence[Mapping[str, Any]],
                         exps: Sequence[PreparedExperiment]) -> list | None:
        """``predicted(model at u, models at the steps, experiment, stride)`` on each experiment;
        None where one of them declines."""
        out = []
        for e in exps:
            got = predicted(models0[e.name], [p[e.name] for p in points], e, self.stride)
            if got is None:
                return None
            out.append(got)
        return out

    def _sensor_batches(self, exps: Sequence[PreparedExperiment]
                        ) -> tuple[list[list[int]], dict[str, np.ndarray] | None]:
        """Groups of free parameters that one evaluation can difference (at most one per sensor,
        shared ones of sensors some experiment records: where one leaves a sensor out, as a
        clipped channel, the sensor's parameter changes nothing there), and each sensor's residual
        rows; kept per set of records (screening asks again for every step and start)."""
        key = tuple(e.span for e in exps)
        if key not in self._batches:
            self._batches[key] = self._new_sensor_batches(exps)
        return self._batches[key]

    def recorded(self, e: PreparedExperiment) -> list[str]:
        """The sensor whose motion each of ``e``'s channels records, in column order: its own, or
        the other's where the model's chain exchanged their cables (a channel swap in the revision
        or among the fixed choices): a sensor's parameter changes the channel that records it."""
        key = ("recorded", e.name)
        if key not in self._batches:  # cables are exchanged by the revision or a discrete choice alone
            self._batches[key] = self.effect.apply(self.base.for_experiment(e.name), dict(self.fixed)).chain.swap
        swap = self._batches[key]
        return [swap.get(s.name, s.name) for s in e.sensors]

    def _new_sensor_batches(self, exps: Sequence[PreparedExperiment]
                            ) -> tuple[list[list[int]], dict[str, np.ndarray] | None]:
        if sum(f.param.sensor is not None and f.experiment is None for f in self.free) < 2:
            return [[i] for i in range(len(self.free))], None
        recorded = {name for e in exps for name in self.recorded(e)}
        local = [i for i, f in enumerate(self.free) if f.param.sensor is not None and f.experiment is None
                 and f.param.sensor in recorded]
        if len(local) < 2:
            return [[i] for i in range(len(self.free))], None
        batches = self._groups(local, lambda f: f.param.sensor)
        rows: dict[str, list[np.ndarray]] = {}
        at = 0
        for e in exps:  # a residual is each experiment's (samples, channels), raveled
            names, n = self.recorded(e), len(range(0, e.n_samples, self.stride))
            for name in dict.fromkeys(names):
                cols = np.array([j for j, m in enumerate(names) if m == name])
                rows.setdefault(name, []).append(at + (np.arange(n)[:, None] * len(names) + cols).ravel())
            at += n * len(names)
        return batches, {name: np.concatenate(parts) for name, parts in rows.items()}

    def _sensor_slices(self, exps: Sequence[PreparedExperiment]) -> dict[str, list[slice]]:
        """Each sensor's residual rows (_sensor_batches) as a strided slice per experiment and
        channel: a Jacobian's column of a sensor's parameter is written through them in a third of
        the time that the rows as an index array took (gathered, then scattered)."""
        key = ("slices",) + tuple(e.span for e in exps)
        if key not in self._batches:
            slices: dict[str, list[slice]] = {}
            at = 0
            for e in exps:  # a residual is each experiment's (samples, channels), raveled
                names, n = self.recorded(e), len(range(0, e.n_samples, self.stride))
                for j, name in enumerate(names):
                    slices.setdefault(name, []).append(slice(at + j, at + n * len(names), len(names)))
                at += n * len(names)
            self._batches[key] = slices
        return self._batches[key]

    def _groups(self, members: Sequence[int], owner: Callable[[_Free], Any]) -> list[list[int]]:
        """The free parameters ``members`` in groups of distinct ``owner`` (each into the first
        group without its owner), then every other free parameter alone."""
        groups: list[list[int]] = []
        for i in members:
            slot = next((g for g in groups if all(owner(self.free[j]) != owner(self.free[i]) for j in g)), None)
            if slot is None:
                groups.append([i])
            else:
                slot.append(i)
        return groups + [[i] for i in range(len(self.free)) if i not in members]

    def _experiment_batches(self, exps: Sequence[PreparedExperiment]
                            ) -> tuple[list[list[int]], dict[str, slice]] | None:
        """Groups of free parameters of one experiment each (scope ``per_experiment``: a hit's
        point) that one evaluation can difference, and each experiment's residual rows; None where
        fewer than two such parameters, or where a projection (``linear``) couples the experiments.
        A step of one experiment's parameter changes that experiment's model alone, so its column
        is zero in the others' rows: a thesis impact_location Jacobian took 15 evaluations of 5
        records each for 3 records' worth of change."""
        key = ("experiments",) + tuple(e.span for e in exps)
        if key not in self._batches:
            names = [e.name for e in exps]
            own = [i for i, f in enumerate(self.free) if f.experiment in names and f.param.sensor is None]
            if self.linear or len(own) < 2:
                self._batches[key] = None
            else:
                batches = self._groups(own, lambda f: f.experiment)
                rows, at = {}, 0
                for e in exps:  # a residual is each experiment's (samples, channels), raveled
                    n = len(range(0, e.n_samples, self.stride)) * len(e.sensors)
                    rows[e.name] = slice(at, at + n)
                    at += n
                self._batches[key] = (batches, rows)
        return self._batches[key]

    def zero(self) -> np.ndarray:
        return np.zeros(len(self.free))

    def lower_upper(self) -> tuple[np.ndarray, np.ndarray]:
        b = np.array([f.bounds for f in self.free]).reshape(-1, 2)
        return b[:, 0], b[:, 1]


#: Levenberg-Marquardt damping tried in turn (relative to the Jacobian's diagonal) until a step
#: lowers the error: parameters of one effect may be redundant (a global scale spread over axes
#: and springs), which a plain Gauss-Newton step would turn into a leap to the bounds
LM_DAMPING = (1e-3, 1e-1, 1.0, 10.0)

#: screening repeats its damped step on the first head while a step leaves less than this share of
#: the head's sum, at most HEAD_STEPS more times
HEAD_STEP_GAIN = 0.5
HEAD_STEPS = 3


class Normal:
    """A Jacobian's normal equations at a residual r: J^T J and J^T r (``G``, ``g``), and J
    where it was formed (then its products are taken where first asked for)."""

    def __init__(self, G: np.ndarray | None, g: np.ndarray | None, J: np.ndarray | None = None,
                 r: np.ndarray | None = None) -> None:
        self._G, self._g, self.J, self._r = G, g, J, r

    @classmethod
    def of(cls, J: np.ndarray, r: np.ndarray) -> Normal:
        return cls(None, None, J, r)

    @property
    def G(self) -> np.ndarray:
        if self._G is None:
            self._G = self.J.T @ self.J
        return self._G

    @property
    def g(self) -> np.ndarray:
        if self._g is None:
            self._g = self.J.T @ self._r
        return self._g

    def tiny(self, r: np.ndarray) -> np.ndarray:
        """_tiny of the Jacobian's columns (from J where formed, else from J^T J)."""
        return _tiny(self.J, r, None if self.J is not None else self.G)


def _lm_step(problem: Problem, J: np.ndarray | Normal, r: np.ndarray, u: np.ndarray, exps) -> np.ndarray:
    """The first damped Gauss-Newton step (r = measured - model, J = d model / d u, or its normal
    equations at r) that lowers the error on ``exps``, clipped to the bounds; ``u`` when none does."""
    lo, hi = problem.lower_upper()
    # parameters the residual cannot see here stay put (a mode's frequency while its amplitudes are
    # zero): the linearisation says nothing about them
    # one Gram matrix and gradient for all three (a sensor's candidate on the whole windows: 54
    # columns of 212,000 rows, whose copy by columns alone took four times the product's time)
    normal = J if isinstance(J, Normal) else Normal.of(J, r)
    G, Jr = normal.G, normal.g
    act = ~_tiny(normal.J, r, G) & ~_repeated(normal.J, G)
    if not act.any():
        return u
    ua = u[act]
    pull = problem.pull[act]
    JtJ = G[np.ix_(act, act)] + np.diag(pull)
    g = Jr[act] - pull * ua
    diag = np.diag(JtJ).copy()
    diag[diag <= 0] = max(float(diag.max(initial=0.0)), 1e-300)
    cost = float(r @ r) + float(u @ (problem.pull * u))
    # the trials push ``u``'s kept predictions out (Problem.keep), which its callers ask for again
    # where every trial fails (the error at the point a screening stays at)
    held = problem.kept(u, exps)
    for lam in LM_DAMPING:
        u1 = u.copy()
        u1[act] += np.linalg.solve(JtJ + lam * np.diag(diag), g)
        u1 = np.clip(u1, lo, hi)
        if float(np.sum(problem.residual(u1, exps) ** 2)) + float(u1 @ (problem.pull * u1)) < cost:
            return u1
    if held is not None:
        problem.keep(u, held, exps)
    return u


# ---------------------------------------------------------------------------------------------
# screening


@dataclass
class Screened:
    effect: Any
    fixed: dict[str, float]
    u0: np.ndarray
    sse: float
    problem: Problem
    #: the evaluations of the discrete choices tried, each on a problem of its own
    tried: int = 0


def _tiny(J: np.ndarray | None, r: np.ndarray, G: np.ndarray | None = None) -> np.ndarray:
    """Columns of a Jacobian that are zero (but for round-off) next to the others and the residual
    (``G``: J's Gram matrix, where it is at hand)."""
    norms = np.linalg.norm(J, axis=0) if G is None else np.sqrt(np.maximum(np.diag(G), 0.0))
    scale = max(float(np.max(norms, initial=0.0)), float(np.linalg.norm(r)))
    return norms <= 1e-7 * (scale if scale > 0 else 1.0)


#: Jacobian columns closer than this (relative) are the same column
SAME_COLUMN = 1e-6


def _repeated(J: np.ndarray | None, G: np.ndarray | None = None) -> np.ndarray:
    """Columns equal to an earlier one: exchangeable parameters at this point (two high-pass
    corners of one filter, both at 0). A step splits evenly between them, and from an even split
    every later step does too: the fit never leaves the symmetric line (two corners at 8.7 Hz where
    the data hold one at 20 Hz). The first of them takes the step alone. ``G``: J's Gram matrix."""
    G = J.T @ J if G is None else G
    sq = np.diag(G)
    # |J_i - J_j|^2 from the Gram matrix: one product for every pair
    same = (sq[:, None] + sq[None, :] - 2 * G <= SAME_COLUMN**2 * sq[:, None]) & (sq[:, None] > 0)
    out = np.zeros(G.shape[0], bool)
    for j in range(1, len(out)):
        out[j] = bool(np.any(same[:j, j] & ~out[:j]))
    return out


def _grid_starts(problem: Problem, r0: np.ndarray, J: Normal, peaks_hz: Sequence[float]) -> list[np.ndarray]:
    """Starting points for parameters the residual cannot see at their nominal value: frequencies
    (unit Hz) and periods (unit s) from the residual's peaks and a logarithmic grid."""
    starts = []
    tiny = J.tiny(r0)
    for i, f in enumerate(problem.free):
        if not tiny[i] or f.param.unit not in ("Hz", "s") or f.experiment is not None or f.param.starts:
            continue
        lo = max(f.param.lower, 1e-12)
        hi = f.param.upper
        if f.param.unit == "Hz":
            cands = list(peaks_hz) + list(np.geomspace(max(lo, 20.0), hi, 6))
        else:
            cands = [1.0 / p for p in peaks_hz] + list(np.geomspace(max(lo, hi / 50), hi, 5))
        for c in cands:
            if f.param.lower <= c <= f.param.upper:
                u = problem.zero()
                u[i] = (c - f.param.nominal) / f.scale
                starts.append(u)
    return starts


#: grid starts of a structure's resonance frequency that screening steps from: the others are
#: ranked out by _resonance_gains (a start costs a Jacobian and a damped step, one a projection)
GRID_KEPT = 2
#: the damping ratio of the basis signals that rank a frequency grid
GRID_DAMPING = 0.02


def _resonance_gains(frequencies_hz: Sequence[float], r: np.ndarray, exps: Sequence[PreparedExperiment],
                     stride: int) -> np.ndarray:
    """The most a resonance at each of ``frequencies_hz`` can take off the residual ``r`` (strided,
    as Problem.residual) on ``exps``: its least-squares projection, channel by channel, on the force
    convolved with a damped sine and cosine at that frequency (any amplitude and phase at each
    sensor: linear, where a mode's start otherwise costs a simulation, a Jacobian and a step).
    RESONANCE_CHUNK frequencies in one convolution and one batch of 2 x 2 solves per experiment."""
    freqs = np.asarray(frequencies_hz, float)
    gains, at = np.zeros(len(freqs)), 0
    if not len(freqs):
        return gains
    w = 2 * np.pi * freqs
    wd = w * math.sqrt(1 - GRID_DAMPING**2)
    for e in exps:
        rows = len(range(0, e.n_samples, stride))
        ch = e.measured.shape[1]
        re = r[at:at + rows * ch].reshape(rows, ch)
        at += rows * ch
        t = np.arange(e.n_samples) / e.fs
        force = np.asarray(e.force, float).reshape(e.n_samples, -1).sum(axis=1)
        for lo in range(0, len(freqs), RESONANCE_CHUNK):
            part = slice(lo, lo + RESONANCE_CHUNK)
            decay = np.exp(-GRID_DAMPING * np.outer(t, w[part]))
            phase = np.outer(t, wd[part])
            kernels = np.concatenate([decay * np.sin(phase), decay * np.cos(phase)], axis=1)
            basis = scipy.signal.fftconvolve(force[:, None], kernels, axes=0)[:e.n_samples:stride]
            basis = basis.reshape(rows, 2, -1).transpose(2, 0, 1)  # frequency, row, sine/cosine
            gram = np.einsum("kti,ktj->kij", basis, basis)
            proj = np.einsum("kti,tc->kic", basis, re)
            # the pseudo-inverse at lstsq's cut-off (singular values of the basis below eps * rows)
            inv = np.linalg.pinv(gram, rcond=(np.finfo(float).eps * max(rows, 2)) ** 2, hermitian=True)
            gains[part] += np.einsum("kic,kij,kjc->k", proj, inv, proj)
    return gains


#: frequencies convolved at once by _resonance_gains: all 73 of a sweep at once held 1.3 GB for a
#: record of 131072 samples; 8 keep it near 150 MB and the batch's speed
RESONANCE_CHUNK = 8


def _ranked_grid(problem: Problem, starts: list[np.ndarray], r: np.ndarray, exps: Sequence[PreparedExperiment]
                 ) -> list[np.ndarray]:
    """The GRID_KEPT grid starts of each resonance frequency of the structure (a parameter in Hz
    of an effect on the model) whose resonance could take most off the residual ``r`` on
    ``exps`` (_resonance_gains), in the grid's order; other grid starts all kept."""
    by_param: dict[int, list[int]] = {}
    for k, u in enumerate(starts):
        i = int(np.flatnonzero(u)[0]) if u.any() else -1
        if i >= 0 and _is_resonance(problem, problem.free[i]):
            by_param.setdefault(i, []).append(k)
    dropped: set[int] = set()
    for i, ks in by_param.items():
        if len(ks) <= GRID_KEPT:
            continue
        f = problem.free[i]
        gains = _resonance_gains([f.to_value(starts[k][i]) for k in ks], r, exps, problem.stride)
        dropped.update(ks[j] for j in np.argsort(gains)[::-1][GRID_KEPT:])
    return [u for k, u in enumerate(starts) if k not in dropped]


def _is_resonance(problem: Problem, f: _Free) -> bool:
    """Whether ``f`` is a resonance frequency of the structure (a parameter in Hz of an effect on
    the model), which _resonance_gains can rank."""
    return f.param.unit == "Hz" and getattr(problem.effect, "target", "model") == "model"


#: of a resonance frequency's declared starts (a grid), the sweep evaluates the SWEEP_KEPT whose
#: resonance could take most off the records' residual without the effect (_resonance_gains: any
#: amplitude and phase per channel, where the effect's own fit is one shape across sensors and
#: experiments), then climbs the grid from the best of them to a neighbour while that is better:
#: the ranking finds the valley, the effect's own error the lowest start in it. Where a mode or a
#: stand-in for one is there (the bench rigs, the thesis rig's plate modes) the ranking put the
#: whole grid's best at places 1-4; on noise alone it may not (another start fitting noise)
SWEEP_KEPT = 4


def _climb_grid(problem: Problem, i: int, best: np.ndarray, best_sse: float, grid: Sequence[float], exps
                ) -> tuple[np.ndarray, float]:
    """_sweep of the resonance frequency ``i`` over its ``grid`` of starts (ascending), from
    ``best`` (its sum of squares ``best_sse`` on ``exps``): SWEEP_KEPT ranked starts, then the
    climb. Returns the lowest start found and its sum of squares, or ``best`` where none is lower
    (of equal ones the lowest frequency, as the sweep through every start kept the first)."""
    f = problem.free[i]
    key = (tuple(grid), tuple(e.span for e in exps))
    gains = problem._gains.get(key)
    if gains is None:  # the residual without the effect: the same for each discrete choice's problem
        without = problem._residual_of([problem.base_prediction(e) for e in exps], exps, None, problem.stride)
        gains = problem._gains[key] = _resonance_gains(grid, without, exps, problem.stride)
    sse: dict[int, float] = {}
    at: dict[int, np.ndarray] = {}

    def evaluate(ks) -> None:
        for k in sorted(k for k in ks if 0 <= k < len(grid) and k not in sse):
            at[k] = best.copy()
            at[k][i] = (grid[k] - f.param.nominal) / f.scale
            sse[k] = float(np.sum(problem.residual(at[k], exps) ** 2))

    evaluate(np.argsort(-gains, kind="stable")[:SWEEP_KEPT])
    while True:
        k = min(sse, key=lambda j: (sse[j], j))
        if all(j in sse for j in (k - 1, k + 1) if 0 <= j < len(grid)):
            break
        evaluate((k - 1, k + 1))
    return (at[k], sse[k]) if sse[k] < best_sse else (best, best_sse)


def _sweep(problem: Problem, u: np.ndarray, exps, peaks_hz: Sequence[float]) -> np.ndarray:
    """Global starts: each shared parameter that declares ``starts`` (an angle, a frequency) set
    to each of them in turn, frequencies also to the residual's peaks, keeping a value whenever it
    lowers the error on ``exps``; parameters are swept one after another (coordinate-wise), so
    the cost is the number of starts, not their product. A resonance frequency's grid is ranked
    first and only its best stretch evaluated (_climb_grid)."""
    swept = [i for i, f in enumerate(problem.free) if f.param.starts and f.experiment is None]
    if not swept:
        return u
    batches, rows_of = problem._sensor_batches(exps)
    if rows_of is not None and all(problem.free[i].param.sensor is not None for i in swept):
        return _sweep_sensors(problem, u, exps, peaks_hz, [[i for i in b if i in swept] for b in batches], rows_of)
    best = u
    best_sse = float(np.sum(problem.residual(u, exps) ** 2))
    for i in swept:
        f = problem.free[i]
        p = f.param
        values = list(p.starts) + (list(peaks_hz) if p.unit == "Hz" else [])
        grid = sorted(c for c in p.starts if p.lower <= c <= p.upper)
        if _is_resonance(problem, f) and len(grid) > SWEEP_KEPT:
            best, best_sse = _climb_grid(problem, i, best, best_sse, grid, exps)
            values = list(peaks_hz)
        last = best_sse  # a ladder's previous rung (Parameter.ladder)
        for c in values:
            if not p.lower <= c <= p.upper:
                continue
            trial = best.copy()
            trial[i] = (c - p.nominal) / f.scale
            sse = float(np.sum(problem.residual(trial, exps) ** 2))
            if sse < best_sse:
                best, best_sse = trial, sse
            if p.ladder and sse > last:  # past the value the data hold: the higher rungs are worse
                break
            last = sse
    return best


def _sweep_sensors(problem: Problem, u: np.ndarray, exps, peaks_hz: Sequence[float], batches: list[list[int]],
                   rows_of: Mapping[str, np.ndarray]) -> np.ndarray:
    """:func:`_sweep` of parameters that each change one sensor's prediction alone: the
    parameters of different sensors are set to a start together, and each keeps it when its own
    sensor's rows lower their error (the other sensors' rows cannot change the comparison)."""
    best = u
    r = problem.residual(u, exps)
    # (a sensor no record holds has no rows: its parameters cannot move the residual and stay put)
    rows = {name: rows_of[name] for name in {problem.free[i].param.sensor for b in batches for i in b}
            if name in rows_of}
    best_sse = {name: float(np.sum(r[m] ** 2)) for name, m in rows.items()}
    for batch in batches:
        values: list[list[float]] = []
        for i in batch:
            p = problem.free[i].param
            values.append(list(p.starts) + (list(peaks_hz) if p.unit == "Hz" else []))
        for k in range(max(map(len, values), default=0)):
            moved = [(i, v[k]) for i, v in zip(batch, values)
                     if k < len(v) and problem.free[i].param.lower <= v[k] <= problem.free[i].param.upper]
            if not moved:
                continue
            trial = best.copy()
            for i, c in moved:
                trial[i] = (c - problem.free[i].param.nominal) / problem.free[i].scale
            r = problem.residual(trial, exps)
            for i, _ in moved:
                name = problem.free[i].param.sensor
                if name not in rows:
                    continue
                sse = float(np.sum(r[rows[name]] ** 2))
                if sse < best_sse[name]:
                    best = best.copy() if best is u else best
                    best[i], best_sse[name] = trial[i], sse
    return best


def _sweep_stage(problem: Problem, stages: list[list[PreparedExperiment]]) -> list[PreparedExperiment]:
    """The stage global starts are compared on: the first head that holds half a period of the
    model's slowest mode. A stiffness or a frequency shows once the response has turned; on a slow
    rig (an 11 Hz suspension) the shortest head is a ninth of a period, where a start that barely
    changes the head's error (a spring hardened a thousandfold) can look better than the right one."""
    slowest = slowest_mode_hz(problem)
    need = 0.5 / slowest if slowest else 0.0
    for stage in stages[:-1]:
        if all((e.n_samples - e.trigger) / e.fs >= need for e in stage):
            return stage
    return stages[-1]


def _activation(problem: Problem, start: np.ndarray, r: np.ndarray, J: Normal, exps
                ) -> tuple[int, float] | None:
    """Products of amplitudes (a mode's participation at a sensor times at the force point) are
    invisible at zero, one at a time. Among the amplitudes (nominal 0) that are still invisible at
    ``start``, the one whose Jacobian column is largest when all of them are moved at once couples
    to the most others: moved alone, it makes the rest linear. Returns its index and value."""
    tiny = J.tiny(r)
    amp = [i for i, f in enumerate(problem.free)
           if tiny[i] and f.param.nominal == 0 and f.param.unit not in ("Hz", "s") and f.experiment is None]
    if len(amp) < 2:
        return None
    lo, hi = problem.lower_upper()
    probe = start.copy()
    probe[amp] = np.minimum(0.1 * (hi[amp] - lo[amp]), hi[amp])
    Jp = problem.jacobian(probe, problem.residual(probe, exps), exps=exps)
    norms = np.linalg.norm(Jp[:, amp], axis=0)
    if not np.max(norms) > 0:
        return None
    k = amp[int(np.argmax(norms))]
    return k, float(probe[k])


#: relative changes of a sum of squares below this are rounding (predictions of one model computed
#: in another order: prediction.predict_sharing)
ROUNDING = 1e-9


def _sensor_choices(problem: Problem, chosen: Mapping[str, float]) -> list:
    """The discrete parameters not yet chosen that change one sensor's prediction alone
    (``Parameter.sensor``: a polarity), where two or more of them can be tried together."""
    if sum(p.sensor is not None and p.name not in chosen for p in problem.discrete) < 2:
        return []
    recorded = {name for e in problem.exps for name in problem.recorded(e)}
    local = [p for p in problem.discrete if p.name not in chosen and p.sensor in recorded]
    return local if len(local) >= 2 else []


def _sensor_sums(problem: Problem, r: np.ndarray) -> dict[str, float]:
    """Each sensor's part of the sum of squares of ``r``, a residual of every sample of the
    problem's records (Problem.sse's): the rows of the channels that record it (Problem.recorded)."""
    out: dict[str, float] = {}
    at = 0
    for e in problem.exps:
        block = r[at:at + e.n_samples * len(e.sensors)].reshape(e.n_samples, len(e.sensors))
        at += block.size
        for name, v in zip(problem.recorded(e), np.einsum("ij,ij->j", block, block)):
            out[name] = out.get(name, 0.0) + float(v)
    return out


def _scored_together(problem: Problem, chosen: Mapping[str, float], local: Sequence
                     ) -> tuple[list[tuple[float, str, float]], int]:
    """Each choice of the sensor-local discrete parameters ``local`` on top of ``chosen``, scored as
    screen scores a choice alone (the sum of squares at the nominal values), from evaluations that
    set one choice of every sensor at once: a choice changes its sensor's rows alone, so its score
    is the sum without it less its sensor's part there plus that part with it (a polarity of 18
    sensors: 2 evaluations instead of 18). Returns (score, parameter, choice) and the evaluations."""
    base = problem.derived(dict(chosen))
    r0 = base.residual(base.zero(), stride=1, weighted=False)
    total, before = float(r0 @ r0), _sensor_sums(base, r0)
    spent = base.evaluations
    rounds: list[dict[str, tuple]] = []  # each: sensor -> (parameter, choice), one per sensor
    for p in local:
        for c in p.choices:
            if c == p.nominal:
                continue
            slot = next((r for r in rounds if p.sensor not in r), None)
            if slot is None:
                rounds.append(slot := {})
            slot[p.sensor] = (p, c)
    out = []
    for together in rounds:
        trial = problem.derived({**chosen, **{p.name: c for p, c in together.values()}})
        after = _sensor_sums(base, trial.residual(trial.zero(), stride=1, weighted=False))
        spent += trial.evaluations
        out += [(total - before.get(sensor, 0.0) + after.get(sensor, 0.0), p.name, c)
                for sensor, (p, c) in together.items()]
    return out, spent


def screen(problem: Problem, sse0: float, peaks_hz: Sequence[float]) -> Screened:
    """Best start found by one Gauss-Newton step (and grids/choices where needed)."""
    effect = problem.effect
    best_fixed: dict[str, float] = {}
    best_u = problem.zero()
    best_sse = sse0
    # discrete parameters: each choice alone, then greedily combined; with global starts, each
    # choice is scored after its sweep (a mode's body only shows near the mode's frequency)
    swept = any(f.param.starts for f in problem.free)

    def score(trial: Problem) -> float:
        if not swept:
            return trial.sse(trial.zero())
        first = heads(trial.exps, trial.stride)[0]
        return float(np.sum(trial.residual(_sweep(trial, trial.zero(), first, peaks_hz), first) ** 2))

    chosen: dict[str, float] = {}
    best_score = score(problem) if swept and problem.discrete else best_sse
    # a choice gains a thousandth of the windows' sum of squares with their rows at rest (the heads'
    # sums leave them out alike)
    rest = 0.0 if swept else problem.rest_sse()
    tried = 0  # the evaluations of the choices tried, each on a problem of its own
    for _ in range(3):
        trial_best = None
        local = [] if swept else _sensor_choices(problem, chosen)
        if local:
            got, spent = _scored_together(problem, chosen, local)
            tried += spent
            for sse, name, c in got:
                if trial_best is None or sse < trial_best[0]:
                    trial_best = (sse, name, c, True)
        for p in problem.discrete:
            if p.name in chosen or any(p.name == q.name for q in local):
                continue
            for c in p.choices:
                if c == p.nominal:
                    continue
                trial = problem.derived({**chosen, p.name: c})
                sse = score(trial)
                tried += trial.evaluations
                if trial_best is None or sse < trial_best[0]:
                    trial_best = (sse, p.name, c, False)
        if trial_best is not None and trial_best[3] and trial_best[0] + rest < (best_score + rest) * 0.999:
            # a sum of sensors' parts that promises a gain: the sum itself decides, and is kept
            whole = problem.derived({**chosen, trial_best[1]: trial_best[2]})
            trial_best = (score(whole), trial_best[1], trial_best[2], False)
            tried += whole.evaluations
        if trial_best is None or trial_best[0] + rest >= (best_score + rest) * 0.999:
            break
        best_score = trial_best[0]
        if not swept:
            best_sse = best_score
        chosen[trial_best[1]] = trial_best[2]
        best_fixed = dict(chosen)
    if best_fixed:
        problem = problem.derived(best_fixed)
    if problem.free:
        stages = heads(problem.exps, problem.stride, ringing_mode_hz(problem), slowest_mode_hz(problem))
        first = stages[0]
        u0 = problem.zero()
        r0 = problem.residual(u0, first)
        J0 = problem.tangent(u0, r0, first)
        # the best start on the shortest head, then one damped step on each longer head
        best_start, best_head = u0, float(r0 @ r0)
        from_head = best_head  # the first head's sum where the best start's step began
        activation: tuple[int, float] | None = None
        swept = _sweep(problem, u0, _sweep_stage(problem, stages), peaks_hz)
        grid = _grid_starts(problem, r0, J0, peaks_hz)
        if grid:
            grid = _ranked_grid(problem, grid, problem.residual(u0, stages[-1]), stages[-1])
        for start in [u0] + ([swept] if swept is not u0 else []) + grid:
            r = r0 if start is u0 else problem.residual(start, first)
            J = J0 if start is u0 else problem.tangent(start, r, first)
            if start is not u0:
                activation = activation or _activation(problem, start, r, J, first)
                if activation is not None and J.tiny(r)[activation[0]]:
                    start = start.copy()
                    start[activation[0]] = activation[1]
                    r = problem.residual(start, first)
                    J = problem.tangent(start, r, first)
            u = _lm_step(problem, J, r, start, first)
            sse = float(np.sum(problem.residual(u, first) ** 2))
            if sse < best_head:
                best_start, best_head, from_head = u, sse, float(r @ r)
        u = best_start
        # a step that took more than half of the head's sum was cut short by its linearisation: the
        # next from where it ended (a mass 75 % up: 1.15, 1.33, 1.49 in three steps on the head)
        for _ in range(HEAD_STEPS):
            if not best_head < HEAD_STEP_GAIN * from_head:
                break
            r = problem.residual(u, first)
            u1 = _lm_step(problem, problem.tangent(u, r, first), r, u, first)
            sse = float(np.sum(problem.residual(u1, first) ** 2))
            if not sse < best_head:
                break
            u, best_head, from_head = u1, sse, best_head
        for exps in stages[1:]:
            r = problem.residual(u, exps)
            u = _lm_step(problem, problem.tangent(u, r, exps), r, u, exps)
        sse = problem.sse(u)
        if swept is not u0:  # damped steps judged on short heads may lead a good start astray
            sse_swept = problem.sse(swept)
            if sse_swept < sse:
                u, sse = swept, sse_swept
        if sse < best_sse * (1 - ROUNDING):  # a gain in the last digits is the arithmetic's, not the data's
            best_sse, best_u = sse, u
    return Screened(effect, best_fixed, best_u, best_sse, problem, tried)


# ---------------------------------------------------------------------------------------------
# fitting and validation


def refined(start: Problem, u: np.ndarray, effect) -> tuple[Problem, np.ndarray]:
    """The problem of ``effect``, which refines ``start.effect`` (its ``refines``), on the same
    records with ``start``'s choices and what the effect holds given them (``held_when``), and its
    start: every parameter the two share at ``start``'s fit at ``u``, the others nominal, and what
    the effect's ``refined_start`` makes of them."""
    fixed = dict(start.fixed)
    held = getattr(effect, "held_when", None)
    if held is not None:
        fixed.update(held(start.base.shared, fixed))
    problem = Problem(start.base, effect, start.exps, fixed, start.prior, start.stride, full=start.full,
                      noise_scale=start.noise_scale, weights=start.weights)
    shared, per = start.values(u)
    begin = getattr(effect, "refined_start", None)
    if begin is not None:
        shared = {**shared, **begin(start.base.shared, {**shared, **fixed})}
    u0 = np.array([((shared if f.experiment is None else per.get(f.experiment, {})).get(f.param.name, f.param.nominal)
                    - f.param.nominal) / f.scale for f in problem.free])
    return problem, np.clip(u0, *problem.lower_upper())



#: the fit's finite-difference step, in natural steps (_scale). Absolute: scipy's own steps are
#: relative to the value, and the search values start at 0 (nominal), so a parameter near its
#: nominal was differenced over 1e-14 of a step (in round-off, or in a filter at 1e15 Hz)
DIFF_STEP = 1e-4
#: a search stops when two of its iterations together lowered its objective (the data's sum of
#: squares and the prior's) by less than this many noise energies per independent sample, or when
#: its linearisation at the current point promises less than that: one is the objective's
#: one-standard-error scale, and every test needs ten or more (chi-square's quantile at
#: checks.FALSE_ALARM: 10.8 for one parameter). Along a direction the data cannot see (a scale
#: spread over axes and springs: a curved valley) a search otherwise crawls on for another eight
#: iterations at about one each; such directions are reported as redundant groups
STALL_GAIN = 1.0
#: a fit given a ``target`` (the sum of squares of a simpler candidate it must beat) stops once its
#: linearisation promises no better than this multiple of it while that promise fell by less than
#: half over the last iteration: it can no longer pass the test against that candidate
TARGET_FACTOR = 4.0


def _promise(G: np.ndarray, g: np.ndarray, free: np.ndarray) -> float:
    """The objective's fall (in cost, half the sum of squares) that a full Gauss-Newton step over
    the ``free`` parameters promises at this point (G = J^T J, g = J^T f)."""
    if not free.any():
        return 0.0
    gf = g[free]
    step = np.linalg.lstsq(G[np.ix_(free, free)], gf, rcond=1e-12)[0]
    return max(0.5 * float(gf @ step), 0.0)


def _promise_within(x: np.ndarray, G: np.ndarray, g: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    """_promise over the parameters not held at a bound ``lo``..``hi`` that the gradient pushes against."""
    tol = AT_BOUND * np.maximum(1.0, np.abs(lo)), AT_BOUND * np.maximum(1.0, np.abs(hi))
    held = ((x - lo <= tol[0]) & (g > 0)) | ((hi - x <= tol[1]) & (g < 0))
    return _promise(G, g, ~held)


def held_implausibly(problem: Problem, u: np.ndarray) -> np.ndarray:
    """The shared parameters held at a bound of the search outside their plausible range."""
    lo, hi = problem.lower_upper()
    tol = AT_BOUND * np.maximum(1.0, np.abs(lo)), AT_BOUND * np.maximum(1.0, np.abs(hi))
    out = np.zeros(len(problem.free), bool)
    for i, f in enumerate(problem.free):
        low, high = f.param.plausible or (f.param.lower, f.param.upper)
        out[i] = f.experiment is None and ((u[i] - lo[i] <= tol[0][i] and f.param.lower < low)
                                           or (hi[i] - u[i] <= tol[1][i] and f.param.upper > high))
    return out


def off_the_bounds(problem: Problem, res: OptimizeResult) -> OptimizeResult:
    """A finished fit that holds parameters at a bound outside their plausible range fitted once
    more from its end with those at their nominal values; the lower of the two ends. A valley of
    one parameter may end at its bound while the data's lies elsewhere: a bracket 1.75 times as
    heavy fitted its moment about z at the bound 0.5 (sum of squares 1.8e4), and from 1 reached
    1.75 with the mass (56, the noise)."""
    held = held_implausibly(problem, res.x)
    if not held.any():
        return res
    u = res.x.copy()
    u[held] = 0.0
    again = fit(problem, u, continuation=False)
    return again if problem.sse(again.x) < problem.sse(res.x) else res


class _Stops:
    """The search's stops, decided after each iteration (scipy's callback) from the objective and
    the Jacobian at the point reached: two iterations together gained less than STALL_GAIN noise
    energies (``least``, in cost), or the linearisation there promises less than that (the
    curved valley's crawl gains no more than it promises), or (with ``target``) it cannot come
    near the target (TARGET_FACTOR), or ``cannot_pass(x, promised)`` says that from ``x``, gaining
    what the linearisation there promises (in cost), the fit cannot pass the test it is made for.
    ``target_stop`` says whether one of the last two was why."""

    def __init__(self, least: float, target: float | None, lo: np.ndarray, hi: np.ndarray,
                 cannot_pass: Callable[[np.ndarray, float], bool] | None = None, rest: float = 0.0) -> None:
        self.least, self.target, self.lo, self.hi = least, target, lo, hi
        self.rest = rest  # the cost of rows the fit leaves out, in both costs TARGET_FACTOR compares
        self.cannot_pass = cannot_pass
        self.costs: list[float] = []
        self.promised: dict[bytes, float] = {}
        self.reach_before = math.inf
        self.target_stop = self.stalled = False

    def jacobian(self, x: np.ndarray, G: np.ndarray, g: np.ndarray) -> None:
        """Note what the linearisation at ``x`` promises (G = J^T J, g = J^T f, J = d f / d x)."""
        self.promised = {x.tobytes(): _promise_within(x, G, g, self.lo, self.hi)}

    def __call__(self, intermediate_result) -> None:
        cost = float(intermediate_result.cost)
        self.costs.append(cost)
        costs, least = self.costs, self.least
        self.stalled = least > 0 and len(costs) >= 3 and costs[-3] - costs[-1] < least
        if self.stalled:
            raise StopIteration
        self.linearisation(np.asarray(intermediate_result.x), cost)

    def linearisation(self, x: np.ndarray, cost: float) -> None:
        """The stops the Jacobian at ``x`` decides (StopIteration): asked again when an updated
        Jacobian (_trf's Broyden update) said stop, with the differenced one."""
        self.target_stop = False
        promised = self.promised.get(x.tobytes())
        if promised is None:
            return
        least = self.least
        if least > 0 and promised < least:
            raise StopIteration
        reach = cost - promised
        if (self.target is not None and reach + self.rest > TARGET_FACTOR * (self.target + self.rest)
                and reach > 0.5 * self.reach_before):
            self.target_stop = True
            raise StopIteration
        self.reach_before = reach
        if self.cannot_pass is not None and self.cannot_pass(x, promised):
            self.target_stop = True
            raise StopIteration

    def at_start(self, x: np.ndarray) -> bool:
        """``cannot_pass`` at the start, from its differenced Jacobian, before a first step: a fit
        from a screened point far behind the best stops there, not one step and one Jacobian
        later. Not where the start is its own minimum to within the least stop (its linearisation
        promises less: a screening that converged), which the search's own stops end as before;
        the other stops wait for the steps they judge."""
        promised = self.promised.get(x.tobytes())
        self.target_stop = bool(promised is not None and self.cannot_pass is not None
                                and not (self.least > 0 and promised < self.least)
                                and self.cannot_pass(x, promised))
        return self.target_stop


#: scipy least_squares' default gradient tolerance, which _trf keeps
GTOL = 1e-8
#: after an accepted step, _trf updates the Jacobian by Broyden's rank-one formula (the secant
#: through the step) instead of differencing every column again, at most this many times in a row
BROYDEN_RUN = 3
#: ... while the steps it gives gain within this fraction of what it predicts; beyond it, or after
#: a step it gave that gained nothing (taken again from a differenced one), the next is differenced
BROYDEN_MISS = 0.5


#: rows of the Jacobian a Broyden update adds at a time
UPDATE_ROWS = 8192


def _square_root(J: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A (n x n) and c with A^T A = J^T J and A^T c = J^T f (J = Q A, c = Q^T f for Q with
    orthonormal columns), from the eigen-decomposition of J^T J; also J^T J and J^T f. A direction
    J does not see has a zero row in A and zero in c."""
    G = J.T @ J
    g = J.T @ f
    w, V = np.linalg.eigh(G)
    s = np.sqrt(np.clip(w, 0.0, None))
    A = s[:, None] * V.T
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.where(s > 0, (V.T @ g) / np.where(s > 0, s, 1.0), 0.0)
    return A, c, G, g


#: a step is taken further along its line (_further) at most this many times its length, ...
FURTHER_MAX = 4.0
#: ... where the parabola through the cost, its slope and the step's cost puts the line's minimum
#: at least this many times the step's length
FURTHER_MIN = 1.25


def _further(fun, x: np.ndarray, cost: float, slope: float, step: np.ndarray, cost_step: float,
             lb: np.ndarray, ub: np.ndarray, least: float) -> tuple[np.ndarray, np.ndarray, float, float] | None:
    """The point, residual, cost and multiple t of ``step`` at the minimum of the parabola through
    the ``cost`` at ``x``, its ``slope`` along ``step`` (g . step) and ``cost_step`` at x + step,
    evaluated; None (nothing evaluated) where that minimum lies within FURTHER_MIN steps or
    promises less than ``least`` more than x + step. A Gauss-Newton step ignores the residual's
    curvature: where the residual stays large (a candidate that does not fit) or the valley bends,
    each step fell 1.3-1.7x what it promised and reached about half way along its line, so the
    search converged linearly at a Jacobian (20 columns: 20 simulations' worth) per iteration."""
    curvature = cost_step - cost - slope
    t = FURTHER_MAX if curvature <= 0 else min(-slope / (2.0 * curvature), FURTHER_MAX)
    if t < FURTHER_MIN or cost_step - (cost + slope * t + curvature * t * t) < least:
        return None
    x_t = make_strictly_feasible(x + t * step, lb, ub, rstep=0)
    f_t = fun(x_t)
    if not np.all(np.isfinite(f_t)):
        return x_t, f_t, math.inf, t
    return x_t, f_t, 0.5 * float(f_t @ f_t), t


def _trf(fun, jac, x0: np.ndarray, lb: np.ndarray, ub: np.ndarray, *, max_nfev: int, xtol: float, ftol: float,
         stops: _Stops, broyden: bool = True, further: bool = True, secant_ends: bool = False) -> OptimizeResult:
    """scipy's least_squares(method="trf", x_scale=1, tr_solver="exact") with bounds, run on the
    n x n square root of J^T J (_square_root) in place of J's m rows, and (``broyden``) with
    Jacobians updated along accepted steps. Written here because scipy's takes an SVD of every row
    of J at every iteration (~212,000 rows on the two-body rig: 0.1 s, 25x the product J^T J),
    though its steps depend on J^T J and J^T f alone, and differences every column after every
    accepted step (each column a simulation). The steps, their acceptance and termination are
    scipy's own functions; without ``broyden`` the iterates are scipy's to rounding where J is well
    conditioned (J^T J squares its condition number: a split the data barely determine, held by the
    prior alone, lands elsewhere along it at the same cost) and without ``further`` (accepted
    steps taken further along their line, _further, until it first declines one).

    ``jac(x, f)`` is d f / d x at ``x`` (``f`` the residual there). An updated Jacobian gives way to
    a differenced one (BROYDEN_RUN, BROYDEN_MISS) and never ends the search: where the gradient,
    scipy's ftol test (which reads the Jacobian's promise) or ``stops`` (which
    sees each Jacobian's G = J^T J and g = J^T f and, after each iteration, the cost and point:
    scipy's callback) stop on its promise, the differenced Jacobian decides; the result's ``jac``
    is always differenced (uncertainties and validation use it). With ``secant_ends`` (a caller that
    reads the point alone: a validation fold) an updated Jacobian may end the search, and the
    result's ``jac`` may be an updated one."""
    x = make_strictly_feasible(np.asarray(x0, float), lb, ub)
    f = fun(x)
    J = jac(x, f)
    nfev = njev = 1
    m, n = J.shape
    cost = 0.5 * float(f @ f)
    A, c, G, g = _square_root(J, f)
    stops.jacobian(x, G, g)
    exact, run = True, 0  # whether J is differenced; updates since it was
    stopped_at_start = stops.at_start(x)

    def differenced() -> None:
        nonlocal J, A, c, G, g, exact, run, njev
        J = jac(x, f)
        njev += 1
        exact, run = True, 0
        A, c, G, g = _square_root(J, f)
        stops.jacobian(x, G, g)

    v, _ = CL_scaling_vector(x, g, lb, ub)
    Delta = float(np.linalg.norm(x / v**0.5)) or 1.0
    f_aug = np.zeros(2 * n)
    alpha, iteration, status, g_norm = 0.0, 0, None, math.inf
    if stopped_at_start:
        status = -2
        g_norm = float(np.linalg.norm(g * CL_scaling_vector(x, g, lb, ub)[0], ord=np.inf))
    while not stopped_at_start:
        v, dv = CL_scaling_vector(x, g, lb, ub)
        g_norm = float(np.linalg.norm(g * v, ord=np.inf))
        if g_norm < GTOL:
            if not exact and not secant_ends:  # an updated Jacobian's gradient: the differenced one decides
                differenced()
                continue
            status = 1
        if status is not None or nfev == max_nfev:
            break
        d = v**0.5
        diag_h = g * dv
        g_h = d * g
        J_h = A * d
        U, s, Vt = scipy.linalg.svd(np.vstack([J_h, np.diag(diag_h**0.5)]), full_matrices=False)
        V = Vt.T
        f_aug[:n] = c
        uf = U.T @ f_aug
        theta = max(0.995, 1 - g_norm)
        actual_reduction, ratio, refresh = -1.0, 1.0, False
        while actual_reduction <= 0 and nfev < max_nfev:
            p_h, alpha, _ = solve_lsq_trust_region(n, m, uf, s, V, Delta, initial_alpha=alpha)
            p = d * p_h
            step, step_h, predicted = select_step(x, J_h, diag_h, g_h, p, p_h, d, Delta, lb, ub, theta)
            if exact and predicted < stops.least:
                # within the region its linearisation is trusted in, it promises less than one noise
                # energy (the region shrank on steps that gained nothing): the least stop's rule
                status = -2
                break
            x_new = make_strictly_feasible(x + step, lb, ub, rstep=0)
            f_new = fun(x_new)
            nfev += 1
            step_h_norm = float(np.linalg.norm(step_h))
            if not np.all(np.isfinite(f_new)):
                Delta = 0.25 * step_h_norm
                continue
            cost_new = 0.5 * float(f_new @ f_new)
            actual_reduction = cost - cost_new
            if not exact and actual_reduction <= 0:
                refresh = True  # the updated Jacobian misled: the differenced one takes this step again
                break
            Delta_new, ratio = update_tr_radius(Delta, actual_reduction, predicted, step_h_norm,
                                                step_h_norm > 0.95 * Delta)
            status = check_termination(actual_reduction, cost, float(np.linalg.norm(step)), float(np.linalg.norm(x)),
                                       ratio, ftol, xtol)
            if status is not None:
                break
            alpha *= Delta / Delta_new
            Delta = Delta_new
        if refresh:
            differenced()
            continue
        confirm = status in (2, 4) and not exact and not secant_ends  # small gain for what an updated Jacobian promised
        if confirm:
            status = None
        if actual_reduction > 0:
            x_old, f_old = x, f
            if further and status is None and nfev < max_nfev:
                longer = _further(fun, x, cost, float(g @ step), step, cost_new, lb, ub, stops.least)
                # once the parabola puts the minimum within reach, later steps are not taken further
                # (tried after every step: more evaluations and Jacobians on the large-residual fits)
                further = longer is not None
                if longer is not None:
                    nfev += 1
                    if longer[2] < cost_new:
                        x_new, f_new, cost_new, t = longer
                        Delta = max(Delta, t * step_h_norm)
            x, f, cost = x_new, f_new, cost_new
            if (broyden and not confirm and status is None and run < BROYDEN_RUN
                    and abs(1 - ratio) <= BROYDEN_MISS):
                # the secant through the step: J += (df - J dx) dx^T / |dx|^2, in place (J is
                # this search's own) and by blocks of rows (no temporary of J's size)
                dx = x - x_old
                a = (f - f_old - J @ dx) / float(dx @ dx)
                for at in range(0, m, UPDATE_ROWS):
                    J[at:at + UPDATE_ROWS] += np.outer(a[at:at + UPDATE_ROWS], dx)
                exact, run = False, run + 1
                A, c, G, g = _square_root(J, f)
                stops.jacobian(x, G, g)
            else:
                differenced()
        iteration += 1
        try:
            stops(OptimizeResult(x=x, fun=f, nit=iteration, nfev=nfev, cost=cost))
        except StopIteration:
            if exact or stops.stalled or secant_ends:
                status = -2
                break
            differenced()  # an updated Jacobian's promise: the differenced one decides
            try:
                stops.linearisation(x, cost)
            except StopIteration:
                status = -2
                break
    if not exact and not secant_ends:
        differenced()
        g_norm = float(np.linalg.norm(g * CL_scaling_vector(x, g, lb, ub)[0], ord=np.inf))
    return OptimizeResult(x=x, cost=cost, fun=f, jac=J, grad=g, optimality=g_norm,
                          active_mask=find_active_constraints(x, lb, ub, rtol=xtol), nfev=nfev, njev=njev,
                          status=0 if status is None else status)


def fit(problem: Problem, u0: np.ndarray, *, exps: Sequence[PreparedExperiment] | None = None,
        max_nfev: int | None = None, continuation: bool = True, target: float | None = None,
        cannot_pass: Callable[[np.ndarray, float], bool] | None = None, jac0: np.ndarray | None = None,
        rows: np.ndarray | None = None, short_of: float = 0.0, secant_ends: bool = False):
    """Bounded output-error least squares from ``u0`` (on short heads of the records first, search);
    returns the result (scipy's fields) for the whole records (``jac`` = d residual / d u). With ``target`` (a
    sum of squares over every sample of ``problem``'s records) the fit stops where it cannot come
    near it, and with ``cannot_pass`` where that says it cannot pass its test (_Stops; ``target_stop``
    true). ``jac0``: the Jacobian at ``u0`` (a stopped fit's ``jac``, going on without
    ``continuation``), taken for the first instead of differencing it again. ``rows``: the
    residual's (strided) rows the fit sees, a mask over them (a validation fold's kept rows;
    without ``continuation``). ``short_of`` (in cost): the fit also stops where its linearisation
    promises less than that (a fold goes as far as the fit it validates went). ``secant_ends``: the
    point alone is read (a fold), so an updated Jacobian may end the search (_trf)."""
    lo, hi = problem.lower_upper()
    u = np.clip(u0, lo, hi)
    n = len(problem.free)
    root = np.sqrt(problem.pull) if problem.prior else None
    stages = (heads(exps or problem.exps, problem.stride, ringing_mode_hz(problem), slowest_mode_hz(problem))
              if continuation else [list(exps or problem.exps)])
    # the cost is half the strided sum of squares, which is about the whole one over the stride
    least = 0.5 * STALL_GAIN * problem.noise_scale / problem.stride if problem.noise_scale > 0 else 0.0
    least = max(least, short_of)
    for k, stage in enumerate(stages):
        last = k == len(stages) - 1

        def fun(x, stage=stage):
            r = problem.residual(x, stage)
            if rows is not None:
                r = r[rows]
            return np.concatenate([r, root * x]) if root is not None else r

        def jac(x, f, stage=stage):
            nonlocal jac0
            if jac0 is not None and last:
                J, jac0 = jac0.copy(), None  # the search scales it in place
                return J
            # the differences need every row's residual (the kept predictions: no evaluation)
            r = problem.residual(x, stage) if rows is not None else f[:f.size - n] if root is not None else f
            J = problem.jacobian(x, r, stage, step=DIFF_STEP)
            if rows is not None:
                J = J[rows]
            if root is None:
                return np.negative(J, out=J)
            # the prior's rows below the data's, in one new array (a Jacobian holds 10-40 MB)
            out = np.empty((J.shape[0] + n, n))
            np.negative(J, out=out[:J.shape[0]])
            out[J.shape[0]:] = np.diag(root)
            return out

        targeted = target is not None and last
        res = search(fun, jac, u, lo, hi, problem.free, least=least,
                     target=0.5 * target / problem.stride if targeted else None,
                     cannot_pass=cannot_pass if last else None, max_nfev=max_nfev or (8 if last else 4) * (n + 1),
                     secant_ends=secant_ends and last, rest=problem.rest_cost() if targeted and exps is None else 0.0)
        u = res.x
    return res


def search(fun, jac, u0: np.ndarray, lo: np.ndarray, hi: np.ndarray, free: Sequence[_Free], *, least: float,
           target: float | None, max_nfev: int, xtol: float = 1e-6, ftol: float = 1e-8,
           cannot_pass: Callable[[np.ndarray, float], bool] | None = None, secant_ends: bool = False,
           rest: float = 0.0) -> OptimizeResult:
    """_trf from ``u0`` within ``lo``..``hi`` over ``free`` (natural steps; ``fun(u)`` the
    residual, ``jac(u, f)`` d f / d u), the factors searched in logarithms (_FactorLogs), stopped
    by _Stops(``least``, ``target``, ``cannot_pass``, ``rest``, in cost; ``cannot_pass`` is asked at
    natural points; ``secant_ends``: _trf's); the result in natural steps, with ``target_stop``."""
    coords = _FactorLogs(free)
    lo_w, hi_w = coords.search(lo), coords.search(hi)
    stops = _Stops(least, target, lo_w, hi_w,
                   None if cannot_pass is None else lambda w, promised: cannot_pass(coords.natural(w), promised),
                   rest)
    res = _trf(lambda w: fun(coords.natural(w)),
               # d f / d w = d f / d u times d u / d w, by columns (in place: ``jac`` returns a new array)
               lambda w, f: coords.in_search(jac(coords.natural(w), f), w),
               coords.search(u0), lo_w, hi_w, max_nfev=max_nfev, xtol=xtol, ftol=ftol, stops=stops,
               secant_ends=secant_ends)
    res.target_stop = stops.target_stop
    coords.natural_result(res, lo, hi)
    return res


class _FactorLogs:
    """The coordinates a fit searches in: a factor (a dimensionless parameter of nominal 1 and a
    positive lower bound: a stiffness's or a mass's scale, a gain) in the logarithm of its value,
    every other parameter in natural steps (u). Scales multiply (a spring's stiffness is an axis's
    scale times its group's), so where one scale can stand in for another the valley of equal error
    is a hyperbola in u, along which the search crawled in short steps (a straight step along its
    tangent climbs its walls); in logarithms it is a straight line. The map is w = ln(1 + k u) / k
    with k = scale (nominal 1): at the nominal value w = u and d u / d w = 1, so steps, the prior
    and the finite differences keep their sizes there. The objective is the same function of the
    parameters in either coordinates: only the path to its minimum changes."""

    def __init__(self, free: Sequence[_Free]) -> None:
        self.mask = np.array([f.param.unit == "1" and f.param.nominal == 1.0 and f.param.lower > 0 for f in free],
                             bool)
        self.k = np.array([f.scale if m else 1.0 for f, m in zip(free, self.mask)])

    def search(self, u: np.ndarray) -> np.ndarray:
        if not self.mask.any():
            return np.asarray(u, float)
        w = np.array(u, float)
        w[self.mask] = np.log1p(self.k[self.mask] * w[self.mask]) / self.k[self.mask]
        return w

    def natural(self, w: np.ndarray) -> np.ndarray:
        if not self.mask.any():
            return w
        u = np.array(w, float)
        u[self.mask] = np.expm1(self.k[self.mask] * u[self.mask]) / self.k[self.mask]
        return u

    def derivative(self, w: np.ndarray) -> np.ndarray:
        """d u / d w at ``w``."""
        return np.where(self.mask, np.exp(np.where(self.mask, self.k * w, 0.0)), 1.0)

    def in_search(self, J: np.ndarray, w: np.ndarray) -> np.ndarray:
        """``J`` = d f / d u at ``w`` as d f / d w, its columns scaled in place."""
        if self.mask.any():
            J *= self.derivative(w)
        return J

    def natural_result(self, res, lo: np.ndarray, hi: np.ndarray) -> None:
        """``res`` (_trf's, in search coordinates) in natural steps: its point, Jacobian and
        gradient."""
        if not self.mask.any():
            return
        dudw = self.derivative(res.x)
        res.x = np.clip(self.natural(res.x), lo, hi)
        res.jac = res.jac / dudw
        res.grad = res.grad / dudw


def effective_samples(exps: Sequence[PreparedExperiment]) -> tuple[float, float]:
    """Samples carrying independent information: the record length times the fraction of the band
    that holds 99 % of the measured energy (filtered signals are strongly correlated); and the
    frequency below which that 99 % lies."""
    total, f99 = 0.0, 0.0
    for e in exps:
        spec = np.sum(np.abs(np.fft.rfft(e.measured, axis=0)) ** 2, axis=1)
        c = np.cumsum(spec)
        k = int(np.searchsorted(c, 0.99 * c[-1])) + 1
        total += e.measured.shape[1] * e.n_samples * min(1.0, k / len(spec))
        f99 = max(f99, k * e.fs / (2 * len(spec)))
    return max(total, 1.0), f99


def uncertainties(problem: Problem, res, n_eff: float | Callable[[], float]
                  ) -> tuple[np.ndarray, np.ndarray, list[list[str]], np.ndarray]:
    """Standard deviations (value units), correlations, redundant groups and the directions the
    data cannot see (search units, parameters x directions, unit length) at the fit.

    The sandwich covariance ``A^+ B A^+`` (A = J^T J, B = Var(J^T r), residual_score_covariance):
    the residual's noise is coloured (the force channel's noise through the model rings at the
    resonances, where the Jacobian's columns are large too), so the gradient's variance is read
    per frequency against the residual's own spectrum. Rows in another layout than the
    experiments' strided samples fall back to ``s2 (J^T J)^+`` with the residual variance
    inflated by N / ``n_eff`` (a number, or a function asked only there). Directions the data
    cannot see at all (an effect whose parameters overlap, e.g. a global scale spread over axes and
    springs) are left out of the covariance (pseudo-inverse) and reported as groups whose
    combination alone is determined.
    """
    J = res.jac[: res.jac.shape[0] - len(problem.free)] if problem.prior else res.jac
    n, p = J.shape
    r = res.fun[:n]
    JtJ = J.T @ J
    w, V = np.linalg.eigh(JtJ)
    null = w <= 1e-8 * max(float(w.max(initial=0.0)), 1e-300)
    groups = []
    for k in np.flatnonzero(null):
        members = [problem.free[i].label for i in np.flatnonzero(np.abs(V[:, k]) > 0.2)]
        if len(members) > 1 and members not in groups:
            groups.append(members)
    inv_w = np.where(null, 0.0, 1.0 / np.where(null, 1.0, w))
    A_plus = (V * inv_w) @ V.T
    blocks = _experiment_blocks(problem, n)
    if blocks is None:  # (rows at rest not counted: their layout is the experiments' blocks')
        n_eff = n_eff() if callable(n_eff) else n_eff
        cov = float(r @ r) / max(1, n - p) * (n / n_eff) * A_plus
    else:
        # the fitted residual lacks the p directions the fit took out of it: as s2's n - p (the
        # rows at rest before the windows counted, as in uncertainties' variance)
        rest = [problem.at_rest(e) for e in problem.exps]
        n_all = n + sum(x.size for x in rest)
        B = residual_score_covariance(J, r, blocks, rest) * (n_all / max(1, n_all - p))
        cov = A_plus @ B @ A_plus
    sd_u = np.sqrt(np.clip(np.diag(cov), 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd_u, sd_u)
    scales = np.array([f.scale for f in problem.free])
    return sd_u * scales, np.nan_to_num(corr), groups, V[:, null]


def force_noise_covariance(problem: Problem, res, scores: Sequence[np.ndarray] | None = None) -> np.ndarray:
    """The covariance (search units) the force channel's noise adds to the fit at ``res`` beyond
    what ``uncertainties`` reads from the residual (errors in the variables). The model is driven
    with the measured force f + n; n is zero outside the force window (the samples where the
    windowed force is not) and white within it, of energy ``force_noise_energy`` (N^2) spread
    evenly. Its response G n is a sum of the model's impulse responses from those few samples,
    a transient as the hit's own response, not noise stationary over the record as the sandwich
    reads the residual (a coherent sum over frequencies averaged as if incoherent: the thesis rig's
    stiffnesses up to 5 sd off with force noise alone). Here its part of the gradient is summed
    directly: ``A^+ (sum over experiments of force_noise_scores) A^+``. The sandwich's own reading
    of that response stays: the sum is conservative by it. The mean of (G' n)^T (G n), the bias
    the noise also gives, is second order in it and left out. ``scores``: force_noise_scores',
    where at hand."""
    p = len(problem.free)
    scores = force_noise_scores(problem, res) if scores is None else scores
    if not p or not any(np.any(b) for b in scores):
        return np.zeros((p, p))
    J = res.jac[: res.jac.shape[0] - p] if problem.prior else res.jac
    A_plus = np.linalg.pinv(J.T @ J, rcond=1e-8, hermitian=True)  # uncertainties' undetermined directions
    return A_plus @ sum(scores) @ A_plus


def force_noise_scores(problem: Problem, res, responses: Sequence[np.ndarray] | None = None) -> list[np.ndarray]:
    """Per experiment, the covariance (search units) of the gradient's part ``J_i^T G n_i`` that
    the force channel's noise n_i in its window gives (force_noise_covariance; checks.consistency
    propagates each experiment's alone to its own fit): ``sum over window samples s of var_s c_s
    c_s^T``, c_s = J_i^T g_s, g_s the residual's response to a unit force sample at s, each
    sample's variance ``force_noise_energy`` over the window's samples. g_s is the response to a
    kick at the trigger sample shifted to s (the model is time-invariant from rest), all c_s one
    product of the Jacobian's rows with the shifted responses. ``responses``: per experiment that
    response (every sample x channel, weighted as the residual, per N); by default read as the
    change of the residual when the force is kicked at its trigger (a nonlinear structure's noise
    response linearised about the hit's by a kick of the noise's size). Effects that project
    parameters (a mode's participations) get none: their projection would refit on the kicked
    force."""
    p = len(problem.free)
    none = [np.zeros((p, p)) for _ in problem.exps]
    J = res.jac[: res.jac.shape[0] - p] if problem.prior else res.jac
    blocks = _experiment_blocks(problem, J.shape[0])
    if not p or blocks is None or not any(e.force_noise_energy > 0 for e in problem.exps):
        return none
    if responses is None:
        if problem.linear:
            return none
        responses = _kick_responses(problem, res)
    out = []
    for e, (start, m, c), g in zip(problem.exps, blocks, responses):
        window = np.flatnonzero(e.force)
        if e.force_noise_energy <= 0 or not window.size or not 0 <= e.trigger < e.n_samples:
            out.append(np.zeros((p, p)))
            continue
        C = _shifted_products(J[start:start + m * c].reshape(m, c, p), np.asarray(g, float).reshape(e.n_samples, c),
                              window - e.trigger, problem.stride)
        out.append(C.T @ C * (e.force_noise_energy / window.size))
    return out


def _shifted_products(Jb: np.ndarray, g: np.ndarray, shifts: np.ndarray, stride: int) -> np.ndarray:
    """Rows ``sum over samples j and channels of Jb[j] g[stride j - s]`` for each shift s (g zero
    outside its samples): the Jacobian's rows (strided samples x channels x parameters) against a
    response delayed by s, all shifts at once as a cross-correlation by FFT. The Jacobian at every
    stride-th sample is the whole-rate sequence with zeros between, whose transform of length
    stride x L is its own of length L repeated; L long enough that no shift wraps."""
    m, c, p = Jb.shape
    n = g.shape[0]
    L = scipy.fft.next_fast_len(-(-(max(n, stride * m) + int(np.max(np.abs(shifts)))) // stride) + 1, real=True)
    N = stride * L
    Jf = scipy.fft.rfft(Jb, L, axis=0)  # L // 2 + 1 x channels x parameters
    if stride > 1:
        f = np.arange(N // 2 + 1) % L
        mirrored = f > L // 2
        # the whole-rate transform's frequency f is the strided one's f mod L, those past L / 2 the
        # conjugates of their mirror images (a real sequence's)
        Jf = Jf[np.where(mirrored, L - f, f)]
        Jf[mirrored] = Jf[mirrored].conj()
    Gf = scipy.fft.rfft(g, N, axis=0)  # N // 2 + 1 x channels
    # correlation: sum_t a[t] b[t - s] is the inverse transform of conj(A) B at lag -s (summed over
    # the channels as one product per frequency)
    X = np.matmul(Gf.conj()[:, None, :], Jf)[:, 0, :].conj()
    corr = scipy.fft.irfft(X, N, axis=0)
    return corr[(-np.asarray(shifts)) % N]


def _count_on(problem: Problem, helper: Problem) -> None:
    """``helper``'s evaluations (a problem built for one computation of ``problem``'s) counted as
    ``problem``'s: diagnose reports the evaluations its candidates' problems count."""
    problem.evaluations += helper.evaluations


def _kick_responses(problem: Problem, res) -> list[np.ndarray]:
    """Per experiment, the residual's response (every sample x channel, weighted, per N) to a kick of
    the force of the noise's size (its energy's root) at the trigger sample."""
    kicked_exps, size = [], []
    for e in problem.exps:
        kick = np.zeros_like(e.force)
        size.append(math.sqrt(e.force_noise_energy))
        if 0 <= e.trigger < kick.size:
            kick[e.trigger] = size[-1]
        # the experiment's caches hold the unkicked force's simulation: not carried over
        kicked_exps.append(replace(e, force=e.force + kick, _cache=None, _filtered=None))
    kicked = Problem(problem.base, problem.effect, kicked_exps, problem.fixed, problem.prior, problem.stride,
                     problem.full, problem.noise_scale, problem.weights)
    response = problem.residual(res.x, stride=1) - kicked.residual(res.x, stride=1)  # every sample
    _count_on(problem, kicked)
    out, first = [], 0
    for e, a in zip(problem.exps, size):
        n = e.n_samples * e.measured.shape[1]
        out.append(response[first:first + n].reshape(e.n_samples, -1) / a if a > 0 else np.zeros((e.n_samples, 1)))
        first += n
    return out


def with_force_noise(problem: Problem, res, sds: np.ndarray, corr: np.ndarray,
                     scores: Sequence[np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``uncertainties``' standard deviations (value units) and correlations with the force
    channel's noise added (force_noise_covariance; ``scores``: force_noise_scores', where at hand);
    a variance the addition would make negative (the sandwich's reading of that noise above the
    rank one's) stays as it was."""
    scales = np.array([f.scale for f in problem.free])
    cov = corr * np.outer(sds, sds) + force_noise_covariance(problem, res, scores) * np.outer(scales, scales)
    var = np.diag(cov)
    sd = np.where(var > 0, np.sqrt(np.clip(var, 0, None)), sds)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.clip(cov / np.outer(sd, sd), -1, 1)
    np.fill_diagonal(out, 1.0)
    return sd, np.nan_to_num(out)


def _experiment_blocks(problem: Problem, n: int) -> list[tuple[int, int, int]] | None:
    """(first row, samples, channels) of each experiment's rows in the fit's residual (its strided
    samples, channels within a sample); None when the rows are laid out otherwise."""
    blocks, start = [], 0
    for e in problem.exps:
        m, c = len(range(0, e.n_samples, problem.stride)), e.measured.shape[1]
        blocks.append((start, m, c))
        start += m * c
    return blocks if start == n else None


#: half-width of the smoothing of the residual's cross-spectra, in the record's own frequency
#: resolution (1 / its duration): the raw periodogram at one frequency is one draw (two degrees
#: of freedom); averaged over 2 x 2 + 1 resolution bins, as Welch's averaging of five segments
#: would, while a resonance of the residual stays narrower than the window only where the record
#: resolves it no better
SPECTRAL_SMOOTHING_BINS = 2


def _score_length(m: int) -> int:
    """The transform length of residual_score_covariance for records of ``m`` samples: the least
    even 5-smooth number (pocketfft's fast lengths) of at least 2 m, so no lag wraps. The power
    of two above 2 m was up to 1.6x longer (two-body records of 5021 samples: 16384 against
    10240), and the transforms of the Jacobian's columns at that length were most of the
    sandwich's cost; the smoothing window keeps its width in the record's own resolution."""
    return 2 * scipy.fft.next_fast_len(m, real=True)


def residual_score_covariance(J: np.ndarray, r: np.ndarray, blocks: Sequence[tuple[int, int, int]],
                              at_rest: Sequence[np.ndarray] | None = None) -> np.ndarray:
    """Var(J^T r) for a residual whose noise is stationary within each experiment and independent
    between them: per experiment ``sum over frequencies of Re(J(f)^H S(f) J(f)) / N``, J(f) the
    discrete Fourier transform of the Jacobian's rows (zero-padded to N, so no lag wraps), S(f) the
    residual's cross-spectral matrix between the experiment's channels (they share the force's
    noise) from its periodogram smoothed over frequency (SPECTRAL_SMOOTHING_BINS): the raw
    periodogram is the product of the residual with itself, which a fit has made orthogonal to
    the Jacobian at zero lag. White noise of variance s2 gives ``s2 J^T J``. ``at_rest``: per
    block, residual rows before it whose Jacobian is zero (Problem.at_rest): they count in S(f)
    as part of the record. Rows of zeros before J's shift its transform by a phase common to its
    channels and parameters at each frequency, which J(f)^H S(f) J(f) does not see: J's own rows
    are transformed, zero-padded to the whole length."""
    p = J.shape[1]
    B = np.zeros((p, p))
    for b, (start, m, c) in enumerate(blocks):
        rows = slice(start, start + m * c)
        rest = None if at_rest is None or not len(at_rest[b]) else at_rest[b]
        resid = r[rows].reshape(m, c) if rest is None else np.concatenate([rest, r[rows].reshape(m, c)])
        m = resid.shape[0]
        nfft = _score_length(m)
        # scipy's transforms: numpy's numbers to the bit (the same pocketfft), a tenth faster on
        # the Jacobian's many columns
        R = scipy.fft.rfft(resid, nfft, axis=0)  # frequencies x channels
        G = scipy.fft.rfft(J[rows].reshape(-1, c, p), nfft, axis=0)  # frequencies x channels x parameters
        n_f = R.shape[0]
        width = 2 * int(round(SPECTRAL_SMOOTHING_BINS * nfft / m)) + 1
        # S(f) is the mean of the rank-one R R^H / m over the window about f (its edges reflected,
        # as scipy.ndimage's "reflect"), so J(f)^H S(f) J(f) is the mean of a a^H / m, a = J(f)^H
        # R(f + k): the channels' cross-spectral matrices are never formed (21 channels and 20
        # parameters: a tenth of the products)
        near = np.arange(n_f)[:, None] + np.arange(-(width // 2), width // 2 + 1)[None, :]
        near = near % (2 * n_f)  # mirrored as often as a window wider than a short record needs
        near = np.where(near >= n_f, 2 * n_f - 1 - near, near)
        # conj(a) (X X^H's real part is the same for conj(X)): the small R conjugated, not G; the
        # one-sided spectrum counts every frequency but zero and Nyquist twice (a carries the root)
        window = R.conj()[near]  # frequencies x window x channels
        root_twice = np.full(n_f, np.sqrt(2.0))
        root_twice[[0, -1]] = 1.0
        window *= root_twice[:, None, None]
        # a written straight into parameters x (frequencies, window), X's layout, whose real view
        # [Re, Im, Re, Im, ...] gives Re(X X^H) = X_re X_re^T + X_im X_im^T as one real product
        a = np.empty((p, n_f, width), complex)
        np.matmul(G.transpose(0, 2, 1), window.transpose(0, 2, 1), out=a.transpose(1, 0, 2))
        X = a.reshape(p, -1).view(np.float64)
        B += (X @ X.T) / (width * m * nfft)
    return (B + B.T) / 2


def validate(problem: Problem, u: np.ndarray, res) -> tuple[float, str]:
    """Held-out sum of squares, each fold refitted to its own minimum (``fit`` on the rows left
    in, its stops the fit's: within a noise energy of what a differenced Jacobian still promises)
    from the full fit, starting on the full fit's Jacobian's rows left in, then evaluated for real
    on the held-out data. A single linearised step from the full fit leapt along directions the
    rows left in barely see: the held-out error turned on where in the full fit's flat valley the
    start sat (a start 1e-7 apart in sum of squares moved it by 5 %).

    Shared parameters: leave one experiment out. Parameters of single experiments: held-out
    channels (alternate sensors), since a left-out experiment's own parameters are never fitted;
    with parameters of single sensors too (a mode's participation at each): alternate blocks of
    time, which leave every parameter some rows.
    """
    exps = problem.exps
    if problem.linear:
        return _validate_blocks(problem, u), f"held-out time blocks (alternate {1e3 * BLOCK_S:g} ms)"
    if not problem.free:
        # discrete choices only: choose on the others, score on the held-out experiment
        if len(exps) < 2:
            return problem.sse(u), "none (one experiment)"
        total = 0.0
        for i, e in enumerate(exps):
            rest = [x for j, x in enumerate(exps) if j != i]
            sub = Problem(problem.base, problem.effect, rest, {}, problem.prior, problem.stride,
                          noise_scale=problem.noise_scale)
            s = screen(sub, sub.sse(sub.zero()), ())
            held = Problem(problem.base, problem.effect, [e], s.fixed, problem.prior, problem.stride,
                           noise_scale=problem.noise_scale)
            total += held.sse(held.zero())
        return total, "leave one experiment out"
    n_data = res.fun.size - (len(problem.free) if problem.prior else 0)
    J, prior_rows = res.jac[:n_data], res.jac[n_data:]
    k = problem.stride
    sizes = [len(range(0, e.n_samples, k)) * e.measured.shape[1] for e in exps]
    # each fold: the experiments it is fitted on, its (strided) rows among theirs (None: all), and
    # the held-out experiments with the mask of their rows (every sample) it is scored on
    if (any(f.experiment is not None for f in problem.free) or len(exps) < 2) and any(
            f.param.sensor is not None for f in problem.free):
        # a sensor's own parameter is never fitted on held-out channels: hold out time instead
        def block(e, step):  # counted from the record's start: a window cut at rest keeps its blocks
            return np.repeat((e.first + np.arange(0, e.n_samples, step)) // max(1, int(round(BLOCK_S * e.fs))),
                             e.measured.shape[1])
        folds = [(exps, np.concatenate([block(e, k) % 2 != h for e in exps]), exps,
                  np.concatenate([block(e, 1) % 2 == h for e in exps])) for h in (0, 1)]
        how = f"held-out time blocks (alternate {1e3 * BLOCK_S:g} ms)"
    elif any(f.experiment is not None for f in problem.free) or len(exps) < 2:
        # an experiment may leave a clipped channel out: its columns are its own
        def col(e, step):
            return np.tile(np.arange(e.measured.shape[1]), len(range(0, e.n_samples, step)))
        folds = [(exps, np.concatenate([col(e, k) % 2 != h for e in exps]), exps,
                  np.concatenate([col(e, 1) % 2 == h for e in exps])) for h in (0, 1)]
        how = "held-out channels (alternate sensors)"
    else:
        folds = [([x for x in exps if x is not e], None, [e], None) for e in exps]
        how = "leave one experiment out"
    # the folds go as far as the fit went: to what its linearisation still promised at its end (a
    # fit stopped short of its minimum: _Stops' target and cannot_pass), else to its own least stop
    lo, hi = problem.lower_upper()
    short_of = _promise_within(u, res.jac.T @ res.jac, res.jac.T @ res.fun, lo, hi)
    total = 0.0
    for fitted, rows, held, scored in folds:
        # the full fit's Jacobian on the fold's rows is the fold's own at the start: differenced
        kept = rows if rows is not None else np.repeat([x is not held[0] for x in exps], sizes)
        fold = fit(problem, u, exps=fitted, continuation=False, rows=rows,
                   jac0=np.concatenate([J[kept], prior_rows]), short_of=short_of, secant_ends=True)
        r = problem.residual(fold.x, held, stride=1, weighted=False)
        total += float(np.sum(r * r if scored is None else r[scored] ** 2))
    return total, how


#: the blocks of time that validate a projected fit: short against a response's decay, long
#: against a period of the modes it is fitted to
BLOCK_S = 0.005


def _validate_blocks(problem: Problem, u: np.ndarray) -> float:
    """Held-out sum of squares of an effect with projected parameters: they are fitted on alternate
    blocks of time of every experiment and scored on the blocks between (the searched parameters
    stay at the fit). A projection cannot be scored on held-out channels or experiments: their own
    participations would never be fitted."""
    exps = problem.exps
    total = 0.0
    for held in (0, 1):
        masks = [(((e.first + np.arange(e.n_samples)) // max(1, int(round(BLOCK_S * e.fs)))) % 2) == held
                 for e in exps]
        _, _, deltas = problem.project(u, exps, [(~m).astype(float) for m in masks])
        for e, d, m in zip(exps, deltas, masks):
            r = (e.measured - problem.base_prediction(e) - d)[m]
            total += float(np.sum(r * r))
    return total
