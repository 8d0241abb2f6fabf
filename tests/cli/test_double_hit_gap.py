"""A double hit said with the time between the blow's peak and the rebound's, in ms: a user reads
time, not samples."""

from __future__ import annotations

import json
import math
from pathlib import Path

from odsuite.cli import main
from tests.cli.test_partial_records import two_body_csv_project

RATE = 10240.0
BLOW, REBOUND = 100, 112  # peaks: 12 samples, 1.17 ms apart
REASON = "double hit 1.17 ms after its peak"


def _project(tmp_path: Path) -> Path:
    """A 10 N blow 7 samples long on the two-body machine's m1, a 4 N rebound 12 samples after it."""
    samples = [(10.0 * math.cos((k - BLOW) * math.pi / 8) if abs(k - BLOW) <= 3 else
                4.0 * math.cos((k - REBOUND) * math.pi / 8) if abs(k - REBOUND) <= 3 else 0.0,
                math.exp(-(k - BLOW) / 150) * math.sin((k - BLOW) / 5) if k >= BLOW else 0.0)
               for k in range(2048)]
    return two_body_csv_project(tmp_path, samples, RATE)


def test_frf_says_a_double_hits_gap_in_ms(tmp_path, capsys):
    p = _project(tmp_path)
    capsys.readouterr()
    assert main(["frf", str(p), "--experiment", "x"]) == 0
    captured = capsys.readouterr()
    assert f"hit at {BLOW / RATE:.4g} s (10 N): rejected: {REASON}" in captured.out
    # the only hit, flagged: used anyway, and the note names it the same way
    assert f"(hit at {BLOW / RATE:.4g} s: {REASON})" in captured.err
    assert main(["frf", str(p), "--experiment", "x", "--json"]) == 0
    (hit,) = json.loads(capsys.readouterr().out)["hits"]
    assert hit["reasons"] == [REASON]
    assert hit["double_hit_after_s"] == (REBOUND - BLOW) / RATE
