"""Default magnification and the Characteristic Forced Response instant against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from odsuite.domain.errors import ConfigError
from odsuite_plugins.renderers.motion import (characteristic_instant, contact_index,
                                              default_magnification)


def test_magnification_from_a_pure_translation(thesis_rig):
    d = np.zeros((50, 6))
    d[:, 2] = 3e-6 * np.sin(np.linspace(0, 3, 50))
    ht, hr = default_magnification(thesis_rig, {"platform": d})
    # every corner moves by |z|; the platform's largest side is its width 169.93 mm
    assert ht == hr == pytest.approx(0.15 * 0.16993 / np.abs(d[:, 2]).max())


def test_magnification_from_a_pure_yaw(thesis_rig):
    d = np.zeros((2, 6))
    d[1, 5] = 2e-5
    ht, _ = default_magnification(thesis_rig, {"platform": d})
    plate = thesis_rig.body("platform").plate
    # yaw about G: the farthest corner in the x-y plane sweeps radius * angle
    xs = plate.corner[0] + np.array([0, plate.size[0]])
    ys = plate.corner[1] + np.array([0, plate.size[1]])
    radius = max(np.hypot(x, y) for x in xs for y in ys)
    assert ht == pytest.approx(0.15 * 0.16993 / (radius * 2e-5))


def test_cfr_is_the_first_peak_after_contact(thesis_rig):
    fs, n0 = 20000.0, 400
    t = np.arange(4000) / fs
    wn, zeta = 2 * np.pi * 180.0, 0.03
    wd = wn * np.sqrt(1 - zeta**2)
    tau = np.clip(t - n0 / fs, 0, None)
    z = 1e-6 * np.exp(-zeta * wn * tau) * np.sin(wd * tau)  # impulse response from sample n0
    d = np.zeros((t.size, 6))
    d[:, 2] = z
    force = np.zeros(t.size)
    force[n0:n0 + 8] = np.hanning(8) * 50
    contact = contact_index(force)
    assert contact == n0 + 1  # the Hann window's first sample is zero
    peak = characteristic_instant(thesis_rig, {"platform": d}, contact=contact)
    t_peak = np.arctan(wd / (zeta * wn)) / wd  # first maximum of the impulse response
    assert peak == pytest.approx(n0 + t_peak * fs, abs=1)


def test_no_motion_no_cfr(thesis_rig):
    with pytest.raises(ConfigError, match="do not move"):
        characteristic_instant(thesis_rig, {"platform": np.zeros((10, 6))})
    assert default_magnification(thesis_rig, {"platform": np.zeros((10, 6))}) == (1.0, 1.0)


def test_a_record_starting_at_its_hit_is_magnified_by_its_vibration(tmp_path, capsys):
    """A 2 kg bracket (tests/data/rigs/stiff-bracket.toml) recorded with no pre-trigger: its
    displacements carry the filters' slow start transient, 30x its 330-830 Hz vibration, and the
    default magnification (x144) made from it drew the vibration at a hundredth of the plate:
    two frames half a 330 Hz period apart in the ringing after the hit differed in a few pixels."""
    from pathlib import Path

    import h5py

    from odsuite.cli import main
    from odsuite.store.project import open_project
    from odsuite_plugins.renderers.motion import plate_scale
    from odsuite_plugins.renderers.scene import Scene

    rig_file = Path(__file__).resolve().parents[2] / "data" / "rigs" / "stiff-bracket.toml"
    p = tmp_path / "b.h5"
    for argv in (["new", p, "--rig", rig_file],
                 ["acquire", p, "--name", "hit30", "--samples", "8192", "--force-point=60mm,0,100mm",
                  "--force-dir=-z", "--force-peak", "30", "--seed", "1"],
                 ["process", p]):
        assert main([str(a) for a in argv]) == 0, capsys.readouterr().err
    with open_project(p) as project:
        rig = project.rig
    with h5py.File(p, "r") as f:
        d = f["experiments/hit30/derived/gencoords/bracket_at_g"][:]
    h = default_magnification(rig, {"bracket": d})
    # the drift drawn within a plate size
    body = rig.body("bracket")
    from odsuite.api import plate_corners, point_displacements
    drawn = np.linalg.norm(point_displacements(d, plate_corners(body.plate) - body.com, linear=True), axis=-1).max()
    assert h[0] * drawn <= 1.0001 * plate_scale(rig, ["bracket"])
    scene = Scene(rig, {"bracket": d[:400]}, magnify=h, axes=False, ghost=False, sensors=False, size=(640, 480))
    try:
        a, b = scene.frame(100).astype(int), scene.frame(139).astype(int)  # 39 samples: half a 330 Hz period
    finally:
        scene.close()
    moved = int((np.abs(a - b).sum(axis=-1) > 60).sum())
    assert moved > 1500, (h, moved)
