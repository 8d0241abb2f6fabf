"""Projection (Eq. 4.25, Table 4.2), comparison and residual-spectrum figures."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from PIL import Image
from scipy.spatial.transform import Rotation

from odsuite.domain.errors import ConfigError, DimensionError
from odsuite_plugins.renderers.figures import (comparison_figure, projection_figure,
                                               residual_spectra_figure)

# Table 4.2 plotting order and Table 4.1 corner vectors (units of l, w, h from corner C)
TABLE_4_2 = ["FRL", "RRL", "RRU", "RRL", "RLL", "RLU", "RLL", "FLL", "FLU", "FLL", "FRL", "FRU",
             "RRU", "RLU", "FLU", "FRU"]
TABLE_4_1 = {"FRU": (1, 0, 1), "FRL": (1, 0, 0), "FLU": (0, 0, 1), "FLL": (0, 0, 0),
             "RRU": (1, 1, 1), "RRL": (1, 1, 0), "RLU": (0, 1, 1), "RLL": (0, 1, 0)}


def polyline(body, d, h):
    p = body.plate
    rest = np.array([p.corner + p.size * np.array(TABLE_4_1[c]) for c in TABLE_4_2])
    R = Rotation.from_euler("ZYX", h * d[[5, 4, 3]]).as_matrix()
    return body.com + h * d[:3] + (rest - body.com) @ R.T


def test_projection_draws_table_4_2_polylines(thesis_rig, tmp_path):
    n = 600
    d = np.zeros((n, 6))
    d[300:, 3] = 2e-5 * np.sin(np.linspace(0, 6, 300))  # roll starting at sample 300
    d[300:, 2] = 1e-6 * np.sin(np.linspace(0, 6, 300))
    h = 3000.0
    view = (20.0, -10.0, 35.0)
    res = projection_figure(thesis_rig, {"platform": d}, 20000.0, tmp_path / "p.png", eye="x",
                            view_angles=view, magnify=(h, h), instants=(250, 400))
    ax = res.figure.axes[0]
    lines = {ln.get_label(): ln for ln in ax.lines}
    body = thesis_rig.body("platform")
    rv = Rotation.from_euler("ZYX", np.radians(view[::-1])).as_matrix()  # Eq. 4.25, R = Rz Ry Rx
    for k, (instant, style) in enumerate(((250, "-."), (400, "-"))):
        ln = next(v for name, v in lines.items() if name.startswith("platform") and f"{instant / 20:.2f} ms" in name)
        assert ln.get_linestyle() == style
        p = polyline(body, d[instant], h) @ rv.T
        # eye on +x looking at the origin with -z up: screen right is -y, screen up is -z
        np.testing.assert_allclose(ln.get_xydata(), np.column_stack([-p[:, 1], -p[:, 2]]) * 1e3, atol=1e-9)
    assert any(name.startswith("reference") for name in lines)
    with Image.open(res.path) as im:
        assert im.format == "PNG"
    # the axes hug the drawing (4 % margin of its larger span), the still plates differ in print,
    # and the title says the magnification in words
    xy = np.concatenate([ln.get_xydata() for ln in ax.lines])
    lo, hi = xy.min(0), xy.max(0)
    pad = 0.04 * (hi - lo).max()
    np.testing.assert_allclose([*ax.get_xlim(), *ax.get_ylim()], [lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad])
    still = [ln for name, ln in lines.items() if "does not move" in name]
    assert len(still) == 2 and len({(ln.get_color(), ln.get_linestyle()) for ln in still}) == 2
    assert ax.get_title().endswith("motion drawn 3,000 times larger than it is")


def test_a_flat_projection_keeps_its_title_inside_the_figure(thesis_rig, tmp_path):
    """Seen side-on (no view angles) the thesis rig is 5 times wider than high, and its legend's
    labels are too long for two columns: four rows under the drawing. The title (two lines) stays
    inside the figure as saved (it was pushed above the top edge)."""
    d = np.zeros((600, 6))
    d[300:, 2] = 1e-6 * np.sin(np.linspace(0, 6, 300))
    res = projection_figure(thesis_rig, {"platform": d}, 20000.0, tmp_path / "p.png", eye="x",
                            magnify=(3000.0, 3000.0), instants=(250, 400))
    fig, ax = res.figure, res.figure.axes[0]
    assert len(fig.legends[0].get_texts()) == 4 and fig.legends[0]._ncols == 1
    renderer = fig.canvas.get_renderer()
    fig.draw(renderer)  # the layout as saved
    title = ax.title.get_window_extent(renderer)
    assert title.y0 >= 0 and title.y1 <= fig.bbox.height


def test_projection_default_instants_use_the_force(thesis_rig, tmp_path):
    n, n0 = 800, 300
    d = np.zeros((n, 6))
    tau = np.arange(n - n0) / 20000.0
    d[n0:, 2] = 1e-6 * np.exp(-50 * tau) * np.sin(2 * np.pi * 200 * tau)
    force = np.zeros(n)
    force[n0] = 100.0
    res = projection_figure(thesis_rig, {"platform": d}, 20000.0, tmp_path / "p.svg", force=force, eye="y")
    # initial position 50 samples before the contact; CFR at the quarter period of 200 Hz (25 samples)
    assert res.instants[0] == n0 - 50
    assert res.instants[1] == pytest.approx(n0 + 25, abs=1)
    ET.parse(res.path)  # valid SVG (XML)


def test_comparison_figure_model_solid_measured_dashed(tmp_path):
    t = np.arange(200) / 20000.0
    model = np.column_stack([np.sin(2 * np.pi * 100 * t * (j + 1)) * 1e-6 for j in range(6)])
    measured = 1.1 * model
    res = comparison_figure(t, measured, model, tmp_path / "c.png")
    axes = {ax.get_ylabel().split(" [")[0]: ax for ax in res.figure.axes if ax.get_visible()}
    assert len(axes) == 6
    for j, name in enumerate(["x", "y", "z", "theta", "phi", "psi"]):
        ax = axes[name]
        # 1.1e-6 peak: one prefix for the whole axis, micro
        assert ax.get_ylabel() == f"{name} [µ{'m' if j < 3 else 'rad'}]"
        assert ax.yaxis.get_major_formatter()(5e-7, 0) == "0.5"
        mod, meas = ax.lines
        assert mod.get_linestyle() == "-" and meas.get_linestyle() == "--"
        assert mod.get_zorder() > meas.get_zorder()  # the model's line on top of the measured one
        np.testing.assert_array_equal(mod.get_ydata(), model[:, j])
        np.testing.assert_array_equal(meas.get_ydata(), measured[:, j])
        np.testing.assert_allclose(mod.get_xdata(), t * 1e3)
    # a window draws only the event's stretch
    win = comparison_figure(t, measured, model, tmp_path / "w.png", window=(0.002, 0.005))
    x = win.figure.axes[0].lines[0].get_xdata()
    assert x[0] == pytest.approx(2.0) and x[-1] == pytest.approx(5.0) and len(x) == 61
    with pytest.raises(DimensionError, match="comparison"):
        comparison_figure(t, measured[:, :5], model, tmp_path / "c.png")
    with pytest.raises(ConfigError, match=r"c\.jpg"):
        comparison_figure(t, measured, model, tmp_path / "c.jpg")


def test_residual_spectrum_peaks_at_the_unmodelled_frequency(tmp_path):
    fs = 20000.0
    t = np.arange(8192) / fs
    model = np.column_stack([np.sin(2 * np.pi * 120 * t), np.sin(2 * np.pi * 150 * t)])
    measured = model.copy()
    measured[:, 1] += 0.2 * np.sin(2 * np.pi * 625 * t)  # what the model lacks, on channel 2 only
    res = residual_spectra_figure(fs, measured, model, tmp_path / "r.svg", names=["a", "b"],
                                  units=["m/s²", "m/s²"], nperseg=2048)
    ax_a, ax_b = [ax for ax in res.figure.axes if ax.get_visible()]
    f, residual_b = ax_b.lines[1].get_xydata().T
    assert f[np.argmax(residual_b)] == pytest.approx(625, abs=fs / 2048)
    f, measured_a = ax_a.lines[0].get_xydata().T
    assert f[np.argmax(measured_a)] == pytest.approx(120, abs=fs / 2048)
    assert ax_a.lines[1].get_ydata().max() < 1e-20  # channel 1 fits exactly


@pytest.mark.parametrize("kind", ["comparison", "spectra"])
def test_many_panel_figures_keep_every_label_inside_and_apart(kind, tmp_path):
    """The fixed margins that replace constrained layout on many-panel figures leave every label
    on the figure, clear of the neighbouring panels, with the widest labels these figures draw
    (five-character ticks, '(m/s²)²/Hz' over eleven decades)."""
    rng = np.random.default_rng(3)
    fs, n, k = 2048.0, 4096, 18
    t = np.arange(n) / fs
    measured = rng.standard_normal((n, k)) * np.logspace(-5, 0, k) * 999.0  # peaks up to -999 in [m/s²]
    measured[:, 0] += 1e-8 * np.sin(2 * np.pi * 40 * t)  # a channel whose residual is ~1e-20
    model = measured + 1e-3 * rng.standard_normal((n, k))
    names, units = [f"M{j}_z" for j in range(k)], ["m/s^2"] * k
    if kind == "comparison":
        res = comparison_figure(t, measured, model, tmp_path / "c.png", names=names, units=units, title="H1: x",
                                dpi=90, window=(0.1, 0.16))
    else:
        res = residual_spectra_figure(fs, measured, model, tmp_path / "s.png", names=names, units=units,
                                      title="H1: spectra", dpi=90)
    fig = res.figure
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    width, height = fig.bbox.width, fig.bbox.height
    panels = [ax for ax in fig.axes if ax.get_visible()]
    # every panel with its drawn tick labels, axis labels and title, the title and the legend
    boxes = [ax.get_tightbbox(renderer) for ax in panels] + [leg.get_window_extent(renderer) for leg in fig.legends]
    if fig._suptitle is not None:
        boxes.append(fig._suptitle.get_window_extent(renderer))
    for box in boxes:
        assert box.x0 >= -0.5 and box.x1 <= width + 0.5 and box.y0 >= -0.5 and box.y1 <= height + 0.5, box
    for leg in fig.legends:  # the legend under the panels
        assert leg.get_window_extent(renderer).y1 <= min(ax.get_tightbbox(renderer).y0 for ax in panels) + 0.5
    for ax in panels:  # a panel's y label and tick labels stay clear of the panel to its left
        left = [o for o in panels if o.get_position().x1 < ax.get_position().x0
                and abs(o.get_position().y0 - ax.get_position().y0) < 1e-6]
        if not left:
            continue
        edge = max(o.get_window_extent(renderer).x1 for o in left)
        assert ax.yaxis.get_tightbbox(renderer).x0 > edge
    if fig._suptitle is not None:  # the title above every panel
        top = max(ax.get_tightbbox(renderer).y1 for ax in panels)
        assert fig._suptitle.get_window_extent(renderer).y0 >= top


@pytest.mark.parametrize("eye", ["x", "y", "z"])
def test_screen_axes_keep_the_thesis_view_and_follow_a_rigs_up(eye):
    from odsuite_plugins.renderers.figures import EYES, screen_axes

    right, up = screen_axes(eye)  # the thesis's z-down frame: its table
    np.testing.assert_allclose(right, EYES[eye][0], atol=1e-15)
    np.testing.assert_allclose(up, EYES[eye][1], atol=1e-15)
    right, up = screen_axes(eye, [0.0, 0.0, 1.0])
    towards_eye = np.eye(3)["xyz".index(eye)]
    # a right-handed screen (right x up towards the eye); z up on the screen, or the eye above
    np.testing.assert_allclose(np.cross(right, up), towards_eye if eye != "z" else [0.0, 0.0, 1.0], atol=1e-15)
    if eye != "z":
        np.testing.assert_allclose(up, [0.0, 0.0, 1.0])


@pytest.mark.parametrize("path, above", [
    # the machine's plate centre 150 mm above the base's in the rig (z up)
    ("projects/rigs/two-body-machine.toml", {("machine", "base"): 150.0}),
    # the motor 200 mm above the pump, the pump 175 mm above the frame
    ("tests/data/rigs/pump-set.toml", {("motor", "pump"): 200.0, ("pump", "frame"): 175.0}),
])
def test_projection_of_a_z_up_rig_draws_the_upper_body_above_and_keeps_the_legend_inside(tmp_path, path, above):
    from pathlib import Path

    from odsuite.contracts.plugins import build_registries, make_plugin_manager
    from odsuite.domain.rig import load_rig

    reg = build_registries(make_plugin_manager())
    rig = load_rig(Path(__file__).parents[3] / path, reg.sensor_types)
    still = np.zeros((100, 6))
    res = projection_figure(rig, {b.name: still for b in rig.bodies if b.mass is not None}, 2000.0,
                            tmp_path / "p.png", eye="x", magnify=(1.0, 1.0), instants=(10, 20))
    ax = res.figure.axes[0]
    height = {name.split(":")[0]: ln.get_xydata()[:, 1].mean() for name, ln in
              ((ln.get_label(), ln) for ln in ax.lines) if "initial" in name}
    for (upper, lower), dz in above.items():  # on the screen as in the rig
        assert height[upper] - height[lower] == pytest.approx(dz, abs=1e-9)
    assert ax.get_ylabel().startswith("z")
    fig = res.figure
    box = fig.legends[0].get_window_extent(fig.canvas.get_renderer())
    assert box.x0 >= 0 and box.x1 <= fig.bbox.width and box.y0 >= 0


@pytest.mark.parametrize("figure", ["overlay", "residuals"])
def test_overlay_and_residual_figures_draw_every_moving_body(figure, tmp_path, monkeypatch):
    from pathlib import Path

    from odsuite.contracts.plugins import build_registries, make_plugin_manager
    from odsuite.domain.rig import load_rig
    from odsuite_plugins.renderers import experiment

    reg = build_registries(make_plugin_manager())
    rig = load_rig(Path(__file__).parents[3] / "projects" / "rigs" / "two-body-machine.toml", reg.sensor_types)
    rng = np.random.default_rng(1)
    coords = {"base": rng.normal(size=(512, 6)), "machine": rng.normal(size=(512, 6))}
    model = {"base": 2 * coords["base"], "machine": 3 * coords["machine"]}
    seen = {}
    real = {"overlay": experiment.comparison_figure, "residuals": experiment.residual_spectra_figure}[figure]

    def spy(*args, **kw):
        seen.update(kw, measured=args[1], model=args[2])
        return real(*args, **kw)

    monkeypatch.setattr(experiment, {"overlay": "comparison_figure", "residuals": "residual_spectra_figure"}[figure], spy)
    experiment._figure(figure, rig, "hit1", coords, model, 2000.0, tmp_path / "f.png", force=None, view=None,
                       magnify=None)
    # twelve panels, the machine's roll among them with its own model (3x the measured)
    assert len(seen["names"]) == 12 and "machine theta" in seen["names"] and "base psi" in seen["names"]
    j = seen["names"].index("machine theta")
    np.testing.assert_array_equal(seen["measured"][:, j], coords["machine"][:, 3])
    np.testing.assert_array_equal(seen["model"][:, j], model["machine"][:, 3])
    assert seen["units"][j] == "rad" and "base, machine" in seen["title"]


def test_a_still_plate_keeps_its_style_whichever_bodies_have_coordinates(tmp_path):
    """The two-body machine's floor (no mass) is drawn alike whether or not the machine has
    coordinates; a machine without them is drawn at rest, not called still (it took the floor's
    solid grey and the floor became dashed, as if the styles had swapped between two figures)."""
    from pathlib import Path

    from odsuite.contracts.plugins import registries
    from odsuite.domain.rig import load_rig

    rig = load_rig(Path(__file__).parents[3] / "projects" / "rigs" / "two-body-machine.toml",
                   registries().sensor_types)
    d = np.zeros((600, 6))
    d[300:, 2] = 1e-6 * np.sin(np.linspace(0, 6, 300))
    styles = []
    for bodies in (("base", "machine"), ("base",)):
        res = projection_figure(rig, {b: d for b in bodies}, 5120.0, tmp_path / f"{len(bodies)}.png",
                                magnify=(3000.0, 3000.0), instants=(250, 400))
        lines = {ln.get_label(): ln for ln in res.figure.axes[0].lines}
        floor = lines["floor (does not move)"]
        styles.append((floor.get_color(), floor.get_linestyle()))
        machine = [name for name in lines if name.startswith("machine")]
        if "machine" not in bodies:
            assert machine == ["machine at rest (moves; its sensors give no coordinates)"]
    assert styles[0] == styles[1]
