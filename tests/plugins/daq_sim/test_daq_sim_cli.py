"""`odsuite acquire` on the simulated rig, and its one-line answer when NI-DAQmx is missing."""

from __future__ import annotations

import sys

import numpy as np
from odsuite_plugins.daq_sim.scenarios import SCENARIOS
from odsuite_plugins.daq_sim.simulator import SimulatedRig

from odsuite.cli import main
from odsuite.contracts.daq import AcquisitionSettings
from odsuite.store.project import open_project


def test_acquire_sim_scenario_is_the_seeded_record(tmp_path, thesis_rig, capsys):
    p = tmp_path / "p.h5"
    assert main(["new", str(p)]) == 0
    args = ["acquire", str(p), "--daq", "sim", "--name", "t5", "--scenario", "T5", "--seed", "3",
            "--samples", "2048", "--pretrigger", "400"]
    assert main(args) == 0
    assert "acquired 't5': 2048 samples x 11 channels at 20000 Hz, 400 before the trigger" in capsys.readouterr().out
    rec = SimulatedRig().record(thesis_rig, AcquisitionSettings(n_samples=2048, pretrigger=400), scenario="T5", seed=3)
    with open_project(p) as project:
        exp = project.experiment("t5")
        np.testing.assert_array_equal(exp.raw(), np.concatenate(list(rec.chunks)))
        np.testing.assert_allclose(exp.excitation.direction, SCENARIOS["T5"].direction)
    assert main(args) == 1
    assert capsys.readouterr().err.strip().count("\n") == 0


def test_acquire_ni_without_nidaqmx_says_what_is_missing(tmp_path, monkeypatch, capsys):
    p = tmp_path / "p.h5"
    assert main(["new", str(p)]) == 0
    monkeypatch.setitem(sys.modules, "nidaqmx", None)
    assert main(["acquire", str(p), "--daq", "ni", "--name", "x"]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    assert "needs the Python package 'nidaqmx' (`pip install nidaqmx`) and the NI-DAQmx driver" in err
    with open_project(p) as project:
        assert project.experiment_names() == []
