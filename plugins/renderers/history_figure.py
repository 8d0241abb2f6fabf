"""The error per model revision as a bar chart (the document of ``odsuite.api.history``)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from odsuite.api import write_output

#: Print size: 16 x 9 cm at 200 dpi, type of 9-11 pt reads at that size.
FIGURE_SIZE_IN = (6.3, 3.6)
FIGURE_DPI = 200


def history_figure(doc: Mapping[str, Any], path):
    """The error per revision as bars on a log scale (errors fall by decades as effects are
    added), each with its value and the effect it added, and the noise floor as a line; returns the
    matplotlib Figure for inspection."""
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
    return fig
