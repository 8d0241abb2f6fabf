"""Checks that separate a cause from a proxy, against the calibrated noise floor
(:mod:`odsuite.analysis.noise_floor`): is a candidate's gain beyond what fitting its parameters to noise
would give (``significant``), do its parameters fitted to each experiment alone agree
(``consistent``; a spread that follows the force level is amplitude dependence), do they lie in the
physical range the effect declares (``plausible``), which candidates explain the same residual
within the noise (``confounded_with``), and whether a fit to the records' early (large) part
predicts their late (small) part (``held_out``: a stand-in for amplitude-dependent physics does not).

Residual samples are correlated (filtered signals, systematic misfit): uncertainties use the
effective number of independent samples from each residual's autocorrelation, not white-noise
formulas.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.optimize
import scipy.stats

from odsuite.analysis import resolved as resolution
from odsuite.analysis.noise_floor import FLOOR_TOLERANCE

#: probability that noise alone passes a test here: a candidate's gain, a parameter's spread over
#: the experiments, the slope of a parameter against the force level
FALSE_ALARM = 1e-3


def effective_samples(residual: np.ndarray) -> float:
    """Independent samples in a residual (samples x columns): per column n / (1 + 2 sum rho_k),
    the autocorrelations summed while positive (Geyer's initial positive sequence: later lags
    are noise)."""
    r = np.atleast_2d(np.asarray(residual, float).T).T
    total = 0.0
    n = r.shape[0]
    if n < 4:
        return float(r.size)
    for col in r.T:
        col = col - col.mean()
        var = float(col @ col)
        if var <= 0:
            continue
        nfft = 1 << int(np.ceil(np.log2(2 * n)))
        spec = np.abs(np.fft.rfft(col, nfft)) ** 2
        acf = np.fft.irfft(spec, nfft)[: n // 2] / var
        neg = np.flatnonzero(acf[1:] <= 0)
        upto = int(neg[0]) + 1 if neg.size else len(acf)
        total += n / max(1.0, 1.0 + 2.0 * float(np.sum(acf[1:upto])))
    return max(total, 1.0)


def residual_effective_samples(problem, res) -> float:
    """Independent samples in a fit's residual, from each experiment's residual autocorrelation
    (on the strided samples the fit sees, as its Jacobian): what its uncertainties are scaled by."""
    n_data = res.fun.size - (len(problem.free) if problem.prior else 0)
    total, start = 0.0, 0
    for e in problem.exps:
        size = len(range(0, e.n_samples, problem.stride)) * e.measured.shape[1]
        total += effective_samples(res.fun[start:start + size].reshape(-1, e.measured.shape[1]))
        start += size
    return min(total, float(n_data))


def noise_scale(floor, exps: Sequence) -> float:
    """Noise energy per independent sample of the floor (physical units squared): the floor's
    energy over its effective samples, these from the spectral flatness of its spectra
    (N (sum S)^2 / (bins sum S^2): N for white noise, fewer for band-limited noise)."""
    energy = n_eff = 0.0
    for e in exps:
        chans = floor.energy.get(e.name, {})
        energy += sum(chans.values())
        if e.name in floor.spectra:
            s = floor.spectra[e.name][1]
            flat = np.sum(s, axis=0) ** 2 / (s.shape[0] * np.maximum(np.sum(s**2, axis=0), 1e-300))
            n_eff += float(np.sum(e.n_samples * np.clip(flat, 1.0 / s.shape[0], 1.0)))
        else:
            n_eff += e.n_samples * len(e.sensors)
    return energy / max(n_eff, 1.0)


def gain_threshold(scale: float, k: int) -> float:
    """The gain in sum of squares that fitting ``k`` parameters to noise exceeds with probability
    FALSE_ALARM (chi-square with k degrees of freedom, per independent sample's noise energy)."""
    return scale * float(scipy.stats.chi2.isf(FALSE_ALARM, max(k, 1)))


@dataclass
class Consistency:
    consistent: bool
    per_experiment: dict[str, dict[str, float]] = field(default_factory=dict)
    spread: dict[str, float] = field(default_factory=dict)  # chi-square / its limit, per parameter
    amplitude_dependent: list[str] = field(default_factory=list)
    #: the sum of squares (every sample, whitened as the fit's residual) fitting per experiment would remove
    gain: float = 0.0


#: values needed to see a trend with the force level: a line through three leaves one degree of
#: freedom, and three scattered values sorted by level pass it too often
AMPLITUDE_LEVELS = 4


def consistency(problem, res, force_levels: Mapping[str, float], tolerated: float | None = None,
                force_noise: Sequence[np.ndarray] | None = None) -> Consistency:
    """Each shared parameter fitted to each experiment alone (one Gauss-Newton step from the joint
    fit on that experiment's rows of the Jacobian; its covariance from that experiment's residual
    with its effective samples) and the spread tested: chi-square of the values about their
    weighted mean against FALSE_ALARM (Bonferroni over the parameters). Inconsistent parameters
    whose values follow log(force level) (weighted slope beyond its own FALSE_ALARM, and the rest
    within the spread noise allows) are amplitude dependent. The levels are measured with the
    force channel's noise (force_level_noise, _trend): hits at one force, whose levels differ by
    that noise alone, show no trend however their values scatter.

    ``force_noise``: per experiment, the covariance the force channel's noise in its window gives
    the gradient (fitting.force_noise_scores, the fit's search units, all its parameters). The
    model is driven with the measured force: that noise rings through the model as a transient
    alike the hit's response, which the fit partly takes up along the parameters, so each value
    scatters by it beyond what its residual shows (a 300 Hz oscillator: 9e-5 against 7e-6). Each
    value's covariance then has its part, propagated through that experiment's own fit.

    ``tolerated``: a misfit energy (sum of squares over every sample, weighted as the fit's
    residual: ``tolerated_misfit`` with the problem's weights) the verdict tolerates. When
    fitting per experiment would lower the sum of squares by less, scattered differences are
    immaterial: a residual that the verdict accepts, a little beyond the floor and aligned with
    the parameter's direction, pulls each experiment's value a little (a 0.8 % spread of a scan
    skew over three hits against a 0.03 % uncertainty). A spread that follows the force level
    (four levels or more) stays inconsistent however small."""
    exps = problem.exps
    shared = [i for i, f in enumerate(problem.free) if f.experiment is None]
    if len(exps) < 2 or not shared or res is None:
        return Consistency(True)
    n_data = res.fun.size - (len(problem.free) if problem.prior else 0)
    J, r = res.jac[:n_data], res.fun[:n_data]
    k = problem.stride
    sizes = [len(range(0, e.n_samples, k)) * e.measured.shape[1] for e in exps]
    starts = np.concatenate([[0], np.cumsum(sizes)])
    values: dict[str, list[tuple[str, float, float]]] = {}
    per: dict[str, dict[str, float]] = {}
    gain = 0.0  # what fitting per experiment lowers the (strided) sum of squares by
    for i, e in enumerate(exps):
        rows = slice(starts[i], starts[i + 1])
        scores = None if force_noise is None else force_noise[i][np.ix_(shared, shared)]
        fitted, part, _, _ = _local_fit(problem, res.x, J[rows][:, shared], r[rows], shared, e.measured.shape[1],
                                        scores=scores, spread_rows=_with_rest(problem, e, r[rows]))
        gain += part
        for label, v, sd in fitted:
            values.setdefault(label, []).append((e.name, v, sd))
            per.setdefault(e.name, {})[label] = v
    tested = {k: v for k, v in values.items() if len(v) >= 2}
    out = Consistency(True, per)
    out.gain = gain * k
    if not tested:
        return out
    alpha = FALSE_ALARM / len(tested)
    noise = force_level_noise(exps)
    for label, rows in tested.items():
        v = np.array([x[1] for x in rows])
        sd = np.array([x[2] for x in rows])
        wts = 1.0 / sd**2
        mean = float(np.sum(wts * v) / np.sum(wts))
        chi2 = float(np.sum(wts * (v - mean) ** 2))
        limit = float(scipy.stats.chi2.isf(alpha, len(v) - 1))
        out.spread[label] = chi2 / limit
        if chi2 <= limit:
            continue
        immaterial = tolerated is not None and out.gain <= tolerated
        levels = np.array([force_levels.get(x[0], np.nan) for x in rows])
        if len(v) >= AMPLITUDE_LEVELS and np.all(np.isfinite(levels)) and np.ptp(np.log(levels)) > 0:
            level_sd = np.array([noise.get(x[0], 0.0) for x in rows]) / levels
            trend = _trend(np.log(levels), level_sd, v, sd)
            if trend is None:
                continue
            slope, slope_sd, rest = trend
            if (abs(slope) / slope_sd > scipy.stats.norm.isf(alpha / 2)
                    and rest <= scipy.stats.chi2.isf(alpha, len(v) - 2)):
                out.amplitude_dependent.append(label)
        # a spread that follows the force level is physics however small; scatter that fits no
        # better than the tolerated misfit is the misfit's pull
        if label in out.amplitude_dependent or not immaterial:
            out.consistent = False
    return out


def force_level_noise(exps: Sequence) -> dict[str, float]:
    """Per experiment, the noise of its force level (N): the force channel's noise per sample inside
    the hits' window (its noise energy over the window's samples, the tapers counted whole, so a
    little under). Experiments that do not say have none."""
    out = {}
    for e in exps:
        force, energy = getattr(e, "force", None), getattr(e, "force_noise_energy", 0.0)
        inside = np.count_nonzero(force) if force is not None else 0
        if energy > 0 and inside:
            out[e.name] = float(np.sqrt(energy / inside))
    return out


def _trend(x: np.ndarray, x_sd: np.ndarray, v: np.ndarray, sd: np.ndarray) -> tuple[float, float, float] | None:
    """The slope of values ``v`` (sd ``sd``) against ``x`` measured with noise ``x_sd``: (slope, its sd,
    the weighted sum of squares left about the line), None where the weighted rows leave it
    undetermined. A level's noise moves its value by slope x its noise, so each value weighs by
    its effective variance sd^2 + slope^2 x_sd^2 (Orear's method, iterated to the slope it gives).
    Levels that differ by no more than their noise then bound the slope's z by how far apart they
    are (a scatter of values a steep line through levels apart by noise alone fits is no trend);
    levels far apart leave the weights as they were."""
    X = np.column_stack([np.ones(len(v)), x])
    slope = 0.0
    for _ in range(50):
        wts = 1.0 / (sd**2 + slope**2 * x_sd**2)
        root = np.sqrt(wts)
        # by least squares on the weighted rows: one experiment far surer than the others
        # leaves the slope undetermined (a singular normal matrix), not an error
        coef, _, rank, sv = np.linalg.lstsq(X * root[:, None], v * root, rcond=None)
        if rank < 2:
            return None
        done = abs(coef[1] - slope) <= 1e-9 * abs(coef[1])
        slope = float(coef[1])
        if done:
            break
    wts = 1.0 / (sd**2 + slope**2 * x_sd**2)
    root = np.sqrt(wts)
    rest = float(np.sum(wts * (v - X @ coef) ** 2))
    _, sv, vt = np.linalg.svd(X * root[:, None], full_matrices=False)
    slope_var = float(np.sum((vt[:, 1] / sv) ** 2))  # [(X^T W X)^-1]_11
    return slope, float(np.sqrt(slope_var * max(1.0, rest / max(1, len(v) - 2)))), rest


def _local_fit(problem, x, Ji: np.ndarray, ri: np.ndarray, shared: Sequence[int], columns: int,
               bounded: bool = False, scores: np.ndarray | None = None, spread_rows: np.ndarray | None = None,
               noise: float | None = None
               ) -> tuple[list[tuple[str, float, float]], float, np.ndarray, np.ndarray]:
    """The shared parameters fitted to some rows of a joint fit alone: one Gauss-Newton step from
    it on those rows of the Jacobian, the covariance from their residual with its effective
    samples (``columns`` channels a row block). Returns (label, value, sd) of the parameters those
    rows determine (sd within a tenth of the range) and the (strided) sum of squares the step
    removes, the step and its covariance (in the fit's scaled units, one per shared parameter).

    ``bounded``: the step is the linearised least squares within the parameters' bounds, as the
    joint fit is. Unbounded, a combination these rows hardly determine takes a step of their noise
    over almost no information, and the model's clipping at the bounds then turns it into an
    error of the combinations they do determine (two high-pass corners in cascade, their sum
    determined, their difference not: fitted to a record's early part 0 and 4.5 Hz for a sum of
    0.33 Hz); within the bounds the undetermined combination moves along them, at no cost.

    ``scores``: the covariance of these rows' gradient ``Ji^T ri`` beyond what their residual
    shows (the force channel's noise: fitting.force_noise_scores), added through the step's
    ``H^+``.

    ``spread_rows``: the residual the covariance's variance is read from, where it holds more rows
    than ``ri`` (the rows at rest before the windows, Problem.at_rest, in the records' order);
    ``ri`` by default. ``noise``: the returned covariance (not the values' sds) is this variance
    per row times ``H^+`` (noise_variance: the noise's alone, without the misfit's)."""
    H = Ji.T @ Ji
    if not np.any(H):
        return [], 0.0, np.zeros(len(shared)), np.zeros((len(shared), len(shared)))
    w, V = np.linalg.eigh(H)
    keep = w > 1e-8 * w.max()
    Hinv = (V[:, keep] / w[keep]) @ V[:, keep].T
    step = -Hinv @ (Ji.T @ ri)
    if bounded:
        step = _bounded_step(problem, x, Ji, ri, shared, step)
    rv = ri if spread_rows is None else spread_rows
    n_i = rv.size
    neff = effective_samples(rv.reshape(-1, columns))
    s2 = float(rv @ rv) / max(1, n_i - len(shared)) * (n_i / neff)
    forced = 0.0 if scores is None else Hinv @ scores @ Hinv
    cov = s2 * Hinv + forced
    given = cov if noise is None else noise * Hinv  # the values' sds below stay the residual's
    out = []
    for j, idx in enumerate(shared):
        f = problem.free[idx]
        sd = float(np.sqrt(max(cov[j, j], 0.0))) * f.scale
        if not np.isfinite(sd) or sd <= 0 or sd > 0.1 * (f.param.upper - f.param.lower):
            continue  # these rows do not determine it
        out.append((f.label, f.to_value(x[idx] + step[j]), sd))
    return out, -float(step @ (Ji.T @ ri)), step, given


def _bounded_step(problem, x, Ji: np.ndarray, ri: np.ndarray, shared: Sequence[int], step: np.ndarray
                  ) -> np.ndarray:
    """The Gauss-Newton step on rows ``Ji``, ``ri`` kept within the shared parameters' bounds
    (scipy's bounded linear least squares; the unbounded ``step`` where it stays within them)."""
    lo = np.array([problem.free[i].bounds[0] for i in shared]) - np.asarray(x, float)[shared]
    hi = np.array([problem.free[i].bounds[1] for i in shared]) - np.asarray(x, float)[shared]
    if np.all((step >= lo) & (step <= hi)):
        return step
    seen = np.any(Ji != 0, axis=0)  # a column without information stays where the joint fit put it
    out = np.zeros(len(shared))
    if np.any(seen):
        lo_s, hi_s = np.minimum(lo[seen], 0.0), np.maximum(hi[seen], 0.0)
        out[seen] = scipy.optimize.lsq_linear(Ji[:, seen], -ri, bounds=(lo_s, hi_s), method="bvls").x
    return out


def _with_rest(problem, e, rows: np.ndarray) -> np.ndarray:
    """A record's residual rows with the rows at rest before its window (Problem.at_rest), whose
    Jacobian is zero: a part's variance is read over both, as over a window that kept them."""
    rest = problem.at_rest(e)
    return np.concatenate([rest.ravel(), rows]) if rest.size else rows


@dataclass
class Linearity:
    linear: bool = True
    early: dict[str, float] = field(default_factory=dict)  # values fitted to the records' early part
    late: dict[str, float] = field(default_factory=dict)  # to their late part
    differing: list[str] = field(default_factory=list)  # parameters whose two values disagree
    u: tuple = ()  # the fit's scaled unknowns with the early part's, the late part's values
    cuts: dict[str, int] = field(default_factory=dict)  # per record, the sample where its late part starts
    #: the early part's fit: covariance of its shared unknowns (scaled units), their indices in the fit
    cov: np.ndarray | None = None
    shared: tuple = ()


def noise_variance(problem) -> float | None:
    """The noise's variance per row of the fit's residual (its strided, weighted rows) with their
    correlation (``effective_samples``), read on the records' quiet stretches (Problem.noise_rows:
    before the hit, after the response): what the noise alone makes of an estimate, which a
    residual's own variance overstates by the model's misfit. None where no record tells it."""
    energy = n_eff = 0.0
    for e in problem.exps:
        for rows in problem.noise_rows(e):
            energy += float(np.sum(rows**2))
            n_eff += effective_samples(rows)
    return energy / n_eff if n_eff > 0 else None


def linearity(problem, res) -> Linearity:
    """Whether a fit holds on the large and the small part of the records alike. A hit's response
    decays through many amplitudes within each record, so a linear effect's parameters fitted to
    the early part and to the late part agree within their uncertainties; a fit that takes up an
    amplitude-dependent residual (a contact closing only at large motion, friction) gives two
    values. Each record is split where the candidate's own information (the squared Jacobian rows
    of its shared parameters) reaches half, so each part determines it alike; each parameter is
    fitted to the early rows of every record and to the late rows (one Gauss-Newton step each from
    the joint fit, as ``consistency``) and their difference tested (chi-square with one degree of
    freedom, FALSE_ALARM, Bonferroni over the parameters). No pooled tolerance as ``consistency``
    has: a contact's misfit sits in one band of one channel, far below a pooled one.

    The early part's covariance (``Linearity.cov``, the held-out test's spread: early_spread)
    is its estimate's under the sensors' noise alone (noise_variance), not under its residual's
    variance: a stand-in's misfit there widens the spread that is to refuse it, the more so where
    no samples at rest dilute it (a two-body rattle at 5 N recorded from its hit read
    "explained"). Its residual's where the records tell no noise. The force channel's noise is
    left out: it drives the late part's own fit alike, and with it (its scores over the whole
    records, fitting.force_noise_scores) the spread of that rattle, recorded with samples at rest,
    doubled and it read "explained", while true causes at 5-10 N passed without it."""
    shared = [i for i, f in enumerate(problem.free) if f.experiment is None]
    if not shared or res is None:
        return Linearity()
    n_data = res.fun.size - (len(problem.free) if problem.prior else 0)
    # every column shared (no per-experiment parameter): the Jacobian as it is, not a copy of all its
    # columns (two-body mass_properties: 35 MB); what is computed below reads it row by row alike
    J = res.jac[:n_data] if shared == list(range(res.jac.shape[1])) else res.jac[:n_data][:, shared]
    r = res.fun[:n_data]
    parts: tuple[list[np.ndarray], list[np.ndarray]] = ([], [])
    early_spread_rows: list[np.ndarray] = []  # the early rows with the rows at rest before them
    cuts: dict[str, int] = {}
    start, columns = 0, None
    for e in problem.exps:
        m = e.measured.shape[1]
        size = len(range(0, e.n_samples, problem.stride)) * m
        columns = m if columns in (None, m) else 0
        info = np.cumsum(np.sum((J[start:start + size] ** 2).reshape(-1, m * len(shared)), axis=1))
        if info[-1] > 0:
            cut = int(np.searchsorted(info, 0.5 * info[-1])) + 1
            parts[0].append(np.arange(start, start + cut * m))
            parts[1].append(np.arange(start + cut * m, start + size))
            early_spread_rows.append(_with_rest(problem, e, r[start:start + cut * m]))
            cuts[e.name] = e.first + cut * problem.stride  # in the record's samples (a window may start later)
        start += size
    if not parts[0] or not columns:
        return Linearity()  # channel counts differ between records: no common row blocks
    fits, us, covs = [], [], []
    noise = noise_variance(problem)
    for part, rows in enumerate(parts):
        idx = np.concatenate(rows)
        early = part == 0
        fitted, _, step, cov = _local_fit(problem, res.x, J[idx], r[idx], shared, columns, bounded=True,
                                          spread_rows=np.concatenate(early_spread_rows) if early else None,
                                          noise=noise if early else None)
        fits.append({label: (v, sd) for label, v, sd in fitted})
        u = np.array(res.x, float)
        u[shared] += step
        us.append(u)
        covs.append(cov)
    out = Linearity(early={k: v for k, (v, _) in fits[0].items()}, late={k: v for k, (v, _) in fits[1].items()},
                    u=tuple(us), cuts=cuts, cov=covs[0], shared=tuple(shared))
    both = [k for k in fits[0] if k in fits[1]]
    if not both:
        return out
    limit = float(scipy.stats.chi2.isf(FALSE_ALARM / len(both), 1))
    for k in both:
        (a, sa), (b, sb) = fits[0][k], fits[1][k]
        if (a - b) ** 2 / (sa**2 + sb**2) > limit:
            out.differing.append(k)
    out.linear = not out.differing
    return out


def early_spread(problem, lin: Linearity | None, exps: Sequence | None = None) -> list[list[np.ndarray]]:
    """The early part's estimation spread as changes of the predictions: per principal direction of
    its covariance (``Linearity.cov``), the change one standard deviation along it makes, from the
    early fit (``Linearity.u[0]``), per experiment of ``exps`` (the problem's own by default). Taken
    within the bounds and scaled up to the standard deviation where a bound is nearer (the model
    clips there). Empty without a covariance."""
    if lin is None or lin.cov is None or len(lin.u) != 2 or not np.any(lin.cov):
        return []
    u0 = np.asarray(lin.u[0], float)
    shared = list(lin.shared)
    lo = np.array([problem.free[i].bounds[0] for i in shared]) - u0[shared]
    hi = np.array([problem.free[i].bounds[1] for i in shared]) - u0[shared]
    w, V = np.linalg.eigh(lin.cov)
    base = None
    out = []
    for lam, v in zip(w, V.T):
        if lam <= 1e-12 * w.max():
            continue
        d = np.sqrt(lam) * v
        # the longer way within the bounds, at most one standard deviation
        reach = [min([1.0] + [float(b / x) for b, x in zip(np.where(sd * d > 0, hi, lo), sd * d) if x != 0])
                 for sd in (1.0, -1.0)]
        sign = 1.0 if reach[0] >= reach[1] else -1.0
        t = max(reach) * sign
        if abs(t) < 1e-3:
            continue
        u = u0.copy()
        u[shared] += t * d
        # not kept: the fit's own kept predictions stay for what follows
        base = problem.predictions(u0, exps, keep=False) if base is None else base
        out.append([(a - b) / t for a, b in zip(problem.predictions(u, exps, keep=False), base)])
    return out


def held_out(exps: Sequence, early: Sequence[np.ndarray], late: Sequence[np.ndarray], floor,
             cuts: Mapping[str, int], spread: Sequence[Sequence[np.ndarray]] = ()) -> resolution.Resolved | None:
    """The late (small) part of each record as the model fitted to the early (large) part predicts
    it, against the late part's own fit, by the verdict's cell test: per experiment, channel and
    band the residual energy beyond the own fit's, over the floor's share of the part (its
    fraction of the samples: the noise is stationary), with the verdict's limits. A linear cause
    fitted where the response is large predicts where it is small; a contact or friction that
    acts at one amplitude only does not. Not the other way round: the late part's fit, its
    estimation noise carried by the early part's large response, mispredicts that part even for a
    true cause (measured: added masses 8-23x the limit). ``cuts``: per record, the sample where
    its late part starts (``Linearity.cuts``). None without the floor's bands or a cut.

    ``spread`` (``early_spread``): the early fit's own parameter uncertainty carried into the late
    part, as a prediction interval does. A true cause's early fit is off by delta ~ N(0, cov), whose
    late-part energy in a cell is a Gaussian quadratic form of mean S (the directions' energies
    there summed); such a form exceeds x S with probability at most P(chi2_1 > x) for x >= 1.54
    (Szekely and Bakirov 2003). A cell is then above only beyond limit x floor share + x_S S, x_S
    the chi-square(1) quantile at the cell test's per-cell false-alarm rate: each of the two
    energies passes its own allowance with at most DETECTION_FALSE_ALARM, so a true cause fails the
    test with about 2 DETECTION_FALSE_ALARM (not a strict bound: the noise's and the spread's cross
    term, zero on average, is left out; (sqrt(a) + sqrt(b))^2 would bound it, at a weaker test).
    The spread's covariance comes from the early part's own residual, so a stand-in's misfit there
    widens it: the test refuses a stand-in less readily than the noise alone would (the outside
    sets' friction and rattles measure what it still refuses)."""
    if not all(e.name in cuts for e in exps):
        return None
    masks = [(np.arange(e.n_samples) >= cuts[e.name])[:, None] for e in exps]
    held = resolution.resolve(exps, [np.where(m, p, e.measured) for e, m, p in zip(exps, masks, early)], floor)
    own = resolution.resolve(exps, [np.where(m, p, e.measured) for e, m, p in zip(exps, masks, late)], floor)
    if held is None or own is None:
        return None
    share = [float(m.mean()) for m in masks]
    floors = [f * s for f, s in zip(held.floor, share)]
    if spread:
        n_cells = sum(f.size for f in held.floor)
        x_s = float(scipy.stats.chi2.isf(resolution.DETECTION_FALSE_ALARM / max(n_cells, 1), 1))
        energy = [np.zeros_like(f) for f in floors]
        for change in spread:  # only their energies: resolve's limits and degrees of freedom are held's
            one = resolution.residual_energies(
                exps, [e.measured - np.where(m, d, 0.0) for e, m, d in zip(exps, masks, change)], floor)
            energy = [a + b for a, b in zip(energy, one)]
        # limit x (floor share + S x_S / limit) = limit x floor share + x_S S
        floors = [f + x_s * s / lim for f, s, lim in zip(floors, energy, held.limit)]
    return replace(held, residual=[np.maximum(a - b, 0.0) for a, b in zip(held.residual, own.residual)],
                   floor=floors)


def tolerated_misfit(floor, exps: Sequence, weights: Mapping[str, np.ndarray] | None = None) -> float:
    """The sum of squares beyond the noise floor's that the verdict accepts as "at the floor" (an
    error up to FLOOR_TOLERANCE x the floor's), over every sample of ``exps``, each channel's floor
    energy (``floor``: a NoiseFloor) times its weight squared as the fits weigh their residual
    (``weights``: fitting.channel_weights; None: unweighted): the gain ``consistency`` compares it
    with is a sum of the whitened residual, so both are in the noise's units."""
    total = 0.0
    for e in exps:
        chans = floor.energy.get(e.name, {})
        w = np.ones(len(e.sensors)) if weights is None else np.asarray(weights[e.name], float)
        total += sum(chans.get(s.name, 0.0) * float(wj) ** 2 for s, wj in zip(e.sensors, w))
    return (FLOOR_TOLERANCE**2 - 1.0) * total


def implausible(effect, model, values: Mapping[str, float | None], params: Sequence | None = None) -> list[str]:
    """The fitted values outside the physical range their parameter declares (``plausible``);
    ``params``: the parameters as the fit bounded them (a problem's, Parameter.within_records),
    else the effect's own."""
    ranges = {p.name: getattr(p, "plausible", None) for p in (effect.parameters(model) if params is None else params)}
    out = []
    for label, v in values.items():
        rng = ranges.get(label.split("/")[-1])
        if rng is not None and v is not None and not rng[0] <= v <= rng[1]:
            out.append(label)
    return out


def at_records_edge(params: Sequence, values: Mapping[str, float | None]) -> list[str]:
    """The fitted frequencies (``below_nyquist``) within the records' last frequency line: beyond
    their plausible top, the fit stopped at the Nyquist bound (Parameter.within_records)."""
    edge = {p.name: p for p in params if getattr(p, "below_nyquist", False) and p.plausible}
    return [label for label, v in values.items()
            if (p := edge.get(label.split("/")[-1])) is not None and v is not None and v > p.plausible[1]]


def indistinguishable(change_a: np.ndarray, change_b: np.ndarray, scale: float, k: int) -> bool:
    """Two candidates' fitted changes of the predictions differ by less than noise fitted with
    ``k`` parameters could: no experiment here tells them apart."""
    d = change_a - change_b
    return float(d @ d) <= gain_threshold(scale, k)
