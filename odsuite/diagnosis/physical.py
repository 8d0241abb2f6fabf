"""A fitted effect in physical quantities: what its optional ``physical(model, values)`` names (an
effective stiffness in N/m, a mass in kg, a position in mm), each with the uncertainty the fit's
covariance gives it.

Parameters the data cannot separate (a stiffness scale per axis times one per spring group) have
large, correlated uncertainties; the quantities an effect reports are their determined combinations,
so their propagated uncertainties are small where the data determine them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from odsuite.domain.display import unit_text
from odsuite.domain.errors import NonPhysicalError

#: finite-difference step of the propagation, as a fraction of a parameter's standard deviation
STEP = 1e-3


def quantities(effect, model, values: Mapping[str, float], labels: Sequence[str] = (),
               sds: Sequence[float] = (), corr: np.ndarray | None = None,
               spread: np.ndarray | None = None) -> list[dict[str, Any]]:
    """``effect.physical(model, values)`` as rows {label, value, unit, uncertainty}, the uncertainty
    propagated linearly from the shared parameters ``labels`` (the fit's standard deviations
    ``sds``, correlation ``corr``; None: independent), or from ``spread`` where that gives more (a
    covariance of the same parameters between records, between_records; propagated as a whole so
    that parameters moving together leave their determined products as certain as they are).
    [] when the effect reports no physical quantities."""
    physical = getattr(effect, "physical", None)
    if physical is None:
        return []
    complete = effect.values(model, {k: v for k, v in values.items() if v is not None})
    try:
        rows = physical(model, complete)
    except NonPhysicalError:  # a fit stopped where no physical body has its values: none to report
        return []
    # the model's own values, where the effect at its nominal reports the same quantities (a
    # missing mode reports none: the model has no such mode)
    at_nominal = physical(model, effect.values(model, {}))
    same = [r[0] for r in at_nominal] == [r[0] for r in rows]
    nominal = [r[1] for r in at_nominal] if same else [None] * len(rows)
    base = np.array([r[1] for r in rows], float)
    sd = np.array([s if s is not None and np.isfinite(s) else np.nan for s in sds], float)
    usable = [i for i, label in enumerate(labels) if label in complete and np.isfinite(sd[i]) and sd[i] > 0]
    var = np.full(len(rows), np.nan) if len(labels) and not usable else np.zeros(len(rows))
    if usable:
        J = np.zeros((len(rows), len(usable)))
        for col, i in enumerate(usable):
            h = STEP * sd[i]
            moved = dict(complete)
            moved[labels[i]] += h
            try:
                J[:, col] = (np.array([r[1] for r in physical(model, moved)], float) - base) / h
            except Exception:  # a step past a bound: the other side
                moved[labels[i]] -= 2 * h
                try:
                    J[:, col] = (base - np.array([r[1] for r in physical(model, moved)], float)) / h
                except NonPhysicalError:  # no physical body on either side: no uncertainty to carry
                    J[:, col] = np.nan
        c = np.eye(len(usable)) if corr is None else np.asarray(corr, float)[np.ix_(usable, usable)]
        cov = c * np.outer(sd[usable], sd[usable])
        var = np.einsum("ij,jk,ik->i", J, cov, J)
        if spread is not None:
            between = np.asarray(spread, float)[np.ix_(usable, usable)]
            if np.all(np.isfinite(between)):
                var = np.fmax(var, np.einsum("ij,jk,ik->i", J, between, J))
    return [{"label": r[0], "value": float(r[1]), "unit": r[2],
             "uncertainty": float(np.sqrt(max(v, 0.0))) if np.isfinite(v) else None, "nominal": None if n is None else float(n)}
            for r, v, n in zip(rows, var, nominal)]


#: a step along a direction the data cannot see (search units: natural steps), taken both ways
NULL_STEP = 1e-2
#: a quantity moving by more than this fraction of itself per natural step along such a direction
#: is not determined by the data
UNDETERMINED_SLOPE = 1e-4


def mark_undetermined(rows: list[dict[str, Any]], effect, model, values_at, x: np.ndarray, nulls: np.ndarray) -> None:
    """Mark, in place, the rows (``quantities``') that move along a direction the data cannot see
    (``nulls``: search units, fitting.uncertainties'): their value is one of many that fit alike,
    so they get no uncertainty and ``determined`` false. Six isolators in two rows of three under a
    rigid frame: one pattern of their vertical stiffnesses moves nothing a sensor sees, and each
    isolator's fitted stiffness read 127 ± 0.07 kN/m where the truth was 120 (the prior picks a
    point of the valley). ``values_at(x)``: the effect's values at search point ``x``."""
    physical = getattr(effect, "physical", None)
    if not rows or physical is None or nulls.size == 0:
        return
    base = np.array([r["value"] for r in rows], float)
    for k in range(nulls.shape[1]):
        try:
            ends = [np.array([r[1] for r in physical(model, effect.values(model, values_at(x + t * nulls[:, k])))],
                             float) for t in (NULL_STEP, -NULL_STEP)]
        except NonPhysicalError:
            continue
        if any(e.shape != base.shape for e in ends):
            continue
        # central: a determined combination (a spring's stiffness where only a scale per axis and
        # one per group trade off) moves at third order, an undetermined one at first (a spring's
        # stiffness by about 5 % of itself per natural step)
        slope = np.abs(ends[0] - ends[1]) / (2 * NULL_STEP)
        for r, s_, v in zip(rows, slope, base):
            if s_ > UNDETERMINED_SLOPE * max(abs(v), 1e-300):
                r["uncertainty"] = None
                r["determined"] = False


def moved(rows: Sequence[Mapping[str, Any]], limit: int = 4) -> list[Mapping[str, Any]]:
    """The rows that moved from their nominal most, in their own uncertainties (or relatively where
    none is known), at most ``limit``; rows that did not move are left out."""
    def score(r) -> float:
        if r["nominal"] is None:
            return np.inf
        d = abs(r["value"] - r["nominal"])
        sd = r.get("uncertainty")
        return d / sd if sd else d / max(abs(r["nominal"]), 1e-300) * 1e3
    out = sorted((r for r in rows if r["value"] != r["nominal"]), key=score, reverse=True)
    return out[:limit]


def engineering_unit(value: float, unit: str) -> tuple[float, str]:
    """The divisor and unit a quantity reads shortest in: forces per unit in kN or MN (2.62e+05 N/m
    as 262 kN/m); other units as they are."""
    if unit.startswith("N") and abs(value) >= 1e4:
        return (1e6, "M" + unit) if abs(value) >= 1e7 else (1e3, "k" + unit)
    return 1.0, unit


def text(rows: Sequence[Mapping[str, Any]]) -> str:
    """'label = value ± sd unit (model: nominal); ...', each in its engineering_unit."""
    parts = []
    for r in rows:
        scale, shown_unit = engineering_unit(r["value"], r["unit"])
        unit = "" if shown_unit in ("", "1") else f" {unit_text(shown_unit)}"
        sd = r.get("uncertainty")
        pm = f" ± {sd / scale:.2g}" if sd is not None and sd > 0 else ""
        alike = "one of many values the data fit alike"
        if r.get("determined", True) is False:
            was = f" (model: {r['nominal'] / scale:.4g}; {alike})" if r["nominal"] is not None else f" ({alike})"
        else:
            was = f" (model: {r['nominal'] / scale:.4g})" if r["nominal"] is not None else ""
        parts.append(f"{r['label']} = {r['value'] / scale:.4g}{pm}{unit}{was}")
    return "; ".join(parts)
