"""Fitted effects in physical units (N/m per spring, kg, mm, Hz), against numbers worked out by hand
from the rig files, and which model families each effect applies to."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest
from odsuite_plugins.beam.model import beam_model

from odsuite.contracts.effects import applies
from odsuite.diagnosis.diagnose import _moved_modes
from odsuite.diagnosis.physical import moved, quantities, text
from odsuite.domain.rig import load_rig

RIGS = Path(__file__).resolve().parents[3] / "projects" / "rigs"


@pytest.fixture
def two_body(registries):
    rig = load_rig(RIGS / "two-body-machine.toml", registries.sensor_types)
    return registries.models.get("rigid-bodies")(rig), tomllib.loads((RIGS / "two-body-machine.toml").read_text())


@pytest.fixture
def beam(registries):
    return beam_model(load_rig(RIGS / "ladisk-beam.toml", registries.sensor_types))


def row(rows, label):
    return next(r for r in rows if r["label"] == label)


def test_spring_stiffness_in_n_per_m_per_spring_and_axis(registries, two_body):
    model, toml = two_body
    springs = {s["name"]: s["stiffness"] for s in toml["springs"]}
    effect = registries.effects.get("stiffness")
    rows = quantities(effect, model, {"scale_z": 1.3, "scale_mount1": 0.5})
    # by hand: the rig file's k times the axis factor times the spring's own factor
    assert row(rows, "stiffness of mount1 along z")["value"] == pytest.approx(springs["mount1"][2] * 1.3 * 0.5, rel=1e-12)
    assert row(rows, "stiffness of mount1 along x")["value"] == pytest.approx(springs["mount1"][0] * 0.5, rel=1e-12)
    assert row(rows, "stiffness of isolator3 along z")["value"] == pytest.approx(springs["isolator3"][2] * 1.3, rel=1e-12)
    assert row(rows, "stiffness of isolator3 along z")["nominal"] == springs["isolator3"][2]
    assert all(r["unit"] == "N/m" for r in rows) and len(rows) == 3 * len(springs)
    # another split of the same products gives the same N/m
    other = quantities(effect, model, {"scale_z": 0.65, "scale_mount1": 1.0, **{
        f"scale_{n}": 2.0 for n in springs if n != "mount1"}, "scale_x": 0.5, "scale_y": 0.5})
    for label in ("stiffness of mount1 along z", "stiffness of isolator3 along z", "stiffness of isolator3 along x"):
        assert row(other, label)["value"] == pytest.approx(row(rows, label)["value"], rel=1e-12)


def test_undetermined_split_leaves_the_product_determined(registries, two_body):
    model, toml = two_body
    k = {s["name"]: s["stiffness"] for s in toml["springs"]}
    # scale_z and scale_mount1 fitted with 0.3 each, perfectly anticorrelated: only their product is seen
    rows = quantities(registries.effects.get("stiffness"), model, {"scale_z": 1.0, "scale_mount1": 1.0},
                      ["scale_z", "scale_mount1"], [0.3, 0.3], np.array([[1.0, -1.0], [-1.0, 1.0]]))
    assert row(rows, "stiffness of mount1 along z")["uncertainty"] == pytest.approx(0.0, abs=1e-6 * k["mount1"][2])
    # isolator3 sees scale_z alone: sd = 0.3 x its rig stiffness
    assert row(rows, "stiffness of isolator3 along z")["uncertainty"] == pytest.approx(0.3 * k["isolator3"][2], rel=1e-6)
    # independent instead: the variances add, (0.3^2 + 0.3^2)^0.5 x k
    rows = quantities(registries.effects.get("stiffness"), model, {}, ["scale_z", "scale_mount1"], [0.3, 0.3])
    assert row(rows, "stiffness of mount1 along z")["uncertainty"] == pytest.approx(0.3 * 2**0.5 * k["mount1"][2], rel=1e-6)


def test_spread_between_records_propagated_as_a_whole(registries, two_body):
    """A spread between records of the same two parameters, moving together (the product fixed),
    adds nothing to mount1's determined stiffness; where it is wider along scale_z alone,
    isolator3's sd is that spread's, not the fit's."""
    model, toml = two_body
    k = {s["name"]: s["stiffness"] for s in toml["springs"]}
    fit_corr = np.array([[1.0, -1.0], [-1.0, 1.0]])
    together = np.array([[1.0, -1.0], [-1.0, 1.0]]) * 0.5**2  # sd 0.5 each, the product unmoved
    rows = quantities(registries.effects.get("stiffness"), model, {"scale_z": 1.0, "scale_mount1": 1.0},
                      ["scale_z", "scale_mount1"], [0.3, 0.3], fit_corr, together)
    assert row(rows, "stiffness of mount1 along z")["uncertainty"] == pytest.approx(0.0, abs=1e-6 * k["mount1"][2])
    assert row(rows, "stiffness of isolator3 along z")["uncertainty"] == pytest.approx(0.5 * k["isolator3"][2], rel=1e-6)
    # narrower than the fit's: the fit's stays
    rows = quantities(registries.effects.get("stiffness"), model, {"scale_z": 1.0, "scale_mount1": 1.0},
                      ["scale_z", "scale_mount1"], [0.3, 0.3], fit_corr, together * 0.01)
    assert row(rows, "stiffness of isolator3 along z")["uncertainty"] == pytest.approx(0.3 * k["isolator3"][2], rel=1e-6)


def test_masses_in_kg_and_centre_of_mass_in_mm(registries, two_body):
    model, toml = two_body
    machine = next(b for b in toml["bodies"] if b["name"] == "machine")
    rows = quantities(registries.effects.get("mass_properties"), model,
                      {"machine_mass_scale": 1.1, "machine_com_dz": 0.004})
    assert row(rows, "mass of machine")["value"] == pytest.approx(machine["mass"] * 1.1, rel=1e-12)
    assert row(rows, "mass of machine")["unit"] == "kg"
    assert row(rows, "centre of mass of machine, z")["value"] == pytest.approx(1e3 * machine["com"][2] + 4.0, rel=1e-12)
    assert row(rows, "centre of mass of machine, z")["unit"] == "mm"
    shown = moved(rows, 2)
    assert [r["label"] for r in shown] == ["mass of machine", "centre of mass of machine, z"]
    assert "mass of machine = 22 kg (model: 20)" in text(shown)


def test_missing_mode_names_its_body_and_no_nominal(registries, two_body):
    model, _ = two_body
    effect = registries.effects.get("missing_mode")
    phis = {p.name: 0.5 for p in effect.parameters(model) if p.name.startswith("phi_") and p.scope == "shared"}
    rows = quantities(effect, model, {"frequency_hz": 183.1, "damping_ratio": 0.012, "body": 1.0, **phis})
    assert [(r["label"], r["value"], r["unit"]) for r in rows] == [
        ("frequency of a mode of machine", 183.1, "Hz"), ("damping ratio of that mode", pytest.approx(1.2), "%")]
    assert all(r["nominal"] is None for r in rows) and "500" not in text(rows) and "model:" not in text(rows)


def test_beam_effects_in_mm_kg_and_n_m2(registries, beam):
    toml = tomllib.loads((RIGS / "ladisk-beam.toml").read_text())
    fx = registries.effects
    pos = quantities(fx.get("beam-positions"), beam, {"acc_shift": 0.0137, "hammer_shift": 0.0265})
    acc = next(s for s in toml["sensors"] if s["name"] == "acc")
    assert row(pos, "sensor acc from the beam's left end")["value"] == pytest.approx(1e3 * acc["position"][0] + 13.7)
    assert row(pos, "hammer from its recorded point")["value"] == pytest.approx(26.5)
    mass = quantities(fx.get("beam-mass-scale"), beam, {"scale": 0.789})
    assert mass[0]["value"] == pytest.approx(toml["bodies"][0]["mass"] * 0.789, rel=1e-12) and mass[0]["unit"] == "kg"
    supports = quantities(fx.get("beam-supports"), beam, {"foam_right_stiffness": 900.0})
    assert [r["value"] for r in supports] == [toml["beam"]["supports"][0]["stiffness"], 900.0]
    ei = quantities(fx.get("beam-stiffness-scale"), beam, {"scale": 0.8})[0]
    assert ei["value"] == pytest.approx(0.8 * beam.structure.spec.bending_stiffness, rel=1e-12)
    assert ei["unit"] == "N m^2"


def test_moved_modes_read_as_mode_numbers():
    assert _moved_modes([9.0, 21.4, 30.0, 225.0], [9.0, 18.2, 30.1, 225.0]) == ["mode 2: 21.4 → 18.2 Hz"]
    assert _moved_modes([9.0, 225.0], [9.0, 225.0]) == []


def test_each_effect_applies_to_its_model_family(registries, beam):
    thesis = registries.models.get("rigid-bodies")(registries.rigs.get("thesis-dynamometer"))
    fx = registries.effects
    on_beam = {n for n in fx.names() if applies(fx.get(n), beam)}
    on_thesis = {n for n in fx.names() if applies(fx.get(n), thesis)}
    assert {"stiffness", "damping", "missing_mode", "coupled_mode", "mounted_mode", "mass_properties",
            "nonlinear_stiffness"}.isdisjoint(on_beam)
    assert {n for n in fx.names() if n.startswith("beam-")} <= on_beam
    assert not any(n.startswith("beam-") for n in on_thesis)
    assert {"sensor_gain", "force_gain", "channel_delay"} <= on_beam & on_thesis
    # what applies can be applied away from its nominal on that model
    for n in on_beam:
        effect = fx.get(n)
        values = {p.name: p.upper if p.choices is None else p.choices[-1] for p in effect.parameters(beam)}
        effect.apply(beam, values).modes()
