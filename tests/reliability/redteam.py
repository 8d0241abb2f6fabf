"""Red team: hostile names, paths, numbers and damaged files across every command and file format,
each run through ``odsuite.cli.main`` in this process.

A try fails when ``main`` raises (a traceback), runs longer than ``try_limit()`` (a hang), exits 1
without exactly one ``error:`` line on stderr, or exits non-zero after changing any file of its
folder (the project, its inputs, anything else); and, whatever its exit code, when it changed a
link or a user's file planted at one of the project's sidecar names, or left a lock file or working
copy behind. Exit 2 is a usage error (typer's own message). Every writing command also meets its
lock file name taken (by a link, a dangling link, a user's file, a dead writer's lock), a working-copy
name taken, the project reached through a link or with a second hard link, the lock held by another
writer, and a disk with 0 to 2 MB free.

``python tests/reliability/redteam.py [DIR]`` runs every try and prints the counts.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import random
import shutil
import signal
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from tests.reliability.harness import TABLE_E3, legacy_volts  # noqa: E402
from tests.reliability.test_bad_input import CTR_TEXT, LVM_TEXT, RIG_TOML, dat_text  # noqa: E402

TRY_TIMEOUT = 60  # s on an idle machine; a try still running then is a hang (the longest take ~10 s)


def try_limit() -> int:
    """``TRY_TIMEOUT`` stretched by the load per core: on a machine shared by 20 runnable processes
    a 120-frame render took 65 s (11 s of CPU). A blocked try (a pipe read) outlasts any limit."""
    per_core = os.getloadavg()[0] / (os.cpu_count() or 1) if hasattr(os, "getloadavg") else 1.0
    return int(TRY_TIMEOUT * max(1.0, per_core))

NAMES = ["[/x]", "[red]", "x\udcff", "a\nb", "\x1b[31mred", "", " ", ".hidden", "a/b", "é²Ω", "x" * 5000, "-",
         "nan", "e1\t"]
NUMBERS = ["0", "-1", "nan", "inf", "-inf", "1e308", "1e-300", "9223372036854775808", "abc", "1e10", "0.5", ""]
PROJECT_PATHS = ["none.h5", ".", "/dev/zero", "pipe.h5", "notes.h5", "empty.h5", "[/x].h5", "x\udcff.h5",
                 "loop.h5", "inputs.DAT"]


@dataclass
class Try:
    label: str
    argv: list[str]
    code: int | None = None
    problems: list[str] = field(default_factory=list)


class _Hang(BaseException):
    pass


def _alarm(signum, frame):
    raise _Hang()


def prepare(work: Path) -> Path:
    """A project with a legacy import e1 and a simulated record s1, and input files
    good and damaged; returns the master folder, copied for every try."""
    from odsuite.cli import main

    master = work / "master"
    master.mkdir(parents=True)
    (master / "good.DAT").write_text(dat_text(legacy_volts()))
    (master / "good.CTR").write_text(CTR_TEXT)
    (master / "good.lvm").write_text(LVM_TEXT)
    (master / "rig.toml").write_text(RIG_TOML)
    (master / "notes.h5").write_text("notes\n")
    (master / "empty.h5").write_bytes(b"")
    (master / "inputs.DAT").write_text("1 2 3\n")
    p = str(master / "p.h5")
    for argv in (["new", p], ["import-legacy", p, str(master / "good.DAT"), "--systeminfo", str(TABLE_E3),
                              "--name", "e1", "--force-point", "0,4.122,-11.399", "--force-dir", "+z"],
                 ["acquire", p, "--name", "s1", "--samples", "2048", "--pretrigger", "256"]):
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            if main(argv) != 0:
                raise RuntimeError(f"odsuite {' '.join(argv)} failed")
    from odsuite_plugins.importers.uff import time_function, write_uff

    volts = legacy_volts()
    write_uff(master / "good.uff", overwrite=True, functions=[
        time_function("force" if k == 0 else f"ch{k}", volts[:, k], 1 / 20_000.0, "N" if k == 0 else "m/s^2")
        for k in range(volts.shape[1])])
    return master


def _damaged(rng: random.Random, good: bytes) -> bytes:
    """One of: cut at a random byte, a random byte changed, a line duplicated or dropped."""
    kind = rng.randrange(4)
    if kind == 0:
        return good[: rng.randrange(len(good))]
    if kind == 1:
        i = rng.randrange(len(good))
        return good[:i] + bytes([rng.randrange(256)]) + good[i + 1:]
    lines = good.splitlines(keepends=True)
    i = rng.randrange(len(lines))
    return b"".join(lines[:i] + ([lines[i]] * 2 if kind == 2 else []) + lines[i + 1:])


def tries(rng: random.Random) -> list[tuple[str, Callable[[Path], list[str]], dict[str, bytes]]]:
    """(label, argv builder on the try's folder, files to write there first)."""
    out: list[tuple[str, Callable[[Path], list[str]], dict[str, bytes]]] = []
    legacy = ["--force-point", "0,4.122,-11.399", "--force-dir", "+z"]

    def add(label, argv, files=None):
        out.append((label, argv, files or {}))

    for name in NAMES:  # names everywhere a name goes
        add(f"acquire --name {name!r}", lambda d, n=name: ["acquire", str(d / "p.h5"), "--name", n, "--samples", "1024", "--pretrigger", "100"])
        add(f"import-legacy --name {name!r}", lambda d, n=name: ["import-legacy", str(d / "p.h5"), str(d / "good.DAT"), "--systeminfo", str(d / "good.CTR"), "--name", n, *legacy])
        add(f"import-lvm --name {name!r}", lambda d, n=name: ["import-lvm", str(d / "p.h5"), str(d / "good.lvm"), "--name", n])
        add(f"import-uff --name {name!r}", lambda d, n=name: ["import-uff", str(d / "p.h5"), str(d / "good.uff"), "--name", n, "--force-channel", "force"])
        add(f"process --experiment {name!r}", lambda d, n=name: ["process", str(d / "p.h5"), "--experiment", n])
        add(f"frf --experiment {name!r}", lambda d, n=name: ["frf", str(d / "p.h5"), "--experiment", n])
        add(f"modes --experiment {name!r}", lambda d, n=name: ["modes", str(d / "p.h5"), "--experiment", n])
        add(f"render {name!r}", lambda d, n=name: ["render", str(d / "p.h5"), n, "-o", str(d / "m.gif")])
        add(f"export-legacy {name!r}", lambda d, n=name: ["export-legacy", str(d / "p.h5"), n, "--cod", str(d / "o.COD")])
        add(f"export-uff {name!r}", lambda d, n=name: ["export-uff", str(d / "p.h5"), n, "-o", str(d / "o.uff")])
        add(f"new --rig {name!r}", lambda d, n=name: ["new", str(d / "q.h5"), "--rig", n])
        add(f"revert {name!r}", lambda d, n=name: ["revert", str(d / "p.h5"), n])
    for path in PROJECT_PATHS:  # hostile project paths for every command that opens one
        for cmd in (["info"], ["verify"], ["process"], ["compare"], ["history"], ["model"], ["diagnose"],
                    ["acquire", "--name", "z", "--samples", "1024", "--pretrigger", "100"],
                    ["frf", "--experiment", "e1"], ["export-legacy", "e1", "--cod", "o.COD"]):
            add(f"{cmd[0]} on {path!r}", lambda d, c=cmd, p=path: [c[0], str(d / p), *[
                str(d / a) if a == "o.COD" else a for a in c[1:]]])
    for option in ("--samples", "--rate", "--pretrigger", "--trigger-level", "--trigger-timeout", "--seed"):
        for value in NUMBERS:
            add(f"acquire {option} {value!r}", lambda d, o=option, v=value: ["acquire", str(d / "p.h5"), "--name", "n", o, v])
    for option in ("--workers", "--frame-step", "--slowdown", "--ods", "--magnify", "--view"):
        for value in NUMBERS:
            add(f"render {option} {value!r}", lambda d, o=option, v=value: ["render", str(d / "p.h5"), "e1", "-o", str(d / "m.gif"), o, v])
    for option in ("--fmin", "--fmax", "--max-order", "--at"):
        for value in NUMBERS:
            add(f"modes {option} {value!r}", lambda d, o=option, v=value: ["modes", str(d / "p.h5"), "--experiment", "e1", o, v])
    for value in NUMBERS:
        add(f"process --corrected --cutoff {value!r}", lambda d, v=value: ["process", str(d / "p.h5"), "--corrected", "--cutoff", v])
        add(f"export-uff --nodes {value!r}", lambda d, v=value: ["export-uff", str(d / "p.h5"), "e1", "-o", str(d / "o.uff"), "--nodes", v])
        add(f"frf --estimator {value!r}", lambda d, v=value: ["frf", str(d / "p.h5"), "--experiment", "e1", "--estimator", v])
    for out_path in ("p.h5", ".p.h5.odsuite-lock", ".", "none/o.x", "good.DAT", "/dev/full"):  # outputs onto things that matter
        add(f"export-legacy --cod {out_path}", lambda d, o=out_path: ["export-legacy", str(d / "p.h5"), "e1", "--cod", str(d / o)])
        add(f"export-uff -o {out_path}", lambda d, o=out_path: ["export-uff", str(d / "p.h5"), "e1", "-o", str(d / o)])
        add(f"history --figure {out_path}", lambda d, o=out_path: ["history", str(d / "p.h5"), "--figure", str(d / o)])
        add(f"render -o {out_path}", lambda d, o=out_path: ["render", str(d / "p.h5"), "e1", "-o", str(d / o)])
    master_files = {
        "good.DAT": dat_text(legacy_volts()).encode(), "good.CTR": CTR_TEXT.encode(), "good.lvm": LVM_TEXT.encode(),
        "rig.toml": RIG_TOML.encode()}
    for k in range(25):  # damaged files of every format
        add(f"damaged .DAT #{k}", lambda d: ["import-legacy", str(d / "p.h5"), str(d / "bad.DAT"), "--systeminfo", str(d / "good.CTR"), "--name", "n", *legacy],
            {"bad.DAT": _damaged(rng, master_files["good.DAT"])})
        add(f"damaged .CTR #{k}", lambda d: ["import-legacy", str(d / "p.h5"), str(d / "good.DAT"), "--systeminfo", str(d / "bad.CTR"), "--name", "n", *legacy],
            {"bad.CTR": _damaged(rng, master_files["good.CTR"])})
        add(f"damaged .lvm #{k}", lambda d: ["import-lvm", str(d / "p.h5"), str(d / "bad.lvm"), "--name", "n"],
            {"bad.lvm": _damaged(rng, master_files["good.lvm"])})
        add(f"damaged rig #{k}", lambda d: ["new", str(d / "q.h5"), "--rig", str(d / "bad.toml")],
            {"bad.toml": _damaged(rng, master_files["rig.toml"])})
        add(f"damaged .uff #{k}", lambda d: ["import-uff", str(d / "p.h5"), str(d / "bad.uff"), "--name", "n", "--force-channel", "force"],
            {"bad.uff": b""})  # filled from the master's good.uff in run_try
    for label, writer in WRITERS:  # the lock, links, sidecar names and a full disk, for every writing command
        for case, setup in SIDECAR_CASES.items():
            add(f"{label} with {case}", lambda d, w=writer, c=case: w(d, "link.h5" if c == "project via a link" else "p.h5"),
                {"\0setup": setup})
        for free in (0, 200_000, 1_000_000, 2_000_000):
            add(f"{label} with {free / 1e6:g} MB free", lambda d, w=writer: w(d, "p.h5"), {"\0setup": _full_disk(free)})
    for label, writer, name in OUTPUTS:  # output files on a full disk, over a user's file, through a link
        first = (_processed,) if label.startswith(("render", "export-legacy")) else ()
        for free in (0, 1_000_000, 5_000_000):  # none, under and over the 1 MiB reserve
            add(f"{label} with {free / 1e6:g} MB free", lambda d, w=writer, n=name: w(d, n),
                {"\0setup": _in_turn(*first, _full_disk(free))})
        add(f"{label} over a user's file on a full disk", lambda d, w=writer, n=name: w(d, n),
            {name: b"a user's older file\n", "\0setup": _in_turn(*first, _full_disk(0))})
        add(f"{label} through a link to a user's file", lambda d, w=writer, n=name: w(d, n),
            {"target.txt": b"a user's older file\n", "\0setup": _in_turn(*first, _plant(name, link_to="target.txt"))})
    for k in range(20):  # UFF files whose counts were changed, on top of the damaged ones above
        add(f"uff count changed #{k}", lambda d: ["import-uff", str(d / "p.h5"), str(d / "bad.uff"), "--name", "n", "--force-channel", "force"],
            {"bad.uff": b"\0count"})
    return out


#: Every command that writes a project: (label, argv from the folder and the project's file name).
WRITERS: tuple[tuple[str, Callable[[Path, str], list[str]]], ...] = (
    ("acquire", lambda d, p: ["acquire", str(d / p), "--name", "w", "--samples", "1024", "--pretrigger", "100"]),
    ("import-legacy", lambda d, p: ["import-legacy", str(d / p), str(d / "good.DAT"), "--systeminfo", str(d / "good.CTR"),
                                    "--name", "w", "--force-point", "0,4.122,-11.399", "--force-dir", "+z"]),
    ("import-lvm", lambda d, p: ["import-lvm", str(d / p), str(d / "good.lvm"), "--name", "w"]),
    ("import-uff", lambda d, p: ["import-uff", str(d / p), str(d / "good.uff"), "--name", "w", "--force-channel", "force"]),
    ("process", lambda d, p: ["process", str(d / p), "--experiment", "s1"]),
    ("frf", lambda d, p: ["frf", str(d / p), "--experiment", "e1"]),
    ("modes", lambda d, p: ["modes", str(d / p), "--experiment", "e1"]),
    ("add-effect", lambda d, p: ["add-effect", str(d / p), "stiffness"]),
    ("revert", lambda d, p: ["revert", str(d / p), "0"]),
)


#: Every command that writes an output file: (label, argv from the folder and the output's name, a name).
OUTPUTS: tuple[tuple[str, Callable[[Path, str], list[str]], str], ...] = (
    ("export-legacy --cod", lambda d, o: ["export-legacy", str(d / "p.h5"), "e1", "--cod", str(d / o)], "o.COD"),
    ("export-uff -o", lambda d, o: ["export-uff", str(d / "p.h5"), "e1", "-o", str(d / o)], "o.uff"),
    ("history --figure", lambda d, o: ["history", str(d / "p.h5"), "--figure", str(d / o)], "h.png"),
    ("render -o", lambda d, o: ["render", str(d / "p.h5"), "e1", "-o", str(d / o), "--frame-step", "64"], "m.gif"),
    ("frf --figure", lambda d, o: ["frf", str(d / "p.h5"), "--experiment", "e1", "--figure", str(d / o)], "f.png"),
    ("modes --figure", lambda d, o: ["modes", str(d / "p.h5"), "--experiment", "e1", "--figure", str(d / o)], "g.svg"),
)


def _plant(name: str, content: bytes | None = None, link_to: str | None = None):
    def setup(d: Path):
        if link_to is not None:
            (d / name).symlink_to(d / link_to)
        else:
            (d / name).write_bytes(content)
    return setup


def _processed(d: Path) -> None:
    """e1 processed (generalized coordinates to export and render)."""
    from odsuite.cli import main

    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        if main(["process", str(d / "p.h5"), "--experiment", "e1"]) != 0:
            raise RuntimeError("processing e1 failed")


def _in_turn(*setups: Callable[[Path], object]) -> Callable[[Path], object]:
    """Several setups one after the other; the undo of the last."""
    def setup(d: Path):
        return [s(d) for s in setups][-1]
    return setup


def _hold_lock(d: Path):
    """Another writer holds the project (this process, through a second lock object)."""
    from odsuite.store.project import open_project

    return open_project(d / "p.h5", "a").close


def _full_disk(free: int):
    def setup(d: Path):
        import collections

        from odsuite.store import diskspace

        real = diskspace.shutil.disk_usage
        diskspace.shutil.disk_usage = lambda p: collections.namedtuple("u", "total used free")(10**9, 10**9 - free, free)

        def undo():
            diskspace.shutil.disk_usage = real
        return undo
    return setup


def _victim(d: Path) -> None:
    (d / "victim.txt").write_text("a user's file no lock may write into\n")


#: The project's sidecar names taken by links or a user's files, linked projects, a held lock.
SIDECAR_CASES: dict[str, Callable[[Path], object]] = {
    "a link at the lock name": lambda d: (_victim(d), _plant(".p.h5.odsuite-lock", link_to="victim.txt")(d)),
    "a dangling link at the lock name": _plant(".p.h5.odsuite-lock", link_to="nowhere.txt"),
    "a user's file at the lock name": _plant(".p.h5.odsuite-lock", b"my notes\n"),
    "a stale lock of a dead writer": _plant(".p.h5.odsuite-lock", b"odsuite-lock 999999 elsewhere\n"),
    "a user's file at a working-copy name": _plant(".p.h5.odsuite-tmp-1", b"my notes\n"),
    "a link at a working-copy name": lambda d: (_victim(d), _plant(f".p.h5.odsuite-tmp-{os.getpid()}", link_to="victim.txt")(d)),
    "the old lock name p.h5.lock taken": _plant("p.h5.lock", b"my notes\n"),
    "project via a link": _plant("link.h5", link_to="p.h5"),
    "a second hard link": lambda d: os.link(d / "p.h5", d / "p2.h5"),
    "the lock held by another writer": _hold_lock,
}


def _count_changed(rng: random.Random, good: bytes) -> bytes:
    """A point count (record 7 of a function) changed to another number of the same width."""
    lines = good.split(b"\n")
    records = [j for j, line in enumerate(lines) if len(line.split()) == 6 and line.split()[0] in (b"2", b"4", b"5", b"6")
               and all(t.isdigit() for t in line.split()[:3])]
    j = rng.choice(records)
    old = lines[j].split()[1]
    new = str(max(0, int(old) + rng.choice([-2, -1, 1, 2, 100]))).encode()
    at = lines[j].index(b" " + old + b" ") + 1
    lines[j] = lines[j][:at + len(old) - len(new)] + new + lines[j][at + len(old):]
    return b"\n".join(lines)


def _digests(folder: Path) -> dict[str, str]:
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file() and not p.is_symlink() and ".odsuite-lock" not in p.name:
            out[str(p.relative_to(folder))] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def run_try(label: str, argv_of: Callable[[Path], list[str]], files: dict[str, bytes], master: Path, d: Path,
            rng: random.Random) -> Try:
    from odsuite.cli import main

    shutil.copytree(master, d)
    undo = None
    for name, content in files.items():
        if name == "\0setup":
            undo = content(d)
            continue
        if name == "bad.uff":
            good = (master / "good.uff").read_bytes()
            content = _count_changed(rng, good) if content == b"\0count" else _damaged(rng, good)
        (d / name).write_bytes(content)
    os.mkfifo(d / "pipe.h5")
    (d / "loop.h5").symlink_to(d / "loop.h5")
    argv = argv_of(d)
    t = Try(label, argv)
    before = _digests(d)
    planted = {p.name: _state(p) for p in d.iterdir() if ".odsuite-" in p.name or p.is_symlink() or "victim" in p.name}
    out, err = io.StringIO(), io.StringIO()
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(try_limit())
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            t.code = main(argv)
    except _Hang:
        t.problems.append("hang")
    except SystemExit as exc:
        t.code = exc.code if isinstance(exc.code, int) else 1
    except BaseException as exc:  # noqa: BLE001 - any escape is the traceback a user would see
        t.problems.append(f"traceback: {type(exc).__name__}: {str(exc)[:200]}")
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
        if callable(undo):
            undo()
    text = err.getvalue()
    if "Traceback" in text:
        t.problems.append("traceback on stderr")
    if t.code == 1 and not (text.count("\n") == 1 and text.startswith("error: ")):
        t.problems.append(f"not one error line: {text[-300:]!r}")
    if t.code not in (0, None):
        after = _digests(d)
        changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
        if changed:
            t.problems.append(f"changed on failure: {changed}")
    # whatever the outcome: links and a user's files stay as they were, no sidecar of odsuite's own is left
    for name, state in planted.items():
        if _state(d / name) != state and not (name.startswith(".p.h5.odsuite-lock") and state[1].startswith("odsuite-lock")):
            t.problems.append(f"{name} changed: {state} -> {_state(d / name)}")
    left = [p.name for p in d.iterdir() if ".odsuite-" in p.name and p.name not in planted]
    if left:
        t.problems.append(f"left behind: {left}")
    shutil.rmtree(d)
    return t


def _state(p: Path) -> tuple[str, str]:
    """What a path is: a link and its target, a file and its text (start), or missing."""
    if p.is_symlink():
        return "link", os.readlink(p)
    if p.is_file():
        return "file", p.read_bytes()[:200].decode("utf-8", "replace")
    return "missing", ""


def run_redteam(work: Path, every: int = 1, seed: int = 19) -> list[Try]:
    """Every ``every``-th try (1: all)."""
    rng = random.Random(seed)
    master = prepare(work)
    results = []
    for k, (label, argv_of, files) in enumerate(tries(rng)):
        if k % every:
            continue
        results.append(run_try(label, argv_of, files, master, work / f"try{k}", rng))
    return results


def summary(results: list[Try]) -> str:
    def count(word):
        return sum(any(p.startswith(word) for p in r.problems) for r in results)

    lines = [f"{len(results)} tries: exit 0 {sum(r.code == 0 for r in results)}, exit 1 "
             f"{sum(r.code == 1 for r in results)}, exit 2 (usage) {sum(r.code == 2 for r in results)}; "
             f"tracebacks {count('traceback')}, hangs {count('hang')}, changed files on failure "
             f"{count('changed')}, messages not one line {count('not one')}"]
    lines += [f"  {r.label[:80]!r}: {r.problems}" for r in results if r.problems]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    work = Path(args[0]) if args else Path(tempfile.mkdtemp(prefix="odsuite-redteam-"))
    results = run_redteam(work)
    print(summary(results))
    return 0 if not any(r.problems for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
