"""The .CTR codec: round trips, the separators it accepts, and one-line errors for bad files."""

from __future__ import annotations

import dataclasses
import warnings

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from odsuite.domain.errors import ConfigError, OdsuiteWarning
from odsuite_plugins.importers.legacy import format_ctr, parse_ctr, read_ctr, write_ctr
from odsuite.domain.systeminfo import ChannelInfo, RigInfo, SensorType, Systeminfo, _ctr_rows
from tests.core.test_systeminfo import TABLE_E3

pytestmark = pytest.mark.filterwarnings("ignore::odsuite.domain.errors.OdsuiteWarning")


def _cells_equal(a: str, b: str) -> bool:
    """Equal as numbers when both parse, else as text; '-' and '' both mean no value."""
    a, b = ("" if a == "-" else a), ("" if b == "-" else b)
    try:
        return float(a) == float(b)
    except ValueError:
        return a == b


def test_table_e3_round_trips_every_cell(tmp_path):
    printed = _ctr_rows(TABLE_E3.read_text(), "e3")
    si = read_ctr(TABLE_E3)
    out = tmp_path / "E3.CTR"
    write_ctr(si, out)
    written = [line.split("\t") for line in out.read_text().splitlines()]
    assert len(written) == 34 and all(len(r) == 11 for r in written)
    for r, (a, b) in enumerate(zip(printed, written)):
        assert all(_cells_equal(x, y) for x, y in zip(a, b)), (r, a, b)
    assert written[2][6] == "01813"
    assert written[3][:4] == ["2.248", "1000", "20.292", "20.903"]  # mV/unit, as printed
    assert written[22][:3] == ["98.46", "139.37", "500"]  # mm, as printed
    again = read_ctr(out)
    assert again == si
    assert format_ctr(again) == out.read_text()  # the text is a fixed point


def test_whitespace_separated_ctr_reads_the_same():
    si = read_ctr(TABLE_E3)
    assert parse_ctr(format_ctr(si).replace("\t", "   ")) == si


finite = st.floats(min_value=1e-6, max_value=1e6, allow_nan=False, allow_infinity=False)
#: half the span of a .CTR's DAQ limits (rows 19-20): a converter's range, 1 mV to +-1000 V
half_range = st.floats(min_value=5e-4, max_value=1e3, allow_nan=False, allow_infinity=False)


@st.composite
def systeminfos(draw):
    n = draw(st.integers(1, 12))
    fs = draw(finite)
    channels = [ChannelInfo(
        sensor_type=draw(st.sampled_from([SensorType.ACCELEROMETER, SensorType.LOADCELL, SensorType.NONE])),
        location=draw(st.sampled_from(["", "11", "corner C x"])), serial=draw(st.sampled_from(["", "007"])),
        sensitivity=draw(finite), filter_order=draw(st.integers(0, 12)), sampling_rate=fs,
        cutoff_high=draw(st.none() | finite), cutoff_low=draw(st.none() | finite),
        ripple_db=draw(finite), attenuation_db=draw(finite), filters_on=draw(st.integers(0, 7)),
        invert=draw(st.booleans()), offset_start=draw(st.integers(0, 10**6)),
        offset_length=draw(st.integers(0, 10**6)), daq_gain=draw(finite),
        limit_high=draw(half_range), limit_low=-draw(half_range),
    ) for _ in range(n)]
    vec = st.tuples(finite, finite, finite)
    plates = draw(st.lists(vec, max_size=3))
    origins = draw(st.lists(vec, min_size=len(plates), max_size=len(plates))) if draw(st.booleans()) else []
    nine = draw(st.lists(st.integers(0, 12), min_size=9, max_size=9)) if draw(st.booleans()) else []
    rig = RigInfo(use_in_gcc=draw(st.booleans()), use_in_ag=draw(st.booleans()), plate_sizes=plates,
                  plate_origins=origins, plot_from_corner=draw(st.booleans()),
                  coordinate_columns=draw(st.lists(st.integers(0, 12), max_size=2)),
                  rx=draw(st.none() | finite), ry=draw(st.none() | finite), rz=draw(st.none() | finite),
                  nine_channels=nine)
    return Systeminfo(channels=channels, rig=rig)


@settings(max_examples=60, deadline=None)
@given(systeminfos())
def test_any_systeminfo_round_trips_exactly(si):
    text = format_ctr(si)
    back = parse_ctr(text)
    assert back == si  # every float exactly, including mV -> V and mm -> m
    assert format_ctr(back) == text


def _e3_text_with(row: int, col: int, cell: str) -> str:
    rows = [line.split("\t") for line in format_ctr(read_ctr(TABLE_E3)).splitlines()]
    rows[row][col] = cell
    return "\n".join("\t".join(r) for r in rows)


@pytest.mark.parametrize("row, col, cell, message", [
    (7, 3, "abc", r"f\.CTR: row 7 \(sampling frequency\), channel 3: not a number: 'abc'"),
    (3, 2, "nan", r"row 3 \(sensitivity\), channel 2: not a finite number: 'nan'"),
    (5, 4, "7", r"row 5 \(filter type\), channel 4: unknown code 7\.0 \(known: 0 = lowpass"),
    (0, 9, "5", r"row 0 \(sensor type\), channel 9: unknown code 5\.0"),
    (4, 2, "3", r"row 4 \(integration\), channel 2: unknown code 3\.0"),
    (18, 2, "2", r"row 18 \(filter family\), channel 2: unknown code 2\.0"),
    (12, 2, "9", r"row 12 \(filter on/off\), channel 2: expected a bitmask 0\.\.7 .*got 9"),
    (14, 2, "2", r"row 14 \(invert signal\), channel 2: expected 0 \(no\) or 1 \(yes\), got '2'"),
    (6, 2, "7.5", r"row 6 \(filter order\), channel 2: expected an integer, got '7\.5'"),
    (33, 4, "-", r"row 33 \(nine-accelerometer channel assignment\), channel 4: missing value"),
    (23, 1, "-", r"row 23 \(plate widths\), channel 1: missing value"),
    # 1e300 V was read, and a range under 1 mV (every sample of it counted as clipped)
    (19, 0, "1e300", r"row 19 \(DAQ high limit\), channel 0: DAQ limits -5\.0 V to 1e\+300 V: expected volts "
                     r"within \+-1000 V, high at least 0\.001 V above low$"),
    (20, 0, "-1000.5", r"row 20 \(DAQ low limit\), channel 0: DAQ limits -1000\.5 V to 5\.0 V: expected volts"),
    (20, 0, "4.9995", r"row 19 \(DAQ high limit\), channel 0: DAQ limits 4\.9995 V to 5\.0 V: expected volts "
                      r"within \+-1000 V, high at least 0\.001 V above low$"),
])
def test_bad_cells_name_row_channel_and_value(row, col, cell, message):
    with pytest.raises(ConfigError, match=message):
        parse_ctr(_e3_text_with(row, col, cell), source="f.CTR")


def test_file_level_errors(tmp_path):
    with pytest.raises(ConfigError, match=r"nope\.CTR: Systeminfo \(\.CTR\) file not found"):
        read_ctr(tmp_path / "nope.CTR")
    (tmp_path / "empty.CTR").write_text("\n\n")
    with pytest.raises(ConfigError, match=r"empty\.CTR: empty file"):
        read_ctr(tmp_path / "empty.CTR")
    short = "\n".join(format_ctr(read_ctr(TABLE_E3)).splitlines()[:33])
    with pytest.raises(ConfigError, match=r"f: expected 34 rows \(Table E\.2\), found 33"):
        parse_ctr(short, source="f")
    extra = format_ctr(read_ctr(TABLE_E3)).replace("20000\n", "20000\t20000\n", 1)
    with pytest.raises(ConfigError, match=r"f: row 7 .*channel 11: row 0 has 11 channels but this row "
                                          r"has a value '20000' beyond them"):
        parse_ctr(extra, source="f")
    printed = TABLE_E3.read_text().replace("| 5 | 1 | 1 |", "| 6 | 1 | 1 |")
    with pytest.raises(ConfigError, match=r"f: line 9: expected row number 5, got '6'"):
        parse_ctr(printed, source="f")


def test_sensor_type_6_warns_once_per_channel():
    text = _e3_text_with(0, 3, "6")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        si = parse_ctr(text, source="f")
    messages = [str(w.message) for w in caught if issubclass(w.category, OdsuiteWarning)]
    assert len(messages) == 2 and "channel 3: sensor type 6" in messages[1]
    assert si.channels[3].sensor_type is SensorType.AUXILIARY


def test_legacy_on_off_16_reads_as_all_three_filters():
    si = parse_ctr(_e3_text_with(12, 5, "16"))
    assert si.channels[5].filters_on == 7
    assert dataclasses.replace(si.channels[5], filters_on=3) == read_ctr(TABLE_E3).channels[5]


def test_unwritable_text_cell_is_refused():
    si = read_ctr(TABLE_E3)
    si.channels[1].location = "a\tb"
    with pytest.raises(ConfigError, match=r"row 1 \(sensor location\), channel 1: 'a\\tb' cannot be written"):
        format_ctr(si)


def test_windows_spreadsheet_text_reads_the_same():
    """LabVIEW on Windows: CRLF line ends and a tab after the last cell of every row."""
    si = read_ctr(TABLE_E3)
    text = "".join(line + "\t\r\n" for line in format_ctr(si).splitlines())
    assert parse_ctr(text) == si


def test_zero_phase_and_integration_rule_rows_round_trip(tmp_path):
    """odsuite's two extra rows (34 zero-phase, 35 integration rule) are written only when a
    channel departs from the thesis's behaviour, and read back exactly; 34-row files keep it."""
    from dataclasses import replace

    from odsuite_plugins.importers.legacy import format_ctr, parse_ctr, read_ctr
    from odsuite.contracts.plugins import registries

    table = read_ctr(registries().rigs.get("thesis-dynamometer").systeminfo_file)
    assert len(format_ctr(table).splitlines()) == 34
    assert all(not ch.zero_phase and ch.integration_rule == "thesis" for ch in table.channels)
    changed = replace(table, channels=[replace(ch, zero_phase=(k % 2 == 0),
                                               integration_rule="trapezoid" if k > 3 else "thesis")
                                       for k, ch in enumerate(table.channels)])
    text = format_ctr(changed)
    assert len(text.splitlines()) == 36
    back = parse_ctr(text)
    assert [ch.zero_phase for ch in back.channels] == [k % 2 == 0 for k in range(len(table.channels))]
    assert [ch.integration_rule for ch in back.channels] == ["thesis"] * 4 + ["trapezoid"] * (len(table.channels) - 4)
    lines = text.splitlines()
    lines[35] = "\t".join(["2"] + lines[35].split("\t")[1:])
    import pytest

    from odsuite.domain.errors import ConfigError

    with pytest.raises(ConfigError, match=r"row 35 \(integration rule \(odsuite\)\), channel 0: .*'2'"):
        parse_ctr("\n".join(lines) + "\n")
