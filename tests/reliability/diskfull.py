"""Full-disk harness: real ``odsuite`` commands on a small tmpfs filled to a seeded random level.

Each run copies a project onto a fresh tmpfs (``mount -t tmpfs -o size=N``, needs root), fills it
with a ballast file until a random number of bytes is left free (from none to more than the command
needs), and runs one command there (project writes and output files). Every other run blinds odsuite's check of the free space (its
``shutil.disk_usage`` reports a huge disk), as when another program fills the disk during a write:
then the disk blocks odsuite reserves before HDF5 writes (posix_fallocate) must still stop it in
one line, before HDF5 meets the full disk (which can crash the HDF5 library). It must end with exit code 0, or 1 and exactly one line on
stderr saying ``no space left on DEVICE: needed ~N MB`` (or another one-line error); never a
traceback or a signal (segfault); on failure every unit of the project as before, no output file;
no working copy or lock file left beside it.

``python tests/reliability/diskfull.py [RUNS] [SEED] [DIR]`` prints the counts.
"""

from __future__ import annotations

import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from tests.reliability.harness import ODSUITE, TABLE_E3, units  # noqa: E402
from tests.reliability.interrupts import seeded_projects  # noqa: E402

RUN_TIMEOUT = 180.0  # s; a command still running then is a hang
DISK_BYTES = 8 << 20  # the tmpfs: 8 MiB, room for the project and some of each command's output
FULL_LINE = re.compile(r"^error: .*: no space left on \S+: needed ~[0-9.]+ MB(, [0-9.]+ MB free)?; "
                       r"(project unchanged|no project created|nothing written|stored before the error: .*)$")


@dataclass(frozen=True)
class DiskCommand:
    """A command line (without ``odsuite``) from the project, the inputs folder and the disk's folder."""

    name: str
    argv: Callable[[Path, Path, Path, int], list[str]]


COMMANDS: tuple[DiskCommand, ...] = (
    DiskCommand("acquire", lambda p, i, d, k: [
        "acquire", str(p), "--daq", "sim", "--name", f"acq{k}", "--seed", str(k % 5), "--samples", "16384"]),
    DiskCommand("import-legacy", lambda p, i, d, k: [
        "import-legacy", str(p), str(i / "T8.DAT"), "--systeminfo", str(TABLE_E3), "--name", f"leg{k}",
        "--force-point", "0,4.122,-11.399", "--force-dir", "+z"]),
    DiskCommand("process", lambda p, i, d, k: ["process", str(p)]),
    DiskCommand("modes", lambda p, i, d, k: ["modes", str(p), "--experiment", "s1"]),
    DiskCommand("export-legacy", lambda p, i, d, k: ["export-legacy", str(p), "s1", "--cod", str(d / "s1.COD")]),
    DiskCommand("new", lambda p, i, d, k: ["new", str(d / "fresh.h5")]),
    DiskCommand("export-uff", lambda p, i, d, k: ["export-uff", str(p), "s1", "-o", str(d / "s1.uff")]),
    DiskCommand("render", lambda p, i, d, k: ["render", str(p), "s1", "-o", str(d / "m.gif"), "--frame-step", "32"]),
    DiskCommand("history", lambda p, i, d, k: ["history", str(p), "--figure", str(d / "h.png")]),
)
#: The files the commands create: none may be left by a command that failed.
OUTPUT_NAMES = ("s1.COD", "fresh.h5", "s1.uff", "m.gif", "h.png")


def can_mount() -> bool:
    """Whether this process may mount a tmpfs (root on Linux)."""
    if not hasattr(os, "geteuid") or os.geteuid() != 0 or not shutil.which("mount"):
        return False
    with tempfile.TemporaryDirectory() as d:
        if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", d], capture_output=True).returncode:
            return False
        subprocess.run(["umount", d], check=True)
    return True


@contextmanager
def small_disk(folder: Path, size: int = DISK_BYTES) -> Iterator[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)], check=True,
                   capture_output=True)
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=True)


def fill(disk: Path, leave: int) -> None:
    """Fill ``disk`` with a ballast file until ``leave`` bytes stay free."""
    room = shutil.disk_usage(disk).free - leave
    if room > 0:
        with open(disk / "ballast", "wb") as fh:
            fh.write(b"\0" * room)  # tmpfs counts written pages, so zeros take room too


@dataclass
class Outcome:
    command: str
    free: int
    code: int | None
    line: str
    problems: list[str] = field(default_factory=list)
    stderr: str = ""


#: odsuite with its free-space check blinded: HDF5 and the copies meet the full disk themselves.
BLIND = ("import shutil, sys, collections; from odsuite.cli import main; "
         "shutil.disk_usage = lambda p: collections.namedtuple('u', 'total used free')(1 << 50, 0, 1 << 50); "
         "sys.argv[0] = 'odsuite'; sys.exit(main(sys.argv[1:]))")


def run_once(cmd: DiskCommand, master: Path, inputs: Path, disk: Path, index: int, leave: int,
             blind: bool = False) -> Outcome:
    project = disk / "p.h5"
    shutil.copyfile(master, project)
    fill(disk, leave)
    free = shutil.disk_usage(disk).free
    before = units(project)
    program = [sys.executable, "-c", BLIND] if blind else [str(ODSUITE)]
    proc = subprocess.Popen([*program, *cmd.argv(project, inputs, disk, index)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, errors="replace")
    try:
        _, err = proc.communicate(timeout=RUN_TIMEOUT)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        return Outcome(cmd.name, free, None, "", ["hang"])
    lines = err.strip().splitlines()
    res = Outcome(cmd.name + (" (blind)" if blind else ""), free, proc.returncode, lines[-1] if lines else "",
                  stderr=err)
    after = units(project)
    if proc.returncode < 0:
        res.problems.append(f"killed by signal {-proc.returncode}")
    if "Traceback" in err or "HDF5-DIAG" in err:
        res.problems.append("traceback")
    left = [p.name for p in disk.iterdir() if ".odsuite-" in p.name or p.name.startswith("odsuite-movie-")]
    if left:
        res.problems.append(f"left behind: {left}")
    if proc.returncode == 0:
        return res
    partial = [p.name for p in disk.iterdir() if p.name in OUTPUT_NAMES]
    if partial:
        res.problems.append(f"an output of the failed command: {partial}")
    if proc.returncode != 1 or len(lines) != 1 or not lines[0].startswith("error: "):
        res.problems.append(f"exit {proc.returncode}, stderr {err.strip()[-300:]!r}")
    elif "no space" in lines[0] and not FULL_LINE.match(lines[0]):
        res.problems.append(f"full-disk line not as documented: {lines[0]!r}")
    changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    # multi-experiment process keeps the experiments it committed before the error, naming them
    kept = lines[-1].split("stored before the error: ")[1].split(" in ")[0].split(", ") \
        if lines and "stored before the error: " in lines[-1] else []
    unsaid = [k for k in changed if not any(k.startswith(f"experiments/{name}/") or k == f"experiments/{name}"
                                            for name in kept)]
    if unsaid:
        res.problems.append(f"failed, yet changed {unsaid[:5]}")
    return res


def run_full_disks(work: Path, runs: int, seed_value: int = 0,
                   commands: tuple[DiskCommand, ...] = COMMANDS) -> list[Outcome]:
    rng = random.Random(seed_value)
    inputs, _, master = seeded_projects(work)  # s1 processed: export-legacy and modes need it
    size = master.stat().st_size
    outcomes = []
    for k in range(runs):
        cmd = commands[k % len(commands)]
        # from a full disk to 3.5 times the project's size free: below, at and above what it needs
        leave = int(rng.uniform(0, 3.5) * size)
        with small_disk(work / f"disk{k}", max(DISK_BYTES, 5 * size)) as disk:
            outcomes.append(run_once(cmd, master, inputs, disk, k, leave, blind=bool(k // len(commands) % 2)))
        (work / f"disk{k}").rmdir()
    return outcomes


def summary(outcomes: list[Outcome]) -> str:
    """Per command: runs, done, refused for a full disk, with problems; then each problem."""
    counts: dict[str, Counter] = {}
    for o in outcomes:
        c = counts.setdefault(o.command, Counter())
        c.update(runs=1, done=o.code == 0, full="no space left" in o.line, problems=bool(o.problems))
    rows = [f"{name}: {c['runs']} runs, {c['done']} done, {c['full']} refused for a full disk, "
            f"{c['problems']} with problems" for name, c in counts.items()]
    rows += [f"  {o.command} with {o.free / 1e6:.2f} MB free: {o.problems}" for o in outcomes if o.problems]
    total = sum(counts.values(), Counter())
    return "\n".join([*rows, f"total: {total['runs']} runs, {total['full']} refused for a full disk, "
                               f"{total['problems']} with problems"])


def main(argv: list[str] | None = None) -> int:
    import argparse

    parser = argparse.ArgumentParser(description="odsuite commands on small full disks")
    parser.add_argument("runs", nargs="?", type=int, default=36)
    parser.add_argument("seed", nargs="?", type=int, default=0)
    parser.add_argument("work", nargs="?", type=Path, default=None)
    args = parser.parse_args(argv)
    if not can_mount():
        print("cannot mount a tmpfs here (needs root); the emulated full disks of test_diskfull.py still run")
        return 0
    outcomes = run_full_disks(args.work or Path(tempfile.mkdtemp(prefix="odsuite-diskfull-")), args.runs, args.seed)
    print("\n".join(f"{o.command:22s} {o.free / 1e6:6.2f} MB free  exit {o.code}  {o.line}"
                    + (f"\n{o.stderr}" if o.problems else "") for o in outcomes))
    print(summary(outcomes))
    return int(any(o.problems for o in outcomes))


if __name__ == "__main__":
    sys.exit(main())
