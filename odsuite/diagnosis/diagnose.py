"""Which physical effect does the model lack? Every registered effect (built-in or a lab's own)
is a candidate: screened, the promising ones fitted and validated (:mod:`odsuite.diagnosis.fitting`),
then ranked.

A candidate whose screening took up less than half of what the best fit explains is ranked by its
screening alone. Candidates are ranked by validated error with a BIC penalty for their number of
parameters. A candidate is ``significant`` when its validated gain exceeds what fitting its
parameters to the calibrated noise floor would give (:mod:`odsuite.diagnosis.checks`); each fitted one
is also checked for ``consistent`` parameters across experiments (amplitude dependence), values in
their ``plausible`` physical range, and ``confounded_with`` candidates that explain the same residual
within the noise. Parameters with an uncertainty comparable to their range are reported as not
identifiable and held at their nominal value. The diagnosis ends in a verdict with the signature of
what is left and one paragraph to act on (:mod:`odsuite.diagnosis.verdict`).
"""

from __future__ import annotations

import gc
import itertools
import math
import multiprocessing
from collections.abc import Callable, Mapping, Sequence
from contextlib import contextmanager
from concurrent.futures import FIRST_COMPLETED, wait
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from odsuite.contracts.effects import applies, family
from odsuite.diagnosis import checks, joint, physical
from odsuite.diagnosis.between_records import reported_with_covariance
from odsuite.analysis.comparison import noise_floor, residual_peaks, residual_spectra
from odsuite.domain import arguments
from odsuite.domain.display import error_text
from odsuite.domain.errors import ConfigError, DivergedError, NonPhysicalError
from odsuite.diagnosis.fitting import (
    ROUNDING,
    Problem,
    Screened,
    _lm_step,
    channel_weights,
    effective_samples,
    fit,
    fit_windows,
    force_noise_scores,
    off_the_bounds,
    records_band,
    refined,
    screen,
    uncertainties,
    validate,
    weight_notes,
    with_force_noise,
)
from odsuite.analysis.modelrev import current_revision, revision_model
from odsuite.analysis.prediction import PreparedExperiment, kept_simulations, predict, prepare
from odsuite.domain.simulation import load_nonlinear_loop
from odsuite.analysis import noise_colour
from odsuite.analysis import resolved as resolution
from odsuite.analysis.noise_floor import FLOOR_TOLERANCE, witnesses
from odsuite.diagnosis.pool import JOBS, SMALL_JOB, TOKENS, InOrder, default_workers, forked_pool, worker_start  # noqa: F401
from odsuite.diagnosis.ranking import (
    is_significant,
    makes_nonlinear,
    mark_confounded,
    mark_proxies,
    prefer_fewer_parameters,
    prefer_named,
    tell_refinements_apart,
)
from odsuite.diagnosis.verdict import Signature, decide, message, signature

#: how many screened candidates get a full fit and validation
FULL_FITS = 4
#: a fitted parameter whose standard deviation exceeds this fraction of its range is not identifiable
UNIDENTIFIABLE_FRACTION = 0.1
#: parameter correlations above this are reported as confounded
CONFOUNDED_CORRELATION = 0.95

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
    #: None: not checked (screened only, or its fit stopped early)
    consistent: bool | None = True
    plausible: bool = True
    implausible: list[str] = field(default_factory=list)
    #: of those, the frequencies the fit stopped at the records' Nyquist frequency (not resolved)
    at_records_edge: list[str] = field(default_factory=list)
    amplitude_dependent: list[str] = field(default_factory=list)
    per_experiment_fits: dict[str, dict[str, float]] = field(default_factory=dict)
    #: its parameters fitted to the records' early (large) and late (small) part agree (checks.linearity;
    #: for the best, the held-out test decides); None: not tested (``early_late_note`` says why)
    early_late_agree: bool | None = True
    early_late_note: str = ""
    early_late_fits: dict[str, dict[str, float]] = field(default_factory=dict)
    early_late_differ: list[str] = field(default_factory=list)
    #: the cells where the early part's fit mispredicts the late part (checks.held_out; best candidate)
    early_late_cells: list[dict[str, Any]] = field(default_factory=list)
    gain_threshold: float = float("nan")
    likelihood_ratio: float = float("nan")  # the whitened excess it removes (odsuite.analysis.resolved)
    #: the fit in physical quantities (the effect's ``physical``): label, value, unit, uncertainty, nominal
    physical: list[dict[str, Any]] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        d = {k: getattr(self, k) for k in (
            "effect", "significant", "error_after", "validated_error", "parameters", "uncertainties",
            "units", "evidence", "n_parameters", "bic", "screened_error", "unidentifiable",
            "confounded_parameters", "confounded_with", "validation", "fitted", "consistent", "plausible",
            "implausible", "at_records_edge", "amplitude_dependent", "per_experiment_fits", "early_late_agree", "early_late_note", "early_late_differ",
            "early_late_fits", "early_late_cells",
            "physical")}
        # false: left undecided (UNSETTLED), and ``significant`` false with it
        d["significance_decided"] = self.validation != UNSETTLED
        d["likelihood_ratio"] = None if not math.isfinite(self.likelihood_ratio) else self.likelihood_ratio
        d["likelihood_ratio_limit"] = None if not math.isfinite(self.gain_threshold) else self.gain_threshold
        return d

    def revision_entry(self) -> dict[str, Any]:
        """How add-effect stores this fit in a model revision."""
        return {"effect": self.effect, "values": dict(self.values), "per_experiment": self.per_experiment,
                "uncertainties": {k: v for k, v in self.uncertainties.items() if v is not None},
                **({"physical": self.physical} if self.physical else {})}


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
        # a value held at an end of its search range has no spread: the linearisation that gives
        # one is cut there (a tilt at -1.05 rad read "± 0.0108 rad")
        edge = "lower" if v == f.param.lower else "upper" if v == f.param.upper else ""
        pm = f" ± {sd:.3g}" if sd is not None and np.isfinite(sd) and not edge else ""
        at = f", at the {edge} end of its range" if edge else ""
        parts.append(f"{f.label} = {v:.4g}{pm}{unit} (nominal {f.param.nominal:g}{at})")
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
    if rigidity is not None and rigidity > 0.1 and getattr(problem.effect, "breaks_rigidity", False):
        words.append(f"rigidity residual {100 * rigidity:.0f} %")
    if modes_before is not None and modes_after is not None and len(modes_before) == len(modes_after) and len(modes_before):
        moved = _moved_modes(modes_before, modes_after)
        if moved:
            words.append("model modes move: " + ", ".join(moved))
    shown = physical.moved(cand.physical)
    desc = physical.text(shown) if cand.physical else _describe_values(problem, cand.parameters, cand.uncertainties)
    if desc:
        words.append(f"fitted {desc}")
    words.append((f"validated error {error_text(baseline)} -> {error_text(cand.validated_error)} ({cand.validation})"
                  if math.isfinite(cand.validated_error) else cand.validation) + f"; noise floor {error_text(noise)}")
    # the factors the data cannot separate (a scale per axis times one per spring) are neither
    # printed nor named where the effect reports quantities: those are what the factors determine,
    # each with the uncertainty their correlations give it
    if not cand.physical and len(cand.confounded_parameters) > 2:  # one phrase, not overlapping groups
        names = list(dict.fromkeys(n for g in cand.confounded_parameters for n in g))
        words.append(f"these data cannot separate {', '.join(names)} "
                     f"({len(cand.confounded_parameters)} overlapping groups)")
    elif not cand.physical:
        for group in cand.confounded_parameters:
            words.append(f"only the combination of {', '.join(group)} is determined")
    if cand.unidentifiable:
        words.append(f"not identifiable from these data: {', '.join(cand.unidentifiable)}")
    return "; ".join(words)


#: a model mode that moves by more than this fraction is named in the evidence
MODE_MOVE = 0.01


def _moved_modes(before: Sequence[float], after: Sequence[float], limit: int = 3) -> list[str]:
    """'mode 3: 21.4 → 18.2 Hz' for the modes (numbered from 1 in frequency order) that move most,
    beyond MODE_MOVE."""
    b, a = np.asarray(before, float), np.asarray(after, float)
    rel = np.abs(a / np.where(b > 0, b, np.nan) - 1)
    order = [i for i in np.argsort(-np.nan_to_num(rel)) if rel[i] > MODE_MOVE][:limit]
    return [f"mode {i + 1}: {b[i]:.4g} → {a[i]:.4g} Hz" for i in sorted(order)]


def _checks_words(cand: Candidate) -> str:
    words = []
    if cand.consistent is False:
        spread = ", ".join(cand.amplitude_dependent) if cand.amplitude_dependent else "some parameters"
        words.append(f"fitted per experiment, {spread} differ beyond their uncertainties"
                     + (" and follow the force level (amplitude dependent)" if cand.amplitude_dependent else ""))
    edge = cand.at_records_edge
    if edge:
        words.append(f"{', '.join(edge[:4])} at the records' Nyquist frequency ({cand._nyquist_hz:g} Hz): "
                     "the fit stopped at the top of what they resolve")
    if [n for n in cand.implausible if n not in edge]:
        words.append(f"outside the physical range: {', '.join(n for n in cand.implausible[:4] if n not in edge)}")
    return "; ".join(words)


@dataclass
class Diagnosis:
    baseline_error: float
    noise_floor_error: float
    revision: int | None
    candidates: list[Candidate]
    residual_peaks: list[dict[str, Any]]
    evaluations: int
    not_applicable: list[str] = field(default_factory=list)
    #: the not applicable effects that apply to other model families (``structures``)
    other_families: list[str] = field(default_factory=list)
    verdict: str = ""
    signature: Signature = field(default_factory=Signature)
    message: str = ""
    #: what the records say against the rig or the comparison (a clipped channel left out), and
    #: channels the fits weigh without a noise estimate (fitting.weight_notes)
    notes: list[str] = field(default_factory=list)

    @property
    def residual_to_floor(self) -> float:
        return self.baseline_error / self.noise_floor_error if self.noise_floor_error > 0 else float("inf")

    def as_dict(self) -> dict[str, Any]:
        return {"verdict": self.verdict, "noise_floor": self.noise_floor_error,
                "residual_to_floor": self.residual_to_floor, "signature": self.signature.as_dict(),
                "message": self.message,
                "baseline_error": self.baseline_error, "noise_floor_error": self.noise_floor_error,
                "revision": self.revision, "candidates": [c.as_dict() for c in self.candidates],
                "residual_peaks": self.residual_peaks, "model_evaluations": self.evaluations,
                "not_applicable": self.not_applicable, "other_families": self.other_families,
                "notes": self.notes}


def _fit_candidate(screened: Screened, exps, sse0: float, den: float, n_eff: float, noise: float,
                   peaks, rigidity, modes_before, tail0: float = 0.0,
                   force_levels: Mapping[str, float] | None = None, target: float | None = None,
                   cannot_pass: Callable[[np.ndarray, float], bool] | None = None, floor=None,
                   out_of_reach: Callable[[np.ndarray, float], bool] | None = None,
                   why: Sequence[str] = (), settle: bool = True) -> Candidate:
    """Fit, validate and describe one screened candidate. Sums of squares of ``screened`` are over
    the fit windows; ``tail0`` is the rest of the records' at the nominal model, ``sse0`` whole;
    ``target``, ``cannot_pass``: the fit stops where it cannot come near that or pass its test
    (fitting.fit), and is neither validated nor checked; ``out_of_reach``: the fit stops where it
    cannot come near the top or change its own significance (_out_of_reach, the words why in
    ``why``), and is judged at the point reached, its consistency checked only where it passes its
    test, and validated (the other half of its significance) only where it passes and ``settle``
    (else the caller settles it where its significance is read: _settled); ``floor``:
    the records' noise floor, whose tolerated misfit the consistency check allows (None: none)."""
    problem = screened.problem
    effect = problem.effect
    stopped = short = False
    if problem.free:
        # screening has already stepped through the short heads to the whole windows
        res = fit(problem, screened.u0, continuation=False, target=target,
                  cannot_pass=cannot_pass if out_of_reach is None else out_of_reach)
        stopped, short = (False, res.target_stop) if out_of_reach is not None else (res.target_stop, False)
        if not (stopped or short):
            res = off_the_bounds(problem, res)
        checked = None
        if short and out_of_reach.passes and settle:
            # significance asks for a validated error below the baseline's too: where it is not
            # there, its significance is not decided and the fit goes on to its end
            checked = validate(problem, res.x, res)
            if not checked[0] + problem.tail_sse(res.x) < sse0:
                res, short, checked = fit(problem, res.x, continuation=False, jac0=res.jac), False, None
        u = res.x
        # stopped out of reach and left unsettled (_settled fits it again where it is read): short of
        # its minimum its residual holds what it has not fitted yet, which no uncertainty reads as noise
        unsettled = short and checked is None and out_of_reach.passes
        if unsettled:
            sds, corr, groups, nulls = (np.full(len(problem.free), np.nan), np.eye(len(problem.free)), [],
                                        np.zeros((len(problem.free), 0)))
        else:
            # uncertainties from the residual as it is: its samples are correlated (filters, misfit)
            sds, corr, groups, nulls = uncertainties(problem, res, lambda: checks.residual_effective_samples(problem, res))
        unident = [f.label for f, sd in zip(problem.free, sds) if not unsettled and (
            not np.isfinite(sd) or sd > UNIDENTIFIABLE_FRACTION * (f.param.upper - f.param.lower))]
        if unident and len(unident) < len(problem.free) and not stopped and not short:
            # hold what the data cannot see at its nominal value and refit the rest
            held = {f.param.name: f.param.nominal for f in problem.free
                    if f.label in unident and f.experiment is None}
            if held:
                problem = problem.derived({**screened.fixed, **held})
                keep = [i for i, f in enumerate(screened.problem.free) if f.param.name not in held]
                res = fit(problem, u[keep], continuation=False)
                u = res.x
                sds, corr, groups, nulls = uncertainties(problem, res, lambda: checks.residual_effective_samples(problem, res))
        sse = problem.sse(u)
        confounded = groups + [[problem.free[i].label, problem.free[j].label]
                               for i in range(len(problem.free)) for j in range(i + 1, len(problem.free))
                               if abs(corr[i, j]) > CONFOUNDED_CORRELATION
                               and not any(problem.free[i].label in g and problem.free[j].label in g
                                           for g in groups)]
        # the force channel's noise per experiment (a simulation a fit): the consistency check's
        # values scatter by it, and the reported uncertainties have it as add-effect stores them
        # (not more certain than the records agree either)
        scores = force_noise_scores(problem, res)
        if unsettled:
            shown_sds, spread = sds, None
        else:
            sds, corr = with_force_noise(problem, res, sds, corr, scores)
            shown_sds, spread = reported_with_covariance(sds, problem, res)
    else:
        u = problem.zero()
        sse = screened.sse
        sds, unident, confounded, corr = np.zeros(0), [], [], None
        shown_sds, spread, scores, nulls = sds, None, None, np.zeros((0, 0))
    sse_win = sse
    tail = problem.tail_sse(u)
    at_fit = problem.predictions(u, problem.full)  # kept by tail_sse where the records are cut
    sse += tail
    shared, per = problem.values(u)
    params: dict[str, float | None] = {}
    uncert: dict[str, float | None] = {}
    units: dict[str, str] = {}
    for f, sd in zip(problem.free, shown_sds):
        params[f.label] = f.to_value(u[problem.free.index(f)])
        uncert[f.label] = float(sd) if np.isfinite(sd) else None
        units[f.label] = f.param.unit
    for name in unident:
        params.setdefault(name, None)
    for name, c in problem.fixed.items():
        params[name] = c
        uncert[name] = None
    # a fit stopped where it cannot pass its test is not validated, refitted or checked further; nor
    # is one stopped out of reach of the top where its test's outcome is left to the caller
    if stopped:
        sse_val, how = math.nan, "not validated: its fit stopped early"
    elif short and checked is None:
        sse_val, how = math.nan, (UNSETTLED if out_of_reach.passes else
                                  "not validated: its fit stopped where it could not pass its likelihood-ratio test")
    else:
        sse_val, how = checked if short else validate(problem, u, res if problem.free else None)
    sse_val += tail
    k = len(problem.free) + len(problem.fixed)
    bic = n_eff * math.log(max(sse_val, 1e-300) / den) + k * math.log(n_eff) if math.isfinite(sse_val) else math.inf
    modes_after = None
    if effect.target == "model" and shared:
        after = list(problem.models(u)[exps[0].name].modes().frequency_hz)
        if len(after) == len(problem.base.shared.modes().frequency_hz):  # none added: pair them in order
            modes_after = after[:len(modes_before)]
    cand = Candidate(
        effect=effect.name, significant=False, error_after=math.sqrt(sse / den),
        validated_error=math.sqrt(sse_val / den), parameters=params, uncertainties=uncert, units=units,
        evidence="", n_parameters=k, bic=bic, screened_error=math.sqrt((screened.sse + tail0) / den),
        unidentifiable=unident, confounded_parameters=confounded, validation=how,
        per_experiment=per, values={n: v for n, v in shared.items()},
    )
    labels = [f.param.name if f.experiment is None else "" for f in problem.free]
    propagation: dict[str, Any] = {}
    cand.physical = physical.quantities(effect, problem.base.shared, {**problem.fixed, **shared}, labels, sds, corr,
                                        spread, propagation)
    physical.mark_undetermined(cand.physical, effect, problem.base.shared,
                               lambda x: problem.searched_values(x, shared), u, nulls, propagation)
    # one that stopped out of reach as passing its test is named: whether its values follow the force
    # level (a proxy for amplitude-dependent physics, ranking.mark_proxies) decides its confounding, so
    # its consistency is checked at the point reached (a weak hardening series' mass_properties, left
    # unchecked, was declared beside the true cause)
    passing = short and out_of_reach.passes
    if stopped or (short and not passing):
        cand.consistent = None
    elif problem.free:
        tolerated = None if floor is None else checks.tolerated_misfit(floor, problem.full, problem.weights)
        cons = checks.consistency(problem, res, force_levels or {}, tolerated, scores)
        cand.consistent, cand.amplitude_dependent = cons.consistent, cons.amplitude_dependent
        cand.per_experiment_fits = cons.per_experiment
    if stopped or short:
        cand.early_late_agree, cand.early_late_note = None, "not tested: its fit stopped early"
    elif problem.free:
        # no pooled tolerance here: the resolved residual decides, and a contact's misfit sits in one band
        lin = checks.linearity(problem, res)
        cand.early_late_agree, cand.early_late_fits = lin.linear, {"early": lin.early, "late": lin.late}
        cand.early_late_differ, cand._early_late_u, cand._early_late_cuts = lin.differing, lin.u, lin.cuts
        cand._early_late = lin
    cand.implausible = checks.implausible(effect, problem.base.shared, params, problem.params)
    cand.at_records_edge = checks.at_records_edge(problem.params, params)
    cand._nyquist_hz = records_band(problem.full)[0]
    cand.plausible = not cand.implausible
    cand._problem, cand._u, cand._sse_win = problem, u, sse_win  # kept for the confounding check
    # the fit windows' sum as the fits weigh it (whitened per channel): a pair's fit stops on it
    cand._cost_win = float(np.sum(problem.residual(u, stride=1) ** 2))
    cand._stopped, cand._short, cand._screened_sse = stopped, short, screened.sse
    baseline = math.sqrt(sse0 / den)
    cand.evidence = _evidence(problem, cand, baseline, noise, peaks, rigidity, modes_before, modes_after)
    if short:
        cand.evidence = (f"{why[-1]}: its values, errors, test and consistency at the point reached; "
                         if passing else f"{why[-1]}: its values, errors and test at the point reached, its "
                         f"consistency not checked; ") + cand.evidence
    # the judgement (_judge) and the verdict predict the whole records at the fit again; the checks
    # above predicted other points since
    problem.keep(u, at_fit, problem.full)
    return cand


def _judge(cand: Candidate, exps, floor, before, sse_before: float, den: float, scale: float,
           k: int | None = None) -> None:
    """Significance of a fitted candidate against ``before`` (the resolved residual it is tested
    over): its validated sum of squares lower than before's, and the likelihood-ratio statistic of
    its change of the resolved, whitened residual beyond what ``k`` parameters (default: its own)
    fitted to noise give (odsuite.analysis.resolved). Without a resolved floor: the pooled gain
    test (checks.gain_threshold)."""
    k = cand.n_parameters if k is None else k
    p = cand._problem
    cand._resolved = None if before is None else resolution.resolve(exps, p.predictions(cand._u, p.full), floor)
    validated_better = cand.validated_error**2 * den < sse_before
    if cand._resolved is None:
        cand.gain_threshold = checks.gain_threshold(scale, k)
        cand.significant = is_significant(sse_before, cand.validated_error**2 * den, cand.gain_threshold)
        return
    cand.gain_threshold = resolution.gain_threshold(k)
    cand.likelihood_ratio = resolution.gain(before, cand._resolved)
    cand.significant = bool(validated_better and cand.likelihood_ratio > cand.gain_threshold)


def _problem(job: Mapping[str, Any], name: str, fixed: Mapping[str, float] | None = None) -> Problem:
    problem = Problem(job["base"], job["effects"].get(name), job["windows"], prior=job["prior"] / job["stride"],
                      stride=job["stride"], full=job["exps"], noise_scale=job["scale"], weights=job["weights"])
    return problem.derived(fixed) if fixed else problem


def _screen_job(token: int, name: str, job: Mapping[str, Any] | None = None
                ) -> tuple[dict[str, float], np.ndarray, float, int] | None:
    """Screen one candidate (on the baseline, or on ``job``'s base by _screen_on_top): its discrete choices, start,
    sum of squares and evaluations."""
    on_top, job = job is not None, job or JOBS[token]
    try:
        problem = _problem(job, name)
    except ConfigError:
        return None  # the effect does not apply to this rig (e.g. no base plate)
    s = (_screen_on_top if on_top else screen)(problem, job["sse0_win"], job["peak_hz"])
    return s.fixed, s.u0, s.sse, problem.evaluations + (s.problem.evaluations if s.problem is not problem else 0) + s.tried


#: the last seed's job a worker built for _partner_job: (key, job with that fit as the base)
_ON_TOP: list[Any] = [None, None]


def _partner_job(token: int, seed: tuple[str, Mapping[str, float], np.ndarray, float], name: str
                 ) -> tuple[dict[str, float], np.ndarray, float, int] | None:
    """Screen ``name`` on top of the seed's fit (its effect, discrete choices, values and sum of
    squares over the fit windows), as _screen_job on the baseline: _partner's search."""
    first, fixed, u, sse_win = seed
    key = (token, first, tuple(sorted(fixed.items())), u.tobytes())
    if _ON_TOP[0] != key:  # the fit's model, rebuilt once per seed in each process
        job = JOBS[token]
        _ON_TOP[:] = [key, {**job, "base": _problem(job, first, fixed).revision(u), "sse0_win": sse_win}]
    return _screen_job(token, name, _ON_TOP[1])


def _fit_job(token: int, name: str, fixed: Mapping[str, float], u0: np.ndarray, sse: float,
             top: tuple[float, Sequence[int]] | None = None, settle: bool = True) -> tuple[Candidate, tuple]:
    """Fit one screened candidate; the candidate without its problem (rebuilt by the caller from what
    _kept hands back: the values it was fitted with, its evaluations, its predictions). With
    ``top`` (an upper bound of the best single fit's cost, and the parameter counts of the
    candidates fitted) the fit stops where it cannot matter (_out_of_reach); one stopped so is
    validated only where ``settle`` (_fit_candidate)."""
    job = JOBS[token]
    problem = _problem(job, name, fixed)
    why: list[str] = []
    hook = None if top is None else _out_of_reach(problem, *top, job["n_eff"], job["floor"], job["res0"], why)
    cand = _fit_candidate(Screened(problem.effect, dict(fixed), u0, sse, problem), job["windows"], job["sse0"],
                          job["den"], job["n_eff"], job["noise"], job["peaks"], job["rigidity"],
                          job["modes_before"], job["tail0"], job["force_levels"], floor=job["floor"],
                          out_of_reach=hook, why=why, settle=settle)
    return cand, _kept(cand.__dict__.pop("_problem"))


def _cost(problem: Problem, u: np.ndarray) -> float:
    """A fit's objective at ``u`` (fitting.fit: half the strided, weighted sum of squares over the
    fit windows and its prior's)."""
    r = problem.residual(u)
    return 0.5 * (float(r @ r) + float(np.sum(problem.pull * u**2)))


def _out_of_reach(problem: Problem, top: float, counts: Sequence[int], n_eff: float, floor, before, why: list[str]
                  ) -> Callable[[np.ndarray, float], bool]:
    """Whether a single candidate's fit (``problem``) at ``x``, gaining at most JOINT_REACH times
    the fall ``promised`` (in cost) that its linearisation there promises, can no longer matter:
    (a) its significance is decided (its likelihood ratio over the baseline ``before`` already
    passes its test, and grows as the fit goes on, or cannot reach it), and (b) it cannot come
    near the top: its cost, less that reach, stays above ``top`` (a fit's cost at its screened
    point: the best single fit's ends at or below it, whatever order the fits run in) by more than
    the likelihood-ratio limit of its and the most parameters of another fitted candidate
    (``counts``: the ranking's tests between two candidates, the parsimony rule's and the
    confounding's) and by more than BIC's penalty for its parameters beyond the fewest. Appends the
    words why to ``why`` when it says stop; each check of (a) predicts the whole records once."""
    k = len(problem.free) + len(problem.fixed)
    unit = 2.0 * problem.stride / problem.noise_scale if problem.noise_scale > 0 else 0.0  # cost -> noise energies
    limit, apart = resolution.gain_threshold(k), resolution.gain_threshold(k + max(counts, default=0))
    penalty = max(k - min(counts, default=k), 0) * math.log(max(n_eff, 1.0))
    rest = problem.rest_cost()  # BIC's ratio of costs over the windows with their rows at rest

    def out_of_reach(x: np.ndarray, promised: float) -> bool:
        if unit == 0.0 or before is None:
            return False
        reach = JOINT_REACH * promised
        least = _cost(problem, x) - reach  # the fit's predictions at x are kept: no evaluation
        if ((least - top) * unit <= apart or least <= 0
                or n_eff * math.log((least + rest) / (top + rest)) <= penalty):
            return False
        try:
            res = resolution.resolve(problem.full, problem.predictions(x, problem.full), floor)
        except (DivergedError, NonPhysicalError):
            return False
        if res is None:
            return False
        g = resolution.gain(before, res)
        out_of_reach.passes = limit < g
        if limit < g or g + reach * unit <= limit:
            why.append(f"its fit stopped where it could not come near the top (cost {(least + reach + rest) * unit:.4g} "
                       f"noise energies, at most {reach * unit:.3g} less by its linearisation, against at most "
                       f"{(top + rest) * unit:.4g} for the best) nor change its significance (likelihood ratio {g:.4g}, "
                       f"limit {limit:.3g})")
            return True
        return False

    out_of_reach.passes = False  # whether it stopped as passing its likelihood-ratio test
    return out_of_reach


def diagnose(project, *, effects: Sequence[str] | None = None, experiments: Sequence[str] | None = None,
             full_fits: int = FULL_FITS, progress: Callable[[str, int, int], None] | None = None,
             prepared: Sequence[PreparedExperiment] | None = None, workers: int | None = None) -> Diagnosis:
    """Rank every registered effect (or ``effects``) by how much of the model's error it explains.

    Candidates are screened and fitted on ``workers`` processes (default: default_workers; 1: one
    after another in this process). Each candidate's work is independent of the others' and runs
    in the same order of operations, so the result does not depend on ``workers`` beyond rounding:
    a candidate that changes only the sensors predicts through its process's kept simulation where
    that holds the base model's, or simulates afresh, and the two sum in another order (screened
    errors a few 1e-13 apart between runs on several workers; decisions are not that fine)."""
    if workers is not None:
        arguments.whole("diagnose", "workers", workers, low=1)
        arguments.check_workers(workers)  # as --workers: a million were forked from Python
    # -1 fitted all but the last candidate; text raised inside
    arguments.whole("diagnose", "full_fits", full_fits, low=1)
    # one BLAS thread throughout, not only around the candidates' work: the baseline, the ranking
    # and the verdict multiply small matrices too, where a second thread spinning for a busy core
    # cost up to 5x the CPU (the two-body bench's verdict: 1.66 s against 0.55 s); and a product's
    # rounding may depend on the threads that share it
    with threadpool_limits(1), _outliving_left_alone(), kept_simulations():
        return _diagnose(project, effects, experiments, full_fits, progress, prepared, workers)


@contextmanager
def _outliving_left_alone():
    """The objects that exist before diagnose (the caller's, the project's, the imported modules':
    150 000 in a script) outlive it: the collector's full passes during it leave them alone (one
    pass over them cost 50-60 ms of CPU, a twentieth of the thesis bench's diagnosis). Frozen for
    the call. Left to a caller that froze its own (the command line does at start): frozen again,
    what lives at the call would stay out of every pass for good (a round of the demo's loop
    kept 50 MB more each time)."""
    if gc.get_freeze_count():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def _diagnose(project, effects, experiments, full_fits, progress, prepared, workers) -> Diagnosis:
    regs = project.registries
    rev = current_revision(project)
    base = revision_model(project, rev)
    silent: list[str] = []  # records without a signal, left out
    exps = list(prepared) if prepared is not None else prepare(project, experiments, silent)
    names, refiners, not_applicable = _candidate_names(project, rev, base, effects)
    cmp, job, before, res0 = _baseline(project, rev, base, exps)
    # candidates go to forked processes, each with one BLAS thread (where the platform cannot fork,
    # one after another): they inherit the records and models, and only effect names, starts and
    # fitted numbers travel. On 2 cores BLAS threads mostly wait for each other on these small
    # products (CPU time 1.7x the wall time): a process per core uses them better
    workers = workers or default_workers(len(names))
    # a daemonic process (a batch's worker) may not start processes of its own
    parallel = (workers > 1 and "fork" in multiprocessing.get_all_start_methods()
                and not multiprocessing.current_process().daemon)
    token = next(TOKENS)
    job["res0"] = res0
    JOBS[token] = job
    if parallel:  # a candidate may give the structure cubic springs: the workers inherit the loop
        load_nonlinear_loop()
    pool = forked_pool(workers) if parallel else InOrder()
    try:
        with pool:
            screened, evaluations = _screen(pool, token, job, names, progress)
            candidates, fitted, count = _fit_best(pool, token, job, screened[:full_fits], workers if parallel else 1,
                                                  exps, cmp, res0, progress)
            evaluations += count
            candidates, count = _refined(token, job, refiners, candidates, cmp)
            evaluations += count
            pairs, partners, count = _fit_pairs(token, job, candidates, screened, res0, cmp.floor, job["scale"],
                                                pool)
            evaluations += count + sum(c._problem.evaluations for c in pairs)
            candidates += partners
            fitted += [s for s in screened if any(p.effect == s.effect.name for p in partners)]
    finally:
        JOBS.pop(token)
        _ON_TOP[:] = [None, None]  # the records it holds (where the partner search ran here)
    candidates += _screened_only(screened, fitted, job)
    judged = _spent(candidates + pairs)  # _ordered adds the pairs
    candidates = _ordered(candidates, pairs, exps, base, job)
    diagnosis = Diagnosis(baseline_error=cmp.error, noise_floor_error=job["noise"], revision=rev.get("revision"),
                          candidates=candidates, residual_peaks=job["peaks"], evaluations=evaluations,
                          not_applicable=not_applicable, notes=silent + list(cmp.notes) + weight_notes(exps),
                          other_families=[n for n in not_applicable if getattr(regs.effects.get(n), "structures", None)
                                          and not isinstance(base.shared.structure, regs.effects.get(n).structures)])
    _conclude(diagnosis, cmp, base, exps, before, res0)
    diagnosis.evaluations += _spent(candidates) - judged  # the ranking's and the verdict's
    if progress:
        progress("done", len(names), len(names))
    return diagnosis


def _spent(candidates: Sequence[Candidate]) -> int:
    """The model evaluations the candidates' problems have made so far."""
    return sum(c._problem.evaluations for c in candidates if getattr(c, "_problem", None) is not None)


def _candidate_names(project, rev, base, effects: Sequence[str] | None) -> tuple[list[str], list[str], list[str]]:
    """The effects to try (those asked for, or every registered one not yet in the model or
    repeatable), the refiners fitted after the effect they refine, and those that do not apply."""
    regs = project.registries
    in_model = {e["effect"] for e in rev.get("effects", [])}

    def absent(n: str) -> bool:  # or one more of it can be added
        return n not in in_model or getattr(regs.effects.get(n), "repeatable", False)

    names = list(effects) if effects else [n for n in regs.effects.names() if absent(n)]
    # an effect for another model family, or without parameters for this model (no base, no
    # plate), does not apply
    not_applicable = [n for n in names if not applies(regs.effects.get(n), base.shared)]
    if effects and not_applicable:
        raise ConfigError(f"{project.path}: effect(s) {', '.join(not_applicable)} do not apply to this model "
                          f"({base.shared.name!r}, a {family(base.shared)}, on rig {project.rig.name!r})")
    names = [n for n in names if n not in not_applicable]
    if not names:
        raise ConfigError(f"{project.path}: no candidate effects left to try (registered: "
                          f"{', '.join(regs.effects.names()) or 'none'})")
    # an effect that refines another (``refines``) is fitted from that one's fit, after it
    refiners = [n for n in names if getattr(regs.effects.get(n), "refines", None)]
    names += [b for b in dict.fromkeys(regs.effects.get(n).refines for n in refiners)
              if b not in names and b in regs.effects.names() and absent(b)]
    return [n for n in names if n not in refiners], refiners, not_applicable


def _baseline(project, rev, base, exps):
    """The current model against the records: the comparison, the job every candidate's work
    reads (records, fit windows, noise scale, residual peaks, modes in the band), the model's
    predictions and where it fails, resolved by experiment, channel and band."""
    from odsuite.analysis.comparison import compare

    cmp = compare(project, revision=rev, prepared=exps, resonances=False, coordinates=False, tables=False)
    den = sum(float(np.sum(e.measured**2)) for e in exps)
    sse0 = cmp.error**2 * den
    n_eff, f99 = effective_samples(exps)
    stride = max(1, int(exps[0].fs / (5.0 * f99)))
    windows = fit_windows(exps, stride)
    sse0_win = sum(float(np.sum((w.measured - predict(base.for_experiment(w.name), w)) ** 2)) for w in windows)
    noise = cmp.noise_floor_error
    peaks = cmp.residual_peaks
    rig_vals = [max(b["fractions"].values()) for per in cmp.rigidity.values() for b in per.values()
                if b["fractions"]]
    job = {"base": base, "effects": project.registries.effects, "windows": windows, "exps": exps, "floor": cmp.floor,
           "prior": 1e-3 * max(noise**2, 1e-8) * den, "stride": stride,
           # noise energy per independent sample of the calibrated floor: the scale of every test
           "scale": checks.noise_scale(cmp.floor, exps), "sse0_win": sse0_win,
           "peak_hz": [p["frequency_hz"] for p in peaks if p["lacking"]], "sse0": sse0, "den": den,
           "n_eff": n_eff, "noise": noise, "peaks": peaks,
           "rigidity": float(np.median(rig_vals)) if rig_vals else None,
           # the modes within the records' band (a finite-element model's highest modes move most
           # and are seen least)
           "modes_before": [f for f in base.shared.modes().frequency_hz if f <= f99],
           "tail0": max(sse0 - sse0_win, 0.0),
           "force_levels": {e.name: float(np.max(np.abs(e.force))) for e in exps},
           # every candidate's channel weights (fitting.channel_weights of the whole records), once
           "weights": channel_weights(exps)}
    # where the model fails, resolved by experiment, channel and band: the baseline of every gain test
    before = cmp.predictions
    return cmp, job, before, resolution.resolve(exps, before, cmp.floor)


def _screen(pool, token, job, names, progress) -> tuple[list[Screened], int]:
    """Every candidate screened (one linearised step), best first; and the model evaluations spent."""
    screened: list[Screened] = []
    evaluations = 0
    for i, (name, done) in enumerate(zip(names, pool.map(_screen_job, [token] * len(names), names))):
        if progress:
            progress(f"screening {name}", i, len(names))
        if done is not None:
            fixed, u0, sse, count = done
            problem = _problem(job, name, fixed)
            screened.append(Screened(problem.effect, fixed, u0, sse, problem))
            evaluations += count
    screened.sort(key=lambda s: s.sse)
    return screened, evaluations


def _fit_best(pool, token, job, top: list[Screened], ahead: int, exps, cmp, res0, progress):
    """The best screened candidates fitted in full (``ahead`` at a time), each judged against the
    resolved floor; a candidate that cannot compete with the fits before it is left screened only.
    Returns the candidates, the screened ones fitted, and the model evaluations spent."""
    candidates: list[Candidate] = []
    best_win = job["sse0_win"]
    fitted = []
    evaluations = 0
    # the cost at the best screened point: the first candidate is always fitted, from there, so the
    # best single fit ends at or below it whatever order the fits finish in; a fit that cannot
    # come near it nor change its own significance stops (_out_of_reach)
    bound = None
    if top and res0 is not None:
        first = top[0].problem
        spent = first.evaluations
        bound = (_cost(first, top[0].u0), [len(t.problem.free) + len(t.problem.fixed) for t in top])
        evaluations += first.evaluations - spent

    def skipped(k: int, win: float | None = None) -> bool:
        # a candidate whose screening took up less than half of what the best fit so far
        # explains cannot compete: screening only ranks it
        win = best_win if win is None else win
        return k > 0 and top[k].sse > win + 0.5 * (job["sse0_win"] - win)

    def submit(k: int) -> None:
        t = top[k]
        jobs[k] = pool.submit(_fit_job, token, t.effect.name, t.fixed, t.u0, t.sse, bound, False)

    jobs: dict[int, Any] = {}
    queued = 0
    for i, s in enumerate(top):
        while True:
            # a process that has finished takes the next candidate while the fit of i runs on; a
            # finished fit ahead of i may already rule that one out (a guess: each is judged in
            # order below, and submitted then if the guess was wrong)
            done = [jobs[k].result()[0]._sse_win for k in jobs
                    if k >= i and jobs[k].done() and jobs[k].exception() is None]
            busy = sum(1 for k in jobs if k >= i and not jobs[k].done())
            while queued < len(top) and (queued <= i or busy < ahead):
                if not skipped(queued, min([best_win, *done])):
                    submit(queued)
                    busy += 1
                queued += 1
            if ahead == 1 or i not in jobs or jobs[i].done():
                break
            wait([jobs[k] for k in jobs if k >= i and not jobs[k].done()], return_when=FIRST_COMPLETED)
        if skipped(i):
            if i in jobs:
                jobs[i].cancel()
            continue
        if i not in jobs:
            submit(i)
        fitted.append(s)
        if progress:
            progress(f"fitting {s.effect.name}", i, len(top))
        cand = _received(job, exps, cmp, res0, s, *jobs[i].result())
        best_win = min(best_win, cand._sse_win)
        evaluations += cand._problem.evaluations  # the fit's and the judgement's
        candidates.append(cand)
    evaluations += _settled(pool, token, job, candidates, fitted, bound, exps, cmp, res0)
    return candidates, fitted, evaluations


def _settled(pool, token, job, candidates: list[Candidate], fitted: Sequence[Screened], bound, exps, cmp, res0
             ) -> int:
    """The fits stopped out of reach of the top left unsettled (UNSETTLED) fitted again as far and
    validated there, as a fit that settles itself, where their significance may be read (a pair, a
    refinement, the best's place, a proxy's name: _decided_without); in place in ``candidates``
    (``fitted``: their screenings, in the same order). Returns the model evaluations spent."""
    unsettled = [i for i, c in enumerate(candidates) if c.validation == UNSETTLED]
    if not unsettled or _decided_without(candidates, job):
        return 0
    again = {i: pool.submit(_fit_job, token, fitted[i].effect.name, fitted[i].fixed, fitted[i].u0,
                            fitted[i].sse, bound, True) for i in unsettled}
    evaluations = 0
    for i, done in again.items():
        candidates[i] = _received(job, exps, cmp, res0, fitted[i], *done.result())
        evaluations += candidates[i]._problem.evaluations
    return evaluations


def _received(job: Mapping[str, Any], exps, cmp, res0, s: Screened, cand: Candidate, kept: tuple) -> Candidate:
    """A fit from _fit_job with its problem rebuilt, judged against the baseline and its checks' words
    added."""
    cand._problem = _kept_back(_problem(job, s.effect.name, kept[0]), kept)
    _judge(cand, exps, cmp.floor, res0, job["sse0"], job["den"], job["scale"])
    words = _checks_words(cand)
    if words:
        cand.evidence += "; " + words
    return cand


#: the validation of a fit stopped out of reach of the top as passing its likelihood-ratio test,
#: left out where its significance changes nothing (_decided_without)
UNSETTLED = ("not validated, nor its uncertainties read: its fit stopped out of reach of the top, and a candidate "
             "that leaves nothing above the floor decides the diagnosis, so its significance is left undecided")


def _decided_without(candidates: Sequence[Candidate], job: Mapping[str, Any]) -> bool:
    """Whether the significance of the fits stopped out of reach of the top and left unsettled can
    change nothing the diagnosis reads:
    - a significant named mechanism (the lead: the lowest BIC of those) leaves no cell above the
      floor: no pair is then fitted and nothing refined;
    - no data-driven stand-in is significant: prefer_named would give its place to a significant
      named mechanism it is confounded with, however far behind;
    - none could go before the lead: its BIC from its error at the point reached (its validated
      error is higher) is above the lead's, and where it has fewer parameters the lead explains
      significantly more than it (prefer_fewer_parameters would put it first otherwise);
    - none has values that follow the force level: mark_proxies would name it beside an
      amplitude-dependent cause, as the fit's end (where the fit would go on) decides."""
    def stand_in(c: Candidate) -> bool:
        return bool(getattr(job["effects"].get(c.effect), "data_driven", False))

    significant = [c for c in candidates if c.fitted and c.significant]
    explaining = [c for c in significant if not stand_in(c) and not _leaves_cells(c, job)]
    if not explaining or any(stand_in(c) for c in significant):
        return False
    lead = min(significant, key=lambda c: c.bic)
    n_eff = job["n_eff"]
    for c in candidates:
        if c.validation != UNSETTLED:
            continue
        lowest = n_eff * math.log(max(c.error_after**2, 1e-300)) + c.n_parameters * math.log(n_eff)
        if not lowest > lead.bic or c.amplitude_dependent:
            return False
        if c.n_parameters < lead.n_parameters and not (
                getattr(c, "_resolved", None) is not None and getattr(lead, "_resolved", None) is not None
                and resolution.gain(c._resolved, lead._resolved) > resolution.gain_threshold(
                    lead.n_parameters - c.n_parameters)):
            return False
    return True


def _refined(token, job, refiners: list[str], candidates: list[Candidate], cmp) -> tuple[list[Candidate], int]:
    """Each refiner fitted from the fit of the effect it refines (taken to its end where it
    stopped out of reach of the top: _finished), or listed as not fitted with why."""
    evaluations = 0
    for name in refiners:
        refines = job["effects"].get(name).refines
        at = next((i for i, c in enumerate(candidates) if c.effect == refines and c.fitted), None)
        if at is not None and candidates[at]._short:
            candidates[at], count = _finished(token, job, candidates[at], cmp.floor)
            evaluations += count
        refined = _refine(job, name, candidates, job["scale"], cmp.floor)
        if refined is not None:
            candidates.append(refined)
            evaluations += refined._problem.evaluations
            continue
        candidates.append(Candidate(
            effect=name, significant=False, error_after=cmp.error, validated_error=float("nan"),
            parameters={}, uncertainties={}, units={}, n_parameters=0, bic=float("inf"),
            screened_error=cmp.error, fitted=False,
            evidence=(f"not fitted: it refines {job['effects'].get(name).refines}'s fit, which is not "
                      "significant or leaves nothing above the noise floor, or another candidate "
                      "brings the error to the floor")))
    return candidates, evaluations


def _screened_only(screened: list[Screened], fitted: list[Screened], job) -> list[Candidate]:
    """The screened candidates not fitted in full, with the error their one step reaches."""
    out = []
    for s in screened:
        if any(s is f for f in fitted):
            continue
        err = math.sqrt((s.sse + job["tail0"]) / job["den"])
        out.append(Candidate(
            effect=s.effect.name, significant=False, error_after=err,
            validated_error=float("nan"), parameters={}, uncertainties={}, units={},
            evidence=f"screening only: one linearised step reaches error {error_text(err)}",
            n_parameters=len(s.problem.free), bic=float("inf"), screened_error=err,
            fitted=False, consistent=None))
    return out


def _ordered(candidates: list[Candidate], pairs: list[Candidate], exps, base, job) -> list[Candidate]:
    """The candidates in the order the verdict reads them: significant first by BIC, confounded,
    proxy and refinement rules applied, an accepted pair ahead of all."""
    effects = job["effects"]
    mark_confounded([c for c in candidates if c.fitted], exps, job["scale"])
    tell_refinements_apart(candidates, effects, job["den"])
    mark_proxies([c for c in candidates if c.fitted], base)
    candidates.sort(key=lambda c: (not c.significant, c.bic if c.fitted else math.inf, c.screened_error))
    prefer_fewer_parameters(candidates, effects)
    prefer_named(candidates, effects)
    # an accepted pair goes first (it passed the tests against each member and every simpler single);
    # the others are listed last with the reason
    return [c for c in pairs if c.significant] + candidates + [c for c in pairs if not c.significant]


def _partner(job: Mapping[str, Any], first: Candidate, names: Sequence[str], pool=None, token: int = 0
             ) -> tuple[list[Screened], int]:
    """The effect that best explains what ``first``'s fit leaves: every other pairable candidate
    screened on top of that fit; and the best named one where a data-driven stand-in (a mode of any
    shape) is best, as prefer_named orders singles. A second cause the first one masks (a flipped
    sensor beside two swapped cables) gains little on the baseline, where its single screening
    ranks it low. The screenings run on ``pool`` (one after another without one)."""
    pool = pool or InOrder()
    on_top = {**job, "base": first._problem.revision(first._u)}
    found, evaluations = [], 0
    a = job["effects"].get(first.effect)
    names = [n for n in names if n != first.effect and joint.pairable(job["effects"].get(n))
             and joint.joined(a, job["effects"].get(n), job["base"].shared) is not None]
    seed = (first.effect, dict(first._problem.fixed), first._u, first._sse_win)
    for name, done in zip(names, pool.map(_partner_job, [token] * len(names), [seed] * len(names), names)):
        if done is None:
            continue
        fixed, u0, sse, count = done
        evaluations += count
        if sse < first._sse_win:
            found.append(Screened(job["effects"].get(name), fixed, u0, sse, _problem(on_top, name, fixed)))
    found.sort(key=lambda s: s.sse)
    named = next((s for s in found if not getattr(s.effect, "data_driven", False)), None)
    out = found[:1] + ([named] if named is not None and found and named is not found[0] else [])
    # and the best plausible one where the best lies outside its physical range: on top of a
    # biased first fit, a sensor position at its bounds out-screened the gain that, fitted
    # jointly, reached the floor; the pairs' tests choose
    if found and _implausible(found[0]):
        plausible = next((s for s in found if not _implausible(s)), None)
        if plausible is not None and all(plausible is not s for s in out):
            out.append(plausible)
    return out, evaluations


def _screen_on_top(problem: Problem, sse0: float, peaks_hz: Sequence[float]) -> Screened:
    """A candidate screened on top of a fitted first effect (_partner; ``sse0`` that fit's sum of
    squares). Where the first fit is good the residual left is small, so a candidate without
    discrete choices, projected parameters, starts or a frequency or period (the parameters whose
    error is not convex, which fitting.screen's heads and sweeps are for) is judged by one damped
    Gauss-Newton step from its Jacobian at the fitted model on the whole fit windows (linearised
    where the structure changes), not by a step on each head; the others are screened as on the
    baseline."""
    if (problem.discrete or problem.linear or not problem.free
            or any(f.param.starts or f.param.unit in ("Hz", "s") for f in problem.free)):
        return screen(problem, sse0, peaks_hz)
    u0 = problem.zero()
    r0 = problem.residual(u0)
    u = _lm_step(problem, problem.jacobian(u0, r0, tangent=True), r0, u0, problem.exps)
    sse = problem.sse(u)
    if sse < sse0 * (1 - ROUNDING):  # as screen: a gain in the last digits is the arithmetic's
        return Screened(problem.effect, {}, u, sse, problem)
    return Screened(problem.effect, {}, u0, sse0, problem)


def _implausible(s: Screened) -> list[str]:
    """A screened candidate's values outside their physical range."""
    shared, _ = s.problem.values(s.u0)
    return checks.implausible(s.effect, s.problem.base.shared, {**s.problem.fixed, **shared}, s.problem.params)


def _single(token: int, job: Mapping[str, Any], screened: Sequence[Screened], name: str, exps, floor, res0
            ) -> Candidate | None:
    """``name`` fitted alone on the baseline from its screening, judged as the singles are (a pair's
    members are each tested against the other alone)."""
    s = next((t for t in screened if t.effect.name == name), None)
    if s is None:
        return None
    return _judged(token, job, name, s.fixed, s.u0, s.sse, exps, floor, res0)


def _judged(token: int, job: Mapping[str, Any], name: str, fixed, u0: np.ndarray, sse: float, exps, floor, res0
            ) -> Candidate:
    """``name`` fitted in full from ``u0`` (``sse``: its screening's sum of squares) and judged
    against the baseline."""
    cand, kept = _fit_job(token, name, fixed, u0, sse)
    cand._problem = _kept_back(_problem(job, name, kept[0]), kept)
    _judge(cand, exps, floor, res0, job["sse0"], job["den"], job["scale"])
    words = _checks_words(cand)
    if words:
        cand.evidence += "; " + words
    return cand


def _finished(token: int, job: Mapping[str, Any], cand: Candidate, floor) -> tuple[Candidate, int]:
    """A single whose fit stopped out of reach of the top (_out_of_reach) fitted on from where it
    stopped to its end, and judged and checked as every full fit: what starts from its values
    (a pair, a refinement) needs them converged. Returns it and the evaluations spent."""
    p = cand._problem
    done = _judged(token, job, cand.effect, dict(p.fixed), cand._u, cand._screened_sse, job["exps"], floor,
                   job["res0"])
    return done, done._problem.evaluations


def _fit_pairs(token: int, job: Mapping[str, Any], candidates: list[Candidate], screened: Sequence[Screened],
               res0, floor, scale: float, pool=None) -> tuple[list[Candidate], list[Candidate], int]:
    """Pairs of the best significant singles whose residuals overlap, and the best single (and the
    best named one) with the effect that best explains what its fit leaves (_partner), fitted
    jointly from their fits, when every significant candidate leaves cells above the floor. At
    most one is accepted (significant,
    odsuite.diagnosis.joint.accepted): the one of the lowest BIC; the others are returned not
    significant with the reason. Also returns the partners fitted alone for the test (new singles)
    and the model evaluations spent besides the pairs' own fits."""
    pool = pool or InOrder()
    if res0 is None:
        return [], [], 0
    singles = sorted((c for c in candidates if c.fitted and c.significant and getattr(c, "_resolved", None) is not None
                      and joint.pairable(job["effects"].get(c.effect))),
                     key=lambda c: c.bic)
    if not singles or not all(_leaves_cells(c, job) for c in candidates if c.fitted and c.significant):
        return [], [], 0  # a single or a refinement leaves nothing above the floor
    evaluations = 0
    if any(c._short for c in singles):  # the pairs start from the singles' fits: each taken to its end
        for i, c in enumerate(candidates):
            if c.fitted and getattr(c, "_short", False):
                candidates[i], count = _finished(token, job, c, floor)
                evaluations += count
        singles = sorted((c for c in candidates if c.fitted and c.significant
                          and getattr(c, "_resolved", None) is not None
                          and joint.pairable(job["effects"].get(c.effect))), key=lambda c: c.bic)
    # each pair's starts: its members' values and discrete choices
    # (and each member's fit with the other at its nominal values: the nearer start where one
    # member's fit compensated for what the other explains)
    starts = {(a.effect, b.effect): [(joint.fitted(a), joint.fitted(b)), (joint.fitted(a), joint.nominal(b)),
                                     (joint.nominal(a), joint.fitted(b))]
              for a, b in itertools.combinations(singles[:joint.PAIR_CANDIDATES], 2) if joint.overlap(a, b, res0)
              and joint.joined(job["effects"].get(a.effect), job["effects"].get(b.effect), job["base"].shared)}
    added = []
    # the partner of the best single, and of the best named one where a data-driven stand-in (a
    # mode of any shape) is best: the order prefer_named gives the singles
    named = next((c for c in singles if not getattr(job["effects"].get(c.effect), "data_driven", False)), None)
    seeds = [singles[0]] + ([named] if named is not None and named is not singles[0] else [])
    initial = len(seeds)
    for first in seeds:  # grows by the partners of an implausible seed below, once
        partners, count = _partner(job, first, [s.effect.name for s in screened], pool, token)
        evaluations += count
        for partner in partners:
            name = partner.effect.name
            single = next((c for c in candidates + added if c.effect == name and c.fitted), None)
            if single is None:  # fitted alone too: each member is tested against the other alone
                single = _single(token, job, screened, name, job["exps"], floor, res0)
                if single is not None:
                    added.append(single)
                    evaluations += single._problem.evaluations
            if single is None or getattr(single, "_resolved", None) is None:
                continue
            if (any(first is s for s in seeds[:initial]) and not first.plausible and single.plausible
                    and single.n_parameters < first.n_parameters and all(single is not s for s in seeds)):
                # a seed outside its physical range with more parameters than its partner may stand
                # in for that one and a second cause: the partner's partner is searched too
                seeds.append(single)
            shared, per = partner.problem.values(partner.u0)
            on_top = joint.Fitted(name, shared, per, dict(partner.problem.fixed))
            key = next((k for k in starts if set(k) == {first.effect, name}), (first.effect, name))
            starts.setdefault(key, []).insert(0, (joint.fitted(first), on_top))
    out = []
    # the pairs' fits on the pool, judged here in order
    significant = [(c.n_parameters, c._cost_win, c.effect, getattr(c, "_resolved", None))
                   for c in candidates + added if c.fitted and c.significant]
    fits = [pool.submit(_pair_job, token, key, options, significant) for key, options in starts.items()]
    for ((ea, eb), options), fitting in zip(starts.items(), fits):
        a = next(c for c in candidates + added if c.effect == ea)
        b = next(c for c in candidates + added if c.effect == eb)
        cand, kept, count, stop = fitting.result()
        evaluations += count
        cand._problem = _kept_back(_pair_problem(job, ea, eb, kept[0]), kept)
        _judge(cand, job["exps"], floor, res0, job["sse0"], job["den"], scale)
        if cand._stopped:
            ok, why = False, stop
        else:
            if cand._resolved is not None:  # each member at its nominal values: the other alone (joint.added)
                # not a member of discrete choices alone (a polarity): with none of its parameters free
                # the point is the pair's own, a gain of 0 over "the other alone"
                cand._without = {m: resolution.resolve(job["exps"], joint.without(
                    cand._problem, cand._u, m, cand._problem.full), floor) for m in (ea, eb)
                    if any(f.param.name.split(".", 1)[0] == m for f in cand._problem.free)}
            ok, why = joint.accepted(cand, (a, b), candidates + added)
        cand.significant = ok
        cand.evidence = f"fitted jointly from the single fits: {why}; " + cand.evidence
        words = _checks_words(cand)
        if words:
            cand.evidence += "; " + words
        out.append(cand)
    best = min((c for c in out if c.significant), key=lambda c: c.bic, default=None)
    for c in out:
        if c.significant and c is not best:
            c.significant = False
            c.evidence = f"a better pair is {best.effect}; " + c.evidence
    return out, added, evaluations


def _pair_problem(job: Mapping[str, Any], ea: str, eb: str, fixed: Mapping[str, float]) -> Problem:
    effect = joint.joined(job["effects"].get(ea), job["effects"].get(eb), job["base"].shared)
    return Problem(job["base"], effect, job["windows"], fixed, prior=job["prior"] / job["stride"],
                   stride=job["stride"], full=job["exps"], noise_scale=job["scale"], weights=job["weights"])


def _pair_job(token: int, pair: tuple[str, str], options: Sequence[Sequence[joint.Fitted]],
              significant: Sequence[tuple[int, float, str, Any]]) -> tuple[Candidate, tuple, int, str]:
    """Fit one pair jointly from the nearest of its starts (``options``: the members' starts); it
    stops where it cannot come near the simplest significant single it must beat, or cannot pass
    the likelihood-ratio test against one with fewer parameters (``significant``: each one's
    parameters, sum of squares over the fit windows, effect and resolved residual;
    _cannot_pass). Returns the candidate without its problem (_kept), the evaluations of the
    starts not fitted, and why its fit stopped (where it did)."""
    job = JOBS[token]
    tried = []
    for members in options:  # of several starts, the one nearest the data is fitted
        fixed = {f"{m.effect}.{k}": v for m in members for k, v in m.fixed.items()}
        problem = _pair_problem(job, *pair, fixed)
        u0 = joint.start(problem, members)
        tried.append(Screened(problem.effect, fixed, u0, problem.sse(u0), problem))
    best = min(tried, key=lambda t: t.sse)
    other = sum(t.problem.evaluations for t in tried if t is not best)  # the best's count with its fit
    # the simplest significant single it must beat (joint.accepted): its fit stops where it cannot
    k = len(best.problem.free) + len(best.problem.fixed)
    simpler = min((c for c in significant if c[0] < k), key=lambda c: c[1], default=None)
    why = [] if simpler is None else [f"its fit stopped where it could not come near {simpler[2]}'s error"]
    cannot_pass = _cannot_pass(best.problem, [(n, name, res) for n, _, name, res in significant if n < k],
                               job["floor"], k, why)
    cand = _fit_candidate(best, job["windows"], job["sse0"], job["den"], job["n_eff"], job["noise"], job["peaks"],
                          job["rigidity"], job["modes_before"], job["tail0"], job["force_levels"],
                          target=None if simpler is None else simpler[1], cannot_pass=cannot_pass,
                          floor=job["floor"])
    return cand, _kept(cand.__dict__.pop("_problem")), other, why[-1] if why else ""


#: a pair's fit stops where, at the point it reached, its likelihood ratio over a significant
#: single with fewer parameters, plus this many times what its linearisation there still
#: promises (in noise energies), stays within the test's limit (_cannot_pass). Along a fit the
#: ratio gained up to 3.7 times the promise at a point (the thesis bench's stiffness +
#: nonlinear_stiffness: -35.2 to -24.9 after a promise of 2.8), the later linearisations
#: promising more: ten leaves room
JOINT_REACH = 10.0


def _cannot_pass(problem: Problem, simpler: Sequence[tuple[int, str, Any]], floor, k: int, why: list[str]
                 ) -> Callable[[np.ndarray, float], bool]:
    """Whether a pair's fit (``problem``, ``k`` parameters) at ``x``, gaining at most JOINT_REACH
    times the fall ``promised`` (in cost), can no longer pass joint.accepted's likelihood-ratio
    test against a significant single with fewer parameters (``simpler``: each one's parameters,
    effect and resolved residual): a member adding too little over the other alone, or a simpler
    single explaining as much. The ratio over a single's fit bounds the test's (joint.added takes
    the smaller of two); each check predicts the whole records once. A single the pair beats with
    that much room is not asked again. Appends the words why to ``why`` when it says stop."""
    tests = [(res, resolution.gain_threshold(k - n), name) for n, name, res in simpler if res is not None]
    unit = 2.0 * problem.stride / problem.noise_scale if problem.noise_scale > 0 else 0.0  # cost -> noise energies

    def cannot_pass(x: np.ndarray, promised: float) -> bool:
        del why[1:]  # words of an earlier call that a differenced Jacobian overruled
        if not tests or unit == 0.0:
            return False
        try:
            predictions = problem.predictions(x, problem.full)
        except (DivergedError, NonPhysicalError):  # a trial point the fit itself scores as bad
            return False
        res = resolution.resolve(problem.full, predictions, floor)
        if res is None:
            tests.clear()
            return False
        reach = JOINT_REACH * promised * unit
        gains = [resolution.gain(before, res) for before, _, _ in tests]
        for g, (_, limit, name) in zip(gains, tests):
            if g + reach <= limit:
                why.append(f"its fit stopped where it could not pass the test against {name} (likelihood ratio "
                           f"{g:.3g}, at most {reach:.3g} more by its linearisation, for a limit of {limit:.3g})")
                return True
        tests[:] = [t for g, t in zip(gains, tests) if g <= t[1] + reach]
        return False

    return cannot_pass


def _kept(p: Problem) -> tuple:
    """What a fitted problem hands back from a worker process: its fixed values, evaluations and
    the predictions and projection it kept (the judgement asks for them again)."""
    return p.fixed, p.evaluations, p._predictions, p._projection


def _kept_back(problem: Problem, kept: tuple) -> Problem:
    """``problem`` (rebuilt from the kept fixed values) as the worker's was (_kept)."""
    _, problem.evaluations, problem._predictions, problem._projection = kept
    for _, predictions in problem._predictions:  # read-only, as the worker kept them (unpickled: writeable)
        for p in predictions:
            p.flags.writeable = False
    return problem


def _leaves_cells(cand: Candidate, job: Mapping[str, Any]) -> bool:
    """Whether the fitted candidate leaves a cell above its floor (the verdict's test; the pooled
    error where the floor has no bands)."""
    res = getattr(cand, "_resolved", None)
    return res.detected() if res is not None else cand.error_after > FLOOR_TOLERANCE * job["noise"]


def _refine(job: Mapping[str, Any], name: str, candidates: Sequence[Candidate], scale: float,
            floor=None) -> Candidate | None:
    """Fit the refining effect ``name`` from the fit of the effect it refines, when that one is
    significant and leaves the residual above the floor, and no candidate but another refinement
    brings it there (else there is nothing for it to add). It counts as significant only when its
    own parameters' gain over that fit passes the test the gain of as many parameters fitted to
    noise would fail (checks.gain_threshold)."""
    effect = job["effects"].get(name)
    start = next((c for c in candidates if c.effect == effect.refines and c.fitted), None)
    # refiners are fitted alike whatever their order: another refinement does not stop one
    done = [c for c in candidates if c.fitted and c.significant
            and not getattr(job["effects"].get(c.effect), "refines", None)]
    if (start is None or not start.significant or not _leaves_cells(start, job)
            or not all(_leaves_cells(c, job) for c in done)):  # another candidate has explained it all
        return None
    problem, u0 = refined(start._problem, start._u, effect)
    cand = _fit_candidate(Screened(effect, problem.fixed, u0, problem.sse(u0), problem), job["windows"], job["sse0"],
                          job["den"], job["n_eff"], job["noise"], job["peaks"], job["rigidity"],
                          job["modes_before"], job["tail0"], job["force_levels"], floor=job["floor"])
    den = job["den"]
    cand._problem = problem
    _judge(cand, job["exps"], floor, getattr(start, "_resolved", None), start.validated_error**2 * den, den, scale,
           k=max(cand.n_parameters - start.n_parameters, 1))
    cand.evidence += (f"; fitted from {start.effect}'s fit (validated error {error_text(start.validated_error)} -> "
                      f"{error_text(cand.validated_error)})")
    words = _checks_words(cand)
    if words:
        cand.evidence += "; " + words
    return cand


def _held_by_tails(exps, base, before, res0):
    """Where no record has samples before its hit to tell the noise's colour and nothing explains
    the cells above the (white) floor, or a candidate only part of them: the baseline's residual
    resolved against the floor the model's residual on the records' quiet tails shows
    (noise_floor.estimate's tail_residuals) and whether only bands no single tail resolves stay
    above it, where nothing else does; else (None, False). Nulls recorded from their hit under 1/f
    noise or a floor's vibration read "unexplained" (2 and 5 of 12), or "partly explained" by a
    mode fitted to the vibration (2 of 12); the detection and the candidates' tests keep the white
    floor, since a softer mount ringing into the tails raises the tails' floor alike (10 N faults
    at 8-18x their noise then read "nothing to explain")."""
    if res0 is None or any(noise_colour.has_pre_hit_lines(e) for e in exps):
        return None, False
    held = resolution.resolve(exps, before, noise_floor(exps, base, spectra=True, tail_predictions=before))
    if held is None or not held.detected():
        return held, False
    # what stays above is only in bands no tail holds two lines of (a slow wave there reads as a
    # trend): those the tails cannot tell (4 of 40 plate-and-motor nulls under a floor's
    # vibration, 0.05 s tails, read "unexplained" at 12.5-25 Hz)
    shown = resolution.judged_on_one_stretch(held, witnesses(exps))
    return (None, False) if shown.detected() else (shown, True)


def _conclude(d: Diagnosis, cmp, base, exps, before=None, res0=None) -> None:
    """The verdict (from the resolved residual where the floor has bands), the signature of what
    is left (after the best significant candidate, if any) and the message."""
    best = next((c for c in d.candidates if c.significant and c.fitted), None)
    nonlinear = best is not None and makes_nonlinear(best, base)  # builds the fit's models: once
    # amplitude dependence as the data show it: the best significant candidate's parameters, fitted
    # per experiment, follow the force level, or it makes the model amplitude dependent (without
    # one: any fitted candidate's). A stand-in's drifting parameters say it stands in, not that the
    # structure is nonlinear: a mass fitted for a worn mount followed the force level
    amplitude = (bool(best.amplitude_dependent) or nonlinear if best is not None
                 else any(c.amplitude_dependent for c in d.candidates if c.fitted))
    res_best, floor_best = getattr(best, "_resolved", None) if best is not None else None, cmp.floor
    after = None
    if best is not None:
        p = best._problem
        after = p.predictions(best._u, p.full)
        if res_best is not None:
            # what is left is judged against the floor the candidate's model would leave if right
            # (its signals' rounding, its response to the force channel's noise), as compare
            # judges the revision that stores it
            floor_best = noise_floor(exps, p.models(best._u), spectra=True, colours=cmp.floor.colours)
            res_best = resolution.resolve(exps, after, floor_best)
    if res_best is not None and not res_best.detected() and len(getattr(best, "_early_late_u", ())) == 2:
        # the verdict's cell test on the late (small) part of the records as the early part's fit
        # predicts it: the parts' parameter test alone took true added masses as a rattle's stand-in.
        # Only where the candidate leaves no cell above the floor: else the late part's own fit
        # takes up some of what is left (a second effect) and the test measures that, not the candidate
        early, late = (p.predictions(u, p.full) for u in best._early_late_u)
        part = checks.held_out(exps, early, late, floor_best, best._early_late_cuts,
                               checks.early_spread(p, getattr(best, "_early_late", None), p.full))
        best.early_late_agree = part is None or not part.detected()
        best.early_late_cells = [] if part is None else part.cells(3)
    elif res_best is not None and res_best.detected():
        # the parts' parameter test then sees what is left too, not the candidate: neither decides
        best.early_late_agree = None
        best.early_late_note = ("not tested: cells stay above the floor after it, and the late part's own fit "
                                "would take up some of them")
    d.verdict = decide(d.baseline_error, d.noise_floor_error, best, before=res0, after=res_best,
                       amplitude_cause=nonlinear)
    modes = list(base.shared.modes().frequency_hz)
    if before is None:
        before = [predict(base.for_experiment(e.name), e) for e in exps]
    held, short = (_held_by_tails(exps, base, before, res0) if d.verdict in ("unexplained", "partly explained")
                   else (None, False))
    if held is not None:
        d.verdict = "nothing to explain"
        # a gain against the white floor where the tails' noise holds every cell is that noise's:
        # the model's residual has no excess left to take (a floor's vibration at 12.5-25 Hz, a
        # mode fitted to it "significant" in 2 of 12 nulls recorded from their hit)
        held_where = ("every cell of the model's residual but in bands no tail holds two lines of" if short
                      else "every cell of the model's residual")
        for c in d.candidates:
            if c.significant:
                c.significant = False
                c.evidence += (f"; not significant against the noise the records' quiet tails show, which "
                               f"holds {held_where}")
    # the residuals' spectra the peaks took serve the signature
    sig_before = signature(exps, before, cmp.floor, d.residual_peaks, amplitude, res0,
                           cmp.residual_spectra if before is cmp.predictions else None)
    if held is not None:
        sig_before.unjudged, sig_before.cells = held.unjudged() if short else sig_before.cells, []
        sig_before.strongest_cell, sig_before.tails_hold, sig_before.tails_short = held.strongest(), True, short
    rest = None
    if best is not None and d.verdict != "nothing to explain":
        spectra = residual_spectra(exps, after)
        rest = signature(exps, after, floor_best, residual_peaks(exps, after, modes, floor_best, spectra=spectra),
                         amplitude, res_best, spectra)
    d.signature = rest if rest is not None else sig_before
    d.message = message(d.verdict, d.baseline_error, d.noise_floor_error, best, sig_before, rest)
    if d.verdict in ("unexplained", "partly explained") and d.other_families:
        # why the library may hold nothing for it here: what it holds for other model families
        d.message += (f" Not tried, as they apply to other model families than this model's "
                      f"({base.shared.name or family(base.shared)}): {', '.join(d.other_families)}.")

