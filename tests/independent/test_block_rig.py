"""A fifth rig, written from docs/rig-format.md alone, with its own simulator (block/blocksim.py,
which shares no code with rigsim or odsuite): a 60 kg block on three soft mounts and one stiff
pad, three triaxial accelerometers of three sensitivities and one single-axis sensor mounted
upside down, a 16-bit DAQ. Records go in as a user's CSV files of volts through `odsuite import`.

What issue 30 promises of the verdict, judged on it: records of the rig file itself leave nothing
to explain; a softer mount struck at 100 N is named as a stiffness."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import linalg

from .block import blocksim

SAMPLES = 2048  # 0.5 s at 4096 Hz: the slowest mode (22 Hz, 5 % damping) has died away by then


def _odsuite(capsys, *args) -> str:
    from odsuite.cli import main

    capsys.readouterr()
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    assert code == 0, out.err[-600:]
    return out.out


def _project(tmp_path, capsys, case, seed, peak, noise):
    """A project on the rig file with the case's four records imported and processed."""
    blows = blocksim.write_case(tmp_path / "rec", case, seed, peak, noise, samples=SAMPLES)
    project = tmp_path / "p.h5"
    _odsuite(capsys, "new", project, "--rig", blocksim.RIG_FILE)
    for b in blows:
        _odsuite(capsys, "import", project, b["file"], "--name", b["name"],
                 f"--force-point={b['point']}", f"--force-dir={b['dir']}")
    _odsuite(capsys, "process", project)
    return project


def _diagnose(capsys, project, *effects) -> dict:
    args = ["diagnose", project, "--json", "--workers", "1"]
    for e in effects:
        args += ["--effect", e]
    return json.loads(_odsuite(capsys, *args))


def test_simulator_modes_are_odsuite_models_modes(tmp_path, capsys):
    """The simulator's M, K, C (assembled here from the rig file by point maps) and odsuite's
    model of the same file: the same six damped modes, frequency and damping ratio."""
    M, K, C, _ = blocksim.system_matrices(blocksim.make_truth("null"))
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-linalg.solve(M, K), -linalg.solve(M, C)]])
    poles = linalg.eigvals(A)
    poles = poles[poles.imag > 0]
    poles = poles[np.argsort(np.abs(poles))]
    project = tmp_path / "p.h5"
    _odsuite(capsys, "new", project, "--rig", blocksim.RIG_FILE)
    modes = json.loads(_odsuite(capsys, "model", project, "--json"))["modes"]
    np.testing.assert_allclose([m["frequency_hz"] for m in modes], np.abs(poles) / (2 * np.pi),
                               rtol=1e-6)
    np.testing.assert_allclose([m["damping_ratio"] for m in modes], -poles.real / np.abs(poles),
                               rtol=1e-6)


def test_records_of_the_rig_itself_leave_nothing_to_explain_white_noise(tmp_path, capsys):
    """A null (the truth is the rig file exactly) under white ADC noise and a 50 Hz hum, blows of
    5-200 N, one a double hit: nothing to explain."""
    project = _project(tmp_path, capsys, "null", 1, None, "white")
    d = _diagnose(capsys, project, "stiffness")
    assert d["verdict"] == "nothing to explain", d["signature"]["cells"]


def test_records_of_the_rig_itself_leave_nothing_to_explain_lab_noise(tmp_path, capsys):
    """The same null under a lab's noise: white plus 1/f-like noise, hum at 50 and 150 Hz, an
    offset and a slow drift, 16-bit rounding."""
    project = _project(tmp_path, capsys, "null", 1, None, "lab")
    d = _diagnose(capsys, project, "stiffness")
    assert d["verdict"] == "nothing to explain", d["signature"]["cells"]


def test_a_softer_mount_struck_at_100_newton_is_named_a_stiffness(tmp_path, capsys):
    """Mount soft2 at 0.6 of its stiffness, every blow 100 N: the best significant candidate is a
    stiffness, and its fitted stiffness of soft2 along each axis is 0.6 of the rig file's (5 %),
    the other mounts' their own (10 %)."""
    project = _project(tmp_path, capsys, "soft", 101, 100.0, "lab")
    d = _diagnose(capsys, project, "stiffness", "spring_stiffness")
    significant = [c for c in d["candidates"] if c["significant"]]
    assert significant and significant[0]["effect"] == "spring_stiffness", d["candidates"][:2]
    fitted = {p["label"]: p["value"] / p["nominal"] for p in significant[0]["physical"]
              if p["label"].startswith("stiffness of ")}
    assert len(fitted) == 12
    for label, ratio in fitted.items():
        expected = 0.6 if "soft2" in label else 1.0
        assert ratio == pytest.approx(expected, rel=0.05 if expected < 1 else 0.1), label
