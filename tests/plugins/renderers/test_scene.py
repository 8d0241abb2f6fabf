"""Rendered frames put every plate corner where the camera's projection of the posed corner says."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage
from scipy.spatial.transform import Rotation

from odsuite.domain.errors import ConfigError, DimensionError

pytestmark = pytest.mark.render

POSE = np.array([1.0e-6, -2.0e-6, 1.5e-6, 2.0e-5, -1.0e-5, 3.0e-5])  # m, rad at G
H = (4000.0, 5000.0)


def expected_corners(body, d, magnify):
    """Posed corners from the plate's own numbers and scipy's rotation (R = Rz Ry Rx)."""
    size, c0 = body.plate.size, body.plate.corner
    rest = np.array([c0 + size * np.array([i, j, k]) for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    R = Rotation.from_euler("ZYX", magnify[1] * d[[5, 4, 3]]).as_matrix()
    return body.com + magnify[0] * d[:3] + (rest - body.com) @ R.T


def world_to_pixel(renderer, points, height):
    """Image (column, row) of world points by VTK's own camera transform (vtkCoordinate)."""
    from vtkmodules.vtkRenderingCore import vtkCoordinate

    c = vtkCoordinate()
    c.SetCoordinateSystemToWorld()
    out = []
    for p in points:
        c.SetValue(*p)
        x, y = c.GetComputedDoubleDisplayValue(renderer)
        out.append((x - 0.5, height - y - 0.5))  # display y runs up from the bottom edge
    return np.array(out)


def marker_centroids(img, colour=(255, 0, 0)):
    """Centres of the square corner markers; edges drawn across a marker may hide some of its
    pixels, so pieces of one 5 x 5 marker are merged and each marker's bounding box is used."""
    mask = np.all(img == np.array(colour, dtype=np.uint8), axis=-1)
    labels, n = ndimage.label(ndimage.binary_dilation(mask, iterations=2))
    boxes = ndimage.find_objects(labels * mask)
    return np.array([((b[1].start + b[1].stop - 1) / 2, (b[0].start + b[0].stop - 1) / 2) for b in boxes if b])


@pytest.mark.parametrize("parallel, view", [(False, (60.0, 25.0)), (True, (-35.0, 40.0))])
def test_corners_land_on_projected_pixels(thesis_rig, parallel, view):
    from odsuite_plugins.renderers.scene import Scene

    body = thesis_rig.body("platform")
    # the sensor dots sit on corners too; they have their own test below
    scene = Scene(thesis_rig, {"platform": POSE[None, :]}, magnify=H, view=view, parallel=parallel,
                  axes=False, ghost=False, markers=True, sensors=False, size=(800, 600))
    try:
        img = scene.frame(0)
        want = world_to_pixel(scene.renderer(), expected_corners(body, POSE, H), 600)
    finally:
        scene.close()
    got = marker_centroids(img)
    assert len(got) == 8
    dist = np.linalg.norm(want[:, None, :] - got[None, :, :], axis=-1)
    nearest = dist.min(axis=1)
    assert nearest.max() < 2.0, nearest
    # the pose moved the corners visibly: the rest corners are not where the markers are
    rest = world_to_pixel(scene.renderer(), expected_corners(body, np.zeros(6), H), 600)
    assert np.linalg.norm(rest - want, axis=1).max() > 10


@pytest.mark.parametrize("elevation", [90.0, -90.0])
def test_straight_down_or_up_the_picture_is_the_one_just_off_the_pole(thesis_rig, elevation, capfd):
    """At elevation +-90 the rig's up lies along the view: VTK warned 'Resetting view-up since view
    plane normal is parallel' and turned the picture its own way. The picture's up is the rig's up
    squared to the view: no warning, and the corners land where they do 0.1 degree off the pole."""
    from odsuite_plugins.renderers.scene import Scene

    body = thesis_rig.body("platform")
    pixels = []
    for view in ((30.0, elevation), (30.0, elevation - np.sign(elevation) * 0.1)):
        scene = Scene(thesis_rig, {"platform": POSE[None, :]}, magnify=H, view=view, ghost=False,
                      markers=True, sensors=False, size=(640, 480))
        try:
            scene.frame(0)
            pixels.append(world_to_pixel(scene.renderer(), expected_corners(body, POSE, H), 480))
        finally:
            scene.close()
    assert "view-up" not in capfd.readouterr().err
    assert np.abs(pixels[0] - pixels[1]).max() < 2.0, pixels


def test_sensor_dots_and_hammer_arrow_follow_the_pose(thesis_rig):
    """Each sensor spot (sensors sharing a position share a dot) is drawn where the posed point
    projects; the hammer arrow turns red exactly while the force is in contact."""
    from odsuite_plugins.renderers.scene import Hammer, Scene

    body = thesis_rig.body("platform")
    spots = np.unique(np.array([s.position for s in thesis_rig.sensors if s.body == "platform"]), axis=0)
    R = Rotation.from_euler("ZYX", H[1] * POSE[[5, 4, 3]]).as_matrix()
    posed = body.com + H[0] * POSE[:3] + (spots - body.com) @ R.T
    force = np.array([0.0, 10.0])
    hammer = Hammer("platform", np.array([0.0, 0.0, body.plate.corner[2]]), np.array([0.0, 0.0, 1.0]), force)
    scene = Scene(thesis_rig, {"platform": np.repeat(POSE[None, :], 2, axis=0)}, magnify=H, axes=False,
                  ghost=False, hammer=hammer, size=(800, 600))
    try:
        quiet, hit = scene.frame(0), scene.frame(1)
        want = world_to_pixel(scene.renderer(), posed, 600)
        colour = tuple((np.array(scene.style.sensor) * 255).round().astype(int))
        red = (np.array(scene.style.hammer) * 255).round().astype(np.uint8)
    finally:
        scene.close()
    assert len(spots) == 4
    # a 9-pixel dot of the sensor colour centred on each posed spot (the names share the colour,
    # so count the dot's pixels around the spot rather than blobs in the whole image)
    mask = np.all(quiet == np.array(colour, dtype=np.uint8), axis=-1)
    rows, cols = np.mgrid[: mask.shape[0], : mask.shape[1]]
    for x, y in want:
        near = (np.hypot(cols - x, rows - y) <= 3.5) & mask
        assert near.sum() >= 20, (x, y, near.sum())
    arrow = lambda img: np.all(img == red, axis=-1).sum()  # noqa: E731
    assert arrow(hit) - arrow(quiet) > 200  # the 5-pixel red shaft; the label and legend are red in both


def test_frame_is_top_up_and_shows_progress(thesis_rig):
    """With the default view the platform (z down in the rig frame) is drawn above the base."""
    from odsuite_plugins.renderers.scene import Scene

    coords = {"platform": np.zeros((3, 6))}
    scene = Scene(thesis_rig, coords, axes=False, ghost=False, markers=True, size=(640, 480))
    try:
        img = scene.frame(1, "t = 0", progress=0.5)
        top = world_to_pixel(scene.renderer(), [thesis_rig.body("platform").com], 480)[0]
        base = world_to_pixel(scene.renderer(), [thesis_rig.body("base").com], 480)[0]
    finally:
        scene.close()
    assert top[1] < base[1]  # image rows grow downwards
    bar = img[-3, :, :].astype(int)
    filled = np.all(bar == (np.array(scene.style.measured) * 255).astype(np.uint8), axis=-1)
    assert filled[:315].all() and not filled[325:].any()


def test_side_by_side_draws_model_in_second_viewport(thesis_rig):
    from odsuite_plugins.renderers.scene import Scene

    d = np.zeros((1, 6))
    scene = Scene(thesis_rig, {"platform": d}, model_coords={"platform": d}, layout="side-by-side",
                  axes=False, size=(640, 240))
    try:
        img = scene.frame(0).astype(int)
    finally:
        scene.close()
    model = np.all(np.abs(img - np.array(scene.style.model) * 255) < 2, axis=-1)
    measured = np.all(np.abs(img - np.array(scene.style.measured) * 255) < 2, axis=-1)
    assert model[:, 320:].sum() > 100 and model[:, :320].sum() == 0
    assert measured[:, :320].sum() > 100 and measured[:, 320:].sum() == 0


def test_bad_coordinates_are_named(thesis_rig):
    from odsuite_plugins.renderers.scene import Scene

    with pytest.raises(DimensionError, match="platform"):
        Scene(thesis_rig, {"platform": np.zeros((4, 5))})
    with pytest.raises(ConfigError, match="wing"):
        Scene(thesis_rig, {"wing": np.zeros((4, 6))})
    with pytest.raises(ConfigError, match="layout"):
        Scene(thesis_rig, {"platform": np.zeros((4, 6))}, model_coords={"platform": np.zeros((4, 6))},
              layout="stacked")


def test_scale_bar_is_a_round_amount_of_motion_as_long_as_the_plate():
    """The bar's real length is 1, 2 or 5 x 10^k m; magnified, it is within a factor sqrt(2.5) of
    the plate's size (the 1-2-5 steps' largest gap on a log scale); and its label says mm."""
    from odsuite_plugins.renderers.scene import _mm, _spot_label, scale_bar_length

    for scale, magnify in ((0.6, 3828.0), (0.4, 1.0), (1.2, 57.3), (0.3, 2.4e5)):
        real, drawn = scale_bar_length(scale, magnify)
        mantissa = real / 10.0 ** np.floor(np.log10(real) + 1e-9)
        assert min(abs(mantissa - m) for m in (1.0, 2.0, 5.0)) < 1e-9
        assert drawn == pytest.approx(real * magnify)
        assert 1 / np.sqrt(2.5) <= drawn / scale <= np.sqrt(2.5)
    assert scale_bar_length(0.6, 3828.0)[0] == pytest.approx(2e-4) and _mm(2e-4) == "0.2 mm"
    assert _spot_label(["P1_x", "P1_y", "P1_z"]) == "P1_xyz" and _spot_label(["a", "b"]) == "a b"


def test_the_hammer_arrow_is_sized_by_the_body_it_hits(registries):
    """On the three-body stand (a 2 m frame, a 0.3 m head on top) a blow on the head draws an arrow
    of a tenth of the scene (0.2 m, more than half the head's 0.3 m plate), not half the frame's
    (1 m, which ran out of the picture through the title); on the thesis platform it stays half its
    plate."""
    from pathlib import Path

    from odsuite.domain.rig import load_rig
    from odsuite_plugins.renderers.scene import Hammer, Scene

    rig = load_rig(Path(__file__).resolve().parents[2] / "data" / "rigs" / "three-body-stand.toml",
                   registries.sensor_types)
    lengths = {}
    for name, point in (("head", [0.05, 0.04, 0.67]), ("frame", [-0.9, 0.0, 0.17])):
        coords = {b: np.zeros((2, 6)) for b in ("frame", "pedestal", "head")}
        hammer = Hammer(name, np.array(point), np.array([0.0, 0.0, -1.0]), np.array([0.0, 10.0]))
        scene = Scene(rig, coords, axes=False, ghost=False, hammer=hammer, size=(320, 240))
        try:
            arrow = next(series for _, series in scene._moving if series.shape[1:] == (4, 3))
        finally:
            scene.close()
        np.testing.assert_allclose(arrow[0, 1], point)  # the tip on the force point
        lengths[name] = float(np.linalg.norm(arrow[0, 0] - arrow[0, 1]))
    assert lengths["head"] == pytest.approx(0.2) and lengths["frame"] == pytest.approx(1.0)


@pytest.mark.parametrize("view", [(60.0, 25.0), (-35.0, 40.0)])
def test_sensor_names_cover_no_other_name_nor_a_dot(thesis_rig, view):
    """Each spot's name is beside its dot: no two names' boxes overlap and none covers a dot (a
    name anchored on its point was drawn under the dot and across the neighbouring names)."""
    from odsuite_plugins.renderers.scene import DOT_ROOM_PX, Scene, _overlap

    coords = {"platform": np.stack([np.zeros(6), POSE])}
    scene = Scene(thesis_rig, coords, magnify=H, view=view, size=(1280, 720), title="T6: a title")
    try:
        for index in (0, 1):
            scene.frame(index)
            boxes = scene.sensor_label_boxes()
            dots = [scene._to_display(series[index]) for _, series, _, _ in scene._sensor_labels]
            assert len(boxes) == 4
            names = list(boxes)
            for i, a in enumerate(names):
                for b in names[i + 1:]:
                    assert not _overlap(boxes[a], boxes[b]), (a, b, boxes[a], boxes[b])
                for x, y in dots:
                    dot = np.array([x - DOT_ROOM_PX / 2, x + DOT_ROOM_PX / 2, y - DOT_ROOM_PX / 2, y + DOT_ROOM_PX / 2])
                    assert not _overlap(boxes[a], dot), (a, boxes[a], (x, y))
    finally:
        scene.close()


@pytest.mark.parametrize("view", [(60.0, 25.0), (-35.0, 40.0), (150.0, 20.0), (30.0, 90.0), (30.0, -90.0)])
def test_axes_and_scale_bar_lie_inside_the_frame_below_the_title(thesis_rig, view):
    """The axes' origin and tips and the scale bar fall inside the frame, a text line clear of
    its edges, below the title and clock and above the progress bar (the axes ran out of the
    frame's bottom edge)."""
    from odsuite_plugins.renderers.scene import Scene

    w, h = 1280, 720
    scene = Scene(thesis_rig, {"platform": np.zeros((1, 6))}, magnify=H, view=view, size=(w, h),
                  title="T6: measured motion\nslow motion; magnified")
    try:
        scene.frame(0, "t = 0 ms", progress=0.5)
        axes = world_to_pixel(scene.renderer(), scene._decorations, h)
        start, end, name = scene.scale_bar_pixels()
        clock_bottom = h - scene._label.GetPosition()[1]
    finally:
        scene.close()
    assert len(axes) == 4  # origin and three tips
    # the bar's ends and its name's corners, as image (column, row)
    bar = np.array([start, end, *[(x, y) for x in name[:2] for y in name[2:]]]) * [1, -1] + [0, h]
    points = np.concatenate([axes, bar])
    margin = scene.style.font_size
    assert (points[:, 0] > margin).all() and (points[:, 0] < w - margin).all(), points
    assert (points[:, 1] > clock_bottom + margin).all(), (points, clock_bottom)
    assert (points[:, 1] < h - max(4, h // 120) - margin).all(), points
    # a ruler one can read: at a tenth of the plate it was 15-18 pixels of 1280
    assert np.linalg.norm(points[5] - points[4]) > 0.1 * w, points


def posed(body, d, magnify, points):
    """Points fixed on ``body`` moved by ``d`` at G, magnified (scipy's rotation, R = Rz Ry Rx)."""
    R = Rotation.from_euler("ZYX", magnify[1] * d[[5, 4, 3]]).as_matrix()
    return body.com + magnify[0] * d[:3] + (np.asarray(points, float) - body.com) @ R.T


def bar_and_name(img, style, below_row):
    """The scale bar and its name found in a frame (image columns and rows, inclusive): the bar
    is the only run of the text's colour at least 40 pixels long and 3 to 6 rows thick below
    ``below_row`` (a line drawn across it leaves gaps of a few pixels, closed here); its name is
    the text-coloured pixels in the two text lines under it."""
    ink = np.all(np.abs(img.astype(int) - np.array(style.text) * 255) < 20, axis=-1)
    ink[: below_row + 1] = False
    labels, _ = ndimage.label(ndimage.binary_closing(ink, structure=np.ones((1, 9))))
    bars = [b for b in ndimage.find_objects(labels)
            if b[1].stop - b[1].start >= 40 and 3 <= b[0].stop - b[0].start <= 6]
    assert len(bars) == 1, bars
    rows, cols = bars[0]
    bar = np.array([cols.start, cols.stop - 1, rows.start, rows.stop - 1])
    left = max(0, cols.start - 2 * style.font_size)
    r, c = np.nonzero(ink[rows.stop: rows.stop + 3 * style.font_size, left:])
    name = np.array([c.min() + left, c.max() + left, r.min() + rows.stop, r.max() + rows.stop])
    return bar, name


def segment_points(a, b):
    """Points every half pixel along the image segment a-b."""
    n = int(np.ceil(2 * np.linalg.norm(np.asarray(b) - a))) + 1
    return np.asarray(a) + np.linspace(0.0, 1.0, n)[:, None] * (np.asarray(b) - a)


def inside(points, box, grow):
    """Which image points (column, row) fall in ``box`` (columns, rows; inclusive) grown by ``grow``."""
    p = np.asarray(points, float).reshape(-1, 2)
    return ((p[:, 0] >= box[0] - grow) & (p[:, 0] <= box[1] + grow)
            & (p[:, 1] >= box[2] - grow) & (p[:, 1] <= box[3] + grow))


def overlap(a, b):
    """Whether boxes (column min, max, row min, max; inclusive) share a pixel."""
    return bool(a[0] <= b[1] and b[0] <= a[1] and a[2] <= b[3] and b[2] <= a[3])


BAR_CASES = [("thesis-dynamometer", "platform", (60.0, 25.0)), ("thesis-dynamometer", "platform", (-35.0, 40.0)),
             ("stiff-bracket", "bracket", (60.0, 25.0)), ("three-body-stand", "head", (150.0, 20.0))]


def bar_rig(registries, name):
    from pathlib import Path

    from odsuite.domain.rig import load_rig

    if name == "thesis-dynamometer":
        return registries.rigs.get(name)
    return load_rig(Path(__file__).resolve().parents[2] / "data" / "rigs" / f"{name}.toml", registries.sensor_types)


@pytest.mark.parametrize("rig_name, moving, view", BAR_CASES)
def test_scale_bar_and_its_name_cover_nothing_drawn(registries, rig_name, moving, view):
    """In every frame the scale bar and its name, found in the picture, lie clear of every plate
    edge (moving, at rest and still), sensor dot and name, the hammer's arrow, the axes and the
    legend, projected by VTK's own transform; and they stay put from frame to frame. Beside the
    axes they lay across the still base plate's outline (the demo's T6) and the bracket's bed."""
    from odsuite.domain.rigidbody import plate_corners
    from odsuite_plugins.renderers.scene import EDGES, Hammer, Scene

    rig = bar_rig(registries, rig_name)
    body = rig.body(moving)
    d = np.stack([np.zeros(6), POSE, -POSE])
    magnify = (0.15 * body.plate.size.max() / 2e-5,) * 2  # a plate-size motion of a fifth of a plate
    point = body.plate.corner + body.plate.size * [0.5, 0.5, 1.0]
    hammer = Hammer(moving, point, -np.asarray(rig.up, float), np.array([0.0, 10.0, 0.0]))
    w, h = 1280, 720
    scene = Scene(rig, {moving: d}, model_coords={moving: d}, magnify=magnify, view=view, hammer=hammer,
                  title="T6: measured motion (blue) and the model's (orange band)\n160 times slower; magnified")
    found = []
    try:
        for index in range(len(d)):
            img = scene.frame(index, "t = +1.00 ms from the hit    hammer force 10.0 N", progress=0.5)
            renderer = scene.renderer()
            clock_bottom = h - scene._label.GetPosition()[1]
            bar, name = bar_and_name(img, scene.style, int(clock_bottom))
            found.append((bar, name))
            edges = []
            for b in rig.bodies:
                if b.plate is None:
                    continue
                poses = [plate_corners(b.plate)] + ([posed(b, d[index], magnify, plate_corners(b.plate))]
                                                     if b.name == moving else [])
                for corners in poses:
                    px = world_to_pixel(renderer, corners, h)
                    edges += [(px[i], px[j]) for i, j in EDGES]
            axes = world_to_pixel(renderer, scene._decorations, h)
            edges += [(axes[0], tip) for tip in axes[1:]]
            arrow = next(series for _, series in scene._moving if series.shape[1:] == (4, 3))[index]
            a = world_to_pixel(renderer, arrow, h)
            edges += [(a[0], a[1]), (a[1], a[2]), (a[1], a[3])]
            points = np.concatenate([segment_points(p, q) for p, q in edges])
            dots = world_to_pixel(renderer, posed(body, d[index], magnify,
                                                  [s.position for s in rig.sensors if s.body == moving]), h)
            # sensor names, axis letters (at their tips) and the legend: boxes in image rows
            boxes = [np.array([x0, x1, h - y1, h - y0]) for x0, x1, y0, y1 in scene.sensor_label_boxes().values()]
            boxes += [np.array([x - 2, x + scene.style.font_size, y - scene.style.font_size, y + 2]) for x, y in axes[1:]]
            legend = scene.plotter.legend
            (lx, ly), (lw, lh) = legend.GetPosition(), legend.GetPosition2()
            boxes.append(np.array([lx * w, (lx + lw) * w, (1 - ly - lh) * h, (1 - ly) * h]))
            for part in (bar, name):
                assert not inside(points, part, 2.0).any(), (part, points[inside(points, part, 2.0)][:5])
                assert not inside(dots, part, 6.0).any(), (part, dots)
                for box in boxes:
                    assert not overlap(part, box), (part, box)
    finally:
        scene.close()
    assert all(np.array_equal(f[0], found[0][0]) and np.array_equal(f[1], found[0][1]) for f in found), found


@pytest.mark.parametrize("parallel, view", [(False, (60.0, 25.0)), (False, (-35.0, 40.0)), (True, (150.0, 20.0))])
def test_scale_bar_is_its_motion_as_drawn_at_the_moving_plates_centre(thesis_rig, parallel, view):
    """The bar's length in the picture is the magnified round motion it names, projected across
    the screen at the moving plate's centre (VTK's camera transform), to a pixel."""
    from odsuite.domain.rigidbody import plate_corners
    from odsuite_plugins.renderers.scene import Scene, _mm, scale_bar_length

    h = 720
    body = thesis_rig.body("platform")
    scene = Scene(thesis_rig, {"platform": np.stack([np.zeros(6), POSE])}, magnify=H, view=view, parallel=parallel,
                  size=(1280, h), title="T6")
    try:
        img = scene.frame(1, "t = 0 ms", progress=0.5)
        bar, _ = bar_and_name(img, scene.style, int(h - scene._label.GetPosition()[1]))
        cam = scene.renderer().GetActiveCamera()
        across = np.cross(cam.GetDirectionOfProjection(), cam.GetViewUp())
        real, drawn = scale_bar_length(float(body.plate.size.max()), H[0])
        corners = plate_corners(body.plate)
        centre = (corners.min(0) + corners.max(0)) / 2
        ends = world_to_pixel(scene.renderer(), [centre, centre + drawn * across / np.linalg.norm(across)], h)
        name = scene.scale_bar_pixels()[2]
    finally:
        scene.close()
    assert real == pytest.approx(5e-5) and _mm(real) == "0.05 mm"  # 0.2 m of plate at x4000
    assert bar[1] - bar[0] + 1 == pytest.approx(np.linalg.norm(ends[1] - ends[0]), abs=1.5)
    assert name[1] - name[0] > 100  # "0.05 mm of motion (x4,000)" is there to read


def test_free_spot_takes_the_corner_free_of_drawing():
    """The box goes in the free corner nearest (lower left first); with no free corner, in the
    free gap; with no gap at all, where it covers least."""
    from odsuite_plugins.renderers.scene import free_spot

    occupied = np.zeros((100, 200), dtype=bool)
    assert free_spot(occupied, 30, 10) == (0, 0)
    occupied[:20, :50] = True  # the lower left taken: the lower right is as near a corner
    assert free_spot(occupied, 30, 10) == (170, 0)
    occupied[:] = True
    occupied[40:52, 100:140] = False  # a 40 x 12 hole
    x, y = free_spot(occupied, 30, 10)
    assert 100 <= x <= 110 and 40 <= y <= 42 and not occupied[y:y + 10, x:x + 30].any()
    occupied[45, :] = True  # no room: the least covered spot, 30 pixels of a row
    x, y = free_spot(occupied, 30, 10)
    assert occupied[y:y + 10, x:x + 30].sum() == 30
