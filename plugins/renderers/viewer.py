"""An interactive 3-D view of the rig's motion and the model's for the HTML report: one <div> with a
canvas, its controls and an inline script, so the page still works offline from a single file.

Drag rotates, the wheel (or the +/- buttons) zooms, play/pause and the slider move through time,
a check box shows or hides the model. The plates' corners are computed here (magnified, rig
frame) and drawn by a few lines of canvas code: a WebGL library would be hundreds of kB inline for
twelve edges per plate. ``#selftest`` in the page address makes the script draw, scrub, switch the
model off, and write what it saw into ``<pre id="viewer-selftest">`` (the Chromium test reads it).
"""

from __future__ import annotations

import json
from collections.abc import Mapping

import numpy as np

from odsuite.api import Rig
from odsuite.api import plate_corners

from .motion import check_coords, corners, default_magnification, magnification_words, plate_scale
from .scene import EDGES, Style

#: About this many frames are embedded: smooth enough to scrub, small enough for the page.
VIEWER_FRAMES = 150


def _rgb(colour) -> str:
    return "rgb(" + ",".join(str(int(round(255 * c))) for c in colour) + ")"


def viewer_data(rig: Rig, coords: Mapping[str, np.ndarray], fs: float, *, start: int = 0, stop: int | None = None,
                model_coords: Mapping[str, np.ndarray] | None = None, time_zero: float | None = None,
                magnify: tuple[float, float] | None = None, frames: int = VIEWER_FRAMES,
                corrected_coords: Mapping[str, np.ndarray] | None = None) -> dict:
    """The viewer's data: posed corners (mm, rig frame) per frame of the window ``start:stop``
    (samples), still plates, edges, times (ms from ``time_zero`` s), colours and the magnification.
    ``corrected_coords``: the motion with the measurement's diagnosed distortions removed, drawn
    beside the recorded and the model's."""
    coords = check_coords(rig, coords)
    if model_coords is not None:
        model_coords = check_coords(rig, model_coords, "model_coords")
    if corrected_coords is not None:
        corrected_coords = check_coords(rig, corrected_coords, "corrected_coords")
    n = next(iter(coords.values())).shape[0]
    stop = n if stop is None else min(n, stop)
    step = max(1, (stop - start) // frames)
    picks = np.arange(start, stop, step)
    if magnify is None:
        magnify = default_magnification(rig, coords, *[c for c in (model_coords, corrected_coords) if c])

    def posed(c):
        return [np.round(1e3 * corners(rig.body(b), d[picks], magnify), 3).reshape(len(picks), -1).tolist()
                for b, d in c.items()]

    still = [np.round(1e3 * plate_corners(b.plate), 3).ravel().tolist() for b in rig.bodies
             if b.plate is not None and b.name not in coords]
    every = np.concatenate([plate_corners(b.plate) for b in rig.bodies if b.plate is not None])
    style = Style()
    t0 = 0.0 if time_zero is None else time_zero
    return {
        "edges": [list(e) for e in EDGES], "measured": posed(coords),
        "model": posed(model_coords) if model_coords is not None else None, "still": still,
        "corrected": posed(corrected_coords) if corrected_coords is not None else None,
        "rest": [np.round(1e3 * plate_corners(rig.body(b).plate), 3).ravel().tolist() for b in coords],
        "t_ms": np.round(1e3 * (picks / fs - t0), 3).tolist(), "from_hit": time_zero is not None,
        "centre_mm": (1e3 * (every.min(0) + every.max(0)) / 2).tolist(),
        "axes": _axes(rig),
        "size_mm": float(1e3 * np.ptp(every, axis=0).max()), "scale_mm": 1e3 * plate_scale(rig, list(coords)),
        "magnification": magnification_words(magnify),
        "colours": {"measured": _rgb(style.measured), "model": _rgb(style.model), "still": _rgb(style.static),
                    "corrected": _rgb(style.corrected),
                    "rest": _rgb(style.ghost)},
    }


def _axes(rig: Rig) -> dict:
    """The horizontal axes and up of the rig, and the frame's handedness seen from above: a
    camera's right is up x view direction, which is +e2 or -e2 at azimuth 0."""
    e1, e2 = rig.horizontal_axes()
    return {"e1": e1.tolist(), "e2": e2.tolist(), "up": rig.up.tolist(),
            "handed": float(np.sign(np.cross(rig.up, e1) @ e2))}


def viewer_html(data: Mapping, element_id: str = "viewer") -> str:
    """The <div> holding the canvas, the controls and the script for ``data`` (:func:`viewer_data`)."""
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    model = "" if data.get("model") is None else (
        '<label><input type="checkbox" class="v-model" checked> model (orange)</label>')
    if data.get("corrected") is not None:  # the switch between recorded, corrected and model motion
        model = ('<label><input type="checkbox" class="v-measured" checked> recorded (blue)</label> '
                 '<label><input type="checkbox" class="v-corrected" checked> corrected (green)</label> ' + model)
    return (f'<div id="{element_id}" class="viewer">'
            f'<canvas width="960" height="540" aria-label="interactive 3-D view of the motion"></canvas>'
            f'<div class="v-controls"><button type="button" class="v-play">play</button>'
            f'<input type="range" class="v-scrub" min="0" max="{len(data["t_ms"]) - 1}" value="0" step="1">'
            f'<span class="v-time"></span> {model}'
            f'<button type="button" class="v-zoom-in">+</button><button type="button" class="v-zoom-out">&minus;</button>'
            f'</div><p class="v-help">Drag to rotate, wheel or +/&minus; to zoom; {data["magnification"]}; '
            f'blue: measured' + (', green: corrected (diagnosed distortions removed)' if data.get("corrected") else '')
            + ', orange: model, dashed grey: rest position, light grey: still bodies.</p>'
            + inline_scripts(element_id, "v-data", payload, _SCRIPT))


#: the start every inline 3-D view's script shares: errors kept for its self-test, its data, its canvas
SCRIPT_PRELUDE = r"""
(function () {
  var errors = [];
  window.addEventListener('error', function (e) { errors.push(String(e.message)); });
  var root = document.getElementById('__ID__');
  var data = JSON.parse(root.querySelector('.__DATA__').textContent);
  var canvas = root.querySelector('canvas');
  var ctx = canvas.getContext('2d', { willReadFrequently: location.hash === '#selftest' });
  // drag to rotate, wheel or +/- to zoom (az, el, zoom, drag and draw are the view's own)
  function navigate(prefix) {
    root.querySelector('.' + prefix + '-zoom-in').addEventListener('click', function () { zoom *= 1.25; draw(); });
    root.querySelector('.' + prefix + '-zoom-out').addEventListener('click', function () { zoom /= 1.25; draw(); });
    canvas.addEventListener('wheel', function (e) {
      e.preventDefault(); zoom *= e.deltaY < 0 ? 1.1 : 1 / 1.1; draw();
    }, { passive: false });
    canvas.addEventListener('pointerdown', function (e) { drag = [e.clientX, e.clientY]; });
    window.addEventListener('pointerup', function () { drag = null; });
    canvas.addEventListener('pointermove', function (e) {
      if (!drag) return;
      az += 0.4 * (e.clientX - drag[0]); el = Math.max(-89, Math.min(89, el + 0.4 * (e.clientY - drag[1])));
      drag = [e.clientX, e.clientY]; draw();
    });
  }"""


def inline_scripts(element_id: str, data_class: str, payload: str, script: str) -> str:
    """A view's data and its script (the shared prelude, then ``script``), closing its element."""
    code = (SCRIPT_PRELUDE.replace("__DATA__", data_class) + script).replace("__ID__", element_id)
    return f'<script type="application/json" class="{data_class}">{payload}</script><script>{code}</script></div>'


# The drawing: the rig seen from azimuth/elevation (as the movie's view: azimuth in the horizontal
# plane from e1 towards e2, elevation towards up), orthographic.
_SCRIPT = r"""
  var scrub = root.querySelector('.v-scrub'), timeLabel = root.querySelector('.v-time');
  var play = root.querySelector('.v-play'), modelBox = root.querySelector('.v-model');
  var measuredBox = root.querySelector('.v-measured'), correctedBox = root.querySelector('.v-corrected');
  var az = 60, el = 25, zoom = 1, frame = 0, timer = null, drag = null;
  var c = data.centre_mm;

  function project(x, y, z) {
    var a = az * Math.PI / 180, e = el * Math.PI / 180;
    var d = [x - c[0], y - c[1], z - c[2]], ax = data.axes;
    function dot(u) { return u[0] * d[0] + u[1] * d[1] + u[2] * d[2]; }
    var h1 = dot(ax.e1), h2 = dot(ax.e2), v = dot(ax.up);
    // screen right: perpendicular to the view azimuth in the horizontal plane; screen up: up tilted by the elevation
    var sx = -Math.sin(a) * h1 + Math.cos(a) * h2;
    var depth = Math.cos(a) * h1 + Math.sin(a) * h2;
    var sy = v * Math.cos(e) - depth * Math.sin(e);
    var s = zoom * 1.05 * Math.min(canvas.width, canvas.height) / data.size_mm;
    return [canvas.width / 2 + ax.handed * s * sx, canvas.height / 2 - s * sy];
  }

  function plate(flat, colour, width, dash) {
    ctx.strokeStyle = colour; ctx.lineWidth = width; ctx.setLineDash(dash || []);
    ctx.beginPath();
    data.edges.forEach(function (e) {
      var p = project(flat[3 * e[0]], flat[3 * e[0] + 1], flat[3 * e[0] + 2]);
      var q = project(flat[3 * e[1]], flat[3 * e[1] + 1], flat[3 * e[1] + 2]);
      ctx.moveTo(p[0], p[1]); ctx.lineTo(q[0], q[1]);
    });
    ctx.stroke(); ctx.setLineDash([]);
  }

  function draw() {
    ctx.fillStyle = '#fff'; ctx.fillRect(0, 0, canvas.width, canvas.height);
    data.still.forEach(function (p) { plate(p, data.colours.still, 1); });
    data.rest.forEach(function (p) { plate(p, data.colours.rest, 1, [6, 4]); });
    if (data.model && (!modelBox || modelBox.checked)) {
      ctx.globalAlpha = 0.45;
      data.model.forEach(function (b) { plate(b[frame], data.colours.model, 7); });
      ctx.globalAlpha = 1;
    }
    if (data.corrected && (!correctedBox || correctedBox.checked)) {
      data.corrected.forEach(function (b) { plate(b[frame], data.colours.corrected, 3); });
    }
    if (!measuredBox || measuredBox.checked) {
      data.measured.forEach(function (b) { plate(b[frame], data.colours.measured, 2); });
    }
    var t = data.t_ms[frame];
    timeLabel.textContent = 't = ' + (data.from_hit && t >= 0 ? '+' : '') + t.toFixed(2) + ' ms' +
      (data.from_hit ? ' from the hit' : '');
  }

  function show(k) { frame = Math.max(0, Math.min(data.t_ms.length - 1, k)); scrub.value = frame; draw(); }
  scrub.addEventListener('input', function () { show(parseInt(scrub.value, 10)); });
  play.addEventListener('click', function () {
    if (timer) { clearInterval(timer); timer = null; play.textContent = 'play'; return; }
    play.textContent = 'pause';
    timer = setInterval(function () { show(frame + 1 < data.t_ms.length ? frame + 1 : 0); }, 40);
  });
  [modelBox, measuredBox, correctedBox].forEach(function (box) { if (box) box.addEventListener('change', draw); });
  navigate('v');
  draw();

  if (location.hash === '#selftest') {
    var fingerprint = function () {
      var px = ctx.getImageData(0, 0, canvas.width, canvas.height).data, h = 0, ink = 0;
      for (var i = 0; i < px.length; i += 4) {
        if (px[i] < 250 || px[i + 1] < 250 || px[i + 2] < 250) { ink++; h = (h * 31 + px[i] + 7 * px[i + 2] + i) % 1000000007; }
      }
      return { ink: ink, hash: h };
    };
    var peak = 0, best = -1;
    data.measured[0].forEach(function (_, k) {
      var f = data.measured[0][k], r = data.rest[0], d = 0;
      for (var i = 0; i < f.length; i++) d = Math.max(d, Math.abs(f[i] - r[i]));
      if (d > best) { best = d; peak = k; }
    });
    var report = { first: fingerprint() };
    show(peak); report.scrubbed = fingerprint(); report.frame = frame; report.label = timeLabel.textContent;
    if (modelBox) { modelBox.checked = false; draw(); report.model_off = fingerprint(); }
    if (correctedBox) { correctedBox.checked = false; draw(); report.corrected_off = fingerprint(); }
    az += 90; draw(); report.rotated = fingerprint();
    report.errors = errors;
    var out = document.createElement('pre'); out.id = 'viewer-selftest';
    out.textContent = JSON.stringify(report); document.body.appendChild(out);
  }
})();
"""
