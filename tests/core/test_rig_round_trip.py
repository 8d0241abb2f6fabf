"""A rig stored in a project reads back with everything its file said: processing tables (rig-wide
and per sensor) and the upward direction."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from odsuite.core.project import create_project, open_project
from odsuite.core.systeminfo import Systeminfo

RIGS = Path(__file__).resolve().parents[2] / "projects" / "rigs"


def test_processing_and_up_survive_the_project(tmp_path):
    text = (RIGS / "two-body-machine.toml").read_text().replace(
        'sensitivity = 0.00225', 'sensitivity = 0.00225\nprocessing = { filter = { type = "lowpass", cutoff_hz = 2000.0 }, '
        'filter_at = ["signal"] }', 1)
    rig_file = tmp_path / "rig.toml"
    rig_file.write_text(text)
    create_project(tmp_path / "p.h5", str(rig_file)).close()
    with open_project(tmp_path / "p.h5") as p:
        rig = p.rig
    assert rig.processing["cutoff_low"] == 4.0 and rig.processing["filter_order"] == 4
    si = Systeminfo.for_rig(rig, 10240.0)
    assert si.channels[0].cutoff_high == 2000.0 and si.channels[0].filters_on == 1
    assert si.channels[1].cutoff_low == 4.0
    assert np.allclose(rig.up, [0, 0, 1])  # the default: the file says nothing


def test_the_thesis_rig_keeps_its_downward_z(tmp_path):
    create_project(tmp_path / "p.h5", "thesis-dynamometer").close()
    with open_project(tmp_path / "p.h5") as p:
        assert np.allclose(p.rig.up, [0, 0, -1])
