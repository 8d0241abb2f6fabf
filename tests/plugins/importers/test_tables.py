"""CSV, .npy, .mat and TDMS records written by their own libraries (csv, numpy, scipy.io, npTDMS),
imported through the registry: numbers, names and units exact; onto a rig by channel name; each
malformed file refused in one line naming file, field or channel and value."""

from __future__ import annotations

import csv
import re
import struct
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from odsuite.analysis.modal_project import physical
from odsuite.domain.errors import OdsuiteError
from odsuite.store.project import create_project, open_project

G = 9.80665
RIG = Path(__file__).resolve().parents[3] / "projects" / "rigs" / "two-body-machine.toml"
RNG = np.random.default_rng(7)
DATA = RNG.normal(size=(500, 3))
NAMES = ["acc1", "acc2", "force"]
UNITS = ["m/s^2", "g", "N"]
FS = 2048.0


def _import(registries, project, file, name="rec", **options):
    from odsuite.contracts.importers import check_options, choose_importer

    imp = choose_importer(registries.importers, file, options.pop("fmt", None))
    return imp.import_file(project, file, name, **check_options(imp, options))


def _write_csv(path: Path, data=DATA, names=NAMES, units=UNITS, time=True):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow((["time"] if time else []) + [f"{n} [{u}]" for n, u in zip(names, units)])
        for k, row in enumerate(data):
            w.writerow(([repr(k / FS)] if time else []) + [repr(float(v)) for v in row])


def _write_tdms(path: Path, data=DATA, names=NAMES, units=UNITS, step=1 / FS):
    from nptdms import ChannelObject, GroupObject, TdmsWriter

    with TdmsWriter(str(path)) as w:
        w.write_segment([GroupObject("Measurements")] + [
            ChannelObject("Measurements", n, data[:, k], properties={"unit_string": u, "wf_increment": step})
            for k, (n, u) in enumerate(zip(names, units))])


def _written(tmp_path: Path, fmt: str) -> Path:
    """The record DATA (names, units, FS) in format ``fmt``, written by that format's own library."""
    if fmt == "csv":
        _write_csv(tmp_path / "r.csv")
    elif fmt == "npy":
        np.save(tmp_path / "r.npy", DATA)
        (tmp_path / "r.toml").write_text(f'sampling_rate = {FS}\nchannels = {NAMES!r}\nunits = {UNITS!r}\n'
                                         .replace("'", '"'))
    elif fmt == "mat":
        scipy.io.savemat(tmp_path / "r.mat", {"data": DATA, "fs": FS, "channels": np.array(NAMES, dtype=object),
                                              "units": np.array(UNITS, dtype=object)})
    else:
        _write_tdms(tmp_path / "r.tdms")
    return next(tmp_path.glob(f"r.{fmt}"))


@pytest.mark.parametrize("fmt", ["csv", "npy", "mat", "tdms"])
def test_each_format_imports_numbers_names_and_units(tmp_path, registries, fmt):
    file = _written(tmp_path, fmt)
    create_project(tmp_path / "p.h5", rig=None).close()
    res = _import(registries, tmp_path / "p.h5", file)
    assert "acc2 [g]" in res.summary
    with open_project(tmp_path / "p.h5") as p:
        exp = p.experiment("rec")
        assert exp.channel_names == NAMES
        assert exp.sampling_rate == pytest.approx(FS, rel=1e-12)
        si = physical(exp)
        # SI inside: m/s^2 as it is, g times 9.80665, newtons as they are
        assert np.allclose(si[:, 0], DATA[:, 0], rtol=1e-12, atol=0)
        assert np.allclose(si[:, 1], DATA[:, 1] * G, rtol=1e-12, atol=0)
        assert np.allclose(si[:, 2], DATA[:, 2], rtol=1e-12, atol=0)
        assert exp.excitation is not None and exp.excitation.force_channel == 2  # the column in N


@pytest.mark.parametrize("fmt", ["csv", "tdms"])
def test_a_record_goes_onto_the_rig_by_channel_name(tmp_path, registries, fmt):
    names, units = ["b1_z", "m1_x", "m2_y"], ["m/s^2", "g", "m/s^2"]
    if fmt == "csv":
        file = tmp_path / "r.csv"
        _write_csv(file, names=names, units=units)
    else:
        file = tmp_path / "r.tdms"
        _write_tdms(file, names=names, units=units)
    create_project(tmp_path / "p.h5", rig=str(RIG)).close()
    res = _import(registries, tmp_path / "p.h5", file)
    assert any("operating record" in n for n in res.notes)
    with open_project(tmp_path / "p.h5") as p:
        exp = p.experiment("rec")
        ch = {s.name: s.channel for s in p.rig.sensors}
        si = physical(exp)
        assert np.allclose(si[:, ch["b1_z"]], DATA[:, 0], rtol=1e-12)
        assert np.allclose(si[:, ch["m1_x"]], DATA[:, 1] * G, rtol=1e-12)
        assert np.allclose(si[:, ch["m2_y"]], DATA[:, 2], rtol=1e-12)


def _bad(tmp_path: Path, case: str) -> tuple[Path, dict]:
    t = tmp_path
    if case == "empty csv":
        (t / "r.csv").write_text("")
        return t / "r.csv", {}
    if case == "binary csv":  # a sparse file: a header, then zeros (the csv module took 12 GB for 2 GiB)
        with open(t / "r.csv", "wb") as f:
            f.write(b"a [g]\n")
            f.truncate(1 << 20)
        return t / "r.csv", {"rate": 100.0}
    if case == "ragged csv":
        (t / "r.csv").write_text("time,a [g],b [g]\n0,1,2\n0.001,3\n")
        return t / "r.csv", {}
    if case == "text in numbers":
        (t / "r.csv").write_text("time,a [g],b [g]\n0,1,2\n0.001,3,abc\n")
        return t / "r.csv", {}
    if case == "nan":
        (t / "r.csv").write_text("time,a [g],b [g]\n0,1,2\n0.001,nan,4\n")
        return t / "r.csv", {}
    if case == "unknown unit":
        (t / "r.csv").write_text("time,a [furlong],b [g]\n0,1,2\n0.001,3,4\n")
        return t / "r.csv", {}
    if case == "missing rate":
        np.save(t / "r.npy", DATA)
        return t / "r.npy", {"units": "g"}
    if case == "wrong shape":
        np.save(t / "r.npy", np.zeros((4, 3, 2)))
        return t / "r.npy", {"rate": 100.0, "units": "g"}
    if case == "names for other columns":
        np.save(t / "r.npy", DATA)
        return t / "r.npy", {"rate": 100.0, "units": "g", "channels": "a,b"}
    if case == "mat without arrays":
        scipy.io.savemat(t / "r.mat", {"note": "no numbers here"})
        return t / "r.mat", {"rate": 100.0, "units": "g"}
    if case == "truncated tdms":
        _write_tdms(t / "full.tdms")
        blob = (t / "full.tdms").read_bytes()
        (t / "r.tdms").write_bytes(blob[: len(blob) // 2])
        return t / "r.tdms", {}
    raise AssertionError(case)


@pytest.mark.parametrize("case, words", [
    ("empty csv", ["r.csv", "empty"]),
    ("binary csv", ["r.csv", "NUL character at line 2", "binary data"]),
    ("ragged csv", ["r.csv", "line 3", "2 fields", "header has 3"]),
    ("text in numbers", ["r.csv", "line 3", "channel 'b'", "'abc'"]),
    ("nan", ["r.csv", "channel 'a'", "sample 1", "nan"]),
    ("unknown unit", ["r.csv", "channel 'a'", "'furlong'"]),
    ("missing rate", ["r.npy", "sampling_rate", "--rate"]),
    ("wrong shape", ["r.npy", "data", "(4, 3, 2)"]),
    ("names for other columns", ["r.npy", "channels", "2 given for 3"]),
    ("mat without arrays", ["r.mat", "variable", "no numeric array"]),
    ("truncated tdms", ["r.tdms", "cut short"]),
])
def test_a_malformed_file_is_one_line(tmp_path, registries, case, words):
    file, options = _bad(tmp_path, case)
    create_project(tmp_path / "p.h5", rig=None).close()
    with pytest.raises(OdsuiteError) as err:
        _import(registries, tmp_path / "p.h5", file, **options)
    message = str(err.value)
    assert "\n" not in message
    for w in words:
        assert w in message, (w, message)
    with open_project(tmp_path / "p.h5") as p:
        assert p.experiment_names() == []  # nothing stored


def test_options_override_the_sidecar_and_mat_v73_is_read(tmp_path, registries):
    h5py = pytest.importorskip("h5py")
    # a v7.3 file is HDF5 with MATLAB's column-major layout: channels x samples on disk
    with h5py.File(tmp_path / "r.mat", "w", userblock_size=512) as f:
        f.create_dataset("acc", data=DATA[:, :2].T)
    header = b"MATLAB 7.3 MAT-file, written as MATLAB does".ljust(116) + bytes(8) + b"\x00\x02IM"
    with open(tmp_path / "r.mat", "r+b") as f:
        f.write(header)
    create_project(tmp_path / "p.h5", rig=None).close()
    _import(registries, tmp_path / "p.h5", tmp_path / "r.mat", rate=FS, units="m/s^2,g", channels="x,y")
    with open_project(tmp_path / "p.h5") as p:
        exp = p.experiment("rec")
        assert exp.channel_names == ["x", "y"]
        assert np.allclose(physical(exp), DATA[:, :2] * [1.0, G], rtol=1e-12)


def test_a_channels_by_samples_npy_is_read_transposed(tmp_path, registries):
    np.save(tmp_path / "r.npy", DATA.T)  # 3 x 500, as MATLAB users often store
    create_project(tmp_path / "p.h5", rig=None).close()
    _import(registries, tmp_path / "p.h5", tmp_path / "r.npy", rate=FS, units="m/s^2")
    with open_project(tmp_path / "p.h5") as p:
        exp = p.experiment("rec")
        assert exp.channel_names == ["ch1", "ch2", "ch3"] and exp.n_samples == 500
        assert np.allclose(physical(exp), DATA, rtol=1e-12)


@pytest.mark.parametrize("delimiter, encoding", [(";", "utf-8"), ("\t", "utf-8"), ("\t", "utf-16")])
def test_a_csv_of_a_decimal_comma_locale_is_read(tmp_path, registries, delimiter, encoding):
    """Fields separated by semicolons or tabs, numbers with decimal commas (what spreadsheets in
    such locales write, by Python's csv module with the locale's number format): the same numbers,
    names and units as the comma file. A spreadsheet's "Unicode text" is UTF-16 with its byte-order
    mark (it was refused as undecodable UTF-8)."""
    path = tmp_path / "r.csv"
    with open(path, "w", newline="", encoding=encoding) as f:
        w = csv.writer(f, delimiter=delimiter)
        w.writerow(["time"] + [f"{n} [{u}]" for n, u in zip(NAMES, UNITS)])
        for k, row in enumerate(DATA):
            w.writerow([repr(k / FS).replace(".", ",")] + [repr(float(v)).replace(".", ",") for v in row])
    create_project(tmp_path / "p.h5", rig=None).close()
    _import(registries, tmp_path / "p.h5", path)
    with open_project(tmp_path / "p.h5") as p:
        exp = p.experiment("rec")
        assert exp.channel_names == NAMES and exp.sampling_rate == pytest.approx(FS, rel=1e-12)
        si = physical(exp)
        assert np.allclose(si, DATA * [1.0, G, 1.0], rtol=1e-12, atol=0)


def _write_timed_csv(path: Path, times: list[str]) -> None:
    """DATA's first len(times) rows with the time column as given (text, as a lab's program wrote it)."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time [s]"] + [f"{n} [{u}]" for n, u in zip(NAMES, UNITS)])
        for t, row in zip(times, DATA):
            w.writerow([t] + [repr(float(v)) for v in row])


@pytest.mark.parametrize("fmt", ["%.6f", "%.9f", "%.6g", "%.4e", "%.5f"])
def test_a_csv_whose_times_are_rounded_is_read_at_the_rate_of_its_span(tmp_path, registries, fmt):
    """4096 Hz with times rounded to 6 decimals has steps of 0.000244 and 0.000245 s (9 decimals:
    0.000244140 and 0.000244141): evenly spaced within the printed precision; the rate is 4096 Hz,
    the fewest digits the span's rounded ends allow."""
    fs = 4096.0
    _write_timed_csv(tmp_path / "r.csv", [fmt % (k / fs) for k in range(len(DATA))])
    create_project(tmp_path / "p.h5", rig=None).close()
    _import(registries, tmp_path / "p.h5", tmp_path / "r.csv")
    with open_project(tmp_path / "p.h5") as p:
        exp = p.experiment("rec")
        assert exp.sampling_rate == fs and exp.n_samples == len(DATA)
        assert np.allclose(physical(exp), DATA * [1.0, G, 1.0], rtol=1e-12, atol=0)


@pytest.mark.parametrize("case, line, value, words", [
    ("a sample missing", 302, "0.073486", ["0.000488 s after the time before it", "allows 1e-06 s"]),
    ("one time late by 3 units", 302, "0.073245", ["0.000247 s after", "mean step 0.00024414 s"]),
    ("a rate 1e-3 faster at the end", 9, "0.001709", ["1.7e-06 s off the even spacing", "allows 1.5e-06 s"]),
    ("a time before the one above", 7, "0.000000", ["does not come after", "'0.000977'"]),
])
def test_unevenly_sampled_rounded_times_are_refused_in_one_line(tmp_path, registries, case, line, value, words):
    """Times of 6 decimals off the even spacing by more than their rounding: refused naming file,
    column, row (its line) and value."""
    fs, n = 4096.0, len(DATA)
    t = np.arange(n) / fs
    if case == "a sample missing":
        t = np.delete(t, 300)
    elif case == "one time late by 3 units":
        t[300] += 3e-6
    elif case == "a rate 1e-3 faster at the end":
        t = t * (1 + 1e-3 * np.arange(n) / n)
    else:
        t[5] = 0.0
    _write_timed_csv(tmp_path / "r.csv", ["%.6f" % x for x in t])
    create_project(tmp_path / "p.h5", rig=None).close()
    with pytest.raises(OdsuiteError) as err:
        _import(registries, tmp_path / "p.h5", tmp_path / "r.csv")
    message = str(err.value)
    assert "\n" not in message
    for w in ["r.csv", f"line {line}", "channel 'time'", f"value {value!r}", *words]:
        assert w in message, (w, message)
    with open_project(tmp_path / "p.h5") as p:
        assert p.experiment_names() == []


@pytest.mark.parametrize("text, line, words", [
    # a value that is not a number after blank lines (a spreadsheet's empty rows): its line in the file
    ("\ntime,a [g],b [g]\n0,1,2\n\n\n0.001,3,4\n\n0.002,5,abc\n", 8, ["channel 'b'", "'abc'"]),
    # a row of too few fields, and a time that goes back, each after blank lines
    ("time,a [g],b [g]\n\n0,1,2\n\n0.001,3\n", 5, ["2 fields"]),
    ("time,a [g],b [g]\n0,1,2\n\n0.001,3,4\n\n\n0.0005,5,6\n", 7, ["channel 'time'", "does not come after"]),
    # a quoted field holding a line break counts its lines: the next row's line is the file's
    ('time,a [g],b [g]\n0,1,"2\n"\n\n0.001,3,x\n', 5, ["channel 'b'", "'x'"]),
])
def test_a_csv_refusal_names_the_files_line_across_blank_lines(tmp_path, registries, text, line, words):
    (tmp_path / "r.csv").write_text(text)
    create_project(tmp_path / "p.h5", rig=None).close()
    with pytest.raises(OdsuiteError) as err:
        _import(registries, tmp_path / "p.h5", tmp_path / "r.csv")
    message = str(err.value)
    for w in ["r.csv", f"line {line}:", *words]:
        assert w in message, (w, message)


def test_a_binary_csv_is_refused_at_its_first_block(tmp_path, registries, monkeypatch):
    # a 64 MiB sparse file: refused on the bytes of its first block, before the whole file is
    # read and decoded (the refusal of a 2 GiB one had taken 10 s and 4 GB)
    with open(tmp_path / "r.csv", "wb") as f:
        f.write(b"a [g]\n1.0\n")
        f.truncate(64 << 20)
    monkeypatch.setattr(Path, "read_bytes", lambda self: pytest.fail(f"{self} read whole"))
    create_project(tmp_path / "p.h5", rig=None).close()
    with pytest.raises(OdsuiteError, match=r"r\.csv: not a CSV table: a NUL character at line 3 \(binary data\)"):
        _import(registries, tmp_path / "p.h5", tmp_path / "r.csv", rate=100.0)


def test_a_nul_in_a_utf16_csv_is_refused(tmp_path, registries):
    # UTF-16's bytes hold NULs in every ASCII character: its decoded text is what is checked
    (tmp_path / "r.csv").write_bytes("a [g]\n1.0\n\x002.0\n".encode("utf-16"))
    create_project(tmp_path / "p.h5", rig=None).close()
    with pytest.raises(OdsuiteError, match=r"NUL character at line 3"):
        _import(registries, tmp_path / "p.h5", tmp_path / "r.csv", rate=100.0)


@pytest.mark.parametrize("header, scale, delimiter", [("time [ms]", 1e3, ","), ("t (us)", 1e6, ";"), ("time [s]", 1.0, ",")])
def test_a_time_column_in_ms_or_us_gives_the_rate_per_second(tmp_path, registries, header, scale, delimiter):
    # 'time [ms]' was read as seconds: 4 Hz for a 4000 Hz record, silently
    t = np.arange(400) / 4000.0
    rows = [f"{header}{delimiter}a1 [g]"] + [f"{x * scale:.6f}{delimiter}{np.sin(600 * x):.6f}" for x in t]
    text = "\n".join(rows) + "\n"
    (tmp_path / "r.csv").write_text(text.replace(".", ",") if delimiter == ";" else text)
    create_project(tmp_path / "p.h5", rig=None).close()
    _import(registries, tmp_path / "p.h5", tmp_path / "r.csv")
    with open_project(tmp_path / "p.h5") as p:
        assert p.experiment("rec").sampling_rate == 4000.0


def test_a_time_column_in_another_unit_is_refused(tmp_path, registries):
    (tmp_path / "r.csv").write_text("time [h],a1 [g]\n0,1\n1,2\n")
    create_project(tmp_path / "p.h5", rig=None).close()
    with pytest.raises(OdsuiteError, match=r"r\.csv: channel 'time': time unit 'h' is not one of s, ms, us"):
        _import(registries, tmp_path / "p.h5", tmp_path / "r.csv")


def _tdms_cut_at(path: Path, where: str) -> int:
    """A two-segment TDMS file (the record, then 500 samples more) cut ``where``; the length it keeps."""
    import struct

    from nptdms import ChannelObject, TdmsWriter

    _write_tdms(path)
    with TdmsWriter(str(path), mode="a") as w:
        w.write_segment([ChannelObject("Measurements", n, DATA[:, k]) for k, n in enumerate(NAMES)])
    blob = path.read_bytes()
    next_offset, meta = struct.unpack("<QQ", blob[12:28])
    second = 28 + next_offset
    keep = {"inside the lead-in": 10, "after the lead-in": 28, "inside the metadata": 28 + meta - 5,
            "inside the data": 28 + meta + 100, "before the data's last byte": second - 1,
            "inside the second lead-in": second + 10, "inside the second segment's data": len(blob) - 3}[where]
    path.write_bytes(blob[:keep])
    return keep


@pytest.mark.parametrize("where", ["inside the lead-in", "after the lead-in", "inside the metadata", "inside the data",
                                   "before the data's last byte", "inside the second lead-in",
                                   "inside the second segment's data"])
def test_a_tdms_file_cut_anywhere_is_refused_as_cut_short(tmp_path, registries, where):
    # cut inside the first metadata npTDMS read no groups ('name one with --group'); cut inside a later
    # lead-in, a file of fewer samples was imported
    keep = _tdms_cut_at(tmp_path / "r.tdms", where)
    create_project(tmp_path / "p.h5", rig=None).close()
    with pytest.raises(OdsuiteError) as err:
        _import(registries, tmp_path / "p.h5", tmp_path / "r.tdms")
    message = str(err.value)
    assert message.startswith(f"{tmp_path / 'r.tdms'}: cut short at byte {keep}: the segment at byte ")
    assert "\n" not in message and "--group" not in message
    with open_project(tmp_path / "p.h5") as p:
        assert p.experiment_names() == []


def test_an_empty_tdms_file_is_refused_as_empty(tmp_path, registries):
    (tmp_path / "r.tdms").write_bytes(b"")
    create_project(tmp_path / "p.h5", rig=None).close()
    with pytest.raises(OdsuiteError, match=r"r\.tdms: empty: 0 bytes, no TDMS segment$"):
        _import(registries, tmp_path / "p.h5", tmp_path / "r.tdms")


def test_a_tdms_file_of_many_groups_names_a_few(tmp_path, registries):
    # each of 3000 groups was named in the message asking for --group
    from nptdms import ChannelObject, GroupObject, TdmsWriter

    with TdmsWriter(str(tmp_path / "r.tdms")) as w:
        w.write_segment([GroupObject(f"run{i}") for i in range(3000)] + [
            ChannelObject(f"run{i}", "a1", DATA[:4, 0], properties={"unit_string": "g"}) for i in range(3000)])
    create_project(tmp_path / "p.h5", rig=None).close()
    with pytest.raises(OdsuiteError) as err:
        _import(registries, tmp_path / "p.h5", tmp_path / "r.tdms")
    assert str(err.value) == (f"{tmp_path / 'r.tdms'}: group: 3000 groups (run0, run1, run2, run3, run4, run5, run6, "
                              "run7, ... (3000 in all)); name one with --group")
    with pytest.raises(OdsuiteError) as err:
        _import(registries, tmp_path / "p.h5", tmp_path / "r.tdms", group="run3000")
    assert str(err.value).endswith("group: no 'run3000' (groups: run0, run1, run2, run3, run4, run5, run6, run7, "
                                   "... (3000 in all))")


@pytest.mark.parametrize("compressed", [False, True])
@pytest.mark.parametrize("where", ["inside the header", "inside a tag", "inside the data", "inside the last variable"])
def test_a_mat_file_cut_short_is_refused_naming_where(tmp_path, registries, compressed, where):
    # scipy read a file cut inside a tag as one without its later variables, and named a cut header
    # 'index out of range'
    scipy.io.savemat(tmp_path / "full.mat", {"data": DATA, "fs": FS, "units": "g"}, do_compression=compressed)
    blob = (tmp_path / "full.mat").read_bytes()
    first = 128 + 8 + int.from_bytes(blob[132:136], "little")  # the end of the first variable
    first += 0 if compressed else -first % 8
    keep = {"inside the header": 60, "inside a tag": first + 3, "inside the data": 128 + 8 + 40,
            "inside the last variable": len(blob) - 1}[where]
    (tmp_path / "r.mat").write_bytes(blob[:keep])
    create_project(tmp_path / "p.h5", rig=None).close()
    with pytest.raises(OdsuiteError) as err:
        _import(registries, tmp_path / "p.h5", tmp_path / "r.mat")
    expected = {"inside the header": "cut short at byte 60: its header has 60 of its 128 bytes",
                "inside a tag": f"cut short at byte {keep}: variable 2's tag at byte {first} has 3 of its 8 bytes",
                "inside the data": f"cut short at byte {keep}: variable 1 at byte 128 declares its data up to byte ",
                "inside the last variable": f"cut short at byte {keep}: variable 3 at byte "}[where]
    assert str(err.value).startswith(f"{tmp_path / 'r.mat'}: {expected}"), str(err.value)
    with open_project(tmp_path / "p.h5") as p:
        assert p.experiment_names() == []


LVM_HEAD = ("LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
            "Multi_Headings\tYes\nX_Columns\tNo\nTime_Pref\tAbsolute\n***End_of_Header***\t\n\t\n"
            "Channels\t2\t\t\nSamples\t4\t4\t\nY_Unit_Label\t{unit}\tm/s^2\t\nX_Dimension\tTime\tTime\t\n"
            "X0\t0.0E+0\t0.0E+0\t\nDelta_X\t1.0E-3\t1.0E-3\t\n***End_of_Header***\t\t\t\n"
            "X_Value\ta\tr\tComment\n\t0.5\t1.0\n\t1.5\t2.0\n\t0.1\t-1.0\n\t0.0\t0.5\n")


def _record_in(tmp_path: Path, fmt: str, unit: str) -> Path:
    """Columns a = 0.5, 1.5, 0.1, 0 in ``unit`` and r in m/s^2 at 1000 Hz, written as ``fmt``."""
    a, r = [0.5, 1.5, 0.1, 0.0], [1.0, 2.0, -1.0, 0.5]
    if fmt == "lvm":
        (tmp_path / "r.lvm").write_text(LVM_HEAD.format(unit=unit), encoding="latin-1")
    elif fmt == "csv":
        (tmp_path / "r.csv").write_text(f"time,a [{unit}],r [m/s^2]\n" + "".join(
            f"{k / 1000},{x},{y}\n" for k, (x, y) in enumerate(zip(a, r))), encoding="utf-8")
    else:
        _write_tdms(tmp_path / "r.tdms", np.column_stack([a, r]), ["a", "r"], [unit, "m/s^2"], 1e-3)
    return tmp_path / f"r.{fmt}"


@pytest.mark.parametrize("fmt", ["csv", "tdms", "lvm"])
@pytest.mark.parametrize("unit, si, sensor", [("m/s^2", 1.5, "ACCELEROMETER"), ("M/S^2", 1.5, "ACCELEROMETER"),
                                              ("g", 1.5 * G, "ACCELEROMETER"), ("G", 1.5 * G, "ACCELEROMETER"),
                                              ("N", 1.5, "LOADCELL"), ("Newtons", 1.5, "LOADCELL"),
                                              ("V", 1.5, "VOLTAGE"), ("volt", 1.5, "VOLTAGE"), ("Volts", 1.5, "VOLTAGE")])
def test_a_known_unit_is_stored_in_si(tmp_path, registries, fmt, unit, si, sensor):
    # 'volt' was accepted as a unit but stored as no sensor (left out of processing)
    file = _record_in(tmp_path, fmt, unit)
    create_project(tmp_path / "p.h5", rig=None).close()
    _import(registries, tmp_path / "p.h5", file)
    with open_project(tmp_path / "p.h5") as p:
        exp = p.experiment("rec")
        assert physical(exp)[1, 0] == pytest.approx(si, rel=1e-12)
        assert physical(exp)[1, 1] == 2.0
        assert exp.systeminfo.channels[0].sensor_type.name == sensor


#: the spellings of m/s^2 estimate_frf reads (display.ascii_unit)
ACCELERATION_SPELLINGS = ["m/s^2", "m/s2", "m/s**2", "m/s²", " m/s**2 "]


@pytest.mark.parametrize("fmt", ["csv", "tdms", "lvm", "csv on the rig"])
@pytest.mark.parametrize("unit", ACCELERATION_SPELLINGS)
def test_every_spelling_estimate_frf_reads_is_imported(tmp_path, registries, fmt, unit):
    # 'm/s**2' was refused as if it were no unit of m/s^2, g, N or V
    from odsuite.analysis.frf import estimate_frf

    frf = estimate_frf([np.r_[1.0, np.zeros(7)]], [np.ones((8, 1))], 100.0, response_units=[unit])
    assert frf.units == ["(m/s^2)/N"]
    if fmt == "csv on the rig":
        file = tmp_path / "r.csv"
        _write_csv(file, DATA[:, :2], ["m1_x", "m1_y"], [unit, "g"])
    else:
        file = _record_in(tmp_path, fmt, unit)
    create_project(tmp_path / "p.h5", rig=str(RIG) if fmt == "csv on the rig" else None).close()
    _import(registries, tmp_path / "p.h5", file)
    with open_project(tmp_path / "p.h5") as p:
        exp = p.experiment("rec")
        k = next(s.channel for s in p.rig.sensors if s.name == "m1_x") if p.rig is not None else 0
        assert exp.systeminfo.channels[k].sensor_type.name == "ACCELEROMETER"
        expected = DATA[:, 0] if p.rig is not None else [0.5, 1.5, 0.1, 0.0]
        assert np.allclose(physical(exp)[:, k], expected, rtol=1e-12, atol=0)


@pytest.mark.parametrize("encoding", ["utf-8", "latin-1"])
def test_an_lvm_file_in_utf8_or_the_code_page_gives_the_same_record(tmp_path, registries, encoding):
    # decoded as latin-1 only, a UTF-8 'm/s²' read as 'm/sÂ²' and was refused
    (tmp_path / "r.lvm").write_text(LVM_HEAD.format(unit="m/s²").replace("\ta\tr\t", "\ta µ\tr\t"), encoding=encoding)
    create_project(tmp_path / "p.h5", rig=None).close()
    _import(registries, tmp_path / "p.h5", tmp_path / "r.lvm")
    with open_project(tmp_path / "p.h5") as p:
        exp = p.experiment("rec")
        assert exp.channel_names == ["a µ", "r"]
        assert [c.sensor_type.name for c in exp.systeminfo.channels] == ["ACCELEROMETER", "ACCELEROMETER"]
        assert physical(exp).tolist() == [[0.5, 1.0], [1.5, 2.0], [0.1, -1.0], [0.0, 0.5]]
        assert exp.sampling_rate == 1000.0


@pytest.mark.parametrize("fmt", ["csv", "tdms", "lvm"])
@pytest.mark.parametrize("unit", ["mg", "km", "km/s^2", "mm/s^2", "mN", "kN", "MN", "mV", "kV", "lbf", "ft/s^2"])
def test_a_unit_of_another_scale_is_refused_naming_channel_and_unit(tmp_path, registries, fmt, unit):
    # a LabVIEW column in mg, mN or mm/s^2 was stored as volts at scale 1, silently
    file = _record_in(tmp_path, fmt, unit)
    create_project(tmp_path / "p.h5", rig=None).close()
    with pytest.raises(OdsuiteError) as err:
        _import(registries, tmp_path / "p.h5", file)
    assert str(err.value).startswith(str(file))
    assert str(err.value).endswith(f"channel 'a': unit {unit!r} is not one of m/s^2, g, N, V")
    with open_project(tmp_path / "p.h5") as p:
        assert p.experiment_names() == []


def _inflated_sizes(blob: bytes) -> list[int]:
    """The decompressed size of each compressed variable of a little-endian v5 .mat file, read from
    its own tags with zlib."""
    import zlib

    sizes, pos = [], 128
    while pos < len(blob):
        kind, count = struct.unpack("<II", blob[pos:pos + 8])
        if kind == 15:
            sizes.append(len(zlib.decompress(blob[pos + 8:pos + 8 + count])))
        pos += 8 + count + (-count % 8 if kind != 15 else 0)
    return sizes


def test_a_compressed_mat_variable_is_decompressed_once(tmp_path, monkeypatch):
    """The check of a .mat's elements decompressed each compressed variable and scipy's read then
    decompressed it again (0.22 s and 0.14 s of a 0.5 s read of 30 MiB): scipy now reads the bytes
    the check decompressed, and the numbers are scipy's own."""
    import os
    import zlib

    from odsuite_plugins.importers.tables import read_mat_columns

    data = np.round(RNG.normal(size=(20_000, 3)), 3)
    scipy.io.savemat(tmp_path / "r.mat", {"data": data, "fs": FS, "units": "g"}, do_compression=True)
    expected = _inflated_sizes((tmp_path / "r.mat").read_bytes())
    assert len(expected) == 3 and max(expected) > data.nbytes
    inflated = []
    real_obj, real_one = zlib.decompressobj, zlib.decompress

    class Counted:
        def __init__(self, *args, **kw):
            self.inner = real_obj(*args, **kw)

        def __getattr__(self, name):
            return getattr(self.inner, name)

        def decompress(self, *args, **kw):
            out = self.inner.decompress(*args, **kw)
            inflated.append(len(out))
            return out

        def flush(self, *args):
            out = self.inner.flush(*args)
            inflated.append(len(out))
            return out

    monkeypatch.setattr(zlib, "decompressobj", Counted)
    monkeypatch.setattr(zlib, "decompress", lambda *a, **k: (out := real_one(*a, **k), inflated.append(len(out)))[0])
    monkeypatch.delattr(os, "fork")  # read in this process, where the bytes are counted
    cols = read_mat_columns(tmp_path / "r.mat", {})
    np.testing.assert_array_equal(cols.data, data)
    assert cols.fs == FS and cols.units == ["g"] * 3
    assert sum(inflated) == sum(expected)


def test_a_mat_variable_that_expands_beyond_free_memory_is_refused(tmp_path, monkeypatch):
    # 32 MiB of zeros compress to 32 kB: a few kB of a file may ask for gigabytes
    from odsuite_plugins.importers import tables

    scipy.io.savemat(tmp_path / "r.mat", {"data": np.zeros((2**21, 2)), "fs": FS}, do_compression=True)
    assert (tmp_path / "r.mat").stat().st_size < 2**16
    monkeypatch.setattr(tables, "free_memory", lambda: 2**24)
    with pytest.raises(OdsuiteError) as err:
        tables.read_mat_columns(tmp_path / "r.mat", {})
    assert str(err.value) == (f"{tmp_path / 'r.mat'}: variable 1 at byte 128: its compressed data expand beyond the "
                              "16 MiB of memory free")


def test_a_crash_of_scipys_reader_is_refused_naming_the_signal(tmp_path, monkeypatch):
    """scipy reads in a forked child: a crash of its compiled reader ends the child, not odsuite."""
    import faulthandler
    import os
    import signal

    from odsuite_plugins.importers.tables import read_mat_columns

    def crash(*args, **kw):
        faulthandler.disable()  # the child's crash needs no report
        os.kill(os.getpid(), signal.SIGSEGV)

    scipy.io.savemat(tmp_path / "r.mat", {"data": DATA, "fs": FS, "units": "g"})
    monkeypatch.setattr(scipy.io, "loadmat", crash)
    with pytest.raises(OdsuiteError) as err:
        read_mat_columns(tmp_path / "r.mat", {})
    assert str(err.value) == (f"{tmp_path / 'r.mat'}: not a readable MATLAB .mat file: scipy's reader crashed on it "
                              "(SIGSEGV): the file is damaged")


def test_a_mat_file_of_thousands_of_arrays_names_a_few(tmp_path, registries):
    # each of 3000 arrays was named in the message asking for --variable (a 20 kB line)
    scipy.io.savemat(tmp_path / "r.mat", {f"run{i}": np.arange(3.0) + i for i in range(3000)})
    create_project(tmp_path / "p.h5", rig=None).close()
    with pytest.raises(OdsuiteError) as err:
        _import(registries, tmp_path / "p.h5", tmp_path / "r.mat", rate=FS, units="g")
    assert str(err.value) == (f"{tmp_path / 'r.mat'}: variable: 3000 arrays (run0, run1, run2, run3, run4, run5, run6, "
                              "run7, ... (3000 in all)); name one with --variable")
    with pytest.raises(OdsuiteError) as err:
        _import(registries, tmp_path / "p.h5", tmp_path / "r.mat", rate=FS, units="g", variable="data")
    assert str(err.value).endswith("variable: no 'data' (variables: run0, run1, run2, run3, run4, run5, run6, run7, "
                                   "... (3000 in all))")


def test_the_summary_of_a_record_of_thousands_of_channels_names_a_few(tmp_path, registries):
    # the summary line named all 3000 channels with their units (44 kB)
    _write_tdms(tmp_path / "r.tdms", np.tile(DATA[:, :1], 3000), [f"c{k}" for k in range(3000)], ["g"] * 3000)
    create_project(tmp_path / "p.h5", rig=None).close()
    res = _import(registries, tmp_path / "p.h5", tmp_path / "r.tdms")
    assert res.summary == ("tdms file r.tdms: 3000 channels (c0 [g], c1 [g], c2 [g], c3 [g], c4 [g], c5 [g], c6 [g], "
                           "c7 [g], ... (3000 in all)) x 500 samples at 2048 Hz as experiment 'rec'")
    assert all(len(n) < 400 for n in res.notes)


@pytest.mark.parametrize("fmt", ["csv", "npy", "mat", "tdms"])
def test_a_folder_named_like_a_record_is_refused_as_a_folder(tmp_path, registries, fmt):
    # it was refused as 'no such file', beside the folder it is
    (tmp_path / f"r.{fmt}").mkdir()
    create_project(tmp_path / "p.h5", rig=None).close()
    with pytest.raises(OdsuiteError, match=rf"^{re.escape(str(tmp_path / f'r.{fmt}'))}: a folder, not a file$"):
        _import(registries, tmp_path / "p.h5", tmp_path / f"r.{fmt}", rate=FS, units="g")


def test_a_mat_files_vectors_read_together_as_one_record(tmp_path, capsys):
    # an analyser's export keeps force and response apart (Time_chan_1, Time_chan_2), and --variable
    # read one array: the impact test could not be imported as one
    import json

    from odsuite.cli import main

    case1 = Path(__file__).resolve().parents[2] / "data" / "real" / "vibration_toolbox_frf" / "case1.mat"
    p = tmp_path / "p.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    assert main(["import", str(p), str(case1), "--name", "bad", "--variable", "Time_chan_1,Freq_domain",
                 "--units", "N,m/s^2", "--rate", "1280"]) == 1
    assert "each must be a vector of real numbers of one length, got shapes (4096, 1), (1601, 1)" in capsys.readouterr().err
    assert main(["import", str(p), str(case1), "--name", "c1", "--variable", "Time_chan_1,Time_chan_2",
                 "--units", "N,m/s^2", "--rate", "1280", "--force-channel", "Time_chan_1"]) == 0
    assert "2 channels (Time_chan_1 [N], Time_chan_2 [m/s^2]) x 4096 samples at 1280 Hz" in capsys.readouterr().out
    assert main(["modes", str(p), "--experiment", "c1", "--json"]) == 0
    f = np.array([m["frequency_hz"] for m in json.loads(capsys.readouterr().out)["modes"]])
    # vibration_toolbox's sdof_cf on the analyser's FRF: 212.0925 Hz (its README)
    assert np.min(np.abs(f - 212.0925)) < 0.1, f


@pytest.mark.parametrize("edit, message", [
    (("0,537321", "inf"), "channel 'Excitation (Trigger)': sample 1: value inf is not a finite number"),
    (("0,537321", "1e308"), "channel 'Excitation (Trigger)': sample 1: value 1e+308 Newtons is beyond 1e+12 Newtons"),
    (("Response (Trigger)", "Excitation (Trigger)"), "channels: name 'Excitation (Trigger)' is given twice or empty"),
])
def test_an_lvm_s_bad_values_are_named_in_the_file(tmp_path, capsys, edit, message):
    # the refusal named the project being written ("p.h5: experiment 'e': ..."), not the .lvm
    from odsuite.cli import main

    short = Path(__file__).resolve().parents[2] / "data" / "real" / "lvm_read_impacts" / "short.lvm"
    bad = tmp_path / "bad.lvm"
    bad.write_text(short.read_text(encoding="latin-1").replace(*edit, 1), encoding="latin-1")
    p = tmp_path / "p.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    capsys.readouterr()
    assert main(["import", str(p), str(bad), "--name", "e"]) == 1
    err = capsys.readouterr().err.strip()
    assert err == f"error: {bad}: {message}" or err.startswith(f"error: {bad}: {message}"), err
    assert len(err.splitlines()) == 1


def test_a_bare_array_names_units_and_rate_at_once(tmp_path, capsys):
    # a .npy without a sidecar was refused for its units, and once they were given for its rate:
    # two tries to learn what one line can say
    from odsuite.cli import main

    np.save(tmp_path / "walk.npy", DATA[:, :2])
    p = tmp_path / "p.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    capsys.readouterr()
    npy = tmp_path / "walk.npy"
    assert main(["import", str(p), str(npy), "--name", "walk"]) == 1
    assert capsys.readouterr().err == (
        f"error: {npy}: units and sampling_rate: not given (channels ch1, ch2); give --units and --rate or a sidecar "
        "walk.toml (units = \"m/s^2\" and sampling_rate = ... in Hz)\n")
    assert main(["import", str(p), str(npy), "--name", "walk", "--rate", "100"]) == 1
    assert "units: not given (channels ch1, ch2); give --units or a sidecar walk.toml" in capsys.readouterr().err
    with open_project(p) as project:
        assert project.experiment_names() == []


def test_a_mat_files_rate_under_a_longer_name_is_read(tmp_path, capsys):
    # the vibration toolbox's case1.mat holds its rate as Time_Sample_Rate = 1280 Hz (its README):
    # it was refused for want of --rate
    from scipy.io import savemat

    from odsuite.cli import main

    case1 = Path(__file__).resolve().parents[2] / "data" / "real" / "vibration_toolbox_frf" / "case1.mat"
    p = tmp_path / "p.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    capsys.readouterr()
    assert main(["import", str(p), str(case1), "--name", "c1", "--variable", "Time_chan_1,Time_chan_2",
                 "--units", "N,m/s^2"]) == 0
    assert "x 4096 samples at 1280 Hz" in capsys.readouterr().out
    # two names of a rate: nothing tells which is the records'
    two = tmp_path / "two.mat"
    savemat(two, {"x": np.zeros((64, 1)), "Time_Sample_Rate": 1280.0, "Freq_Sampling_Rate": 2.0})
    assert main(["import", str(p), str(two), "--name", "t", "--units", "g"]) == 1
    assert "variables 'Freq_Sampling_Rate', 'Time_Sample_Rate' each name a sampling rate: give --rate" in \
        capsys.readouterr().err
