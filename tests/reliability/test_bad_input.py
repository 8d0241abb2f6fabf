"""The bad-input catalogue: every malformed input in ``docs/bad-input.md`` gives its one-line
OdsuiteError (through the CLI: exit code 1, one line on stderr, no traceback) and leaves a project
given to the command byte-identical. The table there and ``CASES`` here must list the same cases."""

from __future__ import annotations

import json
import os
import re
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from odsuite.cli import main
from odsuite.domain.errors import OdsuiteError
from tests.reliability.harness import REPO, TABLE_E3, legacy_volts

DOC = REPO / "docs" / "bad-input.md"
CTR_TEXT = TABLE_E3.read_text(encoding="utf-8")
LEGACY = ["--force-point", "0,4.122,-11.399", "--force-dir", "+z"]

LVM_TEXT = (
    "LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\nDecimal_Separator\t,\n"
    "Multi_Headings\tYes\nX_Columns\tNo\nTime_Pref\tAbsolute\n***End_of_Header***\t\n\t\n"
    "Channels\t2\t\t\nSamples\t4\t4\t\nY_Unit_Label\tNewtons\tm/s^2\t\nX_Dimension\tTime\tTime\t\n"
    "X0\t0,0E+0\t0,0E+0\t\nDelta_X\t1,0E-4\t1,0E-4\t\n***End_of_Header***\t\t\t\n"
    "X_Value\tForce\tResponse\tComment\n\t0,5\t1,0\n\t1,5\t2,0\n\t0,1\t-1,0\n\t0,0\t0,5\n"
)

#: LVM_TEXT's channel header and rows: a second segment
LVM_SEGMENT = "\n" + LVM_TEXT[LVM_TEXT.index("Channels"):]

RIG_TOML = """
name = "bench"
force_channel = 0
[[bodies]]
name = "plate"
mass = 2.0
inertia = [[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]
plate = { size = [0.2, 0.2, 0.02], corner = [-0.1, -0.1, 0.0] }
[[sensors]]
name = "a1"
channel = 1
body = "plate"
position = [0.0, 0.0, 0.0]
axis = [0.0, 0.0, 1.0]
"""
SPRING = """
[[springs]]
name = "s1"
body = "plate"
position = [0.0, 0.0, 0.0]
stiffness = [1000.0, 1000.0, 1000.0]
damping = [1.0, 1.0, 1.0]
"""


def ctr_with(row: int, channel: int, value: str) -> str:
    """The Table E.3 Systeminfo with one cell replaced (row number and channel as in Table E.2)."""
    lines = CTR_TEXT.splitlines()
    for i, line in enumerate(lines):
        cells = line.split("|")
        if len(cells) > 2 and cells[1].strip() == str(row):
            cells[2 + channel] = f" {value} "
            lines[i] = "|".join(cells)
            return "\n".join(lines) + "\n"
    raise AssertionError(f"no row {row}")


def dat_text(data: np.ndarray) -> str:
    return "".join("\t".join(map(repr, r)) + "\n" for r in data.tolist())


GOOD_DAT = dat_text(legacy_volts())


def dat_edit(index: int, change: Callable[[str], str]) -> str:
    """The good .DAT text with line ``index`` (0-based) changed."""
    lines = GOOD_DAT.splitlines()
    lines[index] = change(lines[index])
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class Case:
    """One malformed input. ``argv`` (a CLI command line) or ``call`` (a Python API call) gets the
    working folder; ``files`` are written there first. ``{dir}`` and ``{project}`` in ``expected``
    stand for the folder and the project."""

    name: str
    input: str
    expected: str
    argv: Callable[[Path], list[str]] | None = None
    call: Callable[[Path], object] | None = None
    files: dict[str, str | bytes] = field(default_factory=dict)


def legacy(ctr: str = "bad.CTR", dat: str = "good.DAT", name: str = "new", point: str = "0,4.122,-11.399",
           direction: str = "+z") -> Callable[[Path], list[str]]:
    return lambda d: ["import-legacy", str(d / "p.h5"), str(d / dat), "--systeminfo", str(d / ctr),
                      "--name", name, "--force-point", point, "--force-dir", direction]


def lvm(text: str, *extra: str) -> dict:
    return {"argv": lambda d: ["import-lvm", str(d / "p.h5"), str(d / "bad.lvm"), "--name", "new", *extra],
            "files": {"bad.lvm": text}}


def new_rig(toml: str) -> dict:
    return {"argv": lambda d: ["new", str(d / "q.h5"), "--rig", str(d / "bad.toml")], "files": {"bad.toml": toml}}


def _read_uff(d: Path, name: str):
    from odsuite_plugins.importers.uff import read_uff

    return read_uff(d / name)


def _uff_damaged(d: Path, how: str):
    """Three 8-point time records written by odsuite, then damaged ``how``, read back (API)."""
    from odsuite_plugins.importers.uff import time_function, write_uff

    write_uff(d / "base.uff", functions=[time_function(f"acc{k}", np.arange(8.0) + k, 1e-3, "m/s^2", node=0)
                                         for k in range(3)], binary=how == "58b-count", overwrite=True)
    raw = (d / "base.uff").read_bytes()
    lines = raw.split(b"\n")
    # where the functions start (after whatever units or header datasets the writer puts first)
    starts = [i for i, line in enumerate(lines) if line.strip() in (b"58", b"58b") or line.startswith(b"    58b")]
    first_end = next(i for i in range(starts[0] + 1, len(lines)) if lines[i].strip() == b"-1")
    if how == "cut":  # cut inside the second record's data
        bad = b"\n".join(lines[:starts[1] + 12])
    elif how == "count":  # record 7 of the first function says 9 points, it holds 8
        lines[starts[0] + 7] = lines[starts[0] + 7].replace(b"         8         1", b"         9         1", 1)
        bad = b"\n".join(lines)
    elif how == "line-lost":  # the last data line of the first function lost
        del lines[first_end - 1]
        bad = b"\n".join(lines)
    else:  # 58b: record 7 says 9 points, the data bytes hold 8
        head = raw.index(b"58b")
        at = raw.index(b"         8         1", head)
        bad = raw[:at] + b"         9         1" + raw[at + len(b"         8         1"):]
    assert bad != raw
    (d / "bad.uff").write_bytes(bad)
    return _read_uff(d, "bad.uff")


def _plant_link(d: Path, name: str) -> None:
    (d / "victim.txt").write_text("a file the lock must never write into\n")
    (d / name).symlink_to(d / "victim.txt")


def _full_disk_acquire(d: Path, free: int):
    """Acquire into p.h5 while its disk reports ``free`` bytes free (API, patched disk_usage)."""
    import collections
    from unittest import mock

    from odsuite.store.project import open_project
    from odsuite.domain.systeminfo import ChannelInfo, Systeminfo

    usage = collections.namedtuple("usage", "total used free")(10**9, 10**9 - free, free)
    with mock.patch("odsuite.store.diskspace.shutil.disk_usage", return_value=usage), \
            open_project(d / "p.h5", "a") as p:
        p.add_experiment("full", np.ones((4096, 2)), sampling_rate=1000.0,
                         systeminfo=Systeminfo([ChannelInfo() for _ in range(2)]), excitation=None)


def _read_raw_short_of_memory(d: Path, free: int):
    """e1's raw record read while the machine reports ``free`` bytes of memory free (API)."""
    from unittest import mock

    from odsuite.store.project import open_project

    with mock.patch("odsuite.domain.memory.free_memory", return_value=free), open_project(d / "p.h5") as p:
        return p.experiment("e1").raw()


def _uff_on_rig(d: Path, how: str):
    """A UFF file imported onto a project on the bench rig, whose sensor a1 (no sensitivity)
    declares UFF node 5 and measures along +z: the hammer's record and a1's, changed by ``how``."""
    from odsuite_plugins.importers.uff import time_function, write_uff
    from odsuite_plugins.importers.uff_project import import_uff

    (d / "rig.toml").write_text(RIG_TOML.replace('axis = [0.0, 0.0, 1.0]', 'axis = [0.0, 0.0, 1.0]\nuff_node = 5'))
    assert main(["new", str(d / "r.h5"), "--rig", str(d / "rig.toml")]) == 0
    records = {"impact": (10, "N", 9), "acc": (8 if how == "lengths" else 10, "V" if how == "volts" else "m/s^2", 5)}
    if how in ("unknown-node", "duplicate"):
        records["acc2"] = (10, "m/s^2", 7 if how == "unknown-node" else 5)
    write_uff(d / "r.uff", functions=[
        time_function(name, np.sin(np.arange(n)), 1e-3, unit, node=node, direction=-3 if name == "acc2" else 3)
        for name, (n, unit, node) in records.items()])
    return import_uff(d / "r.h5", d / "r.uff", "new", force_point=np.zeros(3), force_dir=np.array([0.0, 0.0, 1.0]))


def _uff_without_rig(unit: str) -> Callable[[Path], list[str]]:
    """``import`` of a UFF time record in ``unit`` into r.h5, a project without a rig."""
    def argv(d: Path) -> list[str]:
        from odsuite.store.project import create_project
        from odsuite_plugins.importers.uff import time_function, write_uff

        create_project(d / "r.h5", rig=None).close()
        write_uff(d / "r.uff", functions=[time_function("acc", np.sin(np.arange(10.0)), 1e-3, unit, node=1, direction=3)])
        return ["import", str(d / "r.h5"), str(d / "r.uff"), "--name", "new"]
    return argv


def _uff_units(unit: str, description: str, length: float, force: float, nodes: bool = False) -> Callable[[Path], list[str]]:
    """``import`` into r.h5 (no rig) of a UFF whose record is in ``unit`` and whose units set (164)
    has these factors; with ``nodes``, a node set (15) of nodes 1 and 2 too."""
    def argv(d: Path) -> list[str]:
        import pyuff

        argv = _uff_without_rig(unit)(d)
        sets = pyuff.UFF(str(d / "r.uff")).read_sets()
        sets[0] = pyuff.prepare_164(units_code=5, units_description=description, temp_mode=2, length=length,
                                    force=force, temp=1.0, temp_offset=273.15, return_full_dict=True)
        if nodes:
            sets.append(pyuff.prepare_15(node_nums=[1, 2], def_cs=[0, 0], disp_cs=[0, 0], color=[1, 1], x=[0.1, 0.2],
                                         y=[0.0, 0.0], z=[0.0, 0.0], return_full_dict=True))
        (d / "r.uff").write_bytes(b"")
        pyuff.UFF(str(d / "r.uff")).write_sets(sets, mode="add")
        return argv
    return argv


def _unwritten_coordinates(d: Path) -> list[str]:
    """``export-legacy --cod`` of e1 in processed.h5, its platform coordinates replaced by 10^9 rows never written."""
    import h5py

    with h5py.File(d / "processed.h5", "a") as f:
        g = f["experiments/e1/derived/gencoords"]
        attrs = dict(g["platform_at_g"].attrs)
        del g["platform_at_g"]
        g.create_dataset("platform_at_g", shape=(10**9, 6), dtype="f8")
        g["platform_at_g"].attrs.update(attrs)
    return ["export-legacy", str(d / "processed.h5"), "e1", "--cod", str(d / "out.COD")]


def _uff_units_cut(d: Path) -> list[str]:
    """``import`` into r.h5 (no rig) of a UFF whose units set (164) ends after its description line."""
    argv = _uff_without_rig("V")(d)
    text = (d / "r.uff").read_bytes()
    start = text.index(b"164")
    line3 = text.index(b"\n", text.index(b"\n", start) + 1) + 1  # after the type and description lines
    (d / "r.uff").write_bytes(text[:line3] + text[text.index(b"    -1", line3):])
    return argv


def _on_bench_rig(toml: str, *argv: str) -> Callable[[Path], list[str]]:
    """A command line on r.h5, a new project on the bench rig with ``toml`` added to its file."""
    def make(d: Path) -> list[str]:
        from odsuite.store.project import create_project

        (d / "rig.toml").write_text(RIG_TOML + toml)
        create_project(d / "r.h5", str(d / "rig.toml")).close()
        return [a.format(project=d / "r.h5") for a in argv]
    return make


def _full_disk_export(d: Path, free: int):
    """Export e1 as UFF while the output's disk reports ``free`` bytes free (API, patched disk_usage);
    nothing of the output may be left."""
    import collections
    from unittest import mock

    from odsuite_plugins.importers.uff_project import export_uff

    usage = collections.namedtuple("usage", "total used free")(10**9, 10**9 - free, free)
    try:
        with mock.patch("odsuite.store.diskspace.shutil.disk_usage", return_value=usage):
            export_uff(d / "p.h5", d / "o.uff", "e1")
    finally:
        assert [p.name for p in d.iterdir() if "o." in p.name] == []


def _reaching_out(d: Path, kind: str) -> None:
    """x.h5, a copy of p.h5 whose raw record of e1 reaches a file outside it (a key, an HDF5 file)."""
    import h5py

    shutil.copyfile(d / "p.h5", d / "x.h5")
    (d / "key").write_bytes(b"secret" * 100_000)
    with h5py.File(d / "other.h5", "w") as o:
        o["data"] = np.zeros((10, 2))
    with h5py.File(d / "x.h5", "a") as f:
        old = f["experiments/e1/raw"]
        shape, dtype = old.shape, old.dtype
        del f["experiments/e1/raw"]
        if kind == "external storage":
            f.create_dataset("experiments/e1/raw", shape, dtype,
                             external=[(str(d / "key"), 0, int(np.prod(shape)) * dtype.itemsize)])
        elif kind == "virtual":
            layout = h5py.VirtualLayout(shape=(10, 2), dtype="f8")
            layout[...] = h5py.VirtualSource(str(d / "other.h5"), "data", shape=(10, 2))
            f.create_virtual_dataset("experiments/e1/raw", layout)
        else:
            f["experiments/e1/raw"] = h5py.ExternalLink(str(d / "other.h5"), "data")


def _project_reaching_out(kind: str, command: str = "verify") -> Callable[[Path], list[str]]:
    return lambda d: (_reaching_out(d, kind), [command, str(d / "x.h5")])[1]


def _handmade(kind: str, command: str = "info") -> Callable[[Path], list[str]]:
    """``command`` on x.h5, a copy of p.h5 with one stored value changed by hand."""
    def argv(d: Path) -> list[str]:
        import h5py

        shutil.copyfile(d / "p.h5", d / "x.h5")
        with h5py.File(d / "x.h5", "a") as f:
            rev, e = f["models/revisions/0"], f["experiments/e1"]
            if kind == "metrics abc":
                rev.attrs["metrics"] = '{"error": "abc"}'
            elif kind == "metrics list":
                rev.attrs["metrics"] = "[1, 2]"
            elif kind == "effects dict":
                rev.attrs["effects"] = '{"stiffness": 1}'
            elif kind == "metrics negative":
                rev.attrs["metrics"] = '{"error": -0.5}'
            elif kind == "parameter 1e400":
                rev.attrs["parameters"] = '{"stiffness.scale_z": 1%s}' % ("0" * 400)
            elif kind == "filter order 1e12":
                table = e["systeminfo/channels"][()]
                table["filter_order"][2] = 10**12
                e["systeminfo/channels"][...] = table
            elif kind == "force point 1e300":
                e.attrs["force_point"] = [1e300, 0.0, 0.0]
            elif kind == "rate 0":
                e.attrs["sampling_rate"] = 0.0
            elif kind == "rate NaN":
                e.attrs["sampling_rate"] = float("nan")
            elif kind == "force channel 99":
                e.attrs["force_channel"] = 99
            elif kind == "short names":
                e.attrs["channel_names"] = np.array([b"force", b"ai1"])
            elif kind == "names an int":
                e.attrs["channel_names"] = 5
            elif kind.startswith("pretrigger "):
                e.attrs["pretrigger"] = {"pretrigger text": "512", "pretrigger 512.7": 512.7,
                                         "pretrigger array": [1, 2]}[kind]
            elif kind == "force channel text":
                e.attrs["force_channel"] = "zero"
            elif kind == "force direction text":
                e.attrs["force_direction"] = "up"
            elif kind in ("unit furlong", "integration 77", "sensitivity text"):
                table = e["systeminfo/channels"][()]
                if kind != "integration 77":  # the column as text wide enough for it
                    column = "unit" if kind == "unit furlong" else "sensitivity"
                    table = table.astype([(n, "S8" if n == column else table.dtype[n]) for n in table.dtype.names])
                    del e["systeminfo/channels"]
                    e["systeminfo/channels"] = table
                    if kind == "unit furlong":
                        table["unit"][2] = b"furlong"
                else:
                    table["integration"][2] = 77
                e["systeminfo/channels"][...] = table
            elif kind == "systeminfo 3 rows":
                table = e["systeminfo/channels"][:3]
                del e["systeminfo/channels"]
                e["systeminfo/channels"] = table
            elif kind == "rig yaml":
                f["rig"].attrs["definition_format"] = "yaml"
            elif kind == "own parent":
                rev.attrs["parent"] = 0
            elif kind == "rig rx text":
                del e["systeminfo/rig/rx"]
                e["systeminfo/rig"].create_dataset("rx", data=b"abc")
            elif kind == "rig use_in_gcc text":
                e["systeminfo/rig"].attrs["use_in_gcc"] = "no"
            elif kind == "rig columns fractional":
                del e["systeminfo/rig/coordinate_columns"]
                e["systeminfo/rig"].create_dataset("coordinate_columns", data=[1.5, 2.0])
            elif kind.startswith("rig ") and kind.split()[1] in ("coordinate_columns", "nine_channels"):
                _, n, values = kind.split(" ", 2)  # "rig FIELD v,v,...": the column list replaced
                del e[f"systeminfo/rig/{n}"]
                e["systeminfo/rig"].create_dataset(n, data=np.array([int(v) for v in values.split(",")]))
            elif kind == "revision named abc":
                f["models/revisions"].move("0", "abc")
            elif kind.startswith("raw as "):  # the record rewritten in another type, its attributes kept
                attrs, raw = dict(e["raw"].attrs), e["raw"][()]
                del e["raw"]
                e["raw"] = raw.astype(np.float16) if kind == "raw as float16" else raw.astype("S8")
                e["raw"].attrs.update(attrs)
            elif kind == "raw NaN":  # written in place: the checksums of the file stay as they were
                raw = e["raw"][()]
                raw[700, 3] = np.nan
                e["raw"][...] = raw
            elif kind == "raw group":
                del e["raw"]
                e.create_group("raw")
            elif kind == "raw unwritten":  # 10^9 rows declared, no chunk written
                del e["raw"]
                e.create_dataset("raw", shape=(10**9, 11), dtype="f8", chunks=(4096, 11))
            elif kind == "columns unwritten":  # 10^9 column numbers declared, none written
                del e["systeminfo/rig/coordinate_columns"]
                e["systeminfo/rig"].create_dataset("coordinate_columns", shape=(10**9,), dtype="i8")
            elif kind == "raw unwritten gzip":  # compressed chunks: their bytes say nothing, their count does
                del e["raw"]
                e.create_dataset("raw", shape=(10**9, 11), dtype="f8", chunks=(65536, 11), compression="gzip")
            elif kind in ("raw bomb", "raw no checksum"):  # rewritten whole (a bomb: 10^6 rows of zeros)
                attrs, raw = dict(e["raw"].attrs), e["raw"][()]
                del e["raw"]
                if kind == "raw bomb":
                    e.create_dataset("raw", data=np.zeros((10**6, 11)), chunks=(65536, 11), compression="gzip")
                else:
                    e["raw"] = raw
                e["raw"].attrs.update(attrs)
            elif kind == "sensitivity 0":
                table = e["systeminfo/channels"][()]
                table["sensitivity"][2] = 0.0
                e["systeminfo/channels"][...] = table
            elif kind == "rate complex":
                e.attrs["sampling_rate"] = 20000 + 1j
            elif kind == "no revision 0":
                del f["models/revisions/0"]
            elif kind == "experiments dataset":
                del f["experiments"]
                f["experiments"] = np.zeros(3)
            elif kind == "3000 names":
                for k in range(3000):
                    f[f"experiments/h{k:04d}"] = e
        return [command, str(d / "x.h5")]
    return argv


def _uff_undefined_cs(d: Path):
    import pyuff

    nodes = pyuff.prepare_15(node_nums=[1, 2], def_cs=[0, 5], disp_cs=[0, 0], color=[8, 8], x=[0.0, 1.0],
                             y=[0.0, 0.0], z=[0.0, 0.0], return_full_dict=True)
    pyuff.UFF(str(d / "bad.uff")).write_sets([nodes], mode="overwrite")
    return _read_uff(d, "bad.uff")


def _touch(path: Path) -> Path:
    path.touch()
    return path


def _report_diagnosis(plant: Callable[[Path], object]) -> Callable[[Path], list[str]]:
    """``report --diagnosis`` with the file ``plant`` makes (or names, when it returns a str)."""
    def argv(d: Path) -> list[str]:
        named = plant(d)
        diag = named if isinstance(named, str) else str(d / "d.json")
        return ["report", str(d / "p.h5"), "-o", str(d / "r.html"), "--diagnosis", diag, "--no-movie"]
    return argv


#: a diagnosis as `diagnose --json` writes it, the fields the report shows
DIAGNOSIS = {"revision": 0, "baseline_error": 0.1, "noise_floor_error": 0.01, "candidates": [
    {"effect": "stiffness", "significant": True, "error_after": 0.05, "validated_error": 0.06,
     "parameters": {"scale_z": 1.2}, "units": {"scale_z": "1"}, "evidence": "", "physical": []}]}


def _diagnosis_with(field: str, value) -> dict:
    """DIAGNOSIS with one top-level field, or one of its candidate's (``candidates[0].NAME``), changed."""
    import copy

    doc = copy.deepcopy(DIAGNOSIS)
    table, name = (doc["candidates"][0], field.split(".")[1]) if field.startswith("candidates[0].") else (doc, field)
    table[name] = value
    return doc


def _bad_diagnosis_file(field: str, value) -> Callable[[Path], list[str]]:
    return _report_diagnosis(lambda d: (d / "d.json").write_text(json.dumps(_diagnosis_with(field, value))))


def _bad_stored_diagnosis(field: str, value) -> Callable[[Path], list[str]]:
    """``report`` on x.h5, a copy of p.h5 whose revision 0 keeps a diagnosis (as `diagnose` keeps
    one) with ``field`` changed by hand."""
    def argv(d: Path) -> list[str]:
        from odsuite.analysis.stored_diagnosis import diagnosis_stamp, store_diagnosis
        from odsuite.store.project import open_project

        shutil.copyfile(d / "p.h5", d / "x.h5")
        with open_project(d / "x.h5", "a") as p:
            assert store_diagnosis(p, _diagnosis_with(field, value), diagnosis_stamp(p))
        return ["report", str(d / "x.h5"), "-o", str(d / "r.html"), "--no-movie"]
    return argv


def _imported(name: str, write: Callable[[Path], object], *options: str) -> Callable[[Path], list[str]]:
    """``import p.h5 NAME`` of a record file ``write`` makes (npy, mat, tdms: written by their own libraries)."""
    def argv(d: Path) -> list[str]:
        write(d / name)
        return ["import", str(d / "p.h5"), str(d / name), "--name", "new", *options]
    return argv


def _one_sine(d: Path) -> list[str]:
    """``modes --output-only`` of r.h5 (no rig) holding one channel: 4096 samples of a 15.9 Hz sine at 1 kHz."""
    from odsuite.store.project import create_project
    from odsuite_plugins.importers.columns import import_columns

    create_project(d / "r.h5", rig=None).close()
    import_columns(d / "r.h5", d / "one.npy", "one", ["ch1"], ["g"], np.sin(0.1 * np.arange(4096.0))[:, None], 1000.0)
    return ["modes", str(d / "r.h5"), "--experiment", "one", "--output-only"]


def _force_alone(d: Path) -> list[str]:
    """``frf`` of r.h5 (no rig) holding one channel, a hammer's force in N."""
    from odsuite.store.project import create_project
    from odsuite_plugins.importers.columns import import_columns

    create_project(d / "r.h5", rig=None).close()
    force = np.zeros(100)
    force[10] = 50.0
    import_columns(d / "r.h5", d / "f.csv", "fo", ["hammer"], ["N"], force[:, None], 1000.0)
    return ["frf", str(d / "r.h5"), "--experiment", "fo"]


def _npy(data) -> Callable[[Path], None]:
    return lambda path: np.save(path, data)


def _npy_header(shape: tuple) -> Callable[[Path], None]:
    """A .npy header promising ``shape`` float64 values, then 64 bytes."""
    def write(path: Path) -> None:
        import numpy.lib.format as fmt

        with open(path, "wb") as f:
            fmt.write_array_header_1_0(f, {"descr": "<f8", "fortran_order": False, "shape": shape})
            f.write(bytes(64))
    return write


def _mat(**variables) -> Callable[[Path], None]:
    def write(path: Path) -> None:
        import scipy.io

        scipy.io.savemat(path, {"data": np.sin(np.arange(200.0)).reshape(100, 2), **variables})
    return write


def _mat73_external(path: Path) -> None:
    """A MATLAB v7.3 file (HDF5 behind MATLAB's 512-byte header) whose array is external storage on
    another file."""
    import h5py

    (path.parent / "elsewhere.bin").write_bytes(bytes(1600))
    with h5py.File(path, "w", userblock_size=512) as f:
        f.create_dataset("data", shape=(2, 100), dtype="f8", external=[(str(path.parent / "elsewhere.bin"), 0, 1600)])
        f["fs"] = np.array([[1000.0]])
    with open(path, "r+b") as f:
        f.write(b"MATLAB 7.3 MAT-file".ljust(124) + b"\x00\x02IM")


def _patched(write: Callable[[Path], object], old: bytes, new: bytes) -> Callable[[Path], None]:
    """The file ``write`` makes with the first ``old`` bytes in it replaced by as many ``new`` ones."""
    def patched(path: Path) -> None:
        write(path)
        data = path.read_bytes()
        assert len(old) == len(new) and old in data
        path.write_bytes(data.replace(old, new, 1))
    return patched


def _mat73(path: Path) -> None:
    import h5py

    with h5py.File(path, "w", userblock_size=512) as f:
        f["data"] = np.sin(np.arange(200.0)).reshape(2, 100)
        f["fs"] = np.array([[1000.0]])
    with open(path, "r+b") as f:
        f.write(b"MATLAB 7.3 MAT-file".ljust(124) + b"\x00\x02IM")


def _tdms(**properties) -> Callable[[Path], None]:
    def write(path: Path) -> None:
        from nptdms import ChannelObject, GroupObject, TdmsWriter

        with TdmsWriter(str(path)) as w:
            w.write_segment([GroupObject("g"), ChannelObject("g", "a1", np.sin(np.arange(100.0)),
                                                            properties={"unit_string": "m/s^2", **properties})])
    return write


def _cut(write: Callable[[Path], None], keep: int) -> Callable[[Path], None]:
    """The file ``write`` makes, cut after its first ``keep`` bytes."""
    def cut(path: Path) -> None:
        write(path)
        path.write_bytes(path.read_bytes()[:keep])
    return cut


def _csv(text: str, *options: str) -> dict:
    return {"argv": lambda d: ["import", str(d / "p.h5"), str(d / "r.csv"), "--name", "new", *options],
            "files": {"r.csv": text}}


def _add_experiment_at(rate: float) -> Callable[[Path], object]:
    def call(d: Path):
        from odsuite.domain.systeminfo import ChannelInfo, SensorType, Systeminfo
        from odsuite.store.project import open_project

        with open_project(d / "p.h5", "a") as p:
            return p.add_experiment("new", np.zeros((8, 1)), sampling_rate=rate, excitation=None,
                                    systeminfo=Systeminfo([ChannelInfo(sensor_type=SensorType.VOLTAGE)]))
    return call


def _render(output: str, *options: str) -> Callable[[Path], list[str]]:
    """``render`` of e1 in processed.h5 (its motion computed) into ``output``."""
    return lambda d: ["render", str(d / "processed.h5"), "e1", "-o", str(d / output), *options]


def _render_api(renderer: str, output: str, options) -> Callable[[Path], object]:
    """The registered ``renderer`` drawing e1 of processed.h5 into ``output`` with ``options`` (API)."""
    def call(d: Path):
        from odsuite.contracts.plugins import registries
        from odsuite.contracts.renderers import RenderRequest

        return registries().renderers.get(renderer).render(RenderRequest(d / "processed.h5", "e1", d / output, options,
                                                                         progress=False))
    return call


def _read_cod(d: Path):
    from odsuite_plugins.importers.legacy import read_cod

    return read_cod(d / "bad.COD")


def _validate(**changes):
    def run(_d: Path):
        import dataclasses

        from odsuite.domain.systeminfo import ChannelInfo, Systeminfo

        Systeminfo([dataclasses.replace(ChannelInfo(), **changes)]).validate(source="si")
    return run


def _body(**kw):
    def run(_d: Path):
        from odsuite.domain.model import RigidBody

        RigidBody(**{"name": "platform", "mass": 10.0, "inertia": np.eye(3), **kw})
    return run


def _spring(**kw):
    def run(_d: Path):
        from odsuite.domain.model import SpringDamper

        SpringDamper(**{"name": "k1", "point": np.zeros(3), "body": "platform", **kw})
    return run


def _effect(effect: str, values: dict):
    def run(_d: Path):
        from odsuite.contracts.plugins import registries
        from odsuite_plugins.models.thesis import thesis_dynamometer

        registries().effects.get(effect).values(thesis_dynamometer(), values)
    return run


CASES: list[Case] = [
    # legacy .CTR Systeminfo (Table E.2), through `odsuite import-legacy`
    Case("ctr-missing", "--systeminfo names a file that does not exist", "{dir}/bad.CTR: Systeminfo (.CTR) file not found",
         argv=legacy()),
    Case("ctr-empty", "empty .CTR file", "{dir}/bad.CTR: empty file", argv=legacy(), files={"bad.CTR": ""}),
    Case("ctr-33-rows", ".CTR with row 33 missing", "{dir}/bad.CTR: expected 34 rows (Table E.2), found 33",
         argv=legacy(), files={"bad.CTR": "\n".join(line for line in CTR_TEXT.splitlines()
                                                    if not line.startswith("| 33 |")) + "\n"}),
    Case("ctr-text-cell", "sensitivity of channel 4 is `abc`", "{dir}/bad.CTR: row 3 (sensitivity), channel 4: not a number: 'abc'", argv=legacy(),
         files={"bad.CTR": ctr_with(3, 4, "abc")}),
    Case("ctr-nan-cell", "sampling rate of channel 2 is `nan`", "{dir}/bad.CTR: row 7 (sampling frequency), channel 2: not a finite number: 'nan'", argv=legacy(),
         files={"bad.CTR": ctr_with(7, 2, "nan")}),
    Case("ctr-sensor-type", "sensor type 99 on channel 5", '{dir}/bad.CTR: row 0 (sensor type), channel 5: unknown code 99.0 (known: 0 = none, 1 = loadcell, 2 = proximity, 3 = voltage, 4 = accelerometer, 6 = auxiliary, 7 = velocity, 8 = pressure)', argv=legacy(), files={"bad.CTR": ctr_with(0, 5, "99")}),
    Case("ctr-flag", "invert flag 2 on channel 3", "{dir}/bad.CTR: row 13 (micro-units), channel 3: expected 0 (no) or 1 (yes), got '2'", argv=legacy(), files={"bad.CTR": ctr_with(13, 3, "2")}),
    Case("ctr-fractional-order", "filter order 2.5 on channel 6", "{dir}/bad.CTR: row 6 (filter order), channel 6: expected an integer, got '2.5'", argv=legacy(),
         files={"bad.CTR": ctr_with(6, 6, "2.5")}),
    Case("ctr-nine-channels", "row 33 lists 8 channels", '{dir}/bad.CTR: row 33 (nine-accelerometer channel assignment), channel 8: missing value', argv=legacy(), files={"bad.CTR": ctr_with(33, 8, "-")}),
    Case("ctr-coordinate-column-negative", "row 29 (generalized coordinate columns) gives column -1 (accepted, and stored)", '{dir}/bad.CTR: row 29 (generalized coordinate columns), channel 0: expected a column number from 0 to 24575, got -1', argv=legacy(), files={"bad.CTR": ctr_with(29, 0, "-1")}),
    # Systeminfo checks, through the .CTR or the API
    Case("ctr-coordinate-column-huge", "row 29 (generalized coordinate columns) gives column 1e30 (OverflowError: Python int too large to convert to C long)", '{dir}/bad.CTR: row 29 (generalized coordinate columns), channel 0: expected a column number from 0 to 24575, got 1000000000000000019884624838656', argv=legacy(), files={"bad.CTR": ctr_with(29, 0, "1e30")}),
    Case("ctr-ripple-huge", "pass-band ripple 1e300 dB on elliptic channel 2 (process: ValueError 'attempt to get argmin of an empty sequence')", '{dir}/bad.CTR: row 10 (pass-band ripple), channel 2: an elliptic filter needs dB from 1e-06 to below 200, got 1e+300', argv=legacy(), files={"bad.CTR": ctr_with(10, 2, "1e300")}),
    Case("ctr-ripple-above-attenuation", "pass-band ripple 70 dB above the stop-band attenuation 60 dB on elliptic channel 2 (process: scipy's 'Cannot design a filter')", '{dir}/bad.CTR: row 10 (pass-band ripple), channel 2: ripple_db 70 must be below attenuation_db 60', argv=legacy(), files={"bad.CTR": ctr_with(10, 2, "70")}),
    Case("si-zero-sensitivity", "accelerometer channel 2 with sensitivity 0 mV/unit", '{dir}/bad.CTR: row 3 (sensitivity), channel 2: sensitivity must be > 0 on an accelerometer channel, got 0.0 V/m/s^2', argv=legacy(),
         files={"bad.CTR": ctr_with(3, 2, "0")}),
    Case("si-rate-mismatch", "channel 3 sampled at 10000 Hz, channel 0 at 20000 Hz", "{dir}/bad.CTR: row 7 (sampling frequency), channel 3: sampling rate 10000.0 Hz differs from channel 0's 20000.0 Hz", argv=legacy(),
         files={"bad.CTR": ctr_with(7, 3, "10000")}),
    Case("si-limits-inverted", "DAQ low limit 5 V above the high limit on channel 7", '{dir}/bad.CTR: row 20 (DAQ low limit), channel 7: DAQ low limit 6.0 V must be below the high limit 0.5 V', argv=legacy(),
         files={"bad.CTR": ctr_with(20, 7, "6")}),
    Case("ctr-limit-huge", "DAQ high limit 1e300 V on channel 7 (accepted)", '{dir}/bad.CTR: row 19 (DAQ high limit), channel 7: DAQ limits -0.5 V to 1e+300 V: expected volts within +-1000 V, high at least 0.001 V above low', argv=legacy(),
         files={"bad.CTR": ctr_with(19, 7, "1e300")}),
    Case("ctr-limit-span", "DAQ limits -0.5 V to -0.4995 V on channel 7 (accepted: every sample counted as clipped)", '{dir}/bad.CTR: row 19 (DAQ high limit), channel 7: DAQ limits -0.5 V to -0.4995 V: expected volts within +-1000 V, high at least 0.001 V above low', argv=legacy(),
         files={"bad.CTR": ctr_with(19, 7, "-0.4995")}),
    Case("si-cutoff-above-nyquist", "high-pass cut-off 15000 Hz at 20000 Hz sampling on channel 2", '{dir}/bad.CTR: row 9 (low cut-off frequency), channel 2: cut-off must be > 0 and below the Nyquist frequency 10000 Hz, got 15000.0 Hz',
         argv=legacy(), files={"bad.CTR": ctr_with(9, 2, "15000")}),
    Case("si-offset-window", "offset window of 400 samples starting at 5000 in a 4096-sample record", '{dir}/bad.CTR: row 16 (offset length), channel 2: offset window samples 5000..5399 lies outside the record of 4096 samples',
         argv=legacy(), files={"bad.CTR": ctr_with(15, 2, "5000")}),
    Case("si-negative-gain", "Systeminfo channel with DAQ gain -1 (API)", 'si: row 17 (DAQ gain), channel 0: DAQ gain must be > 0, got -1.0', call=_validate(sampling_rate=1000.0, daq_gain=-1.0)),
    # legacy .DAT data
    Case("dat-missing", "data file that does not exist", '{dir}/none.DAT: data (.DAT/.VIZ) file not found', argv=legacy(ctr="good.CTR", dat="none.DAT")),
    Case("dat-empty", "empty .DAT file", '{dir}/bad.DAT: empty file, expected a data (.DAT/.VIZ) table', argv=legacy(ctr="good.CTR", dat="bad.DAT"), files={"bad.DAT": ""}),
    Case("dat-text-cell", ".DAT with `1.0e` in line 3", "{dir}/bad.DAT: line 3, column 0: not a number: '1.0e'", argv=legacy(ctr="good.CTR", dat="bad.DAT"),
         files={"bad.DAT": dat_edit(2, lambda line: "1.0e" + line[line.index("\t"):])}),
    Case("dat-ragged", ".DAT whose line 2 has one cell fewer", '{dir}/bad.DAT: line 2: ragged row, expected 11 cells (as line 1), found 10', argv=legacy(ctr="good.CTR", dat="bad.DAT"),
         files={"bad.DAT": dat_edit(1, lambda line: line.rsplit("\t", 1)[0])}),
    Case("dat-inf", ".DAT with `inf` in line 5", "{dir}/bad.DAT: line 5, column 0: not a finite number: 'inf'", argv=legacy(ctr="good.CTR", dat="bad.DAT"),
         files={"bad.DAT": dat_edit(4, lambda line: "inf" + line[line.index("\t"):])}),
    Case("dat-columns", ".DAT with 10 columns for an 11-channel Systeminfo", '{dir}/bad.DAT: 10 columns, but the Systeminfo describes 11 channels',
         argv=legacy(ctr="good.CTR", dat="bad.DAT"), files={"bad.DAT": dat_text(legacy_volts()[:, :10])}),
    # .COD generalized coordinates (API)
    Case("cod-columns", ".COD with 7 columns (API)", '{dir}/bad.COD: 7 columns, expected 6 per plate (x y z theta phi psi)', call=_read_cod, files={"bad.COD": "1 2 3 4 5 6 7\n"}),
    Case("cod-text", ".COD with `x` in line 1 (API)", "{dir}/bad.COD: line 1, column 3: not a number: 'x'", call=_read_cod, files={"bad.COD": "1 2 3 x 5 6\n"}),
    # LabVIEW .lvm, through `odsuite import-lvm`
    Case("lvm-not-lvm", ".lvm whose first line is not `LabVIEW Measurement`", "{dir}/bad.lvm: line 1 is 'hello', not 'LabVIEW Measurement' (not an .lvm file)", **lvm("hello\n1\t2\n")),
    Case("lvm-no-end-of-header", ".lvm without `***End_of_Header***`", '{dir}/bad.lvm: file header has no ***End_of_Header*** line',
         **lvm(LVM_TEXT.split("***End_of_Header***")[0])),
    Case("lvm-separator", ".lvm with Separator `Pipe`", "{dir}/bad.lvm: header field Separator has unknown value 'Pipe'", **lvm(LVM_TEXT.replace("Separator\tTab", "Separator\tPipe"))),
    Case("lvm-bad-number", ".lvm with data value `1,x`", "{dir}/bad.lvm: line 20, column 2: '1,x' is not a number", **lvm(LVM_TEXT.replace("\t1,5\t", "\t1,x\t"))),
    Case("lvm-delta-x", ".lvm with Delta_X 0", "{dir}/bad.lvm: field Delta_X of channel 0 is '0'; it must be > 0", **lvm(LVM_TEXT.replace("1,0E-4\t1,0E-4", "0\t0"))),
    Case("lvm-no-data", ".lvm with a channel header and no rows", '{dir}/bad.lvm: no data rows after the channel header',
         **lvm(LVM_TEXT[:LVM_TEXT.index("\t0,5")])),
    Case("lvm-unit-prefix", ".lvm whose force column is labelled `mN` (stored as volts at scale 1)", "{dir}/bad.lvm: channel 'Force': unit 'mN' is not one of m/s^2, g, N, V",
         **lvm(LVM_TEXT.replace("Y_Unit_Label\tNewtons", "Y_Unit_Label\tmN"))),
    Case('uff-unit-prefix', 'UFF time record in `mg` imported into a project without a rig (stored as volts at scale 1)', "{dir}/r.uff: dataset 2 (58 'acc') record 9 field 6 (ordinate units label): 'mg' is not one of m/s^2, g, N, V, Pa, m, m/s or NONE",
         argv=_uff_without_rig('mg')),
    Case('uff-units-mm', "UFF time record labelled m/s^2 in a file whose units set (164) is mm and mN (read as SI, 1000 times off)", "{dir}/r.uff: dataset 164 gives the file's units as 'mm (milli newton)' (length factor 1000, force factor 1000 per SI unit): record 'acc' (m/s^2) would be read as SI; odsuite imports records in SI units only",
         argv=_uff_units("m/s^2", "mm (milli newton)", 1000.0, 1000.0)),
    Case("uff-units-cut", "UFF whose units set (164) lacks its line of factors (it named no dataset: 'Error when reading data-set(s).')", "{dir}/r.uff: not a readable UFF file (dataset 1 (164): Error reading data-set #164)",
         argv=_uff_units_cut),
    Case("uff-units-negative", "UFF of a time record in V and nodes whose units set (164) has the length factor -1 (the nodes were stored mirrored)", "{dir}/r.uff: dataset 1 (164 units 'mirror') field 'length': expected a factor from 1e-09 to 1e+09 file units per SI unit, got -1",
         argv=_uff_units("V", "mirror", -1.0, 1.0, nodes=True)),
    Case("uff-units-nan", "UFF of a time record in V and nodes whose units set (164) has the length factor NaN (the nodes were stored as NaN)", "{dir}/r.uff: dataset 1 (164 units 'odd') field 'length': expected a factor from 1e-09 to 1e+09 file units per SI unit, got nan",
         argv=_uff_units("V", "odd", float("nan"), 1.0, nodes=True)),
    Case("lvm-channel-rates", ".lvm whose second channel's Delta_X is twice the first's (stored at the first's rate)", "{dir}/bad.lvm: line 16, Delta_X of channel 1: '2,0E-4' s differs from channel 0's 0.0001 s; odsuite stores a record at one sampling rate",
         **lvm(LVM_TEXT.replace("1,0E-4\t1,0E-4", "1,0E-4\t2,0E-4"))),
    Case("lvm-segment-rate", ".lvm whose second segment has Delta_X 2,0E-4 (both read at the last segment's rate)", "{dir}/bad.lvm: line 29: segment 2's Delta_X [0.0002, 0.0002] differ from segment 1's [0.0001, 0.0001]; odsuite reads the segments as one record",
         **lvm(LVM_TEXT + LVM_SEGMENT.replace("1,0E-4\t1,0E-4", "2,0E-4\t2,0E-4"))),
    Case("lvm-segment-order", ".lvm whose second segment lists Response before Force (its columns were read as the first's)", "{dir}/bad.lvm: line 31: segment 2's channel names (X_Value) ['Response', 'Force'] differ from segment 1's ['Force', 'Response']; odsuite reads the segments as one record",
         **lvm(LVM_TEXT + LVM_SEGMENT.replace("Force\tResponse", "Response\tForce"))),
    Case("lvm-segment-channels", ".lvm whose second segment has one channel (ValueError: inhomogeneous shape)", "{dir}/bad.lvm: line 31: segment 2's channel names (X_Value) ['Force'] differ from segment 1's ['Force', 'Response']; odsuite reads the segments as one record",
         **lvm(LVM_TEXT + LVM_SEGMENT.replace("Channels\t2", "Channels\t1").replace("Force\tResponse", "Force"))),
    Case("lvm-force-channel", "--force-channel names no channel of the file", "{dir}/bad.lvm: no channel 'Hammer'; channels are Force, Response", **lvm(LVM_TEXT, "--force-channel", "Hammer")),
    # UFF (API)
    Case("uff-missing", "UFF file that does not exist (API)", '{dir}/none.uff: UFF file not found', call=lambda d: _read_uff(d, "none.uff")),
    Case("uff-undefined-cs", "UFF node 2 defined in coordinate system 5, which the file lacks (API)", '{dir}/bad.uff: node 2 uses undefined coordinate system 5',
         call=_uff_undefined_cs),
    # CLI options
    Case("force-point-two-numbers", "--force-point=1,2", "--force-point: expected three numbers X,Y,Z, got '1,2'", argv=legacy(ctr="good.CTR", point="1,2")),
    Case("force-point-text", "--force-point=a,b,c", "--force-point: expected three numbers X,Y,Z, got 'a,b,c'", argv=legacy(ctr="good.CTR", point="a,b,c")),
    Case("force-point-nan", "--force-point=nan,0,0", "--force-point: expected finite numbers, got 'nan,0,0'", argv=legacy(ctr="good.CTR", point="nan,0,0")),
    Case("force-point-mixed-units", "--force-point=300mm,0,1800 (a unit on some numbers; a bare 0 is 0 in any unit, 1800 is not)", "--force-point: give a unit on every number other than 0 or on none (bare numbers are mm), got '300mm,0,1800'", argv=legacy(ctr="good.CTR", point="300mm,0,1800")),
    Case("force-point-far", "acquire --force-point=1e308m,0,0 (overflowed: 'outside every body ... inf mm away' after numpy's warnings)", "--force-point: expected a point within 10000 m of the rig's origin, got '1e308m,0,0'", argv=lambda d: ["acquire", str(d / "p.h5"), "--name", "new", "--force-point=1e308m,0,0", "--force-dir=+z"]),
    Case("force-dir-zero", "--force-dir=0,0,0", "--force-dir: the zero vector '0,0,0' has no direction", argv=legacy(ctr="good.CTR", direction="0,0,0")),
    Case("force-dir-axis", "--force-dir=+w", "--force-dir: expected an axis +x, -x, +y, -y, +z, -z or three numbers dx,dy,dz, got '+w'", argv=legacy(ctr="good.CTR", direction="+w")),
    Case("experiment-exists", "--name of an experiment the project holds", "{dir}/p.h5: experiment 'e1' already exists; choose another name", argv=legacy(ctr="good.CTR", name="e1")),
    Case("experiment-slash", "--name a/b", "{dir}/p.h5: experiment name must be a non-empty string without '/' and not starting with '.', got 'a/b'", argv=legacy(ctr="good.CTR", name="a/b")),
    Case("unknown-experiment", "process --experiment nosuch", "{dir}/p.h5: no experiment named 'nosuch' (experiments: e1)",
         argv=lambda d: ["process", str(d / "p.h5"), "--experiment", "nosuch"]),
    Case("unknown-rig", "new --rig nosuch", "unknown rig 'nosuch': not a registered rig (known: thesis-dynamometer) and not a .toml rig file", argv=lambda d: ["new", str(d / "q.h5"), "--rig", "nosuch"]),
    Case("unknown-daq", "acquire --daq foo", "unknown daq backend 'foo' (known: ni, sim)",
         argv=lambda d: ["acquire", str(d / "p.h5"), "--daq", "foo", "--name", "new"]),
    Case("unknown-scenario", "acquire --daq sim --scenario T99", "unknown scenario 'T99' (known: T1, T2, T3, T4, T5, T6, T7, T8)",
         argv=lambda d: ["acquire", str(d / "p.h5"), "--daq", "sim", "--scenario", "T99", "--name", "new"]),
    Case("acquire-samples", "acquire --samples 0", "acquisition setting 'n_samples': must be an integer from 2 to 17179869184, got 0",
         argv=lambda d: ["acquire", str(d / "p.h5"), "--daq", "sim", "--samples", "0", "--name", "new"]),
    Case("acquire-rig-pretrigger", "acquire with the default --samples 4096 on a rig whose file sets [acquisition] pre_trigger = 4096",
         "--samples 4096 is not more than the 4096 samples before the trigger that rig 'bench' sets ([acquisition] pre_trigger = 4096): pass --samples above 4096 (e.g. --samples 8192) or --pretrigger below 4096",
         argv=_on_bench_rig("[acquisition]\npre_trigger = 4096\n", "acquire", "{project}", "--name", "new")),
    Case("magnify-one-number", "render --magnify 5", "--magnify: expected two numbers 'A,B', got '5'",
         argv=lambda d: ["render", str(d / "p.h5"), "e1", "-o", str(d / "m.gif"), "--magnify", "5"]),
    Case("magnify-text", "render --magnify big,2", "--magnify: expected two numbers 'A,B', got 'big,2'",
         argv=lambda d: ["render", str(d / "p.h5"), "e1", "-o", str(d / "m.gif"), "--magnify", "big,2"]),
    Case("magnify-digit-group", "render --magnify 1_0,2", "--magnify: expected two numbers 'A,B', got '1_0,2'",
         argv=lambda d: ["render", str(d / "p.h5"), "e1", "-o", str(d / "m.gif"), "--magnify", "1_0,2"]),
    Case("magnify-negative", "render --magnify=-5,2", "--magnify: magnification factors must be finite numbers >= 0, got '-5,2'",
         argv=lambda d: ["render", str(d / "p.h5"), "e1", "-o", str(d / "m.gif"), "--magnify=-5,2"]),
    Case("magnify-huge", "render --magnify 1e300,1e300 (drew overflowed geometry)", "--magnify 1e+300,1e+300: draws the largest corner motion 9.42e+295 times the plate's 170 mm size, more than the 10 times a picture can show; at most --magnify 1.06e+05,1.06e+05 for this motion",
         argv=_render("m.gif", "--magnify", "1e300,1e300")),
    Case("view-nan", "render --view nan,0 (a movie with nothing drawn)", "--view: angles must be finite numbers of degrees from -360 to 360, got 'nan,0'",
         argv=_render("m.gif", "--view", "nan,0")),
    Case("view-projection-inf", "render --figure projection --view x,inf,0,0", "--view: angles must be finite numbers of degrees from -360 to 360, got 'x,inf,0,0'",
         argv=_render("v.png", "--figure", "projection", "--view", "x,inf,0,0")),
    Case("view-huge", "render --view 1e300,1e300 (degrees that name no direction)", "--view: angles must be finite numbers of degrees from -360 to 360, got '1e300,1e300'",
         argv=_render("m.gif", "--view", "1e300,1e300")),
    Case("view-elevation", "render --view 0,91 (the camera over the top)", "--view: the elevation must be from -90 to 90 degrees, got '0,91'",
         argv=_render("m.gif", "--view", "0,91")),
    Case("not-a-project", "info on a text file", '{dir}/notes.h5: not an HDF5 file, so not an odsuite project', argv=lambda d: ["info", str(d / "notes.h5")],
         files={"notes.h5": "just notes\n"}),
    # rig definitions (TOML), through `odsuite new --rig FILE`
    Case("rig-aa-attenuation-huge", "rig file whose elliptic anti-aliasing filter has attenuation_db 1e300 (scipy's 'Cannot design a filter')", "{dir}/bad.toml: acquisition field 'anti_aliasing'.attenuation_db: expected dB from 1e-06 to below 200, got 1e+300",
         **new_rig(RIG_TOML + '[acquisition]\nanti_aliasing = { family = "elliptic", order = 8, cutoff_hz = 3000.0, attenuation_db = 1e300 }\n')),
    Case("rig-aa-ripple-tiny", "rig file whose elliptic anti-aliasing filter has ripple_db 1e-300 (its poles NaN: a simulated hammer 'peaked near nan N')", "{dir}/bad.toml: acquisition field 'anti_aliasing'.ripple_db: expected dB from 1e-06 to below 200, got 1e-300",
         **new_rig(RIG_TOML + '[acquisition]\nanti_aliasing = { family = "elliptic", order = 8, cutoff_hz = 3000.0, ripple_db = 1e-300 }\n')),
    Case("rig-aa-cutoff-huge", "rig file whose anti-aliasing filter's cutoff_hz is 1e300 (acquire: OverflowError 'Numerical result out of range')", "{dir}/bad.toml: acquisition field 'anti_aliasing'.cutoff_hz: expected 0.0001 to 1e+08 Hz, got 1e+300",
         **new_rig(RIG_TOML + '[acquisition]\nanti_aliasing = { family = "butterworth", order = 8, cutoff_hz = 1e300 }\n')),
    Case("rig-iepe-corner", "rig file whose [acquisition] iepe_corner_hz is 1e300", "{dir}/bad.toml: acquisition field 'iepe_corner_hz': expected 0.0001 to 1e+08 Hz, got 1e+300",
         **new_rig(RIG_TOML + '[acquisition]\niepe_corner_hz = 1e300\n')),
    Case("rig-invalid-toml", "rig file with `name = ` and no value", '{dir}/bad.toml: not valid TOML: Invalid value (at line 1, column 8)', **new_rig('name = \n')),
    Case("rig-missing-name", "rig file without `name`", "{dir}/bad.toml: missing field 'name'", **new_rig(RIG_TOML.replace('name = "bench"\n', ""))),
    Case("rig-bad-vector", "sensor position with 2 numbers", "{dir}/bad.toml: sensors[0] 'a1' field 'position': expected 3 finite numbers, got [0.0, 0.0]",
         **new_rig(RIG_TOML.replace("position = [0.0, 0.0, 0.0]", "position = [0.0, 0.0]"))),
    Case("rig-zero-axis", "sensor axis [0, 0, 0]", "{dir}/bad.toml: sensors[0] 'a1' field 'axis': zero vector",
         **new_rig(RIG_TOML.replace("axis = [0.0, 0.0, 1.0]", "axis = [0.0, 0.0, 0.0]"))),
    Case("rig-unknown-body", "sensor on body `table`, not defined", "{dir}/bad.toml: sensors[0] 'a1' field 'body': no body named 'table'",
         **new_rig(RIG_TOML.replace('body = "plate"', 'body = "table"'))),
    Case("rig-duplicate-channel", "two sensors on channel 1", "{dir}/bad.toml: two sensors share a channel: 'a1' and 'a2' (field 'channel', both 1)",
         **new_rig(RIG_TOML + RIG_TOML[RIG_TOML.index("[[sensors]]"):].replace('"a1"', '"a2"'))),
    Case("rig-negative-mass", "body mass -2 kg", "{dir}/bad.toml: body 'plate' field 'mass': must be > 0, got -2.0", **new_rig(RIG_TOML.replace("mass = 2.0", "mass = -2.0"))),
    Case("rig-inertia", "inertia not positive definite", "{dir}/bad.toml: body 'plate' field 'inertia': not positive definite",
         **new_rig(RIG_TOML.replace("[0, 0, 0.1]]", "[0, 0, -0.1]]"))),
    # models (API)
    Case("model-negative-mass", "rigid body with mass -1 kg (API)", "body 'platform' field 'mass': must be a finite number > 0 kg, got -1.0", call=_body(mass=-1.0)),
    Case("model-inertia-asymmetric", "rigid body inertia with Ixy != Iyx (API)", "body 'platform' field 'inertia': not symmetric",
         call=_body(inertia=np.array([[1.0, 0.2, 0], [0, 1, 0], [0, 0, 1]]))),
    Case("model-negative-stiffness", "spring with stiffness [-1, 0, 0] N/m (API)", "spring 'k1' field 'stiffness': must be >= 0, got [-1.0, 0.0, 0.0]",
         call=_spring(stiffness=np.array([-1.0, 0, 0]))),
    Case("effect-unknown-parameter", "stiffness effect with parameter `foo` (API)", "effect 'stiffness': unknown parameter(s) ['foo'] (known: ['scale_spring1'", call=_effect("stiffness", {"foo": 1.0})),
    # names are data: refused when not printable, printed escaped
    Case("name-newline", "--name with a newline", "{dir}/p.h5: experiment name must be printable text without control characters or undecodable bytes, got 'a\\nb'", argv=legacy(ctr="good.CTR", name="a\nb")),
    Case("name-ansi", "--name with an ANSI colour escape", "{dir}/p.h5: experiment name must be printable text without control characters or undecodable bytes, got '\\x1b[31mred'", argv=legacy(ctr="good.CTR", name="\x1b[31mred")),
    Case("name-too-long", "--name of 201 characters", "{dir}/p.h5: experiment name must be at most 200 characters, got 201: 'nnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnn'...", argv=legacy(ctr="good.CTR", name="n" * 201)),
    Case("name-undecodable", "--name with the byte 0xff (not UTF-8)", "{dir}/p.h5: experiment name must be printable text without control characters or undecodable bytes, got 'x\\udcff'", argv=legacy(ctr="good.CTR", name="x\udcff")),
    Case("name-markup-path", "info on a path with markup, 0xff and an escape", "{dir}/[/x]\\xff\\x1b[31m.h5: no such project file",
         argv=lambda d: ["info", str(d / "[/x]\udcff\x1b[31m.h5")]),
    # numeric limits that follow from physics and memory
    Case("acquire-samples-huge", "acquire --samples 9223372036854775808", "acquisition setting 'n_samples': must be an integer from 2 to 17179869184, got 9223372036854775808",
         argv=lambda d: ["acquire", str(d / "p.h5"), "--samples", "9223372036854775808", "--name", "new"]),
    Case("acquire-samples-memory", "acquire --samples 17179869184 (more than free memory)", "{dir}/p.h5: --samples 17179869184: a record of 17179869184 samples x 11 channels needs 1441792 MiB",
         argv=lambda d: ["acquire", str(d / "p.h5"), "--samples", "17179869184", "--name", "new"]),
    Case("acquire-rate-high", "acquire --rate 1e308", "acquisition setting 'sampling_rate': must be between 0.1 Hz and 1e+08 Hz, got 1e+308 Hz", argv=lambda d: ["acquire", str(d / "p.h5"), "--rate", "1e308", "--name", "new"]),
    Case("acquire-rate-low", "acquire --rate 1e-300", "acquisition setting 'sampling_rate': must be between 0.1 Hz and 1e+08 Hz, got 1e-300 Hz", argv=lambda d: ["acquire", str(d / "p.h5"), "--rate", "1e-300", "--name", "new"]),
    Case("acquire-seed", "acquire --seed -1", "simulator option 'seed': an integer from 0 to 2**63-1, got -1", argv=lambda d: ["acquire", str(d / "p.h5"), "--seed", "-1", "--name", "new"]),
    Case("acquire-trigger-nan", "acquire --trigger-level nan", "acquisition setting 'trigger_level': must be a finite number, got nan",
         argv=lambda d: ["acquire", str(d / "p.h5"), "--trigger-level", "nan", "--name", "new"]),
    Case("option-float-digit-group", "acquire --rate 1_000 (Python's float() reads 1000; data files refuse digit groups)", "--rate: expected a number without digit groups ('_'), got '1_000'",
         argv=lambda d: ["acquire", str(d / "p.h5"), "--rate", "1_000", "--name", "new"]),
    Case("option-int-digit-group", "acquire --samples 4_096", "--samples: expected a number without digit groups ('_'), got '4_096'",
         argv=lambda d: ["acquire", str(d / "p.h5"), "--samples", "4_096", "--name", "new"]),
    Case("render-workers", "render --workers 0", "--workers: at least 1 render process, got 0", argv=lambda d: ["render", str(d / "p.h5"), "e1", "-o", str(d / "m.gif"), "--workers", "0"]),
    Case("render-fps-tiny", "render --duration 3000 --fps 0.001 (a GIF frame's delay overflowed)", "fps: expected 0.001526 to 1000 frames per second (a GIF frame lasts at most 655.35 s), got 0.001",
         argv=_render("m.gif", "--duration", "3000", "--fps", "0.001")),
    Case("render-fps-huge", "render -o m.mp4 --fps 1e300 (ffmpeg refused the rate)", "fps: expected 0.001526 to 1000 frames per second (a GIF frame lasts at most 655.35 s), got 1e+300",
         argv=_render("m.mp4", "--fps", "1e300")),
    Case("render-gif-fps-above-50", "render -o m.gif --fps 60 (played at 50 fps, reported as 60)", "--fps 60: a GIF plays at most 50 frames per second (its frame delays are whole hundredths of a second and players slow delays under 2/100 s down); give --fps 50 or less, or write an .mp4",
         argv=_render("m.gif", "--fps", "60")),
    Case("render-slowdown-huge", "render --slowdown 1e300 (its message printed a number of 298 digits)", "slowdown 1e+300 needs 1.25e+297 frames per sample at 25 fps",
         argv=_render("m.gif", "--slowdown", "1e300")),
    Case("lvm-channels-zero", ".lvm with Channels 0", "{dir}/bad.lvm: line 17: field Channels is 0; it must be from 1 to 4096", **lvm(LVM_TEXT.replace("Channels\t2", "Channels\t0"))),
    Case("lvm-channels-negative", ".lvm with Channels -1", "{dir}/bad.lvm: line 17: field Channels is -1; it must be from 1 to 4096", **lvm(LVM_TEXT.replace("Channels\t2", "Channels\t-1"))),
    Case("lvm-channels-huge", ".lvm with Channels 1000000000", "{dir}/bad.lvm: line 17: field Channels is 1000000000; it must be from 1 to 4096", **lvm(LVM_TEXT.replace("Channels\t2", "Channels\t1000000000"))),
    Case("lvm-delta-x-tiny", ".lvm with Delta_X 1e-320", "{dir}/bad.lvm: field Delta_X of channel 0 is '1E-320' s, a sampling rate outside 0.1..1e+08 Hz", **lvm(LVM_TEXT.replace("1,0E-4\t1,0E-4", "1E-320\t1E-320"))),
    Case("lvm-delta-x-huge", ".lvm with Delta_X 1e308", "{dir}/bad.lvm: field Delta_X of channel 0 is '1E308' s, a sampling rate outside 0.1..1e+08 Hz", **lvm(LVM_TEXT.replace("1,0E-4\t1,0E-4", "1E308\t1E308"))),
    Case("lvm-delta-x-text", ".lvm with Delta_X `1,0E-4s` (it said line 0)", "{dir}/bad.lvm: line 16, Delta_X of channel 0: '1,0E-4s' is not a number", **lvm(LVM_TEXT.replace("1,0E-4\t1,0E-4", "1,0E-4s\t1,0E-4"))),
    Case("lvm-x0-text", ".lvm with X0 `0,0E+0x` on the second channel (it said line 0)", "{dir}/bad.lvm: line 15, X0 of channel 1: '0,0E+0x' is not a number", **lvm(LVM_TEXT.replace("X0\t0,0E+0\t0,0E+0", "X0\t0,0E+0\t0,0E+0x"))),
    Case("lvm-cut-off", ".lvm whose header says 8 samples, holding 4 rows", "{dir}/bad.lvm: header field Samples says 8 samples per channel, the file holds 4 rows (cut off?)", **lvm(LVM_TEXT.replace("Samples\t4\t4", "Samples\t8\t8"))),
    Case("lvm-short-row", ".lvm whose last row lacks its second value", "{dir}/bad.lvm: data row 4, channel 'Response': value missing (1 missing in all; cut off?)", **lvm(LVM_TEXT.replace("\t0,0\t0,5\n", "\t0,0\n"))),
    Case("ctr-sensitivity-tiny", "sensitivity 1e-300 mV/unit on channel 2", "{dir}/bad.CTR: row 3 (sensitivity), channel 2: sensitivity 1e-303 V/m/s^2 is outside what any sensor has (1e-09 to 1000 V/m/s^2)", argv=legacy(), files={"bad.CTR": ctr_with(3, 2, "1e-300")}),
    Case("ctr-filter-order", "filter order 1000 on channel 6", "{dir}/bad.CTR: row 6 (filter order), channel 6: filter order 1000 is above 30, where IIR designs lose their poles to rounding", argv=legacy(), files={"bad.CTR": ctr_with(6, 6, "1000")}),
    Case("rig-inertia-text", "inertia `\"a\"`", "{dir}/bad.toml: body 'plate' field 'inertia': expected a symmetric 3x3 matrix of numbers, got 'a'",
         **new_rig(RIG_TOML.replace("inertia = [[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]", 'inertia = "a"'))),
    Case("rig-inertia-ragged", "inertia with a row of 2 numbers", "{dir}/bad.toml: body 'plate' field 'inertia': expected a symmetric 3x3 matrix of numbers, got [[0.1, 0], [0, 0.1, 0], [0, 0, 0.1]]",
         **new_rig(RIG_TOML.replace("inertia = [[0.1, 0, 0]", "inertia = [[0.1, 0]"))),
    Case("rig-sensor-no-name", "sensor without `name`", "{dir}/bad.toml: sensors[0] field 'name': expected a non-empty name, got None", **new_rig(RIG_TOML.replace('name = "a1"\n', ""))),
    Case("rig-bodies-number", "`bodies = 5`", "{dir}/bad.toml: field 'bodies': expected a list of [[bodies]] tables, got 5", **new_rig('name = "bench"\nbodies = 5\n')),
    Case("rig-no-bodies", "rig file with a force sensor and no [[bodies]]", "{dir}/bad.toml: field 'bodies': no [[bodies]] table; a rig needs at least one body (a project without geometry: --rig none)",
         **new_rig('name = "bench"\n[[sensors]]\nname = "hammer"\nkind = "force"\nchannel = 0\n')),
    Case("rig-duplicate-body", "two bodies named plate", "{dir}/bad.toml: bodies[1]: field 'name': a second body named 'plate'",
         **new_rig(RIG_TOML.replace("[[sensors]]", RIG_TOML[RIG_TOML.index("[[bodies]]"):RIG_TOML.index("[[sensors]]")] + "[[sensors]]"))),
    Case("rig-force-channel", "force_channel = 99 beyond the sensors' channels", "{dir}/bad.toml: field 'force_channel': channel 99 lies beyond the sensors' channels (highest 1); give channel_count to leave the channels between unused", **new_rig(RIG_TOML.replace("force_channel = 0", "force_channel = 99"))),
    Case("rig-channel-count-negative", "channel_count = -3", "{dir}/bad.toml: field 'channel_count': expected an integer from 1 to 4096, got -3", **new_rig(RIG_TOML.replace("force_channel = 0", "force_channel = 0\nchannel_count = -3"))),
    Case("rig-channel-count-huge", "channel_count = 100000", "{dir}/bad.toml: field 'channel_count': expected an integer from 1 to 4096, got 100000", **new_rig(RIG_TOML.replace("force_channel = 0", "force_channel = 0\nchannel_count = 100000"))),
    Case("rig-spring-unknown-body", "spring on body `table`, not defined", "{dir}/bad.toml: springs[0] 's1' field 'body': no body named 'table' (bodies: plate)",
         **new_rig(RIG_TOML + SPRING.replace('body = "plate"', 'body = "table"'))),
    Case("rig-spring-negative", "spring stiffness -5 N/m along y", "{dir}/bad.toml: springs[0] 's1' field 'stiffness': must not be negative, got [1000.0, -5.0, 1000.0]",
         **new_rig(RIG_TOML + SPRING.replace("[1000.0, 1000.0, 1000.0]", "[1000.0, -5.0, 1000.0]"))),
    Case("rig-spring-massless-body", "spring on a body without mass", "{dir}/bad.toml: springs[0] 's1' field 'body': body 'floor' has no mass, so it does not move; attach the spring to 'ground' instead",
         **new_rig(RIG_TOML.replace("[[sensors]]", '[[bodies]]\nname = "floor"\n[[sensors]]') + SPRING.replace('body = "plate"', 'body = "floor"'))),
    Case("rig-axis-not-unit", "sensor axis [0, 0, 2]", "{dir}/bad.toml: sensors[0] 'a1' field 'axis': expected a unit vector, got [0.0, 0.0, 2.0] of length 2 (a gain belongs in 'sensitivity')",
         **new_rig(RIG_TOML.replace("axis = [0.0, 0.0, 1.0]", "axis = [0.0, 0.0, 2.0]"))),
    Case("rig-massless-solver", "a coordinate solver asked for on a body without mass", "{dir}/bad.toml: body 'floor' field 'solver': the body has no mass, so it does not move in the model and its sensors cannot give it coordinates (give it a 'mass' or drop the field)",
         **new_rig(RIG_TOML.replace("[[sensors]]", '[[bodies]]\nname = "floor"\nsolver = "least-squares"\n[[sensors]]'))),
    Case("rig-solver-too-few-directions", "least squares asked for on a body with one sensor direction", "rig 'bench' ({dir}/bad.toml): body 'plate' field 'solver': 'least-squares' cannot solve the body from its sensors (a1 along [0.0, 0.0, 1.0] at [0.0, 0.0, 0.0] mm)",
         **new_rig(RIG_TOML.replace("mass = 2.0", 'mass = 2.0\nsolver = "least-squares"'))),
    Case("rig-solver-unknown", "solver `kalman`, not registered", "rig 'bench' ({dir}/bad.toml): body 'plate' field 'solver': unknown coordinate solver 'kalman' (known: least-squares, padgaonkar-nine)",
         **new_rig(RIG_TOML.replace("mass = 2.0", 'mass = 2.0\nsolver = "kalman"'))),
    Case("rig-processing-cutoff", "[processing] high-pass at -3 Hz", "{dir}/bad.toml: [processing].filter.cutoff_hz: expected one frequency in Hz (> 0) for a highpass filter, got -3.0",
         **new_rig(RIG_TOML + '[processing]\nfilter = { type = "highpass", cutoff_hz = -3.0 }\n')),
    # output paths
    Case("output-is-project", "export-legacy --cod naming the project itself", "--cod {dir}/p.h5: that is the project {dir}/p.h5 or one of its own files; give another file name",
         argv=lambda d: ["export-legacy", str(d / "p.h5"), "e1", "--cod", str(d / "p.h5")]),
    Case("output-is-lock", "export-legacy --cod naming the project's lock file", "--cod {dir}/.p.h5.odsuite-lock: that is the project {dir}/p.h5 or one of its own files; give another file name",
         argv=lambda d: ["export-legacy", str(d / "p.h5"), "e1", "--cod", str(d / ".p.h5.odsuite-lock")]),
    Case("output-folder", "export-legacy --cod naming a folder", "--cod {dir}: is a folder; give a file name",
         argv=lambda d: ["export-legacy", str(d / "p.h5"), "e1", "--cod", str(d)]),
    Case("output-missing-folder", "render -o into a folder that does not exist", "-o {dir}/none/m.gif: folder {dir}/none does not exist",
         argv=lambda d: ["render", str(d / "p.h5"), "e1", "-o", str(d / "none" / "m.gif")]),
    Case("output-link-missing-folder", "export-uff -o naming a link into a folder that does not exist", "-o {dir}/d.uff: folder {dir}/none does not exist",
         argv=lambda d: ((d / "d.uff").symlink_to(d / "none" / "x.uff"), ["export-uff", str(d / "p.h5"), "e1", "-o", str(d / "d.uff")])[1]),
    Case("output-virtual-fs", "export-uff -o into /proc, a file system with no disk (it said 'no space left on /proc')", "/proc/x.uff: /proc is a virtual file system that holds no files; give a path in another folder; nothing written",
         argv=lambda d: ["export-uff", str(d / "p.h5"), "e1", "-o", "/proc/x.uff"]),
    Case("new-in-proc", "new /proc/p.h5 (it said 'project is open in another process (pid ?)')", "/proc/p.h5: cannot create lock file /proc/.p.h5.odsuite-lock: No such file or directory",
         argv=lambda d: ["new", "/proc/p.h5"]),
    Case("output-link-loop", "render -o naming a symbolic link to itself (the link was replaced by the figure)", "-o {dir}/loop.png: is a symbolic link that leads back to itself (a loop), which has no file to write to; remove it or give another file name",
         argv=lambda d: ((d / "loop.png").symlink_to("loop.png"), _render("loop.png", "--figure", "projection")(d))[1]),
    Case("dat-fifo", "a named pipe (FIFO) given as the .DAT file", "{dir}/pipe.DAT: not a regular file (a pipe or device), expected a data (.DAT/.VIZ) file",
         argv=lambda d: (os.mkfifo(d / "pipe.DAT"), legacy(ctr="good.CTR", dat="pipe.DAT")(d))[1]),
    Case("dat-device", "/dev/zero given as the .DAT file", "/dev/zero: not a regular file (a pipe or device), expected a data (.DAT/.VIZ) file",
         argv=lambda d: legacy(ctr="good.CTR", dat="/dev/zero")(d)),
    Case("process-cutoff-nan", "process --corrected --cutoff nan", "--cutoff: must be a finite frequency >= 0.01 Hz, got nan",
         argv=lambda d: ["process", str(d / "p.h5"), "--corrected", "--cutoff", "nan"]),
    Case("process-cutoff-alone", "process --cutoff without --corrected", "--cutoff 40 Hz: sets where the corrected coordinates hand over to the model, so it applies with --corrected only; add --corrected or leave --cutoff out",
         argv=lambda d: ["process", str(d / "p.h5"), "--cutoff", "40"]),
    Case("modes-fmin-nan", "modes --fmin nan", "--fmin: must be a finite frequency >= 0 Hz, got nan",
         argv=lambda d: ["modes", str(d / "p.h5"), "--experiment", "e1", "--fmin", "nan"]),
    Case("project-read-only", "import-legacy into a project with mode 0444", "{dir}/p.h5: project is read-only; make it writable (chmod u+w) to change it",
         argv=lambda d: ((d / "p.h5").chmod(0o444), legacy(ctr="good.CTR")(d))[1]),
    Case("uff-cut", "UFF cut off inside its second function's data (API)", "{dir}/bad.uff: dataset 3 (type 58) from line 24 has no closing '-1' line (cut off?)", call=lambda d: _uff_damaged(d, "cut")),
    Case("uff-count", "UFF function whose header says 9 points, holding 8 (API)", "{dir}/bad.uff: dataset 2 (58) from line 8: 8 values, but its record 7 says 9 points (a line lost or doubled, or the count changed?)", call=lambda d: _uff_damaged(d, "count")),
    Case("uff-line-lost", "UFF function that lost its last data line (API)", "{dir}/bad.uff: dataset 2 (58) from line 8: 4 values, but its record 7 says 8 points (a line lost or doubled, or the count changed?)", call=lambda d: _uff_damaged(d, "line-lost")),
    Case("uff-58b-count", "binary UFF 58b whose record 7 says 9 points, its 64 data bytes holding 8 (API)", "{dir}/bad.uff: dataset 2 (58) 'acc0': header says 9 points, found 8 values and 8 abscissae", call=lambda d: _uff_damaged(d, "58b-count")),
    Case("uff-rig-unknown-node", "UFF time record at node 7, which no sensor of the project's rig has (API)", "{dir}/r.uff: time record 'acc2' at UFF node 7 direction -3 matches no sensor of rig 'bench' (sensor nodes: 5)", call=lambda d: _uff_on_rig(d, "unknown-node")),
    Case("uff-rig-duplicate", "two UFF time records at one sensor's node and line, +z and -z (API)", "{dir}/r.uff: time records 'acc' and 'acc2' (UFF node 5 direction -3) both match sensor 'a1' of rig 'bench'", call=lambda d: _uff_on_rig(d, "duplicate")),
    Case("uff-rig-lengths", "UFF time records of 8 and 10 samples onto a rig (API)", "{dir}/r.uff: time record 'acc' has 8 samples, record 'impact' 10; records must be of one length", call=lambda d: _uff_on_rig(d, "lengths")),
    Case("uff-rig-volts-no-sensitivity", "UFF time record in V for a rig sensor without a sensitivity (API)", "{dir}/r.uff: time record 'acc' is in volts, but rig 'bench' sensor 'a1' (channel 1) has no 'sensitivity' to convert it", call=lambda d: _uff_on_rig(d, "volts")),
    Case("lock-link", "acquire while the lock file name is a symbolic link to a user's file", "{dir}/p.h5: lock file {dir}/.p.h5.odsuite-lock is a link, which odsuite never follows; remove it",
         argv=lambda d: (_plant_link(d, ".p.h5.odsuite-lock"), ["acquire", str(d / "p.h5"), "--name", "n", "--samples", "1024", "--pretrigger", "100"])[1]),
    Case("lock-foreign-file", "acquire while a user's file holds the lock file name", "{dir}/p.h5: {dir}/.p.h5.odsuite-lock is in the way of the writer lock and was not written by odsuite; move it elsewhere",
         argv=lambda d: ["acquire", str(d / "p.h5"), "--name", "n", "--samples", "1024", "--pretrigger", "100"], files={".p.h5.odsuite-lock": "my notes\n"}),
    Case("project-hard-link", "acquire into a project that has a second hard link", "{dir}/p.h5: project has 2 hard links (names of one file), which a write would split; keep one name or give each a copy (cp) to change it",
         argv=lambda d: (os.link(d / "p.h5", d / "p2.h5"), ["acquire", str(d / "p.h5"), "--name", "n", "--samples", "1024", "--pretrigger", "100"])[1]),
    Case("new-folder", "new on a folder (its links were read as a file's hard links)", "{dir}: is a folder; give the new project's file name",
         argv=lambda d: ["new", str(d)]),
    Case("new-link", "new on a symbolic link to a project in a folder that does not exist", "{dir}/n.h5: is a symbolic link (to {dir}/gone/sub/n.h5); a new project is created only as a new file: give the name it should have, or remove the link",
         argv=lambda d: (os.symlink(d / "gone" / "sub" / "n.h5", d / "n.h5"), ["new", str(d / "n.h5")])[1]),
    Case("disk-full", "add an experiment with 0.3 MB free on the project's disk (API)", "{dir}/p.h5: no space left on", call=lambda d: _full_disk_acquire(d, 300_000)),
    Case("output-disk-full", "export-uff -o with 0.3 MB free on the output's disk (API)", "{dir}/o.uff: no space left on", call=lambda d: _full_disk_export(d, 300_000)),
    Case("history-figure-suffix", "history --figure h.txt", "--figure {dir}/h.txt: suffix '.txt' is not .png, .svg or .pdf", argv=lambda d: ["history", str(d / "p.h5"), "--figure", str(d / "h.txt")]),
    Case("project-external-storage", "verify on a project whose raw record is external storage on a user's file", "{dir}/x.h5: refused: dataset 'experiments/e1/raw' has external storage (its data are in other files); an odsuite project holds only itself",
         argv=_project_reaching_out("external storage")),
    Case("project-external-link", "info on a project whose raw record is an external link to another HDF5 file", "{dir}/x.h5: refused: 'experiments/e1/raw' is an external link to '{dir}/other.h5':'data'; an odsuite project holds only itself",
         argv=_project_reaching_out("external link", "info")),
    Case("project-virtual-dataset", "verify on a project whose raw record is a virtual dataset of another file", "{dir}/x.h5: refused: dataset 'experiments/e1/raw' is a virtual dataset (its data are in other files); an odsuite project holds only itself",
         argv=_project_reaching_out("virtual")),
    Case("rig-mass-huge", "body mass 1e41 kg", "{dir}/bad.toml: body 'plate' field 'mass': expected 1e-06 to 1e+07 kg, got 1e+41",
         **new_rig(RIG_TOML.replace("mass = 2.0", "mass = 1e41"))),
    Case("rig-mass-tiny", "body mass 1e-300 kg", "{dir}/bad.toml: body 'plate' field 'mass': expected 1e-06 to 1e+07 kg, got 1e-300",
         **new_rig(RIG_TOML.replace("mass = 2.0", "mass = 1e-300"))),
    Case("rig-stiffness-huge", "spring stiffness 1e308 N/m", "{dir}/bad.toml: springs[0] 's1' field 'stiffness': coefficients beyond 1e+12 (SI), got [1e+308, 1000.0, 1000.0]",
         **new_rig(RIG_TOML + SPRING.replace("stiffness = [1000.0,", "stiffness = [1e308,"))),
    Case("rig-position-far", "sensor position 1e200 m", "{dir}/bad.toml: sensors[0] 'a1' field 'position': positions beyond 1000 m, got [1e+200, 0.0, 0.0]",
         **new_rig(RIG_TOML.replace("position = [0.0, 0.0, 0.0]", "position = [1e200, 0.0, 0.0]"))),
    Case("rig-inertia-triangle", "principal moments 0.1, 0.1, 0.5 kg m^2", "{dir}/bad.toml: body 'plate' field 'inertia': principal moments [0.1, 0.1, 0.5] kg m^2 break the triangle inequality (the largest exceeds the sum of the others)",
         **new_rig(RIG_TOML.replace("[0, 0, 0.1]]", "[0, 0, 0.5]]"))),
    Case("rig-sensitivity-huge", "sensor sensitivity 1e308 V/(m/s^2)", "{dir}/bad.toml: sensors[0] 'a1' field 'sensitivity': expected 1e-09 to 1e+09 V per SI unit, got 1e+308",
         **new_rig(RIG_TOML.replace('axis = [0.0, 0.0, 1.0]', 'axis = [0.0, 0.0, 1.0]\nsensitivity = 1e308'))),
    Case("rig-sensitivity-tiny", "sensor sensitivity 1e-320 V/(m/s^2)", "{dir}/bad.toml: sensors[0] 'a1' field 'sensitivity': expected 1e-09 to 1e+09 V per SI unit, got 1e-320",
         **new_rig(RIG_TOML.replace('axis = [0.0, 0.0, 1.0]', 'axis = [0.0, 0.0, 1.0]\nsensitivity = 1e-320'))),
    Case("rig-force-on-sensor", "force_channel 1, the accelerometer's channel", "{dir}/bad.toml: field 'force_channel' = 1 is the channel of sensor 'a1' (the hammer needs a channel of its own)",
         **new_rig(RIG_TOML.replace("force_channel = 0", "force_channel = 1"))),
    Case("rig-inertia-tiny", "inertia 1e-300 kg m^2 on the diagonal", "{dir}/bad.toml: body 'plate' field 'inertia': principal moment 1e-300 kg m^2, below 1e-15 (no body that carries a sensor is that small)",
         **new_rig(RIG_TOML.replace("[[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]", "[[1e-300, 0, 0], [0, 1e-300, 0], [0, 0, 1e-300]]"))),
    Case("rig-typo-sensor", "sensor field `sensitivty`", "{dir}/bad.toml: sensors[0] 'a1': unknown field 'sensitivty'; did you mean 'sensitivity'?",
         **new_rig(RIG_TOML.replace('axis = [0.0, 0.0, 1.0]', 'axis = [0.0, 0.0, 1.0]\nsensitivty = 0.01'))),
    Case("rig-typo-top", "top-level field `defualt_model`", "{dir}/bad.toml: unknown field 'defualt_model'; did you mean 'default_model'?",
         **new_rig('defualt_model = "rigid-bodies"\n' + RIG_TOML)),
    Case("rig-typo-body", "body field `mas`", "{dir}/bad.toml: body 'plate': unknown field 'mas'; did you mean 'mass'?",
         **new_rig(RIG_TOML.replace("mass = 2.0", "mass = 2.0\nmas = 2.0"))),
    Case("rig-default-model", "default_model `nosuch`", "{dir}/bad.toml: field 'default_model': no model named 'nosuch' (known:",
         **new_rig('default_model = "nosuch"\n' + RIG_TOML)),
    Case("rig-name-bidi", "sensor name with a right-to-left override", "{dir}/bad.toml: sensors[0] 'a\\u202eb' field 'name': expected printable text of at most 200 characters (no control, escape or bidirectional characters), got 'a\\u202eb'",
         **new_rig(RIG_TOML.replace('name = "a1"', 'name = "a\\u202eb"'))),
    Case("rig-nested", "100,000 nested brackets", "{dir}/bad.toml: tables and arrays nested deeper than 32 levels",
         **new_rig("x = " + "[" * 100_000 + "]" * 100_000 + "\n")),
    Case("rig-fifo", "a named pipe (FIFO) as the rig file", "{dir}/pipe.toml: not a regular file (a pipe, device or folder), expected a TOML rig file",
         argv=lambda d: (os.mkfifo(d / "pipe.toml"), ["new", str(d / "q.h5"), "--rig", str(d / "pipe.toml")])[1]),
    Case('stored-metrics-text', 'info on a project whose revision 0 stores the metric error `abc`', "{dir}/x.h5: model revision 0 field 'metrics.error': expected a number or null, got 'abc'",
         argv=_handmade('metrics abc', 'info')),
    Case('stored-metrics-list', 'compare on a project whose revision 0 stores metrics `[1, 2]`', "{dir}/x.h5: model revision 0 field 'metrics': expected a table (JSON object), got [1, 2]",
         argv=_handmade('metrics list', 'compare')),
    Case('stored-effects-dict', 'info on a project whose revision 0 stores effects as a table, not a list', "{dir}/x.h5: model revision 0 field 'effects': expected a list of effect tables, got",
         argv=_handmade('effects dict', 'info')),
    Case('stored-metrics-negative', 'info on a project whose revision 0 stores the metric error -0.5', "{dir}/x.h5: model revision 0 field 'metrics.error': expected a number >= 0 or null, got -0.5",
         argv=_handmade('metrics negative', 'info')),
    Case('stored-parameter-1e400', 'model on a project whose revision 0 stores a parameter of 10^400 (a JSON integer)', "{dir}/x.h5: model revision 0 field 'parameters': expected a table of finite numbers, got",
         argv=_handmade('parameter 1e400', 'model')),
    Case('stored-filter-order', 'compare on a project whose experiment stores a filter order of 10^12 on channel 2', "{dir}/x.h5: experiment 'e1' systeminfo channel 2 field 'filter_order': expected 0 to 30, got 1000000000000",
         argv=_handmade('filter order 1e12', 'compare')),
    Case('stored-force-point', 'info on a project whose experiment stores a force point 1e300 m away', "{dir}/x.h5: experiment 'e1' field 'force_point': expected coordinates within 10000 m of the rig's origin, got [1e+300, 0.0, 0.0]",
         argv=_handmade('force point 1e300', 'info')),
    Case('stored-rate-zero', 'info on a project whose experiment stores sampling rate 0', "{dir}/x.h5: experiment 'e1' field 'sampling_rate': expected 0.1 to 1e+08 Hz, got 0.0",
         argv=_handmade('rate 0', 'info')),
    Case('stored-rate-nan', 'process on a project whose experiment stores sampling rate NaN', "{dir}/x.h5: experiment 'e1' field 'sampling_rate': expected 0.1 to 1e+08 Hz, got nan",
         argv=_handmade('rate NaN', 'process')),
    Case('stored-force-channel', 'info on a project whose experiment stores force channel 99', "{dir}/x.h5: experiment 'e1' field 'force_channel': expected a channel 0 to 10, got 99",
         argv=_handmade('force channel 99', 'info')),
    Case('stored-channel-names', 'info on a project whose experiment stores 2 channel names for 11 columns', "{dir}/x.h5: experiment 'e1' field 'channel_names': expected 11 distinct names (one per raw column), got ['force', 'ai1']",
         argv=_handmade('short names', 'info')),
    Case('stored-channel-names-int', 'info on a project whose experiment stores the channel names as the number 5', "{dir}/x.h5: experiment 'e1' field 'channel_names': expected 11 distinct names (one per raw column), got 5",
         argv=_handmade('names an int', 'info')),
    Case('stored-pretrigger-text', "compare on a project whose experiment stores the pretrigger as the text '512'", "{dir}/x.h5: experiment 'e1' field 'pretrigger': expected an integer 0 to 4096 samples, got '512'",
         argv=_handmade('pretrigger text', 'compare')),
    Case('stored-pretrigger-fraction', 'info on a project whose experiment stores the pretrigger 512.7', "{dir}/x.h5: experiment 'e1' field 'pretrigger': expected an integer 0 to 4096 samples, got 512.7",
         argv=_handmade('pretrigger 512.7', 'info')),
    Case('stored-pretrigger-array', 'info on a project whose experiment stores the pretrigger as an array [1, 2]', "{dir}/x.h5: experiment 'e1' field 'pretrigger': expected an integer 0 to 4096 samples, got [1, 2]",
         argv=_handmade('pretrigger array', 'info')),
    Case('stored-force-channel-text', "info on a project whose experiment stores the force channel as the text 'zero'", "{dir}/x.h5: experiment 'e1' field 'force_channel': expected a channel 0 to 10, got 'zero'",
         argv=_handmade('force channel text', 'info')),
    Case('stored-force-direction-text', "info on a project whose experiment stores the force direction as the text 'up'", "{dir}/x.h5: experiment 'e1' field 'force_direction': expected 3 finite numbers (m; a direction not zero), got 'up'",
         argv=_handmade('force direction text', 'info')),
    Case('stored-unit-furlong', 'compare on a project whose channel 2 (an accelerometer) stores the unit `furlong`', "{dir}/x.h5: experiment 'e1' systeminfo channel 2 field 'unit': expected 'm/s^2' (its sensor type's unit), got 'furlong'",
         argv=_handmade('unit furlong', 'compare')),
    Case('stored-integration-77', 'compare on a project whose channel 2 stores the integration code 77', "{dir}/x.h5: experiment 'e1' systeminfo channel 2 field 'integration': expected one of 0 (none), 1 (double), 2 (single), got 77",
         argv=_handmade('integration 77', 'compare')),
    Case('stored-sensitivity-text', "info on a project whose channel table stores the sensitivities as text ('0.002248' on channel 0)", "{dir}/x.h5: experiment 'e1' systeminfo channel 0 field 'sensitivity': expected a number, got b'0.002248'",
         argv=_handmade('sensitivity text', 'info')),
    Case('stored-systeminfo-rows', 'info on a project whose channel table has 3 rows for 11 raw columns', "{dir}/x.h5: experiment 'e1' field 'systeminfo.channels': expected 11 rows (one per raw column), got 3",
         argv=_handmade('systeminfo 3 rows', 'info')),
    Case('stored-rig-format', 'info on a project whose rig definition says its format is `yaml`', "{dir}/x.h5: rig field 'definition_format': expected 'json' or 'toml' (the formats odsuite writes), got 'yaml'",
         argv=_handmade('rig yaml', 'info')),
    Case('stored-own-parent', 'history on a project whose revision 0 names itself as its parent', "{dir}/x.h5: model revision 0 field 'parent': expected -1 (none) or a stored revision before it (none), got 0",
         argv=_handmade('own parent', 'history')),
    Case('stored-rig-rx-text', "info on a project whose channel table's rig field rx is the text 'abc'", "{dir}/x.h5: experiment 'e1' systeminfo rig field 'rx': expected a finite number (m) or NaN (not given), got b'abc'",
         argv=_handmade('rig rx text', 'info')),
    Case('stored-rig-use-in-gcc-text', "info on a project whose channel table's rig flag use_in_gcc is the text 'no' (read as true)", "{dir}/x.h5: experiment 'e1' systeminfo rig field 'use_in_gcc': expected true or false, got 'no'",
         argv=_handmade('rig use_in_gcc text', 'info')),
    Case('stored-rig-columns-fractional', "info on a project whose channel table's rig coordinate columns are 1.5 and 2.0 (read as 1 and 2)", "{dir}/x.h5: experiment 'e1' systeminfo rig field 'coordinate_columns': expected a list of whole column numbers, got [1.5, 2.0]",
         argv=_handmade('rig columns fractional', 'info')),
    Case('stored-rig-columns-negative', "info on a project whose channel table's rig coordinate columns are -1 and 6", "{dir}/x.h5: experiment 'e1' systeminfo rig field 'coordinate_columns': expected column numbers from 0 to 24575, got [-1, 6]",
         argv=_handmade('rig coordinate_columns -1,6', 'info')),
    Case('stored-rig-nine-channels-range', "info on a project whose channel table's nine-accelerometer channels end with 11, of 11 channels (process refused it later)", "{dir}/x.h5: experiment 'e1' systeminfo rig field 'nine_channels': expected channel numbers 0 to 10, got [2, 3, 4, 5, 6, 7, 8, 9, 11]",
         argv=_handmade('rig nine_channels 2,3,4,5,6,7,8,9,11', 'info')),
    Case('stored-revision-name', "info on a project whose revision 0 is renamed 'abc'", "{dir}/x.h5: models field 'revisions': expected revisions named by whole numbers 0, 1, 2, ..., got 'abc'",
         argv=_handmade('revision named abc', 'info')),
    Case("lvm-underscore", ".lvm with data value `1_000` (Python reads 1000; LabVIEW writes no digit groups)", "{dir}/bad.lvm: line 20, column 2: '1_000' is not a number",
         **lvm(LVM_TEXT.replace("\t1,5\t", "\t1_000\t"))),
    Case("lvm-long-row", ".lvm with a row of 1,000,000 cells in a 2-channel file", "{dir}/bad.lvm: line 20: 1000000 cells, more than the 4 of 2 channel(s) and a comment",
         **lvm(LVM_TEXT.replace("\t1,5\t2,0\n", "\t1,5\t2,0" + "\t1" * 999_997 + "\n"))),
    Case("diagnosis-device", "report --diagnosis /dev/zero", "/dev/zero: not a regular file (a pipe or device), expected a diagnosis (JSON) file",
         argv=_report_diagnosis(lambda d: "/dev/zero")),
    Case("diagnosis-fifo", "report --diagnosis naming a named pipe (FIFO)", "{dir}/d.json: not a regular file (a pipe or device), expected a diagnosis (JSON) file",
         argv=_report_diagnosis(lambda d: os.mkfifo(d / "d.json"))),
    Case("diagnosis-deep", "report --diagnosis with arrays nested 100,000 deep", "{dir}/d.json: JSON nested too deeply to be a diagnosis from `odsuite diagnose --json`",
         argv=_report_diagnosis(lambda d: (d / "d.json").write_text("[" * 100_000 + "]" * 100_000))),
    Case("project-hard-links", "info on a project whose experiment group has 3,000 more names (hard links)", "{dir}/x.h5: refused: 'experiments/h0000' names the same object as 'experiments/e1' (a second hard link); an odsuite project names each object once",
         argv=_handmade("3000 names", "info")),
    Case("diagnosis-huge-integer", "report --diagnosis holding an integer of 100,000 digits", "{dir}/d.json: not a diagnosis from `odsuite diagnose --json` (Exceeds the limit (4300 digits) for integer string conversion",
         argv=_report_diagnosis(lambda d: (d / "d.json").write_text("1" * 100_000))),
    Case("rig-channel-beyond", "sensor on channel 4096 (odsuite records at most 4096 channels)", "{dir}/bad.toml: sensors[0] 'a1' field 'channel': expected a channel index below 4096, got 4096",
         **new_rig(RIG_TOML.replace("channel = 1", "channel = 4096"))),
    Case("rig-mass-integer", "body mass written as the integer 10**41 (beyond numpy's integers)", "{dir}/bad.toml: body 'plate' field 'mass': expected 1e-06 to 1e+07 kg, got 1e+41",
         **new_rig(RIG_TOML.replace("mass = 2.0", "mass = 1" + "0" * 41))),
    Case("rig-stiffness-integer", "spring stiffness written as the integer 10**400 (beyond a float)", "{dir}/bad.toml: springs[0] 's1' field 'stiffness': expected 3 numbers [x, y, z] or a 3x3 matrix, got [1000",
         **new_rig(RIG_TOML + SPRING.replace("[1000.0, 1000.0, 1000.0]", "[1" + "0" * 400 + ", 1000.0, 1000.0]"))),
    Case("rig-stiffness-tiny", "spring stiffness of 1e-300 N/m (subnormal; the simulation's balancing warns)", "{dir}/bad.toml: springs[0] 's1' field 'stiffness': expected 0 or at least 1e-12 (SI), got [1e-300, 1e-300, 1e-300]",
         **new_rig(RIG_TOML + SPRING.replace("[1000.0, 1000.0, 1000.0]", "[1e-300, 1e-300, 1e-300]"))),
    Case("catalog-query-empty", "catalog query with an empty query (no query at all lists the projects)", "catalog query '': expected one of projects, unexplained, errors, experiments, sensors, gains or a SELECT",
         argv=lambda d: ["catalog", "query", str(d), ""]),
    Case("diagnosis-huge", "report --diagnosis with a file of 17 MiB", "{dir}/d.json: more than 16777216 bytes, not a diagnosis from `odsuite diagnose --json`",
         argv=_report_diagnosis(lambda d: os.truncate(_touch(d / "d.json"), 17 * 2**20))),
    Case("diagnosis-parameters-text", "report --diagnosis whose candidate's parameters are the text 'x'", "{dir}/d.json: field 'candidates[0].parameters': expected a table of numbers (or null) by parameter name, got 'x'",
         argv=_bad_diagnosis_file("candidates[0].parameters", "x")),
    Case("diagnosis-units-list", "report --diagnosis whose candidate's units are the list [1]", "{dir}/d.json: field 'candidates[0].units': expected a table of unit texts (or null) by parameter name, got [1]",
         argv=_bad_diagnosis_file("candidates[0].units", [1])),
    Case("diagnosis-physical-number", "report --diagnosis whose candidate's physical quantities are the number 5", "{dir}/d.json: field 'candidates[0].physical': expected a list of quantities, got 5",
         argv=_bad_diagnosis_file("candidates[0].physical", 5)),
    Case("diagnosis-physical-row", "report --diagnosis whose candidate's physical quantity has the value 'x'", "{dir}/d.json: field 'candidates[0].physical[0]': expected a table of label and unit (texts), value (a number), nominal and uncertainty (numbers or null), got",
         argv=_bad_diagnosis_file("candidates[0].physical", [{"label": "k", "value": "x", "unit": "N/m", "nominal": None}])),
    Case("diagnosis-error-text", "report --diagnosis whose candidate's validated error is the text 'x'", "{dir}/d.json: field 'candidates[0].validated_error': expected a number or null, got 'x'",
         argv=_bad_diagnosis_file("candidates[0].validated_error", "x")),
    Case("diagnosis-baseline-text", "report --diagnosis whose baseline error is the text 'x'", "{dir}/d.json: field 'baseline_error': expected a number or null, got 'x'",
         argv=_bad_diagnosis_file("baseline_error", "x")),
    Case("diagnosis-candidates-number", "report --diagnosis whose candidates are the number 5", "{dir}/d.json: field 'candidates': expected a list of candidate tables (the output of `odsuite diagnose --json`), got 5",
         argv=_bad_diagnosis_file("candidates", 5)),
    Case("stored-diagnosis-parameters", "report on a project whose revision 0 keeps a diagnosis whose candidate's parameters are the text 'x'", "{dir}/x.h5: model revision 0 field 'metrics.diagnosis.document.candidates[0].parameters': expected a table of numbers (or null) by parameter name, got 'x'",
         argv=_bad_stored_diagnosis("candidates[0].parameters", "x")),
    Case("stored-diagnosis-units", "report on a project whose revision 0 keeps a diagnosis whose candidate's units are the number 5", "{dir}/x.h5: model revision 0 field 'metrics.diagnosis.document.candidates[0].units': expected a table of unit texts (or null) by parameter name, got 5",
         argv=_bad_stored_diagnosis("candidates[0].units", 5)),
    Case("import-rate-range", "import of a .npy record with --rate 1e9 (a project stores 0.1 Hz to 100 MHz)", "{dir}/r.npy: sampling_rate: 1e+09 Hz is outside 0.1 to 1e+08 Hz",
         argv=_imported("r.npy", _npy(np.zeros((16, 2))), "--rate", "1e9", "--units", "g")),
    Case("store-rate-range", "an experiment added at 1e300 Hz (API; the project's reader refuses such a rate)", "{dir}/p.h5: experiment 'new': sampling_rate must be 0.1 to 1e+08 Hz, got 1e+300",
         call=_add_experiment_at(1e300)),
    Case("import-csv-digit-group", "CSV value `1_000` (Python reads 1000; no DAQ writes digit groups)", "{dir}/r.csv: line 3: channel 'a1': value '1_000' is not a number",
         **_csv("t,a1 [g],a2 [g]\n0,0.1,0.2\n0.01,1_000,0.3\n0.02,0.5,0.1\n")),
    Case("import-csv-other-digits", "CSV value in Arabic-Indic digits", "{dir}/r.csv: line 3: channel 'a1': value '\u0661\u0662' is not a number",
         **_csv("t,a1 [g],a2 [g]\n0,0.1,0.2\n0.01,\u0661\u0662,0.3\n0.02,0.5,0.1\n")),
    Case("import-csv-header-no-separator", "CSV header `time a1 a2` (spaces), data separated by commas", "{dir}/r.csv: line 2: 3 fields separated by commas, the header has 1 (it holds no comma, semicolon or tab: separate its names as the data are)",
         **_csv("time a1 a2\n0,0.1,0.2\n0.01,0.2,0.3\n0.02,0.5,0.1\n")),
    Case("import-csv-other-separator", "CSV header separated by semicolons, data by commas", "{dir}/r.csv: line 2: 1 field separated by semicolons (the header's separator), the header has 3",
         **_csv("t;a1 [g];a2 [g]\n0,0.1,0.2\n0.01,0.2,0.3\n0.02,0.5,0.1\n")),
    Case("import-channel-name-escape", "CSV column named with an ANSI escape", "{dir}/r.csv: channels: column 1 name: expected printable text of at most 200 characters",
         **_csv("t,\x1b[31ma [g],a2 [g]\n0,0.1,0.2\n0.01,0.2,0.3\n0.02,0.5,0.1\n")),
    Case("import-channels-many", "import --channels with 5,000 names for a CSV of 2 channels (all were echoed)", "{dir}/r.csv: channels: 5000 given for 2 column(s) (c0, c1, c2, c3, c4, c5, c6, c7, ... (5000 in all))",
         **_csv("t,a1,a2\n0,0.1,0.2\n0.01,0.2,0.3\n", "--units", "g", "--channels", ",".join(f"c{k}" for k in range(5000)))),
    Case("import-value-huge", ".npy record holding 1e308 in g (infinite in m/s^2)", "{dir}/r.npy: channel 'ch1': sample 0: value 1e+308 g is beyond 1e+12 g, which no sensor reads",
         argv=_imported("r.npy", _npy(np.full((16, 2), 1e308)), "--rate", "100", "--units", "g")),
    Case("import-npy-header-shape", ".npy whose header says 10^11 x 2 values, holding 64 bytes", "{dir}/r.npy: header says shape (100000000000, 2) of float64 (1600000000000 bytes), the file holds 64 bytes after it",
         argv=_imported("r.npy", _npy_header((10**11, 2)), "--rate", "100", "--units", "g")),
    Case("import-mat-rate-text", ".mat whose `fs` is the text 'abc'", "{dir}/r.mat: variable 'fs' (sampling rate): expected one real number of Hz, got array(['abc'], dtype='<U3')",
         argv=_imported("r.mat", _mat(fs="abc"), "--units", "g")),
    Case("import-mat-corrupt", ".mat of 128 zero bytes", "{dir}/r.mat: not a readable MATLAB .mat file: Mat file appears to be corrupt",
         argv=_imported("r.mat", lambda path: path.write_bytes(bytes(128)), "--units", "g", "--rate", "100")),
    Case("import-mat-cut-tag", ".mat cut 3 bytes into its second variable's tag (read as a file without `fs` and `units`)", "{dir}/r.mat: cut short at byte 1787: variable 2's tag at byte 1784 has 3 of its 8 bytes",
         argv=_imported("r.mat", _cut(_mat(fs=100.0, units="g"), 1787))),
    Case("import-mat-units-empty", ".mat whose `units` is an empty text", "{dir}/r.mat: variable 'units': empty",
         argv=_imported("r.mat", _mat(fs=100.0, units=""))),
    Case('import-npy-header-damaged', ".npy whose header reads `'fortran_order': F[lse` (numpy's parser raised TokenError)", "{dir}/r.npy: not a NumPy .npy array file: header: ('EOF in multi-line statement', (2, 0))",
         argv=_imported("r.npy", _patched(_npy(np.ones((16, 2))), b"False", b"F[lse"), "--rate", "100", "--units", "g")),
    Case('import-mat-element-type', ".mat whose array's data element has the reserved data type 8", '{dir}/r.mat: damaged: variable 1 at byte 128: an element of data type 8, which MATLAB does not write',
         argv=_imported("r.mat", _patched(_mat(fs=100.0, units="g"), b"data\x09\x00\x00\x00", b"data\x08\x00\x00\x00"))),
    Case('import-mat-crash', ".mat whose array is flagged complex without an imaginary part (scipy's reader, given the whole file, read the next variable for it and crashed the process)", "{dir}/r.mat: not a readable MATLAB .mat file: could not read bytes",
         argv=_imported("r.mat", _patched(_mat(fs=100.0, units="g"), b"\x06\x00\x00\x00\x00\x00\x00\x00\x05", b"\x06\x08\x00\x00\x00\x00\x00\x00\x05"))),
    Case('import-mat73-damaged', "MATLAB v7.3 .mat whose root group's heap signature is overwritten (h5py raised RuntimeError)", '{dir}/r.mat: not a readable MATLAB .mat file (v7.3/HDF5): Link iteration failed (bad local heap signature)',
         argv=_imported("r.mat", _patched(_mat73, b"HEAP", b"XEAP"), "--units", "g")),
    Case("import-mat73-external", "MATLAB v7.3 .mat whose array is HDF5 external storage on another file", "{dir}/r.mat: variable 'data': its data are stored in other files (HDF5 external storage or a virtual dataset); refused",
         argv=_imported("r.mat", _mat73_external, "--units", "g")),
    Case("import-tdms-increment-text", "TDMS channel whose wf_increment property is the text 'fast'", "{dir}/r.tdms: channel 'a1': property wf_increment is 'fast', not a number of seconds",
         argv=_imported("r.tdms", _tdms(wf_increment="fast"))),
    Case("import-tdms-cut-metadata", "TDMS file of its first 40 bytes, cut inside its metadata (asked for --group)", "{dir}/r.tdms: cut short at byte 40: the segment at byte 0 declares metadata up to byte 126",
         argv=_imported("r.tdms", _cut(_tdms(), 40))),
    Case("import-sidecar-type", "sidecar r.toml with `units = 5`", "{dir}/r.toml: field 'units': expected a text or a list of texts, got 5",
         argv=_imported("r.csv", lambda path: (path.write_text("a,b\n1,2\n3,4\n"), path.with_suffix(".toml").write_text("units = 5\n")), "--rate", "100")),
    Case("rig-names-nfc", "two sensors named 'é', one composed (U+00E9) and one as e + U+0301", "{dir}/bad.toml: two sensors share a name",
         **new_rig(RIG_TOML.replace('"a1"', '"\u00e9"') + RIG_TOML[RIG_TOML.index("[[sensors]]"):]
                   .replace('"a1"', '"e\u0301"').replace("channel = 1", "channel = 2"))),
    Case("import-sidecar-deep", "sidecar r.toml with arrays nested 10,000 deep", "{dir}/r.toml: not a sidecar: arrays or tables nested too deeply",
         argv=_imported("r.csv", lambda path: (path.write_text("a,b\n1,2\n3,4\n"), path.with_suffix(".toml").write_text("x = " + "[" * 10_000 + "]" * 10_000 + "\n")), "--rate", "100")),
    Case("stored-raw-text", "info on a project whose raw record is stored as text (bytes)", "{dir}/x.h5: experiment 'e1' field 'raw': expected real numbers (floating point or integer), got 'dtype |S8'",
         argv=_handmade("raw as text", "info")),
    Case("stored-raw-nan", "process on a project whose raw record holds a NaN at sample 700 (written in place)", "{dir}/x.h5: experiment 'e1' field 'raw': expected finite values within 1e+12 (sample 700, channel",
         argv=_handmade("raw NaN", "process")),
    Case("stored-raw-group", "info on a project whose raw record is a group", "{dir}/x.h5: experiment 'e1' field 'raw': expected a dataset, got a group",
         argv=_handmade("raw group", "info")),
    Case("stored-raw-unwritten", "info on a project whose raw record declares 10^9 rows and stores none", "{dir}/x.h5: experiment 'e1' field 'raw': shape (1000000000, 11) of 88000000000 bytes, of which 0 are stored (not written by odsuite)",
         argv=_handmade("raw unwritten", "info")),
    Case("stored-columns-unwritten", "info on a project whose channel table's coordinate columns declare 10^9 rows and store none (read as 8 GB of zeros)", "{dir}/x.h5: experiment 'e1' field 'systeminfo/rig/coordinate_columns': shape (1000000000,) of 8000000000 bytes, of which 0 are stored (not written by odsuite)",
         argv=_handmade("columns unwritten", "info")),
    Case("stored-derived-unwritten", "export-legacy --cod of a processed experiment whose coordinates declare 10^9 rows and store none (read as 48 GB of zeros)", "{dir}/processed.h5: experiment 'e1' derived 'gencoords' field 'platform_at_g': shape (1000000000, 6) of 48000000000 bytes, of which 0 are stored (not written by odsuite)",
         argv=_unwritten_coordinates),
    Case("stored-raw-unwritten-gzip", "info on a project whose gzip-compressed raw record declares 10^9 rows and stores no chunk (info ran for minutes)", "{dir}/x.h5: experiment 'e1' field 'raw': shape (1000000000, 11) of 88000000000 bytes in 15259 chunks, of which 0 are stored (not written by odsuite)",
         argv=_handmade("raw unwritten gzip", "info")),
    Case("stored-raw-bomb", "compare on a project whose raw record is 10^6 x 11 zeros, gzip-compressed a thousandfold", "{dir}/x.h5: experiment 'e1' field 'raw': shape (1000000, 11) of 88000000 bytes stored in",
         argv=_handmade("raw bomb", "compare")),
    Case("stored-raw-no-checksum", "verify on a project whose raw record was rewritten without its checksum (verify said intact)", "{dir}/x.h5: experiment 'e1': dataset /experiments/e1/raw has no checksum, so it cannot be verified (not written by odsuite)",
         argv=_handmade("raw no checksum", "verify")),
    Case("stored-raw-memory", "e1's raw record read with 0.1 MB of memory free (API)", "{dir}/p.h5: experiment 'e1' field 'raw': a record of",
         call=lambda d: _read_raw_short_of_memory(d, 100_000)),
    Case("stored-sensitivity-zero", "info on a project whose channel 2 stores sensitivity 0", "{dir}/x.h5: experiment 'e1' systeminfo channel 2 field 'sensitivity': expected a finite number other than 0, got 0.0",
         argv=_handmade("sensitivity 0", "info")),
    Case("stored-rate-complex", "info on a project whose experiment stores the sampling rate 20000+1j", "{dir}/x.h5: experiment 'e1' field 'sampling_rate': expected 0.1 to 1e+08 Hz, got (20000+1j)",
         argv=_handmade("rate complex", "info")),
    Case("stored-current-revision", "process on a project whose current revision 0 was deleted", "{dir}/x.h5: models field 'current_revision': expected a stored revision (none), got 0",
         argv=_handmade("no revision 0", "process")),
    Case("stored-experiments-dataset", "info on a project whose experiments group is a dataset", "{dir}/x.h5: field 'experiments': expected a group, got a dataset",
         argv=_handmade("experiments dataset", "info")),
    Case("diagnose-workers-huge", "diagnose --workers 1000000 (more than 4 processes per core)", "processes (4 per core), got 1000000",
         argv=lambda d: ["diagnose", str(d / "p.h5"), "--workers", "1000000"]),
    Case("render-workers-huge", "render --workers 1000000 (more than 4 processes per core)", "processes (4 per core), got 1000000",
         argv=lambda d: ["render", str(d / "p.h5"), "e1", "-o", str(d / "m.gif"), "--workers", "1000000"]),
    Case("modes-max-order", "modes --max-order 0 (the fit looped for ever)", "--max-order: a model order of at least 2, got 0",
         argv=lambda d: ["modes", str(d / "p.h5"), "--experiment", "e1", "--max-order", "0"]),
    Case("modes-output-only-order-huge", "modes --output-only --max-order 100000 (allocated all memory)", "--max-order 100000: 11113 block rows x 9 outputs hold it, whose lags (2 x 11113) need at least 44452 samples at 20000 Hz; the record has 4096 (give a lower --max-order)",
         argv=lambda d: ["modes", str(d / "p.h5"), "--experiment", "e1", "--output-only", "--max-order", "100000"]),
    Case("modes-output-only-order-slow", "modes --output-only --max-order 1000 (ran for half an hour)", "--max-order 1000: at most 400 (SSI-cov solves an eigenproblem per even order, its time grows with the order's fourth power)",
         argv=lambda d: ["modes", str(d / "p.h5"), "--experiment", "e1", "--output-only", "--max-order", "1000"]),
    Case("modes-output-only-short-segments", "modes --output-only of one channel, 4096 samples of a sine at 1 kHz (its quarter segments, decimated, were shorter than the lags: numpy's LinAlgError 'SVD did not converge')", "{dir}/r.h5: experiment 'one': no stable pole in 0..19.5 Hz is confirmed as a mode",
         argv=_one_sine),
    Case("frf-force-alone", "frf of a record holding a hammer's force channel alone (stored 'H1 FRFs of 0 channels')", "{dir}/r.h5: experiment 'fo' holds its force channel 'hammer' alone: no response to estimate FRFs of",
         argv=_force_alone),
    Case("modes-decimate-zero", "modes --output-only --decimate 0", "--decimate: a factor of at least 1, got 0",
         argv=lambda d: ["modes", str(d / "p.h5"), "--experiment", "e1", "--output-only", "--decimate", "0"]),
    Case("import-csv-name-newline", "CSV column name holding a line break inside quotes", "{dir}/r.csv: channels: column 1 name: expected printable text of at most 200 characters (no control, escape or bidirectional characters), got 'a\\nb'",
         **_csv('t,"a\nb [g]",a2 [g]\n0,0.1,0.2\n0.01,0.2,0.3\n0.02,0.5,0.1\n')),
    Case("catalog-empty-folder", "catalog with an empty folder name (pathlib reads it as the current folder)", "catalog: the folder name is empty ('')",
         argv=lambda d: ["catalog", ""]),
    Case("catalog-seconds-nan", "catalog query --seconds nan (NaN is never late: the bound was off)", "--seconds: a finite time > 0 s, got nan",
         argv=lambda d: ["catalog", "query", str(d), "projects", "--seconds", "nan"]),
    Case("api-frf-modes-order-zero", "frf_modes with max_order=0 (API; the fit grew its bands for ever)", "frf_modes: 'max_order' must be an integer of at least 2, got 0",
         call=lambda d: _api().frf_modes(_noise_frf(), max_order=0)),
    Case("api-estimate-frf-rate-zero", "estimate_frf at fs=0 (API; ZeroDivisionError)", "estimate_frf: 'fs' must be a finite number > 0, got 0.0",
         call=lambda d: _api().estimate_frf([np.ones(64)], [np.ones(64)], 0.0)),
    Case("api-estimate-frf-empty-record", "estimate_frf of one hit of no samples (API; numpy's 'Invalid number of FFT data points')", "estimate_frf: 'forces' must be records of 2 or more samples each, got hit 0 of shape (0,)",
         call=lambda d: _api().estimate_frf([np.array([])], [np.array([])], 1000.0)),
    Case("api-estimate-frf-hits-one-response", "estimate_frf of 2 x 64 force hits and one 64-sample response (API; it counted 64 response records, one per sample)", "estimate_frf: 'responses' must be an array of hits x samples (x outputs), as 'forces' is an array of hits x samples, got an array of shape (64,)",
         call=lambda d: _api().estimate_frf(np.ones((2, 64)), np.ones(64), 1000.0)),
    Case("api-estimate-frf-response-unit-g", "estimate_frf with response_units=['g'] (API; the FRF was labelled (g)/N, its values taken as SI)", "estimate_frf: 'response_units' must be a list of 1 SI units, one per response (V, N, m, m/s^2, m/s, Pa), got ['g']",
         call=lambda d: _api().estimate_frf([np.ones(64)], [np.ones(64)], 1000.0, response_units=["g"])),
    Case("api-estimate-frf-response-units-text", "estimate_frf of 5 responses with response_units='m/s^2' (API; its 5 letters were taken as 5 units)", "estimate_frf: 'response_units' must be a list of 5 SI units, one per response (V, N, m, m/s^2, m/s, Pa), got 'm/s^2'",
         call=lambda d: _api().estimate_frf([np.ones(64)], [np.ones((64, 5))], 1000.0, response_units="m/s^2")),
    Case("api-spectral-matrix-3d", "spectral_matrix of a 4 x 4 x 4 array (API; numpy's 'axes don't match array')", "spectral_matrix: 'y' must be samples x outputs (2 or more samples), got an array of shape (4, 4, 4)",
         call=lambda d: _api().spectral_matrix(np.ones((4, 4, 4)), 100.0, 4)),
    Case("api-process-workers-zero", "process_experiment with workers=0 (API; it ran on every core)", "process_experiment: 'workers' must be an integer of at least 1, got 0",
         call=lambda d: _on_project(d, lambda api, p: api.process_experiment(p, "e1", workers=0))),
    Case("api-build-chain-number", "build_chain given the number 5 for its list of steps (API; TypeError)", "build_chain: 'specs' must be a list of steps (tables with a 'step' or 'tap' entry), got 5",
         call=lambda d: _build_chain(5)),
    Case("api-raw-start-text", "e1's raw record read from row 'a' (API; it said the project file is damaged)", "Experiment.raw: 'start' must be an integer, got 'a'",
         call=lambda d: _on_project(d, lambda api, p: p.experiment("e1").raw("a"))),
    Case("api-compare-revision-number", "compare with revision=5 (API; AttributeError)", "compare: 'revision' must be a model revision (an entry of project.model_revisions() or current_revision(project)) or None for the current one, got 5",
         call=lambda d: _on_project(d, lambda api, p: api.compare(p, revision=5))),
    Case("api-run-batch-one-path", "run_batch given one project's path for its list (API; each character was run as a project)", "run_batch: 'projects' is a list of project paths, got '{dir}/p.h5'",
         call=lambda d: _api().run_batch("info", str(d / "p.h5"), workers=1)),
    Case("render-api-fps-nan", "movie renderer with options {\"fps\": nan} (API; NaN reached int())", "--fps: must be a finite number > 0, got nan",
         call=_render_api("movie", "m.gif", {"fps": float("nan")})),
    Case("render-api-duration-text", "movie renderer with options {\"duration\": \"6\"} (API; compared text with 0)", "--duration: must be a finite number > 0, got '6'",
         call=_render_api("movie", "m.gif", {"duration": "6"})),
    Case("render-api-view-number", "projection renderer with options {\"view\": 5} (API; .split() of a number)", "--view: expected text, 'AZ,EL' or 'EYE[,THETA,PHI,PSI]', got 5",
         call=_render_api("projection", "p.png", {"view": 5})),
    Case("render-api-workers-huge", "movie renderer with options {\"workers\": 1000000} (API; only the command line held it to 4 per core)", "processes (4 per core), got 1000000",
         call=_render_api("movie", "m.gif", {"workers": 1000000})),
    Case("api-diagnose-workers-huge", "diagnose with workers=1000000 (API; only the command line held it to 4 per core, and a fork context starts every process)", "processes (4 per core), got 1000000",
         call=lambda d: _on_project(d, lambda api, p: api.diagnose(p, workers=1000000))),
    Case("render-api-options-list", "a RenderRequest whose options are a list (API)", "render options: expected a mapping of option names to values, got list",
         call=_render_api("movie", "m.gif", ["fps"])),
    Case("modes-at-empty", "modes --at '' (ran as if absent)", "--at '': expected comma-separated frequencies in Hz",
         argv=lambda d: ["modes", str(d / "p.h5"), "--experiment", "e1", "--at", ""]),
    Case("modes-fmax-above-nyquist", "modes --fmax 1e300 (the band was cut at the Nyquist frequency without a word)", "-1e+300 Hz: the FRFs end at 10000 Hz, the Nyquist frequency; give --fmin and --fmax within it",
         argv=lambda d: ["modes", str(d / "p.h5"), "--experiment", "e1", "--fmax", "1e300"]),
    Case("add-effect-pair-twice", "add-effect damping+damping (stored two revisions of the one effect)", "{dir}/p.h5: effect 'damping+damping' names 'damping' twice; a model holds it once (give 'damping')",
         argv=lambda d: ["add-effect", str(d / "p.h5"), "damping+damping"]),
]


def _api():
    from odsuite import api

    return api


def _build_chain(specs):
    from odsuite.contracts.plugins import registries
    from odsuite.processing.chain_spec import build_chain

    return build_chain(specs, fs=1000.0, registry=registries().processing_steps)


def _noise_frf():
    rng = np.random.default_rng(0)
    return _api().estimate_frf([rng.standard_normal(1024)], [rng.standard_normal(1024)], 1000.0)


def _on_project(d: Path, call: Callable) -> None:
    """``call(api, project)`` on p.h5 open for writing."""
    api = _api()
    with api.open_project(d / "p.h5", "a") as p:
        call(api, p)


@pytest.fixture(scope="module")
def master(tmp_path_factory):
    """A thesis-rig project holding experiment e1 (a legacy import), processed.h5 the same processed
    (to render), and the good input files."""
    d = tmp_path_factory.mktemp("master")
    (d / "good.DAT").write_text(GOOD_DAT)
    (d / "good.CTR").write_text(CTR_TEXT)
    assert main(["new", str(d / "p.h5")]) == 0
    assert main(legacy(ctr="good.CTR", name="e1")(d)) == 0
    shutil.copyfile(d / "p.h5", d / "processed.h5")
    assert main(["process", str(d / "processed.h5")]) == 0
    return d


@pytest.mark.filterwarnings("ignore::odsuite.domain.errors.OdsuiteWarning")
@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_bad_input(case, master, tmp_path, capsys):
    for f in ("p.h5", "processed.h5", "good.DAT", "good.CTR"):
        shutil.copyfile(master / f, tmp_path / f)
    for name, content in case.files.items():
        (tmp_path / name).write_bytes(content if isinstance(content, bytes) else content.encode())
    project = tmp_path / "p.h5"
    before = project.read_bytes()
    capsys.readouterr()
    if case.argv is not None:
        assert main(case.argv(tmp_path)) == 1
        out, err = capsys.readouterr()
        assert err.count("\n") == 1 and "Traceback" not in err, err
        assert err.startswith("error: "), err
        message = err[len("error: "):].rstrip("\n")
    else:
        with pytest.raises(OdsuiteError) as info:
            case.call(tmp_path)
        message = str(info.value)
        assert "\n" not in message
    expected = case.expected.format(dir=tmp_path, project=project)
    print(f"ACTUAL {case.name}: {message.replace(str(tmp_path), '{dir}')}")
    assert expected in message
    assert project.read_bytes() == before
    assert not (tmp_path / "q.h5").exists()


def _doc_rows() -> list[tuple[str, str, str]]:
    rows = []
    for line in DOC.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]]
        if len(cells) == 3 and cells[0] not in ("name", "") and not set(cells[0]) <= set("-: "):
            rows.append(tuple(c.replace("\\|", "|") for c in cells))
    return rows


def test_catalogue_and_tests_agree():
    doc = _doc_rows()
    assert [r[0] for r in doc] == [c.name for c in CASES]
    assert doc == [(c.name, c.input, c.expected) for c in CASES]
    assert len(CASES) >= 30 and len({c.name for c in CASES}) == len(CASES)
