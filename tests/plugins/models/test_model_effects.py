"""Physical effects: nominal values change nothing; each effect does what physics says it does."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from odsuite import hookimpl
from odsuite.contracts.effects import Effect, Parameter
from odsuite.domain.errors import ConfigError
from odsuite.domain.model import Input, Model, Output, RigidBody, SpringDamper, Structure
from odsuite.contracts.plugins import build_registries, make_plugin_manager
from odsuite.domain.simulation import simulate

FREQS = np.array([20.0, 97.4, 150.0, 222.0, 400.0, 900.0])
T5 = Input.force((0.050025, -0.075761, -0.00632), (-1, 0, 0))  # Table 5.3 test 5
T8 = Input.force((0.0, 0.004122, -0.011399), (0, 0, 1))  # Table 5.3 test 8


@pytest.fixture
def model(registries, thesis_rig) -> Model:
    return registries.models.get("thesis-dynamometer")(thesis_rig)


def sensor_outputs(rig, quantity="acceleration"):
    return [Output.sensor(s, quantity) for s in rig.sensors]


def frf(model, rig, inputs=(T5, T8), quantity="acceleration"):
    return model.transfer(list(inputs), sensor_outputs(rig, quantity), FREQS)


def test_every_registered_effect_at_nominal_leaves_outputs_unchanged(registries, model, thesis_rig):
    ref = frf(model, thesis_rig)
    coords = model.transfer([T5], Output.coordinates(thesis_rig.body("platform")), FREQS)
    u = np.zeros((400, 1))
    u[10:18, 0] = 200 * np.sin(np.pi * np.arange(8) / 8)
    y0 = simulate(model, [T8], u, 20e3, sensor_outputs(thesis_rig))
    assert len(registries.effects) >= 12
    for name, effect in registries.effects.items():
        if registries.effects.entry(name).plugin == "beam":
            continue  # a beam model's effects (tests/plugins/beam): they do not apply to rigid bodies
        if name == "measured-modal-damping":
            # needs a structure whose modal damping is set mode by mode (the beam's: tests/plugins/beam)
            assert effect.parameters(model) == []
            continue
        on = model
        if name == "spring_stiffness":
            assert effect.parameters(model) == []  # the thesis rig's springs are not grouped: stiffness's own
            # the four springs declared alike: a group changes no physics, so the references hold
            st = model.structure
            on = model.replace(structure=type(st)(bodies=st.bodies, flexible_modes=st.flexible_modes,
                                                  springs=tuple(dataclasses.replace(k, group="iso") for k in st.springs)))
        params = effect.parameters(on)
        assert params and all(isinstance(p, Parameter) for p in params)
        assert all(p.scope in ("shared", "per_experiment") and p.lower <= p.nominal <= p.upper for p in params)
        changed = effect.apply(on, {})
        assert changed.effects == (name,)
        assert np.max(np.abs(frf(changed, thesis_rig) - ref)) <= 1e-12 * np.abs(ref).max(), name
        c2 = changed.transfer([T5], Output.coordinates(thesis_rig.body("platform")), FREQS)
        assert np.max(np.abs(c2 - coords)) <= 1e-12 * np.abs(coords).max(), name
        y = simulate(changed, [T8], u, 20e3, sensor_outputs(thesis_rig))
        assert np.max(np.abs(y - y0)) <= 1e-12 * np.abs(y0).max(), name
        assert np.allclose(changed.modes().frequency_hz, model.modes().frequency_hz, rtol=1e-12), name


def test_stiffness_times_1_21_raises_every_frequency_by_1_1(registries, model):
    stiff = registries.effects.get("stiffness")
    damp = registries.effects.get("damping")
    scaled = stiff.apply(model, {"scale_x": 1.21, "scale_y": 1.21, "scale_z": 1.21})
    scaled = damp.apply(scaled, {"scale_x": 1.1, "scale_y": 1.1, "scale_z": 1.1})
    m0, m1 = model.modes(), scaled.modes()
    assert np.allclose(m1.frequency_hz, 1.1 * m0.frequency_hz, rtol=1e-12)
    assert np.allclose(m1.damping_ratio, m0.damping_ratio, rtol=1e-10)
    # stiffness alone on the undamped structure: the same 1.1
    undamped = damp.apply(model, {f"scale_{a}": 0.0 for a in "xyz"})
    f0 = undamped.modes().frequency_hz
    f1 = stiff.apply(undamped, {f"scale_{a}": 1.21 for a in "xyz"}).modes().frequency_hz
    assert np.allclose(f1 / f0, 1.1, rtol=1e-12)


def test_per_spring_scale_changes_only_that_spring(registries, model):
    stiff = registries.effects.get("stiffness").apply(model, {"scale_spring3": 2.0})
    s3 = model.springs[2]
    P = np.hstack([np.eye(3), -np.array([[0, -s3.point[2], s3.point[1]], [s3.point[2], 0, -s3.point[0]],
                                         [-s3.point[1], s3.point[0], 0]])])
    assert np.allclose(stiff.K - model.K, P.T @ np.diag(s3.stiffness) @ P, rtol=0, atol=1e-9 * np.abs(model.K).max())
    assert np.array_equal(stiff.C, model.C)


def test_mass_scale_and_points_stay_on_the_plate(registries, model, thesis_rig):
    mp = registries.effects.get("mass_properties")
    lighter = mp.apply(model, {"mass_scale": 1 / 1.21, "Ixx_scale": 1 / 1.21, "Iyy_scale": 1 / 1.21,
                               "Izz_scale": 1 / 1.21})
    undamped = registries.effects.get("damping")
    f0 = undamped.apply(model, {f"scale_{a}": 0.0 for a in "xyz"})
    f1 = mp.apply(f0, {"mass_scale": 1 / 1.21, "Ixx_scale": 1 / 1.21, "Iyy_scale": 1 / 1.21, "Izz_scale": 1 / 1.21})
    assert np.allclose(f1.modes().frequency_hz / f0.modes().frequency_hz, 1.1, rtol=1e-12)
    assert lighter.M[0, 0] == pytest.approx(2.714 / 1.21, rel=1e-14)
    # a centre-of-mass offset and a heavier body leave the static (0 Hz) response alone: springs,
    # sensors and force points did not move, only the mass did
    moved = mp.apply(model, {"com_dx": 0.004, "com_dy": -0.006, "com_dz": 0.002, "mass_scale": 1.3, "Iyz": 1e-4})
    h0 = model.transfer([T5, T8], sensor_outputs(thesis_rig, "displacement"), [0.0])
    h1 = moved.transfer([T5, T8], sensor_outputs(thesis_rig, "displacement"), [0.0])
    assert np.max(np.abs(h1 - h0)) < 1e-12 * np.abs(h0).max()
    assert np.max(np.abs(frf(moved, thesis_rig) - frf(model, thesis_rig))) > 0.05 * np.abs(frf(model, thesis_rig)).max()
    with pytest.raises(ConfigError, match="positive definite"):
        mp.apply(model, {"Ixx_scale": 0.5, "Iyy_scale": 0.5, "Ixy": 0.0022})


def test_polarity_flip_negates_exactly_its_channel(registries, model, thesis_rig):
    flipped = registries.effects.get("sensor_polarity").apply(model, {"y2_polarity": -1})
    h0, h1 = frf(model, thesis_rig), frf(flipped, thesis_rig)
    names = [s.name for s in thesis_rig.sensors]
    k = names.index("y2")
    assert np.array_equal(h1[:, k], -h0[:, k])
    assert np.array_equal(np.delete(h1, k, axis=1), np.delete(h0, k, axis=1))
    with pytest.raises(ConfigError, match="expected one of"):
        registries.effects.get("sensor_polarity").apply(model, {"y2_polarity": 0.5})


def test_gain_orientation_position_of_one_sensor(registries, model, thesis_rig):
    names = [s.name for s in thesis_rig.sensors]
    k = names.index("zC")
    h0 = frf(model, thesis_rig)
    h = frf(registries.effects.get("sensor_gain").apply(model, {"zC_gain": 1.25}), thesis_rig)
    assert np.allclose(h[:, k], 1.25 * h0[:, k], rtol=1e-14)
    assert np.array_equal(np.delete(h, k, axis=1), np.delete(h0, k, axis=1))
    # a tilted zC axis equals a point output along the tilted direction
    tilted = registries.effects.get("sensor_orientation").apply(model, {"zC_tilt_a": 0.1})
    s = thesis_rig.sensor("zC")
    e1 = np.cross(s.axis, np.eye(3)[np.argmin(np.abs(s.axis))])
    e1 /= np.linalg.norm(e1)
    n = s.axis * np.cos(0.1) + np.cross(e1, s.axis) * np.sin(0.1)  # turned by exactly 0.1 rad about e1
    ref = model.transfer([T5, T8], [Output.at_point(s.position, n)], FREQS)
    assert np.allclose(frf(tilted, thesis_rig)[:, k], ref[:, 0], rtol=1e-12, atol=0)
    moved = registries.effects.get("sensor_position").apply(model, {"zC_dx": 0.01, "zC_dy": -0.005})
    ref = model.transfer([T5, T8], [Output.at_point(s.position + [0.01, -0.005, 0], s.axis)], FREQS)
    assert np.allclose(frf(moved, thesis_rig)[:, k], ref[:, 0], rtol=1e-12, atol=0)


def test_impact_location_and_force_gain(registries, model, thesis_rig):
    moved = registries.effects.get("impact_location").apply(model, {"dx": -0.01, "dy": 0.02})
    ref = frf(model, thesis_rig, [Input.force(T8.point + [-0.01, 0.02, 0], T8.direction)])
    assert np.allclose(frf(moved, thesis_rig, [T8]), ref, rtol=1e-12, atol=0)
    assert registries.effects.get("impact_location").parameters(model)[0].scope == "per_experiment"
    gained = registries.effects.get("force_gain").apply(model, {"gain": 0.8})
    h0 = frf(model, thesis_rig)
    assert np.max(np.abs(frf(gained, thesis_rig) - 0.8 * h0)) < 1e-13 * np.abs(h0).max()


def test_sensor_dynamics_follow_eq_2_2(registries, model, thesis_rig):
    hp, hp1, fn, zeta = 2.0, 0.5, 25e3, 0.03
    dyn = registries.effects.get("sensor_dynamics").apply(
        model, {"highpass_hz": hp, "coupler_highpass_hz": hp1, "resonance_period_s": 1 / fn, "resonance_damping": zeta})
    w = 2 * np.pi * FREQS
    wn, tc, tc1 = 2 * np.pi * fn, 1 / (2 * np.pi * hp), 1 / (2 * np.pi * hp1)
    eq22 = (1 / (1 - (w / wn) ** 2 + 2j * zeta * w / wn)) * (1j * tc1 * w / (1 + 1j * tc1 * w)) * (1j * tc * w / (1 + 1j * tc * w))
    h0 = frf(model, thesis_rig)
    assert np.max(np.abs(frf(dyn, thesis_rig) - eq22[:, None, None] * h0)) < 1e-9 * np.abs(h0).max()


def alpha_pairs(h, rig):
    """Eq. 4.12: each angular acceleration component from two sensor pairs (a, b); rigid: a == b."""
    nine = rig.body("platform").nine_sensor_set
    a = {s.name: h[..., i] for i, s in enumerate(rig.sensors)}
    return np.array([
        [(a["z1"] - a["zC"]) / nine.ry, -(a["y3"] - a["yC"]) / nine.rz],
        [(a["x3"] - a["xC"]) / nine.rz, -(a["z2"] - a["zC"]) / nine.rx],
        [(a["y2"] - a["yC"]) / nine.rx, -(a["x1"] - a["xC"]) / nine.ry]])


@pytest.mark.parametrize("values", [{"twist": 1.0}, {"bend_x": 1.0}, {"bend_y": 1.0}])
def test_flexible_mode_shows_in_frfs_and_breaks_rigidity(registries, model, thesis_rig, values):
    flex = registries.effects.get("plate_flexibility").apply(model, {"frequency_hz": 600.0, "damping_ratio": 0.01, **values})
    assert len(flex.modes()) == 7
    assert any(np.isclose(flex.modes().frequency_hz, 600.0, rtol=1e-12))  # f = |lambda| / 2 pi
    hit = Input.force((0.045, 0.085, -0.0114), (0, 0, 1))  # near a corner of the top face
    f = np.linspace(400, 800, 401)
    outs = sensor_outputs(thesis_rig)
    h_flex = flex.transfer([hit], outs, f)[:, :, 0]
    h_rigid = model.transfer([hit], outs, f)[:, :, 0]
    # the difference peaks at the flexible mode
    diff = np.abs(h_flex - h_rigid).max(axis=1)
    assert abs(f[np.argmax(diff)] - 600.0) <= 1.0
    # rigidity (Eq. 4.12): the rigid model's pairs agree, the flexible one's do not
    p_rigid = alpha_pairs(h_rigid[200], thesis_rig)
    p_flex = alpha_pairs(h_flex[200], thesis_rig)
    scale = np.abs(p_rigid).max()
    assert np.max(np.abs(p_rigid[:, 0] - p_rigid[:, 1])) < 1e-10 * scale
    assert np.max(np.abs(p_flex[:, 0] - p_flex[:, 1])) > 0.5 * scale


def test_free_participation_flexible_mode(registries, model, thesis_rig):
    eff = registries.effects.get("plate_flexibility_free")
    flex = eff.apply(model, {"frequency_hz": 500.0, "damping_ratio": 0.02, "phi_z1": 1.0, "phi_force": 0.8})
    f = [500.0]
    names = [s.name for s in thesis_rig.sensors]
    h0, h1 = model.transfer([T8], sensor_outputs(thesis_rig), f), flex.transfer([T8], sensor_outputs(thesis_rig), f)
    k = names.index("z1")
    w = 2 * np.pi * 500.0
    # the added modal term of acceleration: phi_s phi_F (-w^2) / (wn^2 - w^2 + 2 j zeta wn w)
    added = 1.0 * 0.8 * (-w * w) / (1j * 2 * 0.02 * w * w)
    assert np.isclose(h1[0, k, 0] - h0[0, k, 0], added, rtol=1e-9)
    assert np.allclose(np.delete(h1, k, axis=1), np.delete(h0, k, axis=1), rtol=1e-12, atol=0)


def test_base_motion_adds_the_base_in_series(registries, model, thesis_rig):
    eff = registries.effects.get("base_motion")
    comp = 1e-6
    moved = eff.apply(model, {"compliance": comp, "base_mass": 5.0})
    assert len(moved.bodies) == 2 and len(moved.modes()) == 12
    # static: the platform's motion = its motion relative to the base + the base's motion, and the
    # base carries the same load (a force through the platform reaches the base unchanged)
    base_only = Model.build([RigidBody("base", 5.0, np.eye(3), thesis_rig.body("base").com)],
                            [s for s in moved.springs if s.name.startswith("mount")])
    out_g = Output.coordinates("platform", at=np.zeros(3))
    h_total = moved.transfer([T8], out_g, [0.0])[0, :, 0]
    h_rel = model.transfer([T8], out_g, [0.0])[0, :, 0]
    h_base = base_only.transfer([T8], Output.coordinates("base", at=np.zeros(3)), [0.0])[0, :, 0]
    assert np.allclose(h_total, h_rel + h_base, rtol=1e-9, atol=1e-12 * np.abs(h_total).max())
    assert abs(h_base[2]) > 0.1 * abs(h_rel[2])


def test_values_outside_bounds_and_unknown_names_are_refused(registries, model):
    with pytest.raises(ConfigError, match=r"parameter .scale_x.: expected 0.25 to 4, got 100.0$"):
        registries.effects.get("stiffness").apply(model, {"scale_x": 100.0})
    with pytest.raises(ConfigError, match="unknown parameter"):
        registries.effects.get("stiffness").apply(model, {"scale_q": 1.0})


class AddedMass(Effect):
    """A lab's own effect: a point mass glued to the plate at a fixed place."""

    name = "lab_added_mass"
    description = "A point mass on the platform"

    def parameters(self, model):
        return [Parameter("mass", "kg", 0.0, 0.0, 1.0)]

    def _apply(self, model, v):
        b = model.bodies[0]
        r = np.array([0.03, 0.05, -0.011]) - b.com
        m = b.mass + v["mass"]
        com = b.com + v["mass"] * r / m
        # parallel-axis theorem about the new centre of mass
        d_b, d_p = b.com - com, b.com + r - com
        inertia = (b.inertia + b.mass * (d_b @ d_b * np.eye(3) - np.outer(d_b, d_b))
                   + v["mass"] * (d_p @ d_p * np.eye(3) - np.outer(d_p, d_p)))
        return model.replace(structure=Structure([RigidBody(b.name, m, inertia, com)], model.springs))


class LabPlugin:
    @hookimpl
    def odsuite_register_effects(self, registry):
        registry.add("lab_added_mass", AddedMass())


def test_a_lab_registers_its_own_effect(model, thesis_rig):
    regs = build_registries(make_plugin_manager(extra_plugins=(LabPlugin(),)))
    assert "lab_added_mass" in regs.effects and "stiffness" in regs.effects
    assert regs.effects.entry("lab_added_mass").plugin != "models"
    eff = regs.effects.get("lab_added_mass")
    heavier = eff.apply(model, {"mass": 0.2714})
    assert heavier.M[0, 0] == pytest.approx(1.1 * 2.714)
    assert np.all(heavier.modes().frequency_hz < model.modes().frequency_hz)
    nominal = eff.apply(model, {})
    assert np.allclose(nominal.modes().frequency_hz, model.modes().frequency_hz, rtol=1e-12)


def test_spring_to_unknown_body_refused():
    with pytest.raises(ConfigError, match="unknown body"):
        Model.build([RigidBody("p", 1.0, np.eye(3))], [SpringDamper("s", (0, 0, 0), "p", "q", (1, 1, 1))])


def test_damping_gives_an_undamped_model_a_ratio_per_axis(registries):
    # scaling the damping of springs that have none changed nothing: on such a model the effect
    # sets c = 2 zeta sqrt(k m), m the body's mass over the springs on it
    from pathlib import Path

    from odsuite.domain.rig import load_rig

    rigs = Path(__file__).resolve().parents[2] / "data" / "rigs"
    undamped = registries.models.get("rigid-bodies")(load_rig(rigs / "heavy-press.toml", registries.sensor_types))
    damping = registries.effects.get("damping")
    assert [p.name for p in damping.parameters(undamped)] == ["zeta_x", "zeta_y", "zeta_z"]
    damped = damping.apply(undamped, {"zeta_x": 0.02, "zeta_y": 0.02, "zeta_z": 0.02})
    # 1200 kg on six isolators of 2, 2 and 8 MN/m: 2 x 0.02 x sqrt(k x 200 kg) = 800, 800, 1600 N s/m
    for s in damped.structure.springs:
        assert np.allclose(np.diag(s.matrix("damping")), [800.0, 800.0, 1600.0], rtol=1e-12)
    # a model with damping keeps the scales
    truth = registries.models.get("rigid-bodies")(load_rig(rigs / "heavy-press-damped.toml", registries.sensor_types))
    assert [p.name for p in damping.parameters(truth)][:3] == ["scale_x", "scale_y", "scale_z"]
