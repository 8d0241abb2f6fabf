"""Suspension modes (the bodies together on their mounts) told from modes that deform the assembly,
checked against the physics that defines them: stiffening the mounts between the bodies moves the
second kind and leaves the first nearly where it was."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from odsuite_plugins.renderers.mode_kinds import mode_words, suspension_modes

RIG = Path(__file__).resolve().parents[3] / "examples" / "rigs" / "plate-and-motor.toml"


def _model(rig):
    from odsuite.analysis.modelrev import base_model
    from odsuite.contracts.plugins import build_registries, default_manager

    return base_model(rig, registries=build_registries(default_manager()))


def test_suspension_modes_are_those_the_inner_mounts_do_not_move():
    from odsuite.contracts.plugins import build_registries, default_manager
    from odsuite.domain.rig import load_rig

    rig = load_rig(RIG, build_registries(default_manager()).sensor_types)
    flags = suspension_modes(_model(rig))
    # the same rig with the motor's mounts (between the bodies) ten times stiffer
    stiff = dataclasses.replace(rig, springs=tuple(
        dataclasses.replace(s, stiffness=10 * np.asarray(s.stiffness)) if s.group == "stiff" else s
        for s in rig.springs))
    before = _model(rig).modes().frequency_hz
    after = _model(stiff).modes().frequency_hz
    moved = np.abs(after - before) / before > 0.5  # sqrt(10) for a mode the inner mounts carry
    assert flags is not None and flags.sum() == 6  # one rigid assembly on the floor: six modes
    assert np.array_equal(flags, ~moved)
    words = mode_words(before, flags)
    assert "suspension" in words and f"{before[0]:.1f}" in words.split(";")[0]


def test_report_names_the_suspension_modes_a_record_did_not_identify():
    """Measured modes at the model's two highest suspension modes (within 10 %): the sentence names
    the other four and not those; all six measured: no sentence."""
    from types import SimpleNamespace

    from odsuite.contracts.plugins import build_registries, default_manager
    from odsuite.domain.rig import load_rig
    from odsuite_plugins.renderers.report import _missed_suspension_html

    model = _model(load_rig(RIG, build_registries(default_manager()).sensor_types))
    f = model.modes().frequency_hz
    sus = f[suspension_modes(model)]
    rec = SimpleNamespace(band_hz=(1.0, 900.0), measured_hz=np.array([1.05 * sus[-2], 0.95 * sus[-1], f[-1]]))
    text = _missed_suspension_html(rec, model)
    assert all(f"{v:.1f}" in text for v in sus[:-2]) and not any(f"{v:.1f}" in text for v in sus[-2:])
    assert _missed_suspension_html(SimpleNamespace(band_hz=(1.0, 900.0), measured_hz=sus), model) == ""


def test_a_flexible_plate_mode_is_not_a_suspension_mode():
    """The thesis rig is one platform on four springs: its six rigid-body modes are suspension modes;
    the plate's flexible mode (plate_flexibility at 640 Hz) moves no rigid body and is not one."""
    from odsuite.analysis.modelrev import apply_effects
    from odsuite.contracts.plugins import build_registries, default_manager
    from odsuite.domain.rig import load_rig

    regs = build_registries(default_manager())
    rig = load_rig(Path(__file__).resolve().parents[3] / "plugins" / "models" / "rigs" / "thesis-dynamometer.toml",
                   regs.sensor_types)
    model = apply_effects(_model(rig), [{"effect": "plate_flexibility", "values": {
        "frequency_hz": 640.0, "damping_ratio": 0.02, "twist": 0.4}}], registries=regs).shared
    f = model.modes().frequency_hz
    flags = suspension_modes(model)
    assert f.size == 7 and abs(f[-1] - 640.0) < 1.0
    assert flags.tolist() == [True] * 6 + [False]


def test_a_stack_rocking_on_its_isolators_is_suspension_though_its_mounts_give():
    """The three-body stand (frame, pedestal, head in a chain on two isolators): with the mounts
    between the bodies ten times stiffer, five modes move by less than 15 % (the stack on its
    isolators) and eleven by more than 2.7 times; the first five are suspension modes, the eleven
    not, and the assembly's six rigid motions give six in all. It called two of them so: its mounts
    let the bodies lag each other by 30-60 % of their motion."""
    from odsuite.contracts.plugins import build_registries, default_manager
    from odsuite.domain.rig import load_rig

    rig = load_rig(Path(__file__).resolve().parents[2] / "data" / "rigs" / "three-body-stand.toml",
                   build_registries(default_manager()).sensor_types)
    stiff = dataclasses.replace(rig, springs=tuple(
        dataclasses.replace(s, stiffness=10 * np.asarray(s.stiffness), rot_stiffness=10 * np.asarray(s.rot_stiffness))
        if s.other not in (None, "ground") else s for s in rig.springs))
    before = _model(rig).modes().frequency_hz
    ratio = _model(stiff).modes().frequency_hz / before
    flags = suspension_modes(_model(rig))
    assert (ratio < 1.15).sum() == 5 and (ratio > 2.7).sum() == 11
    assert flags[ratio < 1.15].all() and not flags[ratio > 2.7].any() and flags.sum() == 6


def test_report_lists_the_model_modes_a_record_can_see():
    """The summary listed all 98 modes of the LADISK beam's finite elements, up to 2976048.7 Hz, for
    records sampled at 50 kHz: now those up to the 25 kHz Nyquist frequency, and how many more."""
    from types import SimpleNamespace

    from odsuite.contracts.plugins import build_registries, default_manager
    from odsuite.domain.rig import load_rig
    from odsuite_plugins.renderers.report import _model_modes_words

    beam = Path(__file__).resolve().parents[3] / "projects" / "rigs" / "ladisk-beam.toml"
    model = _model(load_rig(beam, build_registries(default_manager()).sensor_types))
    f = model.modes().frequency_hz
    rmodel = SimpleNamespace(for_experiment=lambda name: model)
    words = _model_modes_words(rmodel, [SimpleNamespace(name="hit", fs=50_000.0)], list(f))
    listed, _, rest = words.partition(" (")
    assert [float(v) for v in listed.split(", ")] == [round(v, 1) for v in f[f <= 25_000.0]]
    assert rest == f"{np.sum(f > 25_000.0)} more above 25000 Hz, the records' Nyquist frequency)"
