"""An interactive 3-D view of identified mode shapes for the HTML report (and as a page of its own):
the structure's nodes and lines, and per mode the nodes' complex motion, animated in the browser
as Re(U e^(i phase)) with a selector naming each mode's frequency, damping and MPC.

A structure is either a geometry (nodes and lines, ``odsuite.domain.geometry``) or a rig's plates
(each plate's eight corners, moved by the body's complex generalized coordinates). ``#selftest``
in the page address makes the script draw, pick the second mode, step the phase and rotate, and
write what it saw into ``<pre id="mode-view-selftest">`` (the Chromium test reads it).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence

import numpy as np

from odsuite.api import ConfigError, Geometry

from .scene import EDGES, Style
from .shapes import DRAWN_FRACTION
from .viewer import _rgb, inline_scripts


def mode_label(kind: str, source: str, k: int, f: float, z: float, mpc: float) -> str:
    """What the selector shows for one mode: units on every number."""
    return f"{kind} {source}: mode {k}, {f:.3f} Hz, damping {100 * z:.2f} %, MPC {mpc:.3f}"


def mode_view_data(nodes: np.ndarray, lines: Sequence[tuple[int, int]], modes: Sequence[tuple[str, np.ndarray]],
                   *, up: np.ndarray = np.array([0.0, 0.0, 1.0]), e1: np.ndarray = np.array([1.0, 0.0, 0.0]),
                   fixed: Sequence[int] = (), sensors: Sequence[int] = ()) -> dict:
    """The view's data: node rest positions (mm), lines (node index pairs), per mode its label and
    node motion (nodes x 3, complex) scaled so that its largest node excursion is
    ``shapes.DRAWN_FRACTION`` of the structure's extent (mm), the axes (``e1``, up) and colours."""
    nodes = np.asarray(nodes, dtype=float)
    size = float(np.ptp(nodes, axis=0).max()) or 1.0
    out = []
    for label, U in modes:
        U = np.asarray(U, dtype=complex).reshape(nodes.shape)
        # the largest excursion over a cycle, per node: the major semi-axis of its ellipse
        peak = max(float(np.linalg.svd(np.c_[u.real, u.imag], compute_uv=False)[0]) for u in U) if U.size else 0.0
        if not np.isfinite(peak) or peak == 0:
            continue  # a mode that moves no node has nothing to show
        U = U * (DRAWN_FRACTION * size / peak)
        out.append({"label": label, "re": np.round(1e3 * U.real, 2).ravel().tolist(),
                    "im": np.round(1e3 * U.imag, 2).ravel().tolist()})
    if not out:
        raise ConfigError("no mode shape moves any node of the structure: no mode to show")
    up = np.asarray(up, float) / np.linalg.norm(up)
    e1 = np.asarray(e1, float) - (np.asarray(e1, float) @ up) * up
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    style = Style()
    return {"nodes": np.round(1e3 * nodes, 2).ravel().tolist(), "lines": [[int(a), int(b)] for a, b in lines],
            "fixed": [int(k) for k in fixed], "sensors": [int(k) for k in sensors], "modes": out,
            "centre_mm": (1e3 * (nodes.min(0) + nodes.max(0)) / 2).tolist(), "size_mm": 1e3 * size,
            "axes": {"e1": e1.tolist(), "e2": e2.tolist(), "up": up.tolist(), "handed": 1.0},
            "drawn": f"largest motion drawn as {100 * DRAWN_FRACTION:.0f} % of the structure's {size:.3g} m",
            "colours": {"moving": _rgb(style.measured), "rest": _rgb(style.ghost), "fixed": _rgb(style.static),
                        "sensor": "rgb(0,150,60)"}}


def geometry_modes(geometry: Geometry, channels: Sequence[str], shapes: np.ndarray, labels: Sequence[str]
                   ) -> tuple[np.ndarray, list[tuple[int, int]], list[tuple[str, np.ndarray]], list[int], list[int]]:
    """Nodes (m), lines, (label, node motion) per mode, fixed and sensor node indices of mode
    shapes (channels x modes) spread over a geometry by its documented rule."""
    ids = [int(n) for n in geometry.node_ids]
    nodes = np.asarray(geometry.xyz, dtype=float)
    index = ids.index
    placed = set(geometry.channels)
    modes = [(lab, geometry.node_motion({c: v for c, v in zip(channels, shapes[:, k]) if c in placed}))
             for k, lab in enumerate(labels)]
    lines = [(index(a), index(b)) for a, b in geometry.lines]
    return nodes, lines, modes, [index(n) for n in geometry.fixed], sorted({index(s.node) for s in geometry.sensors})


def rig_modes(rig, coordinates: Sequence[Mapping[str, np.ndarray]], labels: Sequence[str]
              ) -> tuple[np.ndarray, list[tuple[int, int]], list[tuple[str, np.ndarray]]]:
    """Plate corners (m) of the rig's plated bodies, their edges, and per mode (label, corner
    motion): the bodies' complex generalized coordinates at G (six per body; bodies without them
    stand still) taken to the corners by the small-motion (linearised) pose."""
    from odsuite.api import body_corners, plate_corners

    bodies = [b for b in rig.bodies if b.plate is not None]
    nodes = np.concatenate([plate_corners(b.plate) for b in bodies])
    lines = [(8 * j + a, 8 * j + b) for j in range(len(bodies)) for a, b in EDGES]
    modes = []
    for coords, lab in zip(coordinates, labels):
        U = np.zeros(nodes.shape, dtype=complex)
        for j, b in enumerate(bodies):
            q = coords.get(b.name)
            if q is None:
                continue
            q = np.asarray(q, dtype=complex)
            eps = 1e-6 / max(float(np.abs(q).max()), np.finfo(float).tiny)  # small enough to be linear
            rest = plate_corners(b.plate)
            U[8 * j:8 * j + 8] = ((body_corners(b, eps * q.real) - rest) + 1j * (body_corners(b, eps * q.imag) - rest)) / eps
        modes.append((lab, U))
    return nodes, lines, modes


def mode_view_html(data: Mapping, element_id: str = "mode-view") -> str:
    """The <div> holding the canvas, the mode selector, the controls and the script."""
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    options = "".join(f'<option value="{k}">{m["label"]}</option>' for k, m in enumerate(data["modes"]))
    return (f'<div id="{element_id}" class="viewer mode-view">'
            f'<div class="v-controls"><label>mode <select class="m-mode">{options}</select></label>'
            f'<button type="button" class="m-play">pause</button>'
            f'<button type="button" class="m-zoom-in">+</button><button type="button" class="m-zoom-out">&minus;</button>'
            f'</div><canvas width="960" height="540" aria-label="interactive 3-D view of the mode shapes"></canvas>'
            f'<p class="v-help">Drag to rotate, wheel or +/&minus; to zoom; {data["drawn"]}; blue: the mode shape '
            f'moving through its cycle, dashed grey: rest position, grey dots: fixed nodes, green dots: sensors.</p>'
            + inline_scripts(element_id, "m-data", payload, _SCRIPT))


_SCRIPT = r"""
  var pick = root.querySelector('.m-mode'), play = root.querySelector('.m-play');
  var az = -60, el = 20, zoom = 1, phase = 0, timer = null, drag = null, c = data.centre_mm, ax = data.axes;

  function project(p) {
    var a = az * Math.PI / 180, e = el * Math.PI / 180, d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
    function dot(u) { return u[0] * d[0] + u[1] * d[1] + u[2] * d[2]; }
    var h1 = dot(ax.e1), h2 = dot(ax.e2), v = dot(ax.up);
    var sx = -Math.sin(a) * h1 + Math.cos(a) * h2, depth = Math.cos(a) * h1 + Math.sin(a) * h2;
    var sy = v * Math.cos(e) - depth * Math.sin(e);
    var s = zoom * 0.8 * Math.min(canvas.width, canvas.height) / data.size_mm;
    return [canvas.width / 2 + ax.handed * s * sx, canvas.height / 2 - s * sy];
  }
  function node(k, m, f) {
    var n = data.nodes, p = [n[3 * k], n[3 * k + 1], n[3 * k + 2]];
    if (!m) return p;
    var cs = Math.cos(f), sn = Math.sin(f);
    return [0, 1, 2].map(function (i) { return p[i] + m.re[3 * k + i] * cs - m.im[3 * k + i] * sn; });
  }
  function lines(m, f, colour, width, dash) {
    ctx.strokeStyle = colour; ctx.lineWidth = width; ctx.setLineDash(dash || []); ctx.beginPath();
    data.lines.forEach(function (l) {
      var p = project(node(l[0], m, f)), q = project(node(l[1], m, f));
      ctx.moveTo(p[0], p[1]); ctx.lineTo(q[0], q[1]);
    });
    ctx.stroke(); ctx.setLineDash([]);
  }
  function dots(list, m, f, colour, r) {
    ctx.fillStyle = colour;
    list.forEach(function (k) { var p = project(node(k, m, f)); ctx.beginPath(); ctx.arc(p[0], p[1], r, 0, 2 * Math.PI); ctx.fill(); });
  }
  function draw() {
    var m = data.modes[parseInt(pick.value, 10)];
    ctx.fillStyle = '#fff'; ctx.fillRect(0, 0, canvas.width, canvas.height);
    lines(null, 0, data.colours.rest, 1, [6, 4]);
    lines(m, phase, data.colours.moving, 2);
    dots(data.fixed, null, 0, data.colours.fixed, 3);
    dots(data.sensors, m, phase, data.colours.sensor, 4);
    ctx.fillStyle = '#222'; ctx.font = '15px sans-serif';
    ctx.fillText(m.label, 10, 22);
    ctx.fillText('phase ' + Math.round(phase * 180 / Math.PI) % 360 + '\u00b0', 10, 42);
  }
  function start() { timer = setInterval(function () { phase = (phase + Math.PI / 20) % (2 * Math.PI); draw(); }, 50); play.textContent = 'pause'; }
  play.addEventListener('click', function () {
    if (timer) { clearInterval(timer); timer = null; play.textContent = 'play'; } else { start(); }
  });
  pick.addEventListener('change', draw);
  navigate('m');
  var hash = location.hash;
  // #mode=K: that mode held at its largest excursion (a still for a screenshot or a link)
  if (hash.indexOf('#mode=') === 0) { pick.value = String(parseInt(hash.slice(6), 10) - 1); play.textContent = 'play'; draw(); }
  else if (hash === '#selftest') { draw(); }
  else { draw(); start(); }

  if (hash === '#selftest') {
    var fingerprint = function () {
      var px = ctx.getImageData(0, 0, canvas.width, canvas.height).data, h = 0, ink = 0;
      for (var i = 0; i < px.length; i += 4) {
        if (px[i] < 250 || px[i + 1] < 250 || px[i + 2] < 250) { ink++; h = (h * 31 + px[i] + 7 * px[i + 2] + i) % 1000000007; }
      }
      return { ink: ink, hash: h };
    };
    var report = { modes: data.modes.length, first: fingerprint() };
    phase = Math.PI; draw(); report.phased = fingerprint();
    if (data.modes.length > 1) { pick.value = '1'; draw(); report.second = fingerprint(); report.label = data.modes[1].label; }
    az += 90; draw(); report.rotated = fingerprint();
    report.errors = errors;
    var out = document.createElement('pre'); out.id = 'mode-view-selftest';
    out.textContent = JSON.stringify(report); document.body.appendChild(out);
  }
})();
"""
