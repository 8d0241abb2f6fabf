"""Model revisions: a registered model of the project's rig plus effects at fitted values.

A revision (see ``Project.model_revisions``) names its model factory, lists its effects as
``{"effect": name, "parameters": {...}}`` (or plain names whose values sit in the revision's
``parameters[name]``). A per-experiment parameter's value is a mapping experiment -> value.
Without stored revisions, revision 0 is the rig's default model with no effects.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from odsuite.core.errors import ConfigError
from odsuite.core.rig import Rig

from .multibody import Model


def _effect_entries(revision: Mapping[str, Any]) -> list[tuple[str, dict]]:
    out = []
    for e in revision.get("effects", []):
        if isinstance(e, str):
            out.append((e, dict(revision.get("parameters", {}).get(e, {}))))
        elif isinstance(e, Mapping) and isinstance(e.get("effect", e.get("name")), str):
            name = e.get("effect", e.get("name"))
            out.append((name, dict(e.get("parameters", revision.get("parameters", {}).get(name, {})))))
        else:
            raise ConfigError(f"model revision {revision.get('revision')!r} field 'effects': cannot read entry {e!r}")
    return out


def build_model(rig: Rig | None, revision: Mapping[str, Any] | None, registries, *,
                experiment: str | None = None) -> Model:
    """The model of ``revision`` (None: the rig's default model) for ``experiment``: per-experiment
    values are taken for that experiment, nominal when it is None or has none."""
    revision = revision or {}
    name = revision.get("model") or (rig.default_model if rig is not None else None)
    if not name:
        raise ConfigError("no model: the project has no rig with a default model and no model revision")
    model = registries.models.get(name)(rig)
    for effect_name, values in _effect_entries(revision):
        effect = registries.effects.get(effect_name)
        chosen = {}
        for k, v in values.items():
            if isinstance(v, Mapping):
                if experiment is not None and experiment in v:
                    chosen[k] = v[experiment]
            else:
                chosen[k] = v
        model = effect.apply(model, chosen)
    return model


def model_report(rig: Rig | None, revision: Mapping[str, Any] | None, registries) -> dict[str, Any]:
    """The ``odsuite model --json`` document: revision, parameters, effects, modes (ascending)."""
    revision = revision or {}
    model = build_model(rig, revision, registries)
    effects = _effect_entries(revision)
    return {
        "revision": int(revision.get("revision", 0)),
        "model": model.name,
        "parameters": {name: values for name, values in effects},
        "effects": [name for name, _ in effects],
        "modes": model.modes().as_list(),
        "description": model.describe(),
    }


def project_model_report(path, registries=None) -> dict[str, Any]:
    """``model_report`` of a project's current revision (revision 0 = its rig's default model)."""
    from odsuite.core.plugins import registries as default_registries
    from odsuite.core.project import open_project

    regs = registries or default_registries()
    with open_project(path) as project:
        rig = project.rig
        current = project.current_revision
        revision = None
        if current is not None:
            revision = next(r for r in project.model_revisions() if r["revision"] == current)
    return model_report(rig, revision, regs)
