"""SIGKILL at seeded random moments across the writing CLI commands (see harness.py): the project
always opens, earlier experiments stay bit-identical, and nothing half-written is ever visible."""

from __future__ import annotations

import shutil
import sys
import textwrap

import pytest

from tests.reliability import harness
from tests.reliability.harness import WRITING_COMMANDS, WritingCommand, run_kills

pytestmark = pytest.mark.filterwarnings("ignore::odsuite.domain.errors.OdsuiteWarning")


@pytest.fixture(scope="module")
def seeded(tmp_path_factory):
    """A project with earlier experiments (and its inputs); each test works on its own copy."""
    work = tmp_path_factory.mktemp("seeded")
    inputs = harness.prepare_inputs(work / "inputs")
    return harness.seed_project(work / "p.h5", inputs), inputs


@pytest.fixture
def project(seeded, tmp_path):
    path = tmp_path / "p.h5"
    shutil.copyfile(seeded[0], path)
    return path


def test_kills_across_writing_commands(project, seeded, tmp_path):
    report = run_kills(project, seeded[1], tmp_path / "scratch", 8, seed=8, modes=("point", "write"),
                       timings={c.name: (5.0, 0.4) for c in WRITING_COMMANDS})
    assert [r.problems for r in report.runs] == [[]] * 8, report.summary()
    assert report.lost == 0
    assert {r.command for r in report.runs} == {c.name for c in harness.available(WRITING_COMMANDS, seeded[1])}
    # the seed puts kills before and after the commit point: both outcomes are exercised
    assert any(r.killed and not r.changed for r in report.runs)
    assert any(r.killed and r.changed for r in report.runs)
    assert any(r.recovered for r in report.runs)


def test_kills_in_the_model_loop(tmp_path_factory, tmp_path):
    """add-effect (fit, then one commit of the new revision) killed at crash points and at random
    moments: the project opens, earlier revisions and experiments stay bit-identical."""
    work = tmp_path_factory.mktemp("loop")
    project = harness.seed_loop_project(work / "p.h5")
    report = run_kills(project, harness.prepare_inputs(work / "inputs"), tmp_path / "scratch", 4, seed=1,
                       commands=harness.LOOP_COMMANDS, modes=("point", "write"))
    assert [r.problems for r in report.runs] == [[]] * 4, report.summary()
    assert report.lost == 0
    assert any(r.killed and not r.changed for r in report.runs)


# Deliberately unsafe writers: they change the project in place and kill themselves halfway
# when the crash variable is set. The harness must see the damage.
UNSAFE = textwrap.dedent("""
    import os, signal, sys
    import h5py
    path, what = sys.argv[1], sys.argv[2]
    crash = bool(os.environ.get("ODSUITE_TEST_CRASH_AT"))
    with h5py.File(path, "r+", locking=False) as f:
        if what == "overwrite":
            raw = f["experiments/old-T1/raw"]
            raw[: raw.shape[0] // 2] = 0.0
        else:
            ds = f["experiments"].create_group(what).create_dataset("raw", shape=(1000, 3), fletcher32=True)
            ds[:500] = 1.0
            if what == "open" and crash:  # killed with the file open: HDF5 marks it in use
                f.flush()
                os.kill(os.getpid(), signal.SIGKILL)
    if crash:  # killed between two complete writes of one experiment
        os.kill(os.getpid(), signal.SIGKILL)
    with h5py.File(path, "r+", locking=False) as f:
        if what != "overwrite":
            f["experiments"][what]["raw"][500:] = 2.0
""")


@pytest.mark.parametrize("what, found", [
    ("overwrite", "committed units changed or lost: ['experiments/old-T1']"),
    # verify reads each experiment as the readers do: the half-written one, without its attributes
    ("half", "project does not open or verify after the kill: ProjectFileError: "),
    ("open", "project does not open or verify after the kill: ProjectFileError: "),
])
def test_harness_sees_an_unsafe_writer(project, seeded, tmp_path, what, found):
    unsafe = WritingCommand("unsafe", lambda c: [str(c.project), what], program=(sys.executable, "-c", UNSAFE))
    report = run_kills(project, seeded[1], tmp_path / "scratch", 1, seed=0, commands=[unsafe], modes=("point",))
    assert [p for p in report.runs[0].problems if p.startswith(found) and (what != "half" or "experiment 'half'" in p)], \
        report.runs[0].problems
    assert report.survived == 0
    assert report.lost == (1 if what == "overwrite" else 0)


@pytest.mark.slow
def test_stress_100_kills(project, seeded, tmp_path, capsys):
    report = run_kills(project, seeded[1], tmp_path / "scratch", 100, seed=2024)
    with capsys.disabled():
        print(f"\nkill stress: {report.summary()}; timings (total s, write window s): "
              f"{ {k: tuple(round(x, 2) for x in v) for k, v in report.timings.items()} }")
    assert [r for r in report.runs if r.problems] == []
    assert report.lost == 0
