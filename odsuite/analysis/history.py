"""The error history of a project's model revisions, as a document (the renderers plugin's
``history`` figure draws it)."""

from __future__ import annotations

from typing import Any

from odsuite.domain.errors import ConfigError


def history(project) -> dict[str, Any]:
    """Revisions with their effects and errors, and the noise floor (the error a perfect model
    would leave; it depends on the measurements only). A revision without a stored error (revision
    0 before any comparison) gets one computed now, not stored (reading never writes)."""
    revs = project.model_revisions()
    out = []
    exps = None
    floor = next((r["metrics"]["noise_floor_error"] for r in reversed(revs)
                  if r.get("metrics", {}).get("noise_floor_error") is not None), None)
    if floor is None and project.rig is not None:
        # the comparison (scipy.signal: seconds to import) only where nothing was stored
        from odsuite.analysis.comparison import noise_floor_error
        from odsuite.analysis.modelrev import RevisionModel, base_model

        exps = _comparable(project)
        floor = noise_floor_error(exps, RevisionModel(base_model(project.rig, registries=project.registries))) if exps else None
    for r in revs:
        error = r.get("metrics", {}).get("error")
        if error is None and project.rig is not None:
            from odsuite.analysis.comparison import compare

            exps = _comparable(project) if exps is None else exps
            error = compare(project, revision=r, prepared=exps, resonances=False).error if exps else None
        out.append({"revision": r["revision"], "parent": r["parent"], "effects": [e["effect"] for e in r["effects"]],
                    "error": error, "created": r["created"]})
    return {"current": project.current_revision, "revisions": out, "noise_floor_error": floor}


def _comparable(project) -> list:
    """The experiments a model can be compared with; records it cannot be driven with (no force
    point, not on the rig's channels) are left out of a summary rather than failing it."""
    from odsuite.analysis.prediction import prepare_experiment

    exps = []
    for name in project.experiment_names():
        try:
            exps.append(prepare_experiment(project, name))
        except ConfigError:
            continue
    return exps
