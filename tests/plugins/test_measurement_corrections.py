"""Measurement effects undo themselves: the model's own chain applies each effect to the signals
of a known rigid motion, the effect's ``correct`` (through the correction's ``undo_measurement``)
must give back what an ideal chain records, within round-off."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from odsuite.analysis.correction import MeasurementCorrection, measurement_corrections, undo_measurement
from odsuite.analysis.modelrev import base_model
from odsuite.analysis.prediction import _analog_chain
from odsuite.contracts.effects import corrects
from odsuite.contracts.plugins import registries
from odsuite.domain.model import Output

FS = 20_000.0
N = 2048


def _motion(n_dof: int) -> np.ndarray:
    """A rigid motion from rest: Gaussian-windowed sinusoids (70-900 Hz, 6 ms wide) per
    coordinate, zero to round-off at both ends, so a phase shift of the record is exact."""
    t = np.arange(N) / FS
    rng = np.random.default_rng(5)
    q = np.zeros((N, n_dof))
    for k in range(n_dof):
        for f in rng.uniform(70, 900, 3):
            q[:, k] += rng.normal() * np.sin(2 * np.pi * f * t) * np.exp(-(((t - 0.05) / 0.006) ** 2))
    return q


@pytest.fixture(scope="module")
def thesis():
    rig = registries().rigs.get("thesis-dynamometer")
    model = base_model(rig, registries=registries())
    q = _motion(model.structure.n_dof)
    return rig, model, q


def _recorded(model, rig, q) -> np.ndarray:
    """The model's signals at the accelerometers for coordinates ``q``: rows (position, tilt, gain,
    swap), then the chain's dynamics and sampling delays, as a prediction runs them."""
    sensors = rig.accelerometers
    rows = model.output_rows([Output.sensor(s) for s in sensors])[1]
    return _analog_chain(model, SimpleNamespace(sensors=sensors, fs=FS), q @ rows.T)


CASES = {
    "sensor_gain": {"zC_gain": 1.3, "y2_gain": 0.8},
    "sensor_polarity": {"x1_polarity": -1.0},
    "sensor_orientation": {"y3_tilt_a": 0.35, "y3_tilt_b": -0.2},  # 23 degrees
    "sensor_position": {"z1_dx": 0.012, "z1_dy": -0.006},
    "channel_delay": {"x3_delay": 37e-6, "zC_delay": -12e-6},
    "scan_skew": {"skew_s": 8e-6},
    "sensor_dynamics": {"highpass_hz": 3.0, "coupler_highpass_hz": 0.5, "resonance_period_s": 1 / 12_000.0,
                        "resonance_damping": 0.03},
    "channel_swap": {"pair": 7.0, "ratio": 1.04},
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_apply_then_correct_is_the_identity(thesis, name):
    rig, model, q = thesis
    effect = registries().effects.get(name)
    assert corrects(effect)
    truth = _recorded(model, rig, q)
    distorted = _recorded(effect.apply(model, CASES[name]), rig, q)
    assert np.max(np.abs(distorted - truth)) > 1e-3 * np.max(np.abs(truth))  # the effect does distort
    corr = MeasurementCorrection(name, effect, CASES[name], {}, model)
    undone = undo_measurement(rig, [s.name for s in rig.accelerometers], distorted, FS, [corr],
                              registries().coordinate_solvers)
    # sensor dynamics: the high-passes' inverse recursion and the resonance's spectral division
    # lose a few digits more than a gain
    tol = 1e-7 if name == "sensor_dynamics" else 1e-10
    assert np.max(np.abs(undone - truth)) < tol * np.max(np.abs(truth))


def test_two_at_once_are_undone_from_the_converter_back(thesis):
    """A swap, a gain on one of the swapped sensors and a delay on one of their channels: undone
    in stage order (channel, wiring, sensor) whatever order they were added in."""
    rig, model, q = thesis
    regs = registries()
    pairs = regs.effects.get("channel_swap").pairs(rig.accelerometers)
    k = pairs.index(("yC", "z2")) + 1
    entries = [{"effect": "sensor_gain", "values": {"z2_gain": 1.2}},
               {"effect": "channel_swap", "values": {"pair": float(k)}},
               {"effect": "channel_delay", "values": {"yC_delay": 30e-6}},
               {"effect": "stiffness", "values": {"scale_z": 1.3}}]
    distorted_model = model
    for e in entries:
        distorted_model = regs.effects.get(e["effect"]).apply(distorted_model, e["values"])
    truth = _recorded(model, rig, q)
    distorted = _recorded(distorted_model, rig, q)
    corrections = measurement_corrections({"effects": entries}, "T1", regs.effects, model)
    assert [c.entry for c in corrections] == ["channel_delay", "channel_swap", "sensor_gain"]
    undone = undo_measurement(rig, [s.name for s in rig.accelerometers], distorted, FS, corrections,
                              regs.coordinate_solvers)
    assert np.max(np.abs(undone - truth)) < 1e-10 * np.max(np.abs(truth))


def test_swap_exchanges_the_two_rows_only(thesis):
    rig, model, _ = thesis
    effect = registries().effects.get("channel_swap")
    sensors = rig.accelerometers
    pairs = effect.pairs(sensors)
    assert len(pairs) == len(sensors) * (len(sensors) - 1) // 2  # nine accelerometers of one kind
    p, ratio = effect.parameters(model)
    assert (p.name, ratio.name, ratio.nominal) == ("pair", "ratio", 1.0)
    assert p.choices == tuple(float(i) for i in range(len(pairs) + 1))
    rows = model.output_rows([Output.sensor(s) for s in sensors])[1]
    a, b = pairs[11]
    swapped = effect.apply(model, {"pair": 12.0}).output_rows([Output.sensor(s) for s in sensors])[1]
    ia, ib = [s.name for s in sensors].index(a), [s.name for s in sensors].index(b)
    order = list(range(len(sensors)))
    order[ia], order[ib] = ib, ia
    np.testing.assert_array_equal(swapped, rows[order])
    assert not np.array_equal(rows[ia], rows[ib])
    # sensitivities differing by 4 %: channel a reads sensor b 1.04 times too large, b reads a 1.04 times too small
    scaled = effect.apply(model, {"pair": 12.0, "ratio": 1.04}).output_rows([Output.sensor(s) for s in sensors])[1]
    np.testing.assert_allclose(scaled[ia], 1.04 * rows[ib], rtol=1e-14)
    np.testing.assert_allclose(scaled[ib], rows[ia] / 1.04, rtol=1e-14)


def test_structure_effects_correct_nothing():
    regs = registries()
    for name in ("stiffness", "damping", "mass_properties", "missing_mode", "plate_flexibility",
                 "force_gain", "impact_location"):
        assert not corrects(regs.effects.get(name)), name
