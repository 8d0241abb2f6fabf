"""The error history of a project's model revisions, as a document and as a figure."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from odsuite.core.comparison import compare
from odsuite.core.prediction import prepare


def history(project) -> dict[str, Any]:
    """Revisions with their effects and errors. A revision without a stored error (revision 0
    before any comparison) gets one computed now, not stored (reading never writes)."""
    revs = project.model_revisions()
    out = []
    exps = None
    for r in revs:
        error = r.get("metrics", {}).get("error")
        if error is None and project.rig is not None and project.experiment_names():
            exps = exps or prepare(project)
            error = compare(project, revision=r, prepared=exps, resonances=False).error
        out.append({"revision": r["revision"], "parent": r["parent"], "effects": [e["effect"] for e in r["effects"]],
                    "error": error, "created": r["created"]})
    return {"current": project.current_revision, "revisions": out}


def history_figure(doc: Mapping[str, Any], path) -> None:
    """The error per revision as a bar chart with the added effect under each bar."""
    from matplotlib.figure import Figure

    revs = [r for r in doc["revisions"] if r["error"] is not None]
    fig = Figure(figsize=(6, 3.2), layout="constrained")
    ax = fig.add_subplot()
    labels = [f"r{r['revision']}\n" + (r["effects"][-1] if r["effects"] else "rigid model") for r in revs]
    ax.bar(range(len(revs)), [r["error"] for r in revs], color="tab:blue")
    ax.set_xticks(range(len(revs)), labels, fontsize=8)
    ax.set_ylabel("error (pooled NRMSE)")
    ax.set_title("model error per revision")
    fig.savefig(path)
