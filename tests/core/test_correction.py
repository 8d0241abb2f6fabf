"""Model-based correction against the simulator's truth.

The reference motion is the truth model's own generalized coordinates (``Output.coordinates``),
driven by the simulator's true force at its internal rate, seen through the same 1 kHz
anti-aliasing filter the sensors and the load cell are read through, sampled like the record and
aligned to it by the force channel. It shares no code with the sensor-level path being tested
(neither the solver nor the chain).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.signal
from odsuite_plugins.daq_sim.chain import ChannelChain, run_analog
from odsuite_plugins.daq_sim.hammer import Hit
from odsuite_plugins.daq_sim.simulator import SimulatedRig, default_chains
from odsuite_plugins.daq_sim.truth import truth_model

from odsuite.processing.acquisition import acquire
from odsuite.analysis.correction import (
    KIND,
    correct_experiment,
    corrected_chain_spec,
    default_cutoff,
    drift_estimate,
    process_corrected,
)
from odsuite.contracts.daq import AcquisitionSettings, rig_systeminfo
from odsuite.domain.errors import ConfigError
from odsuite.domain.model import Input, Output
from odsuite.processing.pipeline import process_experiment
from odsuite.store.project import create_project, open_project
from odsuite.domain.simulation import simulate

FS = 20_000.0
OVERSAMPLE = 8
DRIFT_V_PER_S = 5e-3  # five times the default chain's amplifier drift


def _record(path, scenario: str, peak: float, *, noise: bool = True, drift: float = DRIFT_V_PER_S,
            adc_bits: int = 12, seed: int = 3):
    """A project with one weak simulated hit, its chains and the true coordinates of the platform."""
    from odsuite.contracts.plugins import registries

    rig = registries().rigs.get("thesis-dynamometer")
    body = rig.bodies[0]
    model = truth_model(rig)
    sensor_outputs = [Output.sensor(s) for s in rig.sensors]
    captured = {}

    def truth(force, fs, point, direction):
        y = simulate(model, [Input.force(point, direction)], force, fs,
                     sensor_outputs + list(Output.coordinates(body)), hold="foh")
        captured.update(force=force, coords=y[:, len(sensor_outputs):])
        return y[:, :len(sensor_outputs)]

    chains = {k: replace(c, drift=drift if c.drift and noise else 0.0, adc_bits=adc_bits)
              for k, c in default_chains(rig, rig_systeminfo(rig, FS), noise=noise).items()}
    project = create_project(path)
    exp, rec = acquire(project, SimulatedRig(), "hit", AcquisitionSettings(n_samples=8192), scenario=scenario,
                       seed=seed, hits=[Hit(0.0, peak, 0.5e-3)], truth=truth, chains=chains,
                       oversample=OVERSAMPLE, noise=noise)
    assert rec.clipped == {}
    # the anti-aliasing filter alone (unit gain), as every channel has it
    aaf = ChannelChain(sensitivity=1.0, gain=1.0, sensor_tc=None, coupler_tc=None, resonance_hz=None)
    fine = FS * OVERSAMPLE
    force_ref = run_analog(chains[rig.force_channel], captured["force"], fine)[::OVERSAMPLE]
    raw = exp.raw()
    n = raw.shape[0]
    recorded = raw[:, rig.force_channel] - raw[:100, rig.force_channel].mean()
    lag = int(np.argmax(scipy.signal.correlate(force_ref, recorded, mode="valid")))
    true = np.column_stack([run_analog(aaf, captured["coords"][:, i], fine)[::OVERSAMPLE][lag:lag + n]
                            for i in range(6)])
    return project, chains, true


def _rms(a, b, cols):
    return float(np.sqrt(np.mean((a[:, cols] - b[:, cols]) ** 2)))


TRANSLATIONS, ROTATIONS = (0, 1, 2), (3, 4, 5)


@pytest.fixture(scope="module")
def weak_t3(tmp_path_factory):
    """Test 3's point (pitch and z), a 3 N blow instead of 20 N, drift 5 mV/s, 12-bit ADC."""
    project, chains, true = _record(tmp_path_factory.mktemp("corr") / "p.h5", "T3", 3.0)
    process_experiment(project, "hit")
    summary = process_corrected(project)
    yield project, chains, true, summary
    project.close()


def test_corrected_coordinates_halve_the_high_pass_error(weak_t3):
    project, _, true, _ = weak_t3
    signal_based = project.read_derived("hit", "gencoords")["platform_at_g"]
    corrected = project.read_derived("hit", KIND)["platform_at_g"]
    for cols in (TRANSLATIONS, ROTATIONS):
        e_hp, e_corr = _rms(signal_based, true, cols), _rms(corrected, true, cols)
        print(f"columns {cols}: high-pass RMS error {e_hp:.3e}, corrected {e_corr:.3e}, "
              f"ratio {e_corr / e_hp:.3f}, true RMS {np.sqrt(np.mean(true[:, cols] ** 2)):.3e}")
        assert e_corr <= 0.5 * e_hp, (cols, e_hp, e_corr)
    # and the corrected motion is the true motion, not merely less wrong: z and pitch dominate
    for i in (2, 4):
        err = np.sqrt(np.mean((corrected[:, i] - true[:, i]) ** 2) / np.mean(true[:, i] ** 2))
        print(f"coordinate {i}: corrected NRMSE {err:.3f}")
        assert err < 0.3, (i, err)


def test_drift_rate_is_the_amplifiers(weak_t3):
    """The cubic's acceleration slope is the simulated 5 mV/s at the ADC over sensitivity x gain,
    with the channel's software inversion, on every channel whose noise dithers its ADC (x and y:
    +-0.5 V, 0.24 mV codes). On the z channels (+-5 V, 2.4 mV codes, 0.3 mV noise) the 2 mV of
    drift over the record is one code step: what is removed there is that step, not a ramp."""
    project, chains, _, summary = weak_t3
    si = project.experiment("hit").systeminfo
    rig = project.rig
    checked = 0
    for name, (_, rate) in summary["hit"]["drift"].items():
        ch = rig.sensor(name).channel
        if chains[ch].lsb > 2 * chains[ch].noise_rms:
            continue
        info = si.channels[ch]
        expected = chains[ch].drift / (info.sensitivity * info.daq_gain) * (-1 if info.invert else 1)
        assert rate == pytest.approx(expected, rel=0.03), (name, rate, expected)
        checked += 1
    assert checked == 6


def test_stored_with_provenance(weak_t3):
    project, _, _, summary = weak_t3
    info = project.derived_info("hit", KIND)
    params = info["provenance"]["parameters"]
    assert params["revision"] == 0 == summary["hit"]["revision"]
    model = truth_model(project.rig)
    lowest = min(model.modes().frequency_hz)
    assert params["cutoff_hz"] == pytest.approx(lowest / 2) == default_cutoff(model)
    assert info["units"]["platform_at_g"] == "m m m rad rad rad"
    assert info["dims"]["drift"] == ("sample", "channel")
    data = project.read_derived("hit", KIND)
    assert data["platform_at_c"].shape == data["platform_at_g"].shape == (8192, 6)
    assert data["drift"].shape == (8192, 9)


def test_noise_free_record_matches_the_truth(tmp_path):
    """Without noise and drift, on a 16-bit ADC, the corrected coordinates are the true ones
    within what the sensors' ICP high-passes and the sampling leave."""
    project, _, true = _record(tmp_path / "p.h5", "T1", 20.0, noise=False, adc_bits=16)
    with project:
        corr = correct_experiment(project, "hit")
    at_g = corr.coordinates["platform"].at_g
    for cols in (TRANSLATIONS, ROTATIONS):
        err = np.sqrt(np.sum((at_g[:, cols] - true[:, cols]) ** 2) / np.sum(true[:, cols] ** 2))
        print(f"noise-free columns {cols}: NRMSE {err:.4f}")
        assert err < 0.01, (cols, err)


def test_drift_estimate_takes_the_cubic_and_the_slow_part_only():
    """A cubic, a 5 Hz sine and a Hann-windowed 200 Hz burst (nothing below 50 Hz) with a 50 Hz
    cutoff: the estimate is the cubic and the 5 Hz sine, the burst is left within 1 %."""
    fs, n = 20_000.0, 8192
    t = np.arange(n) / fs
    cubic = 1e-3 + 2e-3 * t - 0.05 * t**2 + 0.3 * t**3
    slow = 1e-4 * np.sin(2 * np.pi * 5 * t)
    window = np.zeros(n)
    window[1000:3000] = scipy.signal.windows.hann(2000)
    fast = 1e-4 * window * np.sin(2 * np.pi * 200 * t)
    est, _ = drift_estimate(np.column_stack([cubic + slow + fast]), fs, 50.0)
    rest = (cubic + slow + fast) - est[:, 0]
    assert np.sqrt(np.mean((rest - fast) ** 2)) < 0.01 * np.sqrt(np.mean(fast**2))


def test_bad_cutoff_and_single_integration(weak_t3):
    project = weak_t3[0]
    with pytest.raises(ConfigError, match=r"experiment 'hit'.*cutoff.*10000.*12000"):
        correct_experiment(project, "hit", cutoff_hz=12_000.0)
    ch = replace(project.experiment("hit").systeminfo.channels[2], integration=0)
    with pytest.raises(ConfigError, match=r"channel 2.*integration.*NONE"):
        corrected_chain_spec(ch, where="channel 2")


def test_cli_process_corrected(tmp_path, capsys):
    from odsuite.cli import main

    path = tmp_path / "p.h5"
    with create_project(path) as project:
        acquire(project, SimulatedRig(), "T1", AcquisitionSettings(n_samples=4096), scenario="T1", seed=1)
    assert main(["process", str(path), "--corrected", "--cutoff", "40"]) == 0
    out = capsys.readouterr().out
    assert "T1: gencoords_corrected (model revision 0, cutoff 40.0 Hz; measurement corrections: none)" in out
    with open_project(path) as project:
        info = project.derived_info("T1", KIND)
        assert info["provenance"]["parameters"]["cutoff_hz"] == 40.0
        assert {"gencoords", KIND} <= set(project.derived_kinds("T1"))
    assert main(["process", str(path), "--corrected", "--cutoff", "-1"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cutoff" in err[0] and "-1" in err[0], err


def test_a_structure_only_revision_corrects_nothing(weak_t3):
    """Stiffness and mass change the model, not the records: nothing is undone, and measurement
    effects at their nominal values (undone, but identities) leave every coordinate as the
    drift correction alone gives it."""
    project = weak_t3[0]
    structure = [{"effect": "stiffness", "values": {"scale_z": 1.2}},
                 {"effect": "mass_properties", "values": {"mass_scale": 1.05}}]
    drift_only = correct_experiment(project, "hit", revision={"revision": 1, "effects": structure})
    assert drift_only.corrections == []
    nominal = structure + [{"effect": "sensor_gain", "values": {}}, {"effect": "channel_swap", "values": {"pair": 0.0}},
                           {"effect": "channel_delay", "values": {}}]
    undone = correct_experiment(project, "hit", revision={"revision": 2, "effects": nominal})
    assert [c["effect"] for c in undone.corrections] == ["channel_delay", "channel_swap", "sensor_gain"]
    a, b = undone.coordinates["platform"].at_g, drift_only.coordinates["platform"].at_g
    assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(b))
    # and the structure changed the drift model: not the revision-0 coordinates
    assert np.max(np.abs(b - project.read_derived("hit", KIND)["platform_at_g"])) > 1e-3 * np.max(np.abs(b))


def test_a_diagnosed_gain_is_undone(weak_t3):
    """A revision holding a gain error on zC corrects the record by it: the corrected
    coordinates move as a zC signal over 1.25 would move them, which is not the drift-only result."""
    project = weak_t3[0]
    base = correct_experiment(project, "hit", revision={"revision": 0, "effects": []})
    gain = correct_experiment(project, "hit", revision={"revision": 1, "effects": [
        {"effect": "sensor_gain", "values": {"zC_gain": 1.25}, "uncertainties": {"zC_gain": 0.01}}]})
    assert gain.corrections == [{"effect": "sensor_gain", "stage": "sensor", "values": {"zC_gain": 1.25},
                                 "uncertainties": {"zC_gain": 0.01}}]
    j = base.sensors.index("zC")
    # the undone zC displacement is the recorded one over 1.25, both before the drift is removed
    recorded = base.displacement[:, j] + base.drift[:, j]
    undone = gain.displacement[:, j] + gain.drift[:, j]
    np.testing.assert_allclose(undone, recorded / 1.25, rtol=1e-9, atol=1e-9 * np.max(np.abs(recorded)))
    sd = gain.uncertainty["platform"]["sensor_gain"]
    assert len(sd) == 6 and max(sd) > 0
