"""`process` stores each hammer record's measured modes; `compare` reads them while the record and
the odsuite version are those they were identified from, and gives the numbers it gives without
them (a project written before they were stored)."""

from __future__ import annotations

import json
import shutil

import h5py
import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from odsuite.analysis import stored_modes
from odsuite.analysis.modal_project import hits_frf
from odsuite.cli import main
from odsuite.store.project import open_project


def _json(capsys, *args) -> dict:
    assert main([str(a) for a in args]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.fixture(scope="module")
def processed(tmp_path_factory):
    """Two thesis-rig hammer records (a +z and a -x blow), processed: their modes stored."""
    p = tmp_path_factory.mktemp("stored-modes") / "p.h5"
    for argv in (["new", p], *(["acquire", p, "--daq", "sim", "--name", n, "--scenario", n, "--seed", str(s),
                                "--samples", "2048"] for s, n in enumerate(("T1", "T5"), start=1)), ["process", p]):
        assert main([str(a) for a in argv]) == 0
    return p


def _without_stored_modes(src, dst):
    """A copy of the project as odsuite wrote it before modes were stored."""
    shutil.copy(src, dst)
    with h5py.File(dst, "a") as f:
        for name in f["experiments"]:
            del f["experiments"][name]["derived"][stored_modes.KIND]
    return dst


def test_stored_modes_are_those_identified_from_the_record(processed):
    with open_project(processed) as p:
        for name in p.experiment_names():
            assert stored_modes.KIND in p.derived_kinds(name)
            exp = p.experiment(name)
            with threadpool_limits(1):  # as compare identifies them: other BLAS threads round otherwise
                frf, _ = hits_frf(exp, name, flagged_too=True)
                fresh = stored_modes.identify(frf)
            stored = stored_modes.stored_modes(p, exp)
            assert stored.flagged == ""  # the simulated hits pass the hammer checks
            read = stored.modes()
            assert read.poles.size > 0
            for field in ("poles", "residues", "shapes", "stable_orders"):
                np.testing.assert_array_equal(getattr(read, field), getattr(fresh, field))
            assert (read.output_names, read.band_hz, read.rejected) == (fresh.output_names, fresh.band_hz,
                                                                        fresh.rejected)
            assert read.diagram.orders == fresh.diagram.orders and read.diagram.f_band == fresh.diagram.f_band
            for part in ("poles", "stable_f", "stable"):
                for a, b in zip(getattr(read.diagram, part), getattr(fresh.diagram, part), strict=True):
                    np.testing.assert_array_equal(a, b)
                    assert a.dtype == b.dtype


def test_compare_gives_the_same_document_with_and_without_stored_modes(processed, tmp_path, capsys):
    with_modes = _json(capsys, "compare", processed, "--json")
    before = _json(capsys, "compare", _without_stored_modes(processed, tmp_path / "old.h5"), "--json")
    assert {r["experiment"] for r in with_modes["modal"]} == {"T1", "T5"}
    assert with_modes == before


def test_the_command_line_table_equals_the_one_with_figures(processed, capsys):
    """`compare` asks for the table without figures (no FRFs where modes are stored); the report
    asks for the figures too: the same rows and notes, FRFs only in the second."""
    from odsuite.analysis.comparison import compare

    with open_project(processed) as p:
        table, full = compare(p, figures=False), compare(p)
    assert table.as_dict() == full.as_dict() == _json(capsys, "compare", processed, "--json")
    assert all(r.frf is None for r in table.modal_records)
    assert all(r.frf.H.shape[0] == len(r.modes.output_names) for r in full.modal_records)


def test_stored_modes_are_read_only_for_the_record_they_were_identified_from(processed, tmp_path, capsys):
    """Stored modes altered on purpose show in compare while their stamp holds; the same group
    stamped with another record's id, another odsuite version or other identification code is
    ignored."""
    truth = _json(capsys, "compare", processed, "--json")["modal"]
    altered = tmp_path / "altered.h5"
    shutil.copy(processed, altered)
    with h5py.File(altered, "a") as f:
        g = f["experiments"]["T1"]["derived"][stored_modes.KIND]
        g["poles_imag"][...] = 2 * g["poles_imag"][()]  # every mode at about twice its frequency
        g.attrs["flagged"] = b"hit at sample 9: clipped"  # the note a record of flagged hits gets
    altered_doc = _json(capsys, "compare", altered, "--json")
    assert altered_doc["modal_notes"] == ["T1: every hit is flagged (hit at sample 9: clipped): its modes are "
                                          "identified from them anyway and may be biased"]
    rows = [r for r in altered_doc["modal"] if r["experiment"] == "T1"]
    want = [r["measured_hz"] for r in truth if r["experiment"] == "T1"]
    assert len(rows) == len(want)
    assert all(r["measured_hz"] > 1.9 * w for r, w in zip(rows, want))
    with h5py.File(altered) as f:
        params = json.loads(f["experiments"]["T1"]["derived"][stored_modes.KIND].attrs["parameters"])
    assert params["code"] == stored_modes.code_stamp()
    other_code = json.dumps({**params, "code": "edited-source"}).encode()
    for attr, value in (("inputs", np.array([b"another-record"])), ("plugin_version", b"0.0.0-other"),
                        ("parameters", other_code)):
        stale = tmp_path / f"stale-{attr}.h5"
        shutil.copy(altered, stale)
        with h5py.File(stale, "a") as f:
            f["experiments"]["T1"]["derived"][stored_modes.KIND].attrs[attr] = value
        assert _json(capsys, "compare", stale, "--json")["modal"] == truth


def test_a_stored_failure_prints_the_note_it_was_stored_with(tmp_path, capsys, monkeypatch):
    p = tmp_path / "p.h5"
    for argv in (["new", p], ["acquire", p, "--daq", "sim", "--name", "T1", "--scenario", "T1", "--seed", "1",
                              "--samples", "2048"]):
        assert main([str(a) for a in argv]) == 0

    def fails(frf):
        raise np.linalg.LinAlgError("a singular matrix met while identifying")

    monkeypatch.setattr(stored_modes, "identify", fails)
    assert main(["process", str(p)]) == 0
    monkeypatch.undo()
    capsys.readouterr()
    doc = _json(capsys, "compare", p, "--json")
    assert doc["modal"] == []
    assert doc["modal_notes"] == ["T1: measured modes not identified: a singular matrix met while identifying"]
    fresh = _json(capsys, "compare", _without_stored_modes(p, tmp_path / "old.h5"), "--json")
    # identified again: the 216.9 and 227.5 Hz modes of the blow on the platform's centre
    assert [r["experiment"] for r in fresh["modal"]] == ["T1", "T1"] and fresh["modal_notes"] == []
    assert all(abs(r["measured_hz"] / r["model_hz"] - 1) < 0.005 and r["mac"] > 0.85 for r in fresh["modal"])


def test_a_record_whose_modes_cannot_be_stored_is_not_stored_either(tmp_path, capsys, monkeypatch):
    """process commits a record and its modes together: a disk that fills up while the modes are
    written leaves the project as it was (the processed record had been committed alone)."""
    from odsuite.domain.errors import DiskFullError

    p = tmp_path / "p.h5"
    for argv in (["new", p], ["acquire", p, "--daq", "sim", "--name", "T1", "--scenario", "T1", "--seed", "1",
                              "--samples", "2048"]):
        assert main([str(a) for a in argv]) == 0
    before = p.read_bytes()

    def disk_full(project, name):
        raise DiskFullError(f"{project.path}: no space left on /: needed ~2.3 MB, 2.0 MB free; project unchanged")

    monkeypatch.setattr(stored_modes, "store_record_modes", disk_full)
    capsys.readouterr()
    assert main(["process", str(p)]) == 1
    assert capsys.readouterr().err.strip() == f"error: {p}: no space left on /: needed ~2.3 MB, 2.0 MB free; " \
                                              "project unchanged"
    assert p.read_bytes() == before


def _forge(src, dst, edit):
    shutil.copy(src, dst)
    with h5py.File(dst, "a") as f:
        edit(f["experiments"]["T1"]["derived"][stored_modes.KIND])
    return dst


def _replace(name, value):
    def edit(g):
        del g[name]
        g[name] = value
    return edit


FORGERIES = {
    "missing dataset": lambda g: g.__delitem__("poles_imag"),
    "shapes of the wrong shape": _replace("shapes_real", np.zeros((1, 1))),
    "poles not finite": lambda g: g["poles_real"].write_direct(np.full(g["poles_real"].shape, np.nan)),
    "counts past the poles": _replace("diagram_counts", np.array([10 ** 9])),
    "output names not JSON": lambda g: g.attrs.__setitem__("output_names", "{not json"),
    "band not numbers": lambda g: g.attrs.__setitem__("band_hz", json.dumps(["a", "b"])),
}


@pytest.mark.parametrize("forgery", sorted(FORGERIES))
def test_forged_stored_modes_give_one_line_naming_them(processed, tmp_path, capsys, forgery):
    """A ``hammer_modes`` group whose stamp matches but whose data cannot be modes (hand-edited,
    damaged) is refused in one line naming the file, the record and the field; no traceback, and
    the project is not changed."""
    p = _forge(processed, tmp_path / "forged.h5", FORGERIES[forgery])
    before = p.read_bytes()
    assert main(["compare", str(p), "--json"]) != 0
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    assert str(p) in err and "'T1'" in err and stored_modes.KIND in err, err
    assert p.read_bytes() == before
