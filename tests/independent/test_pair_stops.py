"""A pair's joint fit stops early only where it cannot pass the pair test (diagnose._cannot_pass):
on a case the pairs calibration accepts a pair on (the independent generator's thesis rig, a
sensor gain and a moved centre of mass, seed 300), every check lets the fits go on and the pair
is named as before. Slow: `make stress` runs it."""

from __future__ import annotations

import pytest

import odsuite.diagnosis.diagnose as diagnose_module
from odsuite.store.project import open_project

from . import calibrate, writers

pytestmark = pytest.mark.slow


def test_an_accepted_pair_is_never_stopped(tmp_path, monkeypatch):
    spec = next(s for s in calibrate.specs("pairs", 1) if s["id"] == "pairs-thesis-pair-gain-com-s300")
    case = calibrate.build(spec)
    records = case.simulate()
    rig = writers.write_rig_toml(tmp_path / "rig.toml", case.nominal)
    lvms = [writers.write_lvm(tmp_path / f"r{i:02d}.lvm", calibrate.without_unused(r)) for i, r in enumerate(records)]
    project = calibrate.make_project(tmp_path, rig, lvms, writers.to_jsonable(case.truth_document()))
    said = []
    original = diagnose_module._cannot_pass

    def recorded(problem, simpler, floor, k, why):
        check = original(problem, simpler, floor, k, why)

        def asked(x, promised):
            said.append((problem.effect.name, check(x, promised)))
            return said[-1][1]

        return asked

    monkeypatch.setattr(diagnose_module, "_cannot_pass", recorded)
    with open_project(project) as p:
        d = diagnose_module.diagnose(p, workers=1)
    top = d.candidates[0]
    # measured: mass_properties+sensor_gain, each adding a likelihood ratio of 1e7 over the other
    assert top.effect == "mass_properties+sensor_gain" and top.significant, top.evidence
    assert ("mass_properties+sensor_gain", False) in said and not any(stop for _, stop in said), said
