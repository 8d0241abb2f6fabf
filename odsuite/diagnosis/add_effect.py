"""``add-effect``: fit the named effect together with the current revision's own effects, and
store the result as a new model revision."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from odsuite.contracts.effects import applies, family
from odsuite.diagnosis import checks, physical
from odsuite.diagnosis.between_records import reported_with_covariance
from odsuite.diagnosis.joint import Joint
from odsuite.domain import arguments
from odsuite.domain.errors import ConfigError
from odsuite.diagnosis.fitting import (
    Problem,
    Screened,
    effective_samples,
    fit,
    fit_windows,
    off_the_bounds,
    refined,
    screen,
    uncertainties,
    weight_notes,
    with_force_noise,
    force_noise_scores,
)
from odsuite.analysis.history import data_stamp, valid_metric
from odsuite.analysis.modelrev import apply_effects, current_revision, instance_names, revision_model
from odsuite.analysis.noise_floor import FLOOR_TOLERANCE
from odsuite.analysis.prediction import prepare


def _flat(entries: Sequence[Mapping[str, Any]]) -> dict[str, float]:
    """The revision's parameters as one table, "<effect>.<parameter>" (repeated instances numbered)."""
    return {f"{key}.{k}": v for key, e in zip(instance_names(entries), entries) for k, v in e.get("values", {}).items()}


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
    if not isinstance(name, str) or not name:  # None raised inside
        raise ConfigError(f"add_effect: 'name' names an effect (text), got {arguments.shown(name)}")
    # on one BLAS thread, as diagnose: a product's rounding depends on the threads that share it,
    # and the revision stored must not depend on how the process was started (a fit on two threads
    # ended 4e-9 from one on one, OPENBLAS_NUM_THREADS=1 inherited or not)
    with threadpool_limits(1):
        again = _already_in(project, name)
        result = _add_effect(project, name, progress=progress)
    if again:
        result["notes"] = [again, *result.get("notes", [])]
    return result


def _already_in(project, name: str) -> str | None:
    """The note for an effect the current revision holds already (it is refitted, not added twice:
    the new revision has the same effects), or None."""
    regs = project.registries
    if name not in regs.effects.names() or getattr(regs.effects.get(name), "repeatable", False):
        return None
    rev = current_revision(project)
    if not any(e["effect"] == name for e in rev.get("effects", [])):
        return None
    return (f"{name} is in revision {rev['revision']} already: it was refitted with the others, and the new revision "
            "holds the same effects")


def _add_effect(project, name: str, *, progress: Callable[[str, int, int], None] | None = None) -> dict[str, Any]:
    from odsuite.analysis.comparison import compare
    from odsuite.analysis.modelrev import base_model

    regs = project.registries
    if "+" in name and name not in regs.effects.names():
        # a pair the diagnosis fitted jointly: each added in turn, the last step refitting all of them
        # together (as every addition does); every name is known and named once before the first is
        # fitted, and the steps are stored in one commit: a step that fails leaves the project as it was
        parts = name.split("+")
        for part in parts:
            if part not in regs.effects.names():
                raise ConfigError(f"{project.path}: effect {name!r}: unknown effect {part!r} "
                                  f"(known: {', '.join(regs.effects.names())})")
        twice = next((p for p in parts if parts.count(p) > 1 and not getattr(regs.effects.get(p), "repeatable", False)),
                     None)
        if twice is not None:  # it stored two revisions of the one effect
            raise ConfigError(f"{project.path}: effect {name!r} names {twice!r} twice; a model holds it once "
                              f"(give {twice!r})")
        with project.transaction():
            steps = [add_effect(project, part, progress=progress) for part in parts]
        notes = list(dict.fromkeys(n for step in steps for n in step.get("notes", [])))
        return steps[-1] | {"effect": name, "previous_error": steps[0]["previous_error"], "steps": steps,
                            "notes": notes}
    effect = regs.effects.get(name)
    rev = current_revision(project)
    model = revision_model(project, rev).shared
    if not applies(effect, model):
        raise ConfigError(f"{project.path}: effect {name!r} does not apply to this model "
                          f"({model.name!r}, a {family(model)}, on rig {project.rig.name!r})")
    # a repeatable effect is added after the instances stored; any other one is refitted
    entries = [e for e in rev.get("effects", []) if e["effect"] != name or getattr(effect, "repeatable", False)]
    exps = prepare(project)
    den = sum(float(np.sum(e.measured**2)) for e in exps)
    cmp = compare(project, revision=rev, prepared=exps, resonances=False)
    stamp = data_stamp(project)
    if valid_metric(rev.get("metrics", {}), "error", stamp) is None:
        # the revision's error on these records, just computed: kept, so `info` and `history` read
        # it instead of comparing again (revision 0 had none after the first add-effect)
        project.set_revision_metrics(rev["revision"], {"error": cmp.error, "noise_floor_error": cmp.noise_floor_error,
                                                       "data_stamp": stamp})
    noise = cmp.noise_floor_error
    # the fits stop at gains below the noise, as the diagnosis's do
    scale = checks.noise_scale(cmp.floor, exps)
    f99 = effective_samples(exps)[1]
    stride = max(1, int(exps[0].fs / (5.0 * f99)))
    prior = 1e-3 * max(noise**2, 1e-8) * den / stride
    before = cmp.error
    windows = fit_windows(exps, stride)
    if progress:
        progress(f"screening {name}", 0, 3)
    current = revision_model(project, {**rev, "effects": entries})
    peaks = [p["frequency_hz"] for p in cmp.residual_peaks if p["lacking"]]
    refines = getattr(effect, "refines", None)
    if refines:  # it starts from the fit of the effect it refines, as the diagnosis fits it
        start = Problem(current, regs.effects.get(refines), windows, prior=prior, stride=stride, full=exps,
                        noise_scale=scale)
        s = screen(start, start.sse(start.zero()), peaks)
        res = off_the_bounds(s.problem, fit(s.problem, s.u0, continuation=False)) if s.problem.free else None
        problem, u0 = refined(s.problem, res.x if res is not None else s.problem.zero(), effect)
        return _add_on_top(project, rev, entries, name, effect, Screened(effect, problem.fixed, u0, 0.0, problem),
                           exps, before, progress)
    single = Problem(current, effect, windows, prior=prior, stride=stride, full=exps, noise_scale=scale)
    screened = screen(single, single.sse(single.zero()), peaks)
    if single.linear:
        # an effect that solves its own linear parameters (a mode's participations) is fitted on
        # top of the current effects, as the diagnosis fitted it: refitting everything jointly
        # would hand those parameters to the nonlinear search, which cannot find them
        return _add_on_top(project, rev, entries, name, effect, screened, exps, before, progress)
    # the joint problem names parameters by effect: instances of an effect stored more than once
    # (a repeatable one) are held as stored, the rest refitted
    count = [e["effect"] for e in entries] + [name]
    held = [e for e in entries if count.count(e["effect"]) > 1]
    refit = [e for e in entries if count.count(e["effect"]) == 1]
    joint_effects = [regs.effects.get(e["effect"]) for e in refit] + [effect]
    fixed = {f"{e['effect']}.{k}": v for e in refit for k, v in e.get("values", {}).items()
             if any(p.name == k and p.choices for p in regs.effects.get(e["effect"]).parameters(current.shared))}
    fixed.update({f"{name}.{k}": v for k, v in screened.fixed.items()})
    joint = Problem(apply_effects(base_model(project.rig, rev.get("model"), registries=regs), held,
                                  registries=regs), Joint(joint_effects), windows,
                    fixed, prior, stride, full=exps, noise_scale=scale)
    u0 = _start(joint, refit)
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
    fit_sds, corr, nulls = np.zeros(0), None, np.zeros((len(joint.free), 0))
    if res is not None:
        fit_sds, corr, _, nulls = uncertainties(joint, res, lambda: checks.residual_effective_samples(joint, res))
    scores = None
    if res is not None:
        scores = force_noise_scores(joint, res)
        fit_sds, corr = with_force_noise(joint, res, fit_sds, corr, scores)
    new_entries = list(held) + _entries(joint, joint_effects, u, fit_sds, corr, res, nulls)
    if progress:
        progress("comparing", 2, 3)
    after = compare(project, revision={"model": rev.get("model"), "effects": new_entries}, prepared=exps,
                    resonances=False)
    warnings = _warnings(name, effect, joint, res, current.shared, exps, after, force_noise=scores)
    return _stored(project, rev, name, new_entries, after, before, warnings, exps)


def _entries(joint: Problem, joint_effects, u, fit_sds, corr, res, nulls: np.ndarray) -> list[dict[str, Any]]:
    """The revision's entries of the jointly fitted effects: values, per-experiment values,
    uncertainties and physical quantities (each on the model the effects before it made; those
    that move along a direction the data cannot see (``nulls``) marked, the effect's own values
    moved along it)."""
    sds, spread = reported_with_covariance(fit_sds, joint, res)
    shared, per = joint.values(u)
    entries = []
    model = joint.base.shared
    for e in joint_effects:
        prefix = f"{e.name}."
        values = {k[len(prefix):]: v for k, v in shared.items() if k.startswith(prefix)}
        per_exp = {x: {k[len(prefix):]: v for k, v in d.items() if k.startswith(prefix)} for x, d in per.items()}
        per_exp = {x: d for x, d in per_exp.items() if d}
        unc = {f.label[len(prefix):] if f.experiment is None else f"{f.experiment}/{f.param.name[len(prefix):]}": float(sd)
               for f, sd in zip(joint.free, sds) if f.param.name.startswith(prefix) and np.isfinite(sd)}
        labels = [f.param.name[len(prefix):] if f.experiment is None and f.param.name.startswith(prefix) else ""
                  for f in joint.free]
        propagation: dict[str, Any] = {}
        rows = physical.quantities(e, model, values, labels, fit_sds, corr, spread, propagation)

        def own(x: np.ndarray, prefix: str = prefix) -> dict[str, float]:
            return {k[len(prefix):]: v for k, v in joint.searched_values(x, shared).items() if k.startswith(prefix)}

        physical.mark_undetermined(rows, e, model, own, u, nulls, propagation)
        model = e.apply(model, values)
        entries.append({"effect": e.name, "values": values, "per_experiment": per_exp, "uncertainties": unc,
                        **({"physical": rows} if rows else {})})
    return entries


def _stored(project, rev, name: str, new_entries: list[dict], after, before: float, warnings: list[str],
            exps) -> dict[str, Any]:
    """The new revision stored (its error stamped with the records it was computed on) and made
    current; returns what add-effect reports."""
    metrics = {"error": after.error, "noise_floor_error": after.noise_floor_error, "added": name,
               "previous_error": before, "data_stamp": data_stamp(project)}
    n = project.add_model_revision(new_entries, _flat(new_entries), metrics, rev["revision"], model=rev.get("model"))
    return {"revision": n, "effect": name, "error": after.error, "previous_error": before,
            "noise_floor_error": after.noise_floor_error, "effects": new_entries, "warnings": warnings,
            # what the comparison left out (clipped channels) and the channels the fit weighed blind
            "notes": list(after.notes) + weight_notes(exps)}


def _add_on_top(project, rev, entries, name: str, effect, screened, exps, before, progress) -> dict[str, Any]:
    """Fit ``effect`` alone on the current revision's model and store it after the current effects."""
    from odsuite.analysis.comparison import compare

    problem = screened.problem
    if progress:
        progress(f"fitting {name}", 1, 3)
    # as the diagnosis fits a candidate: off an implausible bound once (what it printed is what is stored)
    res = off_the_bounds(problem, fit(problem, screened.u0, continuation=False)) if problem.free else None
    u = res.x if res is not None else problem.zero()
    nulls = np.zeros((len(problem.free), 0))
    if res is not None:
        fit_sds, corr, _, nulls = uncertainties(problem, res, lambda: checks.residual_effective_samples(problem, res))
    else:
        fit_sds, corr = np.zeros(0), None
    scores = None
    if res is not None:
        scores = force_noise_scores(problem, res)
        fit_sds, corr = with_force_noise(problem, res, fit_sds, corr, scores)
    sds, spread = reported_with_covariance(fit_sds, problem, res)
    shared, per = problem.values(u)
    unc = {f.label if f.experiment is None else f"{f.experiment}/{f.param.name}": float(sd)
           for f, sd in zip(problem.free, sds) if np.isfinite(sd)}
    propagation: dict[str, Any] = {}
    rows = physical.quantities(effect, problem.base.shared, {**problem.fixed, **shared},
                               [f.param.name if f.experiment is None else "" for f in problem.free], fit_sds, corr,
                               spread, propagation)
    physical.mark_undetermined(rows, effect, problem.base.shared, lambda x: problem.searched_values(x, shared), u, nulls,
                               propagation)
    new_entries = [*entries, {"effect": name, "values": dict(shared),
                              "per_experiment": {x: d for x, d in per.items() if d}, "uncertainties": unc,
                              **({"physical": rows} if rows else {})}]
    if progress:
        progress("comparing", 2, 3)
    after = compare(project, revision={"model": rev.get("model"), "effects": new_entries}, prepared=exps,
                    resonances=False)
    warnings = _warnings(name, effect, problem, res, problem.base.shared, exps, after, prefix="", force_noise=scores)
    return _stored(project, rev, name, new_entries, after, before, warnings, exps)


def _warnings(name: str, effect, joint: Problem, res, model, exps, after, prefix: str | None = None,
              force_noise=None) -> list[str]:
    """One line each when the added effect is implausible (a value outside its declared physical
    range), inconsistent (its parameters fitted per experiment disagree), or a proxy (the error
    stays above the noise floor's tolerance): add-effect refuses nothing, but says so. ``prefix``:
    how the problem names the effect's parameters (a joint problem: "<effect>."); ``force_noise``:
    the fit's force_noise_scores, for the consistency check."""
    prefix = f"{name}." if prefix is None else prefix
    shared, per = joint.values(res.x) if res is not None else ({}, {})
    own = {k[len(prefix):]: v for k, v in shared.items() if k.startswith(prefix)}
    own.update({f"{x}/{k[len(prefix):]}": v for x, d in per.items() for k, v in d.items() if k.startswith(prefix)})
    out = []
    # as the fit bounded them (a mode's frequency below the records' Nyquist frequency)
    ranges = {p.name[len(prefix):]: replace(p, name=p.name[len(prefix):]) for p in joint.params
              if p.name.startswith(prefix)}
    edge = checks.at_records_edge(list(ranges.values()), own)
    for label in checks.implausible(effect, model, own, list(ranges.values())):
        p = ranges[label.split("/")[-1]]
        unit = "" if p.unit in ("", "1") else f" {p.unit}"  # a ratio: '0.29 1' read as two numbers
        out.append(f"{name}: {label} = {own[label]:.4g}{unit} " + (
            f"stopped at the records' Nyquist frequency {p.upper:g}{unit}, above what they resolve: implausible"
            if label in edge else
            f"lies outside its physical range [{p.plausible[0]:.4g}, {p.plausible[1]:.4g}]: implausible"))
    if res is not None:
        cons = checks.consistency(joint, res, {e.name: float(np.max(np.abs(e.force))) for e in exps},
                                  checks.tolerated_misfit(after.floor, joint.full, joint.weights), force_noise)
        mine = [k for k, v in cons.spread.items() if k.startswith(prefix) and v > 1]
        if mine and not cons.consistent:
            amp = [k for k in cons.amplitude_dependent if k.startswith(prefix)]
            out.append(f"{name}: fitted per experiment, {', '.join(mine)} disagree beyond their uncertainties"
                       + (f" and follow the force level ({', '.join(amp)}): amplitude dependent" if amp else "")
                       + ": inconsistent")
    if after.error > FLOOR_TOLERANCE * after.noise_floor_error:
        out.append(f"{name}: the error stays at {after.error:.4g}, {after.error / after.noise_floor_error:.2f} "
                   "times the noise floor: it may be a proxy for physics the model still lacks")
    return out
