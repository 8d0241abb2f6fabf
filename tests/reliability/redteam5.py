"""Red team, round five: records from other tools (CSV, NumPy, MATLAB v5 and v7.3, TDMS, .lvm and
UFF through ``odsuite import``), rig files written from docs/rig-format.md with the mistakes people
make, projects altered with h5py, and every reporting command with ``--json`` and option values out
of range. Each try is a real ``odsuite`` subprocess run by the round-three harness
(``redteam3.run``: a folder of its own, a time limit, judged from the outside) with two more
outcomes:

- ``bad json``: a command given ``--json`` whose stdout is not exactly one JSON object, or that
  failed without ``{"error": ...}`` (docs/modal.md, JSON);
- ``unreadable after``: an import or ``new`` that succeeded left a project that ``odsuite info``
  then refuses (a value stored that the project's own reader does not accept).

``python -m tests.reliability.redteam5 --out DIR [--only GROUP] [--timeout S] [--jobs N]`` prints
the table by group and outcome and writes ``DIR/redteam5.json``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np

from tests.reliability import redteam3 as rt
from tests.reliability.redteam3 import Case

rt.OUTCOMES = rt.OUTCOMES[:rt.OUTCOMES.index("wrong success") + 1] + ("bad json", "unreadable after") \
    + rt.OUTCOMES[rt.OUTCOMES.index("wrong success") + 1:]
FAILURES = rt.FAILURES + ("bad json", "unreadable after", "changed project")


def _setup_files(files: dict[str, bytes | Callable[[Path], None]]) -> Callable[[Path, int], None]:
    def setup(d: Path, variant: int) -> None:
        for name, content in files.items():
            if callable(content):
                content(d / name)
            else:
                (d / name).write_bytes(content)
    return setup


def prepare(work: Path) -> Path:
    """Round three's master folder, plus ``q.h5``: a project without a rig, for plain records."""
    m = rt.prepare_master(work)
    if not (m / "q.h5").exists():
        r = rt._run_setup(["new", "q.h5", "--rig", "none"], m)
        if r.returncode:
            raise RuntimeError(r.stderr)
    return m


# ----------------------------------------------------------------------------- judging


def _json_check(d: Path, r: dict) -> list[tuple[str, str]]:
    out = r["stdout"].decode("utf-8", "replace").strip()
    try:
        doc = json.loads(out)
    except ValueError as exc:
        return [("bad json", f"stdout is not one JSON document ({exc}): {out[:80]!r}")]
    if not isinstance(doc, dict) and not (isinstance(doc, list) and r.get("list_ok") and r["code"] == 0):
        return [("bad json", f"a JSON {type(doc).__name__}, not an object")]
    if r["code"] not in (0, None) and not isinstance(doc.get("error"), str):
        return [("bad json", f"failed (exit {r['code']}) without an 'error' line: {out[:80]!r}")]
    return []


def _query_json(d: Path, r: dict) -> list[tuple[str, str]]:
    """``catalog query --json`` prints its rows as one JSON list (docs/batch.md)."""
    return _json_check(d, {**r, "list_ok": True})


def _catalogued(d: Path, variant: int) -> None:
    rt._run_setup(["catalog", "."], d)


def _readable_after(project: str) -> Callable[[Path, dict], list[tuple[str, str]]]:
    def check(d: Path, r: dict) -> list[tuple[str, str]]:
        if r["code"] != 0 or not (d / project).exists():
            return []
        env = {**os.environ, "HOME": str(d / "home"), "TMPDIR": str(d / "tmp"), "MPLCONFIGDIR": str(d.parent / "mplconfig")}
        p = subprocess.run([rt.ODSUITE, "info", project], cwd=d, capture_output=True, text=True, timeout=120, env=env)
        if p.returncode:
            return [("unreadable after", (p.stderr.strip().splitlines() or ["?"])[-1][:200])]
        return []
    return check


def _both(*checks):
    def check(d: Path, r: dict) -> list[tuple[str, str]]:
        return [p for c in checks if c is not None for p in c(d, r)]
    return check


def _import_case(group: str, label: str, file: str, files: dict, *opts: str, expect: str = "any",
                 project: str = "q.h5") -> Case:
    argv = ["import", project, file, "--name", "x", *opts]
    return Case(group, label, lambda d, a=tuple(argv): list(a), _setup_files(files), expect=expect,
                projects=(project,), check=_readable_after(project), timeout=60.0)


# ----------------------------------------------------------------------------- CSV

def _csv(text: str, encoding: str = "utf-8") -> bytes:
    return text.encode(encoding)


ROWS = "".join(f"{k / 100:.2f},{np.sin(k / 5):.5f},{np.cos(k / 5):.5f}\n" for k in range(64))
GOOD_CSV = "time,a1 [m/s^2],a2 [m/s^2]\n" + ROWS

CSV: dict[str, tuple[str | bytes, tuple[str, ...], str]] = {  # label -> (content, options, expect)
    "good": (GOOD_CSV, (), "any"),
    "a UTF-8 BOM": (b"\xef\xbb\xbf" + GOOD_CSV.encode(), (), "any"),
    "a UTF-16 file": (GOOD_CSV.encode("utf-16"), (), "refuse"),
    "latin-1 bytes in a name": (GOOD_CSV.replace("a1", "a\xe9").encode("latin-1"), (), "refuse"),
    # a decimal-comma locale's spreadsheet: read (the numbers checked in tests/plugins/importers/test_tables.py)
    "semicolons and decimal commas": (GOOD_CSV.replace(",", ";").replace(".", ","), (), "any"),
    "tabs": (GOOD_CSV.replace(",", "\t"), (), "any"),
    "CRLF line ends": (GOOD_CSV.replace("\n", "\r\n"), (), "any"),
    "CR line ends": (GOOD_CSV.replace("\n", "\r"), (), "any"),
    "an empty column": ("time,a1 [m/s^2],,a2 [m/s^2]\n" + ROWS.replace(",", ",,", 2).replace("\n", "\n") , (), "refuse"),
    "an empty cell": (GOOD_CSV.replace("0.19867", ""), (), "refuse"),
    "a NaN": (GOOD_CSV.replace("0.19867", "NaN"), (), "refuse"),
    "nan lower case": (GOOD_CSV.replace("0.19867", "nan"), (), "refuse"),
    "inf": (GOOD_CSV.replace("0.19867", "inf"), (), "refuse"),
    "-Infinity": (GOOD_CSV.replace("0.19867", "-Infinity"), (), "refuse"),
    "1e999": (GOOD_CSV.replace("0.19867", "1e999"), (), "refuse"),
    "1e308 in g": (GOOD_CSV.replace("[m/s^2]", "[g]").replace("0.19867", "1e308"), (), "refuse"),
    "1e300": (GOOD_CSV.replace("0.19867", "1e300"), (), "refuse"),
    "1e-320": (GOOD_CSV.replace("0.19867", "1e-320"), (), "any"),
    "a digit group 1_000": (GOOD_CSV.replace("0.19867", "1_000"), (), "refuse"),
    "a hex number": (GOOD_CSV.replace("0.19867", "0x10"), (), "refuse"),
    "Arabic-Indic digits": (GOOD_CSV.replace("0.19867", "\u0661\u0662"), (), "refuse"),
    "full-width digits": (GOOD_CSV.replace("0.19867", "\uff11"), (), "refuse"),
    "a number of 10,000 digits": (GOOD_CSV.replace("0.19867", "1" * 10_000), (), "refuse"),
    "a long fraction": (GOOD_CSV.replace("0.19867", "0." + "0" * 10_000 + "1"), (), "any"),
    "a quoted number": (GOOD_CSV.replace("0.19867", '"0.19867"'), (), "any"),
    "a ragged row": (GOOD_CSV.replace("0.19867,", "0.19867,1,"), (), "refuse"),
    "only a header": ("time,a1 [m/s^2]\n", (), "refuse"),
    "empty": ("", (), "refuse"),
    "one sample": ("time,a1 [m/s^2]\n0,1\n", (), "refuse"),
    "mixed units": (GOOD_CSV.replace("a2 [m/s^2]", "a2 [g]"), (), "any"),
    "a unit mm/s": (GOOD_CSV.replace("a2 [m/s^2]", "a2 [mm/s]"), (), "refuse"),
    "a unit of 10,000 characters": (GOOD_CSV.replace("m/s^2]", "m" * 10_000 + "]", 1), (), "refuse"),
    "units on some columns": (GOOD_CSV.replace("a2 [m/s^2]", "a2"), (), "refuse"),
    "a unit (g) in parentheses": (GOOD_CSV.replace("[m/s^2]", "(g)"), (), "any"),
    "two columns of one name": (GOOD_CSV.replace("a2", "a1"), (), "refuse"),
    "a name with a newline": (GOOD_CSV.replace("a1 [m/s^2]", '"a\nb [m/s^2]"'), (), "refuse"),
    "a name with an escape": (GOOD_CSV.replace("a1", "\x1b[31ma"), (), "refuse"),
    "a name with a bidi override": (GOOD_CSV.replace("a1", "a\u202eb"), (), "refuse"),
    "a name of 10,000 characters": (GOOD_CSV.replace("a1", "n" * 10_000), (), "refuse"),
    "a name with a NUL": (GOOD_CSV.replace("a1", "a\x00b"), (), "refuse"),
    "a name with a slash": (GOOD_CSV.replace("a1", "a/b"), (), "any"),
    "time going backwards": (GOOD_CSV.replace("0.05,", "0.03,", 1), (), "refuse"),
    "time steps of 1e-320 s": ("time,a1 [m/s^2]\n" + "".join(f"{k}e-320,{k}\n" for k in range(1, 9)), (), "refuse"),
    "time steps of 1e300 s": ("time,a1 [m/s^2]\n" + "".join(f"{k}e300,{k}\n" for k in range(1, 9)), (), "refuse"),
    "time steps of 1 ns": ("time,a1 [m/s^2]\n" + "".join(f"{k}e-9,{k}\n" for k in range(1, 9)), (), "refuse"),
    "time steps of 100 s": ("time,a1 [m/s^2]\n" + "".join(f"{k * 100},{k}\n" for k in range(1, 9)), (), "refuse"),
    "only a time column": ("time\n" + "".join(f"{k / 100}\n" for k in range(9)), ("--units", "g"), "refuse"),
    "a force column in N": (GOOD_CSV.replace("a1 [m/s^2]", "hammer [N]"), (), "any"),
    "two force columns": (GOOD_CSV.replace("a1 [m/s^2]", "f1 [N]").replace("a2 [m/s^2]", "f2 [N]"), (), "refuse"),
    "4,097 columns": ("time," + ",".join(f"c{k} [g]" for k in range(4097)) + "\n"
                      + "".join(f"{t / 100}," + ",".join(["0.1"] * 4097) + "\n" for t in range(3)), (), "refuse"),
    "20,000 rows of one column": ("a [g]\n" + "0.5\n" * 20_000, ("--rate", "1000"), "any"),
    "a line of 1,000,000 commas (a blank row)": (GOOD_CSV + "," * 1_000_000 + "\n", (), "any"),
    "--rate 0": (GOOD_CSV.replace("time,", "x [g],"), ("--rate", "0"), "refuse"),
    "--rate -5": (GOOD_CSV.replace("time,", "x [g],"), ("--rate=-5",), "refuse"),
    "--rate nan": (GOOD_CSV.replace("time,", "x [g],"), ("--rate", "nan"), "refuse"),
    "--rate 1e300": (GOOD_CSV.replace("time,", "x [g],"), ("--rate", "1e300"), "refuse"),
    "--rate 1e-300": (GOOD_CSV.replace("time,", "x [g],"), ("--rate", "1e-300"), "refuse"),
    "--rate 0.01": (GOOD_CSV.replace("time,", "x [g],"), ("--rate", "0.01"), "refuse"),
    "--rate 1e9": (GOOD_CSV.replace("time,", "x [g],"), ("--rate", "1e9"), "refuse"),
    "--units empty": (GOOD_CSV.replace(" [m/s^2]", ""), ("--units", ""), "refuse"),
    "--units two for three": (GOOD_CSV.replace(" [m/s^2]", "").replace("time,", "x,"), ("--units", "g,g", "--rate", "100"),
                              "refuse"),
    "--channels empty": (GOOD_CSV, ("--channels", ""), "refuse"),
    "--channels one name twice": (GOOD_CSV, ("--channels", "a,a"), "refuse"),
    "--channels ' , '": (GOOD_CSV, ("--channels", " , "), "refuse"),
    "--format npy on a CSV": (GOOD_CSV, ("--format", "npy"), "refuse"),
    "--format nosuch": (GOOD_CSV, ("--format", "nosuch"), "refuse"),
    "--format empty": (GOOD_CSV, ("--format", ""), "refuse"),
}
CSV_SIDECARS = {
    "sidecar rate a string": 'sampling_rate = "fast"\n',
    "sidecar rate 1e300": "sampling_rate = 1e300\n",
    "sidecar rate a huge integer": "sampling_rate = " + "9" * 400 + "\n",
    "sidecar rate true": "sampling_rate = true\n",
    "sidecar units a table": "units = { a = 1 }\n",
    "sidecar units a number": "units = 5\n",
    "sidecar channels numbers": "channels = [1, 2]\n",
    "sidecar channels nested": "channels = [[1], [2]]\n",
    "sidecar unknown field": "sampling_rat = 100.0\n",
    "sidecar not TOML": "sampling_rate = \n",
    "sidecar nested 10,000 deep": "x = " + "[" * 10_000 + "]" * 10_000 + "\n",
    "sidecar latin-1": "channels = ['\xe9', 'b']\n",
}


def csv_cases() -> list[Case]:
    out = [_import_case("csv", f"import csv: {label}", "r.csv", {"r.csv": c if isinstance(c, bytes) else _csv(c)}, *o,
                        expect=e) for label, (c, o, e) in CSV.items()]
    plain = GOOD_CSV.replace(" [m/s^2]", "").replace("time,", "x,")
    for label, side in CSV_SIDECARS.items():
        data = side.encode("latin-1") if "latin-1" in label else side.encode()
        extra = () if "units" in label else ("--units", "g")
        extra += () if "rate" in label else ("--rate", "100")
        if "channels" in label:
            plain3 = plain
            out.append(_import_case("csv", f"import csv: {label}", "r.csv", {"r.csv": _csv(plain3), "r.toml": data},
                                    *extra, expect="refuse"))
        else:
            out.append(_import_case("csv", f"import csv: {label}", "r.csv", {"r.csv": _csv(plain), "r.toml": data}, *extra,
                                    expect="refuse"))
    # the record onto the rig of p.h5 (its sensors by name)
    out.append(_import_case("csv", "import csv onto a rig: columns no sensor has", "r.csv", {"r.csv": _csv(GOOD_CSV)},
                            project="p.h5"))
    out.append(_import_case("csv", "import csv: a FIFO", "r.csv", {"r.csv": lambda p: os.mkfifo(p)}, expect="refuse"))
    out.append(_import_case("csv", "import csv: a link to /dev/zero", "r.csv",
                            {"r.csv": lambda p: os.symlink("/dev/zero", p)}, expect="refuse"))
    out.append(_import_case("csv", "import csv: a folder", "r.csv", {"r.csv": lambda p: p.mkdir()}, expect="refuse"))
    out.append(_import_case("csv", "import csv: a missing file", "none.csv", {}, expect="refuse"))
    out.append(_import_case("csv", "import csv: a sparse 2 GiB file", "r.csv",
                            {"r.csv": lambda p: (p.write_text("a [g]\n"), os.truncate(p, 2**31))}, "--rate", "100",
                            expect="refuse"))
    return out


# ----------------------------------------------------------------------------- npy

def _npy(make: Callable[[], np.ndarray], **kw) -> Callable[[Path], None]:
    def write(p: Path) -> None:
        with open(p, "wb") as f:
            np.save(f, make(), **kw)
    return write


def _npy_header(descr: str, shape: tuple, fortran: bool = False, payload: bytes = b"\0" * 64) -> Callable[[Path], None]:
    def write(p: Path) -> None:
        import numpy.lib.format as fmt
        with open(p, "wb") as f:
            fmt.write_array_header_1_0(f, {"descr": descr, "fortran_order": fortran, "shape": shape})
            f.write(payload)
    return write


SIG = lambda n=200, c=3: np.sin(np.arange(n)[:, None] / (3 + np.arange(c)))  # noqa: E731
NPY: dict[str, tuple[Callable[[Path], None], str]] = {
    "good": (_npy(SIG), "any"),
    "object dtype": (_npy(lambda: np.array([1, "a", None], dtype=object), allow_pickle=True), "refuse"),
    "object dtype of numbers": (_npy(lambda: SIG().astype(object), allow_pickle=True), "refuse"),
    "fortran order": (_npy(lambda: np.asfortranarray(SIG())), "any"),
    "0-d": (_npy(lambda: np.array(3.0)), "refuse"),
    "structured": (_npy(lambda: np.zeros(10, dtype=[("a", "f8"), ("b", "f8")])), "refuse"),
    "big-endian": (_npy(lambda: SIG().astype(">f8")), "any"),
    "big-endian int16": (_npy(lambda: (SIG() * 1000).astype(">i2")), "any"),
    "float16": (_npy(lambda: SIG().astype(np.float16)), "any"),
    "bool": (_npy(lambda: SIG() > 0), "refuse"),
    "complex": (_npy(lambda: SIG() + 1j), "refuse"),
    "strings": (_npy(lambda: np.array([["1", "2"], ["3", "4"]])), "refuse"),
    "datetime64": (_npy(lambda: np.arange(10).astype("datetime64[s]")), "refuse"),
    "timedelta64": (_npy(lambda: np.arange(10).astype("timedelta64[s]")), "refuse"),
    "uint64 near 2**64": (_npy(lambda: np.full((10, 2), 2**64 - 1, dtype=np.uint64)), "refuse"),
    "1e308 values": (_npy(lambda: np.full((10, 2), 1e308)), "refuse"),
    "a NaN": (_npy(lambda: np.where(np.arange(200)[:, None] == 7, np.nan, SIG())), "refuse"),
    "an inf": (_npy(lambda: np.where(np.arange(200)[:, None] == 7, np.inf, SIG())), "refuse"),
    "3-D": (_npy(lambda: np.zeros((4, 4, 4))), "refuse"),
    "0 x 3": (_npy(lambda: np.zeros((0, 3))), "refuse"),
    "1 x 3 (read transposed: 3 samples)": (_npy(lambda: np.zeros((1, 3))), "any"),
    "2 x 100,000 (read transposed)": (_npy(lambda: np.zeros((2, 100_000))), "any"),
    "5000 x 5000 of one channel each row": (_npy(lambda: np.zeros((70, 70))), "any"),
    "header: 10^11 x 2 float64, 64 bytes": (_npy_header("<f8", (10**11, 2)), "refuse"),
    "header: 2^62 x 2": (_npy_header("<f8", (2**62, 2)), "refuse"),
    "header: negative shape": (_npy_header("<f8", (-1, 2)), "refuse"),
    "header: shape of 10^6 dimensions": (_npy_header("<f8", (1,) * 64), "refuse"),
    "header: fortran order with too few bytes": (_npy_header("<f8", (100, 3), fortran=True), "refuse"),
    "header: unknown dtype": (_npy_header("<q9", (4, 2)), "refuse"),
    "header cut": (lambda p: p.write_bytes(b"\x93NUMPY\x01\x00\x76\x00{'descr': '<f8', 'fortran_order'"), "refuse"),
    "not npy": (lambda p: p.write_bytes(b"hello"), "refuse"),
    "empty": (lambda p: p.write_bytes(b""), "refuse"),
    "npz saved as npy": (lambda p: (np.savez(p.with_suffix(".npz"), a=SIG()), os.replace(p.with_suffix(".npz"), p)),
                         "refuse"),
    "pickle": (lambda p: p.write_bytes(__import__("pickle").dumps([1, 2, 3])), "refuse"),
    "a FIFO": (lambda p: os.mkfifo(p), "refuse"),
    "a link to /dev/zero": (lambda p: os.symlink("/dev/zero", p), "refuse"),
}
NPY_OPTIONS = {
    "--units N,N,N": ("--units", "N,N,N"),
    "--channels of 4 names for 3": ("--channels", "a,b,c,d"),
    "--units kg": ("--units", "kg"),
    "--rate 1e10": ("--rate", "1e10"),
    "--rate 0.0": ("--rate", "0.0"),
    "--variable on a npy": ("--variable", "x"),
    "--group on a npy": ("--group", "x"),
    "--force-channel nosuch": ("--force-channel", "nosuch"),
    "--force-point on a project without a rig": ("--force-point", "0,0,0"),
}


def npy_cases() -> list[Case]:
    base = ("--rate", "1000", "--units", "g")
    out = [_import_case("npy", f"import npy: {label}", "r.npy", {"r.npy": w}, *base, expect=e)
           for label, (w, e) in NPY.items()]
    for label, opts in NPY_OPTIONS.items():
        o = base + opts if "--units" not in opts and "--rate" not in opts else (
            opts + (("--units", "g") if "--rate" in opts else ("--rate", "1000")))
        out.append(_import_case("npy", f"import npy: {label}", "r.npy", {"r.npy": _npy(SIG)}, *o,
                                expect="refuse"))
    return out


# ----------------------------------------------------------------------------- mat

def _savemat(variables: dict, **kw) -> Callable[[Path], None]:
    def write(p: Path) -> None:
        import scipy.io
        scipy.io.savemat(p, variables, **kw)
    return write


MAT73_HEADER = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Fri Nov 27 00:00:00 2026 HDF5 schema 1.00 .".ljust(116) \
    + b"\0" * 8 + b"\x00\x02IM"


def _mat73(fill: Callable[[h5py.File, Path], None], header: bool = True) -> Callable[[Path], None]:
    def write(p: Path) -> None:
        with h5py.File(p, "w", userblock_size=512) as f:
            fill(f, p)
        if header:
            with open(p, "r+b") as f:
                f.write(MAT73_HEADER)
    return write


def _char(f: h5py.File, name: str, text: str) -> None:
    ds = f.create_dataset(name, data=np.array([[ord(c)] for c in text], dtype=np.uint16))
    ds.attrs["MATLAB_class"] = np.bytes_("char")


def _v73_good(f, p):
    f["data"] = SIG(200, 3).T
    f["fs"] = np.array([[1000.0]])


def _v73_ext(f, p):
    (p.parent / "home" / "secret.bin").write_bytes(np.random.default_rng(0).random(600).tobytes())
    f.create_dataset("data", shape=(3, 200), dtype="f8", external=[(str(p.parent / "home" / "secret.bin"), 0, 4800)])
    f["fs"] = np.array([[1000.0]])


def _v73_extlink(f, p):
    f["data"] = h5py.ExternalLink(str(p.parent / "p.h5"), "experiments/s1/raw")
    f["fs"] = np.array([[1000.0]])


def _v73_virtual(f, p):
    layout = h5py.VirtualLayout(shape=(2048, 11), dtype="f8")
    layout[:] = h5py.VirtualSource(str(p.parent / "p.h5"), "experiments/s1/raw", shape=(2048, 11))
    f.create_virtual_dataset("data", layout)
    f["fs"] = np.array([[1000.0]])


MAT: dict[str, tuple[Callable[[Path], None], tuple[str, ...], str]] = {
    "good v5": (_savemat({"data": SIG(), "fs": 1000.0, "units": "g"}), (), "any"),
    "v4": (_savemat({"data": SIG(), "fs": 1000.0}, format="4"), ("--units", "g"), "any"),
    "fs a string": (_savemat({"data": SIG(), "fs": "abc", "units": "g"}), (), "refuse"),
    "fs a string, --rate given": (_savemat({"data": SIG(), "fs": "abc", "units": "g"}), ("--rate", "100"), "any"),
    "fs a cell": (_savemat({"data": SIG(), "fs": np.array([[1.0]], dtype=object), "units": "g"}), (), "refuse"),
    "fs a struct": (_savemat({"data": SIG(), "fs": {"a": 1}, "units": "g"}), (), "refuse"),
    "fs complex": (_savemat({"data": SIG(), "fs": 1000.0 + 1j, "units": "g"}), (), "refuse"),
    "fs logical (scipy reads uint8 1: 1 Hz)": (_savemat({"data": SIG(), "fs": np.array([[True]]), "units": "g"}), (), "any"),
    "fs -5": (_savemat({"data": SIG(), "fs": -5.0, "units": "g"}), (), "refuse"),
    "fs 1e300": (_savemat({"data": SIG(), "fs": 1e300, "units": "g"}), (), "refuse"),
    "fs 1e-300": (_savemat({"data": SIG(), "fs": 1e-300, "units": "g"}), (), "refuse"),
    "fs nan": (_savemat({"data": SIG(), "fs": np.nan, "units": "g"}), (), "refuse"),
    "fs empty": (_savemat({"data": SIG(), "fs": np.zeros((0, 0)), "units": "g"}), (), "refuse"),
    "complex data": (_savemat({"data": SIG() + 1j, "fs": 1000.0, "units": "g"}), (), "refuse"),
    "complex data named": (_savemat({"data": SIG() + 1j, "fs": 1000.0, "units": "g"}), ("--variable", "data"), "refuse"),
    "sparse data named": (_savemat({"data": __import__("scipy.sparse").sparse.csc_matrix(np.eye(50)), "fs": 1000.0,
                                    "units": "g"}), ("--variable", "data"), "refuse"),
    "a cell array named": (_savemat({"data": np.array([SIG(), SIG()], dtype=object), "fs": 1000.0, "units": "g"}),
                           ("--variable", "data"), "refuse"),
    "a struct named": (_savemat({"data": {"a": SIG()}, "fs": 1000.0, "units": "g"}), ("--variable", "data"), "refuse"),
    "a struct array named": (_savemat({"data": np.array([({"a": 1},), ({"a": 2},)], dtype=object), "fs": 1000.0,
                                       "units": "g"}), ("--variable", "data"), "refuse"),
    "logical data named (scipy reads uint8)": (_savemat({"data": SIG() > 0, "fs": 1000.0, "units": "g"}),
                                               ("--variable", "data"), "any"),
    "char data named": (_savemat({"data": "hello", "fs": 1000.0, "units": "g"}), ("--variable", "data"), "refuse"),
    "channels a cell of strings": (_savemat({"data": SIG(), "fs": 1000.0, "units": "g",
                                             "channels": np.array(["a", "b", "c"], dtype=object)}), (), "any"),
    "channels a cell with a number": (_savemat({"data": SIG(), "fs": 1000.0, "units": "g",
                                                "channels": np.array(["a", 5.0, "c"], dtype=object)}), (), "any"),
    "channels a cell of empty arrays": (_savemat({"data": SIG(), "fs": 1000.0, "units": "g",
                                                  "channels": np.array([np.zeros(0)] * 3, dtype=object)}), (), "refuse"),
    "channels a struct": (_savemat({"data": SIG(), "fs": 1000.0, "units": "g", "channels": {"a": 1}}), (), "refuse"),
    "channels empty": (_savemat({"data": SIG(), "fs": 1000.0, "units": "g", "channels": np.zeros((0, 0))}), (),
                       "refuse"),
    "units a cell with a struct": (_savemat({"data": SIG(), "fs": 1000.0,
                                             "units": np.array([{"a": 1}, "g", "g"], dtype=object)}), (), "refuse"),
    "units an empty char": (_savemat({"data": SIG(), "fs": 1000.0, "units": ""}), (), "refuse"),
    "two numeric arrays": (_savemat({"data": SIG(), "more": SIG(), "fs": 1000.0, "units": "g"}), (), "refuse"),
    "--variable nosuch": (_savemat({"data": SIG(), "fs": 1000.0, "units": "g"}), ("--variable", "nosuch"), "refuse"),
    "--variable fs (one number)": (_savemat({"data": SIG(), "fs": 1000.0, "units": "g"}), ("--variable", "fs"), "refuse"),
    "--variable __header__": (_savemat({"data": SIG(), "fs": 1000.0, "units": "g"}), ("--variable", "__header__"),
                              "refuse"),
    "data of 1e308": (_savemat({"data": np.full((50, 2), 1e308), "fs": 1000.0, "units": "g"}), (), "refuse"),
    "data with a NaN": (_savemat({"data": np.where(np.arange(200)[:, None] == 3, np.nan, SIG()), "fs": 1000.0,
                                  "units": "g"}), (), "refuse"),
    "data 3-D": (_savemat({"data": np.zeros((4, 4, 4)), "fs": 1000.0, "units": "g"}), (), "refuse"),
    "not a mat file": (lambda p: p.write_bytes(b"hello, world" * 20), ("--rate", "100", "--units", "g"), "refuse"),
    "empty": (lambda p: p.write_bytes(b""), ("--rate", "100", "--units", "g"), "refuse"),
    "128 zero bytes": (lambda p: p.write_bytes(b"\0" * 128), ("--rate", "100", "--units", "g"), "refuse"),
    "v5 cut in half": (lambda p: (_savemat({"data": SIG(), "fs": 1000.0, "units": "g"})(p),
                                  os.truncate(p, p.stat().st_size // 2)), (), "refuse"),
    "v5 with a byte flipped in the tag": (lambda p: (_savemat({"data": SIG(), "fs": 1000.0, "units": "g"})(p),
                                                     _flip(p, 130)), (), "refuse"),
    "v7.3 good": (_mat73(_v73_good), ("--units", "g"), "any"),
    "v7.3 without the MATLAB header": (_mat73(_v73_good, header=False), ("--units", "g"), "refuse"),
    "v7.3 fs a char array": (_mat73(lambda f, p: (_v73_good(f, p), f.__delitem__("fs"), _char(f, "fs", "abc"))),
                             ("--units", "g"), "refuse"),
    "v7.3 channels a char array": (_mat73(lambda f, p: (_v73_good(f, p), _char(f, "channels", "abc"))),
                                   ("--units", "g"), "any"),
    "v7.3 complex data": (_mat73(lambda f, p: (f.__setitem__("data", (SIG(200, 3) + 1j).T),
                                               f.__setitem__("fs", np.array([[1000.0]])))), ("--units", "g"), "refuse"),
    "v7.3 a dangling soft link": (_mat73(lambda f, p: (_v73_good(f, p), f.__setitem__("x", h5py.SoftLink("/none")))),
                                  ("--units", "g"), "any"),
    "v7.3 a soft link to itself": (_mat73(lambda f, p: (_v73_good(f, p), f.__setitem__("x", h5py.SoftLink("/x")))),
                                   ("--units", "g"), "any"),
    "v7.3 data a soft link": (_mat73(lambda f, p: (f.__setitem__("d0", SIG(200, 3).T), f.__setitem__("fs", np.array([[1e3]])),
                                                   f.__setitem__("data", h5py.SoftLink("/d0")))), ("--units", "g", "--variable", "data"),
                              "any"),
    "v7.3 data external storage on a user's file": (_mat73(_v73_ext), ("--units", "g"), "refuse"),
    "v7.3 data an external link into the project": (_mat73(_v73_extlink), ("--units", "g", "--variable", "data"), "refuse"),
    "v7.3 data a virtual dataset of the project": (_mat73(_v73_virtual), ("--units", "g"), "refuse"),
    "v7.3 data 3 x 10^11 unallocated": (_mat73(lambda f, p: (f.create_dataset("data", shape=(3, 10**11), dtype="f8",
                                                                              chunks=(3, 1000)),
                                                             f.__setitem__("fs", np.array([[1e3]])))), ("--units", "g"),
                                        "refuse"),
    "v7.3 data 10^6 x 10^6 unallocated": (_mat73(lambda f, p: (f.create_dataset("data", shape=(10**6, 10**6), dtype="f8",
                                                                                chunks=(100, 100)),
                                                               f.__setitem__("fs", np.array([[1e3]])))),
                                          ("--units", "g"), "refuse"),
    "v7.3 data compressed 1 GB of zeros": (_mat73(lambda f, p: (f.create_dataset("data", data=np.zeros((3, 2**20)),
                                                                                 chunks=(3, 2**16), compression="gzip"),
                                                                f.__setitem__("fs", np.array([[1e3]])))),
                                           ("--units", "g"), "any"),
    "v7.3 data in a group": (_mat73(lambda f, p: (f.create_group("g").__setitem__("data", SIG(200, 3).T),
                                                  f.__setitem__("fs", np.array([[1e3]])))), ("--units", "g"), "refuse"),
    "v7.3 data a reference array (cell)": (_mat73(lambda f, p: (f.__setitem__("d0", SIG(200, 3).T),
                                                                f.create_dataset("data", data=np.array([f["d0"].ref]),
                                                                                 dtype=h5py.ref_dtype),
                                                                f.__setitem__("fs", np.array([[1e3]])))),
                                           ("--units", "g", "--variable", "data"), "refuse"),
    "v7.3 data a compound dtype": (_mat73(lambda f, p: (f.create_dataset("data", data=np.zeros(10, dtype=[("re", "f8"), ("im", "f8")])),
                                                        f.__setitem__("fs", np.array([[1e3]])))),
                                   ("--units", "g", "--variable", "data"), "refuse"),
    "v7.3 data with a NaN fill value": (_mat73(lambda f, p: (f.create_dataset("data", shape=(3, 200), dtype="f8",
                                                                              fillvalue=np.nan),
                                                             f.__setitem__("fs", np.array([[1e3]])))), ("--units", "g"),
                                        "refuse"),
}


def _flip(p: Path, at: int) -> None:
    b = bytearray(p.read_bytes())
    b[at] ^= 0xFF
    p.write_bytes(bytes(b))


def mat_cases() -> list[Case]:
    return [_import_case("mat", f"import mat: {label}", "r.mat", {"r.mat": w}, *o, expect=e)
            for label, (w, o, e) in MAT.items()]


# ----------------------------------------------------------------------------- TDMS

def _tdms(channels: list[tuple[str, object, dict]], group: str = "g", cut: int | None = None,
          more_groups: tuple[str, ...] = ()) -> Callable[[Path], None]:
    def write(p: Path) -> None:
        from nptdms import ChannelObject, GroupObject, TdmsWriter
        with TdmsWriter(str(p)) as w:
            objs = [GroupObject(group)] + [ChannelObject(group, n, np.asarray(v), properties=props)
                                           for n, v, props in channels]
            objs += [GroupObject(g) for g in more_groups]
            w.write_segment(objs)
        if cut is not None:
            os.truncate(p, p.stat().st_size - cut)
    return write


def _ch(name: str = "a1", data=None, **props):
    base = {"unit_string": "m/s^2", "wf_increment": 0.001}
    base.update(props)
    return (name, SIG(200, 1)[:, 0] if data is None else data, {k: v for k, v in base.items() if v is not None})


TDMS: dict[str, tuple[Callable[[Path], None], tuple[str, ...], str]] = {
    "good": (_tdms([_ch("a1"), _ch("a2")]), (), "any"),
    "wf_increment a string": (_tdms([_ch("a1", wf_increment="fast")]), (), "refuse"),
    "wf_increment a number string": (_tdms([_ch("a1", wf_increment="0.001")]), (), "any"),
    "wf_increment 0": (_tdms([_ch("a1", wf_increment=0.0)]), (), "refuse"),
    "wf_increment -0.001": (_tdms([_ch("a1", wf_increment=-0.001)]), (), "refuse"),
    "wf_increment nan": (_tdms([_ch("a1", wf_increment=float("nan"))]), (), "refuse"),
    "wf_increment inf": (_tdms([_ch("a1", wf_increment=float("inf"))]), (), "refuse"),
    "wf_increment 1e-300": (_tdms([_ch("a1", wf_increment=1e-300)]), (), "refuse"),
    "wf_increment 1e300": (_tdms([_ch("a1", wf_increment=1e300)]), (), "refuse"),
    "wf_increment an integer (1 s)": (_tdms([_ch("a1", wf_increment=np.int32(1))]), (), "any"),
    "wf_increment a bool": (_tdms([_ch("a1", wf_increment=True)]), (), "refuse"),
    "wf_increment differs": (_tdms([_ch("a1"), _ch("a2", wf_increment=0.002)]), (), "refuse"),
    "wf_increment a timestamp": (_tdms([_ch("a1", wf_increment=np.datetime64("2020-01-01T00:00:00"))]), (), "refuse"),
    "unit_string kg": (_tdms([_ch("a1", unit_string="kg")]), (), "refuse"),
    "unit_string empty on one": (_tdms([_ch("a1"), _ch("a2", unit_string="")]), (), "refuse"),
    "unit_string a number": (_tdms([_ch("a1", unit_string=5.0)]), (), "refuse"),
    "no properties": (_tdms([_ch("a1", unit_string=None, wf_increment=None)]), (), "refuse"),
    "no properties, options given": (_tdms([_ch("a1", unit_string=None, wf_increment=None)]),
                                     ("--rate", "1000", "--units", "g"), "any"),
    "string data": (_tdms([_ch("a1", data=np.array(["a", "b", "c"]))]), (), "refuse"),
    "bool data": (_tdms([_ch("a1", data=np.array([True, False, True]))]), (), "refuse"),
    "complex data": (_tdms([_ch("a1", data=SIG(200, 1)[:, 0] + 1j)]), (), "refuse"),
    "timestamp data": (_tdms([_ch("a1", data=np.array(["2020-01-01", "2020-01-02"], dtype="datetime64[s]"))]), (),
                       "refuse"),
    "NaN data": (_tdms([_ch("a1", data=np.array([0.0, np.nan, 1.0]))]), (), "refuse"),
    "1e308 data in g": (_tdms([_ch("a1", data=np.full(10, 1e308), unit_string="g")]), (), "refuse"),
    "channels of different lengths": (_tdms([_ch("a1"), _ch("a2", data=np.zeros(7))]), (), "refuse"),
    "one sample": (_tdms([_ch("a1", data=np.zeros(1))]), (), "refuse"),
    "empty channel": (_tdms([_ch("a1", data=np.zeros(0))]), (), "refuse"),
    "two groups, none named": (_tdms([_ch("a1")], more_groups=("other",)), (), "refuse"),
    "--group nosuch": (_tdms([_ch("a1")]), ("--group", "nosuch"), "refuse"),
    "--group empty": (_tdms([_ch("a1")]), ("--group", ""), "refuse"),
    "a group name with an escape": (_tdms([_ch("a1")], group="\x1b[31mg"), (), "any"),
    "a channel name with a newline": (_tdms([_ch("a\nb")]), (), "refuse"),
    "channel names differing in case": (_tdms([_ch("a1"), _ch("A1")]), (), "any"),
    "cut by 8 bytes": (_tdms([_ch("a1"), _ch("a2")], cut=8), (), "refuse"),
    "cut by 1 byte": (_tdms([_ch("a1"), _ch("a2")], cut=1), (), "refuse"),
    "not TDMS": (lambda p: p.write_bytes(b"TDSm" + b"\0" * 60), (), "refuse"),
    "empty": (lambda p: p.write_bytes(b""), (), "refuse"),
    "a lead-in claiming 2^60 bytes": (lambda p: p.write_bytes(b"TDSm" + (14).to_bytes(4, "little") + (4713).to_bytes(4, "little")
                                                            + (2**60).to_bytes(8, "little") + (2**59).to_bytes(8, "little")
                                                            + b"\0" * 64), (), "refuse"),
    "a FIFO": (lambda p: os.mkfifo(p), (), "refuse"),
}


def tdms_cases() -> list[Case]:
    return [_import_case("tdms", f"import tdms: {label}", "r.tdms", {"r.tdms": w}, *o, expect=e)
            for label, (w, o, e) in TDMS.items()]


# ----------------------------------------------------------------------------- lvm and UFF through `import`

def _good_uff(p: Path) -> None:
    import pyuff
    u = pyuff.UFF(str(p))
    t = np.arange(64) / 1000.0
    for k, (name, sig) in enumerate((("force", np.exp(-((t - 0.005) / 0.001) ** 2)), ("acc", np.sin(2 * np.pi * 50 * t)))):
        u.write_sets({"type": 58, "binary": 0, "func_type": 1, "rsp_node": 1, "rsp_dir": 3, "ref_node": 1, "ref_dir": 3,
                      "data": sig, "x": t, "id1": name, "rsp_ent_name": name, "ref_ent_name": "force",
                      "abscissa_spacing": 1, "abscissa_spec_data_type": 17, "ordinate_spec_data_type": 8 if k else 13,
                      "orddenom_spec_data_type": 13, "z_axis_spec_data_type": 0}, mode="add")


OTHER: dict[str, tuple[str, Callable[[Path], None], tuple[str, ...], str]] = {
    "lvm good": ("r.lvm", lambda p: p.write_text(rt.lvm_text(rt.GOOD_ROWS)), (), "any"),
    "lvm decimal comma": ("r.lvm", lambda p: p.write_text(rt.lvm_text([r.replace(".", ",") for r in rt.GOOD_ROWS])
                                                          .replace("Decimal_Separator\t.", "Decimal_Separator\t,")), (), "any"),
    "lvm decimal comma undeclared": ("r.lvm", lambda p: p.write_text(rt.lvm_text([r.replace(".", ",") for r in rt.GOOD_ROWS])),
                                     (), "refuse"),
    "lvm a NaN sample": ("r.lvm", lambda p: p.write_text(rt.lvm_text(["NaN\t0.1"] + rt.GOOD_ROWS[1:])), (), "refuse"),
    "lvm Delta_X 1e-300": ("r.lvm", lambda p: p.write_text(rt.lvm_text(rt.GOOD_ROWS).replace("1.0E-4\t1.0E-4", "1e-300\t1e-300")),
                           (), "refuse"),
    "lvm with --rate": ("r.lvm", lambda p: p.write_text(rt.lvm_text(rt.GOOD_ROWS)), ("--rate", "100"), "refuse"),
    "lvm with --variable": ("r.lvm", lambda p: p.write_text(rt.lvm_text(rt.GOOD_ROWS)), ("--variable", "x"), "refuse"),
    "lvm --format csv": ("r.lvm", lambda p: p.write_text(rt.lvm_text(rt.GOOD_ROWS)), ("--format", "csv"), "refuse"),
    "uff good": ("r.uff", _good_uff, (), "any"),
    "uff empty": ("r.uff", lambda p: p.write_bytes(b""), (), "refuse"),
    "uff only -1 lines": ("r.uff", lambda p: p.write_text("    -1\n    -1\n"), (), "refuse"),
    "uff an unknown dataset type": ("r.uff", lambda p: p.write_text("    -1\n  9999\nhello\n    -1\n"), (), "refuse"),
    "uff cut inside its second record": ("r.uff", lambda p: (_good_uff(p), os.truncate(p, p.stat().st_size * 3 // 5)), (),
                                          "refuse"),
    "uff with a NaN": ("r.uff", lambda p: (_good_uff(p), p.write_text(p.read_text().replace("0.00000e+00", "NaN", 3))), (),
                       "refuse"),
    "uff binary garbage": ("r.uff", lambda p: p.write_bytes(b"    -1\n    58b\n" + bytes(range(256)) * 4), (), "refuse"),
    "uff --format mat": ("r.uff", _good_uff, ("--format", "mat"), "refuse"),
    "unv suffix": ("r.unv", _good_uff, (), "any"),
    "no suffix": ("r", lambda p: p.write_text(GOOD_CSV), (), "refuse"),
    "suffix .CSV in capitals": ("r.CSV", lambda p: p.write_text(GOOD_CSV), (), "any"),
    "suffix .txt": ("r.txt", lambda p: p.write_text(GOOD_CSV), (), "refuse"),
    "the project itself": ("q.h5", lambda p: None, ("--format", "mat", "--units", "g", "--rate", "100"), "refuse"),
    "the project's lock name": (".q.h5.odsuite-lock", lambda p: p.write_text(GOOD_CSV), ("--format", "csv"), "refuse"),
}


def other_import_cases() -> list[Case]:
    return [_import_case("lvm, uff, suffixes", f"import: {label}", f, {f: w} if f != "q.h5" else {}, *o, expect=e)
            for label, (f, w, o, e) in OTHER.items()]


# ----------------------------------------------------------------------------- rig files (docs/rig-format.md)

RIG_DOC = """name = "bench"
description = "a plate on four springs"
force_channel = 0
default_model = "rigid-bodies"

[[bodies]]
name = "plate"
mass = 2.0
inertia = [[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.18]]
plate = { size = [0.2, 0.2, 0.02], corner = [-0.1, -0.1, 0.0] }

[[sensors]]
name = "a1"
channel = 1
body = "plate"
position = [0.05, 0.05, 0.02]
axis = [0.0, 0.0, 1.0]
sensitivity = 0.01

[[sensors]]
name = "a2"
channel = 2
body = "plate"
position = [-0.05, 0.05, 0.02]
axis = [0.0, 0.0, 1.0]
sensitivity = 0.01

[[springs]]
name = "s1"
body = "plate"
position = [0.08, 0.08, 0.0]
stiffness = [1e5, 1e5, 1e5]
damping = [1.0, 1.0, 1.0]

[[springs]]
name = "s2"
body = "plate"
position = [-0.08, 0.08, 0.0]
stiffness = [1e5, 1e5, 1e5]
damping = [1.0, 1.0, 1.0]

[[springs]]
name = "s3"
body = "plate"
position = [0.0, -0.08, 0.0]
stiffness = [1e5, 1e5, 1e5]
damping = [1.0, 1.0, 1.0]
"""


def _no_springs(text: str) -> str:
    return text.split("[[springs]]")[0]


RIGS: dict[str, tuple[str, str]] = {  # label -> (text, expect)
    "as documented": (RIG_DOC, "any"),
    "one body, no springs": (_no_springs(RIG_DOC), "any"),
    "no bodies": ("name = \"x\"\nforce_channel = 0\n", "any"),
    "no sensors": (RIG_DOC.split("[[sensors]]")[0] + "[[springs]]" + RIG_DOC.split("[[springs]]", 1)[1], "any"),
    "mass 0": (RIG_DOC.replace("mass = 2.0", "mass = 0.0"), "any"),
    "mass -2": (RIG_DOC.replace("mass = 2.0", "mass = -2.0"), "refuse"),
    "mass in grams as text": (RIG_DOC.replace("mass = 2.0", 'mass = "2000 g"'), "refuse"),
    "mass 2000 (grams meant)": (RIG_DOC.replace("mass = 2.0", "mass = 2000.0"), "any"),
    "mass -0.0": (RIG_DOC.replace("mass = 2.0", "mass = -0.0"), "any"),
    "inertia negative definite": (RIG_DOC.replace("[[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.18]]",
                                                  "[[-0.1, 0, 0], [0, -0.1, 0], [0, 0, -0.18]]"), "refuse"),
    "inertia indefinite": (RIG_DOC.replace("[[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.18]]",
                                           "[[0.1, 0.2, 0], [0.2, 0.1, 0], [0, 0, 0.18]]"), "refuse"),
    "inertia zero": (RIG_DOC.replace("[[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.18]]", "[[0, 0, 0], [0, 0, 0], [0, 0, 0]]"), "refuse"),
    "inertia a vector": (RIG_DOC.replace("[[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.18]]", "[0.1, 0.1, 0.18]"), "any"),
    "inertia asymmetric": (RIG_DOC.replace("[[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.18]]",
                                           "[[0.1, 0.01, 0], [0, 0.1, 0], [0, 0, 0.18]]"), "refuse"),
    "inertia with NaN": (RIG_DOC.replace("[[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.18]]",
                                         "[[nan, 0, 0], [0, 0.1, 0], [0, 0, 0.18]]"), "refuse"),
    "sensor outside the plate": (RIG_DOC.replace("position = [0.05, 0.05, 0.02]", "position = [5.0, 5.0, 0.02]"), "any"),
    "sensor 900 m away": (RIG_DOC.replace("position = [0.05, 0.05, 0.02]", "position = [900.0, 0.0, 0.0]"), "any"),
    "sensor in mm (50, 50, 20)": (RIG_DOC.replace("position = [0.05, 0.05, 0.02]", "position = [50, 50, 20]"), "any"),
    "position with units as text": (RIG_DOC.replace("position = [0.05, 0.05, 0.02]", 'position = ["50mm", "50mm", "20mm"]'),
                                    "refuse"),
    "two sensors of one name": (RIG_DOC.replace('name = "a2"', 'name = "a1"'), "refuse"),
    "a sensor named like a body": (RIG_DOC.replace('name = "a2"', 'name = "plate"'), "any"),
    "two springs of one name": (RIG_DOC.replace('name = "s2"', 'name = "s1"'), "refuse"),
    "unicode names": (RIG_DOC.replace('"a1"', '"Beschleunigung-Ü-α"').replace('"plate"', '"Platte-β"'), "any"),
    "an emoji name": (RIG_DOC.replace('"a1"', '"\U0001f4a5"'), "any"),
    "a combining-mark name": (RIG_DOC.replace('"a1"', '"a\u0301"'), "any"),
    "a zero-width name": (RIG_DOC.replace('"a1"', '"\u200b"'), "refuse"),
    "names equal after NFC": (RIG_DOC.replace('"a1"', '"\u00e9"').replace('"a2"', '"e\u0301"'), "refuse"),
    "an empty sensor name": (RIG_DOC.replace('"a1"', '""'), "refuse"),
    "a name of spaces": (RIG_DOC.replace('"a1"', '"   "'), "refuse"),
    "a name with a slash": (RIG_DOC.replace('"a1"', '"a/1"'), "any"),
    "a name of 10,000 characters": (RIG_DOC.replace('"a1"', '"' + "n" * 10_000 + '"'), "refuse"),
    "rig name with a newline": (RIG_DOC.replace('name = "bench"', 'name = "be\\nnch"'), "refuse"),
    "rig name empty": (RIG_DOC.replace('name = "bench"', 'name = ""'), "refuse"),
    "typo: bodys": (RIG_DOC.replace("[[bodies]]", "[[bodys]]"), "refuse"),
    "typo: sensor": (RIG_DOC.replace("[[sensors]]", "[[sensor]]"), "refuse"),
    "typo: stifness": (RIG_DOC.replace("stiffness = [1e5", "stifness = [1e5", 1), "refuse"),
    "typo: postion": (RIG_DOC.replace("position = [0.05", "postion = [0.05"), "refuse"),
    "typo: plate.sise": (RIG_DOC.replace("size = [0.2", "sise = [0.2"), "refuse"),
    "typo: axis 'Z'": (RIG_DOC.replace("axis = [0.0, 0.0, 1.0]", 'axis = "Z"', 1), "any"),
    "key in capitals: Mass": (RIG_DOC.replace("mass = 2.0", "Mass = 2.0"), "refuse"),
    "stiffness a scalar": (RIG_DOC.replace("stiffness = [1e5, 1e5, 1e5]", "stiffness = 1e5", 1), "any"),
    "stiffness kN/m as text": (RIG_DOC.replace("stiffness = [1e5, 1e5, 1e5]", 'stiffness = "100 kN/m"', 1), "refuse"),
    "stiffness all zero": (RIG_DOC.replace("stiffness = [1e5, 1e5, 1e5]", "stiffness = [0.0, 0.0, 0.0]"), "any"),
    "damping negative": (RIG_DOC.replace("damping = [1.0, 1.0, 1.0]", "damping = [-1.0, 1.0, 1.0]", 1), "refuse"),
    "spring on ground": (RIG_DOC.replace('body = "plate"\nposition = [0.08', 'body = "ground"\nposition = [0.08'), "refuse"),
    "spring between plate and itself": (RIG_DOC.replace('body = "plate"\nposition = [0.08',
                                                        'body = "plate"\nother = "plate"\nposition = [0.08'), "refuse"),
    "spring to a body that is not there": (RIG_DOC.replace('body = "plate"\nposition = [0.08',
                                                           'body = "plate"\nother = "table"\nposition = [0.08'), "refuse"),
    "force_channel -1": (RIG_DOC.replace("force_channel = 0", "force_channel = -1"), "refuse"),
    "force_channel 2.0": (RIG_DOC.replace("force_channel = 0", "force_channel = 2.0"), "refuse"),
    "force_channel 3 (a free channel)": (RIG_DOC.replace("force_channel = 0", "force_channel = 3"), "any"),
    "channel_count 2 with sensors on 1 and 2": (RIG_DOC.replace("force_channel = 0", "force_channel = 0\nchannel_count = 2"),
                                                "refuse"),
    "sensitivity in mV as text": (RIG_DOC.replace("sensitivity = 0.01", 'sensitivity = "10 mV/g"', 1), "refuse"),
    "sensitivity 0": (RIG_DOC.replace("sensitivity = 0.01", "sensitivity = 0.0", 1), "refuse"),
    "sensitivity -0.01": (RIG_DOC.replace("sensitivity = 0.01", "sensitivity = -0.01", 1), "any"),
    "axis [0, 0, -1]": (RIG_DOC.replace("axis = [0.0, 0.0, 1.0]", "axis = [0.0, 0.0, -1.0]", 1), "any"),
    "plate size negative": (RIG_DOC.replace("size = [0.2, 0.2, 0.02]", "size = [-0.2, 0.2, 0.02]"), "refuse"),
    "plate size zero thickness": (RIG_DOC.replace("size = [0.2, 0.2, 0.02]", "size = [0.2, 0.2, 0.0]"), "any"),
    "default_model empty": (RIG_DOC.replace('default_model = "rigid-bodies"', 'default_model = ""'), "refuse"),
    "a duplicate key": (RIG_DOC.replace("mass = 2.0", "mass = 2.0\nmass = 3.0"), "refuse"),
    "a BOM": ("\ufeff" + RIG_DOC, "any"),
    "latin-1 bytes": (RIG_DOC.replace('"a1"', '"\udce9"'), "refuse"),
    "CRLF": (RIG_DOC.replace("\n", "\r\n"), "any"),
    "empty": ("", "refuse"),
    "a 20 MB comment": (RIG_DOC + "# " + "x" * 20_000_000 + "\n", "any"),
    "1,000 bodies, no springs": ("name = \"many\"\nforce_channel = 0\n" + "".join(
        f"[[bodies]]\nname = \"b{k}\"\nmass = 1.0\ninertia = [0.1, 0.1, 0.1]\n" for k in range(1000)), "any"),
}


def _rig_file(text: str) -> Callable[[Path, int], None]:
    def setup(d: Path, variant: int) -> None:
        data = text.encode("utf-8", "surrogateescape")
        (d / "bad.toml").write_bytes(data)
    return setup


def rig_cases() -> list[Case]:
    out = []
    for label, (text, expect) in RIGS.items():
        out.append(Case("rig files", f"new --rig: {label}", lambda d: ["new", "n.h5", "--rig", "bad.toml"], _rig_file(text),
                        expect=expect, outputs=("n.h5",), projects=(), check=_readable_after("n.h5"), timeout=60.0))
    # the rig as documented, then what a project on it is used for
    for label, argv in (("acquire", ["acquire", "n.h5", "--name", "s", "--samples", "512"]),
                        ("info --json", ["info", "n.h5", "--json"]), ("model --json", ["model", "n.h5", "--json"])):
        for rig in ("as documented", "one body, no springs", "mass 2000 (grams meant)", "sensor 900 m away",
                    "stiffness all zero"):
            out.append(Case("rig files", f"{label} on a rig {rig}", lambda d, a=tuple(argv): list(a),
                            _then_new(RIGS[rig][0]),
                            outputs=("n.h5",), projects=("n.h5",) if label != "acquire" else (),
                            check=_json_check if "--json" in argv else None, timeout=90.0))
    return out


def _then_new(text: str) -> Callable[[Path, int], None]:
    def setup(d: Path, variant: int) -> None:
        _rig_file(text)(d, variant)
        r = rt._run_setup(["new", "n.h5", "--rig", "bad.toml"], d)
        if r.returncode:
            (d / "n.h5").write_bytes(b"")  # the try then judges a command on an empty file
    return setup


# ----------------------------------------------------------------------------- projects altered with h5py

def _alter(fn: Callable[[h5py.File], None]) -> Callable[[Path, int], None]:
    def setup(d: Path, variant: int) -> None:
        with h5py.File(d / "p.h5", "a") as f:
            fn(f)
    return setup


def _replace(path: str, make: Callable[[h5py.Dataset], object], **kw) -> Callable[[h5py.File], None]:
    def fn(f: h5py.File) -> None:
        old = f[path]
        attrs = dict(old.attrs)
        value = make(old)
        del f[path]
        ds = f.create_dataset(path, data=value, **kw) if not callable(value) else value(f, path)
        for k, v in attrs.items():
            ds.attrs[k] = v
    return fn


def _set_attr(path: str, name: str, value) -> Callable[[h5py.File], None]:
    return lambda f: f[path].attrs.__setitem__(name, value)


def _del_attr(path: str, name: str) -> Callable[[h5py.File], None]:
    return lambda f: f[path].attrs.__delitem__(name)


def _cycle(f: h5py.File) -> None:
    f.copy("models/revisions/0", "models/revisions/1")
    f["models/revisions/1"].attrs["object_id"] = np.bytes_(b"0bf8645d-c24a-4b92-ab18-000000000001")
    f["models/revisions/0"].attrs["parent"] = 1
    f["models/revisions/1"].attrs["parent"] = 0
    f["models"].attrs["current_revision"] = 1


def _self_parent(f: h5py.File) -> None:
    f["models/revisions/0"].attrs["parent"] = 0


def _many_revisions(f: h5py.File) -> None:
    for k in range(1, 200):
        f.copy("models/revisions/0", f"models/revisions/{k}")
        f[f"models/revisions/{k}"].attrs["parent"] = k - 1
    f["models/revisions/0"].attrs["parent"] = 199
    f["models"].attrs["current_revision"] = 199


RAW = "experiments/s1/raw"
SHAPE = (2048, 11)
STORED_EDITS: dict[str, Callable[[h5py.File], None]] = {
    "raw as text": _replace(RAW, lambda o: np.array([["1.0"] * SHAPE[1]] * SHAPE[0], dtype="S8")),
    "raw as int8": _replace(RAW, lambda o: o[()].astype(np.int8)),
    "raw as complex": _replace(RAW, lambda o: o[()].astype(complex)),
    "raw as bool": _replace(RAW, lambda o: o[()] > 0),
    "raw as float16": _replace(RAW, lambda o: o[()].astype(np.float16)),
    "raw big-endian": _replace(RAW, lambda o: o[()].astype(">f8")),
    "raw compound": _replace(RAW, lambda o: np.zeros(SHAPE[0], dtype=[("a", "f8")] * 1)),
    "raw 1-D": _replace(RAW, lambda o: o[()][:, 0]),
    "raw 3-D": _replace(RAW, lambda o: o[()][:, :, None]),
    "raw scalar": _replace(RAW, lambda o: np.float64(1.0)),
    "raw empty (0 x 11)": _replace(RAW, lambda o: np.zeros((0, SHAPE[1]))),
    "raw 2048 x 10": _replace(RAW, lambda o: o[()][:, :10]),
    "raw with a NaN": _replace(RAW, lambda o: np.where(np.arange(SHAPE[0])[:, None] == 700, np.nan, o[()])),
    "raw with an inf": _replace(RAW, lambda o: np.where(np.arange(SHAPE[0])[:, None] == 700, np.inf, o[()])),
    "raw all 1e308": _replace(RAW, lambda o: np.full(SHAPE, 1e308)),
    "raw a null dataspace": _replace(RAW, lambda o: (lambda f, p: f.create_dataset(p, dtype="f8", data=h5py.Empty("f8")))),
    "raw 10^9 x 11 unallocated": _replace(RAW, lambda o: (lambda f, p: f.create_dataset(p, shape=(10**9, 11), dtype="f8",
                                                                                      chunks=(1024, 11)))),
    "raw 2^40 x 11 resizable": _replace(RAW, lambda o: (lambda f, p: f.create_dataset(p, shape=(2**40, 11), maxshape=(None, 11),
                                                                                    dtype="f8", chunks=(4096, 11)))),
    "raw a group": _replace(RAW, lambda o: (lambda f, p: f.create_group(p))),
    "raw a soft link to derived": lambda f: (f.__delitem__(RAW), f.__setitem__(RAW, h5py.SoftLink(
        "/experiments/s1/derived/processed/acceleration"))),
    "raw a soft link to itself": lambda f: (f.__delitem__(RAW), f.__setitem__(RAW, h5py.SoftLink("/" + RAW))),
    "raw a dangling soft link": lambda f: (f.__delitem__(RAW), f.__setitem__(RAW, h5py.SoftLink("/nowhere"))),
    "raw an external link to the project itself": lambda f: (f.copy(RAW, "experiments/s1/raw0"), f.__delitem__(RAW),
                                                           f.__setitem__(RAW, h5py.ExternalLink("p.h5", "experiments/s1/raw0"))),
    "experiment group missing its attributes": lambda f: [f["experiments/s1"].attrs.__delitem__(k)
                                                          for k in list(f["experiments/s1"].attrs)],
    "no sampling_rate": _del_attr("experiments/s1", "sampling_rate"),
    "no channel_names": _del_attr("experiments/s1", "channel_names"),
    "no force_channel": _del_attr("experiments/s1", "force_channel"),
    "no odsuite_type on the experiment": _del_attr("experiments/s1", "odsuite_type"),
    "sampling_rate a string": _set_attr("experiments/s1", "sampling_rate", "20000"),
    "sampling_rate bytes": _set_attr("experiments/s1", "sampling_rate", np.bytes_(b"20000")),
    "sampling_rate an array": _set_attr("experiments/s1", "sampling_rate", np.array([20000.0, 1.0])),
    "sampling_rate bool": _set_attr("experiments/s1", "sampling_rate", True),
    "sampling_rate complex": _set_attr("experiments/s1", "sampling_rate", 20000 + 1j),
    "sampling_rate int64 max": _set_attr("experiments/s1", "sampling_rate", np.int64(2**63 - 1)),
    "pretrigger a string": _set_attr("experiments/s1", "pretrigger", "512"),
    "pretrigger a float NaN": _set_attr("experiments/s1", "pretrigger", float("nan")),
    "pretrigger 2048.5": _set_attr("experiments/s1", "pretrigger", 2048.5),
    "force_channel a string": _set_attr("experiments/s1", "force_channel", "zero"),
    "force_channel NaN": _set_attr("experiments/s1", "force_channel", float("nan")),
    "force_point a string": _set_attr("experiments/s1", "force_point", "origin"),
    "force_point 2 numbers": _set_attr("experiments/s1", "force_point", np.array([0.0, 0.0])),
    "force_point NaN": _set_attr("experiments/s1", "force_point", np.array([np.nan, 0.0, 0.0])),
    "force_direction zero": _set_attr("experiments/s1", "force_direction", np.zeros(3)),
    "channel_names numbers": _set_attr("experiments/s1", "channel_names", np.arange(11)),
    "channel_names one string": _set_attr("experiments/s1", "channel_names", "force"),
    "channel_names with a newline": _set_attr("experiments/s1", "channel_names",
                                              np.array([b"force", b"a\nb"] + [f"c{k}".encode() for k in range(9)])),
    "channel_names undecodable": _set_attr("experiments/s1", "channel_names",
                                           np.array([b"force", b"\xff\xfe"] + [f"c{k}".encode() for k in range(9)])),
    "systeminfo channels of 3 rows": _replace("experiments/s1/systeminfo/channels", lambda o: o[()][:3]),
    "systeminfo sensitivity NaN": _replace("experiments/s1/systeminfo/channels",
                                           lambda o: (lambda a: (a.__setitem__("sensitivity", np.nan), a)[1])(o[()])),
    "systeminfo sensitivity 0": _replace("experiments/s1/systeminfo/channels",
                                         lambda o: (lambda a: (a.__setitem__("sensitivity", 0.0), a)[1])(o[()])),
    "systeminfo sensor_type 99": _replace("experiments/s1/systeminfo/channels",
                                          lambda o: (lambda a: (a.__setitem__("sensor_type", 99), a)[1])(o[()])),
    "systeminfo a float array": _replace("experiments/s1/systeminfo/channels", lambda o: np.zeros((11, 20))),
    "derived gencoords with NaN": _replace("experiments/s1/derived/gencoords/platform_at_g",
                                           lambda o: np.full(o.shape, np.nan)),
    "derived gencoords 5 columns": _replace("experiments/s1/derived/gencoords/platform_at_g", lambda o: o[()][:, :5]),
    "derived processed as text": _replace("experiments/s1/derived/processed/acceleration",
                                          lambda o: np.array([["x"] * 9] * 2048, dtype="S1")),
    "hammer_modes poles with NaN": _replace("experiments/s1/derived/hammer_modes/poles_real", lambda o: np.full(o.shape, np.nan)),
    "revision parents in a circle": _cycle,
    "revision its own parent": _self_parent,
    "200 revisions in a circle": _many_revisions,
    "current_revision 99": _set_attr("models", "current_revision", 99),
    "current_revision -1": _set_attr("models", "current_revision", -1),
    "current_revision a string": _set_attr("models", "current_revision", "0"),
    "current_revision NaN": _set_attr("models", "current_revision", float("nan")),
    "revision parent a string": _set_attr("models/revisions/0", "parent", "none"),
    "revision parent 10^30": _set_attr("models/revisions/0", "parent", 1e30),
    "revision named 'abc'": lambda f: f.move("models/revisions/0", "models/revisions/abc"),
    "no revisions": lambda f: f.__delitem__("models/revisions/0"),
    "revision metrics NaN error": _set_attr("models/revisions/0", "metrics", '{"error": NaN}'),
    "revision model nosuch": _set_attr("models/revisions/0", "model", "nosuch"),
    "revision model bytes 0xff": _set_attr("models/revisions/0", "model", np.bytes_(b"\xff")),
    "revision parameters huge": _set_attr("models/revisions/0", "parameters", '{"x": 1e999}'),
    "rig definition not JSON": _set_attr("rig", "definition", "{"),
    "rig definition a mass of -1": lambda f: f["rig"].attrs.__setitem__("definition", f["rig"].attrs["definition"].decode()
                                                                        .replace('"mass": ', '"mass": -1e9 * 0 + -', 1)),
    "rig missing": lambda f: f.__delitem__("rig"),
    "experiments a dataset": lambda f: (f.__delitem__("experiments"), f.__setitem__("experiments", np.zeros(3))),
    "file format version 99": _set_attr("/", "odsuite_format_version", "99.0.0"),
    "file format a number": _set_attr("/", "odsuite_format", 5),
    "an experiment named with an escape": lambda f: f.move("experiments/s1", "experiments/\x1b[31ms1"),
    "an experiment named '.hidden'": lambda f: f.move("experiments/s1", "experiments/.hidden"),
    "10,000 attributes on the experiment": lambda f: [f["experiments/s1"].attrs.__setitem__(f"a{k}", k) for k in range(10_000)],
}
STORED_COMMANDS = {
    "info --json": ["info", "p.h5", "--json"],
    "verify --json": ["verify", "p.h5", "--json"],
    "history --json": ["history", "p.h5", "--json"],
    "compare --json": ["compare", "p.h5", "--json"],
}
#: edits that only some commands reach, each with the commands that read it
STORED_MORE = {
    "process --json": ["process", "p.h5", "--json"],
    "ods --json": ["ods", "p.h5", "s1", "--reference", "zC", "--at", "100", "--json"],
}


def stored_cases() -> list[Case]:
    """Each edit under ``info --json`` and the one command that reads the edited object further."""
    out = []
    for label, fn in STORED_EDITS.items():
        if label.startswith(("raw", "systeminfo", "sampling", "channel_names", "force", "pretrigger", "no ")):
            second = STORED_MORE["process --json"]
        elif label.startswith(("revision", "current", "200", "no revisions")):
            second = STORED_COMMANDS["history --json"]
        elif label.startswith(("derived", "hammer")):
            second = ["modes", "p.h5", "--experiment", "s1", "--json"]
        else:
            second = STORED_COMMANDS["verify --json"]
        for argv in (STORED_COMMANDS["info --json"], second):
            out.append(Case("stored values", f"{' '.join(argv[:1] + argv[2:])}: {label}", lambda d, a=tuple(argv): list(a),
                            _alter(fn), check=_json_check, timeout=90.0, outputs=()))
    return out


# ----------------------------------------------------------------------------- commands and options

P = ["p.h5"]
COMMANDS: dict[str, tuple[list[str], str]] = {  # label -> (argv, expect)
    "info --json": (["info", "p.h5", "--json"], "any"),
    "info --json on a missing file": (["info", "none.h5", "--json"], "refuse"),
    "info --json on a text file": (["info", "home/notes.txt", "--json"], "refuse"),
    "info --json on an empty path": (["info", "", "--json"], "refuse"),
    "info --json on a folder": (["info", "home", "--json"], "refuse"),
    "info --json with an unknown option": (["info", "p.h5", "--json", "--bogus"], "refuse"),
    "info --json with no project": (["info", "--json"], "refuse"),
    "model --json": (["model", "p.h5", "--json"], "any"),
    "verify --json": (["verify", "p.h5", "--json"], "any"),
    "history --json": (["history", "p.h5", "--json"], "any"),
    "history --json --figure h.txt": (["history", "p.h5", "--json", "--figure", "h.txt"], "refuse"),
    "history --json --figure empty": (["history", "p.h5", "--json", "--figure", ""], "refuse"),
    "history --json --figure the project": (["history", "p.h5", "--json", "--figure", "p.h5"], "refuse"),
    "plugins --json": (["plugins", "--json"], "any"),
    "process --json": (["process", "p.h5", "--json"], "any"),
    "process --json --experiment nosuch": (["process", "p.h5", "--json", "--experiment", "nosuch"], "refuse"),
    "process --json --experiment empty": (["process", "p.h5", "--json", "--experiment", ""], "refuse"),
    "process --json --corrected --cutoff -1": (["process", "p.h5", "--json", "--corrected", "--cutoff=-1"], "refuse"),
    "process --json --corrected --cutoff 0": (["process", "p.h5", "--json", "--corrected", "--cutoff", "0"], "refuse"),
    "process --json --corrected --cutoff above Nyquist": (["process", "p.h5", "--json", "--corrected", "--cutoff", "15000"],
                                                          "refuse"),
    "process --json --corrected --cutoff inf": (["process", "p.h5", "--json", "--corrected", "--cutoff", "inf"], "refuse"),
    "process --json --corrected --cutoff text": (["process", "p.h5", "--json", "--corrected", "--cutoff", "low"], "refuse"),
    "compare --json": (["compare", "p.h5", "--json"], "any"),
    "compare --json on a project without experiments": (["compare", "q.h5", "--json"], "refuse"),
    "diagnose --json --workers 0": (["diagnose", "p.h5", "--json", "--workers", "0"], "refuse"),
    "diagnose --json --workers -1": (["diagnose", "p.h5", "--json", "--workers=-1"], "refuse"),
    "diagnose --json --workers 10^6": (["diagnose", "p.h5", "--json", "--workers", "1000000"], "refuse"),
    "diagnose --json --workers text": (["diagnose", "p.h5", "--json", "--workers", "many"], "refuse"),
    "diagnose --json --effect nosuch": (["diagnose", "p.h5", "--json", "--effect", "nosuch"], "refuse"),
    "diagnose --json --effect empty": (["diagnose", "p.h5", "--json", "--effect", ""], "refuse"),
    "diagnose --json on a project without experiments": (["diagnose", "q.h5", "--json"], "refuse"),
    "add-effect --json nosuch": (["add-effect", "p.h5", "nosuch", "--json"], "refuse"),
    "add-effect --json empty": (["add-effect", "p.h5", "", "--json"], "refuse"),
    "add-effect --json on a project without experiments": (["add-effect", "q.h5", "stiffness", "--json"], "refuse"),
    "modes --json --fmin -5": (["modes", "p.h5", "--experiment", "s1", "--json", "--fmin=-5"], "refuse"),
    "modes --json --fmin above --fmax": (["modes", "p.h5", "--experiment", "s1", "--json", "--fmin", "500", "--fmax", "100"],
                                         "refuse"),
    "modes --json band above Nyquist": (["modes", "p.h5", "--experiment", "s1", "--json", "--fmin", "50000", "--fmax", "60000"],
                                        "refuse"),
    "modes --json --fmax above Nyquist": (["modes", "p.h5", "--experiment", "s1", "--json", "--fmax", "1e9"], "refuse"),
    "modes --json --fmax nan": (["modes", "p.h5", "--experiment", "s1", "--json", "--fmax", "nan"], "refuse"),
    "modes --json --fmin = --fmax": (["modes", "p.h5", "--experiment", "s1", "--json", "--fmin", "100", "--fmax", "100"],
                                     "refuse"),
    "modes --json --max-order 0": (["modes", "p.h5", "--experiment", "s1", "--json", "--max-order", "0"], "refuse"),
    "modes --json --max-order -3": (["modes", "p.h5", "--experiment", "s1", "--json", "--max-order=-3"], "refuse"),
    "modes --json --max-order 10^9": (["modes", "p.h5", "--experiment", "s1", "--json", "--max-order", "1000000000"],
                                      "refuse"),
    "modes --json --experiment nosuch": (["modes", "p.h5", "--experiment", "nosuch", "--json"], "refuse"),
    "modes --json --at nosuch": (["modes", "p.h5", "--experiment", "s1", "--json", "--at", "nosuch"], "refuse"),
    "modes --json --output-only --block-rows 0": (["modes", "p.h5", "--experiment", "s1", "--output-only", "--json",
                                                   "--block-rows", "0"], "refuse"),
    "modes --json --output-only --block-rows -1": (["modes", "p.h5", "--experiment", "s1", "--output-only", "--json",
                                                    "--block-rows=-1"], "refuse"),
    "modes --json --output-only --decimate 0": (["modes", "p.h5", "--experiment", "s1", "--output-only", "--json",
                                                 "--decimate", "0"], "refuse"),
    "modes --json --output-only --decimate 10^6": (["modes", "p.h5", "--experiment", "s1", "--output-only", "--json",
                                                    "--decimate", "1000000"], "refuse"),
    "modes --json --output-only --reference nosuch": (["modes", "p.h5", "--experiment", "s1", "--output-only", "--json",
                                                       "--reference", "nosuch"], "refuse"),
    "modes --json --figure x.txt": (["modes", "p.h5", "--experiment", "s1", "--json", "--figure", "x.txt"], "refuse"),
    "modes --json --figure empty": (["modes", "p.h5", "--experiment", "s1", "--json", "--figure", ""], "refuse"),
    "modes --json --output-only on an operating record": (["modes", "p.h5", "--experiment", "s1", "--output-only", "--json"],
                                                          "any"),
    "frf --json --estimator nosuch": (["frf", "p.h5", "--experiment", "s1", "--json", "--estimator", "nosuch"], "refuse"),
    "frf --json --estimator empty": (["frf", "p.h5", "--experiment", "s1", "--json", "--estimator", ""], "refuse"),
    "ods --json": (["ods", "p.h5", "s1", "--reference", "zC", "--at", "100", "--json"], "any"),
    "ods --json without --reference": (["ods", "p.h5", "s1", "--at", "100", "--json"], "refuse"),
    "ods --json --at -5": (["ods", "p.h5", "s1", "--reference", "zC", "--at=-5", "--json"], "refuse"),
    "ods --json --at 0": (["ods", "p.h5", "s1", "--reference", "zC", "--at", "0", "--json"], "refuse"),
    "ods --json --at above Nyquist": (["ods", "p.h5", "s1", "--reference", "zC", "--at", "15000", "--json"], "refuse"),
    "ods --json --at 1e308": (["ods", "p.h5", "s1", "--reference", "zC", "--at", "1e308", "--json"], "refuse"),
    "ods --json --at nan": (["ods", "p.h5", "s1", "--reference", "zC", "--at", "nan", "--json"], "refuse"),
    "ods --json --at text": (["ods", "p.h5", "s1", "--reference", "zC", "--at", "high", "--json"], "refuse"),
    "ods --json --at empty": (["ods", "p.h5", "s1", "--reference", "zC", "--at", "", "--json"], "refuse"),
    "ods --json --reference the force": (["ods", "p.h5", "s1", "--reference", "force", "--at", "100", "--json"], "refuse"),
    "ods --json --reference empty": (["ods", "p.h5", "s1", "--reference", "", "--at", "100", "--json"], "refuse"),
    "ods --json experiment empty": (["ods", "p.h5", "", "--reference", "zC", "--at", "100", "--json"], "refuse"),
    "ods --json --movie x.txt": (["ods", "p.h5", "s1", "--reference", "zC", "--at", "100", "--movie", "x.txt", "--json"],
                                 "refuse"),
    "render --json --workers 0": (["render", "p.h5", "s1", "-o", "m.gif", "--workers", "0", "--json"], "refuse"),
    "render --json --fps 0": (["render", "p.h5", "s1", "-o", "m.gif", "--fps", "0", "--json"], "refuse"),
    "render --json --fps -1": (["render", "p.h5", "s1", "-o", "m.gif", "--fps=-1", "--json"], "refuse"),
    "render --json --fps nan": (["render", "p.h5", "s1", "-o", "m.gif", "--fps", "nan", "--json"], "refuse"),
    "render --json --frame-step 0": (["render", "p.h5", "s1", "-o", "m.gif", "--frame-step", "0", "--json"], "refuse"),
    "render --json --slowdown 0": (["render", "p.h5", "s1", "-o", "m.gif", "--slowdown", "0", "--json"], "refuse"),
    "render --json --slowdown -1": (["render", "p.h5", "s1", "-o", "m.gif", "--slowdown=-1", "--json"], "refuse"),
    "render --json --duration 0": (["render", "p.h5", "s1", "-o", "m.gif", "--duration", "0", "--json"], "refuse"),
    # a movie longer than the window plays every sample once: the longest the record gives
    "render --json --duration 1e9": (["render", "p.h5", "s1", "-o", "m.gif", "--duration", "1e9", "--json"], "any"),
    "render --json --start after --end": (["render", "p.h5", "s1", "-o", "m.gif", "--start", "0.05", "--end", "0.01",
                                           "--json"], "refuse"),
    "render --json --start -1": (["render", "p.h5", "s1", "-o", "m.gif", "--start=-1", "--json"], "refuse"),
    "render --json --start past the record": (["render", "p.h5", "s1", "-o", "m.gif", "--start", "100", "--json"], "refuse"),
    "render --json --magnify nan,1": (["render", "p.h5", "s1", "-o", "m.gif", "--magnify", "nan,1", "--json"], "refuse"),
    "render --json --view nosuch": (["render", "p.h5", "s1", "-o", "m.gif", "--view", "nosuch", "--json"], "refuse"),
    "render --json --renderer nosuch": (["render", "p.h5", "s1", "-o", "m.gif", "--renderer", "nosuch", "--json"], "refuse"),
    "render --json --mode 0": (["render", "p.h5", "s1", "-o", "m.gif", "--mode", "0", "--json"], "refuse"),
    "render --json --mode -1": (["render", "p.h5", "s1", "-o", "m.gif", "--mode=-1", "--json"], "refuse"),
    "render --json --mode 999": (["render", "p.h5", "s1", "-o", "m.gif", "--mode", "999", "--json"], "refuse"),
    "render --json --ods -5": (["render", "p.h5", "s1", "-o", "m.gif", "--ods=-5", "--reference", "zC", "--json"], "refuse"),
    "render --json --ods above Nyquist": (["render", "p.h5", "s1", "-o", "m.gif", "--ods", "15000", "--reference", "zC",
                                          "--json"], "refuse"),
    "render --json -o x.txt": (["render", "p.h5", "s1", "-o", "x.txt", "--json"], "refuse"),
    "render --json -o empty": (["render", "p.h5", "s1", "-o", "", "--json"], "refuse"),
    "render --json experiment nosuch": (["render", "p.h5", "nosuch", "-o", "m.gif", "--json"], "refuse"),
    "report --json -o the project": (["report", "p.h5", "-o", "p.h5", "--json"], "refuse"),
    "report --json -o x.txt": (["report", "p.h5", "-o", "x.txt", "--json"], "refuse"),
    "report --json --frf-channel nosuch": (["report", "p.h5", "-o", "r.html", "--frf-channel", "nosuch", "--no-movie",
                                            "--no-diagnose", "--json"], "refuse"),
    "report --json --movie-experiment nosuch": (["report", "p.h5", "-o", "r.html", "--movie-experiment", "nosuch",
                                                 "--no-diagnose", "--json"], "refuse"),
    "report --json --diagnosis missing": (["report", "p.h5", "-o", "r.html", "--diagnosis", "none.json", "--json"], "refuse"),
    "catalog --json": (["catalog", ".", "--json"], "any"),
    "catalog --json of a missing folder": (["catalog", "nowhere", "--json"], "refuse"),
    "catalog --json of a file": (["catalog", "p.h5", "--json"], "refuse"),
    "catalog --json of an empty path": (["catalog", "", "--json"], "refuse"),
    "catalog query --json": (["catalog", "query", ".", "projects", "--json"], "any"),
    "catalog query --json a SELECT": (["catalog", "query", ".", "SELECT 1 AS one", "--json"], "any"),
    "catalog query --json of an empty folder name": (["catalog", "query", "", "--json"], "refuse"),
    "catalog query --json --limit 0": (["catalog", "query", ".", "projects", "--json", "--limit", "0"], "refuse"),
    "catalog query --json --limit -1": (["catalog", "query", ".", "projects", "--json", "--limit=-1"], "refuse"),
    "catalog query --json --seconds 0": (["catalog", "query", ".", "projects", "--json", "--seconds", "0"], "any"),
    "catalog query --json --seconds -1": (["catalog", "query", ".", "projects", "--json", "--seconds=-1"], "refuse"),
    "catalog query --json --seconds nan": (["catalog", "query", ".", "projects", "--json", "--seconds", "nan"], "refuse"),
    "catalog query --json a write": (["catalog", "query", ".", "DELETE FROM projects", "--json"], "refuse"),
    "catalog query --json three arguments": (["catalog", "query", ".", "projects", "x", "--json"], "refuse"),
    "catalog --json nosuch subcommand": (["catalog", "nosuch", ".", "--json"], "refuse"),
    "batch --json info": (["batch", "info", "a.h5", "b.h5", "--json"], "any"),
    "batch --json --workers 0": (["batch", "info", "a.h5", "--json", "--workers", "0"], "refuse"),
    "batch --json --workers -1": (["batch", "info", "a.h5", "--json", "--workers=-1"], "refuse"),
    "batch --json nosuch command": (["batch", "nosuch", "a.h5", "--json"], "refuse"),
    "batch --json no projects": (["batch", "info", "--json"], "refuse"),
    "batch --json a missing project": (["batch", "info", "none.h5", "--json"], "any"),
    "batch --json --scheduler empty": (["batch", "info", "a.h5", "--json", "--scheduler", ""], "refuse"),
    "batch --json one project twice": (["batch", "info", "a.h5", "a.h5", "--json"], "any"),
    "new --rig empty": (["new", "n.h5", "--rig", ""], "refuse"),
    "new over an existing project": (["new", "p.h5"], "refuse"),
    "new at an empty path": (["new", ""], "refuse"),
    "new in a missing folder": (["new", "none/n.h5"], "refuse"),
    "new named .h5 only": (["new", ".h5"], "any"),
    "new without .h5": (["new", "n"], "any"),
    "export-uff --nodes 3": (["export-uff", "p.h5", "s1", "-o", "o.uff", "--nodes", "3"], "refuse"),
    "export-legacy --at nosuch": (["export-legacy", "p.h5", "s1", "--cod", "o.cod", "--at", "nosuch"], "refuse"),
    "revert to 99": (["revert", "p.h5", "99"], "refuse"),
    "revert to -1": (["revert", "p.h5", "--", "-1"], "refuse"),
    "acquire --samples 1": (["acquire", "p.h5", "--name", "x", "--samples", "1"], "refuse"),
    "acquire --pretrigger above --samples": (["acquire", "p.h5", "--name", "x", "--samples", "512", "--pretrigger", "600"],
                                             "refuse"),
    "acquire --pretrigger -1": (["acquire", "p.h5", "--name", "x", "--samples", "512", "--pretrigger=-1"], "refuse"),
    "acquire --name empty": (["acquire", "p.h5", "--name", "", "--samples", "512"], "refuse"),
    "acquire --trigger-timeout -1": (["acquire", "p.h5", "--name", "x", "--samples", "512", "--trigger-timeout=-1"], "refuse"),
}


def command_cases() -> list[Case]:
    out = []
    for label, (argv, expect) in COMMANDS.items():
        outputs = ("m.gif", "r.html", "x.txt", "h.txt", "o.uff", "o.cod", "n.h5", "n", ".h5", "odsuite-catalog.*")
        # a command that writes the project: the project is its output when it succeeds, untouched when refused
        writes = argv[0] in ("new", "acquire", "process", "revert") and expect != "refuse"
        projects = ("p.h5", "a.h5", "b.h5", "q.h5") if not writes else ()
        outputs += ("p.h5",) if writes else ()
        query = argv[:2] == ["catalog", "query"]
        out.append(Case("commands", label, lambda d, a=tuple(argv): list(a), _catalogued if query else None,
                        expect=expect, outputs=outputs, projects=projects,
                        check=(_query_json if query else _json_check) if "--json" in argv else None, timeout=120.0))
    return out


GROUPS: dict[str, Callable[[], list[Case]]] = {
    "csv": csv_cases, "npy": npy_cases, "mat": mat_cases, "tdms": tdms_cases, "other": other_import_cases,
    "rig": rig_cases, "stored": stored_cases, "commands": command_cases,
}


def all_cases(only: str | None = None) -> list[Case]:
    return rt.selected(GROUPS, only)


def main(argv: list[str] | None = None) -> int:
    return rt.command_line("redteam5", __doc__, GROUPS, argv, failures=FAILURES, timeout=60.0, prepare=prepare)


if __name__ == "__main__":
    sys.exit(main())
