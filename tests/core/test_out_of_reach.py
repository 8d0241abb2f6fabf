"""A single candidate's full fit stops where it can no longer matter (diagnose._out_of_reach):
its significance decided at the point reached and its error, less what its linearisation still
promises, far above the best screened candidate's; one that passes its test has its consistency
(amplitude dependence, which decides its confounding) checked there. The stop saves evaluations and changes no
outcome: the same verdict, top, significance and order as the fits let run to their ends."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from hidden_effects import CASES, make_project  # noqa: E402

import odsuite.diagnosis.diagnose as diagnose_module  # noqa: E402
from odsuite.store.project import open_project  # noqa: E402

EFFECTS = ("stiffness", "mass_properties", "nonlinear_stiffness")


@pytest.fixture(scope="module")
def stiffer(tmp_path_factory):
    """Two thesis hits (2048 samples) of a rig whose springs are stiffer vertically."""
    return make_project(tmp_path_factory.mktemp("reach") / "stiffer.h5", [("stiffness", CASES["stiffness"])],
                        n_samples=2048, scenarios=("T1", "T2"))


def _diagnosis(path):
    with open_project(path) as project:
        return diagnose_module.diagnose(project, effects=EFFECTS, workers=1)


def _outcome(d):
    return (d.verdict, d.candidates[0].effect, [(c.effect, c.significant) for c in d.candidates],
            [c.effect for c in d.candidates if c.significant])


def test_a_fit_out_of_reach_stops_and_changes_no_outcome(stiffer, monkeypatch):
    stopped = _diagnosis(stiffer)
    short = [c for c in stopped.candidates if "could not come near the top" in c.evidence]
    assert short, "no fit stopped on this problem: the test would not test the stop"
    for c in short:  # reported at the point reached; one that passes its test has its consistency checked there
        passing = "test and consistency at the point reached" in c.evidence
        assert c.fitted and c.early_late_agree is None and (c.consistent is not None) == passing
        assert c is not stopped.candidates[0]
    assert any("test and consistency at the point reached" in c.evidence for c in short)

    def never(*args, **kwargs):
        def out_of_reach(x, promised):
            return False
        out_of_reach.passes = False
        return out_of_reach

    monkeypatch.setattr(diagnose_module, "_out_of_reach", never)
    full = _diagnosis(stiffer)
    assert not any("could not come near the top" in c.evidence for c in full.candidates)
    assert _outcome(stopped) == _outcome(full)
    for c in short:  # the finished fit's significance is the stopped one's, and it stays below the top
        done = next(f for f in full.candidates if f.effect == c.effect)
        assert done.significant == c.significant and done is not full.candidates[0]
        if c.consistent is not None:  # checked at the point reached as at the fit's end
            assert (c.consistent, c.amplitude_dependent) == (done.consistent, done.amplitude_dependent)
    assert stopped.evaluations < full.evaluations
