"""Red team, round four: new hostile tries on what round three left open (issue 33), run by the
round-three harness (``redteam3.run``: a real ``odsuite`` subprocess per try, in a folder of its own,
with a time limit, judged from the outside).

Groups: objects of a project under several names (hard links); ``report --diagnosis`` files that
are devices, pipes, huge or deeply nested; ``.lvm`` rows too long and numbers LabVIEW never
writes; plugins that never finish importing or registering, and bad time bounds; rig files with
extreme values in every numeric field; stored values changed by hand; 1,000- and 4,000-sensor rigs.

``python -m tests.reliability.redteam4 --out DIR [--only GROUP] [--timeout S] [--jobs N]`` prints
the table by group and outcome and writes ``DIR/redteam4.json``.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np

from tests.reliability import redteam3 as rt
from tests.reliability.redteam3 import Case

# ----------------------------------------------------------------------------- hard links

#: where a second name of an existing object is planted: (label, object, new name)
LINK_SPOTS = {
    "experiment group": ("experiments/s1", "experiments/s1-again"),
    "raw dataset": ("experiments/s1/raw", "experiments/s1/raw-again"),
    "raw into another experiment": ("experiments/s1/raw", "rig/raw"),
    "rig group": ("rig", "rig-again"),
    "models group": ("models", "experiments/models"),
    "revision 0": ("models/revisions/0", "models/revisions/1"),
    "derived group": ("experiments/s1/derived", "experiments/s1/derived-again"),
    "systeminfo": ("experiments/s1/systeminfo", "systeminfo"),
    "3,000 names of the experiment": ("experiments/s1", None),
    "300 names of raw in one group": ("experiments/s1/raw", "experiments/s1/r{k}"),
}
LINK_COMMANDS = {"info": ["info", "p.h5"], "verify": ["verify", "p.h5"], "history": ["history", "p.h5"],
                 "export-uff": ["export-uff", "p.h5", "s1", "-o", "o.uff"], "catalog": ["catalog", "."]}


def _hard_links(spot: str) -> Callable[[Path, int], None]:
    obj, name = LINK_SPOTS[spot]

    def setup(d: Path, variant: int) -> None:
        with h5py.File(d / "p.h5", "a") as f:
            target = f[obj]
            if name is None:
                for k in range(3000):
                    f[f"experiments/e{k:04d}"] = target
            elif "{k}" in name:
                for k in range(300):
                    f[name.format(k=k)] = target
            else:
                f[name] = target
    return setup


def hardlink_cases() -> list[Case]:
    # the catalogue lists a project it cannot read with its error and goes on (exit 0): judged by the check
    return [Case("hard links", f"{c}: {spot}", lambda d, a=argv: list(a), _hard_links(spot),
                 expect="refuse" if c != "catalog" else "any",
                 outputs=("o.uff", "odsuite-catalog.*"), timeout=60.0,
                 check=None if c != "catalog" else _listed_with_error)
            for spot in LINK_SPOTS for c, argv in LINK_COMMANDS.items()]


def _listed_with_error(d: Path, r: dict) -> list[tuple[str, str]]:
    """The catalogue lists the project with its one-line error instead of indexing it."""
    import sqlite3

    try:
        with sqlite3.connect(f"file:{d / 'odsuite-catalog.sqlite'}?mode=ro", uri=True) as db:
            err = dict(db.execute("SELECT project, read_error FROM projects").fetchall()).get("p.h5")
    except sqlite3.Error as exc:
        return [("changed project", f"no catalogue: {exc}")]
    return [] if err and "names the same object" in err else [("wrong success", f"p.h5 indexed: {err!r}")]


# ----------------------------------------------------------------------------- report --diagnosis

def _deep_array(n: int) -> str:
    return "[" * n + "]" * n


DIAGNOSIS: dict[str, Callable[[Path], str]] = {}


def _diag(label: str, make: Callable[[Path], str]) -> None:
    DIAGNOSIS[label] = make


def _file(content: bytes | str) -> Callable[[Path], str]:
    def make(d: Path) -> str:
        (d / "diag.json").write_bytes(content if isinstance(content, bytes) else content.encode())
        return "diag.json"
    return make


for dev in ("/dev/zero", "/dev/urandom", "/dev/null", "/dev/full", "/dev/tty", "/dev/stdin"):
    _diag(f"the device {dev}", lambda d, dev=dev: dev)
    _diag(f"a link to {dev}", lambda d, dev=dev: (os.symlink(dev, d / "diag.json"), "diag.json")[1])
_diag("a FIFO", lambda d: (os.mkfifo(d / "diag.json"), "diag.json")[1])
_diag("a link to a FIFO", lambda d: (os.mkfifo(d / "pipe"), os.symlink(d / "pipe", d / "diag.json"), "diag.json")[2])
_diag("a folder", lambda d: ((d / "diag.json").mkdir(), "diag.json")[1])
_diag("a dangling link", lambda d: (os.symlink(d / "none", d / "diag.json"), "diag.json")[1])
_diag("a missing file", lambda d: "none.json")
_diag("a socket", lambda d: (__import__("socket").socket(__import__("socket").AF_UNIX).bind(str(d / "diag.json")),
                             "diag.json")[1])
_diag("an unreadable file", lambda d: (_file("{}")(d), (d / "diag.json").chmod(0), "diag.json")[2])
for depth in (100, 1_000, 10_000, 100_000, 1_000_000):
    _diag(f"arrays nested {depth:,} deep", _file(_deep_array(depth)))
    _diag(f"objects nested {depth:,} deep", _file('{"a":' * depth + "1" + "}" * depth))
_diag("candidates nested 100,000 deep", _file('{"candidates": ' + _deep_array(100_000) + "}"))
for size in (17 * 2**20, 64 * 2**20):  # the harness hashes every file: no GiB files
    _diag(f"a sparse file of {size / 2**20:,.0f} MiB",
          lambda d, size=size: ((d / "diag.json").touch(), os.truncate(d / "diag.json", size), "diag.json")[2])
_diag("16 MiB of spaces then {}", _file(" " * (16 * 2**20 - 10) + "{}"))
for label, text in {"a number": "5", "a string": '"x"', "null": "null", "true": "true", "a list": "[1]",
                    "candidates a string": '{"candidates": "x"}', "candidates null": '{"candidates": null}',
                    "candidates of lists": '{"candidates": [[1]]}', "effect a list": '{"candidates": [{"effect": [1]}]}',
                    "effect null": '{"candidates": [{"effect": null}]}', "UTF-16": '{"candidates": []}'.encode("utf-16"),
                    "latin-1 bytes": b'{"candidates": "\xe9"}', "a NUL byte": b'{"candidates"\x00: []}',
                    "a UTF-8 BOM": b"\xef\xbb\xbf" + b'{"candidates": 1}', "NaN at the top": "NaN",
                    "a huge integer": "1" * 100_000, "10,000 keys": "{" + ",".join(f'"k{k}": 1' for k in range(10_000)) + "}",
                    "trailing garbage": '{"candidates": 1} x', "empty": "", "only spaces": "   "}.items():
    _diag(label, _file(text))


def diagnosis_cases() -> list[Case]:
    return [Case("report --diagnosis", f"report --diagnosis: {label}", lambda d, m=make: [
        "report", "p.h5", "-o", "r.html", "--diagnosis", m(d), "--no-movie"], expect="refuse", outputs=("r.html",),
        timeout=60.0) for label, make in DIAGNOSIS.items()]


# ----------------------------------------------------------------------------- .lvm

def _rows_with(first: str) -> list[str]:
    return [first] + rt.GOOD_ROWS[1:]


LVM: dict[str, tuple[str, str]] = {}  # label -> (text, expect)
for cell in ("1_000", "1_0.5", "_1", "1_", "1__0", "1e1_0", "0x1_0", "1_000.000_1", "-1_0", "+1_0", "nan_", "in_f"):
    LVM[f"value {cell!r}"] = (rt.lvm_text(_rows_with(f"{cell}\t0.0")), "refuse")
    LVM[f"value {cell!r} in the second column"] = (rt.lvm_text(_rows_with(f"0.0\t{cell}")), "refuse")
for field, good in (("Delta_X", "1.0E-4\t1.0E-4"), ("X0", "0.0E+0\t0.0E+0")):
    for cell in ("1_0E-4", "1.0_E-4", "_1.0E-4"):
        text = rt.lvm_text(rt.GOOD_ROWS).replace(f"{field}\t{good}", f"{field}\t{cell}\t{cell}")
        LVM[f"{field} {cell!r}"] = (text, "refuse")
for cells in (4, 5, 10, 100, 10_000, 100_000, 1_000_000):
    # cells with the empty X column first; the fourth is the Comment column, which LabVIEW may fill
    expect = "any" if cells == 4 else "refuse"
    LVM[f"a first row of {cells:,} cells"] = (rt.lvm_text(_rows_with("\t".join(["0.5"] * (cells - 1)))), expect)
    LVM[f"a last row of {cells:,} cells"] = (rt.lvm_text(rt.GOOD_ROWS[:-1] + ["\t".join(["0.5"] * (cells - 1))]), expect)
LVM["a row of 1,000,000 separators"] = (rt.lvm_text(_rows_with("0.5\t0.5" + "\t" * 1_000_000)), "refuse")
LVM["a row of 3 cells, text comment"] = (rt.lvm_text(_rows_with("0.5\t0.5\tmy comment")), "any")
LVM["every row one cell too many"] = (rt.lvm_text([r + "\t1.0\t2.0" for r in rt.GOOD_ROWS]), "refuse")
for cell in ("1e999", "-1e999", "inf", "Infinity", "nan", "0x10", "1,0", "1.0.0", "1e", "--1", "\u00bd", "\x00", "1 000",
             "\x1b[31m1", "\u202e1", "1" * 10_000, "0." + "0" * 10_000 + "1"):
    LVM[f"value {cell[:20]!r}"] = (rt.lvm_text(_rows_with(f"{cell}\t0.0")), "any")
for n in (0, 1, 2, 3, 5000):
    LVM[f"Channels {n}"] = (rt.lvm_text(rt.GOOD_ROWS).replace("Channels\t2", f"Channels\t{n}"), "any")
for sep in ("Comma", "Semicolon", "Space", "Pipe", "", "Tab\x00"):
    LVM[f"Separator {sep!r}"] = (rt.lvm_text(rt.GOOD_ROWS).replace("Separator\tTab", f"Separator\t{sep}"), "any")
for dec in (",", "", "_", "e", "1"):
    LVM[f"Decimal_Separator {dec!r}"] = (rt.lvm_text(rt.GOOD_ROWS).replace("Decimal_Separator\t.", f"Decimal_Separator\t{dec}"), "any")
for xc in ("One", "Multi", "Two", ""):
    LVM[f"X_Columns {xc!r}"] = (rt.lvm_text(rt.GOOD_ROWS).replace("X_Columns\tNo", f"X_Columns\t{xc}"), "any")
LVM["no end of header"] = (rt.lvm_text(rt.GOOD_ROWS).replace("***End_of_Header***", "***End***"), "refuse")
LVM["only the first line"] = ("LabVIEW Measurement\t\n", "refuse")
LVM["10,000 segments"] = (rt.lvm_text(rt.GOOD_ROWS) + "".join(
    rt.lvm_text(rt.GOOD_ROWS[:2]).split("***End_of_Header***\t\n\t\n", 1)[1] for _ in range(10_000)), "any")


def lvm_cases() -> list[Case]:
    return [Case("lvm", f"import-lvm: {label}", lambda d: ["import-lvm", "p.h5", "bad.lvm", "--name", "l"],
                 rt._write("bad.lvm", text), expect=expect, timeout=60.0) for label, (text, expect) in LVM.items()]


# ----------------------------------------------------------------------------- plugins

ENDLESS = {
    "loops at import": "while True:\n    pass\n",
    "sleeps at import": "import time\ntime.sleep(10_000)\n",
    "swallows exceptions while looping": "while True:\n    try:\n        pass\n    except Exception:\n        pass\n",
    "sleeps and swallows exceptions": "import time\nwhile True:\n    try:\n        time.sleep(100)\n    except Exception:\n        pass\n",
    "waits on a lock": "import threading\nlock = threading.Lock()\nlock.acquire()\nlock.acquire()\n",
    "waits on an event": "import threading\nthreading.Event().wait()\n",
    "reads a FIFO at import": "import os\nos.mkfifo('plugin-pipe')\nopen('plugin-pipe').read()\n",
    "recurses for ever": "import sys\nsys.setrecursionlimit(10**6)\ndef f(n):\n    return f(n + 1)\nf(0)\n",
    "loops in its hook": "from odsuite import hookimpl\n@hookimpl\ndef odsuite_register_effects(registry):\n"
                         "    while True:\n        pass\n",
    "sleeps in its hook": "from odsuite import hookimpl\nimport time\n@hookimpl\ndef odsuite_register_models(registry):\n"
                          "    time.sleep(10_000)\n",
    "loops in its rigs hook": "from odsuite import hookimpl\n@hookimpl\ndef odsuite_register_rigs(registry):\n"
                              "    while True:\n        pass\n",
    "builds a huge list at import": "x = []\nwhile True:\n    x.append(0)\n    if len(x) > 10**7:\n        x.clear()\n",
}


def _endless(kind: str) -> Callable[[Path, int], None]:
    def setup(d: Path, variant: int) -> None:
        rt.PLUGIN_BODIES.setdefault(kind, ENDLESS[kind])
        rt._plugin(kind)(d, variant)
    return setup


def plugin_cases() -> list[Case]:
    out = []
    for kind in ENDLESS:
        for label, argv in (("plugins", ["plugins"]), ("plugins --json", ["plugins", "--json"]),
                            ("info", ["info", "p.h5"]), ("--version", ["--version"])):
            out.append(Case("plugins", f"{label}: a plugin that {kind} (bound 1 s)", lambda d, a=argv: list(a),
                            _endless(kind), env={"PYTHONPATH": "site", "ODSUITE_PLUGIN_TIMEOUT": "1"}, timeout=60.0))
    for kind in ("loops at import", "loops in its hook"):
        out.append(Case("plugins", f"info: a plugin that {kind} (default bound)", lambda d: ["info", "p.h5"],
                        _endless(kind), env={"PYTHONPATH": "site"}, timeout=90.0))
    for value in ("abc", "-1", "nan", "inf", "1e9", "", " ", "0x10", "\x1b[31m", "3601"):
        out.append(Case("plugins", f"info with ODSUITE_PLUGIN_TIMEOUT={value!r}", lambda d: ["info", "p.h5"],
                        env={"ODSUITE_PLUGIN_TIMEOUT": value}, timeout=60.0))
    return out


# ----------------------------------------------------------------------------- rig files

RIG_FIELDS = {"mass": "mass", "inertia": "inertia", "position": "position", "stiffness": "stiffness"}
RIG_VALUES = ("nan", "inf", "-inf", "1e308", "-1.0", "0.0", '"x"', "[]", "true", "1e-320", "[nan, 0, 0]",
              "[1e308, 1e308, 1e308]", "[-1.0, 0.0, 0.0]", "{ a = 1 }")
RIG_EXTRA = {
    "sensitivity": ('sensitivity = 0.01', ("nan", "0.0", "-0.01", "1e308", "1e-320", '"x"')),
    "channel": ("channel = 1", ("-1", "0", "4096", "1e3", '"1"', "1.5", "99999999999999999999")),
    "axis": ("axis = [0.0, 0.0, 1.0]", ("[0, 0, 0]", "[nan, 0, 1]", "[1, 1, 1]", "[0, 0]", "[0, 0, 1, 0]", '"z"')),
    "plate size": ("size = [0.2, 0.2, 0.02]", ("[0, 0, 0]", "[-1, 1, 1]", "[1e308, 1, 1]", "[nan, 1, 1]")),
    "force_channel": ("force_channel = 0", ("-1", "1", "1e9", '"0"')),
    "damping": ("damping = [1.0, 1.0, 1.0]", ("[nan, 1, 1]", "[-1, 1, 1]", "[1e308, 1, 1]", "1")),
}


def rig_cases() -> list[Case]:
    out = []
    for f, key in RIG_FIELDS.items():
        for v in RIG_VALUES:
            out.append(Case("rig files", f"new --rig: {f} = {v}", lambda d: ["new", "q.h5", "--rig", "bad.toml"],
                            rt._write("bad.toml", rt.rig_text(**{key: v})), outputs=("q.h5",), projects=()))
    for f, (good, values) in RIG_EXTRA.items():
        for v in values:
            text = rt.rig_text().replace(good, good.split(" = ")[0] + " = " + v)
            out.append(Case("rig files", f"new --rig: {f} = {v}", lambda d: ["new", "q.h5", "--rig", "bad.toml"],
                            rt._write("bad.toml", text), expect="refuse", outputs=("q.h5",), projects=()))
    return out


# ----------------------------------------------------------------------------- stored values

STORED = {
    "experiment attribute sampling_rate": [-1.0, 1e308, float("inf"), "abc", [1, 2]],
    "experiment attribute force_channel": [-1, 11, 2**40, 1.5, "0"],
    "experiment attribute pretrigger": [-1, 10**12, 1.5, "x"],
    "revision attribute metrics": ['{"error": 1e999}', '{"error": [1]}', "null", '"x"', "[" * 10_000 + "]" * 10_000],
    "revision attribute effects": ["null", '[{"name": 5}]', '[{"effect": "stiffness"}]', "[" * 10_000 + "]" * 10_000],
    "rig attribute definition": ["[]", "null", '{"name": 5}', "[" * 10_000 + "]" * 10_000, '{"bodies": 5}'],
    "file attribute odsuite_format_version": ["0.0.0", "abc", "1.1.0 ", "9" * 1000],
}


def _stored(where: str, value) -> Callable[[Path, int], None]:
    def setup(d: Path, variant: int) -> None:
        with h5py.File(d / "p.h5", "a") as f:
            obj = {"experiment": f["experiments/s1"], "revision": f["models/revisions/0"], "rig": f["rig"],
                   "file": f}[where.split()[0]]
            name = where.split()[-1]
            obj.attrs[name] = np.array(value) if isinstance(value, list) else value
    return setup


def stored_cases() -> list[Case]:
    out = []
    for where, values in STORED.items():
        for v in values:
            for c in ("info", "verify"):
                out.append(Case("stored values", f"{c}: {where} = {str(v)[:30]!r}", lambda d, c=c: [c, "p.h5"],
                                _stored(where, v), timeout=60.0))
    return out


# ----------------------------------------------------------------------------- scale

def scale_cases() -> list[Case]:
    out = []
    for n in (1000, 4000):
        text = rt._sensors_rig(n).replace("force_channel = 0", f"force_channel = 0\nchannel_count = {n + 1}")
        out.append(Case("scale", f"new on a {n}-sensor rig", lambda d: ["new", "q.h5", "--rig", "big.toml"],
                        rt._write("big.toml", text), outputs=("q.h5",), projects=(), timeout=120.0))
        out.append(Case("scale", f"acquire 256 samples on a {n}-sensor rig", lambda d: [
            "acquire", "q.h5", "--name", "s", "--samples", "256", "--pretrigger", "32"],
            rt._then_new(rt._write("big.toml", text), "big.toml"), outputs=("q.h5",), projects=(), timeout=180.0))
    return out


GROUPS: dict[str, Callable[[], list[Case]]] = {
    "hardlinks": hardlink_cases, "diagnosis": diagnosis_cases, "lvm": lvm_cases, "plugins": plugin_cases,
    "rig": rig_cases, "stored": stored_cases, "scale": scale_cases,
}


def all_cases(only: str | None = None) -> list[Case]:
    return rt.selected(GROUPS, only)


def main(argv: list[str] | None = None) -> int:
    return rt.command_line("redteam4", __doc__, GROUPS, argv)


if __name__ == "__main__":
    sys.exit(main())
