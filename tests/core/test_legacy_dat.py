""".DAT/.VIZ and .COD codecs: exact round trips, LabVIEW's time column, one-line errors."""

from __future__ import annotations

import numpy as np
import pytest

from odsuite.domain.errors import ConfigError, DimensionError
from odsuite_plugins.importers.legacy import read_cod, read_dat, read_table, write_cod, write_dat


@pytest.fixture
def volts() -> np.ndarray:
    rng = np.random.default_rng(7)
    data = rng.normal(scale=0.05, size=(257, 11))
    data[0, 0] = 1e-300  # extremes keep their exact value too
    data[1, 1] = -4.999999999999999
    return data


def test_dat_round_trips_exactly(tmp_path, volts):
    write_dat(tmp_path / "a.DAT", volts)
    rec = read_dat(tmp_path / "a.DAT", n_channels=11, sampling_rate=20000.0)
    assert rec.time is None
    np.testing.assert_array_equal(rec.data, volts)
    assert (tmp_path / "a.DAT").read_text().count("\t") == 257 * 10


def test_whitespace_separated_and_integers(tmp_path):
    (tmp_path / "w.VIZ").write_text("1  2.5 -3\n4 5e-3\t6\n\n")
    np.testing.assert_array_equal(read_dat(tmp_path / "w.VIZ", 3).data, [[1, 2.5, -3], [4, 5e-3, 6]])


def test_time_column_is_detected_and_split(tmp_path, volts):
    fs = 20000.0
    t = np.round(np.arange(volts.shape[0]) / fs, 6)  # LabVIEW wrote 6 digits after the point
    write_dat(tmp_path / "t.DAT", volts, time=t)
    rec = read_dat(tmp_path / "t.DAT", n_channels=11, sampling_rate=fs)
    np.testing.assert_array_equal(rec.data, volts)
    np.testing.assert_array_equal(rec.time, t)
    # the same column at a different sampling rate is not a time column: a column-count error
    with pytest.raises(DimensionError, match=r"t\.DAT: 12 columns, but the Systeminfo describes 11 channels"):
        read_dat(tmp_path / "t.DAT", n_channels=11, sampling_rate=10000.0)


def test_extra_non_time_column_is_a_column_count_error(tmp_path, volts):
    write_dat(tmp_path / "x.DAT", np.column_stack([volts, volts[:, 0]]))
    with pytest.raises(DimensionError, match=r"x\.DAT: 12 columns, but the Systeminfo describes 11 channels"):
        read_dat(tmp_path / "x.DAT", n_channels=11, sampling_rate=20000.0)
    with pytest.raises(DimensionError, match=r"x\.DAT: 12 columns, but the Systeminfo describes 13 channels"):
        read_dat(tmp_path / "x.DAT", n_channels=13, sampling_rate=20000.0)


@pytest.mark.parametrize("text, message", [
    ("1\t2\t3\n4\t5\t6\n7\t8\n", r"b\.DAT: line 3: ragged row, expected 3 cells \(as line 1\), found 2"),
    ("1\t2\t3\n4\t\t6\n", r"b\.DAT: line 2: ragged row, expected 3 cells \(as line 1\), found 2"),
    ("1\t2\t3\n4\t5,1\t6\n", r"b\.DAT: line 2, column 1: not a number: '5,1'"),
    ("1\t2\t3\n4\t5\tabc\n", r"b\.DAT: line 2, column 2: not a number: 'abc'"),
    ("1\t2\t3\n\n4\tnan\t6\n", r"b\.DAT: line 3, column 1: not a finite number: 'nan'"),
    ("1\t2\t-inf\n", r"b\.DAT: line 1, column 2: not a finite number: '-inf'"),
    ("", r"b\.DAT: empty file, expected a data \(\.DAT/\.VIZ\) table"),
    (" \n\t\n", r"b\.DAT: empty file"),
])
def test_bad_data_files(tmp_path, text, message):
    (tmp_path / "b.DAT").write_text(text)
    with pytest.raises(ConfigError, match=message):
        read_dat(tmp_path / "b.DAT", n_channels=3)


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match=r"none\.DAT: data \(\.DAT/\.VIZ\) file not found"):
        read_dat(tmp_path / "none.DAT")
    with pytest.raises(ConfigError, match=r"is a directory"):
        read_table(tmp_path)


def test_cod_two_plates_round_trip(tmp_path):
    rng = np.random.default_rng(3)
    platform, base = rng.normal(scale=1e-6, size=(100, 6)), rng.normal(scale=1e-7, size=(100, 6))
    write_cod(tmp_path / "m.COD", [platform, base])
    first = (tmp_path / "m.COD").read_text().splitlines()[0].split("\t")
    assert len(first) == 12 and float(first[0]) == platform[0, 0] and float(first[6]) == base[0, 0]
    back = read_cod(tmp_path / "m.COD")
    assert len(back) == 2
    np.testing.assert_array_equal(back[0], platform)
    np.testing.assert_array_equal(back[1], base)


def test_cod_errors(tmp_path):
    (tmp_path / "s.COD").write_text("\t".join(["0"] * 7) + "\n")
    with pytest.raises(DimensionError, match=r"s\.COD: 7 columns, expected 6 per plate"):
        read_cod(tmp_path / "s.COD")
    with pytest.raises(DimensionError, match=r"plate 1 has shape \(9, 6\), expected \(10, 6\)"):
        write_cod(tmp_path / "o.COD", [np.zeros((10, 6)), np.zeros((9, 6))])


def test_windows_line_ends(tmp_path, volts):
    text = "".join("\t".join(map(repr, row)) + "\r\n" for row in volts.tolist())
    (tmp_path / "w.DAT").write_bytes(text.encode())
    np.testing.assert_array_equal(read_dat(tmp_path / "w.DAT", 11).data, volts)
