"""Fuzzing the readers with corrupted bytes of valid files (bytes flipped, inserted, deleted, the file
cut short): every case ends in a valid result or an OdsuiteError, never another exception or a hang,
and reading never changes the file.

``FUZZ_EXAMPLES`` sets the cases per reader (default 200; ``make fuzz`` runs 10 000).
"""

from __future__ import annotations

import os
import signal
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from odsuite.core.errors import OdsuiteError
from tests.reliability.harness import TABLE_E3, legacy_volts

EXAMPLES = int(os.environ.get("FUZZ_EXAMPLES", "200"))
CASE_TIMEOUT = 10.0  # s per case: longer is a hang
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                       HealthCheck.data_too_large])


@contextmanager
def time_limit(seconds: float):
    def hang(*_):
        raise TimeoutError(f"case still running after {seconds} s")

    old = signal.signal(signal.SIGALRM, hang)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


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


def _run(path: Path, read) -> None:
    before = path.read_bytes()
    try:
        with time_limit(CASE_TIMEOUT):
            read(path)
    except OdsuiteError as exc:
        assert "\n" not in str(exc), str(exc)
    assert path.read_bytes() == before


def _uff_bases(tmp: Path) -> tuple[bytes, ...]:
    from odsuite.core.uff import time_function, write_uff

    out = []
    for binary in (False, True):
        path = tmp / f"b{int(binary)}.uff"
        write_uff(path, functions=[time_function("acc", np.sin(np.arange(32) / 3), 1e-3, "m/s^2", node=1,
                                                 direction=3)], binary=binary)
        out.append(path.read_bytes())
    return tuple(out)


def _project_base(tmp: Path) -> bytes:
    from odsuite.core.project import DerivedArray, create_project
    from odsuite.core.systeminfo import ChannelInfo, Systeminfo

    path = tmp / "base.h5"
    with create_project(path, rig=None) as p:
        p.add_experiment("e", legacy_volts(64)[:, :3], sampling_rate=1000.0,
                         systeminfo=Systeminfo([ChannelInfo() for _ in range(3)]), excitation=None)
        p.write_derived("e", "v", {"v": DerivedArray(np.ones((64, 3)), "m/s", ("sample", "channel"))},
                        provenance={"plugin": "test"})
    return path.read_bytes()


def _read_ctr(path: Path) -> None:
    from odsuite.core.legacy import read_ctr

    read_ctr(path).validate(source=path)


def _read_dat(path: Path) -> None:
    from odsuite.core.legacy import read_dat

    read_dat(path, n_channels=11, sampling_rate=20_000.0)


def _read_uff(path: Path) -> None:
    from odsuite.core.uff import read_uff

    read_uff(path)


def _read_project(path: Path) -> None:
    from odsuite.core.project import open_project

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
    from odsuite.core.legacy import format_ctr, read_ctr

    table = TABLE_E3.read_bytes()
    return table, format_ctr(read_ctr(TABLE_E3)).encode()


READERS = {
    "ctr": (_read_ctr, lambda tmp: _ctr_bases(), "x.CTR"),
    "dat": (_read_dat, lambda tmp: ("".join("\t".join(map(repr, r)) + "\n"
                                            for r in legacy_volts(40).tolist()).encode(),), "x.DAT"),
    "uff": (_read_uff, _uff_bases, "x.uff"),
    "project": (_read_project, lambda tmp: (_project_base(tmp),), "x.h5"),
}


@pytest.mark.filterwarnings("ignore::odsuite.core.errors.OdsuiteWarning")
@pytest.mark.parametrize("reader", list(READERS))
def test_corrupted_bytes_end_in_a_result_or_an_odsuite_error(reader, tmp_path):
    read, make_bases, name = READERS[reader]
    bases = make_bases(tmp_path)
    for base in bases:  # the unmutated files are valid
        (tmp_path / name).write_bytes(base)
        read(tmp_path / name)

    @FUZZ
    @given(corrupted(bases))
    def case(data):
        path = tmp_path / name
        path.write_bytes(data)
        _run(path, read)

    case()


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

    from odsuite.core.errors import ProjectFileError

    path = tmp_path / "x.h5"
    path.write_bytes(_project_base(tmp_path))
    with h5py.File(path, "r+") as f:
        damage(f)
    before = path.read_bytes()
    with pytest.raises(ProjectFileError, match=expected) as info:
        _read_project(path)
    assert str(info.value).startswith(f"{path}: ") and "\n" not in str(info.value)
    assert path.read_bytes() == before
