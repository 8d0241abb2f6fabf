"""The NI-DAQmx backend against a faithful fake of nidaqmx, and on real NI-DAQmx where present."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from odsuite_plugins.daq_ni.backend import NiDaq, available

from odsuite.processing.acquisition import acquire
from odsuite.contracts.daq import AcquisitionSettings
from odsuite.domain.errors import ConfigError, HardwareError

sys.path.insert(0, str(Path(__file__).parent))
import fake_nidaqmx as fake  # noqa: E402

FS = 20_000.0
HIT_AT = 3000  # sample where the hammer pulse starts on the fake card's inputs
TABLE_A1_MV_PER_G = {"xC": 199, "yC": 205, "zC": 210, "x1": 197, "z1": 201, "y2": 198, "z2": 203, "x3": 200, "y3": 196}


def card_signal(n=12_000, seed=0):
    """Volts at the 11 inputs: noise everywhere, a 20 N half-sine on the load cell (2.248 mV/N)."""
    rng = np.random.default_rng(seed)
    x = rng.normal(0.0, 1e-3, (n, 11))
    k = np.arange(10)
    x[HIT_AT:HIT_AT + 10, 0] += 20.0 * 2.248e-3 * np.sin(np.pi * (k + 0.5) / 10)
    return x


@pytest.fixture
def card(monkeypatch):
    c = fake.Card(card_signal())
    fake.install(monkeypatch, c)
    return c


def settings(**kw):
    return AcquisitionSettings(**{"n_samples": 4096, "pretrigger": 512, "trigger_level": 5.0, "chunk_size": 1000, **kw})


def take(rig, s=None, **kw):
    rec = NiDaq().record(rig, s or settings(), **kw)
    return rec, np.concatenate(list(rec.chunks))


def test_thesis_rig_channel_timing_trigger_and_read_calls(card, thesis_rig):
    rec, raw = take(thesis_rig, device="Dev1")
    calls = card.calls
    chans = [c for c in calls if c[0].startswith("add_ai")]
    assert [c[1] for c in chans] == [f"Dev1/ai{k}" for k in range(11)]
    force = chans[0]
    assert force[0] == "add_ai_force_iepe_chan"
    assert force[2]["sensitivity"] == pytest.approx(2.248)  # mV/N, Table A.1
    assert force[2]["units"] == fake.ForceUnits.NEWTONS
    assert force[2]["current_excit_source"] == fake.ExcitationSource.INTERNAL
    assert force[2]["current_excit_val"] == 0.004
    assert (force[2]["min_val"], force[2]["max_val"]) == pytest.approx((-5 / 2.248e-3, 5 / 2.248e-3))
    assert chans[1][0] == "add_ai_voltage_chan" and (chans[1][2]["min_val"], chans[1][2]["max_val"]) == (-2.0, 3.0)
    for kind, phys, kw in chans[2:]:
        sensor = thesis_rig.sensor_on_channel(int(phys.split("ai")[1]))
        assert kind == "add_ai_accel_chan" and kw["name_to_assign_to_channel"] == sensor.name
        assert kw["units"] == fake.AccelUnits.METERS_PER_SECOND_SQUARED
        assert kw["sensitivity_units"] == fake.AccelSensitivityUnits.MILLIVOLTS_PER_G
        # the rig's V/(m/s^2) back in mV/g agrees with Table A.1's own mV/g column
        assert kw["sensitivity"] == pytest.approx(TABLE_A1_MV_PER_G[sensor.name], abs=0.6)
    timing = next(c for c in calls if c[0] == "cfg_samp_clk_timing")
    assert timing[1] == FS and timing[2] == {"sample_mode": fake.AcquisitionType.FINITE, "samps_per_chan": 4096}
    trig = next(c for c in calls if c[0] == "cfg_anlg_edge_ref_trig")
    assert trig[1] == "Dev1/ai0"
    assert trig[2] == {"pretrigger_samples": 512, "trigger_slope": fake.Slope.RISING, "trigger_level": 5.0}
    names = [c[0] for c in calls]
    assert names.index("cfg_anlg_edge_ref_trig") < names.index("start") < names.index("read")
    assert [c[1] for c in calls if c[0] == "read"] == [1000, 1000, 1000, 1000, 96]
    assert card.tasks[0].closed

    # what was stored: the inputs' volts, 512 samples before the first sample at or above 5 N
    sig = card.signal
    level_v = 5.0 * 2.248e-3
    first = np.flatnonzero(sig[:, 0] >= level_v)[0]
    np.testing.assert_allclose(raw, sig[first - 512:first - 512 + 4096], rtol=1e-12, atol=1e-15)
    assert raw[511, 0] < level_v <= raw[512, 0]
    assert all(rec.systeminfo.channels[k].daq_gain == 1.0 for k in (0, *range(2, 11)))
    assert rec.channel_names[:3] == ["force", "ai1", "xC"]


def test_voltage_channels_behind_external_conditioning(card, thesis_rig):
    card.signal = card.signal * 10  # the thesis's couplers and gain-10 filters before the card
    rec, raw = take(thesis_rig, iepe=False)
    assert {c[0] for c in card.calls if c[0].startswith("add_ai")} == {"add_ai_voltage_chan"}
    trig = next(c for c in card.calls if c[0] == "cfg_anlg_edge_ref_trig")
    # the level in volts: 5 N x 2.248 mV/N x gain 10 (Table E.3 row 17)
    assert trig[2]["trigger_level"] == pytest.approx(5.0 * 2.248e-3 * 10)
    assert rec.systeminfo.channels[2].daq_gain == 10.0
    first = np.flatnonzero(card.signal[:, 0] >= 5.0 * 2.248e-3 * 10)[0]
    np.testing.assert_array_equal(raw, card.signal[first - 512:first - 512 + 4096])


def test_digital_reference_trigger_on_pfi(monkeypatch, thesis_rig):
    card = fake.Card(card_signal(), digital_trigger_at=5000)
    fake.install(monkeypatch, card)
    _, raw = take(thesis_rig, settings(trigger_slope="falling"), trigger_source="/Dev1/PFI0")
    trig = next(c for c in card.calls if c[0] == "cfg_dig_edge_ref_trig")
    assert trig[1] == "/Dev1/PFI0" and trig[2] == {"pretrigger_samples": 512, "trigger_edge": fake.Edge.FALLING}
    np.testing.assert_allclose(raw, card.signal[5000 - 512:5000 - 512 + 4096], rtol=1e-12, atol=1e-15)


def test_continuous_mode_keeps_the_samples_before_capture(card, thesis_rig):
    polls = iter([False, False, False, True])
    s = settings(mode="continuous", chunk_size=300)
    _, raw = take(thesis_rig, s, capture=lambda: next(polls))
    timing = next(c for c in card.calls if c[0] == "cfg_samp_clk_timing")
    assert timing[2]["sample_mode"] == fake.AcquisitionType.CONTINUOUS
    assert not any(c[0].startswith("cfg_") and "trig" in c[0] for c in card.calls)
    # three 300-sample blocks before the capture: the record starts 512 samples before sample 900
    np.testing.assert_allclose(raw, card.signal[900 - 512:900 - 512 + 4096], rtol=1e-12, atol=1e-15)


def test_errors_are_one_line_hardware_errors(monkeypatch, thesis_rig):
    fake.install(monkeypatch, fake.Card(card_signal()))
    with pytest.raises(HardwareError, match=r"invalid device while configuring Dev9 \(NI-DAQmx -200220\).*--device"):
        take(thesis_rig, device="Dev9")
    with pytest.raises(HardwareError, match=r"trigger timeout: no rising edge through 500 N on the force channel within 2 s"):
        take(thesis_rig, settings(trigger_level=500.0, trigger_timeout=2.0))
    fake.install(monkeypatch, fake.Card(card_signal(), driver=False))
    with pytest.raises(HardwareError, match="NI-DAQmx driver not found while creating the task: install"):
        take(thesis_rig)
    monkeypatch.setitem(sys.modules, "nidaqmx", None)
    with pytest.raises(HardwareError, match=r"needs the Python package 'nidaqmx' \(`pip install nidaqmx`\)"):
        take(thesis_rig)
    with pytest.raises(ConfigError, match="continuous acquisition needs a capture"):
        NiDaq().record(thesis_rig, settings(mode="continuous"))


def test_over_range_warning_becomes_a_hardware_error(card, thesis_rig):
    card.warning = 200005  # DAQmx "ADC overloaded"
    with pytest.raises(HardwareError, match=r"input over-range while waiting for the trigger \(NI-DAQmx 200005\).*widen"):
        take(thesis_rig)


def test_streams_into_project_and_a_failed_read_stores_nothing(card, thesis_rig, tmp_path):
    from odsuite.store.project import create_project

    with create_project(tmp_path / "p.odsuite") as project:
        exp, _ = acquire(project, NiDaq(), "hit1", settings(), point=[0.0, 0.004122, -0.011399],
                         direction=[0, 0, 1])
        assert exp.n_samples == 4096 and exp.pretrigger == 512
        np.testing.assert_allclose(exp.excitation.direction, [0, 0, 1])
        card.signal = card.signal[:HIT_AT + 2000]  # the card stops delivering mid-record
        with pytest.raises(HardwareError, match="NI-DAQmx error -200284 while reading"):
            acquire(project, NiDaq(), "hit2", settings())
        assert project.experiment_names() == ["hit1"]


@pytest.mark.hardware
def test_real_nidaqmx_simulated_device(thesis_rig):
    if not available():
        pytest.skip("NI-DAQmx driver not installed: `python -m nidaqmx installdriver`, then create a "
                    "simulated device named Dev1 with 11+ analog inputs in NI MAX (e.g. a PCIe-6363)")
    s = settings(n_samples=2048, pretrigger=100, trigger_level=-1e9, trigger_timeout=5.0)
    rec, raw = take(thesis_rig, s, iepe=False)
    assert raw.shape == (2048, 11) and np.all(np.isfinite(raw))
