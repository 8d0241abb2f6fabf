"""A fitted effect in physical quantities: what its optional ``physical(model, values)`` names (an
effective stiffness in N/m, a mass in kg, a position in mm), each with the uncertainty the fit's
covariance gives it.

Parameters the data cannot separate (a stiffness scale per axis times one per spring group) have
large, correlated uncertainties; the quantities an effect reports are their determined combinations,
so their propagated uncertainties are small where the data determine them.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from odsuite.domain.display import unit_text
from odsuite.domain.errors import NonPhysicalError

#: finite-difference step of the propagation, as a fraction of a parameter's standard deviation
STEP = 1e-3


def quantities(effect, model, values: Mapping[str, float], labels: Sequence[str] = (),
               sds: Sequence[float] = (), corr: np.ndarray | None = None,
               spread: np.ndarray | None = None, propagation: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """``effect.physical(model, values)`` as rows {label, value, unit, uncertainty}, the uncertainty
    propagated linearly from the shared parameters ``labels`` (the fit's standard deviations
    ``sds``, correlation ``corr``; None: independent), or from ``spread`` where that gives more (a
    covariance of the same parameters between records, between_records; propagated as a whole so
    that parameters moving together leave their determined products as certain as they are).
    [] when the effect reports no physical quantities. ``propagation``: filled with what carries the
    uncertainties to a combination of the rows (mark_undetermined's): the rows' gradients ``J``
    (rows x parameters used), those parameters' covariance ``cov`` and ``between`` (or None)."""
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
        between = None if spread is None else np.asarray(spread, float)[np.ix_(usable, usable)]
        if between is not None and not np.all(np.isfinite(between)):
            between = None
        if between is not None:
            var = np.fmax(var, np.einsum("ij,jk,ik->i", J, between, J))
        if propagation is not None:
            propagation.update(J=J, cov=cov, between=between)
    return [{"label": r[0], "value": float(r[1]), "unit": r[2],
             "uncertainty": float(np.sqrt(max(v, 0.0))) if np.isfinite(v) else None, "nominal": None if n is None else float(n)}
            for r, v, n in zip(rows, var, nominal)]


#: a step along a direction the data cannot see (search units: natural steps), taken both ways
NULL_STEP = 1e-2
#: a quantity moving by more than this fraction of itself per natural step along such a direction
#: is not determined by the data
UNDETERMINED_SLOPE = 1e-4


def mark_undetermined(rows: list[dict[str, Any]], effect, model, values_at, x: np.ndarray, nulls: np.ndarray,
                      propagation: Mapping[str, Any] | None = None) -> None:
    """Mark, in place, the rows (``quantities``') that move along a direction the data cannot see
    (``nulls``: search units, fitting.uncertainties'): their value is one of many that fit alike,
    so they get no uncertainty and ``determined`` false. Six isolators in two rows of three under a
    rigid frame: one pattern of their vertical stiffnesses moves nothing a sensor sees, and each
    isolator's fitted stiffness read 127 ± 0.07 kN/m where the truth was 120 (the prior picks a
    point of the valley). ``values_at(x)``: the effect's values at search point ``x``. The
    combinations of such rows that the data do determine are appended (determined_combinations),
    with uncertainties where ``propagation`` (quantities') carries them."""
    physical = getattr(effect, "physical", None)
    if not rows or physical is None or nulls.size == 0:
        return
    base = np.array([r["value"] for r in rows], float)
    slopes = []
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
        slopes.append((ends[0] - ends[1]) / (2 * NULL_STEP))
    if not slopes:
        return
    S = np.array(slopes)  # nulls x rows: each row's move per natural step along each direction
    for r, s_, v in zip(rows, np.abs(S).max(axis=0), base):
        if s_ > UNDETERMINED_SLOPE * max(abs(v), 1e-300):
            r["uncertainty"] = None
            r["determined"] = False
    rows += determined_combinations(rows, S, propagation)


#: a row's label split into its quantity, the member it is of and what follows: "stiffness of iso3
#: along z" -> ("stiffness of ", "iso3", " along z")
_MEMBER = re.compile(r"^(.*? of )(\S+)( along .*)?$")


def determined_combinations(rows: Sequence[Mapping[str, Any]], S: np.ndarray,
                            propagation: Mapping[str, Any] | None = None) -> list[dict[str, Any]]:
    """What the data determine of the undetermined rows (``determined`` false) of one quantity
    along one axis (alike labels: "stiffness of iso1 along z", "... of iso2 along z"): their sum,
    and the difference of two that move alike along every direction the data cannot see (``S``:
    directions x rows, each row's move per natural step). Six isolators in two rows of three, the
    pattern +1 -2 +1 / -1 +2 -1 unseen: the total vertical stiffness, and the end isolators of a
    row against each other. A combination is determined where it moves by at most
    UNDETERMINED_SLOPE of its members' size; its uncertainty is the rows' covariance carried to
    it (``propagation``: quantities' gradients and covariance; without them none)."""
    groups: dict[tuple, list[int]] = {}
    for i, r in enumerate(rows):
        found = _MEMBER.match(r["label"]) if r.get("determined", True) is False else None
        if found:
            groups.setdefault((r["unit"], found.group(1), found.group(3) or ""), []).append(i)
    J = None if propagation is None else propagation.get("J")
    if J is not None and J.shape[0] != len(rows):
        J = None
    out = []

    def add(weights: dict[int, float], joined: str, key: tuple) -> None:
        w = np.zeros(len(rows))
        for i, c in weights.items():
            w[i] = c
        size = sum(abs(c * rows[i]["value"]) for i, c in weights.items())
        if np.abs(S @ w).max() > UNDETERMINED_SLOPE * max(size, 1e-300):
            return
        sd = None
        if J is not None:
            g = w @ J
            var = float(g @ propagation["cov"] @ g)
            if propagation.get("between") is not None:
                var = max(var, float(g @ propagation["between"] @ g))
            sd = float(np.sqrt(max(var, 0.0)))
        nominals = [rows[i]["nominal"] for i in weights]
        out.append({"label": f"{key[1]}{joined}{key[2]}", "value": float(sum(c * rows[i]["value"] for i, c in weights.items())),
                    "unit": key[0], "uncertainty": sd,
                    "nominal": None if any(n is None for n in nominals) else
                    float(sum(c * rows[i]["nominal"] for i, c in weights.items())),
                    "combination": {rows[i]["label"]: c for i, c in weights.items()}})

    for key, members in groups.items():
        if len(members) < 2:
            continue
        names = {i: _MEMBER.match(rows[i]["label"]).group(2) for i in members}
        add({i: 1.0 for i in members}, " + ".join(names[i] for i in members), key)
        # members that move alike along every unseen direction: each against the next of its kind
        kinds: list[list[int]] = []
        for i in members:
            scale = UNDETERMINED_SLOPE * abs(rows[i]["value"])
            kind = next((k for k in kinds if np.abs(S[:, k[0]] - S[:, i]).max()
                         <= max(scale, UNDETERMINED_SLOPE * abs(rows[k[0]]["value"]))), None)
            if kind is None:
                kinds.append([i])
            else:
                kind.append(i)
        for kind in kinds:
            for a, b in zip(kind, kind[1:]):
                add({a: 1.0, b: -1.0}, f"{names[a]} - {names[b]}", key)
    return out


def moved(rows: Sequence[Mapping[str, Any]], limit: int = 4) -> list[Mapping[str, Any]]:
    """The determined rows that moved from their nominal most, in their own uncertainties (or
    relatively where none is known), at most ``limit``, then the rows the data do not determine one
    by one (``determined`` false), which ``text`` names in one phrase: their determined
    combinations are rows of their own. Rows that did not move are left out."""
    def score(r) -> float:
        if r["nominal"] is None:
            return np.inf
        d = abs(r["value"] - r["nominal"])
        sd = r.get("uncertainty")
        return d / sd if sd else d / max(abs(r["nominal"]), 1e-300) * 1e3
    undetermined = [r for r in rows if r.get("determined", True) is False]
    # to nine digits: two values of one parameter (a beam's radius of gyration and the height it
    # means) score alike but for rounding, which flipped their order between runs
    out = sorted((r for r in rows if r["value"] != r["nominal"] and r.get("determined", True) is not False),
                 key=lambda r: float(f"{score(r):.9g}"), reverse=True)
    return out[:limit] + undetermined


def engineering_unit(value: float, unit: str) -> tuple[float, str]:
    """The divisor and unit a quantity reads shortest in: forces per unit in kN or MN (2.62e+05 N/m
    as 262 kN/m); other units as they are."""
    if unit.startswith("N") and abs(value) >= 1e4:
        return (1e6, "M" + unit) if abs(value) >= 1e7 else (1e3, "k" + unit)
    return 1.0, unit


def text(rows: Sequence[Mapping[str, Any]]) -> str:
    """'label = value ± sd unit (model: nominal); ...', each in its engineering_unit; the rows the
    data do not determine one by one in one phrase at the end (their values are not findings)."""
    parts = []
    undetermined = [r for r in rows if r.get("determined", True) is False]
    for r in rows:
        if r.get("determined", True) is False:
            continue
        scale, shown_unit = engineering_unit(r["value"], r["unit"])
        unit = "" if shown_unit in ("", "1") else f" {unit_text(shown_unit)}"
        sd = r.get("uncertainty")
        pm = f" ± {sd / scale:.2g}" if sd is not None and sd > 0 else ""
        was = f" (model: {r['nominal'] / scale:.4g})" if r["nominal"] is not None else ""
        parts.append(f"{r['label']} = {r['value'] / scale:.4g}{pm}{unit}{was}")
    if undetermined:
        some = ", ".join(r["label"] for r in undetermined[:2])
        parts.append(f"{len(undetermined)} {'value' if len(undetermined) == 1 else 'values'} not determined one by one ({some}"
                     f"{', ...' if len(undetermined) > 2 else ''}: the data fit a pattern of them alike)")
    return "; ".join(parts)
