"""Two causes at once: effects fitted together as one, and the pairs of the single candidates that
the diagnosis fits jointly where their residuals overlap.

A pair is accepted by the rules the singles are judged and ranked by: each member must remove
significantly more than the other does alone (odsuite.analysis.resolved's likelihood ratio on the
resolved, whitened residual, the test for its own parameters; "alone" is the better of the other's
single fit and the pair's fit with the member at its nominal values, so a member is tested
against the best fit without it that is known: the nested models' likelihood-ratio test), and the pair must beat each member
by the validated (held-out) error and by the BIC the singles are ranked with, so a pair is never
named where one effect explains the residual; and no significant single with fewer parameters may explain it as well (the
test for the pair's extra parameters), so a proxy pair is not preferred to a simpler cause.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from odsuite.analysis import resolved as resolution
from odsuite.analysis.prediction import predict

#: single candidates (significant, best first) whose pairs are fitted jointly
PAIR_CANDIDATES = 3


class Joint:
    """Several effects as one: parameters named "<effect>.<parameter>", applied in order."""

    def __init__(self, effects: Sequence[Any]) -> None:
        self.effects = list(effects)
        self.name = "+".join(e.name for e in self.effects)
        self.target = "model" if any(e.target == "model" for e in self.effects) else "chain"
        self.breaks_rigidity = any(getattr(e, "breaks_rigidity", False) for e in self.effects)

    def parameters(self, model) -> list:
        return [replace(p, name=f"{e.name}.{p.name}") for e in self.effects for p in e.parameters(model)]

    def apply(self, model, values: Mapping[str, float]):
        for e in self.effects:
            model = e.apply(model, own(e, values))
        return model

    def values(self, model, values: Mapping[str, float] | None = None) -> dict[str, float]:
        """Each member's values completed with its nominals, on the model the members before it made."""
        out = {}
        for e in self.effects:
            v = e.values(model, own(e, values or {}))
            out.update({f"{e.name}.{k}": x for k, x in v.items()})
            model = e.apply(model, v)
        return out

    def physical(self, model, values: Mapping[str, float]) -> list[tuple[str, float, str]]:
        """The members' physical quantities (each on the model the members before it made), and the
        values of a member that reports none: a pair is reported as its members are."""
        rows = []
        for e in self.effects:
            v = e.values(model, own(e, values))
            if getattr(e, "physical", None) is not None:
                rows += list(e.physical(model, v))
            else:
                rows += [(f"{e.name} {p.name}", v[p.name], p.unit) for p in e.parameters(model) if p.name in v]
            model = e.apply(model, v)
        return rows


def own(effect, values: Mapping[str, float]) -> dict[str, float]:
    """A member's values out of a joint's "<effect>.<parameter>" table."""
    return {k.split(".", 1)[1]: v for k, v in values.items() if k.split(".", 1)[0] == effect.name}


def projects(effect) -> bool:
    """The effect solves parameters of its own by projection (a mode's participations)."""
    return callable(getattr(effect, "linear_parameters", None))


class ProjectingJoint(Joint):
    """A pair whose second member solves its own parameters by projection (a mode's participations)
    on the models the first has changed; the search runs over the rest, as for that member alone."""

    def linear_parameters(self, model) -> list[str]:
        last = self.effects[-1]
        return [f"{last.name}.{n}" for n in last.linear_parameters(model)]

    def project(self, models, values, exps, base, weights):
        first, last = self.effects
        moved = {n: first.apply(m, own(first, values)) for n, m in models.items()}
        before = [predict(moved[e.name], e) for e in exps]
        shared, per, deltas = last.project(moved, own(last, values), exps, before, weights)
        return ({f"{last.name}.{k}": v for k, v in shared.items()},
                {n: {f"{last.name}.{k}": v for k, v in t.items()} for n, t in per.items()},
                [p - b + d for p, b, d in zip(before, base, deltas)])


def joined(a, b, model) -> Joint | None:
    """The pair of effects ``a`` and ``b`` as one, the projecting one (or one that ``adds_body``)
    last; None where a joint fit cannot hold them: both project, or the other has values per
    experiment (a projection sees the shared values only)."""
    if projects(a) and projects(b):
        return None
    if projects(a) or projects(b):
        first, last = (b, a) if projects(a) else (a, b)
        if any(p.scope == "per_experiment" for p in first.parameters(model)):
            return None
        return ProjectingJoint([first, last])
    if getattr(a, "adds_body", False) and not getattr(b, "adds_body", False):
        # the other's parameters are named on the model without the new body
        a, b = b, a
    return Joint([a, b])


@dataclass
class Fitted:
    """A member's start in a joint fit: its values, per experiment values and discrete choices."""

    effect: str
    values: Mapping[str, float]
    per_experiment: Mapping[str, Mapping[str, float]]
    fixed: Mapping[str, float]


def fitted(c) -> Fitted:
    """A fitted single candidate as a joint fit's start."""
    return Fitted(c.effect, c.values, c.per_experiment, dict(c._problem.fixed))


def nominal(c) -> Fitted:
    """A fitted single candidate's start at its nominal values (its discrete choices kept)."""
    return Fitted(c.effect, {}, {}, dict(c._problem.fixed))


def pairable(effect) -> bool:
    """An effect the diagnosis pairs: one that refines no other fit (it is fitted from that fit
    alone) and solves no parameters by projection. ProjectingJoint can hold the latter, but its
    projected parameters (a mode's participations at every sensor and blow) are not counted in
    the BIC and the likelihood-ratio test, so such a pair would beat a named cause with fewer true
    parameters (a gain + 35 degree tilt was named sensor_orientation+missing_mode)."""
    return not getattr(effect, "refines", None) and not projects(effect)


def overlap(a, b, before: resolution.Resolved) -> bool:
    """Both candidates lower the residual in a common cell that is above its floor: their residuals
    overlap there, so fitted alone each is biased by the other's part."""
    ra, rb = a._resolved, b._resolved
    for q0, lim, qa, qb in zip(before.ratios(), before.limit, ra.ratios(), rb.ratios()):
        above = q0 > lim
        if np.any(above & (qa < q0) & (qb < q0)):
            return True
    return False


def start(problem, members: Sequence[Any]) -> np.ndarray:
    """The joint problem's start: each member's single fit, in the joint's normalised units."""
    u = problem.zero()
    for i, f in enumerate(problem.free):
        eff, name = f.param.name.split(".", 1)
        c = next((m for m in members if m.effect == eff), None)
        if c is None:
            continue
        v = c.per_experiment.get(f.experiment, {}).get(name) if f.experiment else c.values.get(name)
        if v is not None:
            u[i] = float(np.clip((float(v) - f.param.nominal) / f.scale, *f.bounds))
    return u


def without(problem, u: np.ndarray, effect: str, exps=None) -> list[np.ndarray]:
    """A joint fit's predictions on ``exps`` (the fit's own where None) with ``effect`` left out:
    the other member alone, at the values the pair fitted it to. A projected member (a
    ProjectingJoint's last) is left out by predicting the first member's model: with its searched
    values at their nominal ones (a mode at its nominal frequency) the projection would still fit
    it there."""
    exps = list(exps or problem.exps)
    members = getattr(problem.effect, "effects", [])
    if isinstance(problem.effect, ProjectingJoint) and members[-1].name == effect:
        first = members[0]
        shared, _ = problem.values(u, exps)
        return [predict(first.apply(problem.base.for_experiment(e.name), own(first, shared)), e) for e in exps]
    out = np.array(u, float)
    zero = problem.zero()
    for i, f in enumerate(problem.free):
        if f.param.name.split(".", 1)[0] == effect:
            out[i] = zero[i]
    return problem.predictions(out, exps)


def added(pair, m, other) -> float:
    """The likelihood-ratio statistic of ``other``'s parameters in the pair: the pair's gain over
    ``m`` alone, whichever fit of ``m`` alone leaves less, its single fit or the pair's with
    ``other`` at its nominal values (``pair._without[other.effect]``, a resolved residual). The
    second is a fit of ``m`` alone too, and the better one where the single fit stopped short: a
    coupling's corners held at zero as not identifiable, a mass of 1.999 kg for 2 kg that the
    pair fitted beside the corners then seemed to add a likelihood ratio of 1,650."""
    g = resolution.gain(m._resolved, pair._resolved)
    alone = getattr(pair, "_without", {}).get(other.effect)
    return g if alone is None else min(g, resolution.gain(alone, pair._resolved))


def accepted(pair, members: Sequence[Any], singles: Sequence[Any]) -> tuple[bool, str]:
    """Whether the pair's joint fit is a finding, and the words why (or why not)."""
    if not pair.significant:
        return False, "the pair is not significant"
    for m, other in (members, members[::-1]):
        # on data it was not fitted to, and by the ranking's penalty for parameters, the pair must
        # beat each member alone: a second effect that soaks up a sliver of a misfit the first
        # leaves (its gain on the resolved residual is large wherever cells hold many lines) does not
        if not (pair.validated_error < m.validated_error and pair.bic < m.bic):
            return False, (f"{other.effect} does not improve {m.effect}'s validated error "
                           f"({m.validated_error:.4g} -> {pair.validated_error:.4g}) by more than its "
                           f"{pair.n_parameters - m.n_parameters} parameters' penalty")
        extra = max(pair.n_parameters - m.n_parameters, 1)
        g = added(pair, m, other)
        if not g > resolution.gain_threshold(extra):
            return False, (f"{other.effect} adds no significant gain over {m.effect} alone "
                           f"(likelihood ratio {g:.3g} for a limit of {resolution.gain_threshold(extra):.3g})")
    for s in singles:
        if s.significant and s.n_parameters < pair.n_parameters and getattr(s, "_resolved", None) is not None:
            extra = pair.n_parameters - s.n_parameters
            if resolution.gain(s._resolved, pair._resolved) <= resolution.gain_threshold(extra):
                return False, f"{s.effect} alone explains as much with fewer parameters"
    g = [added(pair, m, o) for m, o in (members, members[::-1])]
    return True, (f"each adds significantly over the other alone (likelihood ratio "
                  f"{g[1]:.3g} over {members[1].effect}, {g[0]:.3g} over {members[0].effect})")
