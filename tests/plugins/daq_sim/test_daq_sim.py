"""The simulated rig: trigger, pre-trigger, ADC, analog chain, seeds, scenarios, storage."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest
from odsuite_plugins.daq_sim.chain import ChannelChain, run_analog
from odsuite_plugins.daq_sim.hammer import Hit, half_sine_force, impulse
from odsuite_plugins.daq_sim.scenarios import SCENARIOS
from odsuite_plugins.daq_sim.simulator import (
    SimulatedRig,
    adc_range,
    default_chains,
    find_trigger,
)
from scipy import signal

from odsuite.processing.acquisition import acquire
from odsuite.contracts.daq import AcquisitionSettings, rig_systeminfo
from odsuite.domain.errors import ConfigError, HardwareError

FORCE = 0


def free_mass_truth(mass: float):
    """Closed form: the rig as one free point mass, every sensor sees F/m along its axis."""

    def factory(rig, effects):
        axes = np.array([s.axis for s in rig.sensors])

        def truth(force, fs, point, direction):
            return np.outer(force / mass, axes @ direction)

        return truth

    return factory


def thesis_chains(rig):
    return default_chains(rig, rig_systeminfo(rig, 20_000.0))


@pytest.fixture
def sim():
    return SimulatedRig(free_mass_truth(2.714))


def record(sim, rig, settings=None, **kw):
    rec = sim.record(rig, settings or AcquisitionSettings(), **kw)
    return rec, np.concatenate(list(rec.chunks))


def volts_per_newton(rec):
    ch = rec.systeminfo.channels[FORCE]
    return ch.sensitivity * ch.daq_gain


@pytest.mark.parametrize("slope", ["rising", "falling"])
@pytest.mark.parametrize("pretrigger", [0, 1, 300, 1023])
def test_trigger_sample_sits_after_exactly_pretrigger_samples(sim, thesis_rig, slope, pretrigger):
    hits = [Hit(0.0, 20.0, 0.5e-3)]
    s = AcquisitionSettings(n_samples=2048, pretrigger=pretrigger, trigger_level=5.0, trigger_slope=slope,
                            chunk_size=300)
    rec, raw = record(sim, thesis_rig, s, scenario="T1", hits=hits, seed=3)
    assert raw.shape == (2048, thesis_rig.channel_count)
    assert rec.pretrigger == pretrigger and rec.n_samples == 2048
    level = 5.0 * volts_per_newton(rec)
    f = raw[:, FORCE]
    if pretrigger == 0:
        assert f[0] >= level if slope == "rising" else f[0] <= level
        return
    if slope == "rising":
        assert f[pretrigger - 1] < level <= f[pretrigger]
        assert np.all(f[:pretrigger] < level)  # the first crossing: nothing above it before
    else:  # falling: the hammer's trailing edge, so the pulse is in the pre-trigger part
        assert f[pretrigger - 1] > level >= f[pretrigger]


def test_find_trigger_on_hand_made_signal():
    x = np.array([0.0, 0.5, 1.0, 0.2, 0.9, 1.5, 0.1])
    assert find_trigger(x, 1.0, "rising", 0) == 2
    assert find_trigger(x, 1.0, "rising", 3) == 5  # crossings before the buffer is full don't count
    assert find_trigger(x, 0.5, "falling", 1) == 3
    assert find_trigger(x, 2.0, "rising", 0) is None


def test_trigger_timeout_names_channel_and_peak(sim, thesis_rig):
    s = AcquisitionSettings(trigger_level=500.0)
    with pytest.raises(HardwareError, match=r"trigger timeout: force channel 0 never crossed 500 N \(rising\); the hammer peaked near \d+"):
        sim.record(thesis_rig, s, scenario="T1", seed=0)


def test_adc_quantisation_and_clipping_by_hand():
    c = ChannelChain(sensitivity=1.0, adc_bits=3, limit_low=-1.0, limit_high=1.0)
    assert c.lsb == 0.25
    v = np.array([-2.0, -1.0, -0.13, 0.13, 0.62, 0.9, 2.0])
    # codes k = round((v + 1) / 0.25) clipped to 0..7; value = -1 + 0.25 k
    np.testing.assert_array_equal(c.quantise(v), [-1.0, -1.0, -0.25, 0.25, 0.5, 0.75, 0.75])
    assert c.clipped(v) == 3  # -2.0, 0.9 (beyond 0.75 + half a code) and 2.0


def test_recorded_values_are_adc_codes_and_clip_at_limits(sim, thesis_rig):
    # channel 4 (zC) with a +-0.05 V range: T1's z response overflows it
    chains = {4: replace(thesis_chains(thesis_rig)[4], limit_low=-0.05, limit_high=0.05)}
    rec, raw = record(sim, thesis_rig, scenario="T1", seed=1, chains=chains)
    for ch, chain in thesis_chains(thesis_rig).items():
        lo = -0.05 if ch == 4 else chain.limit_low
        lsb = -2 * lo / 2**12
        k = (raw[:, ch] - lo) / lsb
        np.testing.assert_allclose(k, np.round(k), atol=1e-6)
        assert k.min() >= -1e-6 and k.max() <= 4095 + 1e-6
    z = raw[:, 4]
    top = 0.05 - 0.1 / 4096
    assert z.min() == pytest.approx(-0.05, abs=1e-12) and z.max() == pytest.approx(top, abs=1e-12)
    assert rec.clipped[4] == np.count_nonzero(np.isclose(z, -0.05, rtol=0, atol=1e-12) | np.isclose(z, top, rtol=0, atol=1e-12))
    assert set(rec.clipped) == {4}  # the other channels of T1 stay in range


def test_adc_range_is_the_smallest_e_series_range_holding_the_limits(thesis_rig):
    assert adc_range(-2.0, 3.0) == 5.0  # Table E.3 channel 1
    assert adc_range(-0.5, 5.0) == 5.0  # Table E.3 channel 6
    assert adc_range(-0.5, 0.5) == 0.5
    assert adc_range(-0.3, 0.2) == 0.5
    assert adc_range(-50.0, 50.0) == 10.0
    ranges = {ch: c.limit_high for ch, c in thesis_chains(thesis_rig).items()}
    assert ranges == {0: 5, 1: 5, 2: 0.5, 3: 0.5, 4: 5, 5: 0.5, 6: 5, 7: 0.5, 8: 5, 9: 0.5, 10: 0.5}


def test_one_seed_one_record_two_seeds_differ(sim, thesis_rig):
    _, a = record(sim, thesis_rig, scenario="T8", seed=42)
    _, b = record(sim, thesis_rig, scenario="T8", seed=42)
    _, c = record(sim, thesis_rig, scenario="T8", seed=43)
    np.testing.assert_array_equal(a, b)
    assert np.mean(a != c) > 0.5


def test_analog_chain_matches_eq_2_2_times_butterworth():
    c = ChannelChain(sensitivity=0.020292, sign=-1.0, gain=10.0, sensor_tc=0.5, coupler_tc=10.0,
                     resonance_hz=54e3, resonance_damping=0.03, aaf_order=8, aaf_cutoff_hz=1000.0)
    f = np.array([0.3, 1.0, 10.0, 100.0, 500.0, 1000.0, 1500.0])
    w = 2 * np.pi * f
    wn = 2 * np.pi * 54e3
    eq22 = (1 / (1 - (w / wn) ** 2 + 2j * 0.03 * w / wn)
            * (1j * 10.0 * w / (1 + 1j * 10.0 * w)) * (1j * 0.5 * w / (1 + 1j * 0.5 * w)))
    b, a = signal.butter(8, 2 * np.pi * 1000.0, analog=True)
    _, aaf = signal.freqs(b, a, worN=w)
    expected = -0.020292 * 10.0 * eq22 * aaf
    np.testing.assert_allclose(c.frequency_response(f), expected, rtol=1e-9)
    fs = 160e3  # the simulator's internal rate at 8x oversampling of 20 kHz
    _, hd = signal.sosfreqz(c.discrete_sos(fs), worN=f, fs=fs)
    # first-order-hold sections: in-band error grows as (f/fs)^2, below 0.2 % up to 1.5 kHz
    np.testing.assert_allclose(hd, expected, rtol=2e-3)


def test_sine_through_chain_has_eq_2_2_amplitude_and_phase():
    c = ChannelChain(sensitivity=0.02, gain=10.0)
    fs, f0 = 160e3, 150.0
    t = np.arange(int(2.0 * fs)) / fs
    y = run_analog(c, np.sin(2 * np.pi * f0 * t), fs)
    h = c.frequency_response([f0])[0]
    tail = t > 1.5  # the 10 s coupler is not settled, but its transient is tiny at 150 Hz after 1.5 s
    np.testing.assert_allclose(y[tail], np.abs(h) * np.sin(2 * np.pi * f0 * t[tail] + np.angle(h)),
                               atol=2e-3 * np.abs(h))


def test_force_channel_area_is_the_hammer_impulse(sim, thesis_rig):
    hits = [Hit(0.0, 12.0, 0.8e-3), Hit(0.03, 7.0, 0.3e-3)]
    s = AcquisitionSettings(n_samples=2048, pretrigger=200)
    rec, raw = record(sim, thesis_rig, s, scenario="T8", hits=hits, seed=5, noise=False)
    fs = rec.sampling_rate
    area = raw[:, FORCE].sum() / fs / volts_per_newton(rec)  # N s; quantisation averages out
    assert area == pytest.approx(impulse(hits), rel=5e-3)
    assert impulse(hits) == pytest.approx((2 / np.pi) * (12.0 * 0.8e-3 + 7.0 * 0.3e-3))
    t = np.arange(400_000) / 1e7
    assert half_sine_force(t, hits).sum() / 1e7 == pytest.approx(impulse(hits), rel=1e-4)


def test_force_peak_scales_the_hits_and_their_impulse(sim, thesis_rig):
    """--force-peak sets the largest hit's peak; the others keep their ratio, so the recorded
    impulse is the half-sine's (2/pi) peak x width summed with the scaled peaks."""
    hits = [Hit(0.0, 12.0, 0.8e-3), Hit(0.03, 6.0, 0.3e-3)]
    s = AcquisitionSettings(n_samples=2048, pretrigger=200)
    rec, raw = record(sim, thesis_rig, s, scenario="T8", hits=hits, seed=5, noise=False, force_peak=24.0)
    area = raw[:, FORCE].sum() / rec.sampling_rate / volts_per_newton(rec)
    assert area == pytest.approx((2 / np.pi) * (24.0 * 0.8e-3 + 12.0 * 0.3e-3), rel=5e-3)
    assert "force_peak=24N" in rec.source
    with pytest.raises(ConfigError, match="--force-peak: a hammer's peak force, 0.001 to 1e.06 N, got -1.0"):
        record(sim, thesis_rig, s, scenario="T8", force_peak=-1.0)


@pytest.mark.parametrize("peak", [1e300, 2e6, 1e-300, 5e-4, float("nan")])
def test_a_peak_force_no_hammer_delivers_is_refused(sim, thesis_rig, peak):
    # 1e300 N was recorded: every accelerometer clipped at the ADC's limits
    s = AcquisitionSettings(n_samples=2048, pretrigger=200)
    got = re.escape(repr(peak))
    with pytest.raises(ConfigError, match=rf"^--force-peak: a hammer's peak force, 0.001 to 1e\+06 N, got {got}$"):
        record(sim, thesis_rig, s, force_peak=peak)
    with pytest.raises(ConfigError, match=r"^simulator hit 1: hit field 'peak' must be 0.001-1e\+06 N \(a hammer's peak "
                                          rf"force\), got {got}$"):
        record(sim, thesis_rig, s, hits=[Hit(0.0, 20.0, 0.5e-3), Hit(0.05, peak, 0.5e-3)])


def test_accelerometer_volts_follow_sign_sensitivity_gain(sim, thesis_rig):
    # free mass, force +z: zC sees F/m along +z; volts = sign * sensitivity * gain * a; compare areas
    rec, raw = record(sim, thesis_rig, scenario="T1", seed=2, noise=False)
    zc = thesis_rig.sensor("zC")
    dv = raw[:, zc.channel].sum() / rec.sampling_rate
    expected = zc.sign * zc.sensitivity * 10.0 * impulse(list(SCENARIOS["T1"].hits)) / 2.714
    # the 0.5 s / 10 s high-passes remove a little of the area over 0.2 s: 0.2/0.5 + ... ~ 2 %
    assert dv == pytest.approx(expected, rel=0.05)
    assert np.sign(dv) == -1


def test_systeminfo_is_the_experimenters_view(sim, thesis_rig):
    chains = {4: replace(thesis_chains(thesis_rig)[4], sensitivity=0.03)}  # hidden sensor fault
    rec, _ = record(sim, thesis_rig, scenario="T1", seed=0, chains=chains)
    si = rec.systeminfo
    assert si.channels[4].sensitivity == thesis_rig.sensor("zC").sensitivity
    assert si.channels[0].sensitivity == pytest.approx(2.248e-3)
    acc = si.channels[2]
    assert (acc.integration, acc.filter_order, acc.cutoff_low, acc.filters_on, acc.invert, acc.daq_gain) == (1, 8, 20.0, 3, True, 10.0)
    assert si.rig.nine_channels == list(range(2, 11))
    assert rec.excitation.force_channel == 0
    np.testing.assert_allclose(rec.excitation.point, SCENARIOS["T1"].point)


def test_bad_options_give_one_line_errors(sim, thesis_rig):
    with pytest.raises(ConfigError, match="unknown scenario 'T9'"):
        sim.record(thesis_rig, AcquisitionSettings(), scenario="T9")
    with pytest.raises(ConfigError, match="width' must be 0.05-50 ms"):
        sim.record(thesis_rig, AcquisitionSettings(), hits=[Hit(0.0, 10.0, 0.1)])
    with pytest.raises(ConfigError, match="pretrigger"):
        AcquisitionSettings(n_samples=512, pretrigger=512)
    with pytest.raises(ConfigError, match="channel 4: chain field 'limit_high'"):
        sim.record(thesis_rig, AcquisitionSettings(),
                   chains={4: ChannelChain(sensitivity=0.02, limit_low=1.0, limit_high=-1.0)})


def test_acquire_streams_into_project(sim, thesis_rig, tmp_path):
    from odsuite.store.project import create_project

    stages = []
    with create_project(tmp_path / "p.odsuite") as project:
        s = AcquisitionSettings(n_samples=1500, pretrigger=400, chunk_size=256)
        exp, rec = acquire(project, sim, "T6", s, scenario="T6", seed=9,
                           progress=lambda stage, done, total: stages.append((stage, done, total)))
        assert exp.n_samples == 1500 and exp.pretrigger == 400 and exp.sampling_rate == 20_000.0
        assert exp.channel_names[:3] == ["force", "ai1", "xC"]
        np.testing.assert_allclose(exp.excitation.point, SCENARIOS["T6"].point)
        _, again = record(sim, thesis_rig, s, scenario="T6", seed=9)
        np.testing.assert_array_equal(exp.raw(), again)
        with pytest.raises(ConfigError, match="'T6' already exists"):
            acquire(project, sim, "T6", s, scenario="T6")
    assert stages[0][0] == "waiting for trigger"
    assert [d for st, d, _ in stages if st == "reading"] == [256, 512, 768, 1024, 1280, 1500]


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_scenarios_on_the_rigs_default_model_stay_in_range(thesis_rig, name):
    rec, raw = record(SimulatedRig(), thesis_rig, scenario=name, seed=0)
    assert rec.clipped == {}
    si = rec.systeminfo
    # pass-band physical units (thesis Eq. 4.3) without the sensor sign; offsets removed
    acc = {s.name: (raw[:, s.channel] - raw[:100, s.channel].mean()) / (s.sign * si.channels[s.channel].sensitivity * 10)
           for s in thesis_rig.sensors}
    rms = {k: float(np.sqrt(np.mean(v**2))) for k, v in acc.items()}
    z = max(rms["zC"], rms["z1"], rms["z2"])
    xy = max(rms[k] for k in ("xC", "yC", "x1", "y2", "x3", "y3"))
    if SCENARIOS[name].direction[2] > 0:  # vertical blows: z sensors dominate (Table 5.1, 5.3)
        assert z > 3 * xy
    else:  # side blows along x: x sensors dominate
        assert max(rms["xC"], rms["x1"], rms["x3"]) > 3 * z


def test_hidden_effect_changes_the_truth_not_the_systeminfo(thesis_rig):
    s = AcquisitionSettings(n_samples=4096, pretrigger=100)
    nominal, a = record(SimulatedRig(), thesis_rig, s, scenario="T1", seed=4, noise=False)
    hidden, b = record(SimulatedRig(), thesis_rig, s, scenario="T1", seed=4, noise=False,
                       effects=[("stiffness", {"scale_z": 1.44})])
    assert nominal.systeminfo == hidden.systeminfo
    # T1 excites the bounce mode, whose frequency goes as sqrt(kz): 1.2 x with kz x 1.44
    def peak_hz(x):
        spec = np.abs(np.fft.rfft(x[100:] - x[100:].mean(), 1 << 18))
        f = np.fft.rfftfreq(1 << 18, 1 / s.sampling_rate)
        band = (f > 50) & (f < 800)
        return f[band][np.argmax(spec[band])]
    zc = thesis_rig.sensor("zC").channel
    assert peak_hz(b[:, zc]) / peak_hz(a[:, zc]) == pytest.approx(1.2, rel=0.02)


def test_front_end_drift_is_linear_then_settles():
    """The ADC input's drift: linear for DRIFT_LINEAR_S (impact records are unchanged), then
    settling with value and slope continuous, bounded at twice that (a 10-minute operating record
    no longer runs into the ADC's limits)."""
    from odsuite_plugins.daq_sim.chain import DRIFT_LINEAR_S, drift_profile

    t = np.linspace(0.0, 20 * DRIFT_LINEAR_S, 200_001)
    d = drift_profile(t)
    early = t <= DRIFT_LINEAR_S
    np.testing.assert_array_equal(d[early], t[early])
    assert d[-1] < 2 * DRIFT_LINEAR_S and d[-1] == pytest.approx(2 * DRIFT_LINEAR_S, rel=1e-8)
    assert drift_profile(np.array([2 * DRIFT_LINEAR_S]))[0] == pytest.approx(DRIFT_LINEAR_S * (2 - np.exp(-1)))
    slope = np.diff(d) / np.diff(t)
    k = np.searchsorted(t, DRIFT_LINEAR_S)
    assert slope[k - 1] == pytest.approx(1.0) and slope[k + 1] == pytest.approx(1.0, abs=1e-3)
    assert np.all(slope >= 0)
