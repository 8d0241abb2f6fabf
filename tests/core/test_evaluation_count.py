"""The model evaluations diagnose reports are every evaluation its candidates' problems made: a
discrete choice's trials (channel_swap tries every pair of sensors), the judgement of a fit on the
whole records, the ranking's and the verdict's predictions. Tallied here on every problem as it
counts, one worker so that every problem lives in this process."""

from __future__ import annotations

from collections import Counter

import pytest

from hidden_effects import make_project


class _Tally:
    """Problem.evaluations as a descriptor that adds each increase to ``counts``, except where a
    count is copied onto a rebuilt problem (diagnose._kept_back: counted where it was made)."""

    def __init__(self) -> None:
        self.counts: Counter = Counter()
        self.copying = False

    def __get__(self, obj, typ=None):
        return self if obj is None else obj.__dict__.get("_tallied", 0)

    def __set__(self, obj, value) -> None:
        old = obj.__dict__.get("_tallied")
        if old is not None and value > old and not self.copying:
            self.counts[obj.effect.name] += value - old
        obj.__dict__["_tallied"] = value


def test_diagnose_reports_every_evaluation_of_a_discrete_choices_trials(tmp_path, monkeypatch):
    from odsuite.diagnosis import diagnose as dg
    from odsuite.diagnosis import fitting
    from odsuite.store.project import open_project

    path = make_project(tmp_path / "p.odsp", [("channel_swap", {"pair": 1.0, "ratio": 1.0})], n_samples=2048,
                        scenarios=("T1", "T5", "T6"))
    tally = _Tally()
    monkeypatch.setattr(fitting.Problem, "evaluations", tally, raising=False)

    def copying(move):  # counts moved from one problem to another, tallied where they were made
        def moved(*args):
            tally.copying = True
            try:
                return move(*args)
            finally:
                tally.copying = False
        return moved

    monkeypatch.setattr(dg, "_kept_back", copying(dg._kept_back))
    monkeypatch.setattr(fitting, "_count_on", copying(fitting._count_on))
    with open_project(path) as p:
        d = dg.diagnose(p, effects=["channel_swap"], workers=1)
        pairs = len(p.registries.effects.get("channel_swap").parameters(dg.revision_model(p).shared)[0].choices) - 1
    assert pairs >= 20  # nine accelerometers of one kind
    assert tally.counts["channel_swap"] > pairs
    assert d.evaluations == sum(tally.counts.values())


def test_the_judgement_of_a_fit_predicts_nothing_again(tmp_path, monkeypatch):
    """A fitted candidate's judgement (diagnose._judge: its resolved residual over the whole
    records) reads the prediction its fit made there, kept past the checks that predict other
    points since: no model evaluation."""
    from odsuite.diagnosis import diagnose as dg
    from odsuite.store.project import open_project

    from hidden_effects import CASES

    spent: list[tuple[str, int]] = []
    judge = dg._judge

    def counted(cand, *args, **kwargs):
        before = cand._problem.evaluations
        judge(cand, *args, **kwargs)
        spent.append((cand.effect, cand._problem.evaluations - before))

    monkeypatch.setattr(dg, "_judge", counted)
    path = make_project(tmp_path / "p.odsp", [("stiffness", CASES["stiffness"])], n_samples=2048,
                        scenarios=("T1", "T3", "T5"))
    with open_project(path) as p:
        dg.diagnose(p, effects=["stiffness", "damping"], workers=1)
    assert "stiffness" in {e for e, _ in spent}  # fitted (damping may be ranked by its screening alone)
    assert all(n == 0 for _, n in spent), spent
