"""A single candidate's full fit stops where it can no longer matter (diagnose._out_of_reach):
its significance decided at the point reached and its error, less what its linearisation still
promises, far above the best screened candidate's; one that passes its test has its consistency
(amplitude dependence, which decides its confounding) checked there. Its validation, the other half of its
significance, is left out where a named candidate leaves nothing above the floor (diagnose._decided_without):
it is then not called significant. Where its significance is read (diagnose._settled fits it again and
validates it), the outcome is the one of the fits let run to their ends: the same verdict, top, significance
and order. The stop saves evaluations."""

from __future__ import annotations

import io
import json
import math
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

    # the same diagnosis with every stopped fit's significance read: each settled, alike on two workers
    with monkeypatch.context() as m:
        m.setattr(diagnose_module, "_decided_without", lambda *a: False)
        settled = _diagnosis(stiffer)
        with open_project(stiffer) as project:
            two = diagnose_module.diagnose(project, effects=EFFECTS, workers=2)
    assert json.dumps(two.as_dict()) == json.dumps(settled.as_dict()) and two.evaluations == settled.evaluations
    unsettled = [c for c in stopped.candidates if c.validation == diagnose_module.UNSETTLED]
    assert unsettled, "no stopped fit was left unsettled: the test would not test it"
    assert not any(c.validation == diagnose_module.UNSETTLED for c in settled.candidates)

    monkeypatch.setattr(diagnose_module, "_out_of_reach", never)
    full = _diagnosis(stiffer)
    assert not any("could not come near the top" in c.evidence for c in full.candidates)
    assert _outcome(settled) == _outcome(full)
    # left unsettled: the same verdict and top, and the same significance of every other candidate
    assert stopped.verdict == full.verdict == "explained" and stopped.candidates[0].effect == full.candidates[0].effect
    for c in unsettled:
        assert c.fitted and not c.significant and math.isnan(c.validated_error) and math.isinf(c.bic)
        assert all(v is None for v in c.uncertainties.values())
    # diagnose's table says "-" (not decided) in its significance column, not "no"
    from rich.console import Console

    from odsuite.cli.loop_commands import _candidates_table

    console = Console(width=100, record=True, file=io.StringIO())
    console.print(_candidates_table([c.as_dict() for c in stopped.candidates], 100))
    rows = {line.split("│")[1].strip(): line.split("│")[2].strip() for line in console.export_text().splitlines()
            if line.count("│") > 3}
    assert all(rows[c.effect] == "-" for c in unsettled) and rows[stopped.candidates[0].effect] == "yes"
    # and the report "not decided"
    from plugins.renderers.report import _candidates_section

    doc = stopped.as_dict()
    assert [c["significance_decided"] for c in doc["candidates"]] == [c not in unsettled for c in stopped.candidates]
    html = _candidates_section(doc, doc["revision"], [])
    assert html.count("not decided") == len(unsettled)
    assert ([c.effect for c in stopped.candidates if c.significant]
            == [c.effect for c in full.candidates if c.significant and all(u.effect != c.effect for u in unsettled)])
    for c in short:  # the finished fit's significance is the settled one's, and it stays below the top
        done = next(f for f in full.candidates if f.effect == c.effect)
        again = next(f for f in settled.candidates if f.effect == c.effect)
        assert done.significant == again.significant and done is not full.candidates[0]
        if c.consistent is not None:  # checked at the point reached as at the fit's end
            assert (c.consistent, c.amplitude_dependent) == (done.consistent, done.amplitude_dependent)
    assert stopped.evaluations < full.evaluations


def test_the_stopped_fits_are_settled_unless_a_named_candidate_leaves_nothing():
    """_decided_without: a significant named mechanism leaving no cell above the floor decides; one that
    leaves cells (a pair or a refinement may follow) or a significant data-driven stand-in (prefer_named
    may promote a named one however far behind) does not."""
    from types import SimpleNamespace

    from odsuite.contracts.plugins import registries

    effects = registries().effects
    assert getattr(effects.get("missing_mode"), "data_driven", False)
    job = {"effects": effects, "noise": 0.01, "n_eff": 1000.0}

    def cand(effect, error, significant=True):
        return SimpleNamespace(effect=effect, fitted=True, significant=significant, error_after=error, _resolved=None,
                               bic=math.log(error), validation="leave one experiment out", n_parameters=7)

    explains = cand("stiffness", 0.01)  # at the floor (pooled: no bands in this job)
    leaves = cand("stiffness", 0.2)
    assert diagnose_module._decided_without([explains, cand("mass_properties", 0.3, False)], job)
    assert not diagnose_module._decided_without([leaves, cand("mass_properties", 0.3, False)], job)
    assert not diagnose_module._decided_without([explains, cand("missing_mode", 0.01)], job)
    assert not diagnose_module._decided_without([cand("stiffness", 0.01, significant=False)], job)
    # the resolved test where the floor has bands: a cell above it is left
    resolved = cand("stiffness", 0.2)
    resolved._resolved = SimpleNamespace(detected=lambda: False)
    assert diagnose_module._decided_without([resolved, cand("mass_properties", 0.3, False)], job)
    resolved._resolved = SimpleNamespace(detected=lambda: True)
    assert not diagnose_module._decided_without([resolved, cand("mass_properties", 0.3, False)], job)


def test_a_stopped_fit_that_could_go_first_is_settled():
    """An unsettled fit with fewer parameters whose BIC at the point reached is not above the lead's,
    or that the lead does not explain significantly more than, or whose values follow the force
    level, is settled (_decided_without)."""
    from types import SimpleNamespace

    from odsuite.analysis import resolved as resolution
    from odsuite.contracts.plugins import registries

    job = {"effects": registries().effects, "noise": 0.01, "n_eff": 1000.0}
    lead = SimpleNamespace(effect="mass_properties", fitted=True, significant=True, error_after=0.01,
                           validation="leave one experiment out", n_parameters=10, bic=1000.0 * math.log(0.0105**2) + 10 * math.log(1000.0), _resolved=None)

    def unsettled(error, k=4, amplitude=(), gain=None):
        c = SimpleNamespace(effect="stiffness", fitted=True, significant=False, error_after=error, n_parameters=k,
                            validation=diagnose_module.UNSETTLED, amplitude_dependent=list(amplitude), _resolved=None)
        if gain is not None:  # both judged on the resolved residual: the lead leaves no cell
            c._resolved = SimpleNamespace(detected=lambda: True)
            lead._resolved = SimpleNamespace(detected=lambda: False)
        return c

    far = unsettled(0.3, k=12)
    assert diagnose_module._decided_without([lead, far], job)
    # its BIC at the point reached below the lead's: 6 parameters fewer make up for 1.4 % more error
    assert not diagnose_module._decided_without([lead, unsettled(0.0106, k=12 - 8)], job)
    assert not diagnose_module._decided_without([lead, unsettled(0.3, k=12, amplitude=["stiffness_z"])], job)
    # fewer parameters: the lead must explain significantly more (the resolved test)
    original = resolution.gain
    try:
        resolution.gain = lambda a, b: 1e6
        assert diagnose_module._decided_without([lead, unsettled(0.3, k=4, gain=True)], job)
        resolution.gain = lambda a, b: 1.0
        assert not diagnose_module._decided_without([lead, unsettled(0.3, k=4, gain=True)], job)
    finally:
        resolution.gain = original
