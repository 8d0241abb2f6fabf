"""Movie rendering speed: odsuite's renderer against a bare pyvista loop, same boxes, same machine.

Three plates of the thesis rig (platform moving, base and reference plate still) at 1280 x 720,
drawn and encoded to H.264 MP4. The baseline is the plain single-process loop one would write
with pyvista's defaults: update the box, render, take a screenshot, pipe it into imageio-ffmpeg.
Prints frames per second of each and the ratios; run with ``.venv/bin/python bench/bench_render.py``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

FS = 20000.0
SIZE = (1280, 720)


def motion(n: int) -> dict[str, np.ndarray]:
    t = np.arange(n) / FS
    d = np.zeros((n, 6))
    env = np.exp(-40 * t)
    d[:, 2] = 2e-6 * env * np.sin(2 * np.pi * 150 * t)
    d[:, 3] = 3e-5 * env * np.sin(2 * np.pi * 220 * t)
    d[:, 5] = 1e-5 * env * np.sin(2 * np.pi * 190 * t)
    return {"platform": d}


def bare(rig, coords, path: Path, msaa: bool = True) -> float:
    """Frames per second of a plain pyvista loop with default settings (``msaa=False``: without
    pyvista's default multi-sample anti-aliasing, to show what that setting alone costs)."""
    import imageio_ffmpeg
    import pyvista as pv

    from odsuite.domain.rigidbody import plate_corners
    from odsuite_plugins.renderers.motion import corners, default_magnification

    mag = default_magnification(rig, coords)
    series = corners(rig.body("platform"), coords["platform"], mag)
    t0 = time.perf_counter()
    p = pv.Plotter(off_screen=True, window_size=SIZE)
    if not msaa:
        p.ren_win.SetMultiSamples(0)
    boxes = {}
    for body in rig.bodies:
        c = plate_corners(body.plate)
        box = pv.Box(np.column_stack([c.min(0), c.max(0)]).ravel())
        p.add_mesh(box, style="wireframe", line_width=2, color="navy" if body.name == "platform" else "gray")
        boxes[body.name] = box
    # map each box vertex to its Table 4.1 corner to pose it like odsuite does
    rest = plate_corners(rig.body("platform").plate)
    idx = [int(np.argmin(np.linalg.norm(rest - v, axis=1))) for v in boxes["platform"].points]
    text = p.add_text(" ", position="upper_left")
    p.camera_position = "iso"
    writer = imageio_ffmpeg.write_frames(str(path), SIZE, fps=25, macro_block_size=16)
    writer.send(None)
    for i in range(len(series)):
        boxes["platform"].points = series[i][idx]
        text.SetText(2, f"t = {1e3 * i / FS:.3f} ms")
        p.render()  # screenshot() alone returns the last rendered image
        img = p.screenshot(return_img=True)
        writer.send(np.ascontiguousarray(img))
    writer.close()
    p.close()
    return len(series) / (time.perf_counter() - t0)


def odsuite_fps(rig, coords, path: Path, workers: int) -> float:
    from odsuite_plugins.renderers.movie import render_movie

    t0 = time.perf_counter()
    res = render_movie(rig, coords, FS, path, size=SIZE, workers=workers, progress=False)
    return res.n_frames / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=400)
    args = ap.parse_args()
    from odsuite.contracts.plugins import registries

    rig = registries().rigs.get("thesis-dynamometer")
    coords = motion(args.frames)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        base = bare(rig, coords, tmp / "bare.mp4")
        no_msaa = bare(rig, coords, tmp / "bare_no_msaa.mp4", msaa=False)
        one = odsuite_fps(rig, coords, tmp / "one.mp4", workers=1)
        two = odsuite_fps(rig, coords, tmp / "two.mp4", workers=2)
    print(f"frames: {args.frames} at {SIZE[0]}x{SIZE[1]}, three plates, H.264 MP4 including encoding")
    print(f"bare pyvista loop (defaults, 1 process): {base:6.1f} fps")
    print(f"bare loop without MSAA:                  {no_msaa:6.1f} fps   ratio {no_msaa / base:4.2f}")
    print(f"odsuite, 1 process:                      {one:6.1f} fps   ratio {one / base:4.2f}")
    print(f"odsuite, 2 processes:                    {two:6.1f} fps   ratio {two / base:4.2f}")


if __name__ == "__main__":
    main()
