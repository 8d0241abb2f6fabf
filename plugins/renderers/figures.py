"""Static matplotlib figures (Agg, no display): the thesis projection and model-vs-measurement plots.

Lengths are drawn in mm (a display edge); every function takes SI arrays.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from odsuite.api import unit_text, write_output
from odsuite.api import ConfigError, DimensionError
from odsuite.api import Rig
from odsuite.api import COORDINATE_UNITS, COORDINATES, PLOT_INDEX, plate_corners, rotation_matrix

from .motion import (characteristic_instant, check_coords, check_magnification, contact_index, corners,
                     default_magnification, magnification_words)

FIGURE_FORMATS = (".png", ".svg", ".pdf")
#: Screen (right, up) unit vectors for an eye on each rig axis looking at the origin in the
#: thesis's z-down rig frame ("up" is -z; the eye on z sits above the plates); see ``screen_axes``.
EYES = {
    "x": (np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.0, -1.0])),
    "y": (np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.0])),
    "z": (np.array([1.0, 0.0, 0.0]), np.array([0.0, -1.0, 0.0])),
}
THESIS_UP = np.array([0.0, 0.0, -1.0])


def screen_axes(eye: str, up: Sequence[float] = THESIS_UP) -> tuple[np.ndarray, np.ndarray]:
    """Screen (right, up) for an eye on the rig axis ``eye`` looking at the origin, the rig's
    ``up`` drawn upwards (an eye along ``up`` looks down on the plates); right x up points at
    the eye, as in ``EYES``, which this gives for the thesis's up = -z."""
    if eye not in EYES:
        raise ConfigError(f"eye: expected one of {', '.join(EYES)}, got {eye!r}")
    e = np.eye(3)["xyz".index(eye)]
    u = np.asarray(up, dtype=float) / np.linalg.norm(up)
    if abs(u @ e) < 0.9:
        screen_up = (u - (u @ e) * e) / np.linalg.norm(u - (u @ e) * e)
        return np.cross(screen_up, e), screen_up
    right = np.eye(3)[0] if abs(u[0]) < 0.9 else np.eye(3)[1]
    right = right - (right @ u) * u
    right /= np.linalg.norm(right)
    return right, np.cross(u, right)
#: Thesis Sec. 5.3.2: the initial position is taken 50 samples before the impact.
INITIAL_LEAD = 50
#: Still plates, one (grey, line style) each so two of them can be told apart in print.
STILL_GREYS = (("0.35", "-"), ("0.6", "--"), ("0.75", ":"))
#: A moving body drawn at rest because its sensors give it no coordinates: not a still plate.
UNMEASURED_STYLE = ("tab:brown", ":")


@dataclass(frozen=True)
class FigureResult:
    """The written file, the matplotlib Figure (for inspection) and what was chosen."""

    path: Path
    figure: object
    instants: tuple[int, ...] = ()
    magnify: tuple[float, float] | None = None


def _new_figure(size: tuple[float, float], layout: str | None = "constrained"):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, layout=layout)
    FigureCanvasAgg(fig)
    return fig


def _grid_margins(fig, rows: int, cols: int, *, left: float, right: float, bottom: float, top: float,
                  wspace: float, hspace: float, title: str = "") -> None:
    """Fixed margins and gaps (inches) around a grid of panels, for figures of many panels:
    constrained layout measures every tick label of every panel twice per save (on 18 panels,
    60 % of the figure's time). ``title``: room above for a suptitle (which hangs from 98 % of the
    height)."""
    w, h = fig.get_size_inches()
    if title:
        top += 0.02 * h + 0.2
    aw = (w - left - right - (cols - 1) * wspace) / cols
    ah = (h - bottom - top - (rows - 1) * hspace) / rows
    fig.subplots_adjust(left=left / w, right=1 - right / w, bottom=bottom / h, top=1 - top / h,
                        wspace=wspace / aw, hspace=hspace / ah)


def _save(fig, path: str | Path, dpi: int) -> Path:
    path = Path(path)
    if path.suffix.lower() not in FIGURE_FORMATS:
        raise ConfigError(f"{path}: figure format must be one of {', '.join(FIGURE_FORMATS)}, "
                          f"got {path.suffix or 'no suffix'!r}")
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_output(path, 0, lambda tmp: fig.savefig(tmp, dpi=dpi))  # a figure fits the reserve


def project(points: np.ndarray, eye: str = "x", view_angles: Sequence[float] = (0.0, 0.0, 0.0),
            up: Sequence[float] = THESIS_UP) -> np.ndarray:
    """Screen coordinates (..., 2) of rig-frame points (..., 3).

    Eq. 4.25: the points are first rotated by the viewpoint angles (theta_V, phi_V, psi_V, degrees)
    with the odsuite rotation convention, then projected along the ``eye`` axis, the rig's ``up``
    upwards on the screen.
    """
    right, up = screen_axes(eye, up)
    rv = rotation_matrix(np.radians(np.asarray(view_angles, dtype=float)))
    p = np.asarray(points, dtype=float) @ rv.T
    return np.stack([p @ right, p @ up], axis=-1)


def _axis_label(vector: np.ndarray) -> str:
    k = int(np.argmax(np.abs(vector)))
    return f"{'−' if vector[k] < 0 else ''}{'xyz'[k]}  [mm]"


def projection_figure(
    rig: Rig,
    coords: Mapping[str, np.ndarray],
    fs: float,
    path: str | Path,
    *,
    force: np.ndarray | None = None,
    instants: tuple[int, int] | None = None,
    eye: str = "x",
    view_angles: Sequence[float] = (0.0, 0.0, 0.0),
    magnify: tuple[float, float] | None = None,
    dpi: int = 150,
    title: str | None = None,
) -> FigureResult:
    """The thesis's Table 5.2 picture: initial position dash-dotted, the CFR solid.

    Each plate is drawn as the Table 4.2 corner polyline, rotated by the viewpoint (Eq. 4.25)
    and projected along ``eye``. ``instants`` = (initial, response) sample indices; by default
    the response is the Characteristic Forced Response (first response peak after the hammer
    contact found in ``force``) and the initial position 50 samples before the contact.
    """
    coords = check_coords(rig, coords)
    if magnify is None:
        magnify = default_magnification(rig, coords)
    if instants is None:
        contact = contact_index(force) if force is not None else None
        cfr = characteristic_instant(rig, coords, contact=contact)
        start = contact if contact is not None else cfr
        instants = (max(0, start - INITIAL_LEAD), cfr)
    n = next(iter(coords.values())).shape[0]
    for i in instants:
        if not 0 <= i < n:
            raise ConfigError(f"instants: sample {i} outside the record of {n} samples")
    check_magnification(rig, magnify, {b: d[list(instants)] for b, d in coords.items()})
    drawn = []  # (xy, style) so the axes can be fitted to the content before drawing
    # a still plate's style is its own (its place among the massless bodies), the same in every figure
    # of the rig whichever moving bodies have coordinates
    still = [b.name for b in rig.bodies if b.mass is None]
    for body in rig.bodies:
        if body.plate is None:
            continue
        if body.name not in coords:
            xy = project(plate_corners(body.plate)[list(PLOT_INDEX)], eye, view_angles, rig.up) * 1e3
            if body.mass is None:
                colour, ls = STILL_GREYS[min(still.index(body.name), len(STILL_GREYS) - 1)]
                label = f"{body.name} (does not move)"
            else:
                colour, ls = UNMEASURED_STYLE
                label = f"{body.name} at rest (moves; its sensors give no coordinates)"
            drawn.append((xy, dict(ls=ls, color=colour, lw=1.0, label=label)))
            continue
        d = coords[body.name][list(instants)]
        poly = corners(body, d, magnify)[:, list(PLOT_INDEX)]
        for k, (ls, what) in enumerate((("-.", "initial position"), ("-", "characteristic forced response"))):
            xy = project(poly[k], eye, view_angles, rig.up) * 1e3
            drawn.append((xy, dict(ls=ls, color="k", lw=1.4 if k else 1.0,
                                   label=f"{body.name}: {what} (t = {1e3 * instants[k] / fs:.2f} ms)")))
    every = np.concatenate([xy for xy, _ in drawn])
    lo, hi = every.min(0), every.max(0)
    pad = 0.04 * (hi - lo).max()
    lo, hi = lo - pad, hi + pad
    width, height = hi - lo
    # two legend columns only while two labels fit the figure's width (else they are cut at its edges)
    ncol = 2 if max(len(style["label"]) for _, style in drawn) <= 40 else 1
    # the figure takes the content's shape (equal scales); the titles, the x label and the legend's
    # rows underneath get their own room (a one-column legend of four rows pushed the title off)
    fig_w = 6.4
    room = 1.0 + 0.17 * -(-len(drawn) // ncol)
    fig = _new_figure((fig_w, min(9.0 + room, max(2.6, fig_w * height / width + room))))
    ax = fig.add_subplot()
    for xy, style in drawn:
        ax.plot(xy[:, 0], xy[:, 1], **style)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    right, up = screen_axes(eye, rig.up)
    ax.set_xlabel(_axis_label(right))
    ax.set_ylabel(_axis_label(up))
    ax.set_aspect("equal", adjustable="box")
    head = title or f"eye on {eye}, view angles {tuple(float(a) for a in view_angles)} deg"
    ax.set_title(f"{head}\n{magnification_words(magnify)}", fontsize=10)
    fig.legend(fontsize=8, loc="outside lower center", ncol=ncol, frameon=False)
    return FigureResult(_save(fig, path, dpi), fig, tuple(int(i) for i in instants), magnify)


def _pair(measured: np.ndarray, model: np.ndarray, what: str) -> tuple[np.ndarray, np.ndarray]:
    a, b = np.asarray(measured, dtype=float), np.asarray(model, dtype=float)
    if a.ndim == 1 and b.ndim == 1:
        a, b = a[:, None], b[:, None]
    if a.ndim != 2 or a.shape != b.shape:
        raise DimensionError(f"{what}: measured {a.shape} and model {b.shape} must both be (n, k)")
    return a, b


#: SI prefixes by power of 1000, for one prefix per axis (mixed ones on one axis mislead).
PREFIXES = {-4: "p", -3: "n", -2: "µ", -1: "m", 0: "", 1: "k", 2: "M"}


def _prefix(peak: float) -> tuple[str, float]:
    """The SI prefix that puts ``peak`` between 1 and 1000, and its factor."""
    if not np.isfinite(peak) or peak <= 0:
        return "", 1.0
    k = int(np.clip(np.floor(np.log10(peak) / 3), min(PREFIXES), max(PREFIXES)))
    return PREFIXES[k], 1000.0 ** k


def comparison_figure(
    t: np.ndarray,
    measured: np.ndarray,
    model: np.ndarray,
    path: str | Path,
    *,
    names: Sequence[str] = COORDINATES,
    units: Sequence[str] = COORDINATE_UNITS,
    title: str = "",
    dpi: int = 150,
    window: tuple[float, float] | None = None,
) -> FigureResult:
    """Measured vs model, one panel per column (thesis Fig. 5.8-5.11: model solid, measured dashed).

    Defaults label the six generalized coordinates; pass ``names``/``units`` for sensor channels.
    ``window`` (s): draw only that stretch (the event, not the whole record). Each panel has one
    unit prefix (in its label), and the model's line is drawn over the measured one.
    """
    from matplotlib.ticker import FuncFormatter

    a, b = _pair(measured, model, "comparison")
    t = np.asarray(t, dtype=float)
    if t.shape != (a.shape[0],):
        raise DimensionError(f"comparison: time has shape {t.shape}, the signals have {a.shape[0]} samples")
    if window is not None:
        keep = (t >= window[0]) & (t <= window[1])
        if not keep.any():
            raise ConfigError(f"comparison: window {window[0]:g}-{window[1]:g} s holds no sample")
        t, a, b = t[keep], a[keep], b[keep]
    k = a.shape[1]
    if len(names) != k or len(units) != k:
        raise DimensionError(f"comparison: {k} columns but {len(names)} names and {len(units)} units")
    cols = 2 if k > 3 else 1
    rows = -(-k // cols)
    fig = _new_figure((4.2 * cols, 1.6 * rows + 0.6), layout=None)
    _grid_margins(fig, rows, cols, left=0.8, right=0.12, bottom=0.5, top=0.12, wspace=0.85, hspace=0.12, title=title)
    axes = fig.subplots(rows, cols, sharex=True, squeeze=False).T.ravel()  # column-major, as the thesis
    for j in range(k):
        ax = axes[j]
        ax.plot(t * 1e3, b[:, j], "-", color="k", lw=1.0, label="model", zorder=3)
        ax.plot(t * 1e3, a[:, j], "--", color="tab:blue", lw=1.0, label="measured", zorder=2)
        prefix, scale = _prefix(max(np.abs(a[:, j]).max(), np.abs(b[:, j]).max()))
        ax.set_ylabel(f"{names[j]} [{prefix}{unit_text(units[j])}]")
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _, s=scale: f"{v / s:g}"))
        ax.grid(alpha=0.3)
    for ax in axes[k:]:
        ax.set_visible(False)
    for j in range(k):
        if j % rows == rows - 1 or j == k - 1:  # the lowest panel of each column: its time ticks too
            axes[j].set_xlabel("t [ms]")
            axes[j].xaxis.set_tick_params(labelbottom=True)
    axes[0].legend(fontsize=8, loc="upper right")
    if title:
        fig.suptitle(title, fontsize=10)
    return FigureResult(_save(fig, path, dpi), fig)


def residual_spectra_figure(
    fs: float,
    measured: np.ndarray,
    model: np.ndarray,
    path: str | Path,
    *,
    names: Sequence[str],
    units: Sequence[str],
    nperseg: int | None = None,
    title: str = "",
    dpi: int = 150,
    before_save: Callable[[object], None] | None = None,
) -> FigureResult:
    """Welch power spectral densities of each measured channel and of its residual (measured - model).
    ``before_save(figure)`` may add to the figure (lines, a legend) before it is saved, once."""
    from scipy.signal import welch

    a, b = _pair(measured, model, "residual spectra")
    k = a.shape[1]
    if len(names) != k or len(units) != k:
        raise DimensionError(f"residual spectra: {k} channels but {len(names)} names and {len(units)} units")
    nper = min(a.shape[0], nperseg or 1024)
    f, pa = welch(a, fs=fs, nperseg=nper, axis=0)
    _, pr = welch(a - b, fs=fs, nperseg=nper, axis=0)
    cols = 3 if k > 4 else 1
    rows = -(-k // cols)
    fig = _new_figure((3.6 * cols, 1.9 * rows + 0.6), layout=None)
    _grid_margins(fig, rows, cols, left=0.75, right=0.12, bottom=0.95, top=0.25, wspace=0.8, hspace=0.3,
                  title=title)
    axes = fig.subplots(rows, cols, sharex=True, squeeze=False).ravel()
    tiny = np.finfo(float).tiny
    for j in range(k):
        ax = axes[j]
        # log frequency: the modes of a rig sit in the first few per cent of a linear 0..fs/2 axis
        ax.loglog(f[1:], np.maximum(pa[1:, j], tiny), color="tab:blue", lw=0.9, label="measured")
        ax.loglog(f[1:], np.maximum(pr[1:, j], tiny), color="tab:red", lw=0.9, label="residual")
        ax.set_xlim(f[1], f[-1])
        ax.set_title(names[j], fontsize=9, y=1.0)  # placed: matplotlib skips measuring the tick labels for room
        ax.set_ylabel(f"PSD [({unit_text(units[j])})²/Hz]", fontsize=8)
        ax.grid(alpha=0.3, which="both")
    for ax in axes[k:]:
        ax.set_visible(False)
    for ax in axes[max(0, k - cols):k]:
        ax.set_xlabel("f [Hz]")
    # under the panels, where it hides no curve; callers add their own lines to it (see legend_below)
    legend_below(fig, axes[0].get_legend_handles_labels()[0])
    if title:
        fig.suptitle(title, fontsize=10)
    if before_save is not None:
        before_save(fig)
    return FigureResult(_save(fig, path, dpi), fig)


def legend_below(fig, handles) -> None:
    """One legend for every panel, under them (replacing an earlier one)."""
    for old in fig.legends:
        old.remove()
    fig.legend(handles=handles, fontsize=8, loc="outside lower center", ncol=min(len(handles), 3), frameon=False)

