"""How the diagnosis orders its fitted candidates: significance, confounding (candidates that explain
the same residual), refinements told apart, proxies for amplitude-dependent physics, and the
preference for fewer parameters and for named mechanisms over data-driven stand-ins."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from odsuite.analysis import resolved as resolution
from odsuite.diagnosis import checks

#: diagnose's Candidate (fitted effect, its error and tests): named, not imported, since diagnose
#: imports this module
Candidate = Any

#: candidates whose prediction changes have at least this cosine similarity are named as confounded
CONFOUNDED_COSINE = 0.9


def is_significant(sse0: float, sse_validated: float, threshold: float) -> bool:
    """The validated gain in sum of squares exceeds what fitting the candidate's parameters to the
    calibrated noise would give with probability checks.FALSE_ALARM (``threshold``,
    checks.gain_threshold)."""
    return sse0 - sse_validated > threshold


def prefer_fewer_parameters(cands: list[Candidate], effects) -> None:
    """A significant candidate confounded with the top one and with fewer parameters goes first
    unless the top one's change of the resolved residual over it passes the likelihood-ratio test
    for its extra parameters: a proxy with more freedom does not win on the same residual. Nor does
    a proxy with less: a simpler candidate whose parameters, fitted per experiment, disagree is not
    promoted over a top one whose parameters agree (a stiffness pattern standing in for a pump's
    added mass fits each hit with other values; the mass, with twice the parameters, fits all
    hits with one)."""
    if not cands or not cands[0].significant or getattr(cands[0], "_resolved", None) is None:
        return
    top = cands[0]
    # a data-driven stand-in (a mode of any shape) is not promoted over a named mechanism
    simpler = [c for c in cands[1:] if c.significant and c.fitted and c.effect in top.confounded_with
               and not getattr(effects.get(c.effect), "data_driven", False)
               and (c.consistent is not False or top.consistent is False)
               and c.n_parameters < top.n_parameters and getattr(c, "_resolved", None) is not None]
    for c in sorted(simpler, key=lambda c: c.n_parameters):
        extra = top.n_parameters - c.n_parameters
        if resolution.gain(c._resolved, top._resolved) <= resolution.gain_threshold(extra):
            cands.remove(c)
            cands.insert(0, c)
            return


def prefer_named(cands: list[Candidate], effects) -> None:
    """A data-driven stand-in on top (a mode of any shape) gives the first place to a significant
    named mechanism it is confounded with: the same residual explained, and the cause named."""
    if not cands or not cands[0].significant or not getattr(effects.get(cands[0].effect), "data_driven", False):
        return
    named = next((c for c in cands[1:] if c.significant and c.effect in cands[0].confounded_with
                  and not getattr(effects.get(c.effect), "data_driven", False)), None)
    if named is not None:
        cands.remove(named)
        cands.insert(0, named)


def explains_more(a: Candidate, b: Candidate) -> bool:
    """``b`` explains more than ``a`` by more than ``b``'s parameters fitted to noise could: the
    change from ``a``'s resolved residual to ``b``'s against the significance test's threshold for
    ``b``'s parameters (odsuite.analysis.resolved). The two models are not nested, so this is that
    threshold used as a yardstick, not a likelihood-ratio test with a stated false-alarm rate.
    False without resolved residuals."""
    ra, rb = getattr(a, "_resolved", None), getattr(b, "_resolved", None)
    if ra is None or rb is None:
        return False
    return resolution.gain(ra, rb) > resolution.gain_threshold(b.n_parameters)


def _told_apart(a: Candidate, b: Candidate) -> bool:
    """``b`` explains significantly more than ``a`` and is a named mechanism: a data-driven stand-in
    (a mode of any shape) explains more of any residual of its shape by its freedom, which tells
    nothing of the cause (a free mode of 20 parameters beside the true plate bending mode of 5),
    as prefer_named has it."""
    return explains_more(a, b) and not getattr(getattr(b._problem, "effect", None), "data_driven", False)


def mark_confounded(cands: Sequence[Candidate], exps, scale: float) -> None:
    """Candidates that explain the same residual cannot be told apart by these experiments; name
    each other: their fitted changes of the predictions differ by less than noise could
    (checks.indistinguishable), or point the same way (cosine above CONFOUNDED_COSINE), and
    neither explains significantly more than the other (``explains_more``; a data-driven stand-in
    explaining more does not count, ``_told_apart``): alike changes of which one leaves far less
    of the residual (a foot's stiffness at validated 0.028 against a mass at 0.375) are told apart by how much
    each explains."""
    changes = {}
    for c in cands:
        if c.error_after >= c.screened_error * 1.5:
            continue
        p = c._problem
        if p.linear:  # projected parameters are fitted at any search value: the base is without the effect
            base_pred = np.concatenate([p.base_prediction(e).ravel() for e in p.exps])
        else:
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
            ca = next(c for c in cands if c.effect == a)
            cb = next(c for c in cands if c.effect == b)
            if ((abs(va @ vb) / (na * nb) > CONFOUNDED_COSINE
                    or checks.indistinguishable(va, vb, scale, ca.n_parameters + cb.n_parameters))
                    and not _told_apart(ca, cb) and not _told_apart(cb, ca)):
                ca.confounded_with.append(b)
                cb.confounded_with.append(a)


def tell_refinements_apart(cands: Sequence[Candidate], effects, den: float) -> None:
    """Refinements of one fit are told apart from it and from each other by the gain test, however
    alike their changes of the predictions look: a refiner's significance is its gain over the fit
    it refines, and of two refiners the better is apart when its gain over the other passes the test
    for its own extra parameters."""
    def apart(a: Candidate, b: Candidate) -> None:
        if b.effect in a.confounded_with:
            a.confounded_with.remove(b.effect)
        if a.effect in b.confounded_with:
            b.confounded_with.remove(a.effect)

    refiners = [c for c in cands if c.fitted and getattr(effects.get(c.effect), "refines", None)]
    for c in refiners:
        if c.significant:
            apart(c, next(b for b in cands if b.effect == effects.get(c.effect).refines))
        for o in refiners:
            if (o is not c and effects.get(o.effect).refines == effects.get(c.effect).refines
                    and is_significant(o.validated_error**2 * den, c.validated_error**2 * den, c.gain_threshold)):
                apart(c, o)


def makes_nonlinear(cand: Candidate, base) -> bool:
    """The candidate's fitted model responds to the force level (cubic springs) where the base
    model does not."""
    if not base.shared.structure.is_linear:
        return False
    return not all(m.structure.is_linear for m in cand._problem.models(cand._u).values())


def mark_proxies(cands: Sequence[Candidate], base) -> None:
    """A linear candidate whose parameters, fitted per experiment, follow the force level
    (``amplitude_dependent``) is a proxy: a linear change cannot depend on the level, so it stands in
    for amplitude-dependent physics. A candidate that makes the model amplitude dependent and fits
    the records better (its error over all of them, not its leave-one-experiment-out error: left out,
    the top force level is an extrapolation) is named by the proxy (``confounded_with``), and names
    it: both describe the level-dependent part of the residual, which only one of them can cause."""
    causes = [c for c in cands if makes_nonlinear(c, base)]
    for c in cands:
        if not c.amplitude_dependent or c in causes:
            continue
        for n in causes:
            if n.error_after < c.error_after and n.effect not in c.confounded_with:
                c.confounded_with.append(n.effect)
                n.confounded_with.append(c.effect)
