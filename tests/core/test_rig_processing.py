"""A rig file's [processing] table: the chain of records that come without a .CTR, rig-wide and
per sensor, checked against closed-form filter responses."""

from __future__ import annotations

import numpy as np
import pytest

from odsuite.processing.chain_spec import chain_for_channel
from odsuite.domain.errors import ConfigError
from odsuite.domain.rig import rig_from_dict
from odsuite.domain.systeminfo import FilterFamily, FilterType, Integration, Systeminfo

def _installed_steps():
    """The installed plugins' processing steps (chains name them)."""
    from odsuite.contracts.plugins import registries

    return registries().processing_steps


FS = 10240.0


def rig_data(processing=None, hammer_processing=None) -> dict:
    hammer = {"name": "hammer", "kind": "force", "channel": 0, "sensitivity": 0.0025}
    if hammer_processing is not None:
        hammer["processing"] = hammer_processing
    data = {"name": "plate-rig",
            "bodies": [{"name": "plate", "mass": 5.0, "inertia": np.diag([0.05, 0.08, 0.1]).tolist()}],
            "sensors": [hammer, {"name": "a1", "body": "plate", "position": [0.1, 0.0, 0.0], "axis": [0, 0, 1],
                                 "channel": 1, "sensitivity": 0.01}]}
    if processing is not None:
        data["processing"] = processing
    return data


def test_without_the_table_a_rig_keeps_the_thesis_settings(registries):
    si = Systeminfo.for_rig(rig_from_dict(rig_data(), registries.sensor_types), FS)
    acc = si.channels[1]
    assert (acc.filter_family, acc.filter_type, acc.filter_order, acc.cutoff_low) == (
        FilterFamily.ELLIPTIC, FilterType.HIGHPASS, 8, 20.0)
    assert acc.filters_on == 3 and acc.integration is Integration.DOUBLE and acc.offset_length == 100
    assert si.channels[0].filters_on == 0


def test_rig_wide_settings_reach_the_accelerometers_and_a_sensor_table_overrides_them(registries):
    processing = {"offset_samples": [10, 300], "integration": "trapezoid", "zero_phase": True,
                  "filter": {"family": "butterworth", "type": "highpass", "order": 4, "cutoff_hz": 3.0},
                  "filter_at": ["signal", "integral", "double_integral"]}
    hammer = {"filter": {"type": "lowpass", "order": 2, "cutoff_hz": 500.0}, "filter_at": ["signal"]}
    si = Systeminfo.for_rig(rig_from_dict(rig_data(processing, hammer), registries.sensor_types), FS)
    acc, force = si.channels[1], si.channels[0]
    assert (acc.filter_family, acc.filter_order, acc.cutoff_low, acc.cutoff_high) == (
        FilterFamily.BUTTERWORTH, 4, 3.0, None)
    assert acc.filters_on == 7 and acc.integration_rule == "trapezoid" and acc.zero_phase
    assert (acc.offset_start, acc.offset_length) == (10, 300)
    # the force sensor: its own low-pass, rig-wide offset window kept
    assert (force.filter_type, force.filter_order, force.cutoff_high, force.filters_on) == (
        FilterType.LOWPASS, 2, 500.0, 1)
    assert force.offset_length == 300


def test_a_sensor_low_pass_attenuates_3_db_at_its_cutoff(registries):
    """Butterworth: |H(fc)| = 1/sqrt(2) for any order; 2nd order two decades up: 1e-4 (40 dB/dec)."""
    hammer = {"filter": {"type": "lowpass", "order": 2, "cutoff_hz": 500.0}, "filter_at": ["signal"],
              "offset_samples": [0, 0]}
    si = Systeminfo.for_rig(rig_from_dict(rig_data(None, hammer), registries.sensor_types), FS)
    chain = chain_for_channel(si.channels[0], registry=_installed_steps())
    t = np.arange(40960) / FS
    gain = si.channels[0].daq_gain  # the thesis's DAQ gain: volts read = gain * sensitivity * force
    for f, expected in ((500.0, 1 / np.sqrt(2)), (40.0, 1.0)):
        volts = gain * 0.0025 * np.sin(2 * np.pi * f * t)
        out = chain.run(volts)["force"][20480:]
        assert np.max(np.abs(out)) == pytest.approx(expected, rel=2e-3)


def test_no_filter_leaves_the_accelerometer_unfiltered(registries):
    si = Systeminfo.for_rig(rig_from_dict(rig_data({"filter": "none"}), registries.sensor_types), FS)
    assert si.channels[1].filters_on == 0


@pytest.mark.parametrize("processing, words", [
    ({"filter": {"type": "highpass", "cutoff_hz": -3.0}}, ["[processing].filter.cutoff_hz", "-3.0"]),
    ({"filter": {"type": "bandpass", "cutoff_hz": 3.0}}, ["[processing].filter.cutoff_hz", "[low, high]"]),
    ({"filter": {"type": "bandpass", "cutoff_hz": [300.0, 3.0]}}, ["[processing].filter.cutoff_hz", "[300.0, 3.0]"]),
    ({"filter": {"family": "bessel", "cutoff_hz": 3.0}}, ["[processing].filter.family", "'bessel'"]),
    ({"filter": {"order": 0, "cutoff_hz": 3.0}}, ["[processing].filter.order", "0"]),
    ({"filter": {"cutoff_hz": 3.0, "slope": 2}}, ["[processing].filter", "slope"]),
    ({"filter_at": ["acceleration"]}, ["[processing].filter_at", "'acceleration'"]),
    ({"offset_samples": [0, -5]}, ["[processing].offset_samples", "-5"]),
    ({"integration": "simpson"}, ["[processing].integration", "'simpson'"]),
    ({"zero_phase": "yes"}, ["[processing].zero_phase", "'yes'"]),
    ({"highpass": 3.0}, ["[processing]", "highpass"]),
])
def test_bad_processing_fields_are_one_line(registries, processing, words):
    with pytest.raises(ConfigError) as err:
        rig_from_dict(rig_data(processing), registries.sensor_types)
    msg = str(err.value)
    assert "\n" not in msg and all(w in msg for w in words), msg


def test_a_bad_sensor_processing_field_names_the_sensor(registries):
    with pytest.raises(ConfigError) as err:
        rig_from_dict(rig_data(None, {"filter": {"type": "lowpass", "cutoff_hz": "fast"}}), registries.sensor_types)
    assert "'hammer'" in str(err.value) and "processing" in str(err.value) and "'fast'" in str(err.value)


def test_the_acquisition_range_sets_the_channels_limits_and_what_counts_as_clipped(registries):
    """A rig recording on +-10 V: a 7 V force sample is within range (it was counted clipped
    against the thesis's +-5 V limits), a sample at the top code is clipped."""
    from types import SimpleNamespace

    from odsuite.store.clipping import scan

    data = rig_data()
    data["acquisition"] = {"adc_range": [-10.0, 10.0], "adc_bits": 16}
    si = Systeminfo.for_rig(rig_from_dict(data, registries.sensor_types), FS)
    assert [(c.limit_low, c.limit_high) for c in si.channels] == [(-10.0, 10.0)] * 2
    assert (Systeminfo.for_rig(rig_from_dict(rig_data(), registries.sensor_types), FS).channels[0].limit_high
            == 5.0)  # no range declared: the thesis's
    volts = np.zeros((100, 2))
    volts[10, 0], volts[20, 1] = 7.0, 10.0 - 20.0 / 2**16
    record = SimpleNamespace(n_samples=100, n_channels=2, systeminfo=si, raw=lambda a=0, b=None: volts[a:b])
    peak, clipped = scan(record)
    assert peak.tolist() == [7.0, 10.0 - 20.0 / 2**16] and clipped.tolist() == [0, 1]
