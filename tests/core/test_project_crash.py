"""Crash safety: a writer SIGKILLed anywhere in a large streamed import leaves the project readable,
every earlier experiment bit-identical and checksum-clean, and no half experiment."""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
from odsuite.store.project import create_project, open_project
from odsuite.store.storage import CRASH_ENV
from odsuite.domain.systeminfo import ChannelInfo, Systeminfo

ROWS, CHANNELS, CHUNK = 2_000_000, 11, 100_000

WRITER = textwrap.dedent("""
    import sys
    import numpy as np
    from odsuite.store.project import open_project
    from odsuite.domain.systeminfo import ChannelInfo, Systeminfo

    path, name, rows, channels, chunk = sys.argv[1], sys.argv[2], *map(int, sys.argv[3:6])
    def chunks():
        for r0 in range(0, rows, chunk):
            yield np.arange(r0, min(r0 + chunk, rows))[:, None] * 1e-6 + np.arange(channels) * 0.5
    with open_project(path, "a") as p:
        print("writing", flush=True)
        p.add_experiment(name, chunks(), n_samples=rows, sampling_rate=10_000.0,
                         systeminfo=Systeminfo([ChannelInfo() for _ in range(channels)]), excitation=None)
    print("done", flush=True)
""")


def _expected(r0, r1):
    return np.arange(r0, r1)[:, None] * 1e-6 + np.arange(CHANNELS) * 0.5


def _digests(p):
    return {n: hashlib.sha256(p.experiment(n).raw().tobytes()).hexdigest() for n in ("e1", "e2")}


def _run(path, name, *, crash_at=None, kill_after=None):
    env = dict(os.environ)
    env.pop(CRASH_ENV, None)
    if crash_at:
        env[CRASH_ENV] = crash_at
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path), name, str(ROWS), str(CHANNELS), str(CHUNK)],
                            env=env, stdout=subprocess.PIPE, text=True)
    if kill_after is not None:
        assert proc.stdout.readline().strip() == "writing"
        time.sleep(kill_after)
        proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=60)
    return proc.returncode


def test_sigkill_at_any_point_keeps_the_project_consistent(tmp_path):
    path = tmp_path / "p.h5"
    rng = np.random.default_rng(7)
    with create_project(path, rig=None) as p:
        for name in ("e1", "e2"):
            p.add_experiment(name, rng.normal(size=(50_000, CHANNELS)), sampling_rate=10_000.0,
                             systeminfo=Systeminfo([ChannelInfo() for _ in range(CHANNELS)]), excitation=None)
        before = _digests(p)
    # deterministic points of the write, then kills at arbitrary moments
    cases = [("copied", None), ("chunk-1", None), ("chunk-12", None), ("written", None), ("synced", None),
             (None, 0.05), (None, 0.4), ("replaced", None)]
    outcomes = []
    for i, (crash_at, kill_after) in enumerate(cases):
        name = f"big{i}"
        code = _run(path, name, crash_at=crash_at, kill_after=kill_after)
        with open_project(path) as p:  # readers ignore the killed writer's temp file
            assert _digests(p) == before
            assert p.verify()["e1"] == 1
            names = p.experiment_names()
            assert names[:2] == ["e1", "e2"]
            if name in names:  # present means complete
                e = p.experiment(name)
                assert e.n_samples == ROWS
                for r0 in range(0, ROWS, 500_000):
                    assert np.array_equal(e.raw(r0, r0 + 500_000), _expected(r0, r0 + 500_000))
        tmp_left = any(f.name.startswith(".p.h5.odsuite-tmp-") for f in tmp_path.iterdir())
        outcomes.append((crash_at or f"after {kill_after} s", code, name in names, tmp_left))
    by_case = {c: (present, tmp_left) for c, _, present, tmp_left in outcomes}
    for c in ("copied", "chunk-1", "chunk-12", "written", "synced"):
        assert by_case[c] == (False, True), c  # killed before the rename: absent, a temp file left
    assert by_case["replaced"] == (True, False)  # the rename is the commit point
    assert all(code == -signal.SIGKILL for c, code, _, _ in outcomes if not c.startswith("after")), outcomes
    # a killed writer cannot remove its lock file; the next writer takes it over and removes it
    with open_project(path, "a"):
        pass
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.h5"]  # each writer cleaned up, lock file too
