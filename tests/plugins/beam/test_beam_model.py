"""The beam model family against closed-form beam theory, and its effects."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from odsuite_plugins.beam.fe import BeamSpec, BeamStructure, PointMass, Support
from odsuite_plugins.beam.model import beam_model

from odsuite.domain.errors import ConfigError
from odsuite.domain.model import Input, Model, Output
from odsuite.domain.rig import load_rig

RIG = Path(__file__).resolve().parents[3] / "projects" / "rigs" / "ladisk-beam.toml"
L, MU, EI = 0.5, 2.0, 100.0  # m, kg/m, N m^2
# roots of cosh(bL) cos(bL) = 1 (free-free) and = -1 (clamped-free), Blevins Table 8-1
FREE_FREE = np.array([4.730040745, 7.853204624, 10.99560784, 14.13716549])
CLAMPED_FREE = np.array([1.875104069, 4.694091133, 7.854757438])


def spec(**kw) -> BeamSpec:
    return BeamSpec("beam", np.zeros(3), L, MU, EI, **kw)


def test_euler_bernoulli_ends_match_closed_form():
    scale = np.sqrt(EI / MU) / (2 * np.pi * L**2)
    free = BeamStructure(spec()).bending_frequencies_hz()[:4]
    assert np.allclose(free, FREE_FREE**2 * scale, rtol=2e-5)
    cantilever = BeamStructure(spec(ends=("clamped", "free"))).bending_frequencies_hz()[:3]
    assert np.allclose(cantilever, CLAMPED_FREE**2 * scale, rtol=2e-5)
    pinned = BeamStructure(spec(ends=("pinned", "pinned"))).bending_frequencies_hz()[:3]
    assert np.allclose(pinned, (np.pi * np.arange(1, 4)) ** 2 * scale, rtol=2e-5)


def test_timoshenko_pinned_beam_matches_its_frequency_equation():
    """Pinned-pinned Timoshenko beam: EI k^4 - mu w^2 (1 + k^2 r^2 (1 + E/kG)) + mu r^2 (E/kG) mu w^4 / EI ... in
    the exact form mu r^2 mu/(kGA) w^4 - (mu + (mu r^2 + EI mu/(kGA)) k^2) w^2 + EI k^4 = 0, k = n pi / L."""
    g2, flex = 4e-4, 2 * 1.3 / (5 / 6)
    st = BeamStructure(spec(ends=("pinned", "pinned"), theory="timoshenko", gyration_ratio_sq=g2,
                            shear_flexibility=flex, elements=80))
    r2 = g2 * L**2
    kga = EI / (r2 * flex)
    expected = []
    for n in range(1, 4):
        k = n * np.pi / L
        a, b, c = MU * r2 * MU / kga, -(MU + (MU * r2 + EI * MU / kga) * k**2), EI * k**4
        expected.append(np.sqrt((-b - np.sqrt(b * b - 4 * a * c)) / (2 * a)) / (2 * np.pi))
    # the element converges as h^2 (80 elements: 5.5e-5 on the third mode, 160: 1.4e-5)
    assert np.allclose(st.bending_frequencies_hz()[:3], expected, rtol=1e-4)
    # and it lies below Euler-Bernoulli, more so for higher modes
    eb = BeamStructure(spec(ends=("pinned", "pinned"))).bending_frequencies_hz()[:3]
    drop = 1 - np.array(expected) / eb
    assert np.all(np.diff(drop) > 0) and drop[0] > 0


def exact_receptance(xs: float, xh: float, f: float) -> float:
    """Deflection at ``xs`` per unit harmonic force at ``xh`` of an undamped free-free
    Euler-Bernoulli beam, solved exactly: w = A cosh bx + B sinh bx + C cos bx + D sin bx on each
    side of the force; free ends (no moment, no shear); deflection, slope and moment continuous at
    ``xh``, where EI times the third derivative jumps by the force."""
    b = (MU * (2 * np.pi * f) ** 2 / EI) ** 0.25

    def basis(x: float, d: int) -> np.ndarray:  # d-th derivative of [cosh, sinh, cos, sin](b x)
        ch, sh, c, s = np.cosh(b * x), np.sinh(b * x), np.cos(b * x), np.sin(b * x)
        return b**d * np.array([[ch, sh, c, s], [sh, ch, -s, c], [ch, sh, -c, -s], [sh, ch, s, -c]][d])

    A, rhs, z = np.zeros((8, 8)), np.zeros(8), np.zeros(4)
    A[0] = np.r_[basis(0.0, 2), z]
    A[1] = np.r_[basis(0.0, 3), z]
    A[2] = np.r_[z, basis(L, 2)]
    A[3] = np.r_[z, basis(L, 3)]
    for k, d in enumerate((0, 1, 2)):
        A[4 + k] = np.r_[basis(xh, d), -basis(xh, d)]
    A[7] = np.r_[-basis(xh, 3), basis(xh, 3)]
    rhs[7] = 1.0 / EI
    coef = np.linalg.solve(A, rhs)
    return float(basis(xs, 0) @ (coef[:4] if xs <= xh else coef[4:]))


def test_accelerance_between_two_points_is_the_exact_beam_solution():
    """The model's transfer from a force at 0.42 m to an accelerometer at 0.03 m (through the core
    Model, Input and Output) against the exact solution of the undamped beam equation."""
    model = Model(BeamStructure(spec(damping_ratio=(0.0,), support_damping_ratio=0.0, elements=60)), name="beam")
    xs, xh = 0.03, 0.42
    f = np.array([150.0, 420.0, 700.0, 1100.0])  # between the bending modes (101, 277, 544, 900, 1344 Hz)
    H = model.transfer([Input.force([xh, 0, 0], [0, 0, 1])], [Output.at_point([xs, 0, 0], [0, 0, 1])], f)[:, 0, 0]
    ref = np.array([-((2 * np.pi * fk) ** 2) * exact_receptance(xs, xh, fk) for fk in f])
    assert np.allclose(H.imag, 0.0, atol=1e-9 * np.abs(H).max())
    # the discretisation error grows with frequency: 1e-5 below 700 Hz, 1.3e-4 at 1.1 kHz with 60 elements
    assert np.allclose(H.real, ref, rtol=2e-4)


def test_supports_and_point_masses_move_modes_the_right_way():
    bare = BeamStructure(spec())
    loaded = BeamStructure(spec(masses=(PointMass("acc", 0.0, 0.005),)))
    held = BeamStructure(spec(supports=(Support("a", 0.112, 5e3), Support("b", 0.388, 5e3))))
    assert np.all(loaded.bending_frequencies_hz()[:3] < bare.bending_frequencies_hz()[:3])
    # a small mass at the end of a free beam lowers f by m/(mu L) x phi(0)^2/2 = 0.5 % x 4/2 (Rayleigh,
    # first order in the mass ratio)
    assert 1 - loaded.bending_frequencies_hz()[0] / bare.bending_frequencies_hz()[0] == pytest.approx(0.01, rel=0.03)
    # two soft springs 0.138 m from the centre: pitch sqrt(2 k d^2 / (m L^2 / 12)) and bounce sqrt(2 k / m)
    # as a rigid beam; the bending modes nearly untouched
    rigid = np.sqrt([2 * 5e3 * 0.138**2 / (MU * L**3 / 12), 2 * 5e3 / (MU * L)]) / (2 * np.pi)
    assert np.allclose(held.normal_modes[0][:2] / (2 * np.pi), rigid, rtol=0.01)
    assert np.allclose(held.bending_frequencies_hz()[:3], bare.bending_frequencies_hz()[:3], rtol=2e-3)


def test_modal_damping_gives_each_mode_its_ratio():
    st = BeamStructure(spec(damping_ratio=(0.004, 0.003, 0.002), supports=(Support("a", 0.1, 1e3), Support("b", 0.4, 1e3))))
    modes = Model(st).modes()
    assert np.allclose(modes.damping_ratio[2:6], [0.004, 0.003, 0.002, 0.002], rtol=1e-6)
    assert np.allclose(modes.damping_ratio[:2], 0.1, rtol=1e-6)


def test_bad_beams_are_refused_in_one_line():
    with pytest.raises(ConfigError, match="field 'ends'"):
        spec(ends=("free", "glued"))
    with pytest.raises(ConfigError, match="point mass 'acc' field 'position'.*not on the beam"):
        spec(masses=(PointMass("acc", 0.7, 0.01),))
    with pytest.raises(ConfigError, match="not on the beam"):
        BeamStructure(spec()).point_rows("beam", np.array([0.6, 0.0, 0.0]))


def test_rig_file_model_has_its_first_mode_and_the_effects_apply(registries):
    rig = load_rig(RIG, registries.sensor_types)
    model = beam_model(rig)
    bending = model.structure.bending_frequencies_hz()
    # the bare beam's first mode is the rig's first_mode_hz; the soft foam under the ends raises it
    bare = model.structure.with_spec(supports=())
    assert bare.bending_frequencies_hz()[0] == pytest.approx(695.0, rel=1e-9)
    assert 0 < bending[0] / 695.0 - 1 < 2e-3
    fx = registries.effects
    timo = fx.get("beam-shear-rotary").apply(model, {"gyration_ratio_sq": 1e-4})
    ratio = timo.structure.bending_frequencies_hz()[:3] / bending[:3]
    assert np.all(np.diff(ratio) < 0) and ratio[0] < 1
    heavy = fx.get("beam-sensor-mass").apply(model, {"mass": 0.02})
    assert heavy.structure.bending_frequencies_hz()[0] < bending[0]
    moved = fx.get("beam-positions").apply(model, {"acc_shift": 0.05, "hammer_shift": -0.02})
    _, rows = moved.output_rows([Output.sensor(rig.sensor("acc"))])
    assert np.allclose(rows[0], model.structure.point_rows("beam", np.array([0.06, 0, 0]))[2])
    stiffer = fx.get("beam-stiffness-scale").apply(model, {"scale": 1.21}).structure.with_spec(supports=())
    assert stiffer.bending_frequencies_hz()[0] == pytest.approx(1.1 * 695.0, rel=1e-9)
    # the beam's effects do not apply to a rigid-body rig
    thesis = registries.models.get("rigid-bodies")(registries.rigs.get("thesis-dynamometer"))
    assert all(fx.get(n).parameters(thesis) == [] for n in fx.names() if n.startswith("beam-"))


def test_a_rig_without_a_beam_table_is_refused(registries):
    with pytest.raises(ConfigError, match=r"\[beam\] table"):
        beam_model(registries.rigs.get("thesis-dynamometer"))
    rig = load_rig(RIG, registries.sensor_types)
    bad = replace(rig, extra={"beam": {**rig.extra["beam"], "ends": ["free", "welded"]}})
    with pytest.raises(ConfigError, match="field 'ends'.*welded"):
        beam_model(bad)


def test_every_beam_effect_at_nominal_leaves_the_prediction_unchanged(registries):
    rig = load_rig(RIG, registries.sensor_types)
    model = beam_model(rig)
    inputs, outputs = [Input.force([0.2, 0, 0], [0, 0, 1], body="beam")], [Output.sensor(rig.sensor("acc"))]
    f = np.array([300.0, 695.0, 1900.0, 3700.0])
    ref = model.transfer(inputs, outputs, f)
    names = [n for n in registries.effects.names() if registries.effects.entry(n).plugin == "beam"]
    assert len(names) == 8
    for name in names:
        effect = registries.effects.get(name)
        params = effect.parameters(model)
        assert params and all(p.lower <= p.nominal <= p.upper for p in params), name
        changed = effect.apply(model, {})
        assert changed.effects == (name,)
        assert np.allclose(changed.transfer(inputs, outputs, f), ref, rtol=1e-9, atol=0), name
