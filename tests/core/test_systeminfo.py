"""Systeminfo: Table E.3 as printed, validation messages, and the rig default."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from odsuite.domain.errors import ConfigError, OdsuiteWarning
from odsuite_plugins.importers.legacy import read_ctr
from odsuite.domain.rig import NINE_ROLES
from odsuite.domain.systeminfo import (
    FilterFamily,
    FilterType,
    Integration,
    SensorType,
    Systeminfo,
    enum_code,
    filters_on_code,
)
from tests.conftest import REPO

TABLE_E3 = REPO / "plugins" / "models" / "rigs" / "thesis-table-e3.CTR"


@pytest.fixture
def e3() -> Systeminfo:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OdsuiteWarning)
        return read_ctr(TABLE_E3)


def test_table_e3_as_printed_imports_with_its_values(thesis_rig):
    with pytest.warns(OdsuiteWarning, match=r"row 0 \(sensor type\), channel 1: sensor type 6"):
        si = read_ctr(TABLE_E3)
    assert len(si.channels) == 11
    force, aux, *acc = si.channels
    assert force.sensor_type is SensorType.LOADCELL and aux.sensor_type is SensorType.AUXILIARY
    assert all(c.sensor_type is SensorType.ACCELEROMETER for c in acc)
    # Table A.1: load cell 2.248 mV/N; the auxiliary channel 1000 mV/V
    assert force.sensitivity == pytest.approx(2.248e-3, rel=1e-12)
    assert aux.sensitivity == pytest.approx(1.0, rel=1e-12)
    # accelerometer sensitivities agree with the rig file (Table A.1 per serial), in V/(m/s^2)
    for ch, k in zip(acc, range(2, 11)):
        assert ch.sensitivity == pytest.approx(thesis_rig.sensor_on_channel(k).sensitivity, rel=1e-12)
    assert [c.serial for c in si.channels][:7] == ["1519", "0", "100868", "100859", "100867",
                                                   "100852", "01813"]  # leading zero kept
    assert {c.sampling_rate for c in si.channels} == {20000.0}
    assert all(c.filter_type is FilterType.HIGHPASS and c.filter_order == 8 for c in si.channels)
    assert all(c.filter_family is FilterFamily.ELLIPTIC for c in si.channels)
    assert all(c.cutoff_low == 20.0 and c.cutoff_high == 10000.0 for c in si.channels)
    assert [c.filters_on for c in si.channels] == [0, 0] + [3] * 9
    assert [c.integration for c in si.channels] == [Integration.NONE] * 2 + [Integration.DOUBLE] * 9
    assert [c.invert for c in si.channels] == [False, False] + [True] * 9
    assert [c.offset_length for c in si.channels] == [400, 400, 400, 100, 100, 400, 100, 100, 100, 100, 100]
    assert [c.daq_gain for c in si.channels] == [10.0, 1000.0] + [10.0] * 9
    assert (si.channels[6].limit_high, si.channels[6].limit_low) == (5.0, -0.5)
    rig = si.rig
    assert rig.use_in_gcc and rig.use_in_ag and rig.plot_from_corner
    np.testing.assert_allclose(rig.plate_sizes, [(0.09846, 0.16993, 0.0221), (0.13937, 0.16993, 0.0254),
                                                 (0.5, 0.5, 0.0254)], rtol=1e-12)
    np.testing.assert_allclose(rig.plate_origins, [(0, 0.07482, 0), (0, 0.07482, 0.023),
                                                   (0.07482, 0.07482, 0.0381)], rtol=1e-12)
    assert (rig.rx, rig.ry, rig.rz) == pytest.approx((0.09846, 0.16993, 0.0221), rel=1e-12)
    assert rig.coordinate_columns == [0, 6]
    # row 33 names the same channels as the rig's nine-sensor set
    nine = thesis_rig.body("platform").nine_sensor_set
    assert rig.nine_channels == [thesis_rig.sensor(nine.sensors[r]).channel for r in NINE_ROLES]
    # row 8 = 10 kHz is Nyquist at 20 kHz, but high-pass filters never read it
    si.validate(n_samples=512, source="e3")


def _bad(si: Systeminfo, k: int, **changes) -> Systeminfo:
    channels = list(si.channels)
    channels[k] = dataclasses.replace(channels[k], **changes)
    return Systeminfo(channels=channels, rig=si.rig)


@pytest.mark.parametrize("k, changes, message", [
    (3, {"sampling_rate": 0.0}, r"f\.CTR: row 7 \(sampling frequency\), channel 3: .*> 0 Hz, got 0\.0"),
    (3, {"sampling_rate": -20000.0}, r"row 7 .*channel 3: .*got -20000\.0"),
    (4, {"sampling_rate": 10000.0}, r"row 7 .*channel 4: sampling rate 10000\.0 Hz differs from channel 0's 20000\.0"),
    (2, {"cutoff_low": 10000.0}, r"row 9 \(low cut-off frequency\), channel 2: .*Nyquist frequency 10000 Hz, got 10000\.0"),
    (2, {"cutoff_low": 0.0}, r"row 9 .*channel 2: .*got 0\.0 Hz"),
    (2, {"cutoff_low": None}, r"row 9 .*channel 2: a highpass filter needs this cut-off"),
    (5, {"filter_type": FilterType.LOWPASS}, r"row 8 \(high cut-off frequency\), channel 5: .*got 10000\.0 Hz"),
    (5, {"filter_type": FilterType.BANDPASS, "cutoff_high": 500.0, "cutoff_low": 600.0},
     r"row 9 .*channel 5: low cut-off 600\.0 Hz must be below the high cut-off 500\.0 Hz"),
    (6, {"filter_order": 0}, r"row 6 \(filter order\), channel 6: .*>= 1 when a filter is on \(row 12 = 3\), got 0"),
    (7, {"sensitivity": 0.0}, r"row 3 \(sensitivity\), channel 7: .*accelerometer channel, got 0\.0 V/m/s\^2"),
    (0, {"sensitivity": -2.248e-3}, r"row 3 .*channel 0: .*loadcell channel, got -0\.002248 V/N"),
    (8, {"limit_low": 5.0}, r"row 20 \(DAQ low limit\), channel 8: .*5\.0 V must be below the high limit 5\.0 V"),
    (9, {"daq_gain": 0.0}, r"row 17 \(DAQ gain\), channel 9: .*got 0\.0"),
    (10, {"filter_type": 7}, r"row 5 \(filter type\), channel 10: unknown code 7"),
    (10, {"sensor_type": 5}, r"row 0 \(sensor type\), channel 10: unknown code 5"),
    (10, {"integration": 3}, r"row 4 \(integration\), channel 10: unknown code 3"),
    (10, {"filter_family": 2}, r"row 18 \(filter family\), channel 10: unknown code 2"),
    (10, {"filters_on": 9}, r"row 12 \(filter on/off\), channel 10: expected a bitmask 0\.\.7, got 9"),
    (2, {"ripple_db": 0.0}, r"row 10 \(pass-band ripple\), channel 2: an elliptic filter needs dB from 1e-06 to below 200"),
    (2, {"integration_rule": "simpson"}, r"channel 2 field 'integration_rule'.*'simpson'"),
])
def test_validation_names_file_row_channel_and_value(e3, k, changes, message):
    with pytest.raises(ConfigError, match=message):
        _bad(e3, k, **changes).validate(n_samples=4096, source="f.CTR")


def test_only_the_cutoffs_a_filter_reads_are_checked(e3):
    # a low-pass reads only row 8; a silly row 9 does not matter
    _bad(e3, 2, filter_type=FilterType.LOWPASS, cutoff_high=1000.0, cutoff_low=-5.0).validate()
    # filters off: neither cut-off nor order is read
    _bad(e3, 2, filters_on=0, filter_order=0, cutoff_low=1e9).validate()
    # Butterworth ignores ripple and attenuation
    _bad(e3, 2, filter_family=FilterFamily.BUTTERWORTH, ripple_db=0.0).validate()


def test_offset_window_against_record_length(e3):
    e3.validate(n_samples=400)  # channel 0: samples 0..399 of 400
    with pytest.raises(ConfigError, match=r"row 16 \(offset length\), channel 0: offset window samples "
                                          r"0\.\.399 lies outside the record of 399 samples"):
        e3.validate(n_samples=399, source="f.CTR")
    with pytest.raises(ConfigError, match=r"row 15 .*channel 1: offset start must be >= 0, got -1"):
        _bad(e3, 1, offset_start=-1).validate()


def test_nine_channel_assignment_must_name_existing_channels(e3):
    bad = Systeminfo(channels=e3.channels[:10], rig=e3.rig)
    with pytest.raises(ConfigError, match=r"row 33 .*channel 8: channel 10 is not one of the 10 channels"):
        bad.validate()


def test_legacy_codes():
    assert filters_on_code(16, "x") == 7  # erratum 8: "16 = all on"
    assert filters_on_code(3.0, "x") == 3
    with pytest.raises(ConfigError, match="x: expected a bitmask 0..7 .* got 8"):
        filters_on_code(8, "x")
    with pytest.raises(ConfigError, match=r"x: expected an integer, got 1\.5"):
        enum_code(FilterType, 1.5, "x")


def test_for_rig_starts_from_the_rigs_ctr(thesis_rig, e3):
    si = Systeminfo.for_rig(thesis_rig, 10000.0)
    assert len(si.channels) == thesis_rig.channel_count == 11
    assert {c.sampling_rate for c in si.channels} == {10000.0}
    for mine, printed in zip(si.channels, e3.channels):
        assert dataclasses.replace(mine, sampling_rate=printed.sampling_rate) == printed
    assert si.rig == e3.rig
    si.validate()  # row 8 = 10 kHz is above Nyquist now, but unused by the high-pass filters


def test_for_rig_without_ctr_describes_the_sensors(thesis_rig, e3):
    rig = dataclasses.replace(thesis_rig, systeminfo_file=None)
    si = Systeminfo.for_rig(rig, 20000.0)
    si.validate()
    assert si.channels[0].sensor_type is SensorType.LOADCELL
    for k in range(2, 11):
        ch, printed, sensor = si.channels[k], e3.channels[k], rig.sensor_on_channel(k)
        assert ch.sensor_type is SensorType.ACCELEROMETER
        assert ch.sensitivity == sensor.sensitivity
        # the thesis's processing settings, as Table E.3 records them
        for name in ("invert", "integration", "filter_type", "filter_order", "cutoff_low",
                     "ripple_db", "attenuation_db", "filters_on", "filter_family"):
            assert getattr(ch, name) == getattr(printed, name), name
    assert si.rig.nine_channels == e3.rig.nine_channels
    assert (si.rig.rx, si.rig.ry, si.rig.rz) == pytest.approx((e3.rig.rx, e3.rig.ry, e3.rig.rz), rel=1e-12)
    assert len(Systeminfo.for_rig(rig, 20000.0, n_channels=12).channels) == 12


def test_a_proximity_probe_may_give_volts_per_millimetre(e3):
    # an eddy-current probe of 7.87 V/mm (200 mV/mil) is 7870 V/m: it was refused as beyond any
    # sensor (the 1000 V per SI unit meant for accelerometers); a capacitive one gives up to 1e7
    _bad(e3, 10, sensor_type=SensorType.PROXIMITY, sensitivity=7870.0).validate()
    _bad(e3, 10, sensor_type=SensorType.PROXIMITY, sensitivity=1e7).validate()
    with pytest.raises(ConfigError, match=r"row 3 .*channel 10: sensitivity 20000000\.0 V/m is outside what any sensor "
                                          r"has \(1e-09 to 1e\+07 V/m\)"):
        _bad(e3, 10, sensor_type=SensorType.PROXIMITY, sensitivity=2e7).validate()
    with pytest.raises(ConfigError, match=r"channel 10: sensitivity 7870\.0 V/m/s\^2 is outside"):
        _bad(e3, 10, sensitivity=7870.0).validate()  # an accelerometer keeps its bound
