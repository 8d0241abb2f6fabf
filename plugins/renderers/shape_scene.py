"""An off-screen pyvista scene of a structure's geometry (nodes, lines, faces) posed frame by frame
from node displacements: the plate scene's look (colours, rest position dash-dotted, sensors named,
legend, axes), for structures that are not rigid plates."""

from __future__ import annotations

import numpy as np

from odsuite.api import Geometry

from .scene import (Scene, Style, _ctrl_c_held, _lines_polydata, dash_dot_segments, offscreen_pyvista,
                    title_and_label)


def view_vector(azimuth: float, elevation: float) -> np.ndarray:
    """Unit vector from the focal point to the camera (degrees; azimuth from x towards y, z up)."""
    a, e = np.radians(azimuth), np.radians(elevation)
    return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])


def view_up_vector(azimuth: float, elevation: float) -> np.ndarray:
    """The picture's up, z squared to the view (as :func:`.scene.view_up`): z lies along the view
    at elevation +-90."""
    a, e = np.radians(azimuth), np.radians(elevation)
    return np.array([-np.sin(e) * np.cos(a), -np.sin(e) * np.sin(a), np.cos(e)])


class ShapeScene:
    """``motion`` (frames, nodes, 3; m, already scaled for drawing) moves the geometry's nodes;
    :meth:`frame` poses them at one frame and returns RGB, as :class:`.scene.Scene` does."""

    @_ctrl_c_held
    def __init__(self, geometry: Geometry, motion: np.ndarray, *, view: tuple[float, float] = (-60.0, 20.0),
                 title: str = "", size: tuple[int, int] = (1280, 720), style: Style = Style(),
                 sensors: bool = True, axes: bool = True, what: str = "mode shape") -> None:
        pv = offscreen_pyvista()
        self.size = (int(size[0]), int(size[1]))
        self.style = style
        g = geometry
        rest = g.xyz
        self._series = rest[None] + np.asarray(motion, float)
        self.plotter = pv.Plotter(off_screen=True, window_size=self.size, line_smoothing=True, border=False)
        self.plotter.ren_win.SetMultiSamples(0)
        self.plotter.set_background(style.background)
        self._moving: list[tuple[object, np.ndarray]] = []
        edges = g.edges()
        scale = g.size()
        # the rest position, dash-dotted as the plates' ghost
        segs = [dash_dot_segments(rest[a], rest[b], 0.03 * scale) for a, b in edges]
        segs = np.concatenate([s for s in segs if len(s)]) if segs else np.empty((0, 2, 3))
        if len(segs):
            n = len(segs)
            ghost = pv.PolyData(segs.reshape(-1, 3), lines=np.column_stack([np.full(n, 2), 2 * np.arange(n),
                                                                           2 * np.arange(n) + 1]).ravel())
            self.plotter.add_mesh(ghost, color=style.ghost, line_width=1.0, lighting=False)
        lines = _lines_polydata(self._series[0], [tuple(e) for e in edges])
        if g.faces:
            faces = np.hstack([[len(f), *(g.index(v) for v in f)] for f in g.faces]).astype(np.int64)
            shell = pv.PolyData(lines.points, faces=faces)
            shell.SetPoints(lines.GetPoints())  # one set of points poses both
            self.plotter.add_mesh(shell, color=tuple(0.35 + 0.65 * np.asarray(style.measured)), opacity=0.35,
                                  show_edges=False, lighting=False)
        self.plotter.add_mesh(lines, color=style.measured, line_width=style.line_width + 0.5, point_size=9,
                              render_points_as_spheres=not len(edges), lighting=False)
        self._moving.append((lines, self._series))
        fixed = [g.index(n) for n in g.fixed]
        if fixed:
            self.plotter.add_mesh(pv.PolyData(rest[fixed]), color=style.static, point_size=8,
                                  render_points_as_spheres=True, lighting=False)
        if sensors and g.sensors:
            spots: dict[int, list[str]] = {}
            for s in g.sensors:
                spots.setdefault(g.index(s.node), []).append(s.channel)
            idx = list(spots)
            dots = pv.PolyData(self._series[0][idx].copy())
            self.plotter.add_mesh(dots, color=style.sensor, point_size=11, render_points_as_spheres=True,
                                  lighting=False)
            # on a pale box: the labels sit where the structure's lines cross
            self.plotter.add_point_labels(dots, [" ".join(v) for v in spots.values()], shape="rect",
                                          shape_color=style.background, shape_opacity=0.8, margin=2,
                                          show_points=False, font_size=style.font_size, text_color=style.sensor,
                                          always_visible=True, bold=True)
            self._moving.append((dots, self._series[:, idx]))
        lo, hi = self._series.min(axis=(0, 1)), self._series.max(axis=(0, 1))
        if axes:
            origin = lo - 0.08 * scale
            tips = origin + 0.12 * scale * np.eye(3)
            for tip, colour in zip(tips, ((0.8, 0, 0), (0, 0.6, 0), (0, 0, 0.8))):
                self.plotter.add_mesh(pv.Line(origin, tip), color=colour, line_width=2.0, lighting=False)
            self.plotter.add_point_labels(tips, ["x", "y", "z"], shape=None, show_points=False,
                                          font_size=style.font_size, text_color=style.text, always_visible=True)
            lo = np.minimum(lo, origin)
        self._label = title_and_label(self.plotter, self.size, style, title)
        entries = [(what, style.measured), ("rest position (dash-dot)", style.ghost)]
        if fixed:
            entries.append(("fixed nodes", style.static))
        if sensors and g.sensors:
            entries.append(("sensors", style.sensor))
        width = 0.0088 * max(len(t) for t, _ in entries) + 0.04
        legend = self.plotter.add_legend([{"label": t, "color": c, "face": "-"} for t, c in entries],
                                         bcolor=style.background, border=True, size=(width, 0.028 * len(entries)),
                                         loc="lower right", face="-")
        legend.SetPosition(1.0 - width - 0.01, 0.03)
        self._camera(lo, hi, view, scale)

    def _camera(self, lo, hi, view, scale) -> None:
        pad = 0.05 * scale
        box = np.array([[x, y, z] for x in (lo[0] - pad, hi[0] + pad) for y in (lo[1] - pad, hi[1] + pad)
                        for z in (lo[2] - pad, hi[2] + pad)])
        centre = box.mean(axis=0)
        cam = self.plotter.camera
        cam.focal_point = centre
        cam.position = centre + view_vector(*view)
        cam.up = tuple(view_up_vector(*view))
        self.plotter.reset_camera(bounds=np.column_stack([box.min(0), box.max(0)]).ravel())
        cam.zoom(0.9 / Scene._filled(self.plotter.renderers[0], box))

    @property
    def n_samples(self) -> int:
        return self._series.shape[0]

    frame = Scene.frame
    close = Scene.close
    _hammer = None
