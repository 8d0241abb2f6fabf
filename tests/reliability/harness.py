"""Kill harness: SIGKILL writing ``odsuite`` commands at seeded random moments and check the project.

Each run starts one writing command as a real ``odsuite`` subprocess on a project that already holds
experiments, kills it at one of three kinds of moment, then checks the project:

- ``point``: at a named stage of the copy-on-write commit (``ODSUITE_TEST_CRASH_AT``),
- ``write``: a random delay after the command's temporary copy appears (inside the write),
- ``any``: a random delay after start, up to the command's measured unkilled duration.

After the kill the project must open for reading as it is, then for writing (the writer's start
removes what the killed one left, with a logged warning); ``verify()`` must pass; every unit the
project held before (an experiment's raw data and Systeminfo, one derived group, one model revision)
must be unchanged; every unit that differs from before must equal the same unit after an unkilled
run of the same command on a copy taken before (so a half-written unit is never visible).

Adding a writing command is one ``WritingCommand`` line in ``WRITING_COMMANDS``.
"""

from __future__ import annotations

import fnmatch
import hashlib
import json
import logging
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from odsuite.store.project import open_project
from odsuite.store.storage import CRASH_ENV

ODSUITE = Path(sys.executable).with_name("odsuite")
REPO = Path(__file__).resolve().parents[2]
TABLE_E3 = REPO / "plugins" / "models" / "rigs" / "thesis-table-e3.CTR"
#: A real hammer record (LADISK beam, LabVIEW .lvm), kept in the repository (tests/data/real).
LVM_SOURCE = REPO / "tests" / "data" / "real" / "ladisk_beam_impact" / "acceleration.lvm"
#: Named stages of a commit (see ``Project.transaction`` and ``Project._write_raw``).
CRASH_POINTS = ("copied", "chunk-1", "written", "synced", "replaced")
#: Attributes that differ between two otherwise identical writes.
VOLATILE_ATTRS = frozenset({"object_id", "created", "file_time", "file_update_time"})
MODES = ("point", "write", "any")
RUN_TIMEOUT = 180.0  # s; a command still running then is a hang


@dataclass
class Context:
    """What a command line may depend on: the project, the inputs folder, the run index, a seeded
    random source and the experiments the project holds before the run."""

    project: Path
    inputs: Path
    index: int
    rng: random.Random
    experiments: list[str]


@dataclass(frozen=True)
class WritingCommand:
    """A command that writes into the project; ``argv`` builds its arguments (without ``odsuite``).
    ``program`` replaces ``odsuite`` (the harness's own tests run deliberately unsafe writers);
    ``needs`` names an input file without which the command is left out. ``updates`` names committed
    units the command may change, as shell-style patterns (still checked against a complete run):
    ``models``, whose current revision add-effect moves; a revision's stored error, which process
    writes."""

    name: str
    argv: Callable[[Context], list[str]]
    program: tuple[str, ...] | None = None
    needs: str | None = None
    updates: tuple[str, ...] = ()


WRITING_COMMANDS: tuple[WritingCommand, ...] = (
    WritingCommand("import-legacy", lambda c: [
        "import-legacy", str(c.project), str(c.inputs / "T8.DAT"), "--systeminfo", str(TABLE_E3),
        "--name", f"leg{c.index}", "--force-point", "0,4.122,-11.399", "--force-dir", "+z"]),
    WritingCommand("acquire", lambda c: [
        "acquire", str(c.project), "--daq", "sim", "--name", f"acq{c.index}", "--seed", str(c.index % 5),
        "--samples", "4096"]),
    # process stores the current revision's error on the records it leaves (models/revisions/N)
    WritingCommand("process", lambda c: [
        "process", str(c.project), "--experiment", c.rng.choice([e for e in c.experiments if "lvm" not in e])],
        updates=("models/revisions/*",)),
    WritingCommand("import-lvm", lambda c: [
        "import-lvm", str(c.project), str(c.inputs / "beam.lvm"), "--name", f"lvm{c.index}"], needs="beam.lvm"),
    WritingCommand("frf", lambda c: [
        "frf", str(c.project), "--experiment", c.rng.choice([e for e in c.experiments if "lvm" in e])],
        needs="beam.lvm"),
    WritingCommand("import-uff", lambda c: [
        "import-uff", str(c.project), str(c.inputs / "T8.uff"), "--name", f"uff{c.index}", "--force-channel", "force",
        "--force-point", "0,4.122,-11.399", "--force-dir", "+z"]),  # its 11 records go onto the rig in order
)

#: Commands of the model loop. They need a project whose experiments all match the rig (compare
#: refuses the .lvm beam record of the seeded project), so they run on ``seed_loop_project``.
LOOP_COMMANDS: tuple[WritingCommand, ...] = (
    WritingCommand("add-effect", lambda c: ["add-effect", str(c.project), "stiffness"], updates=("models",)),
)


def legacy_volts(n: int = 4096, seed: int = 0, fs: float = 20_000.0) -> np.ndarray:
    """11 channels like the thesis rig records them: a hammer pulse on channel 0, a quiet channel,
    nine decaying accelerometer responses (volts)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    data = rng.normal(scale=2e-3, size=(n, 11))
    hit = (t >= 0.01) & (t < 0.011)
    data[hit, 0] += 0.8 * np.sin(np.pi * (t[hit] - 0.01) / 0.001)
    after = np.clip(t - 0.01, 0, None)
    for k in range(2, 11):
        data[:, k] += 0.3 * np.exp(-after * 40) * np.sin(2 * np.pi * (120 + 10 * k) * after) * (t >= 0.01)
    return data


def prepare_inputs(folder: Path) -> Path:
    """The input files the writing commands read."""
    from odsuite_plugins.importers.legacy import write_dat
    from odsuite_plugins.importers.uff import time_function, write_uff

    folder.mkdir(parents=True, exist_ok=True)
    write_dat(folder / "T8.DAT", legacy_volts())
    volts = legacy_volts()
    names = ["force"] + [f"ch{k}" for k in range(1, volts.shape[1])]
    write_uff(folder / "T8.uff", overwrite=True, functions=[
        # the thesis rig's channels in order: the load cell, an auxiliary voltage, nine accelerometers
        time_function(n, volts[:, k], 1 / 20_000.0, "N" if k == 0 else "V" if k == 1 else "m/s^2")
        for k, n in enumerate(names)])
    shutil.copyfile(LVM_SOURCE, folder / "beam.lvm")
    return folder


def available(commands: Sequence[WritingCommand], inputs: Path) -> list[WritingCommand]:
    """The commands whose input files are present."""
    return [c for c in commands if c.needs is None or (inputs / c.needs).is_file()]


# ----------------------------------------------------------------------------- project state


def _unit(name: str) -> str:
    """The unit an HDF5 object belongs to: an experiment (raw, Systeminfo, attributes), one of its
    derived groups, a model revision, or a top-level group."""
    parts = name.split("/")
    if parts[0] == "experiments" and len(parts) >= 2:
        if len(parts) >= 3 and parts[2] == "derived":
            return "/".join(parts[:4]) if len(parts) >= 4 else "/".join(parts[:2]) + "/derived"
        return "/".join(parts[:2])
    if parts[0] == "models" and len(parts) >= 3:
        return "/".join(parts[:3])
    return parts[0]


def _bytes(value: np.ndarray) -> bytes:
    # variable-length strings (also inside compound rows) are pointers in memory: hash their text
    return repr(value.tolist()).encode() if value.dtype.hasobject else value.tobytes()


def _feed_attrs(h, obj) -> None:
    for key in sorted(obj.attrs):
        if key in VOLATILE_ATTRS:
            continue
        value = np.asarray(obj.attrs[key])
        if key == "metrics":  # a revision's stored error: its data_stamp names the records' object ids
            value = np.asarray(_without_stamp(obj.attrs[key]))
        h.update(key.encode())
        h.update(_bytes(value))


def _updated(unit: str, updates: tuple[str, ...]) -> bool:
    """Whether a command may change ``unit``: one ``updates`` names (shell-style patterns)."""
    return any(fnmatch.fnmatchcase(unit, u) for u in updates)


def _without_stamp(text) -> str:
    text = text.decode() if isinstance(text, bytes) else str(text)
    try:
        metrics = json.loads(text)
    except ValueError:  # not odsuite's JSON: hashed as it is
        return text
    if isinstance(metrics, dict):
        metrics.pop("data_stamp", None)
    return json.dumps(metrics, sort_keys=True)


def units(path: Path) -> dict[str, str]:
    """A digest per unit of the committed project (data, shapes, dtypes and non-volatile attributes)."""
    hashes: dict[str, hashlib._Hash] = {}

    def visit(name: str, obj) -> None:
        h = hashes.setdefault(_unit(name), hashlib.sha256())
        h.update(f"{type(obj).__name__}:{name}".encode())
        _feed_attrs(h, obj)
        if isinstance(obj, h5py.Dataset):
            data = np.asarray(obj[()])
            h.update(f"{data.dtype}{data.shape}".encode())
            h.update(_bytes(data))

    with h5py.File(path, "r", locking=False) as f:
        root = hashes.setdefault("/", hashlib.sha256())
        _feed_attrs(root, f)
        f.visititems(visit)
    return {k: h.hexdigest() for k, h in hashes.items()}


# ----------------------------------------------------------------------------- runs


@dataclass
class Run:
    """One killed (or completed) command and what the checks found."""

    index: int
    command: str
    mode: str
    moment: str
    returncode: int | None = None
    recovered: bool = False
    changed: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)

    @property
    def killed(self) -> bool:
        return self.returncode == -signal.SIGKILL

    @property
    def survived(self) -> bool:
        return not self.problems


@dataclass
class Report:
    runs: list[Run]
    lost: int  # units committed before a kill and changed or missing after it
    timings: dict[str, tuple[float, float]]

    @property
    def survived(self) -> int:
        return sum(r.survived for r in self.runs)

    def summary(self) -> str:
        killed = sum(r.killed for r in self.runs)
        return (f"{self.survived}/{len(self.runs)} survived, {self.lost} lost "
                f"({killed} killed, {len(self.runs) - killed} completed before the kill, "
                f"{sum(r.recovered for r in self.runs)} recoveries)")


def _env(crash_at: str | None = None) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != CRASH_ENV}
    if crash_at:
        env[CRASH_ENV] = crash_at
    return env


def _tmp_file(project: Path, pid: int) -> Path:
    return project.with_name(f".{project.name}.odsuite-tmp-{pid}")


def _wait_group(pgid: int, timeout: float = 30.0) -> None:
    """Wait until every process of the killed command's group is gone (forked processing workers
    finish their channels and exit on their own; they hold the writer lock until then)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.01)
    raise TimeoutError(f"processes of group {pgid} still alive {timeout} s after the kill")


def run_command(argv: Sequence[str], project: Path, *, crash_at: str | None = None,
                kill_after: float | None = None, after_write_starts: bool = False,
                program: Sequence[str] | None = None) -> tuple[int, float, float | None]:
    """Run ``odsuite argv``; kill it ``kill_after`` s after start (or after its temporary copy
    appears). Returns (returncode, seconds run, seconds from the temporary copy to exit or None)."""
    t0 = time.monotonic()
    with open(project.with_name(project.name + ".stderr"), "wb") as err:  # read only when it failed
        proc = subprocess.Popen([*(program or [str(ODSUITE)]), *argv], env=_env(crash_at), stdout=subprocess.DEVNULL,
                                stderr=err, start_new_session=True)
    tmp = _tmp_file(project, proc.pid)
    t_write = None
    deadline = t0 + RUN_TIMEOUT
    while proc.poll() is None and time.monotonic() < deadline:
        now = time.monotonic()
        if t_write is None and tmp.exists():
            t_write = now
        if kill_after is not None and (t_write if after_write_starts else t0) is not None \
                and now - (t_write if after_write_starts else t0) >= kill_after:
            proc.send_signal(signal.SIGKILL)
            break
        time.sleep(0.002)
    try:
        proc.wait(timeout=max(1.0, deadline - time.monotonic()))
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        raise TimeoutError(f"odsuite {' '.join(argv)} still running after {RUN_TIMEOUT} s") from None
    finally:
        _wait_group(proc.pid)
    end = time.monotonic()
    return proc.returncode, end - t0, None if t_write is None else end - t_write


def measure(commands: Sequence[WritingCommand], project: Path, inputs: Path, scratch: Path,
            seed: int = 0) -> dict[str, tuple[float, float]]:
    """Unkilled duration and write window (s) of each command on a copy of ``project``."""
    scratch.mkdir(parents=True, exist_ok=True)
    out = {}
    for k, cmd in enumerate(commands):
        copy = scratch / f"measure-{k}.h5"
        shutil.copyfile(project, copy)
        with open_project(copy) as p:
            names = p.experiment_names()
        argv = cmd.argv(Context(copy, inputs, 10_000 + k, random.Random(seed), names))
        code, total, window = run_command(argv, copy, program=cmd.program)
        if code != 0:
            raise RuntimeError(f"odsuite {' '.join(argv)} failed unkilled (exit {code})")
        out[cmd.name] = (total, window or total)
    return out


def _oracle(cmd: WritingCommand, argv: list[str], before: Path, project: Path, scratch: Path) -> dict[str, str]:
    """Units after an unkilled run of the same command on the copy taken before."""
    from odsuite.cli import main

    oracle = scratch / "oracle.h5"
    shutil.copyfile(before, oracle)
    argv = [str(oracle) if a == str(project) else a for a in argv]
    if cmd.program is None:
        code = main(argv)  # in this process: no interpreter start-up
    else:
        code = subprocess.run([*cmd.program, *argv], env=_env(), capture_output=True).returncode
    if code != 0:
        raise RuntimeError(f"odsuite {' '.join(argv)} failed on the copy taken before (exit {code})")
    try:
        return units(oracle)
    finally:
        oracle.unlink()


class _Records(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


def _check(run: Run, project: Path, before_units: dict[str, str], oracle: Callable[[], dict[str, str]],
           updates: tuple[str, ...] = ()) -> dict[str, str]:
    """The checks after one run; returns the units now committed."""
    leftovers = sorted(p.name for p in project.parent.glob(f".{project.name}.odsuite-tmp-*"))
    try:
        with open_project(project) as p:  # a reader opens the project as the kill left it
            p.verify()
        records = _Records()
        logger = logging.getLogger("odsuite.store.storage")
        logger.addHandler(records)
        try:
            with open_project(project, "a") as p:  # the next writer recovers
                p.verify()
        finally:
            logger.removeHandler(records)
    except Exception as exc:  # noqa: BLE001 - any failure to open is what the harness reports
        run.problems.append(f"project does not open or verify after the kill: {type(exc).__name__}: {exc}")
        return before_units
    run.recovered = any("left by an interrupted write" in m for m in records.messages)
    if leftovers and not run.recovered:
        run.problems.append(f"temporary files {leftovers} left and not removed by the next writer")
    if any(p.name.startswith(f".{project.name}.odsuite-tmp-") for p in project.parent.iterdir()):
        run.problems.append("temporary file still present after recovery")
    after = units(project)
    hidden = [u for u in after if any(part.startswith(".") for part in u.split("/"))]
    if hidden:
        run.problems.append(f"half-written groups visible: {hidden}")
    run.changed = sorted(u for u in set(after) | set(before_units) if after.get(u) != before_units.get(u))
    lost = [u for u in run.changed if u in before_units and not _updated(u, updates)]
    if lost:
        run.problems.append(f"committed units changed or lost: {lost}")
    if run.changed:
        complete = oracle()
        partial = [u for u in run.changed if after.get(u) != complete.get(u)]
        if partial:
            run.problems.append(f"units differ from a complete run: {partial}")
    return after


def run_kills(project: Path, inputs: Path, scratch: Path, n: int, seed: int, *,
              commands: Sequence[WritingCommand] = WRITING_COMMANDS, modes: Sequence[str] = MODES,
              timings: dict[str, tuple[float, float]] | None = None,
              progress: Callable[[Run], None] | None = None) -> Report:
    """``n`` seeded kills over ``commands`` (cycled in a shuffled order) on ``project``."""
    rng = random.Random(seed)
    commands = available(commands, inputs)
    scratch.mkdir(parents=True, exist_ok=True)
    if timings is None and "any" in modes:
        timings = measure(commands, project, inputs, scratch / "measure", seed)
    timings = timings or {}
    before = scratch / "before.h5"
    runs: list[Run] = []
    lost = 0
    committed = units(project)
    for i in range(n):
        cmd = commands[i % len(commands)] if i < len(commands) else rng.choice(commands)
        mode = rng.choice(modes)
        with open_project(project) as p:
            names = p.experiment_names()
        argv = cmd.argv(Context(project, inputs, i, rng, names))
        shutil.copyfile(project, before)  # the copy taken before
        total, window = timings.get(cmd.name, (5.0, 0.5))
        if mode == "point":
            point = rng.choice(CRASH_POINTS)
            run = Run(i, cmd.name, mode, point)
            code, *_ = run_command(argv, project, crash_at=point, program=cmd.program)
        else:
            delay = rng.uniform(0.0, window if mode == "write" else total)
            run = Run(i, cmd.name, mode, f"{delay:.3f} s after {'the write starts' if mode == 'write' else 'start'}")
            code, *_ = run_command(argv, project, kill_after=delay, after_write_starts=mode == "write",
                                   program=cmd.program)
        run.returncode = code
        if code not in (0, -signal.SIGKILL):
            err = project.with_name(project.name + ".stderr").read_text(errors="replace").strip()
            run.problems.append(f"exit code {code}: {err.splitlines()[-1] if err else ''}")
        after = _check(run, project, committed, lambda: _oracle(cmd, argv, before, project, scratch), cmd.updates)
        lost += sum(1 for u in run.changed if u in committed and not _updated(u, cmd.updates))
        committed = after
        runs.append(run)
        if progress:
            progress(run)
    before.unlink(missing_ok=True)
    return Report(runs, lost, timings)


def seed_project(path: Path, inputs: Path) -> Path:
    """A thesis-rig project holding earlier experiments: one legacy import, two simulated
    acquisitions, one of them processed, and a real .lvm hammer record when available."""
    from odsuite.cli import main

    steps = [
        ["new", str(path)],
        ["import-legacy", str(path), str(inputs / "T8.DAT"), "--systeminfo", str(TABLE_E3), "--name", "old-T8",
         "--force-point", "0,4.122,-11.399", "--force-dir", "+z"],
        ["acquire", str(path), "--daq", "sim", "--name", "old-T1", "--seed", "11", "--samples", "4096"],
        ["acquire", str(path), "--daq", "sim", "--name", "old-T5", "--scenario", "T5", "--seed", "12",
         "--samples", "4096"],
        ["process", str(path), "--experiment", "old-T1"],
    ]
    if (inputs / "beam.lvm").is_file():
        steps.append(["import-lvm", str(path), str(inputs / "beam.lvm"), "--name", "old-lvm"])
    for argv in steps:
        if main(argv) != 0:
            raise RuntimeError(f"odsuite {' '.join(argv)} failed")
    return path


def seed_loop_project(path: Path) -> Path:
    """A thesis-rig project with two simulated records at different hammer points, both processed."""
    from odsuite.cli import main

    steps = [
        ["new", str(path)],
        ["acquire", str(path), "--daq", "sim", "--name", "sim-T1", "--seed", "21", "--samples", "2048"],
        ["acquire", str(path), "--daq", "sim", "--name", "sim-T5", "--scenario", "T5", "--seed", "22",
         "--samples", "2048"],
        ["process", str(path)],
    ]
    for argv in steps:
        if main(argv) != 0:
            raise RuntimeError(f"odsuite {' '.join(argv)} failed")
    return path


def main(argv: Sequence[str] | None = None) -> int:
    """``python tests/reliability/harness.py [KILLS] [SEED] [DIR]``: run the kills, print the summary."""
    import tempfile

    args = list(sys.argv[1:] if argv is None else argv)
    n = int(args[0]) if args else 100
    seed = int(args[1]) if len(args) > 1 else 2024
    work = Path(args[2]) if len(args) > 2 else Path(tempfile.mkdtemp(prefix="odsuite-kills-"))
    inputs = prepare_inputs(work / "inputs")
    project = seed_project(work / "p.h5", inputs)
    t0 = time.monotonic()
    report = run_kills(project, inputs, work / "scratch", n, seed,
                       progress=lambda r: print(f"{r.index:3d} {r.command:14s} {r.mode:5s} {r.moment:32s} "
                                                f"exit {r.returncode} {'ok' if r.survived else r.problems}",
                                                flush=True))
    print(report.summary(), f"in {time.monotonic() - t0:.0f} s", flush=True)
    return 0 if report.survived == n and report.lost == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
