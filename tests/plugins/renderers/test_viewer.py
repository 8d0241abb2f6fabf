"""The report's interactive 3-D view: its data are the posed plate corners, and in headless
Chromium it loads without console errors, draws on the canvas, and scrubbing, switching the model
off and rotating each change the picture."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from odsuite_plugins.renderers.viewer import viewer_data, viewer_html

CHROMIUM = Path("/usr/bin/chromium")
FS = 20000.0


def motion(n: int, scale: float = 1.0) -> dict[str, np.ndarray]:
    t = np.arange(n) / FS
    d = np.zeros((n, 6))
    d[:, 2] = scale * 2e-6 * np.exp(-60 * t) * np.sin(2 * np.pi * 150 * t)
    d[:, 3] = scale * 3e-5 * np.exp(-60 * t) * np.sin(2 * np.pi * 220 * t)
    return {"platform": d}


def test_viewer_data_are_the_posed_corners(thesis_rig):
    from odsuite.domain.rigidbody import body_corners, plate_corners

    coords = motion(3000)
    data = viewer_data(thesis_rig, coords, FS, start=1000, stop=2500, time_zero=0.05, magnify=(2000.0, 2000.0),
                       frames=100)
    k = 37  # frame 37 is sample 1000 + 37 * 15
    d = coords["platform"][1000 + 37 * 15].copy()
    d *= 2000.0
    want = 1e3 * body_corners(thesis_rig.body("platform"), d)
    assert np.allclose(np.reshape(data["measured"][0][k], (8, 3)), want, atol=1e-3)
    assert data["t_ms"][k] == pytest.approx(1e3 * ((1000 + 37 * 15) / FS - 0.05))
    assert np.allclose(np.reshape(data["rest"][0], (8, 3)), 1e3 * plate_corners(thesis_rig.body("platform").plate),
                       atol=5e-4)  # stored to 1 um
    assert len(data["still"]) == 2 and data["model"] is None
    assert data["magnification"] == "motion drawn 2,000 times larger than it is"


@pytest.mark.render
def test_viewer_works_in_chromium(thesis_rig, tmp_path):
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} not found: `apt-get update && apt-get install -y chromium` to test the 3-D view")
    data = viewer_data(thesis_rig, motion(2000), FS, model_coords=motion(2000, 0.7), time_zero=0.0)
    page = tmp_path / "viewer.html"
    page.write_text(f'<!DOCTYPE html><html><head><meta charset="utf-8"></head><body>{viewer_html(data)}</body></html>')
    run = subprocess.run(
        [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         f"--user-data-dir={tmp_path / 'profile'}", "--enable-logging=stderr", "--v=0",
         "--virtual-time-budget=5000", "--dump-dom", page.resolve().as_uri() + "#selftest"],
        capture_output=True, text=True, timeout=180, check=False)
    assert run.returncode == 0, run.stderr[-2000:]
    console = [ln for ln in run.stderr.splitlines() if ":CONSOLE" in ln or "Uncaught" in ln]
    assert not console, console
    m = re.search(r'<pre id="viewer-selftest">(.*?)</pre>', run.stdout, flags=re.DOTALL)
    assert m, "the view's self-test did not run: " + run.stdout[-500:]
    report = json.loads(m.group(1).replace("&quot;", '"').replace("&amp;", "&"))
    assert report["errors"] == []
    assert report["first"]["ink"] > 5000  # plates drawn on the 960 x 540 canvas
    assert report["frame"] > 0 and report["scrubbed"]["hash"] != report["first"]["hash"]
    assert report["label"].endswith("ms from the hit")
    # the model's translucent band covers more pixels than the measured line alone
    assert report["model_off"]["ink"] < 0.8 * report["scrubbed"]["ink"]
    assert report["rotated"]["hash"] != report["model_off"]["hash"]


@pytest.mark.render
def test_viewer_switches_the_corrected_motion(thesis_rig, tmp_path):
    """Recorded, corrected and model motion: the corrected set is posed like the others, and in
    Chromium switching it off takes its green line off the canvas."""
    corrected = motion(2000, 1.3)
    data = viewer_data(thesis_rig, motion(2000), FS, model_coords=motion(2000, 0.7), time_zero=0.0,
                       corrected_coords=corrected, magnify=(2000.0, 2000.0))
    from odsuite.domain.rigidbody import body_corners

    want = 1e3 * body_corners(thesis_rig.body("platform"), 2000.0 * corrected["platform"][0])
    assert np.allclose(np.reshape(data["corrected"][0][0], (8, 3)), want, atol=1e-3)
    html_text = viewer_html(data)
    assert 'class="v-corrected"' in html_text and 'class="v-measured"' in html_text
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} not found")
    page = tmp_path / "viewer.html"
    page.write_text(f'<!DOCTYPE html><html><head><meta charset="utf-8"></head><body>{html_text}</body></html>')
    run = subprocess.run(
        [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
         f"--user-data-dir={tmp_path / 'profile'}", "--virtual-time-budget=5000", "--dump-dom",
         page.resolve().as_uri() + "#selftest"], capture_output=True, text=True, timeout=180, check=False)
    m = re.search(r'<pre id="viewer-selftest">(.*?)</pre>', run.stdout, flags=re.DOTALL)
    assert m, run.stdout[-500:]
    report = json.loads(m.group(1).replace("&quot;", '"').replace("&amp;", "&"))
    assert report["errors"] == []
    # model off, then corrected off: fewer inked pixels, and a different picture
    assert report["corrected_off"]["ink"] < report["model_off"]["ink"]
    assert report["corrected_off"]["hash"] != report["model_off"]["hash"]
