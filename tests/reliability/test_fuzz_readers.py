"""Fuzzing the readers with corrupted bytes of valid files (bytes flipped, inserted, deleted, the file
cut short): every case ends in a valid result or an OdsuiteError, never another exception or a hang,
and reading never changes the file.

Each case runs in a forked worker process: a hang inside HDF5's C code cannot be interrupted from
Python, so the parent waits a limit, counts the case as a hang and replaces the worker. The limit
follows the machine: it is a multiple of a valid file's read time measured by the same worker, and a
case that runs out of it is run again under a limit measured anew at that moment (a loaded machine
slows every read alike; an endless loop runs out of any limit).
``FUZZ_EXAMPLES`` sets the cases per reader (default 200; ``make fuzz`` runs 10 000 and prints the
outcome counts); ``FUZZ_SEED`` draws other cases than the fixed default sequence; ``FUZZ_KEEP``
names a directory where failing cases are saved.
"""

from __future__ import annotations

import multiprocessing
import os
import time
import traceback
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from odsuite.domain.errors import OdsuiteError
from tests.reliability.harness import TABLE_E3, legacy_volts

EXAMPLES = int(os.environ.get("FUZZ_EXAMPLES", "200"))
#: s per case at least: longer is a hang (or a loaded machine, see ``Limits``)
CASE_TIMEOUT = 10.0
#: A corrupted file takes at most this many times a valid one's read time before it counts as a
#: hang: damage makes readers stop early or check more, not loop (valid reads take 1 ms to 1 s).
SLOWDOWN = 20.0
SEED = os.environ.get("FUZZ_SEED")
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=SEED is None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                       HealthCheck.data_too_large])


def _serve(conn, read) -> None:
    from odsuite.store import project_migration

    while True:
        path, timeout = conn.recv()
        # a format-1.0.0 text migration ends in an error before the worker counts as a hang
        project_migration.HEAP_TEXT_TIMEOUT = timeout / 3
        try:
            read(Path(path))
            conn.send(("valid", ""))
        except OdsuiteError as exc:
            conn.send((type(exc).__name__, str(exc)))
        except BaseException as exc:  # noqa: BLE001 - any other exception is what the fuzzer looks for
            conn.send(("other", "".join(traceback.format_exception(exc))))


class Worker:
    """A forked process that runs ``read`` on one file per request."""

    def __init__(self, read) -> None:
        self.read = read
        self._start()

    def _start(self) -> None:
        ctx = multiprocessing.get_context("fork")
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_serve, args=(child, self.read), daemon=True)
        self.proc.start()
        child.close()  # the worker's end: its death then reads as EOF here

    def run(self, path: Path, timeout: float) -> tuple[str, str]:
        """(outcome, message) within ``timeout`` s: outcome is "valid", an OdsuiteError class name,
        "other", "hang" or "crash" (the worker died, e.g. a segfault in HDF5)."""
        try:
            self.conn.send((str(path), timeout))
            if self.conn.poll(timeout):
                return self.conn.recv()
            outcome = "hang"
        except (EOFError, OSError):  # the worker died
            outcome = "crash"
        self.proc.kill()
        self.proc.join()
        code = self.proc.exitcode
        self._start()
        return outcome, f"worker {outcome} (exit code {code})"

    def close(self) -> None:
        self.proc.kill()
        self.proc.join()


def _timed_out(outcome: str, message: str) -> bool:
    return outcome == "hang" or "did not finish within" in message


class Limits:
    """The time limit of a case: ``SLOWDOWN`` times a valid file's read in the same worker, measured
    now (at least ``CASE_TIMEOUT``)."""

    def __init__(self, worker: Worker, valid: Path) -> None:
        self.worker, self.valid = worker, valid
        self.limit = CASE_TIMEOUT
        self.measure()

    def measure(self) -> float:
        """Time a valid read; the new limit (s)."""
        start = time.perf_counter()
        outcome, message = self.worker.run(self.valid, 10 * self.limit)
        took = time.perf_counter() - start
        assert outcome == "valid", f"the calibration file did not read back valid: {outcome}: {message}"
        self.limit = max(CASE_TIMEOUT, SLOWDOWN * took)
        return self.limit

    def run(self, path: Path) -> tuple[str, str]:
        """A case's outcome; one that ran out of time is run again under a limit measured anew, and
        counts as a hang only if it runs out of that one too."""
        outcome, message = self.worker.run(path, self.limit)
        if _timed_out(outcome, message):
            before = self.limit
            self.measure()
            outcome, message = self.worker.run(path, max(self.limit, before))
        return outcome, message


@st.composite
def corrupted(draw, bases: tuple[bytes, ...]) -> bytes:
    """A valid file with 1-4 edits: a byte XORed, bytes inserted or deleted, or the end cut off."""
    data = bytearray(draw(st.sampled_from(bases)))
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(("flip", "insert", "delete", "truncate")))
        at = draw(st.integers(0, max(0, len(data) - 1)))
        if kind == "flip" and data:
            data[at] ^= draw(st.integers(1, 255))
        elif kind == "insert":
            data[at:at] = draw(st.binary(min_size=1, max_size=16))
        elif kind == "delete":
            del data[at:at + draw(st.integers(1, 16))]
        else:
            del data[at:]
    return bytes(data)


def _uff_bases(tmp: Path) -> tuple[bytes, ...]:
    from odsuite_plugins.importers.uff import time_function, write_uff

    out = []
    for binary in (False, True):
        path = tmp / f"b{int(binary)}.uff"
        write_uff(path, functions=[time_function("acc", np.sin(np.arange(32) / 3), 1e-3, "m/s^2", node=1,
                                                 direction=3)], binary=binary)
        out.append(path.read_bytes())
    return tuple(out)


def _project_base(tmp: Path) -> bytes:
    from odsuite.store.project import DerivedArray, create_project
    from odsuite.domain.systeminfo import ChannelInfo, Systeminfo

    path = tmp / "base.h5"
    with create_project(path, rig=None) as p:
        p.add_experiment("e", legacy_volts(64)[:, :3], sampling_rate=1000.0,
                         systeminfo=Systeminfo([ChannelInfo() for _ in range(3)]), excitation=None)
        p.write_derived("e", "v", {"v": DerivedArray(np.ones((64, 3)), "m/s", ("sample", "channel"))},
                        provenance={"plugin": "test"})
    return path.read_bytes()


def _read_ctr(path: Path) -> None:
    from odsuite_plugins.importers.legacy import read_ctr

    read_ctr(path).validate(source=path)


def _read_dat(path: Path) -> None:
    from odsuite_plugins.importers.legacy import read_dat

    read_dat(path, n_channels=11, sampling_rate=20_000.0)


def _read_uff(path: Path) -> None:
    from odsuite_plugins.importers.uff import read_uff

    read_uff(path)


def _read_project(path: Path) -> None:
    from odsuite.store.project import open_project

    with open_project(path) as p:
        p.info()
        for name in p.experiment_names():
            e = p.experiment(name)
            e.raw()
            for kind in p.derived_kinds(name):
                p.read_derived(name, kind)
                p.derived_info(name, kind)
        p.model_revisions()
        p.verify()


def _ctr_bases() -> tuple[bytes, ...]:
    from odsuite_plugins.importers.legacy import format_ctr, read_ctr

    table = TABLE_E3.read_bytes()
    return table, format_ctr(read_ctr(TABLE_E3)).encode()


#: what a table's file does not say (a file that says it wins where it may: a CSV's units, a .mat's rate)
TABLE_OPTIONS = {".npy": {"sampling_rate": 1000.0, "units": "m/s^2"}}
TABLE = np.round(legacy_volts(24)[:, :3], 4)


def _read_table(path: Path) -> None:
    from odsuite_plugins.importers.tables import read_columns

    read_columns(path, dict(TABLE_OPTIONS.get(path.suffix, {})))


def _csv_bases(tmp: Path) -> tuple[bytes, ...]:
    header = ["time [s]", "acc1 [m/s^2]", "acc2 [g]", "force [N]"]
    rows = [[f"{k / 1000:.3f}"] + [repr(float(v)) for v in r] for k, r in enumerate(TABLE.tolist())]
    comma = "\n".join(",".join(r) for r in [header] + rows) + "\n"
    # a decimal-comma locale's spreadsheet, as UTF-16 "Unicode text"
    semi = "\r\n".join(";".join(c.replace(".", ",") if k else c for k, c in enumerate(r))
                        for r in [header] + rows) + "\r\n"
    return comma.encode(), semi.encode("utf-16"), semi.encode()


def _npy_bases(tmp: Path) -> tuple[bytes, ...]:
    out = []
    for a in (TABLE, TABLE.astype(">f4").T, (TABLE * 1000).astype("<i2")):
        np.save(tmp / "b.npy", a)
        out.append((tmp / "b.npy").read_bytes())
    return tuple(out)


def _mat_bases(tmp: Path) -> tuple[bytes, ...]:
    import h5py
    import scipy.io

    variables = {"data": TABLE, "fs": 1000.0, "channels": np.array(["acc1", "acc2", "force"], dtype=object),
                 "units": np.array(["m/s^2", "g", "N"], dtype=object)}
    out = []
    for kw in ({}, {"do_compression": True}, {"format": "4"}):
        v = variables if kw.get("format") != "4" else {"data": TABLE, "fs": np.array([[1000.0]]), "units": "m/s^2"}
        scipy.io.savemat(tmp / "b.mat", v, **kw)
        out.append((tmp / "b.mat").read_bytes())
    # v7.3: HDF5 behind MATLAB's header, column-major, text as UTF-16 code units
    with h5py.File(tmp / "b.mat", "w", userblock_size=512) as f:
        f.create_dataset("data", data=TABLE.T)
        f.create_dataset("fs", data=[[1000.0]])
        f.create_dataset("units", data=np.array([[ord(c)] for c in "m/s^2"], dtype="u2"))
        f["units"].attrs["MATLAB_class"] = np.bytes_("char")
    with open(tmp / "b.mat", "r+b") as f:
        f.write(b"MATLAB 7.3 MAT-file".ljust(116) + bytes(8) + b"\x00\x02IM")
    out.append((tmp / "b.mat").read_bytes())
    return tuple(out)


def _tdms_bases(tmp: Path) -> tuple[bytes, ...]:
    from nptdms import ChannelObject, GroupObject, TdmsWriter

    path = tmp / "b.tdms"
    with TdmsWriter(str(path)) as w:
        # two segments: the second one's metadata refers back to the first one's
        for part in (TABLE[:12], TABLE[12:]):
            w.write_segment([GroupObject("Measurements")] + [
                ChannelObject("Measurements", n, part[:, k], properties={"unit_string": u, "wf_increment": 1e-3})
                for k, (n, u) in enumerate(zip(("acc1", "acc2", "force"), ("m/s^2", "g", "N")))])
    return (path.read_bytes(),)


REAL = Path(__file__).resolve().parents[1] / "data" / "real"


def _read_lvm(path: Path) -> None:
    from odsuite.store.project import create_project
    from odsuite_plugins.importers.columns import import_lvm
    from odsuite_plugins.importers.lvm import read_lvm

    read_lvm(path).records()  # what `odsuite import` does not call: the split by Samples
    project = path.with_name("lvm-import.h5")
    project.unlink(missing_ok=True)
    create_project(project, rig=None).close()
    import_lvm(project, path, "e")


def _lvm_bases(tmp: Path) -> tuple[bytes, ...]:
    """LADISK's beam and lvm_read's files (decimal comma, X_Columns Multi, no Decimal_Separator
    field), cut to 300 rows at most with Samples saying so (as the file's own header would)."""
    out = []
    for name in ("ladisk_beam_impact/acceleration.lvm", "lvm_read_impacts/long_single_header_multi_ch.lvm",
                 "lvm_read_impacts/short.lvm", "lvm_read_impacts/multi_time_column.lvm",
                 "lvm_read_impacts/no_decimal_separator.lvm"):
        lines = (REAL / name).read_bytes().splitlines(keepends=True)
        head = next(k for k, s in enumerate(lines) if s.startswith(b"X_Value")) + 1
        rows = [r for r in lines[head:] if r.strip()][:300]
        for k, s in enumerate(lines[:head]):
            if s.startswith(b"Samples"):
                cells = s.split(b"\t")
                lines[k] = b"\t".join(cells[:1] + [str(len(rows)).encode() if c.strip() else c for c in cells[1:]])
        out.append(b"".join(lines[:head] + rows))
    return tuple(out)


READERS = {
    "ctr": (_read_ctr, lambda tmp: _ctr_bases(), "x.CTR"),
    "dat": (_read_dat, lambda tmp: ("".join("\t".join(map(repr, r)) + "\n"
                                            for r in legacy_volts(40).tolist()).encode(),), "x.DAT"),
    "uff": (_read_uff, _uff_bases, "x.uff"),
    "csv": (_read_table, _csv_bases, "x.csv"),
    "npy": (_read_table, _npy_bases, "x.npy"),
    "mat": (_read_table, _mat_bases, "x.mat"),
    "tdms": (_read_table, _tdms_bases, "x.tdms"),
    "lvm": (_read_lvm, _lvm_bases, "x.lvm"),
    "project": (_read_project, lambda tmp: (_project_base(tmp),), "x.h5"),
    # format 1.0.0 kept text in HDF5's global heap: read first in a child process (~0.3 s a case)
    "project-1.0.0": (_read_project, lambda tmp: (FROZEN_1_0_0.read_bytes(),), "x.h5"),
}
#: readers that get 1/20 of the cases
SLOW = {"project-1.0.0"}
FROZEN_1_0_0 = Path(__file__).resolve().parents[1] / "data" / "back_compat" / "project-1.0.0.h5"


@pytest.mark.filterwarnings("ignore::odsuite.domain.errors.OdsuiteWarning")
@pytest.mark.parametrize("reader", list(READERS))
def test_corrupted_bytes_end_in_a_result_or_an_odsuite_error(reader, tmp_path):
    read, make_bases, name = READERS[reader]
    bases = make_bases(tmp_path)
    for base in bases:  # the unmutated files are valid
        (tmp_path / name).write_bytes(base)
        read(tmp_path / name)
    valid = tmp_path / f"valid{Path(name).suffix}"
    valid.write_bytes(bases[0])
    worker, counts, failures = Worker(read), Counter(), []
    limits = Limits(worker, valid)

    @settings(FUZZ, max_examples=max(EXAMPLES // 20, 5) if reader in SLOW else EXAMPLES)
    @given(corrupted(bases))
    def case(data):
        path = tmp_path / name
        path.write_bytes(data)
        outcome, message = limits.run(path)
        counts[outcome] += 1
        bad = outcome in ("other", "hang", "crash") or "\n" in message
        if path.read_bytes() != data:
            bad, message = True, "reading changed the file"
        if bad:
            failures.append(f"{outcome}: {message}")
            if keep := os.environ.get("FUZZ_KEEP"):
                Path(keep).mkdir(parents=True, exist_ok=True)
                (Path(keep) / f"{reader}-{len(failures)}{Path(name).suffix}").write_bytes(data)

    try:
        (seed(int(SEED))(case) if SEED else case)()
    finally:
        worker.close()
    print(f"\nfuzz {reader}: {sum(counts.values())} cases: "
          + ", ".join(f"{n} {k}" for k, n in counts.most_common()))
    assert not failures, f"{len(failures)} failing cases, first: {failures[0]}"


@pytest.mark.parametrize(("damage", "expected"), [
    (lambda f: f["experiments"]["e"].attrs.__delitem__("sampling_rate"),
     r"project file is damaged \(experiment 'e': .*sampling_rate"),
    (lambda f: f["experiments"]["e"]["derived"]["v"].attrs.__setitem__("parameters", "{not json"),
     r"project file is damaged \(experiment 'e' derived 'v': Expecting property name"),
    (lambda f: f["experiments"]["e"].__delitem__("systeminfo"),
     r"project file is damaged \(experiment 'e': .*systeminfo"),
])
def test_damaged_metadata_is_named(tmp_path, damage, expected):
    """Metadata a reader needs, removed or garbled behind odsuite's back: one line naming the
    experiment and derived group."""
    import h5py

    from odsuite.domain.errors import ProjectFileError

    path = tmp_path / "x.h5"
    path.write_bytes(_project_base(tmp_path))
    with h5py.File(path, "r+") as f:
        damage(f)
    before = path.read_bytes()
    with pytest.raises(ProjectFileError, match=expected) as info:
        _read_project(path)
    assert str(info.value).startswith(f"{path}: ") and "\n" not in str(info.value)
    assert path.read_bytes() == before
