"""Concurrency: one writer at a time (also through the CLI), readers only ever see complete
experiments while a writer adds them, and a lock left by a killed writer clears itself."""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from odsuite.cli import main
from odsuite.store.project import create_project, open_project
from odsuite.store.storage import CRASH_ENV
from tests.reliability.harness import ODSUITE

pytestmark = pytest.mark.filterwarnings("ignore::odsuite.domain.errors.OdsuiteWarning")

ROWS, CHANNELS, N_EXPERIMENTS = 20_000, 4, 12


def _expected(k: int) -> np.ndarray:
    """Experiment k's raw data: every value tells its experiment, row and channel."""
    return k + np.arange(ROWS)[:, None] * 1e-6 + np.arange(CHANNELS) * 1e-1


WRITER = textwrap.dedent(f"""
    import sys
    import numpy as np
    from odsuite.store.project import open_project
    from odsuite.domain.systeminfo import ChannelInfo, Systeminfo
    ROWS, CHANNELS = {ROWS}, {CHANNELS}
    def chunks(k):
        for r0 in range(0, ROWS, 2000):
            rows = np.arange(r0, min(r0 + 2000, ROWS))
            yield k + rows[:, None] * 1e-6 + np.arange(CHANNELS) * 1e-1
    with open_project(sys.argv[1], "a") as p:
        print("locked", flush=True)
        sys.stdin.readline()
        for k in range({N_EXPERIMENTS}):
            p.add_experiment(f"e{{k}}", chunks(k), n_samples=ROWS, sampling_rate=1000.0,
                             systeminfo=Systeminfo([ChannelInfo() for _ in range(CHANNELS)]), excitation=None)
""")


def test_second_writer_through_the_cli_gets_one_line(tmp_path, capsys):
    path = tmp_path / "p.h5"
    create_project(path).close()
    before = path.read_bytes()
    writer = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)
    try:
        assert writer.stdout.readline().strip() == "locked"
        second = subprocess.run([str(ODSUITE), "acquire", str(path), "--daq", "sim", "--name", "x"],
                                capture_output=True, text=True, timeout=120)
        assert second.returncode == 1
        assert second.stderr == (f"error: {path}: project is open in another process (pid {writer.pid}); "
                                 "close it there first\n")
        assert main(["process", str(path)]) == 1  # the same answer from every writing command
        assert capsys.readouterr().err.strip() == second.stderr.strip()
        assert main(["info", str(path)]) == 0  # readers are not blocked
    finally:
        writer.kill()
        writer.wait()
    assert path.read_bytes() == before


def test_reader_polling_sees_only_complete_experiments(tmp_path):
    path = tmp_path / "p.h5"
    create_project(path, rig=None).close()
    writer = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)
    assert writer.stdout.readline().strip() == "locked"
    writer.stdin.write("go\n")
    writer.stdin.flush()
    seen: list[int] = []
    checked: set[str] = set()
    while True:
        done = writer.poll() is not None
        with open_project(path) as p:
            names = p.experiment_names()
            assert names == [f"e{k}" for k in range(len(names))]  # in commit order, no gaps
            for name in names:
                e = p.experiment(name)
                assert (e.n_samples, e.n_channels) == (ROWS, CHANNELS)
                if name not in checked:  # every value of each experiment, once
                    np.testing.assert_array_equal(e.raw(), _expected(int(name[1:])))
                    checked.add(name)
            p.verify()
        seen.append(len(names))
        if done:
            break
    assert writer.returncode == 0
    assert seen[-1] == N_EXPERIMENTS
    assert len(set(seen)) >= 3, seen  # the reader really ran while experiments were being added


def test_lock_of_a_killed_cli_writer_is_cleared(tmp_path, caplog, capsys):
    path = tmp_path / "p.h5"
    create_project(path).close()
    env = {**os.environ, CRASH_ENV: "chunk-1"}  # SIGKILLed halfway through writing the record
    killed = subprocess.Popen([str(ODSUITE), "acquire", str(path), "--daq", "sim", "--name", "x"],
                              env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    assert killed.wait(timeout=120) == -signal.SIGKILL
    lock = path.with_name(".p.h5.odsuite-lock")
    assert lock.read_text().split()[:2] == ["odsuite-lock", str(killed.pid)]  # the dead writer's pid is left behind
    leftover = path.with_name(f".p.h5.odsuite-tmp-{killed.pid}")
    assert leftover.exists()
    with caplog.at_level(logging.WARNING, logger="odsuite.store.storage"):
        assert main(["acquire", str(path), "--daq", "sim", "--name", "x"]) == 0
    assert f"removing {leftover.name} left by an interrupted write" in caplog.text
    assert not leftover.exists()
    assert not lock.exists()  # released and removed
    with open_project(path) as p:
        assert p.experiment_names() == ["x"]
        assert p.verify() == {"x": 1}

