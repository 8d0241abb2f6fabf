"""Model revisions: the rig's default model plus a list of fitted physical effects.

A revision's ``effects`` is a list of ``{"effect": name, "values": {...}, "per_experiment":
{experiment: {...}}, "uncertainties": {...}}``: shared values apply to every experiment, the
per-experiment ones (e.g. an impact location) only when predicting that experiment.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from odsuite.domain import arguments
from odsuite.domain.errors import ConfigError
from odsuite.domain.model import AnalogFilter


def base_model(rig, model_name: str | None = None, *, registries):
    """The model a project starts from (revision 0): the rig's default model, from ``registries``'
    models (a project's ``project.registries``)."""
    name = model_name or rig.default_model
    if not name:
        raise ConfigError(f"rig {rig.name!r} names no default model (field 'default_model')")
    model = registries.models.get(name)(rig)
    # what the rig declares of its front end is part of every model of it: like with like
    declared = AnalogFilter.front_end(getattr(rig, "acquisition", None))
    if declared is not None and model.chain.front_end is None:
        model = model.replace(chain=replace(model.chain, front_end=declared))
    return model


@dataclass
class RevisionModel:
    """A model with its effects applied; ``for_experiment`` adds that experiment's own values."""

    shared: Any  # odsuite.domain.model.Model
    per_experiment: list[tuple[Any, dict[str, dict[str, float]]]] = field(default_factory=list)

    def for_experiment(self, name: str):
        model = self.shared
        for effect, table in self.per_experiment:
            if name in table:
                model = effect.apply(model, table[name])
        return model


def apply_effects(model, effects: Sequence[Mapping[str, Any]], *, registries) -> RevisionModel:
    """``model`` with the stored ``effects`` applied, each looked up in ``registries``' effects."""
    per = []
    for entry in effects:
        effect = registries.effects.get(entry["effect"])
        values = entry.get("values") or {}
        if values or not entry.get("per_experiment"):
            model = effect.apply(model, values)
        if entry.get("per_experiment"):
            # a repeatable effect's instances are told apart by their shared values
            shared = dict(values) if getattr(effect, "repeatable", False) else {}
            per.append((effect, {k: {**shared, **v} for k, v in entry["per_experiment"].items()}))
    return RevisionModel(model, per)


def instance_names(entries: Sequence[Mapping[str, Any]]) -> list[str]:
    """Each entry's effect name, the second and later instances of a repeatable effect numbered
    ("missing_mode", "missing_mode#2"): the keys of flat parameter tables."""
    seen: dict[str, int] = {}
    out = []
    for e in entries:
        seen[e["effect"]] = seen.get(e["effect"], 0) + 1
        out.append(e["effect"] if seen[e["effect"]] == 1 else f"{e['effect']}#{seen[e['effect']]}")
    return out


def current_revision(project) -> dict[str, Any]:
    """The project's current revision as stored (revision 0 when none is marked current)."""
    revs = {r["revision"]: r for r in project.model_revisions()}
    if not revs:
        raise ConfigError(f"{project.path}: the project has no model revisions (was it created with --rig none?)")
    n = project.current_revision
    return revs[n if n in revs else min(revs)]


def check_revision(where: str, revision: Any) -> None:
    """``revision`` as the functions taking one accept it: None (the current one) or a revision as
    ``project.model_revisions()`` lists it, whose ``effects`` is a list of ``{"effect": name, ...}``.
    A number raised an AttributeError; a dict without effects was compared as the rig's model."""
    if revision is None:
        return
    expected = ("a model revision (an entry of project.model_revisions() or current_revision(project)) "
                "or None for the current one")
    if not isinstance(revision, Mapping) or "effects" not in revision:
        arguments.refuse(where, "revision", revision, expected)
    effects = revision["effects"]
    if isinstance(effects, str | bytes | Mapping) or not isinstance(effects, Sequence) or not all(
            isinstance(e, Mapping) and isinstance(e.get("effect"), str) for e in effects):
        raise ConfigError(f"{where}: 'revision' field 'effects' must be a list of {{'effect': NAME, ...}}, "
                          f"got {arguments.shown(effects)}")
    if not isinstance(revision.get("model"), str | None):
        raise ConfigError(f"{where}: 'revision' field 'model' must be a model's name or None, "
                          f"got {arguments.shown(revision['model'])}")


def revision_model(project, revision: Mapping[str, Any] | None = None) -> RevisionModel:
    check_revision("revision_model", revision)
    rev = revision or current_revision(project)
    if project.rig is None:
        raise ConfigError(f"{project.path}: the project has no rig, so it has no model")
    regs = project.registries
    return apply_effects(base_model(project.rig, rev.get("model"), registries=regs), rev.get("effects", []),
                         registries=regs)


def model_report(project) -> dict[str, Any]:
    """The ``odsuite model --json`` document of the current revision: revision, model, parameters
    (per effect), ``parameter_info`` (per effect and parameter: unit and description, for the
    effects still registered), effects, modes (ascending; f = |lambda|/2 pi,
    zeta = -Re lambda/|lambda|), ``physical`` (per effect: the quantities stored with it, e.g. each
    spring's effective stiffness in N/m with its uncertainty and the rig's value; [] for effects
    whose parameters are their quantities)."""
    rev = current_revision(project)
    rmodel = revision_model(project, rev)
    model = rmodel.shared
    effects = rev.get("effects", [])
    registered = project.registries.effects
    info: dict[str, dict[str, dict[str, str]]] = {}
    for e in effects:
        if e["effect"] in registered:
            info[e["effect"]] = {p.name: {"unit": p.unit, "description": p.description}
                                 for p in registered.get(e["effect"]).parameters(model)}
    return {
        "revision": int(rev["revision"]),
        "model": model.name,
        "parameters": {key: {**e.get("values", {}),
                             **({"per_experiment": e["per_experiment"]} if e.get("per_experiment") else {})}
                       for key, e in zip(instance_names(effects), effects)},
        "parameter_info": info,
        "physical": {key: list(e.get("physical") or []) for key, e in zip(instance_names(effects), effects)},
        "effects": [e["effect"] for e in effects],
        "modes": model.modes().as_list(),
        "description": model.describe(),
    }
