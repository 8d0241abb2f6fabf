"""The report's measured mode shapes on a rig whose sensors cannot give a body's motion: one note
naming every mode it concerns, not the same long reason once per mode."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from odsuite.contracts.plugins import build_registries, make_plugin_manager
from odsuite.domain.rig import load_rig

#: a 2 kg block on three feet with five accelerometer axes: its six motions cannot be solved
RIG = Path(__file__).parents[2] / "data" / "rigs" / "block-on-three-feet.toml"


def test_an_unsolvable_layout_is_one_note_for_every_mode(tmp_path):
    from odsuite_plugins.renderers.report import _mode_view_section

    reg = build_registries(make_plugin_manager())
    rig = load_rig(RIG, reg.sensor_types)
    names = ["tri_x", "tri_y", "tri_z", "force", "top_z", "side_xy"]
    experiment = SimpleNamespace(channel_names=names)
    project = SimpleNamespace(rig=rig, path=tmp_path / "p.h5", registries=reg, experiment=lambda name: experiment)

    def record(name, n_modes):
        shapes = np.ones((4, n_modes), complex)
        modes = SimpleNamespace(frequency_hz=np.linspace(30.0, 80.0, n_modes), damping_ratio=np.full(n_modes, 0.04),
                                output_names=["tri_x", "tri_y", "tri_z", "top_z"], shapes=shapes)
        return SimpleNamespace(experiment=name, modes=modes)

    notes: list[str] = []
    html = _mode_view_section(project, [record("side", 1), record("corner", 2)], notes)
    assert len(notes) == 1, notes
    assert notes[0].startswith(f"mode view: {tmp_path / 'p.h5'}: side mode 1, corner mode 1, corner mode 2: "), notes
    assert "body 'block'" in notes[0] and "six independent directions" in notes[0], notes
    assert "cannot be drawn" in html and "no hammer record's modes identified" not in html


def test_no_movie_names_the_sensor_layout_not_the_chains(tmp_path):
    from odsuite_plugins.renderers.report import _movie_section, _view_section, _why_no_motion

    reg = build_registries(make_plugin_manager())
    project = SimpleNamespace(rig=load_rig(RIG, reg.sensor_types), registries=reg)
    why = _why_no_motion(project)
    assert why.startswith("no body's motion can be solved from its sensors (") and "body 'block'" in why, why
    for html in (_movie_section(project.rig, None, {}, tmp_path, why=why), _view_section(project.rig, None, {}, why=why)):
        assert "no body&#x27;s motion can be solved" in html and "chains" not in html, html
