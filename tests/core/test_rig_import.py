"""Columns of another tool's record laid onto a rig's channels (odsuite_plugins.importers.rig_import)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from odsuite.domain.errors import ConfigError, DimensionError
from odsuite.domain.rig import load_rig
from odsuite_plugins.importers.rig_import import onto_rig
from odsuite_plugins.importers.tables import G
from odsuite.domain.systeminfo import SensorType

RIG = Path(__file__).resolve().parents[2] / "projects" / "rigs" / "two-body-machine.toml"
HIT = (np.array([0.1, 0.05, 0.25]), np.array([0.0, 0.0, -1.0]))


@pytest.fixture
def rig(registries):
    return load_rig(RIG, registries.sensor_types)


def physical(si, raw, ch):
    """The SI value a channel's Systeminfo makes of its stored column."""
    c = si.channels[ch]
    return raw[:, ch] * (-1 if c.invert else 1) / (c.sensitivity * c.daq_gain)


def test_columns_go_to_their_sensors_by_name_however_spelled(rig):
    names = ["Hammer", "M1 X", "b1-z", "m2.y"]
    units = ["N", "g", "m/s^2", "V"]
    data = np.array([[10.0, 0.5, 2.0, 0.03]] * 4)
    rec = onto_rig(rig, names, units, data, 1000.0, "f.lvm", *HIT)
    ch = {s.name: s.channel for s in rig.sensors}
    assert physical(rec.systeminfo, rec.raw, ch["hammer"])[0] == pytest.approx(10.0)
    assert physical(rec.systeminfo, rec.raw, ch["m1_x"])[0] == pytest.approx(0.5 * G)  # g -> m/s^2
    assert physical(rec.systeminfo, rec.raw, ch["b1_z"])[0] == pytest.approx(2.0)
    # volts at the sensor: the rig's 0.0102 V/(m/s^2), no DAQ gain
    assert physical(rec.systeminfo, rec.raw, ch["m2_y"])[0] == pytest.approx(0.03 / 0.0102)
    # channels the file does not hold are not processed as accelerometers
    assert rec.systeminfo.channels[ch["m3_z"]].sensor_type == SensorType.NONE
    assert rec.notes and "m3_z" in rec.notes[0]
    assert np.allclose(rec.excitation.point, HIT[0]) and rec.excitation.force_channel == 0


def test_unnamed_columns_are_the_channels_in_order(rig):
    data = np.arange(19 * 3, dtype=float).reshape(3, 19)
    rec = onto_rig(rig, [f"Untitled {k}" for k in range(19)], ["V"] * 19, data, 1000.0, "f.lvm", *HIT)
    assert np.array_equal(rec.raw, data)
    with pytest.raises(DimensionError, match=r"f\.lvm: no column is named like a sensor .* its 18 columns cannot be its 19"):
        onto_rig(rig, [f"c{k}" for k in range(18)], ["V"] * 18, data[:, :18], 1000.0, "f.lvm", *HIT)


@pytest.mark.parametrize("names, units, point, words", [
    (["hammer", "m1_x", "spare"], ["N", "g", "V"], HIT[0], ["'spare'", "match no sensor"]),
    (["hammer", "m1_x"], ["N", "N"], HIT[0], ["'m1_x'", "'N'", "channel 10 measures acceleration"]),
    (["hammer", "m1_x"], ["N", "furlong"], HIT[0], ["'m1_x'", "'furlong'"]),
    (["m1_x"], ["g"], HIT[0], ["no column is the force channel 0"]),
    (["hammer", "m1_x"], ["N", "g"], None, ["--force-point"]),
])
def test_records_that_do_not_fit_the_rig_are_one_line(rig, names, units, point, words):
    data = np.ones((4, len(names)))
    with pytest.raises(ConfigError) as err:
        onto_rig(rig, names, units, data, 1000.0, "f.lvm", point, HIT[1])
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("f.lvm") and all(w in msg for w in words), msg


@pytest.mark.parametrize("names, units", [
    (["force", "m1_x"], ["N", "g"]),  # named like a force, in N
    (["load [kN]", "m1_x"], ["N", "g"]),  # in N, named otherwise
    (["Hammer 2", "m1_x"], ["V", "g"]),  # named like a force (without the rig's force sensor's name)
])
def test_a_force_column_not_named_like_the_rigs_force_sensor_is_the_force(rig, names, units):
    # docs/importing.md: a column in N (or named like a force) is the force; it was refused as a
    # column that matches no sensor unless --force-channel named it
    data = np.array([[10.0, 0.5]] * 4)
    rec = onto_rig(rig, names, units, data, 1000.0, "f.csv", *HIT)
    assert rec.excitation.force_channel == rig.force_channel
    assert rec.raw[0, rig.force_channel] == pytest.approx(10.0)
    # two candidates: the user names it (--force-channel)
    with pytest.raises(ConfigError, match="match no sensor"):
        onto_rig(rig, ["force", "impact", "m1_x"], ["N", "N", "g"], np.zeros((4, 3)), 1000.0, "f.csv", *HIT)
