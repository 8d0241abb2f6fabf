"""The interactive 3-D view of mode shapes: its data are the geometry's node motions (its own
documented rule) and a rig plate's small-motion corner displacements (translation + rotation x
arm), scaled to the drawn fraction; in headless Chromium it draws, and picking another mode,
stepping the phase and rotating each change the picture."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from odsuite_plugins.renderers.mode_view import mode_view_data, mode_view_html, rig_modes
from odsuite_plugins.renderers.shapes import DRAWN_FRACTION

CHROMIUM = Path("/usr/bin/chromium")


def test_rig_corners_move_by_translation_plus_rotation_cross_arm(thesis_rig):
    from odsuite.domain.rigidbody import plate_corners

    body = next(b for b in thesis_rig.bodies if b.plate is not None)
    q = np.array([1e-6, -2e-6, 0.5e-6, 3e-6j, 1e-5, -2e-6j])  # x, y, z (m), three small rotations (rad)
    nodes, lines, modes = rig_modes(thesis_rig, [{body.name: q}], ["m"])
    j = [b.name for b in thesis_rig.bodies if b.plate is not None].index(body.name)
    arm = plate_corners(body.plate) - body.com
    want = q[None, :3] + np.cross(np.broadcast_to(q[3:], arm.shape), arm)
    np.testing.assert_allclose(modes[0][1][8 * j:8 * j + 8], want, atol=1e-6 * np.abs(q).max())
    assert len(lines) == 12 * (len(nodes) // 8)


def test_view_data_scaled_to_the_drawn_fraction():
    nodes = np.array([[0.0, 0, 0], [0, 0, 4.0], [2.0, 0, 4.0]])
    U = np.array([[0, 0, 0], [1.0, 0, 0], [1.0, 0.5j, 0]])
    data = mode_view_data(nodes, [(0, 1), (1, 2)], [("a", U), ("b", 2j * U)], fixed=[0], sensors=[1])
    for m in data["modes"]:
        d = (np.array(m["re"]) + 1j * np.array(m["im"])).reshape(3, 3) / 1e3
        peak = max(np.linalg.svd(np.c_[u.real, u.imag], compute_uv=False)[0] for u in d)
        assert peak == pytest.approx(DRAWN_FRACTION * 4.0, rel=1e-3)
    assert data["size_mm"] == pytest.approx(4000.0)


@pytest.mark.render
def test_mode_view_works_in_chromium(tmp_path):
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} not found: `apt-get update && apt-get install -y chromium` to test the 3-D view")
    nodes = np.array([[0.0, 0, 0], [0, 0, 4.0], [2.0, 0, 4.0], [2.0, 0, 0]])
    sway = np.array([[0, 0, 0], [0, 1.0, 0], [0, 1.0, 0], [0, 0, 0]])
    twist = np.array([[0, 0, 0], [0, 1.0, 0], [0, -1.0, 0], [0, 0, 0]])
    data = mode_view_data(nodes, [(0, 1), (1, 2), (2, 3)], [("sway: 1.000 Hz", sway), ("twist: 2.000 Hz", twist)],
                          fixed=[0, 3], sensors=[1, 2])
    page = tmp_path / "modes.html"
    page.write_text(f'<!DOCTYPE html><html><head><meta charset="utf-8"></head><body>{mode_view_html(data)}</body></html>')
    run = subprocess.run(
        [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         f"--user-data-dir={tmp_path / 'profile'}", "--virtual-time-budget=3000", "--dump-dom",
         page.resolve().as_uri() + "#selftest"],
        capture_output=True, text=True, timeout=180, check=False)
    assert run.returncode == 0, run.stderr[-2000:]
    m = re.search(r'<pre id="mode-view-selftest">(.*?)</pre>', run.stdout, flags=re.DOTALL)
    assert m, run.stdout[-2000:]
    seen = json.loads(m.group(1))
    assert seen["errors"] == [] and seen["modes"] == 2 and seen["first"]["ink"] > 1000
    assert len({seen[k]["hash"] for k in ("first", "phased", "second", "rotated")}) == 4
    assert seen["label"] == "twist: 2.000 Hz"
