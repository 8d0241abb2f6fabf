"""Measured modes of a simulated null record against the model's own eigenvalues (the truth of a
record simulated from the model itself): the plate-and-motor rig's suspension modes at 10-30 Hz
and its plate modes at 80-200 Hz, from one 4096-sample hammer record at 2048 Hz (0.5 Hz lines)."""

import subprocess
import sys
from pathlib import Path

import numpy as np

from odsuite.analysis.modal_project import frf_modes, hits_frf
from odsuite.analysis.modelrev import revision_model
from odsuite.store.project import open_project

RIG = Path(__file__).resolve().parents[2] / "examples" / "rigs" / "plate-and-motor.toml"
ODSUITE = str(Path(sys.executable).with_name("odsuite"))


def test_plate_and_motor_null_record_modes_match_model(tmp_path):
    project = tmp_path / "null.h5"
    for cmd in (["new", str(project), "--rig", str(RIG)],
                ["acquire", str(project), "--name", "H2", "--force-point=-200,-100,75", "--force-dir=-z",
                 "--daq", "sim", "--seed", "2", "--force-peak", "200"]):
        subprocess.run([ODSUITE, *cmd], check=True, capture_output=True)
    with open_project(project) as p:
        truth = revision_model(p).shared.modes()
        frf, _ = hits_frf(p.experiment("H2"), "H2")
    res = frf_modes(frf)
    f_model, z_model = truth.frequency_hz, truth.damping_ratio
    # the modes this hit drives above the noise: three suspension modes and four plate modes
    for f_true in (19.61, 26.21, 30.46, 80.67, 94.07, 155.05, 194.04):
        k = int(np.argmin(np.abs(f_model - f_true)))
        assert abs(f_model[k] - f_true) < 0.01  # the rig's model is the one these numbers describe
        r = int(np.argmin(np.abs(res.frequency_hz - f_model[k])))
        assert abs(res.frequency_hz[r] / f_model[k] - 1) < 0.01
        assert abs(res.damping_ratio[r] / z_model[k] - 1) < 0.15
