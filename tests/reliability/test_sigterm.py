"""SIGTERM is answered like Ctrl-C: one line, exit 128 + 15, locks and working copies removed; a
catalogue query running inside SQLite stops at it (and at Ctrl-C) instead of at its end."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ODSUITE = str(Path(sys.executable).with_name("odsuite"))
ENDLESS = "WITH RECURSIVE c(x) AS (SELECT 1 UNION ALL SELECT x + 1 FROM c) SELECT count(*) FROM c"


def _signalled(argv: list[str], cwd: Path, signum: int, after: float) -> tuple[int, str, float]:
    proc = subprocess.Popen([ODSUITE, *argv], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    time.sleep(after)
    sent = time.monotonic()
    os.killpg(proc.pid, signum)
    try:
        _, err = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail(f"{argv[0]} still running 30 s after signal {signum}")
    return proc.returncode, err, time.monotonic() - sent


@pytest.mark.parametrize("signum, code, line", [(signal.SIGTERM, 143, "terminated (SIGTERM): nothing stored"),
                                                (signal.SIGINT, 130, "interrupted: nothing stored")])
def test_signal_stops_an_endless_catalogue_query(tmp_path, signum, code, line):
    subprocess.run([ODSUITE, "catalog", "."], cwd=tmp_path, check=True, capture_output=True)
    rc, err, took = _signalled(["catalog", "query", ".", ENDLESS, "--seconds", "600"], tmp_path, signum, 4.0)
    assert (rc, err) == (code, line + "\n")
    assert took < 10


def test_sigterm_during_acquire_leaves_no_lock_or_copy(tmp_path):
    subprocess.run([ODSUITE, "new", "p.h5"], cwd=tmp_path, check=True, capture_output=True)
    before = (tmp_path / "p.h5").read_bytes()
    rc, err, _ = _signalled(["acquire", "p.h5", "--name", "n", "--samples", "1000000", "--pretrigger", "100"],
                            tmp_path, signal.SIGTERM, 5.0)
    names = sorted(p.name for p in tmp_path.iterdir())
    if rc == 0 or "of memory are free" in err:  # finished before the signal, or a busy machine
        pytest.skip(f"acquire not running at the signal: {err.strip() or 'finished within 5 s'}")
    assert rc == 143 and err.startswith("terminated (SIGTERM): ") and err.count("\n") == 1, err
    assert names == ["p.h5"], names
    assert (tmp_path / "p.h5").read_bytes() == before or "stored n" in err
