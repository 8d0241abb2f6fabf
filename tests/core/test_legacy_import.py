"""import_legacy / export_legacy against a generated legacy record and the project file."""

from __future__ import annotations

import hashlib
import math
import warnings

import numpy as np
import pytest

from odsuite.domain.errors import ConfigError, DimensionError, OdsuiteWarning
from odsuite.domain.excitation import parse_force_direction, parse_force_point
from odsuite_plugins.importers.importing import export_legacy, import_legacy
from odsuite_plugins.importers.legacy import read_cod, read_ctr, write_ctr, write_dat
from odsuite.store.project import DerivedArray, create_project, open_project
from tests.core.test_systeminfo import TABLE_E3

pytestmark = pytest.mark.filterwarnings("ignore:.*sensor type 6:odsuite.domain.errors.OdsuiteWarning")

FS = 20000.0


def legacy_volts(n: int = 2048, seed: int = 0) -> np.ndarray:
    """11 channels as the thesis rig records them: a 1 ms hammer pulse on channel 0 (V), a quiet
    auxiliary channel, nine decaying accelerometer responses within +-0.5 V."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    data = rng.normal(scale=2e-3, size=(n, 11))
    hit = (t >= 0.01) & (t < 0.011)
    data[hit, 0] += 0.8 * np.sin(np.pi * (t[hit] - 0.01) / 0.001)
    after = np.clip(t - 0.01, 0, None)
    for k in range(2, 11):
        f = 120 + 10 * k
        data[:, k] += 0.3 * np.exp(-after * 40) * np.sin(2 * np.pi * f * after) * (t >= 0.01)
    return data


@pytest.fixture
def legacy_set(tmp_path):
    data = legacy_volts()
    write_dat(tmp_path / "T8.DAT", data)
    return tmp_path / "T8.DAT", TABLE_E3, data


@pytest.fixture
def project(tmp_path):
    path = tmp_path / "p.h5"
    create_project(path).close()
    return path


def _hash(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_import_stores_raw_volts_systeminfo_and_excitation(project, legacy_set):
    dat, ctr, data = legacy_set
    assert import_legacy(project, dat, ctr, "T8", "0,4.122,-11.399", "+z") == "T8"
    with open_project(project) as p:
        e = p.experiment("T8")
        np.testing.assert_array_equal(e.raw(), data)  # the .DAT holds volts: stored unchanged
        assert e.sampling_rate == FS and e.n_channels == 11 and e.n_samples == 2048
        assert e.systeminfo == read_ctr(ctr)
        assert e.excitation.force_channel == 0
        np.testing.assert_allclose(e.excitation.point, [0.0, 0.004122, -0.011399], rtol=1e-15)
        np.testing.assert_array_equal(e.excitation.direction, [0.0, 0.0, 1.0])
        assert "T8.DAT" in e.source
        assert p.info()["experiments"]["T8"]["clipped"] == []


def test_force_point_and_direction_parsing():
    np.testing.assert_allclose(parse_force_point("50.025,-75.761,-6.320"), [0.050025, -0.075761, -0.00632])
    np.testing.assert_allclose(parse_force_point([1, 2, 3]), [0.001, 0.002, 0.003])
    for text, vec in (("+x", (1, 0, 0)), ("-x", (-1, 0, 0)), ("+y", (0, 1, 0)), ("-y", (0, -1, 0)),
                      ("+z", (0, 0, 1)), ("-Z", (0, 0, -1)), ("1,1,0", (math.sqrt(0.5), math.sqrt(0.5), 0)),
                      ("0,0,-3", (0, 0, -1))):
        np.testing.assert_allclose(parse_force_direction(text), vec, rtol=1e-15)


@pytest.mark.parametrize("point, direction, message", [
    ("1,2", "+z", r"--force-point: expected three numbers X,Y,Z, got '1,2'"),
    ("a,b,c", "+z", r"--force-point: expected three numbers X,Y,Z, got 'a,b,c'"),
    ("nan,0,0", "+z", r"--force-point: expected finite numbers, got 'nan,0,0'"),
    ("0,0,0", "0,0,0", r"--force-dir: the zero vector '0,0,0' has no direction"),
    ("0,0,0", "+w", r"--force-dir: expected an axis \+x, -x, \+y, -y, \+z, -z or three numbers dx,dy,dz, got '\+w'"),
    ("0,0,0", "inf,0,0", r"--force-dir: expected finite numbers, got 'inf,0,0'"),
])
def test_bad_excitation_options(project, legacy_set, point, direction, message):
    dat, ctr, _ = legacy_set
    before = _hash(project)
    with pytest.raises(ConfigError, match=message):
        import_legacy(project, dat, ctr, "T8", point, direction)
    assert _hash(project) == before


def _write(path, text):
    path.write_text(text)
    return path


@pytest.mark.parametrize("make, error, message", [
    (lambda d, v: d / "missing.DAT", ConfigError, r"missing\.DAT: data \(\.DAT/\.VIZ\) file not found"),
    (lambda d, v: _write(d / "e.DAT", ""), ConfigError, r"e\.DAT: empty file"),
    (lambda d, v: (write_dat(d / "c.DAT", v[:, :10]), d / "c.DAT")[1], DimensionError,
     r"c\.DAT: 10 columns, but the Systeminfo describes 11 channels"),
    (lambda d, v: _write(d / "n.DAT", "0\t" * 10 + "0\n" + "0\t" * 5 + "x\t" + "0\t" * 4 + "0\n"),
     ConfigError, r"n\.DAT: line 2, column 5: not a number: 'x'"),
    (lambda d, v: _write(d / "i.DAT", "0\t" * 10 + "0\n" + "0\t" * 3 + "inf\t" + "0\t" * 6 + "0\n"),
     ConfigError, r"i\.DAT: line 2, column 3: not a finite number: 'inf'"),
    (lambda d, v: _write(d / "r.DAT", "0\t" * 10 + "0\n" + "0\t" * 9 + "0\n"),
     ConfigError, r"r\.DAT: line 2: ragged row, expected 11 cells \(as line 1\), found 10"),
    # Table E.3 averages samples 0..399 of channel 0: a 300-sample record is too short
    (lambda d, v: (write_dat(d / "s.DAT", v[:300]), d / "s.DAT")[1], ConfigError,
     r"thesis-table-e3\.CTR: row 16 \(offset length\), channel 0: offset window samples 0\.\.399 lies "
     r"outside the record of 300 samples"),
])
def test_bad_data_leaves_the_project_unchanged(project, legacy_set, tmp_path, make, error, message):
    _, ctr, data = legacy_set
    import_legacy(project, legacy_set[0], ctr, "first", "0,0,0", "+z")
    before = _hash(project)
    with pytest.raises(error, match=message):
        import_legacy(project, make(tmp_path, data), ctr, "T8", "0,4.122,-11.399", "+z")
    assert _hash(project) == before
    with open_project(project) as p:
        assert p.experiment_names() == ["first"]


def test_bad_systeminfo_and_duplicate_name_leave_the_project_unchanged(project, legacy_set, tmp_path):
    dat, ctr, _ = legacy_set
    si = read_ctr(ctr)
    si.channels[3].sampling_rate = -1.0
    write_ctr(si, tmp_path / "bad.CTR")
    before = _hash(project)
    with pytest.raises(ConfigError, match=r"bad\.CTR: row 7 \(sampling frequency\), channel 3: .*got -1\.0"):
        import_legacy(project, dat, tmp_path / "bad.CTR", "T8", "0,0,0", "+z")
    with pytest.raises(ConfigError, match=r"nope\.CTR: Systeminfo \(\.CTR\) file not found"):
        import_legacy(project, dat, tmp_path / "nope.CTR", "T8", "0,0,0", "+z")
    assert _hash(project) == before
    import_legacy(project, dat, ctr, "T8", "0,0,0", "+z")
    after = _hash(project)
    with pytest.raises(ConfigError, match=r"experiment 'T8' already exists"):
        import_legacy(project, dat, ctr, "T8", "0,0,0", "+z")
    assert _hash(project) == after


def test_clipping_warns_and_is_flagged(project, tmp_path):
    data = legacy_volts()
    data[500:530, 4] = 5.0  # zC: Table E.3 row 19 = 5 V
    data[600:605, 2] = -0.5  # xC: row 20 = -0.5 V
    write_dat(tmp_path / "clip.DAT", data)
    with pytest.warns(OdsuiteWarning, match=r"clip\.DAT: samples at the DAQ limits \(clipped\) on "
                                            r"xC \(5 samples\), zC \(30 samples\)"):
        import_legacy(project, tmp_path / "clip.DAT", TABLE_E3, "clip", "0,0,0", "-z")
    with open_project(project) as p:
        assert p.info()["experiments"]["clip"]["clipped"] == ["xC", "zC"]


def test_project_without_rig_takes_the_load_cell_as_force_channel(tmp_path, legacy_set):
    dat, ctr, _ = legacy_set
    create_project(tmp_path / "free.h5", None).close()
    import_legacy(tmp_path / "free.h5", dat, ctr, "T8", "0,0,0", "+x")
    with open_project(tmp_path / "free.h5") as p:
        assert p.experiment("T8").excitation.force_channel == 0


def test_export_legacy_writes_the_stored_coordinates(project, legacy_set, tmp_path):
    dat, ctr, _ = legacy_set
    import_legacy(project, dat, ctr, "T8", "0,0,0", "+z")
    with pytest.raises(ConfigError, match=r"experiment 'T8': no generalized coordinates: run "
                                          r"`odsuite process PROJECT` first"):
        export_legacy(project, "T8", tmp_path / "x.COD")
    rng = np.random.default_rng(2)
    at_g, at_c = rng.normal(size=(2048, 6)), rng.normal(size=(2048, 6))
    with open_project(project, "a") as p:
        p.write_derived("T8", "gencoords", {
            "platform_at_g": DerivedArray(at_g, "m|rad", ("sample", "coordinate")),
            "platform_at_c": DerivedArray(at_c, "m|rad", ("sample", "coordinate")),
        }, provenance={"plugin": "test", "version": "0", "parameters": {}, "inputs": []})
    export_legacy(project, "T8", tmp_path / "g.COD")
    export_legacy(project, "T8", tmp_path / "c.COD", at="corner")
    (g,), (c,) = read_cod(tmp_path / "g.COD"), read_cod(tmp_path / "c.COD")
    np.testing.assert_array_equal(g, at_g)
    np.testing.assert_array_equal(c, at_c)
    with pytest.raises(ConfigError, match=r"--at: expected one of center, corner, got 'middle'"):
        export_legacy(project, "T8", tmp_path / "m.COD", at="middle")
    with pytest.raises(ConfigError, match=r"no experiment named 'T9'"):
        export_legacy(project, "T9", tmp_path / "m.COD")


def test_no_warning_on_a_clean_record(project, legacy_set):
    dat, ctr, _ = legacy_set
    with warnings.catch_warnings():
        warnings.filterwarnings("error", message=".*clipped.*")
        import_legacy(project, dat, ctr, "T8", "0,0,0", "+z")
