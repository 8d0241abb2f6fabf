"""A candidate whose fit stopped early (a pair that cannot pass its test: diagnose._cannot_pass) is
not checked further: its consistency reads "not checked" (None; "-" in diagnose's table), as a
screened-only candidate's, not "consistent"."""

from __future__ import annotations

import io
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from hidden_effects import make_project  # noqa: E402

import odsuite.diagnosis.diagnose as diagnose_module  # noqa: E402
from odsuite.analysis.comparison import noise_floor  # noqa: E402
from odsuite.analysis.modelrev import current_revision, revision_model  # noqa: E402
from odsuite.analysis.prediction import prepare  # noqa: E402
from odsuite.diagnosis.fitting import Problem, Screened, fit_windows  # noqa: E402
from odsuite.store.project import open_project  # noqa: E402


@pytest.fixture(scope="module")
def stiffer(tmp_path_factory):
    """Two thesis hits (2048 samples) of a rig whose springs are 30 % stiffer vertically."""
    path = make_project(tmp_path_factory.mktemp("stopped") / "stiffer.h5", [("stiffness", {"scale_z": 1.3})],
                        n_samples=2048, scenarios=("T1", "T2"))
    with open_project(path) as project:
        base = revision_model(project, current_revision(project))
        exps = prepare(project, None)
        effect = project.registries.effects.get("stiffness")
    return base, effect, exps


def _candidate(stiffer, monkeypatch, stop: bool):
    base, effect, exps = stiffer
    real = diagnose_module.fit

    def stopping(*args, **kwargs):
        res = real(*args, **kwargs)
        res.target_stop = stop
        return res

    monkeypatch.setattr(diagnose_module, "fit", stopping)
    windows = fit_windows(exps)
    problem = Problem(base, effect, windows, full=exps)
    u0 = problem.zero()
    den = sum(float(np.sum(e.measured**2)) for e in exps)
    sse0 = problem.sse(u0, exps)
    floor = noise_floor(exps, base)
    return diagnose_module._fit_candidate(
        Screened(effect, {}, u0, problem.sse(u0), problem), windows, sse0, den, float(sum(e.n_samples for e in exps)),
        floor.error(), [], None, [], force_levels={e.name: float(np.max(np.abs(e.force))) for e in exps},
        floor=floor)


def test_a_stopped_fit_is_not_called_consistent(stiffer, monkeypatch):
    cand = _candidate(stiffer, monkeypatch, stop=True)
    assert cand._stopped and cand.consistent is None and math.isnan(cand.validated_error)
    assert cand.as_dict()["consistent"] is None
    assert "differ beyond their uncertainties" not in diagnose_module._checks_words(cand)
    # the same fit let go is checked
    assert isinstance(_candidate(stiffer, monkeypatch, stop=False).consistent, bool)


def test_the_table_shows_not_checked_for_a_fitted_candidate_never_checked():
    from rich.console import Console

    from odsuite.cli.loop_commands import _candidates_table

    rows = [{"effect": "stiffness+damping", "significant": False, "consistent": None, "plausible": True,
             "fitted": True, "error_after": 0.03, "validated_error": float("nan"), "confounded_with": []},
            {"effect": "stiffness", "significant": True, "consistent": True, "plausible": True,
             "fitted": True, "error_after": 0.02, "validated_error": 0.02, "confounded_with": []}]
    console = Console(width=120, record=True, file=io.StringIO())
    console.print(_candidates_table(rows, 120))
    lines = {ln.split("│")[1].strip(): [c.strip() for c in ln.split("│")[2:5]]
             for ln in console.export_text().splitlines() if ln.startswith("│")}
    assert lines["stiffness+damping"] == ["no", "-", "yes"]
    assert lines["stiffness"] == ["yes", "yes", "yes"]
