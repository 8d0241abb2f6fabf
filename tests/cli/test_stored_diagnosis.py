"""`diagnose` keeps a diagnosis of every effect with the current revision, stamped with the records
it was made on; the report shows it while the records and revision are as they were, and
diagnoses again (saying so) once they change."""

from __future__ import annotations

import json
import math

import pytest

from odsuite.analysis.history import data_stamp
from odsuite.analysis.stored_diagnosis import diagnosis_stamp, store_diagnosis, stored_diagnosis
from odsuite.cli import main
from odsuite.store.project import open_project


def _run(*argv) -> None:
    assert main([str(a) for a in argv]) == 0


def _acquire(p, name: str, seed: int) -> None:
    _run("acquire", p, "--daq", "sim", "--name", name, "--scenario", "T1", "--seed", seed, "--samples", "2048")


@pytest.fixture
def project(tmp_path, capsys):
    p = tmp_path / "p.h5"
    _run("new", p)
    _acquire(p, "T1", 1)
    _run("process", p)
    capsys.readouterr()
    return p


class _Doc:
    """What `diagnose` returns, as far as the command uses it (the diagnosis itself is tested in
    tests/core/test_diagnosis.py): a document with numbers JSON has no literal for."""

    def __init__(self, revision: int) -> None:
        self.doc = {"verdict": "explained", "noise_floor": 0.05, "residual_to_floor": math.inf, "message": "m",
                    "signature": {"channels": [], "experiments": [], "bands": [], "peaks_hz": [],
                                  "amplitude_dependent": False},
                    "baseline_error": 0.25, "noise_floor_error": 0.05, "revision": revision,
                    "candidates": [{"effect": "stiffness", "significant": True, "consistent": True,
                                    "plausible": True, "fitted": True, "error_after": 0.06,
                                    "validated_error": math.nan, "confounded_with": [], "evidence": "e"}],
                    "residual_peaks": [], "model_evaluations": 3, "not_applicable": [], "other_families": []}

    def as_dict(self) -> dict:
        return json.loads(json.dumps(self.doc))


def test_the_diagnose_command_keeps_its_result_for_the_records_it_saw(project, capsys, monkeypatch):
    import odsuite.diagnosis.diagnose as diagnosis

    calls = []

    def fake(p, **kw):
        calls.append(kw.get("effects"))
        return _Doc(p.current_revision)

    monkeypatch.setattr(diagnosis, "diagnose", fake)
    # a subset of the effects is not the diagnosis the report shows: nothing kept
    _run("diagnose", project, "--effect", "stiffness", "--json")
    with open_project(project) as p:
        assert stored_diagnosis(p, 0) is None
    capsys.readouterr()
    _run("diagnose", project, "--json")
    printed = json.loads(capsys.readouterr().out)
    with open_project(project) as p:
        kept = stored_diagnosis(p, 0)
        metrics = p.model_revisions()[0]["metrics"]
        assert metrics["diagnosis"]["stamp"]["data_stamp"] == data_stamp(p)
    assert calls == [["stiffness"], None]
    assert kept["candidates"][0]["effect"] == printed["candidates"][0]["effect"] == "stiffness"
    assert kept["baseline_error"] == printed["baseline_error"] == 0.25
    assert math.isinf(kept["residual_to_floor"]) and math.isnan(kept["candidates"][0]["validated_error"])
    # the stored error beside it is untouched
    assert metrics["error"] > 0 and metrics["data_stamp"] == metrics["diagnosis"]["stamp"]["data_stamp"]

    # a second record: the kept diagnosis no longer holds
    _acquire(project, "T2", 2)
    with open_project(project) as p:
        assert stored_diagnosis(p, 0) is None


def test_a_diagnosis_is_kept_only_for_the_project_its_stamp_describes(project):
    with open_project(project) as p:
        stamp = diagnosis_stamp(p)
    _acquire(project, "T2", 2)  # the records changed while "diagnosing"
    doc = _Doc(0).as_dict()
    with open_project(project, "a") as p:
        assert not store_diagnosis(p, doc, stamp)
        assert "diagnosis" not in p.model_revisions()[0]["metrics"]
        assert not store_diagnosis(p, {**doc, "revision": 1}, diagnosis_stamp(p))  # no such revision is current
        assert store_diagnosis(p, doc, diagnosis_stamp(p))
    with open_project(project) as p:
        assert stored_diagnosis(p, 0)["baseline_error"] == 0.25
        assert stored_diagnosis(p, 1) is None


def test_the_report_shows_the_kept_diagnosis_and_diagnoses_when_there_is_none(project, monkeypatch):
    import odsuite.diagnosis.diagnose as diagnosis
    from odsuite.api import prepare
    from odsuite_plugins.renderers.report import _candidates_section, _diagnosis

    import odsuite.api as api

    ran = []
    fake = lambda p, **kw: ran.append(kw) or _Doc(p.current_revision)  # noqa: E731
    # the API first (it keeps a name once looked up: looked up after the module's patch, the fake
    # would be what the undo puts back)
    monkeypatch.setattr(api, "diagnose", fake, raising=False)
    monkeypatch.setattr(diagnosis, "diagnose", fake)
    told: list[str] = []
    with open_project(project) as p:
        notes: list[str] = []
        doc, source = _diagnosis(p, prepare(p), 0, None, True, notes, told.append)
    assert len(ran) == 1 and told and told[0] == "diagnosing"
    assert "run now for this page" in source and "odsuite diagnose p.h5" in notes[0]
    with open_project(project, "a") as p:
        assert store_diagnosis(p, {**doc, "baseline_error": 0.125}, diagnosis_stamp(p))
    with open_project(project) as p:
        notes, told = [], []
        doc, source = _diagnosis(p, prepare(p), 0, None, True, notes, told.append)
    assert len(ran) == 1 and not told and not notes  # not diagnosed again
    assert doc["baseline_error"] == 0.125 and "kept with revision 0" in source
    html = _candidates_section(doc, 0, notes, source)
    assert "kept with revision 0" in html and "stiffness" in html and "0.1250" in html


def test_the_kept_diagnosis_outlives_an_frf_run(project, capsys, monkeypatch):
    """`frf` and `modes` store the record's FRFs again at every run; no comparison reads them, so
    the kept diagnosis (and the revision's stored error) still hold afterwards."""
    import odsuite.diagnosis.diagnose as diagnosis

    monkeypatch.setattr(diagnosis, "diagnose", lambda p, **kw: _Doc(p.current_revision))
    _run("diagnose", project, "--json")
    with open_project(project) as p:
        before = data_stamp(p)
        assert stored_diagnosis(p, 0) is not None
    _run("frf", project, "--experiment", "T1")
    _run("frf", project, "--experiment", "T1")
    with open_project(project) as p:
        assert "frf" in p.derived_kinds("T1")
        assert data_stamp(p) == before and stored_diagnosis(p, 0) is not None
    _run("process", project)  # the records processed again: it no longer holds
    with open_project(project) as p:
        assert data_stamp(p) != before and stored_diagnosis(p, 0) is None
