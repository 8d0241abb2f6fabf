"""A hammer hit on a record's last samples: its record set the length of every hit's (its few
samples after the pretrigger), and frf, process and compare said nothing of it. It is left out,
and each of them says so with the hit's time."""

from __future__ import annotations

import json
import math
from pathlib import Path

from odsuite.cli import main
from tests.cli.test_partial_records import two_body_csv_project

RATE = 10240.0
SAMPLES = 4096
HITS = (300, 2300, SAMPLES - 1)  # peaks; the last on the record's last sample
NOTE = f"hit at {(SAMPLES - 1) / RATE:.4g} s: left out: its "


def _project(tmp_path: Path) -> Path:
    """Three 10 N blows 7 samples long, each ringing at 326 Hz, on the two-body machine's m1."""
    samples = [(sum(10.0 * math.cos((k - h) * math.pi / 8) for h in HITS if abs(k - h) <= 3),
                sum(math.exp(-(k - h) / 150) * math.sin((k - h) / 5) for h in HITS if k >= h)) for k in range(SAMPLES)]
    return two_body_csv_project(tmp_path, samples, RATE)


def test_frf_process_and_compare_leave_out_a_hit_on_the_last_sample_and_say_so(tmp_path, capsys):
    p = _project(tmp_path)
    capsys.readouterr()
    assert main(["frf", str(p), "--experiment", "x", "--json"]) == 0
    out = capsys.readouterr()
    doc = json.loads(out.out)
    # the two others keep records as long as the closest pair's spacing: 1795 samples, 898 lines
    assert doc["n_averages"] == 2 and doc["lines"] == (HITS[2] - HITS[1]) // 2 + 1
    assert [h["accepted"] for h in doc["hits"]] == [True, True, False]
    assert [line for line in out.err.splitlines() if "left out" in line] == [
        f"note: {p}: experiment 'x': {NOTE}{(HITS[2] - HITS[1]) / RATE:.4g} s record runs past the data, "
        f"which end {1 / RATE:.4g} s after its peak"]
    for stored in (False, True):  # the modes compare identifies, then those process stored
        assert main(["compare", str(p), "--json"]) == 0
        notes = json.loads(capsys.readouterr().out)["modal_notes"]
        assert [n for n in notes if "left out" in n] == [f"x: {NOTE}{(HITS[2] - HITS[1]) / RATE:.4g} s record "
                                                         f"runs past the data, which end {1 / RATE:.4g} s after its peak"]
        if not stored:
            assert main(["process", str(p)]) == 0
            err = capsys.readouterr().err
            assert f"note (x): {NOTE}" in err
