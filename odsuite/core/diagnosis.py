"""Which physical effect does the model lack? Fit every registered effect, validate, rank.

Every registered effect (built-in or a lab's own) is a candidate. Fits see each record only up to
where its response has decayed into the noise (the rest is added back to reported errors). The
search runs in three passes:

1. *Screening*: each candidate's parameters are moved one small step from their nominal values
   (finite differences); one Gauss-Newton step, evaluated for real, says how much of the residual
   the candidate can take up. Parameters that the residual cannot see at their nominal value (a
   resonance frequency while its amplitude is zero) get a start from a grid and from the peaks of
   the residual spectrum; amplitudes that only act in products (a mode's participation at a
   sensor times at the force point) get one of them moved first; discrete parameters (a sensor's
   polarity) are tried one choice at a time.
2. *Fitting*: the promising candidates are fitted by output-error least squares over all
   experiments (scipy.optimize.least_squares, bounded); a candidate whose screening took up less
   than half of what the best fit explains is ranked by its screening alone.
3. *Validation*: shared parameters are validated by leaving one experiment out; per-experiment
   parameters (an impact location) on held-out channels. Candidates are ranked by validated error
   with a BIC penalty for their number of parameters. A candidate is ``significant`` only when its
   validated improvement is well beyond what the noise floor allows.

Parameters with an uncertainty comparable to their range are reported as not identifiable and held
at their nominal value; strongly correlated parameters and candidates whose fits change the
predictions the same way are named as confounded.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.optimize

from odsuite.core.comparison import (
    PreparedExperiment,
    noise_floor_error,
    predict,
    prepare,
)
from odsuite.core.errors import ConfigError
from odsuite.core.modelrev import RevisionModel, current_revision, revision_model

#: how many screened candidates get a full fit and validation
FULL_FITS = 4
#: a fitted parameter whose standard deviation exceeds this fraction of its range is not identifiable
UNIDENTIFIABLE_FRACTION = 0.1
#: parameter correlations above this are reported as confounded
CONFOUNDED_CORRELATION = 0.95
#: candidates whose prediction changes have at least this cosine similarity are named as confounded
CONFOUNDED_COSINE = 0.9
#: fits start on short heads of the records (s after the hit), then the whole record: a frequency
#: error makes the time-domain residual oscillate in the parameter, a short head keeps it convex
HEADS_S = (0.01, 0.04)


#: fits stop where the measured response has decayed into the noise: the record after that point
#: holds less excess energy (above the noise) than this fraction of the record's noise energy
TAIL_FRACTION = 0.05
#: ... plus a margin of this fraction of the response's length, and at least WINDOW_MIN_S
WINDOW_MARGIN = 0.25
WINDOW_MIN_S = 0.04


def fit_windows(exps: Sequence[PreparedExperiment]) -> list[PreparedExperiment]:
    """Each experiment cut where its response has died away into the noise (a hammer response
    decays within tens of milliseconds of records that last far longer): fits and screening see
    the same information for a fraction of the cost. The sum of squares of the rest is added back
    where an error is reported."""
    out = []
    for e in exps:
        power = np.sum(e.measured**2, axis=1)
        var = float(np.sum(e.noise_var))
        n = len(power)
        tail = np.cumsum(power[::-1])[::-1] - (n - np.arange(n)) * var
        above = np.flatnonzero(tail > TAIL_FRACTION * n * var)
        last = int(above[-1]) if above.size else e.trigger
        end = last + max(WINDOW_MARGIN * max(last - e.trigger, 0), WINDOW_MIN_S * e.fs)
        out.append(e.head(int(math.ceil(end))))
    return out


def heads(exps: Sequence[PreparedExperiment]) -> list[list[PreparedExperiment]]:
    """The experiments cut to each of HEADS_S after their hit, then whole."""
    stages = [[e.head(e.trigger + int(round(t * e.fs))) for e in exps] for t in HEADS_S]
    return stages + [list(exps)]


# ---------------------------------------------------------------------------------------------
# the fitting problem of one candidate


@dataclass
class _Free:
    """One free scalar of a fit: an effect parameter, shared or of one experiment."""

    param: Any  # odsuite_plugins.models.Parameter
    experiment: str | None
    scale: float

    @property
    def label(self) -> str:
        return self.param.name if self.experiment is None else f"{self.experiment}/{self.param.name}"

    def to_value(self, u: float) -> float:
        return float(np.clip(self.param.nominal + u * self.scale, self.param.lower, self.param.upper))

    @property
    def bounds(self) -> tuple[float, float]:
        p = self.param
        return (p.lower - p.nominal) / self.scale, (p.upper - p.nominal) / self.scale


def _scale(p) -> float:
    """A natural step for a parameter: 5 % of its size or of a tenth of its range."""
    span = p.upper - p.lower
    size = max(abs(p.nominal), span / 10.0) if np.isfinite(span) else max(abs(p.nominal), 1.0)
    return 0.05 * min(size, span) if span > 0 else 1.0


class Problem:
    """Residuals of one candidate effect on top of the current revision, over all experiments."""

    def __init__(self, base: RevisionModel, effect, exps: Sequence[PreparedExperiment],
                 fixed: Mapping[str, float] | None = None, prior: float = 0.0, stride: int = 1,
                 full: Sequence[PreparedExperiment] | None = None) -> None:
        self.base = base
        # ``exps`` are what the fit sees (usually fit windows); ``full`` the whole records they
        # were cut from, for reported errors
        self.full = list(full) if full is not None else list(exps)
        # fits see every stride-th sample: the signals are band-limited far below Nyquist, so the
        # sum of squares keeps its shape while the Jacobian shrinks
        self.stride = stride
        # a weak pull towards the nominal values (sum of squares per unit step squared): it decides
        # directions the data cannot see and keeps damped steps well posed; negligible elsewhere
        self.prior = prior
        self.effect = effect
        self.exps = list(exps)
        params = effect.parameters(base.shared)
        self.discrete = [p for p in params if p.choices is not None]
        self.fixed = dict(fixed or {})  # discrete choices and parameters held at a value
        self.free: list[_Free] = []
        for p in params:
            if p.choices is not None or p.name in self.fixed:
                continue
            if p.scope == "per_experiment":
                self.free += [_Free(p, e.name, _scale(p)) for e in self.exps]
            else:
                self.free.append(_Free(p, None, _scale(p)))
        self.evaluations = 0

    # values ------------------------------------------------------------------------------------
    def values(self, u: np.ndarray) -> tuple[dict[str, float], dict[str, dict[str, float]]]:
        shared = dict(self.fixed)
        per: dict[str, dict[str, float]] = {}
        for f, x in zip(self.free, u):
            if f.experiment is None:
                shared[f.param.name] = f.to_value(x)
            else:
                per.setdefault(f.experiment, {})[f.param.name] = f.to_value(x)
        return shared, per

    def models(self, u: np.ndarray) -> dict[str, Any]:
        shared, per = self.values(u)
        has_shared = any(f.experiment is None for f in self.free) or self.fixed or not self.free
        model = self.effect.apply(self.base.shared, shared) if has_shared else self.base.shared
        rm = RevisionModel(model, self.base.per_experiment)
        out = {}
        for e in self.exps:
            m = rm.for_experiment(e.name)
            if e.name in per:
                m = self.effect.apply(m, {**{k: v for k, v in shared.items()}, **per[e.name]})
            out[e.name] = m
        return out

    def predictions(self, u: np.ndarray, exps: Sequence[PreparedExperiment] | None = None) -> list[np.ndarray]:
        self.evaluations += 1
        models = self.models(u)
        return [predict(models[e.name], e) for e in (exps or self.exps)]

    # residuals ---------------------------------------------------------------------------------
    def residual(self, u: np.ndarray, exps: Sequence[PreparedExperiment] | None = None,
                 columns: Sequence[int] | None = None, stride: int | None = None) -> np.ndarray:
        exps = exps or self.exps
        k = self.stride if stride is None else stride
        preds = self.predictions(u, exps)
        parts = []
        for e, p in zip(exps, preds):
            r = (e.measured - p)[::k]
            parts.append((r if columns is None else r[:, columns]).ravel())
        return np.concatenate(parts)

    def sse(self, u: np.ndarray, exps: Sequence[PreparedExperiment] | None = None) -> float:
        """Sum of squares over every sample (the contract's error), not only the strided ones."""
        r = self.residual(u, exps, stride=1)
        return float(r @ r)

    def tail_sse(self, u: np.ndarray) -> float:
        """Sum of squares of the records outside the fit windows (nearly all noise)."""
        if all(f is e for f, e in zip(self.full, self.exps)):
            return 0.0
        return self.sse(u, self.full) - self.sse(u)

    def derived(self, fixed: Mapping[str, float]) -> Problem:
        """The same problem with other parameters fixed."""
        return Problem(self.base, self.effect, self.exps, fixed, self.prior, self.stride, self.full)

    def jacobian(self, u: np.ndarray, r0: np.ndarray, **kw) -> np.ndarray:
        J = np.empty((r0.size, len(self.free)))
        for i, f in enumerate(self.free):
            lo, hi = f.bounds
            h = 1.0 if u[i] + 1.0 <= hi else -1.0
            if not lo <= u[i] + h <= hi:
                h = 0.5 * (hi - u[i]) if hi - u[i] > u[i] - lo else -0.5 * (u[i] - lo)
            du = np.zeros_like(u)
            du[i] = h
            J[:, i] = -(self.residual(u + du, **kw) - r0) / h if h else 0.0
        return J

    def zero(self) -> np.ndarray:
        return np.zeros(len(self.free))

    def lower_upper(self) -> tuple[np.ndarray, np.ndarray]:
        b = np.array([f.bounds for f in self.free]).reshape(-1, 2)
        return b[:, 0], b[:, 1]


#: Levenberg-Marquardt damping tried in turn (relative to the Jacobian's diagonal) until a step
#: lowers the error: parameters of one effect may be redundant (a global scale spread over axes
#: and springs), which a plain Gauss-Newton step would turn into a leap to the bounds
LM_DAMPING = (1e-3, 1e-1, 1.0, 10.0)


def _lm_step(problem: Problem, J: np.ndarray, r: np.ndarray, u: np.ndarray, exps) -> np.ndarray:
    """The first damped Gauss-Newton step (r = measured - model, J = d model / d u) that lowers
    the error on ``exps``, clipped to the bounds; ``u`` when none does."""
    lo, hi = problem.lower_upper()
    # parameters the residual cannot see here stay put (a mode's frequency while its amplitudes are
    # zero): the linearisation says nothing about them
    act = ~_tiny(J, r)
    if not act.any():
        return u
    Ja, ua = J[:, act], u[act]
    JtJ = Ja.T @ Ja + problem.prior * np.eye(len(ua))
    g = Ja.T @ r - problem.prior * ua
    diag = np.diag(JtJ).copy()
    diag[diag <= 0] = max(float(diag.max(initial=0.0)), 1e-300)
    cost = float(r @ r) + problem.prior * float(u @ u)
    for lam in LM_DAMPING:
        u1 = u.copy()
        u1[act] += np.linalg.solve(JtJ + lam * np.diag(diag), g)
        u1 = np.clip(u1, lo, hi)
        if float(np.sum(problem.residual(u1, exps) ** 2)) + problem.prior * float(u1 @ u1) < cost:
            return u1
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


def _tiny(J: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Columns of a Jacobian that are zero (but for round-off) next to the others and the residual."""
    norms = np.linalg.norm(J, axis=0)
    scale = max(float(np.max(norms, initial=0.0)), float(np.linalg.norm(r)))
    return norms <= 1e-7 * (scale if scale > 0 else 1.0)


def _grid_starts(problem: Problem, r0: np.ndarray, J: np.ndarray, peaks_hz: Sequence[float]) -> list[np.ndarray]:
    """Starting points for parameters the residual cannot see at their nominal value: frequencies
    (unit Hz) and periods (unit s) from the residual's peaks and a logarithmic grid."""
    starts = []
    tiny = _tiny(J, r0)
    for i, f in enumerate(problem.free):
        if not tiny[i] or f.param.unit not in ("Hz", "s") or f.experiment is not None:
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


def _activation(problem: Problem, start: np.ndarray, r: np.ndarray, J: np.ndarray, exps
                ) -> tuple[int, float] | None:
    """Products of amplitudes (a mode's participation at a sensor times at the force point) are
    invisible at zero, one at a time. Among the amplitudes (nominal 0) that are still invisible at
    ``start``, the one whose Jacobian column is largest when all of them are moved at once couples
    to the most others: moved alone, it makes the rest linear. Returns its index and value."""
    tiny = _tiny(J, r)
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


def screen(problem: Problem, sse0: float, peaks_hz: Sequence[float]) -> Screened:
    """Best start found by one Gauss-Newton step (and grids/choices where needed)."""
    effect = problem.effect
    best_fixed: dict[str, float] = {}
    best_u = problem.zero()
    best_sse = sse0
    # discrete parameters: each choice alone, then greedily combined
    chosen: dict[str, float] = {}
    for _ in range(3):
        trial_best = None
        for p in problem.discrete:
            if p.name in chosen:
                continue
            for c in p.choices:
                if c == p.nominal:
                    continue
                trial = problem.derived({**chosen, p.name: c})
                sse = trial.sse(trial.zero())
                if trial_best is None or sse < trial_best[0]:
                    trial_best = (sse, p.name, c)
        if trial_best is None or trial_best[0] >= best_sse * 0.999:
            break
        best_sse = trial_best[0]
        chosen[trial_best[1]] = trial_best[2]
        best_fixed = dict(chosen)
    if best_fixed:
        problem = problem.derived(best_fixed)
    if problem.free:
        stages = heads(problem.exps)
        first = stages[0]
        u0 = problem.zero()
        r0 = problem.residual(u0, first)
        J0 = problem.jacobian(u0, r0, exps=first)
        # the best start on the shortest head, then one damped step on each longer head
        best_start, best_head = u0, float(r0 @ r0)
        activation: tuple[int, float] | None = None
        for start in [u0] + _grid_starts(problem, r0, J0, peaks_hz):
            r = r0 if start is u0 else problem.residual(start, first)
            J = J0 if start is u0 else problem.jacobian(start, r, exps=first)
            if start is not u0:
                activation = activation or _activation(problem, start, r, J, first)
                if activation is not None and _tiny(J, r)[activation[0]]:
                    start = start.copy()
                    start[activation[0]] = activation[1]
                    r = problem.residual(start, first)
                    J = problem.jacobian(start, r, exps=first)
            u = _lm_step(problem, J, r, start, first)
            sse = float(np.sum(problem.residual(u, first) ** 2))
            if sse < best_head:
                best_start, best_head = u, sse
        u = best_start
        for exps in stages[1:]:
            r = problem.residual(u, exps)
            u = _lm_step(problem, problem.jacobian(u, r, exps=exps), r, u, exps)
        sse = problem.sse(u)
        if sse < best_sse:
            best_sse, best_u = sse, u
    return Screened(effect, best_fixed, best_u, best_sse, problem)


# ---------------------------------------------------------------------------------------------
# fitting and validation


def fit(problem: Problem, u0: np.ndarray, *, exps: Sequence[PreparedExperiment] | None = None,
        columns: Sequence[int] | None = None, max_nfev: int | None = None, continuation: bool = True):
    """Bounded output-error least squares from ``u0`` (on short heads of the records first);
    returns scipy's result for the whole records."""
    lo, hi = problem.lower_upper()
    u = np.clip(u0, lo, hi)
    n = len(problem.free)
    stages = heads(exps or problem.exps) if continuation else [list(exps or problem.exps)]
    for k, stage in enumerate(stages):
        last = k == len(stages) - 1
        root = math.sqrt(problem.prior)
        res = scipy.optimize.least_squares(
            lambda x: np.concatenate([problem.residual(x, stage, columns), root * x]) if root
            else problem.residual(x, stage, columns), u, bounds=(lo, hi), method="trf",
            x_scale=1.0, diff_step=1e-4, max_nfev=max_nfev or (8 if last else 4) * (n + 1),
            xtol=1e-6, ftol=1e-8,
        )
        u = res.x
    return res


def _effective_samples(exps: Sequence[PreparedExperiment]) -> tuple[float, float]:
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


@dataclass
class Candidate:
    effect: str
    significant: bool
    error_after: float
    validated_error: float
    parameters: dict[str, float | None]
    uncertainties: dict[str, float | None]
    units: dict[str, str]
    evidence: str
    n_parameters: int
    bic: float
    screened_error: float
    unidentifiable: list[str] = field(default_factory=list)
    confounded_parameters: list[list[str]] = field(default_factory=list)
    confounded_with: list[str] = field(default_factory=list)
    validation: str = ""
    fitted: bool = True
    per_experiment: dict[str, dict[str, float]] = field(default_factory=dict)
    values: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        d = {k: getattr(self, k) for k in (
            "effect", "significant", "error_after", "validated_error", "parameters", "uncertainties",
            "units", "evidence", "n_parameters", "bic", "screened_error", "unidentifiable",
            "confounded_parameters", "confounded_with", "validation", "fitted")}
        return d

    def revision_entry(self) -> dict[str, Any]:
        """How add-effect stores this fit in a model revision."""
        return {"effect": self.effect, "values": dict(self.values), "per_experiment": self.per_experiment,
                "uncertainties": {k: v for k, v in self.uncertainties.items() if v is not None}}


def _uncertainties(problem: Problem, res, n_eff: float) -> tuple[np.ndarray, np.ndarray, list[list[str]]]:
    """Standard deviations (value units), correlations and redundant groups at the fit.

    The residual variance is inflated by N / N_eff for the samples' correlation. Directions the
    data cannot see at all (an effect whose parameters overlap, e.g. a global scale spread over axes
    and springs) are left out of the covariance (pseudo-inverse) and reported as groups whose
    combination alone is determined.
    """
    J = res.jac[: res.jac.shape[0] - len(problem.free)] if problem.prior else res.jac
    n, p = J.shape
    s2 = float(np.sum(res.fun[:n] ** 2)) / max(1, n - p) * (n / n_eff)
    JtJ = J.T @ J
    w, V = np.linalg.eigh(JtJ)
    null = w <= 1e-8 * max(float(w.max(initial=0.0)), 1e-300)
    groups = []
    for k in np.flatnonzero(null):
        members = [problem.free[i].label for i in np.flatnonzero(np.abs(V[:, k]) > 0.2)]
        if len(members) > 1 and members not in groups:
            groups.append(members)
    inv_w = np.where(null, 0.0, 1.0 / np.where(null, 1.0, w))
    cov = s2 * (V * inv_w) @ V.T
    sd_u = np.sqrt(np.clip(np.diag(cov), 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd_u, sd_u)
    scales = np.array([f.scale for f in problem.free])
    return sd_u * scales, np.nan_to_num(corr), groups


def _validate(problem: Problem, u: np.ndarray, res) -> tuple[float, str]:
    """Held-out sum of squares, each fold refitted by one Gauss-Newton step from the full fit with
    the fold's own rows removed (at the optimum the rows left in pull by exactly minus the held-out
    rows' gradient), then evaluated for real on the held-out data.

    Shared parameters: leave one experiment out. Parameters of single experiments: held-out
    channels (alternate sensors), since a left-out experiment's own parameters are never fitted.
    """
    exps = problem.exps
    if not problem.free:
        # discrete choices only: choose on the others, score on the held-out experiment
        if len(exps) < 2:
            return problem.sse(u), "none (one experiment)"
        total = 0.0
        for i, e in enumerate(exps):
            rest = [x for j, x in enumerate(exps) if j != i]
            sub = Problem(problem.base, problem.effect, rest, {}, problem.prior, problem.stride)
            s = screen(sub, sub.sse(sub.zero()), ())
            held = Problem(problem.base, problem.effect, [e], s.fixed, problem.prior, problem.stride)
            total += held.sse(held.zero())
        return total, "leave one experiment out"
    n_data = res.fun.size - (len(problem.free) if problem.prior else 0)
    J, r = res.jac[:n_data], res.fun[:n_data]
    k = problem.stride
    sizes = [len(range(0, e.n_samples, k)) * e.measured.shape[1] for e in exps]
    starts = np.concatenate([[0], np.cumsum(sizes)])
    ncols = exps[0].measured.shape[1]
    if any(f.experiment is not None for f in problem.free) or len(exps) < 2:
        col = np.concatenate([np.tile(np.arange(e.measured.shape[1]), n // e.measured.shape[1])
                              for e, n in zip(exps, sizes)])
        folds = [(col % 2 == h, list(range(h, ncols, 2)), None) for h in (0, 1)]
        how = "held-out channels (alternate sensors)"
    else:
        folds = []
        for i, e in enumerate(exps):
            rows = np.zeros(n_data, bool)
            rows[starts[i]:starts[i + 1]] = True
            folds.append((rows, None, e))
        how = "leave one experiment out"
    lo, hi = problem.lower_upper()
    H = J.T @ J + problem.prior * np.eye(len(u))
    total = 0.0
    for rows, cols, exp in folds:
        Jh, rh = J[rows], r[rows]
        # r = measured - model and res.jac = d r / d u: the kept rows' step is -(H_kept)^-1 J_h^T r_h
        step = np.linalg.lstsq(H - Jh.T @ Jh, Jh.T @ rh, rcond=1e-10)[0]
        u_fold = np.clip(u + step, lo, hi)
        if exp is not None:
            total += problem.sse(u_fold, [exp])
        else:
            held = np.concatenate([(e.measured - p)[:, cols].ravel()
                                   for e, p in zip(exps, problem.predictions(u_fold))])
            total += float(held @ held)
    return total, how


def _describe_values(problem: Problem, values: Mapping[str, float | None], sds: Mapping[str, float | None],
                     limit: int = 3) -> str:
    moved = []
    for f in problem.free:
        v = values.get(f.label)
        if v is None:
            continue
        moved.append((abs(v - f.param.nominal) / f.scale, f, v, sds.get(f.label)))
    moved.sort(key=lambda t: -t[0])
    parts = []
    for _, f, v, sd in moved[:limit]:
        unit = "" if f.param.unit in ("1", "") else f" {f.param.unit}"
        pm = f" ± {sd:.3g}" if sd is not None and np.isfinite(sd) else ""
        parts.append(f"{f.label} = {v:.4g}{pm}{unit} (nominal {f.param.nominal:g})")
    for name, c in problem.fixed.items():
        parts.append(f"{name} = {c:g}")
    return "; ".join(parts)


def _evidence(problem: Problem, cand: Candidate, baseline: float, noise: float,
              peaks: Sequence[Mapping[str, Any]], rigidity: float | None, modes_before, modes_after) -> str:
    words = []
    freq = next((v for k, v in cand.parameters.items() if k.endswith("frequency_hz") and v is not None), None)
    if freq is not None:
        near = [p for p in peaks if abs(p["frequency_hz"] - freq) <= 0.1 * freq]
        if near and near[0]["lacking"]:
            words.append(f"a resonance at {near[0]['frequency_hz']:.0f} Hz in the "
                         f"{', '.join(near[0]['channels'][:4])} channels that no model mode explains")
    if rigidity is not None and rigidity > 0.1 and problem.effect.name.startswith(("plate", "sensor")):
        words.append(f"rigidity residual {100 * rigidity:.0f} %")
    if modes_before is not None and modes_after is not None and len(modes_before) == len(modes_after) and len(modes_before):
        shift = np.asarray(modes_after) / np.asarray(modes_before)
        if np.max(np.abs(shift - 1)) > 0.01:
            words.append(f"model modes move from {modes_before[0]:.0f}-{modes_before[-1]:.0f} Hz to "
                         f"{modes_after[0]:.0f}-{modes_after[-1]:.0f} Hz")
    desc = _describe_values(problem, cand.parameters, cand.uncertainties)
    if desc:
        words.append(f"fitted {desc}")
    words.append(f"validated error {baseline:.3g} -> {cand.validated_error:.3g} ({cand.validation}); "
                 f"noise floor {noise:.3g}")
    for group in cand.confounded_parameters:
        words.append(f"only the combination of {', '.join(group)} is determined")
    if cand.unidentifiable:
        words.append(f"not identifiable from these data: {', '.join(cand.unidentifiable)}")
    return "; ".join(words)


@dataclass
class Diagnosis:
    baseline_error: float
    noise_floor_error: float
    revision: int | None
    candidates: list[Candidate]
    residual_peaks: list[dict[str, Any]]
    evaluations: int

    def as_dict(self) -> dict[str, Any]:
        return {"baseline_error": self.baseline_error, "noise_floor_error": self.noise_floor_error,
                "revision": self.revision, "candidates": [c.as_dict() for c in self.candidates],
                "residual_peaks": self.residual_peaks, "model_evaluations": self.evaluations}


def _fit_candidate(screened: Screened, exps, sse0: float, den: float, n_eff: float, noise: float,
                   peaks, rigidity, modes_before, tail0: float = 0.0) -> Candidate:
    """Fit, validate and describe one screened candidate. Sums of squares of ``screened`` are over
    the fit windows; ``tail0`` is the rest of the records' at the nominal model, ``sse0`` whole."""
    problem = screened.problem
    effect = problem.effect
    if problem.free:
        # screening has already stepped through the short heads to the whole windows
        res = fit(problem, screened.u0, continuation=False)
        u = res.x
        sds, corr, groups = _uncertainties(problem, res, n_eff)
        unident = [f.label for f, sd in zip(problem.free, sds)
                   if not np.isfinite(sd) or sd > UNIDENTIFIABLE_FRACTION * (f.param.upper - f.param.lower)]
        if unident and len(unident) < len(problem.free):
            # hold what the data cannot see at its nominal value and refit the rest
            held = {f.param.name: f.param.nominal for f in problem.free
                    if f.label in unident and f.experiment is None}
            if held:
                problem = problem.derived({**screened.fixed, **held})
                keep = [i for i, f in enumerate(screened.problem.free) if f.param.name not in held]
                res = fit(problem, u[keep], continuation=False)
                u = res.x
                sds, corr, groups = _uncertainties(problem, res, n_eff)
        sse = problem.sse(u)
        confounded = groups + [[problem.free[i].label, problem.free[j].label]
                               for i in range(len(problem.free)) for j in range(i + 1, len(problem.free))
                               if abs(corr[i, j]) > CONFOUNDED_CORRELATION
                               and not any(problem.free[i].label in g and problem.free[j].label in g
                                           for g in groups)]
    else:
        u = problem.zero()
        sse = screened.sse
        sds, unident, confounded = np.zeros(0), [], []
    sse_win = sse
    tail = problem.tail_sse(u)
    sse += tail
    shared, per = problem.values(u)
    params: dict[str, float | None] = {}
    uncert: dict[str, float | None] = {}
    units: dict[str, str] = {}
    for f, sd in zip(problem.free, sds):
        params[f.label] = f.to_value(u[problem.free.index(f)])
        uncert[f.label] = float(sd) if np.isfinite(sd) else None
        units[f.label] = f.param.unit
    for name in unident:
        params.setdefault(name, None)
    for name, c in problem.fixed.items():
        params[name] = c
        uncert[name] = None
    sse_val, how = _validate(problem, u, res if problem.free else None)
    sse_val += tail
    k = len(problem.free) + len(problem.fixed)
    bic = n_eff * math.log(max(sse_val, 1e-300) / den) + k * math.log(n_eff)
    modes_after = None
    if effect.target == "model" and shared:
        modes_after = list(problem.models(u)[exps[0].name].modes().frequency_hz)
    cand = Candidate(
        effect=effect.name, significant=False, error_after=math.sqrt(sse / den),
        validated_error=math.sqrt(sse_val / den), parameters=params, uncertainties=uncert, units=units,
        evidence="", n_parameters=k, bic=bic, screened_error=math.sqrt((screened.sse + tail0) / den),
        unidentifiable=unident, confounded_parameters=confounded, validation=how,
        per_experiment=per, values={n: v for n, v in shared.items()},
    )
    cand._problem, cand._u, cand._sse_win = problem, u, sse_win  # kept for the confounding check
    baseline = math.sqrt(sse0 / den)
    cand.evidence = _evidence(problem, cand, baseline, noise, peaks, rigidity, modes_before, modes_after)
    return cand


def is_significant(baseline: float, validated: float, noise: float, bic_gain: float) -> bool:
    """Validated improvement well beyond the noise: more than the whole noise energy, more than 10 %
    of the excess over the noise floor, and a lower BIC than the model without the effect."""
    gain = baseline**2 - validated**2
    excess = max(baseline**2 - noise**2, 0.0)
    return gain > max(noise**2, 1e-4, 0.1 * excess) and bic_gain > 0


class _Deferred:
    """A call run when its result is asked for: a fit that is never asked for costs nothing."""

    def __init__(self, fn: Callable, args: tuple) -> None:
        self._fn, self._args = fn, args

    def cancel(self) -> bool:
        return True

    def result(self) -> Any:
        return self._fn(*self._args)


class _InOrder:
    """The part of concurrent.futures' executor interface diagnose uses, one call after another
    in this thread (workers=1)."""

    def __enter__(self) -> _InOrder:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    def map(self, fn: Callable, items) -> Any:
        return map(fn, items)

    def submit(self, fn: Callable, *args: Any) -> _Deferred:
        return _Deferred(fn, args)


def _own_copies(exps: Sequence[PreparedExperiment]) -> list[PreparedExperiment]:
    """Shallow copies with an empty simulation cache: a candidate running in its own thread must
    not see another thread's cache entry change between its check and its use."""
    return [replace(e, _cache=None) for e in exps]


def diagnose(project, *, effects: Sequence[str] | None = None, experiments: Sequence[str] | None = None,
             full_fits: int = FULL_FITS, progress: Callable[[str, int, int], None] | None = None,
             prepared: Sequence[PreparedExperiment] | None = None, workers: int | None = None) -> Diagnosis:
    """Rank every registered effect (or ``effects``) by how much of the model's error it explains.

    Candidates are screened and fitted on ``workers`` threads (default 1: one after another).
    Each candidate's work is independent of the others' and runs in the same order of operations,
    so the result does not depend on ``workers``."""
    from odsuite.core.comparison import compare
    from odsuite.core.plugins import registries

    if workers is not None and workers < 1:
        raise ConfigError(f"diagnose: workers must be at least 1, got {workers}")
    regs = registries()
    rev = current_revision(project)
    base = revision_model(project, rev)
    exps = list(prepared) if prepared is not None else prepare(project, experiments)
    in_model = {e["effect"] for e in rev.get("effects", [])}
    names = list(effects) if effects else [n for n in regs.effects.names() if n not in in_model]
    if not names:
        raise ConfigError(f"{project.path}: no candidate effects left to try (registered: "
                          f"{', '.join(regs.effects.names()) or 'none'})")
    cmp = compare(project, revision=rev, prepared=exps, resonances=False)
    den = sum(float(np.sum(e.measured**2)) for e in exps)
    sse0 = cmp.error**2 * den
    windows = fit_windows(exps)
    sse0_win = sum(float(np.sum((w.measured - predict(base.for_experiment(w.name), w)) ** 2)) for w in windows)
    tail0 = max(sse0 - sse0_win, 0.0)
    noise = noise_floor_error(exps)
    n_eff, f99 = _effective_samples(exps)
    stride = max(1, int(exps[0].fs / (5.0 * f99)))
    prior = 1e-3 * max(noise**2, 1e-8) * den
    peaks = cmp.residual_peaks
    peak_hz = [p["frequency_hz"] for p in peaks if p["lacking"]]
    rig_vals = [max(b["fractions"].values()) for per in cmp.rigidity.values() for b in per.values()
                if b["fractions"]]
    rigidity = float(np.median(rig_vals)) if rig_vals else None
    modes_before = list(base.shared.modes().frequency_hz)

    # one thread by default: on 2 cores, 2 threads took 0.8-1.2x the serial time (bench_batch.py),
    # as each model evaluation's Python work holds the GIL; many projects scale through `batch`
    threads = workers or 1
    parallel = threads > 1

    def screen_one(name: str) -> tuple[Screened, int] | None:
        own_windows, own_exps = (_own_copies(windows), _own_copies(exps)) if parallel else (windows, exps)
        try:
            problem = Problem(base, regs.effects.get(name), own_windows, prior=prior / stride, stride=stride,
                              full=own_exps)
        except ConfigError:
            return None  # the effect does not apply to this rig (e.g. no base plate)
        s = screen(problem, sse0_win, peak_hz)
        return s, problem.evaluations + (s.problem.evaluations if s.problem is not problem else 0)

    def fit_one(s: Screened) -> Candidate:
        return _fit_candidate(s, windows, sse0, den, n_eff, noise, peaks, rigidity, modes_before, tail0)

    screened: list[Screened] = []
    evaluations = 0
    # the candidates are independent: numpy and scipy release the GIL in much of their work
    with ThreadPoolExecutor(max_workers=threads) if parallel else _InOrder() as pool:
        for i, (name, done) in enumerate(zip(names, pool.map(screen_one, names))):
            if progress:
                progress(f"screening {name}", i, len(names))
            if done is not None:
                screened.append(done[0])
                evaluations += done[1]
        screened.sort(key=lambda s: s.sse)
        candidates: list[Candidate] = []
        top = screened[:full_fits]
        best_win = sse0_win
        fitted = []

        def skipped(k: int) -> bool:
            # a candidate whose screening took up less than half of what the best fit so far
            # explains cannot compete: screening only ranks it. best_win only falls, so a
            # candidate skipped before the fits ahead of it have finished stays skipped
            return k > 0 and top[k].sse > best_win + 0.5 * (sse0_win - best_win)

        jobs: dict[int, Any] = {}
        queued = 0
        for i, s in enumerate(top):
            while queued < min(len(top), i + threads):  # keep the pool's threads busy ahead of i
                if not skipped(queued):
                    jobs[queued] = pool.submit(fit_one, top[queued])
                queued += 1
            if i not in jobs or skipped(i):
                if i in jobs:
                    jobs[i].cancel()
                continue
            fitted.append(s)
            if progress:
                progress(f"fitting {s.effect.name}", i, len(top))
            cand = jobs[i].result()
            best_win = min(best_win, cand._sse_win)
            evaluations += cand._problem.evaluations
            bic0 = n_eff * math.log(max(sse0, 1e-300) / den)
            cand.significant = is_significant(cmp.error, cand.validated_error, noise, bic0 - cand.bic)
            candidates.append(cand)
    for s in screened:
        if any(s is f for f in fitted):
            continue
        err = math.sqrt((s.sse + tail0) / den)
        candidates.append(Candidate(
            effect=s.effect.name, significant=False, error_after=err,
            validated_error=float("nan"), parameters={}, uncertainties={}, units={},
            evidence=f"screening only: one linearised step reaches error {err:.3g}",
            n_parameters=len(s.problem.free), bic=float("inf"), screened_error=err,
            fitted=False))
    _mark_confounded([c for c in candidates if c.fitted], exps)
    candidates.sort(key=lambda c: (not c.significant, c.bic if c.fitted else math.inf, c.screened_error))
    if progress:
        progress("done", len(names), len(names))
    return Diagnosis(baseline_error=cmp.error, noise_floor_error=noise, revision=rev.get("revision"),
                     candidates=candidates, residual_peaks=peaks, evaluations=evaluations)


def _mark_confounded(cands: Sequence[Candidate], exps) -> None:
    """Candidates whose fits change the predictions in nearly the same way cannot be told apart by
    these experiments; name each other."""
    changes = {}
    for c in cands:
        if c.error_after >= c.screened_error * 1.5:
            continue
        p = c._problem
        base_pred = np.concatenate([x.ravel() for x in p.predictions(np.zeros(0) if not p.free else p.zero())])
        fit_pred = np.concatenate([x.ravel() for x in p.predictions(c._u)])
        changes[c.effect] = fit_pred - base_pred
    names = list(changes)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            va, vb = changes[a], changes[b]
            na, nb = np.linalg.norm(va), np.linalg.norm(vb)
            if na == 0 or nb == 0:
                continue
            if abs(va @ vb) / (na * nb) > CONFOUNDED_COSINE:
                ca = next(c for c in cands if c.effect == a)
                cb = next(c for c in cands if c.effect == b)
                ca.confounded_with.append(b)
                cb.confounded_with.append(a)


# ---------------------------------------------------------------------------------------------
# add-effect: fit the named effect together with the revision's own, store a new revision


class _Joint:
    """Several effects as one: parameters named "<effect>.<parameter>", applied in order."""

    def __init__(self, effects: Sequence[Any]) -> None:
        self.effects = list(effects)
        self.name = "+".join(e.name for e in self.effects)
        self.target = "model" if any(e.target == "model" for e in self.effects) else "chain"

    def parameters(self, model) -> list:
        from dataclasses import replace

        return [replace(p, name=f"{e.name}.{p.name}") for e in self.effects for p in e.parameters(model)]

    def apply(self, model, values: Mapping[str, float]):
        for e in self.effects:
            own = {k.split(".", 1)[1]: v for k, v in values.items() if k.split(".", 1)[0] == e.name}
            model = e.apply(model, own)
        return model


def _start(problem: Problem, entries: Sequence[Mapping[str, Any]]) -> np.ndarray:
    """The normalised start of a joint problem from stored revision entries."""
    u = problem.zero()
    for i, f in enumerate(problem.free):
        eff, name = f.param.name.split(".", 1)
        entry = next((e for e in entries if e["effect"] == eff), None)
        if entry is None:
            continue
        v = (entry.get("per_experiment", {}).get(f.experiment, {}) if f.experiment else entry.get("values", {})).get(name)
        if v is not None:
            u[i] = (float(v) - f.param.nominal) / f.scale
    return u


def add_effect(project, name: str, *, progress: Callable[[str, int, int], None] | None = None) -> dict[str, Any]:
    """Fit effect ``name`` together with the current revision's effects (all their parameters
    refitted) and store the result as a new revision, made current. Returns the new revision's
    number, its error and the previous error."""
    from odsuite.core.comparison import compare
    from odsuite.core.modelrev import base_model
    from odsuite.core.plugins import registries

    regs = registries()
    effect = regs.effects.get(name)
    rev = current_revision(project)
    entries = [e for e in rev.get("effects", []) if e["effect"] != name]
    exps = prepare(project)
    den = sum(float(np.sum(e.measured**2)) for e in exps)
    noise = noise_floor_error(exps)
    n_eff, f99 = _effective_samples(exps)
    stride = max(1, int(exps[0].fs / (5.0 * f99)))
    prior = 1e-3 * max(noise**2, 1e-8) * den / stride
    cmp = compare(project, revision=rev, prepared=exps, resonances=False)
    before = cmp.error
    windows = fit_windows(exps)
    if progress:
        progress(f"screening {name}", 0, 3)
    current = revision_model(project, {**rev, "effects": entries})
    single = Problem(current, effect, windows, prior=prior, stride=stride, full=exps)
    screened = screen(single, single.sse(single.zero()),
                      [p["frequency_hz"] for p in cmp.residual_peaks if p["lacking"]])
    joint_effects = [regs.effects.get(e["effect"]) for e in entries] + [effect]
    fixed = {f"{e['effect']}.{k}": v for e in entries for k, v in e.get("values", {}).items()
             if any(p.name == k and p.choices for p in regs.effects.get(e["effect"]).parameters(current.shared))}
    fixed.update({f"{name}.{k}": v for k, v in screened.fixed.items()})
    joint = Problem(RevisionModel(base_model(project.rig, rev.get("model"))), _Joint(joint_effects), windows,
                    fixed, prior, stride, full=exps)
    u0 = _start(joint, entries)
    for i, f in enumerate(joint.free):  # the new effect starts where screening left it
        if f.param.name.startswith(f"{name}."):
            k = next((j for j, g in enumerate(screened.problem.free)
                      if g.param.name == f.param.name.split(".", 1)[1] and g.experiment == f.experiment), None)
            if k is not None:
                u0[i] = screened.u0[k]
    if progress:
        progress(f"fitting {', '.join(e.name for e in joint_effects)}", 1, 3)
    res = fit(joint, u0) if joint.free else None
    u = res.x if res is not None else joint.zero()
    sds = _uncertainties(joint, res, n_eff)[0] if res is not None else np.zeros(0)
    shared, per = joint.values(u)
    new_entries = []
    flat: dict[str, float] = {}
    for e in joint_effects:
        prefix = f"{e.name}."
        values = {k[len(prefix):]: v for k, v in shared.items() if k.startswith(prefix)}
        per_exp = {x: {k[len(prefix):]: v for k, v in d.items() if k.startswith(prefix)} for x, d in per.items()}
        per_exp = {x: d for x, d in per_exp.items() if d}
        unc = {f.label[len(prefix):] if f.experiment is None else f"{f.experiment}/{f.param.name[len(prefix):]}": float(sd)
               for f, sd in zip(joint.free, sds) if f.param.name.startswith(prefix) and np.isfinite(sd)}
        new_entries.append({"effect": e.name, "values": values, "per_experiment": per_exp, "uncertainties": unc})
        flat.update({f"{e.name}.{k}": v for k, v in values.items()})
    if progress:
        progress("comparing", 2, 3)
    candidate_rev = {"model": rev.get("model"), "effects": new_entries}
    after = compare(project, revision=candidate_rev, prepared=exps, resonances=False)
    metrics = {"error": after.error, "noise_floor_error": after.noise_floor_error, "added": name,
               "previous_error": before}
    n = project.add_model_revision(new_entries, flat, metrics, rev["revision"], model=rev.get("model"))
    return {"revision": n, "effect": name, "error": after.error, "previous_error": before,
            "noise_floor_error": after.noise_floor_error, "effects": new_entries}
