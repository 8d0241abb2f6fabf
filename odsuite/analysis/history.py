"""The error history of a project's model revisions, as a document and as a figure."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from odsuite.domain.errors import ConfigError
from odsuite.store.diskspace import write_output

#: Print size: 16 x 9 cm at 200 dpi, type of 9-11 pt reads at that size.
FIGURE_SIZE_IN = (6.3, 3.6)
FIGURE_DPI = 200


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


def history_figure(doc: Mapping[str, Any], path) -> None:
    """The error per revision as bars on a log scale (errors fall by decades as effects are
    added), each with its value and the effect it added, and the noise floor as a line."""
    from matplotlib.figure import Figure

    revs = [r for r in doc["revisions"] if r["error"] is not None]
    fig = Figure(figsize=FIGURE_SIZE_IN, layout="constrained")
    ax = fig.add_subplot()
    labels = [f"r{r['revision']}\n" + (("+ " + r["effects"][-1]) if r["effects"] else "rigid model") for r in revs]
    errors = [r["error"] for r in revs]
    bars = ax.bar(range(len(revs)), errors, color="tab:blue", width=0.6)
    ax.bar_label(bars, [f"{e:.4f}" for e in errors], padding=2, fontsize=9)
    ax.set_yscale("log")
    floor = doc.get("noise_floor_error")
    if floor:
        ax.axhline(floor, color="tab:red", ls="--", lw=1.2, label=f"noise floor {floor:.4f}")
        ax.legend(fontsize=9, loc="upper right")
    low = min(errors + ([floor] if floor else [])) if errors else 1e-3
    high = max(errors) if errors else 1.0
    ax.set_ylim(low / 2, high * 3)  # room for the values above the bars
    ax.set_xticks(range(len(revs)), labels, fontsize=9)
    ax.set_ylabel("error (pooled NRMSE, log scale)", fontsize=10)
    ax.set_title("model error per revision", fontsize=11)
    ax.grid(axis="y", which="both", alpha=0.3)
    write_output(Path(path), 0, lambda tmp: fig.savefig(tmp, dpi=FIGURE_DPI))  # a figure fits the reserve
