"""An FRF matrix across experiments (a roving hammer on the exact 3-DOF system): `modes` with
several --experiment options against the exact poles and shapes, and the MAC figure."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "core"))
import mck_threedof as mck  # noqa: E402

from odsuite.cli import main  # noqa: E402
from odsuite.analysis.modal import mac  # noqa: E402
from odsuite.store.project import open_project  # noqa: E402
from odsuite.domain.excitation import Excitation  # noqa: E402
from odsuite.domain.systeminfo import ChannelInfo, SensorType, Systeminfo  # noqa: E402

FS = 1024.0


@pytest.fixture(scope="module")
def roving(tmp_path_factory):
    """Three experiments, the hammer on mass 1, 2 and 3 in turn (four hits each), the three
    accelerometers fixed; 1e-5 relative noise on every channel."""
    p = tmp_path_factory.mktemp("roving") / "r.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    rng = np.random.default_rng(5)
    chans = ([ChannelInfo(sensor_type=SensorType.LOADCELL, location="hammer", sampling_rate=FS, limit_high=1e3,
                          limit_low=-1e3)]
             + [ChannelInfo(sensor_type=SensorType.ACCELEROMETER, location=f"a{k + 1}", sampling_rate=FS,
                            limit_high=1e4, limit_low=-1e4) for k in range(3)])
    with open_project(p, "a") as proj:
        for dof in range(3):
            amps = [100.0, 70.0, 130.0, 90.0]
            f, a = mck.simulate(FS, 8 * len(amps) + 0.1, [(0.1 + 8 * k, 0.004, v) for k, v in enumerate(amps)],
                                input_dof=dof)
            data = np.column_stack([f, a])
            data = data + 1e-5 * np.abs(data).max(axis=0) * rng.standard_normal(data.shape)
            proj.add_experiment(f"hit{dof + 1}", data, sampling_rate=FS, systeminfo=Systeminfo(chans),
                                excitation=Excitation(0, np.array([0.0, 0.0, float(dof)]), np.array([0.0, 0.0, 1.0])),
                                channel_names=["hammer", "a1", "a2", "a3"])
    return p


def test_roving_hammer_matrix_gives_the_exact_modes(roving, tmp_path, capsys):
    lam, phi = mck.modes()
    capsys.readouterr()
    args = ["modes", str(roving), "--experiment", "hit1", "--experiment", "hit2", "--experiment", "hit3",
            "--fmin", "5", "--fmax", "200", "--max-order", "30", "--json", "--mac-figure", str(tmp_path / "mac.png")]
    assert main(args) == 0
    doc = json.loads(capsys.readouterr().out)
    f = np.array([m["frequency_hz"] for m in doc["modes"]])
    np.testing.assert_allclose(f, np.abs(lam) / (2 * np.pi), rtol=1e-3)
    zeta = np.array([m["damping_ratio"] for m in doc["modes"]])
    np.testing.assert_allclose(zeta, -lam.real / np.abs(lam), rtol=0.02)
    rows = list(doc["modes"][0]["shape"])
    assert rows == [f"a{o} @ hit{e}" for e in (1, 2, 3) for o in (1, 2, 3)]
    assert doc["references"]["hit3"]["point_m"] == [0.0, 0.0, 2.0]
    shapes = np.array([[complex(*m["shape"][r]) for r in rows] for m in doc["modes"]]).T
    # roving: the accelerometer on mass 1 over the three hit points is the mode shape (reciprocity)
    roving_a1 = shapes[[rows.index(f"a1 @ hit{e}") for e in (1, 2, 3)]]
    assert np.diag(mac(roving_a1, phi)).min() > 0.99
    # and so is every hit's column of accelerometers
    for e in (1, 2, 3):
        fixed = shapes[[rows.index(f"a{o} @ hit{e}") for o in (1, 2, 3)]]
        assert np.diag(mac(fixed, phi)).min() > 0.99
    assert (tmp_path / "mac.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_matrix_needs_distinct_experiments_and_output_only_one(roving, capsys):
    capsys.readouterr()
    assert main(["modes", str(roving), "--experiment", "hit1", "--experiment", "hit1"]) == 1
    assert "an experiment is named twice in hit1, hit1" in capsys.readouterr().err
    assert main(["modes", str(roving), "--experiment", "hit1", "--experiment", "hit2", "--output-only"]) == 1
    # several --output-only records are setups merged through reference channels: the same
    # channels in both leave nothing roving (docs/modal.md)
    assert "setup 'hit1' has only the reference channels" in capsys.readouterr().err


def test_a_failing_matrix_fit_stores_nothing_and_a_passing_one_every_frf(roving, tmp_path, capsys):
    """The experiments' FRFs are stored only once the fit passed, all in one commit (they were
    stored before the fit, so a failing `modes` changed the project)."""
    import shutil

    p = tmp_path / "r.h5"
    shutil.copyfile(roving, p)
    before = p.read_bytes()
    capsys.readouterr()
    assert main(["modes", str(p), "--experiment", "hit1", "--experiment", "hit2", "--fmin", "5", "--fmax", "6"]) == 1
    assert "needs more" in capsys.readouterr().err
    assert p.read_bytes() == before
    assert main(["modes", str(p), "--experiment", "hit1", "--experiment", "hit2", "--fmin", "5", "--fmax", "200",
                 "--max-order", "30", "--json"]) == 0
    with open_project(p) as proj:
        assert all("frf" in proj.derived_kinds(e) for e in ("hit1", "hit2"))


def test_hits_whose_windows_differ_by_one_sample_make_one_matrix(tmp_path, capsys):
    """Two records of one rate and length whose hits lie one sample apart: the windows to the
    records' ends are 2m and 2m + 1 samples, the same count of lines on other frequencies, which
    was refused as 'other frequency lines' (only the counts were compared)."""
    p = tmp_path / "r.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    chans = ([ChannelInfo(sensor_type=SensorType.LOADCELL, location="hammer", sampling_rate=FS, limit_high=1e3,
                          limit_low=-1e3)]
             + [ChannelInfo(sensor_type=SensorType.ACCELEROMETER, location=f"a{k + 1}", sampling_rate=FS,
                            limit_high=1e4, limit_low=-1e4) for k in range(3)])
    rng = np.random.default_rng(7)
    f, a = mck.simulate(FS, 4.0, [(0.5, 0.004, 100.0)], input_dof=0)
    data = np.column_stack([f, a])
    data = data + 1e-5 * np.abs(data).max(axis=0) * rng.standard_normal(data.shape)
    with open_project(p, "a") as proj:
        for name, shift in (("late", 0), ("early", -1)):
            proj.add_experiment(name, np.roll(data, shift, axis=0), sampling_rate=FS, systeminfo=Systeminfo(chans),
                                excitation=Excitation(0, np.zeros(3), np.array([0.0, 0.0, 1.0])),
                                channel_names=["hammer", "a1", "a2", "a3"])
    capsys.readouterr()
    assert main(["modes", str(p), "--experiment", "early", "--experiment", "late", "--fmin", "5", "--fmax", "200",
                 "--max-order", "30", "--json"]) == 0, capsys.readouterr().err
    doc = json.loads(capsys.readouterr().out)
    lam, _ = mck.modes()
    np.testing.assert_allclose([m["frequency_hz"] for m in doc["modes"]], np.abs(lam) / (2 * np.pi), rtol=1e-3)
