"""An off-screen pyvista scene of the rig's plates, posed frame by frame from generalized coordinates.

pyvista is imported inside the functions so the plugin loads on machines without it.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from odsuite.api import ConfigError
from odsuite.api import Rig
from odsuite.api import PLOT_INDEX, plate_corners
from odsuite.api import interrupts_held

from .motion import _times, check_coords, corners, magnified, plate_scale

#: The 12 edges of a box as corner-index pairs, taken from the Table 4.2 polyline (retraces dropped).
EDGES = tuple(dict.fromkeys(tuple(sorted(p)) for p in zip(PLOT_INDEX[:-1], PLOT_INDEX[1:])))
#: The 6 faces of a box in CORNER_NAMES indices (FRU FRL FLU FLL RRU RRL RLU RLL).
FACES = ((3, 1, 0, 2), (7, 5, 4, 6), (3, 1, 5, 7), (2, 0, 4, 6), (3, 2, 6, 7), (1, 0, 4, 5))

LAYOUTS = ("overlay", "side-by-side")


@dataclass(frozen=True)
class Style:
    """Colours (RGB 0-1) and sizes; the defaults print well on white."""

    background: tuple[float, float, float] = (1.0, 1.0, 1.0)
    measured: tuple[float, float, float] = (0.05, 0.15, 0.55)
    model: tuple[float, float, float] = (0.85, 0.35, 0.0)
    corrected: tuple[float, float, float] = (0.0, 0.55, 0.2)
    static: tuple[float, float, float] = (0.55, 0.55, 0.55)
    ghost: tuple[float, float, float] = (0.25, 0.25, 0.25)
    text: tuple[float, float, float] = (0.1, 0.1, 0.1)
    marker: tuple[float, float, float] = (1.0, 0.0, 0.0)
    sensor: tuple[float, float, float] = (0.0, 0.45, 0.25)
    hammer: tuple[float, float, float] = (0.85, 0.0, 0.0)
    line_width: float = 2.0
    #: the model is drawn as a wide translucent band under the measured line, so where both
    #: coincide the measured line runs inside the model's band instead of flickering over it
    model_width: float = 7.0
    model_opacity: float = 0.45
    font_size: int = 13


@dataclass(frozen=True)
class Hammer:
    """The hit drawn as an arrow onto ``point`` (rig frame, m, on ``body``) along ``direction``
    (unit); ``force`` (N, one value per sample of the coordinates) sets when it is in contact."""

    body: str
    point: np.ndarray
    direction: np.ndarray
    force: np.ndarray

    #: contact while |force| is at least this fraction of its peak (the pulse's foot is noise)
    CONTACT_FRACTION = 0.05


def view_direction(rig: Rig, azimuth: float, elevation: float) -> np.ndarray:
    """Unit vector from the focal point to the camera (degrees).

    Azimuth is measured in the horizontal plane from the rig's x towards its y; elevation is the
    angle above that plane (along the rig's ``up``: the top of a plate faces the camera for
    elevation > 0).
    """
    a, e = np.radians(azimuth), np.radians(elevation)
    e1, e2 = rig.horizontal_axes()
    return np.cos(e) * (np.cos(a) * e1 + np.sin(a) * e2) + np.sin(e) * rig.up


def view_up(rig: Rig, azimuth: float, elevation: float) -> np.ndarray:
    """The picture's up: the rig's up squared to the view direction, cos(el) up - sin(el) h (h the
    horizontal towards the camera). The rig's up itself lies along the view at elevation +-90 (VTK
    warned within 2.6 degrees of it and chose another); this turns smoothly into the pole, where
    the rig's side towards the azimuth is at the bottom seen from above, at the top from below."""
    a, e = np.radians(azimuth), np.radians(elevation)
    e1, e2 = rig.horizontal_axes()
    return np.cos(e) * np.asarray(rig.up, float) - np.sin(e) * (np.cos(a) * e1 + np.sin(a) * e2)


def dash_dot_segments(p0: np.ndarray, p1: np.ndarray, period: float) -> np.ndarray:
    """A dash-dotted line from p0 to p1 as segments (k, 2, 3): dash 55 %, gap, dot 10 %, gap."""
    length = float(np.linalg.norm(p1 - p0))
    if length == 0:
        return np.empty((0, 2, 3))
    n = max(1, int(round(length / period)))
    step = length / n
    pattern = ((0.0, 0.55), (0.7, 0.8))  # (start, end) as fractions of one period
    u = (p1 - p0) / length
    segs = [(p0 + u * (k + a) * step, p0 + u * (k + b) * step) for k in range(n) for a, b in pattern]
    return np.array(segs)


def _ctrl_c_held(method: Callable) -> Callable:
    """Run a method that calls into VTK with Ctrl-C held back until it returns: an interrupt
    raised inside VTK's import, a callback or a half-built plotter crashed the interpreter (a
    segmentation fault at exit, 1 in 10 interrupted renders). A constructor that ends in an
    interrupt closes what it built (its scene is never handed out to be closed)."""
    @functools.wraps(method)
    def held(self, *args, **kwargs):
        try:
            with interrupts_held():
                return method(self, *args, **kwargs)
        except BaseException:
            if method.__name__ == "__init__":
                self.close()
            raise
    return held


def offscreen_pyvista():
    """pyvista, with VTK told to render through EGL when there is no display.

    Without the hint VTK first tries an X window and logs a "bad X server connection" warning.
    """
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista

    return pyvista


def _point_series(body, d: np.ndarray, point: np.ndarray, magnify) -> np.ndarray:
    """Rig-frame positions (n, 3) of a point fixed on ``body`` moving with ``d`` (n, 6), magnified."""
    from odsuite.api import transform_points

    return body.com + transform_points(magnified(d, magnify), (point - body.com)[None])[:, 0]


def _lines_polydata(points: np.ndarray, edges) -> "pyvista.PolyData":  # noqa: F821
    import pyvista as pv

    edges = list(edges)
    if not edges:  # a geometry of nodes alone: each a vertex, drawn as a dot
        return pv.PolyData(np.asarray(points, dtype=float))
    lines = np.hstack([[2, a, b] for a, b in edges]).astype(np.int64)
    return pv.PolyData(np.asarray(points, dtype=float), lines=lines)


def title_and_label(plotter, size, style, title: str | None):
    """The title (if any) at the top left and, below it, the text actor each frame writes its time
    or phase into; returns that actor."""
    import textwrap

    fs = style.font_size
    top = size[1] - 12
    # VTK's text is about fs pixels a character and 2 fs a line: long lines wrap to the frame's width
    lines = [w for line in (title or "").split("\n")
             for w in textwrap.wrap(line, max(20, int((size[0] - 24) / (0.95 * fs))))]
    if lines:
        plotter.add_text("\n".join(lines), position=(12, top - 2 * len(lines) * fs), font_size=fs, color=style.text)
    return plotter.add_text(" ", position=(12, top - (2 * len(lines) + 2) * fs - 4), font_size=fs, color=style.text)


#: the camera's margin around the plates, as a fraction of the largest plate: the magnified
#: motion (15 %) and the axes just outside the plates' corner
AXES_ROOM = 0.2


#: the scale bar's drawn length, as a fraction of the plate size (15-18 % of the frame's width)
BAR_OF_PLATE = 1.0


def scale_bar_length(scale: float, magnify: float) -> tuple[float, float]:
    """(real, drawn) lengths (m) of the scale bar: the round amount of motion (1, 2 or 5 x 10^k m)
    whose magnified length is nearest to the plate size, and that magnified length (at a tenth,
    the bar was a few pixels beside its label in a 1280-pixel frame)."""
    target = BAR_OF_PLATE * scale / magnify
    exponent = np.floor(np.log10(target))
    real = min((m * 10.0**e for e in (exponent - 1, exponent, exponent + 1) for m in (1.0, 2.0, 5.0)),
               key=lambda v: abs(np.log(v / target)))
    return float(real), float(real * magnify)


#: the scale bar's thickness; the room between it and its name, and between both and anything drawn
BAR_PX = 4
BAR_GAP_PX = 4
BAR_CLEARANCE_PX = 8
#: a pixel further than this from the background (0-255, any channel) shows something drawn
DRAWN_LEVELS = 8
#: samples projected at once when measuring how far the moving parts travel on screen
PROJECTION_CHUNK = 1 << 20


def free_spot(occupied: np.ndarray, width: int, height: int) -> tuple[int, int]:
    """Lower-left (column, row) of a ``width`` x ``height`` box in the mask ``occupied`` (rows from
    the bottom) that covers the fewest occupied pixels, nearest a corner of the mask among equals
    (the lower left first)."""
    rows, cols = occupied.shape
    ny, nx = rows - height + 1, cols - width + 1
    if ny < 1 or nx < 1:  # larger than the room: from its lower left
        return 0, 0
    summed = np.zeros((rows + 1, cols + 1), dtype=np.int32)
    summed[1:, 1:] = occupied.cumsum(0, dtype=np.int32).cumsum(1)
    covered = (summed[height:, width:] - summed[:ny, width:] - summed[height:, :nx] + summed[:ny, :nx])
    y, x = np.nonzero(covered == covered.min())  # row by row from the bottom: the lower left wins ties
    distance = np.hypot(np.minimum(x, nx - 1 - x), np.minimum(y, ny - 1 - y))
    best = int(np.argmin(distance))
    return int(x[best]), int(y[best])


def window_pixels(render_window, size: tuple[int, int]) -> np.ndarray:
    """Render and read the window: (H, W, 3) uint8, rows from the bottom as OpenGL gives them."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonCore import vtkUnsignedCharArray

    render_window.Render()
    w, h = size
    buf = vtkUnsignedCharArray()
    render_window.GetPixelData(0, 0, w - 1, h - 1, 0, buf, 0)
    return vtk_to_numpy(buf).reshape(h, w, 3)


def _spot_label(names: list[str]) -> str:
    """One short label for the sensors at one spot: a triaxial's "P1_x P1_y P1_z" as "P1_xyz"."""
    stems = {n.rpartition("_")[0] for n in names}
    if len(names) > 1 and len(stems) == 1 and "" not in stems:
        return f"{stems.pop()}_{''.join(n.rpartition('_')[2] for n in names)}"
    return " ".join(names)


#: pixels between a sensor's dot and its name; half the side of the square a dot keeps free of names
LABEL_GAP_PX = 8.0
DOT_ROOM_PX = 6.0


def _overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two boxes (xmin, xmax, ymin, ymax) share area."""
    return bool(a[0] < b[1] and b[0] < a[1] and a[2] < b[3] and b[2] < a[3])


def _mm(metres: float) -> str:
    return f"{1e3 * metres:g} mm"


class Scene:
    """Plates of a rig drawn off-screen; :meth:`frame` poses them at one sample and returns RGB.

    ``coords`` and ``model_coords`` map body names to (n, 6) generalized coordinates at each
    body's centre of mass (rig frame); bodies with a plate but no coordinates are drawn still.
    """

    @_ctrl_c_held
    def __init__(
        self,
        rig: Rig,
        coords: Mapping[str, np.ndarray],
        *,
        model_coords: Mapping[str, np.ndarray] | None = None,
        corrected_coords: Mapping[str, np.ndarray] | None = None,
        layout: str = "overlay",
        magnify: tuple[float, float] = (1.0, 1.0),
        view: tuple[float, float] = (60.0, 25.0),
        parallel: bool = False,
        solid: bool = False,
        axes: bool = True,
        ghost: bool = True,
        markers: bool = False,
        sensors: bool = True,
        hammer: Hammer | None = None,
        title: str = "",
        size: tuple[int, int] = (1280, 720),
        style: Style = Style(),
        scale_bar: bool = True,
    ) -> None:
        pv = offscreen_pyvista()

        if layout not in LAYOUTS:
            raise ConfigError(f"layout: expected one of {', '.join(LAYOUTS)}, got {layout!r}")
        coords = check_coords(rig, coords)
        if model_coords is not None:
            model_coords = check_coords(rig, model_coords, "model_coords")
        if corrected_coords is not None:
            corrected_coords = check_coords(rig, corrected_coords, "corrected_coords")
        self.size = (int(size[0]), int(size[1]))
        self.style = style
        side = model_coords is not None and layout == "side-by-side"
        # No MSAA: llvmpipe resolves it at several times the cost of the frame; smoothed lines
        # give the same look for a wireframe.
        self.plotter = pv.Plotter(off_screen=True, window_size=self.size, shape=(1, 2) if side else (1, 1),
                                  line_smoothing=True, border=False)
        self.plotter.ren_win.SetMultiSamples(0)
        # Plain alpha blending for the translucent lines (the rest position, the model's band):
        # order-independent transparency cost two thirds of each frame in llvmpipe (31 -> 10 ms
        # at 1280 x 720) and changed 0.1 % of the pixels, by at most 14 of 255 levels.
        for renderer in self.plotter.renderers:
            renderer.SetUseOIT(False)
        self.plotter.set_background(style.background)
        self._moving: list[tuple[object, np.ndarray]] = []  # (polydata, corners (n, 8, 3))
        # the model first, so the measured line is drawn over the model's band
        sets = []
        if model_coords is not None:
            sets.append((model_coords, style.model, 1 if side else 0, not side))
        if corrected_coords is not None:  # with the recorded motion: both are the measurement
            sets.append((corrected_coords, style.corrected, 0, False))
        sets.append((coords, style.measured, 0, False))
        scale = plate_scale(rig, list(coords))
        # translations drawn x0 (held still) have no ruler: any motion is a bar of no length
        self._magnify = magnify if scale_bar and magnify[0] > 0 else None
        self._towards_camera, self._up = view_direction(rig, *view), view_up(rig, *view)
        self._decorations: list[np.ndarray] = []  # points of the axes, kept in view
        # (text, dot series (n, 3), offset from the dot in pixels, its body's centre)
        self._sensor_labels: list[tuple[object, np.ndarray, np.ndarray, np.ndarray]] = []
        for k in range(2 if side else 1):
            self.plotter.subplot(0, k)
            self._static_plates(rig, set().union(*(c for c, _, v, _ in sets if v == k)), scale, ghost, solid, axes)
        before = {id(a) for r in self.plotter.renderers for a in r.actors.values()}
        for c, colour, viewport, band in sets:
            self.plotter.subplot(0, viewport)
            for name, d in c.items():
                body = rig.body(name)
                series = corners(body, d, magnify)
                self._moving.append((self._add_plate(series[0], colour, solid, markers, band=band), series))
        self.plotter.subplot(0, 0)
        self._hammer = None
        if sensors:
            self._sensor_marks(rig, coords, magnify)
        if hammer is not None:
            self._hammer_arrow(rig, hammer, coords, magnify, scale)
        # the plates, dots, names and arrow added since `before` move with the coordinates
        self._moving_actors = [a for r in self.plotter.renderers for a in r.actors.values() if id(a) not in before]
        self._label = title_and_label(self.plotter, self.size, style, title)
        # pixels from the top the title and the frame's clock take (the clock's line is the lowest)
        self._title_px = self.size[1] - self._label.GetPosition()[1] + style.font_size
        self._legend(side, model_coords is not None, ghost, hammer is not None, sensors, corrected_coords is not None)
        self._camera(rig, coords, view, parallel, side)
        self._place_sensor_labels(rig, coords)
        self._bar_pixels: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        if axes and self._magnify is not None:
            self._scale_bars(rig, coords, scale)

    # -- construction ------------------------------------------------------------------------
    def _add_plate(self, pts: np.ndarray, colour, solid: bool, markers: bool, opacity: float = 1.0,
                   band: bool = False):
        import pyvista as pv

        lines = _lines_polydata(pts, EDGES)
        if solid:
            faces = np.hstack([[4, *f] for f in FACES]).astype(np.int64)
            shell = pv.PolyData(lines.points, faces=faces)
            # the shell shares the wireframe's vtkPoints, so posing one poses both
            shell.SetPoints(lines.GetPoints())
            self.plotter.add_mesh(shell, color=tuple(0.35 + 0.65 * np.asarray(colour)), opacity=opacity,
                                  smooth_shading=False, show_edges=False)
        if band:
            self.plotter.add_mesh(lines, color=colour, line_width=self.style.model_width,
                                  opacity=self.style.model_opacity, lighting=False)
        else:
            self.plotter.add_mesh(lines, color=colour, line_width=self.style.line_width, lighting=False,
                                  opacity=opacity)
        if markers:
            dots = pv.PolyData(lines.points)
            dots.SetPoints(lines.GetPoints())
            self.plotter.add_mesh(dots, color=self.style.marker, point_size=5,
                                  render_points_as_spheres=False, lighting=False)
        return lines

    def _static_plates(self, rig: Rig, moving: set[str], scale: float, ghost: bool, solid: bool,
                       axes: bool) -> None:
        import pyvista as pv

        for body in rig.bodies:
            if body.plate is None:
                continue
            rest = plate_corners(body.plate)
            if body.name not in moving:
                self._add_plate(rest, self.style.static, solid, False, opacity=0.25)
            elif ghost:
                segs = np.concatenate([dash_dot_segments(rest[a], rest[b], 0.08 * scale) for a, b in EDGES])
                n = len(segs)
                mesh = pv.PolyData(segs.reshape(-1, 3),
                                   lines=np.column_stack([np.full(n, 2), 2 * np.arange(n), 2 * np.arange(n) + 1]).ravel())
                # as wide as the measured line: at one pixel, smoothed, the dashes faded to a faint grey
                self.plotter.add_mesh(mesh, color=self.style.ghost, line_width=self.style.line_width, lighting=False)
        if axes:
            # just outside the plates' lower corner leftmost in the picture, within the camera's
            # margin (AXES_ROOM): the corner nearest the camera put them at the bottom edge, under
            # the legend
            box = self._bounds(rig, moving).reshape(3, 2)
            corner_points = np.array([[x, y, z] for x in box[0] for y in box[1] for z in box[2]])
            lower = corner_points[np.argsort(corner_points @ np.asarray(rig.up, float))[:4]]
            right = np.cross(-self._towards_camera, self._up)
            corner = lower[np.argmin(lower @ right)]
            out = corner - box.mean(axis=1)
            origin = corner + 0.1 * scale * out / max(np.linalg.norm(out), 1e-12)
            tips = origin + 0.2 * scale * np.eye(3)
            self._decorations += [origin, *tips]
            for tip, colour in zip(tips, ((0.8, 0, 0), (0, 0.6, 0), (0, 0, 0.8))):
                self.plotter.add_mesh(pv.Line(origin, tip), color=colour, line_width=2.0, lighting=False)
            self.plotter.add_point_labels(tips, ["x", "y", "z"], shape=None, show_points=False,
                                          font_size=self.style.font_size, text_color=self.style.text,
                                          always_visible=True)

    def _scale_bars(self, rig: Rig, coords, scale: float) -> None:
        """In each view, a bar whose length on screen is a round amount of motion (mm) magnified,
        as drawn at the moving plates' centre, with its name under it: in the free spot nearest a
        corner of the picture, clear of everything drawn in any frame. Placed once, so it stays put;
        beside the axes, at a fixed offset, it lay across the still plates' outlines."""
        from scipy.ndimage import maximum_filter

        real, drawn = scale_bar_length(scale, self._magnify[0])
        moving = np.concatenate([plate_corners(rig.body(n).plate) for n in coords])
        centre = (moving.min(0) + moving.max(0)) / 2.0
        still, travelling = self._drawn_masks()
        w, h = self.size
        # below the title and clock, above the progress bar, a text line from the sides
        margin, clear = self.style.font_size, BAR_CLEARANCE_PX
        bottom, top = max(4, h // 120) + margin, h - int(np.ceil(self._title_px))
        for k, renderer in enumerate(self.plotter.renderers):
            cam = renderer.GetActiveCamera()
            across = np.cross(cam.GetDirectionOfProjection(), cam.GetViewUp())
            across /= np.linalg.norm(across)
            ends = self._display_points(renderer, [centre - drawn / 2 * across, centre + drawn / 2 * across])
            length = float(np.linalg.norm(ends[1] - ends[0]))
            reach = int(np.ceil(min(self._pixel_travel(renderer), w + h)))
            occupied = still | (maximum_filter(travelling, 2 * reach + 1) if reach else travelling)
            name = self._screen_text(f"{_mm(real)} of motion (x{_times(self._magnify[0])})", self.style.text)
            renderer.add_actor(name, reset_camera=False, pickable=False)
            box = self.text_box(name, k)  # at the position (0, 0)
            width = int(np.ceil(max(length, box[1] - box[0])))
            height = int(np.ceil(box[3] - box[2])) + BAR_GAP_PX + BAR_PX
            # the box grown by the clearance on every side, within the view's part of the frame
            vx0, _, vx1, _ = (np.array(renderer.GetViewport()) * [w, h, w, h]).round().astype(int)
            x, y = free_spot(occupied[bottom:top, vx0 + margin:vx1 - margin], width + 2 * clear, height + 2 * clear)
            x, y = x + vx0 + margin + clear, y + bottom + clear  # the box's lower left, display pixels
            name.SetPosition(x - vx0 - box[0], y - box[2])  # a text actor sits in its view's pixels
            bar_y = y + height - BAR_PX / 2.0
            start, end = np.array([x, bar_y]), np.array([x + length, bar_y])
            renderer.add_actor(self._bar_actor(start - [vx0, 0], end - [vx0, 0]), reset_camera=False, pickable=False)
            self._bar_pixels.append((start, end, self.text_box(name, k) + np.array([vx0, vx0, 0, 0])))

    def _bar_actor(self, start: np.ndarray, end: np.ndarray):
        """The scale bar: a line between two pixels of its view, in the text's colour."""
        from vtkmodules.vtkCommonCore import vtkPoints
        from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData
        from vtkmodules.vtkRenderingCore import vtkActor2D, vtkPolyDataMapper2D

        points = vtkPoints()
        for p in (start, end):
            points.InsertNextPoint(p[0], p[1], 0.0)
        line = vtkCellArray()
        line.InsertNextCell(2, [0, 1])
        poly = vtkPolyData()
        poly.SetPoints(points)
        poly.SetLines(line)
        mapper = vtkPolyDataMapper2D()
        mapper.SetInputData(poly)
        bar = vtkActor2D()
        bar.SetMapper(mapper)
        bar.GetProperty().SetColor(self.style.text)
        bar.GetProperty().SetLineWidth(float(BAR_PX))
        return bar

    def scale_bar_pixels(self, k: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The scale bar's ends (x, y) and its name's box (xmin, xmax, ymin, ymax) in view ``k``,
        in display pixels (y from the bottom)."""
        return self._bar_pixels[k]

    def _drawn_masks(self) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (rows from the bottom) where the still parts are drawn, and where the moving
        parts are drawn at the first sample, each rendered alone."""
        props = [a for r in self.plotter.renderers for a in r.actors.values()]
        shown = {id(a): a.GetVisibility() for a in props}
        moving = {id(a) for a in self._moving_actors}
        background = np.asarray(self.style.background) * 255.0
        low = np.clip(background - DRAWN_LEVELS, 0, 255).astype(np.uint8)
        high = np.clip(background + DRAWN_LEVELS, 0, 255).astype(np.uint8)
        masks = []
        try:
            for draw_moving in (False, True):
                for a in props:
                    a.SetVisibility(shown[id(a)] and (id(a) in moving) == draw_moving)
                img = window_pixels(self.plotter.ren_win, self.size)
                drawn = np.zeros(img.shape[:2], dtype=bool)
                for c in range(3):  # plane by plane: 5 times faster than .any over the colour axis
                    drawn |= (img[..., c] < low[c]) | (img[..., c] > high[c])
                masks.append(drawn)
        finally:
            for a in props:
                a.SetVisibility(shown[id(a)])
        return masks[0], masks[1]

    def _pixel_travel(self, renderer) -> float:
        """The farthest (pixels, along x or y) any moving point gets in the record from where it
        is drawn at the first sample (inf when one passes the camera); the names beside the dots
        move with them."""
        far = 0.0
        for _, series in self._moving:
            series = series.reshape(len(series), -1, 3)  # a dot's series is (n, 3)
            first = self._display_points(renderer, series[0])
            step = max(1, PROJECTION_CHUNK // series.shape[1])
            for i in range(0, len(series), step):
                xy = self._display_points(renderer, series[i:i + step]).reshape(-1, series.shape[1], 2)
                far = max(far, float(np.abs(xy - first).max(initial=0.0)))
                if not np.isfinite(far):
                    return np.inf
        return far

    def _sensor_marks(self, rig: Rig, coords, magnify) -> None:
        """A dot at every sensor position of a moving body, named (sensors sharing a spot share a label)."""
        import pyvista as pv

        spots: dict[tuple, list[str]] = {}
        for s in rig.sensors:
            if s.body in coords:
                spots.setdefault((s.body, *np.round(np.asarray(s.position, float), 6)), []).append(s.name)
        for (body_name, *pos), names in spots.items():
            body = rig.body(body_name)
            series = _point_series(body, coords[body_name], np.asarray(pos), magnify)
            dot = pv.PolyData(series[:1].copy())
            self.plotter.add_mesh(dot, color=self.style.sensor, point_size=9, render_points_as_spheres=True,
                                  lighting=False)
            self._moving.append((dot, series))
            # the name is screen text placed beside the dot each frame (_place_sensor_labels): a
            # label anchored on its point was drawn under the dot and across its neighbours'
            text = self._screen_text(_spot_label(names), self.style.sensor)
            prop = text.GetTextProperty()
            prop.SetBold(True)
            prop.SetVerticalJustificationToCentered()
            # on a patch of the background: the plates' edges crossed the letters
            prop.SetBackgroundColor(self.style.background)
            prop.SetBackgroundOpacity(0.85)
            self.plotter.add_actor(text, reset_camera=False)
            self._sensor_labels.append((text, series, np.zeros(2), body.com))

    def _screen_text(self, words: str, colour) -> "vtkTextActor":  # noqa: F821
        """A text actor placed in pixels, one size below the frame's text."""
        from vtkmodules.vtkRenderingCore import vtkTextActor

        text = vtkTextActor()
        text.SetInput(words)
        prop = text.GetTextProperty()
        prop.SetFontSize(self.style.font_size - 1)
        prop.SetColor(colour)
        prop.SetFontFamilyToArial()
        return text

    def _hammer_arrow(self, rig: Rig, hammer: Hammer, coords, magnify, scale: float) -> None:
        """An arrow ending on the force point, red while in contact: half the hit body's plate long
        (a tenth of the scene's at least; half the scene's, 1 m over a 0.3 m head on a 2 m frame, ran
        out of the picture through its title)."""
        import pyvista as pv

        body = rig.body(hammer.body)
        point = np.asarray(hammer.point, float)
        if hammer.body in coords:
            tip = _point_series(body, coords[hammer.body], point, magnify)
        else:
            tip = np.repeat(point[None], self.n_samples, axis=0)
        u = np.asarray(hammer.direction, float)
        u = u / np.linalg.norm(u)
        length = max(0.5 * float(body.plate.size.max()), 0.1 * scale) if body.plate is not None else 0.5 * scale
        side = np.cross(u, [0.0, 0.0, 1.0] if abs(u[2]) < 0.9 else [1.0, 0.0, 0.0])
        side /= np.linalg.norm(side)
        rel = np.array([-length * u, np.zeros(3), -0.25 * length * u + 0.12 * length * side,
                        -0.25 * length * u - 0.12 * length * side])
        series = tip[:, None, :] + rel[None]
        arrow = _lines_polydata(series[0], ((0, 1), (1, 2), (1, 3)))
        actor = self.plotter.add_mesh(arrow, color=self.style.ghost, line_width=2.0, lighting=False)
        force = np.abs(np.asarray(hammer.force, float))
        label = pv.PolyData(series[:1, 0].copy())
        self.plotter.add_point_labels(label, ["hammer"], shape=None, show_points=False,
                                      font_size=self.style.font_size - 2, text_color=self.style.hammer,
                                      always_visible=True)
        self._moving += [(arrow, series), (label, series[:, :1])]
        self._hammer = (actor, force >= Hammer.CONTACT_FRACTION * max(force.max(initial=0.0), 1e-300))

    def _legend(self, side: bool, model: bool, ghost: bool, hammer: bool, sensors: bool,
                corrected: bool = False) -> None:
        st = self.style
        entries = [("measured motion", st.measured)]
        if corrected:
            entries.append(("corrected motion", st.corrected))
        if model and not side:  # side by side, the right-hand view is headed "model"
            entries.append(("model motion (wide band)", st.model))
        if ghost:
            entries.append(("rest position (dash-dot)", st.ghost))
        entries.append(("still bodies", st.static))
        if sensors:
            entries.append(("sensors", st.sensor))
        if hammer:
            entries.append(("hammer (red: in contact)", st.hammer))
        self.plotter.subplot(0, 0)
        # VTK scales the legend's text to fit the box: size it to the longest label and the rows
        width = 0.0088 * max(len(t) for t, _ in entries) + 0.04
        legend = self.plotter.add_legend([{"label": t, "color": c, "face": "-"} for t, c in entries],
                                         bcolor=st.background, border=True, size=(width, 0.028 * len(entries)),
                                         loc="lower right", face="-")
        # pyvista's "lower right" offsets x by the box's height, not its width: place it ourselves
        legend.SetPosition(1.0 - width - 0.01, 0.03)
        if side:
            self.plotter.subplot(0, 1)
            self.plotter.add_text("model", position="upper_right", font_size=st.font_size, color=st.model)
            self.plotter.subplot(0, 0)
            self.plotter.add_text("measured", position="upper_right", font_size=st.font_size, color=st.measured)

    def _to_display(self, point: np.ndarray, k: int = 0) -> np.ndarray:
        """Pixel (x, y from the bottom left) of a world point in viewport ``k``."""
        return self._display_points(self.plotter.renderers[k], point)[0]

    def text_box(self, text, k: int = 0) -> np.ndarray:
        """Pixel box (xmin, xmax, ymin, ymax; y from the bottom) a text actor covers where it is,
        in view ``k``'s pixels."""
        box = np.zeros(4)
        text.GetBoundingBox(self.plotter.renderers[k], box)  # relative to the actor's position
        x, y = text.GetPosition()
        return box + np.array([x, x, y, y])

    def sensor_label_boxes(self) -> dict[str, np.ndarray]:
        """Each sensor name's pixel box in the last frame (y from the bottom)."""
        return {text.GetInput(): self.text_box(text) for text, _, _, _ in self._sensor_labels}

    def _place_sensor_labels(self, rig: Rig, coords) -> None:
        """Each sensor's name beside its dot, on the side (left or right) away from its plate's
        centre, moved along the screen's vertical until it covers neither another name nor a dot
        (at rest)."""
        if not self._sensor_labels:
            return
        dots = [self._to_display(series[0]) for _, series, _, _ in self._sensor_labels]
        taken = [np.array([x - DOT_ROOM_PX, x + DOT_ROOM_PX, y - DOT_ROOM_PX, y + DOT_ROOM_PX]) for x, y in dots]
        placed = []
        for (text, series, _, centre), dot in zip(self._sensor_labels, dots):
            away = dot - self._to_display(centre)
            prop = text.GetTextProperty()
            if away[0] >= 0:
                prop.SetJustificationToLeft()
            else:
                prop.SetJustificationToRight()
            offset = np.array([LABEL_GAP_PX if away[0] >= 0 else -LABEL_GAP_PX, 0.0])
            step = 1.0 if away[1] >= 0 else -1.0
            for _ in range(50):
                text.SetPosition(*(dot + offset))
                box = self.text_box(text)
                clash = [b for b in taken if _overlap(box, b)]
                if not clash:
                    break
                offset = offset + np.array([0.0, 3.0 * step])
            taken.append(box)
            placed.append((text, series, offset, centre))
        self._sensor_labels = placed

    @staticmethod
    def _bounds(rig: Rig, names) -> np.ndarray:
        """x/y/z bounds of every plate of the rig (a still reference plate too: none is cut off)."""
        p = np.concatenate([plate_corners(b.plate) for b in rig.bodies if b.plate is not None])
        return np.column_stack([p.min(0), p.max(0)]).ravel()

    def _camera(self, rig: Rig, coords, view, parallel: bool, side: bool) -> None:
        bounds = self._bounds(rig, set(coords))
        centre = bounds.reshape(3, 2).mean(1)
        # room for the magnified motion (DEFAULT_EXCURSION of the plate size) and the axes beside the plates
        pad = AXES_ROOM * plate_scale(rig, list(coords))
        padded = bounds + np.array([-pad, pad] * 3)
        box = np.array([[x, y, z] for x in padded[:2] for y in padded[2:4] for z in padded[4:]])
        if self._decorations:  # the axes lie outside the plates' corner
            box = np.concatenate([box, np.array(self._decorations)])
        direction = view_direction(rig, *view)
        for k in range(2 if side else 1):
            self.plotter.subplot(0, k)
            cam = self.plotter.camera
            cam.focal_point = centre
            cam.position = centre + direction
            cam.up = tuple(self._up)
            if parallel:
                self.plotter.enable_parallel_projection()
            self.plotter.reset_camera(bounds=padded)
            # reset_camera fits the bounding sphere, which leaves a wide margin around a flat
            # rig: zoom until the padded box's projection just fills the viewport
            # fill the viewport below the title, centred there: the axes outside the plates'
            # corner ran out of the frame's bottom edge while the top stayed empty
            below_title = 1.0 - 2.0 * self._title_px / self.size[1]
            for _ in range(2):
                cam.zoom(1.0 / self._band_filled(self.plotter.renderers[k], box, (-0.95, below_title - 0.05)))
                self._centre(self.plotter.renderers[k], box, (below_title - 0.95) / 2.0)
        if side:
            self.plotter.link_views()
        self.plotter.subplot(0, 0)

    @staticmethod
    def _centre(renderer, points: np.ndarray, middle_y: float = 0.0) -> None:
        """Move the camera across its view (focal point and position together) so the middle of
        ``points``' projection lands on the viewport's horizontal centre, at height ``middle_y``
        (view coordinates, -1 to 1)."""
        cam = renderer.GetActiveCamera()
        xy = Scene._view_points(renderer, points)
        mid = (xy.max(0) + xy.min(0)) / 2.0 - np.array([0.0, middle_y])  # view coordinates: -1 to 1
        if cam.GetParallelProjection():
            half_h = cam.GetParallelScale()
        else:
            half_h = cam.GetDistance() * np.tan(np.radians(cam.GetViewAngle()) / 2.0)
        half_w = half_h * renderer.GetTiledAspectRatio()
        up = np.asarray(cam.GetViewUp(), float)
        right = np.cross(np.asarray(cam.GetDirectionOfProjection(), float), up)
        shift = mid[0] * half_w * right / np.linalg.norm(right) + mid[1] * half_h * up
        cam.SetFocalPoint(*(np.asarray(cam.GetFocalPoint()) + shift))
        cam.SetPosition(*(np.asarray(cam.GetPosition()) + shift))

    @staticmethod
    def _view_points(renderer, points: np.ndarray) -> np.ndarray:
        """View coordinates (-1 to 1 across the viewport) of world points (k, 3), by the camera's
        matrix as vtkRenderer.WorldToView applies it."""
        m = renderer.GetActiveCamera().GetCompositeProjectionTransformMatrix(renderer.GetTiledAspectRatio(), 0, 1)
        mat = np.array([[m.GetElement(i, j) for j in range(4)] for i in range(4)])
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        h = p @ mat[:, :3].T + mat[:, 3]
        return h[:, :2] / h[:, 3:]

    @staticmethod
    def _display_points(renderer, points: np.ndarray) -> np.ndarray:
        """Display pixels (x, y from the window's bottom left) of world points (k, 3), as
        vtkViewport.ViewToDisplay places view coordinates."""
        x0, y0, x1, y1 = renderer.GetViewport()
        w, h = renderer.GetRenderWindow().GetSize()
        xy = Scene._view_points(renderer, points)
        return (xy + 1.0) / 2.0 * np.array([w * (x1 - x0), h * (y1 - y0)]) + np.array([w * x0, h * y0])

    @staticmethod
    def _filled(renderer, points: np.ndarray) -> float:
        """The larger of the fractions of the viewport's width and height that ``points`` span."""
        xy = Scene._view_points(renderer, points)
        span = (xy.max(0) - xy.min(0)) / 2.0  # view coordinates run from -1 to 1
        return float(max(span.max(), 1e-6))

    @staticmethod
    def _band_filled(renderer, points: np.ndarray, height: tuple[float, float]) -> float:
        """The larger of the fractions of the viewport's width (less a 5 % margin each side) and
        of the ``height`` band (view coordinates) that ``points`` span."""
        xy = Scene._view_points(renderer, points)
        extent = xy.max(0) - xy.min(0)
        return float(max(extent[0] / 1.9, extent[1] / (height[1] - height[0]), 1e-6))

    # -- drawing -----------------------------------------------------------------------------
    @property
    def n_samples(self) -> int:
        return self._moving[0][1].shape[0]

    def renderer(self, k: int = 0):
        """The vtkRenderer of viewport ``k`` (0: measured, 1: model when side by side)."""
        return self.plotter.renderers[k]

    @_ctrl_c_held
    def frame(self, index: int, label: str = "", progress: float | None = None) -> np.ndarray:
        """Pose every moving plate at sample ``index`` and return the frame (H, W, 3) uint8.

        ``progress`` in [0, 1] draws a bar along the bottom edge of the frame.
        """
        for poly, series in self._moving:
            poly.points[:] = series[index]
            poly.GetPoints().Modified()
            poly.Modified()
        # a shape's scene borrows this method and names no sensors
        for text, series, offset, _ in self.__dict__.get("_sensor_labels", ()):
            text.SetPosition(*(self._to_display(series[index]) + offset))
        if self._hammer is not None:
            actor, contact = self._hammer
            hit = bool(contact[index])
            actor.GetProperty().SetColor(self.style.hammer if hit else self.style.ghost)
            actor.GetProperty().SetLineWidth(5.0 if hit else 2.0)
        self._label.SetInput(label or " ")
        w, h = self.size
        img = window_pixels(self.plotter.ren_win, self.size)[::-1].copy()  # OpenGL rows run bottom-up
        if progress is not None:
            bar = max(4, h // 120)
            img[h - bar:, :, :] = (np.asarray(self.style.background) * 255 * 0.85).astype(np.uint8)
            img[h - bar:, : int(round(np.clip(progress, 0, 1) * w)), :] = (np.asarray(self.style.measured) * 255).astype(np.uint8)
        return img

    @_ctrl_c_held
    def close(self) -> None:
        plotter = self.__dict__.get("plotter")  # none yet when the constructor failed early
        if plotter is not None and not self.__dict__.get("_closed"):  # once
            self._closed = True
            plotter.close()
