"""Every older project file runs through `compare` as a project written today does: the frozen
file of each format version (tests/data/back_compat) gives the numbers of a current project
holding the same records with the sampling rate written into every channel."""

from __future__ import annotations

import importlib.util
import json
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from odsuite.cli import main
from odsuite.contracts.plugins import registries
from odsuite.domain.rig import load_rig
from odsuite.domain.systeminfo import Systeminfo
from odsuite.store.project import create_project

BACK_COMPAT = Path(__file__).resolve().parents[1] / "data" / "back_compat"
REPO = BACK_COMPAT.parents[2]
FROZEN = sorted(BACK_COMPAT.glob("project-*.h5"))


def _expected() -> dict:
    spec = importlib.util.spec_from_file_location("make_files", BACK_COMPAT / "make_files.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.expected(), module.RIG_FILE


def _compare(capsys, path) -> dict:
    capsys.readouterr()
    assert main(["compare", str(path), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def _current(path: Path) -> Path:
    """The frozen file's content written by today's code, every channel's row 7 at 5000 Hz."""
    e, rig_file = _expected()
    si = e["systeminfo"]
    assert {ch.sampling_rate for ch in si.channels} == {0.0}  # what the frozen files hold in row 7
    si = Systeminfo([replace(ch, sampling_rate=5000.0) for ch in si.channels], si.rig)
    with create_project(path, rig=load_rig(REPO / rig_file, registries().sensor_types)) as p:
        p.add_experiment("hit-z", e["raw"], sampling_rate=5000.0, systeminfo=si, excitation=e["excitation"],
                         pretrigger=200, source="make_files.py")
        p.add_model_revision(*e["revision"], parent=0)
    return path


@pytest.mark.parametrize("frozen_file", FROZEN, ids=lambda f: f.stem)
def test_frozen_project_compares_as_a_current_one(frozen_file, tmp_path, capsys):
    old = tmp_path / frozen_file.name
    shutil.copyfile(frozen_file, old)
    got = _compare(capsys, old)
    want = _compare(capsys, _current(tmp_path / "current.h5"))
    assert got["revision"] == want["revision"] == 1
    assert got["experiments"]["hit-z"]["trigger_sample"] == 200
    assert np.isfinite(got["error"]) and np.isfinite(got["noise_floor_error"])
    assert got["experiments"] == want["experiments"]
    assert (got["error"], got["noise_floor_error"], got["bands"]) == (want["error"], want["noise_floor_error"],
                                                                      want["bands"])
