"""A response still ringing at the end of its hit's record: assess_hits noted it for each hit, and
no command printed it. frf, modes, process and compare now say it once per record, naming the hits
by their time and the channels with the most of their peak they kept."""

from __future__ import annotations

import json
import math
from pathlib import Path

from odsuite.cli import main
from tests.cli.test_partial_records import two_body_csv_project

RATE = 10240.0
SAMPLES = 2048
HIT = 100
#: the record runs from 20 samples before the hit to the data's end (1968 samples); its last 39
#: samples are the tail judged, whose largest crest, 1910 samples after the hit, is at 3 % of the
#: first (10 samples after it): the decay's time constant
TAU = 1900 / math.log(100 / 3)
NOTE = (f"hit at {HIT / RATE:.4g} s: still ringing at the end of its record: m1_x at 3.0 %, m1_y at 3.0 %, m1_z "
        "at 3.0 % of their peaks (leakage: the FRFs' peaks read wider, as if more damped; record longer after each "
        "hit, or hit less often)")


def _project(tmp_path: Path) -> Path:
    """One 10 N blow 7 samples long on the two-body machine's m1, which rings at 256 Hz (crests
    every 20 samples) along x, y and z."""
    samples = [(10.0 * math.cos((k - HIT) * math.pi / 8) if abs(k - HIT) <= 3 else 0.0,
                math.exp(-(k - HIT) / TAU) * math.sin((k - HIT) * math.pi / 20) if k >= HIT else 0.0)
               for k in range(SAMPLES)]
    return two_body_csv_project(tmp_path, samples, RATE)


def test_frf_modes_and_process_say_a_records_leakage_once(tmp_path, capsys):
    p = _project(tmp_path)
    capsys.readouterr()
    assert main(["frf", str(p), "--experiment", "x"]) == 0
    captured = capsys.readouterr()
    assert f"hit at {HIT / RATE:.4g} s (10 N): accepted" in captured.out  # was "hit at sample 100"
    assert [line for line in captured.err.splitlines() if "ringing" in line] == [f"note: {p}: experiment 'x': {NOTE}"]
    assert main(["frf", str(p), "--experiment", "x", "--json"]) == 0
    (hit,) = json.loads(capsys.readouterr().out)["hits"]
    assert hit["sample"] == HIT and hit["time_s"] == HIT / RATE
    assert main(["modes", str(p), "--experiment", "x"]) == 0
    assert [line for line in capsys.readouterr().err.splitlines() if "ringing" in line] == [
        f"note: {p}: experiment 'x': {NOTE}"]
    assert main(["process", str(p)]) == 0
    assert [line for line in capsys.readouterr().err.splitlines() if "ringing" in line] == [f"note (x): {NOTE}"]


def test_compare_says_a_records_leakage_once_whether_its_modes_are_stored_or_not(tmp_path, capsys):
    # frf, modes and process said it; compare, identifying the same record's modes, did not
    p = _project(tmp_path)
    for stored in (False, True):  # the modes compare identifies, then those process stored
        if stored:
            assert main(["process", str(p)]) == 0
        capsys.readouterr()
        assert main(["compare", str(p), "--json"]) == 0
        doc = json.loads(capsys.readouterr().out)
        assert [n for n in doc["modal_notes"] if "ringing" in n] == [f"x: {NOTE}"]
        assert not [n for n in doc["notes"] if "ringing" in n]
        assert main(["compare", str(p)]) == 0
        out = " ".join(capsys.readouterr().out.split())  # its notes wrap at the terminal's width
        assert out.count("still ringing") == 1 and f"x: {NOTE}" in out
