"""The README's import examples run from a fresh clone on the files shipped in examples/data."""

from __future__ import annotations

import json

from odsuite.cli import main
from tests.conftest import REPO

DATA = REPO / "examples" / "data"


def test_legacy_and_lvm_examples_run_on_shipped_data(tmp_path, capsys):
    lab, beam = tmp_path / "lab.h5", tmp_path / "beam.h5"
    assert main(["new", str(lab)]) == 0
    assert main(["import", str(lab), str(DATA / "T2-sim.DAT"), "--systeminfo",
                 str(REPO / "plugins" / "models" / "rigs" / "thesis-table-e3.CTR"), "--name", "T2-legacy",
                 "--force-point=-0.795,79.089,-11.4", "--force-dir=+z"]) == 0
    assert main(["new", str(beam), "--rig", "none"]) == 0
    assert main(["import-lvm", str(beam), str(DATA / "acceleration.lvm"), "--name", "hit1"]) == 0
    capsys.readouterr()
    assert main(["modes", str(beam), "--experiment", "hit1", "--json"]) == 0
    modes = [m["frequency_hz"] for m in json.loads(capsys.readouterr().out)["modes"]]
    # the four modes the README prints for this record
    assert [round(f) for f in modes] == [696, 1898, 2778, 3671]
