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


def test_readme_prints_the_modes_table_modes_prints(tmp_path, capsys):
    # the README's table of the LADISK record's modes had gone stale (695.74 Hz, ζ 0.00458, 37
    # stable orders, no MPC column) while `modes` printed 695.73 Hz, 0.00462, "44 of 49" and MPC
    import re

    beam = tmp_path / "beam.h5"
    assert main(["new", str(beam), "--rig", "none"]) == 0
    assert main(["import-lvm", str(beam), str(DATA / "acceleration.lvm"), "--name", "hit1"]) == 0
    capsys.readouterr()
    assert main(["modes", str(beam), "--experiment", "hit1", "--json"]) == 0
    modes = json.loads(capsys.readouterr().out)["modes"]
    row = r"│ (\d+) +│ ([0-9.]+) +│ ([0-9.]+) +│ (\d+) of \d+ +│ ([0-9.]+) +│"
    printed = re.findall(row, (REPO / "README.md").read_text().split("modes of hit1 (1.0-4928.0 Hz)")[1][:1200])
    assert [(int(k), float(f), float(z), int(n), float(m)) for k, f, z, n, m in printed] == [
        (k + 1, round(m["frequency_hz"], 2), round(m["damping_ratio"], 5), m["stable_orders"], round(m["mpc"], 3))
        for k, m in enumerate(modes)]
