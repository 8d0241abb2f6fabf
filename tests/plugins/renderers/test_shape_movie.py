"""Shapes moving on a geometry that is not a set of plates: an operating deflection shape through
`odsuite ods --movie` on a project without a rig (the drawn node motion is the record's, closed
form), and the Palisaden building's modes written as UFF 55 by the mode-shape renderer."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest

from odsuite.cli import main
from odsuite.domain.geometry import project_geometry
from odsuite.store.project import open_project
from odsuite_plugins.renderers.shapes import CYCLES, DRAWN_FRACTION, FRAMES_PER_CYCLE, shape_motion

FS, F0, N = 200.0, 5.0, 8192
MAST = ('nodes = [[1, 0, 0, 0], [2, 0, 0, 2], [3, 0, 0, 4]]\nlines = [[1, 2], [2, 3]]\nfixed = [1]\n'
        'sensors = [["a", 2, "+x"], ["b", 3, "+x"], ["c", 3, "-y"]]\n')


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def mast(tmp_path, capsys):
    """A 4 m mast on a project without a rig: its top moves 2.5 times its middle in x, against it
    in phase, and 0.5 times in -y, in step (a CSV record at 5 Hz with a little noise)."""
    rng = np.random.default_rng(5)
    t = np.arange(N) / FS
    s = np.sin(2 * np.pi * F0 * t)
    cols = {"a": s, "b": -2.5 * s, "c": 0.5 * s}
    with open(tmp_path / "r.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time"] + [f"{k} [m/s^2]" for k in cols])
        for i in range(N):
            w.writerow([repr(float(t[i]))] + [repr(float(v[i] + 1e-4 * rng.normal())) for v in cols.values()])
    (tmp_path / "mast.toml").write_text(MAST)
    path = tmp_path / "p.h5"
    assert run(capsys, "new", path, "--rig", "none")[0] == 0
    code, _, err = run(capsys, "import", path, tmp_path / "r.csv", "--name", "rec")
    assert code == 0, err
    code, _, err = run(capsys, "import", path, tmp_path / "mast.toml", "--name", "geometry")
    assert code == 0, err
    return path


def test_the_drawn_motion_is_the_operating_shape(mast):
    from odsuite.analysis.ods import operating_shape

    with open_project(mast) as p:
        g = project_geometry(p)
        ods = operating_shape(p, "rec", "a", F0)
    motion, factor, U = shape_motion(g, ods.shape)
    # node 3 against node 2: -2.5 along x, and c's -y reading 0.5 of a: y = -0.5 a
    assert U[2, 0] / U[1, 0] == pytest.approx(-2.5, rel=1e-3)
    assert U[2, 1] / U[1, 0] == pytest.approx(-0.5, rel=1e-3)
    assert np.abs(U[0]).max() == 0.0  # fixed
    # the largest drawn excursion is the documented fraction of the 4 m mast, once per cycle
    assert motion.shape == (FRAMES_PER_CYCLE * CYCLES, 3, 3)
    assert np.linalg.norm(motion, axis=2).max() == pytest.approx(DRAWN_FRACTION * 4.0, rel=1e-3)
    assert np.allclose(motion[0], motion[FRAMES_PER_CYCLE])


@pytest.mark.render
@pytest.mark.parametrize("elevation", [90.0, -90.0])
def test_a_shape_seen_straight_down_or_up_warns_nothing(elevation, capfd):
    """The picture's up is z squared to the view: at elevation +-90 z lies along it, and VTK warned
    that it reset the view-up (and turned the picture its own way)."""
    from odsuite.domain.geometry import Geometry
    from odsuite_plugins.renderers.shape_scene import ShapeScene, view_up_vector, view_vector

    g = Geometry("mast", np.array([1, 2, 3]), np.array([[0, 0, 0], [0, 0, 2], [1, 0, 4]], float), [[1, 2], [2, 3]])
    scene = ShapeScene(g, np.zeros((1, 3, 3)), view=(30.0, elevation), size=(320, 240))
    try:
        scene.frame(0)
        up = np.asarray(scene.plotter.camera.GetViewUp())
    finally:
        scene.close()
    assert "view-up" not in capfd.readouterr().err
    # the up VTK keeps is the one given, the limit of the picture just off the pole
    assert np.allclose(up, view_up_vector(30.0, elevation)) and abs(up @ view_vector(30.0, elevation)) < 1e-12
    assert np.allclose(view_up_vector(30.0, elevation), view_up_vector(30.0, elevation - np.sign(elevation) * 1e-4),
                       atol=1e-5)


@pytest.mark.render
def test_ods_movie_without_a_rig(mast, tmp_path, capsys):
    out = tmp_path / "ods.mp4"
    code, stdout, err = run(capsys, "ods", mast, "rec", "--reference", "a", "--at", F0, "--movie", out, "--json")
    assert code == 0, err
    doc = json.loads(stdout)
    assert Path(doc["movie"]["files"][0] if "files" in doc["movie"] else out).exists()
    reader = imageio_ffmpeg.read_frames(str(out))
    meta = next(reader)
    frames = np.array([np.frombuffer(f, np.uint8).reshape(meta["size"][1], meta["size"][0], 3) for f in reader])
    assert len(frames) == FRAMES_PER_CYCLE * CYCLES
    # the mast moves: half a cycle apart the frames differ where the top swings
    assert np.abs(frames[0].astype(int) - frames[FRAMES_PER_CYCLE // 2].astype(int)).max() > 100
    assert np.array_equal(frames[0], frames[FRAMES_PER_CYCLE]) or \
        np.abs(frames[0].astype(int) - frames[FRAMES_PER_CYCLE].astype(int)).mean() < 1.0


def test_no_rig_and_no_geometry_is_one_line(tmp_path, capsys):
    path = tmp_path / "p.h5"
    assert run(capsys, "new", path, "--rig", "none")[0] == 0
    code, _, err = run(capsys, "render", path, "rec", "-o", tmp_path / "m.mp4", "--renderer", "mode-shape",
                       "--mode", 1)
    assert code != 0 and "no geometry" in err and len(err.strip().splitlines()) == 1


@pytest.mark.slow
def test_palisaden_modes_as_uff_55_read_back_by_pyuff(tmp_path, capsys, real_data):
    import pyuff

    base = real_data / "palisaden_building"
    np.save(tmp_path / "pali.npy", np.load(base / "Palisaden_dataset.npy"))
    (tmp_path / "pali.toml").write_text('sampling_rate = 100.0\nunits = "m/s^2"\n')
    path = tmp_path / "p.h5"
    example = Path(__file__).resolve().parents[3] / "examples" / "geometry" / "palisaden.toml"
    assert run(capsys, "new", path, "--rig", "none")[0] == 0
    for file, name in ((tmp_path / "pali.npy", "ambient"), (example, "geometry")):
        code, _, err = run(capsys, "import", path, file, "--name", name)
        assert code == 0, err
    code, _, err = run(capsys, "render", path, "ambient", "-o", tmp_path / "modes.uff", "--renderer", "mode-shape")
    assert code == 0, err
    sets = pyuff.UFF(str(tmp_path / "modes.uff")).read_sets()
    modes = [s for s in sets if s["type"] == 55]
    freqs = [abs(s["eig"]) / (2 * np.pi) for s in modes]
    published = json.loads((base / "pyoma2_reference.json").read_text())["published_hz"]["SSIcov"]
    # each published mode is among those written (the identification's own band may hold more)
    assert all(min(abs(f / p - 1) for f in freqs) < 5e-3 for p in published)
    nodes = next(s for s in sets if s["type"] == 15)
    assert len(nodes["node_nums"]) == 42 and np.array_equal(modes[0]["node_nums"], nodes["node_nums"])


def test_the_building_as_a_rig_of_floors(tmp_path, capsys, real_data):
    """projects/rigs/palisaden-floors.toml: the top floor a plate moving in its plane; the record's
    channels go onto its sensors by name and the ODS at the first mode is the floor's sway along y."""
    from odsuite.analysis.ods import operating_shape

    rig = Path(__file__).resolve().parents[3] / "projects" / "rigs" / "palisaden-floors.toml"
    base = real_data / "palisaden_building"
    np.save(tmp_path / "pali.npy", np.load(base / "Palisaden_dataset.npy")[:60000])  # 10 minutes
    (tmp_path / "pali.toml").write_text('sampling_rate = 100.0\nchannels = "ch1,ch2,ch3,ch4,ch5,ch6"\n'
                                        'units = "m/s^2"\n')
    path = tmp_path / "p.h5"
    assert run(capsys, "new", path, "--rig", rig)[0] == 0
    code, _, err = run(capsys, "import", path, tmp_path / "pali.npy", "--name", "ambient")
    assert code == 0, err
    with open_project(path) as p:
        ods = operating_shape(p, "ambient", "ch4", 1.882)
    floor = ods.coordinates["top floor"]
    # x, y, z, theta, phi, psi: y dominates x and the twist (psi times a 10 m lever); no z, theta, phi seen
    assert abs(floor[1]) > 5 * abs(floor[0]) and abs(floor[1]) > 5 * abs(floor[5]) * 10.0
    assert floor[2] == floor[3] == floor[4] == 0


@pytest.mark.parametrize("existing", ["link", "project"])
def test_a_shape_movies_gif_fallback_never_replaces_a_file_the_user_did_not_name(tmp_path, monkeypatch, existing):
    """-o m.mp4 without an H.264 encoder writes m.gif: the shape movie wrote it through a link (into
    the user's talk.gif) or over a file that is no GIF, which the plate movie refused; the same one
    line now, and the file is left as it was."""
    from odsuite.domain.errors import ConfigError
    from odsuite.domain.geometry import Geometry, GeometrySensor
    from odsuite_plugins.renderers import movie
    from odsuite_plugins.renderers.shapes import render_shape_movie

    monkeypatch.setattr(movie, "mp4_available", lambda: False)
    g = Geometry("mast", np.array([1, 2, 3]), np.array([[0, 0, 0], [0, 0, 2], [0, 0, 4]], float), [[1, 2], [2, 3]],
                 sensors=(GeometrySensor("a", 3, (1.0, 0.0, 0.0)),), fixed=(1,))
    kept = tmp_path / ("talk.gif" if existing == "link" else "m.gif")
    kept.write_bytes(b"\x89HDF\r\n\x1a\n precious")
    if existing == "link":
        (tmp_path / "m.gif").symlink_to(kept)
    with pytest.raises(ConfigError, match=r"m\.mp4: no H\.264 encoder .* m\.gif, the GIF written instead, is "
                                          f"{'a link' if existing == 'link' else 'another file'}: give -o m\\.gif"):
        render_shape_movie(g, {"a": 1.0 + 0j}, 5.0, tmp_path / "m.mp4", title="mast", what="mode shape 1",
                           workers=1, progress=False)
    assert kept.read_bytes() == b"\x89HDF\r\n\x1a\n precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted({"m.gif", kept.name})


@pytest.mark.parametrize("output, options", [("m.mp4", []), ("m.png", ["--figure", "projection"])])
def test_a_record_movie_without_a_rig_names_what_the_geometry_can_draw(mast, tmp_path, capsys, output, options):
    # the refusal said the project had "no geometry of nodes and lines" when it had one
    code, _, err = run(capsys, "render", mast, "rec", "-o", tmp_path / output, *options)
    assert code == 1 and len(err.strip().splitlines()) == 1
    assert "no geometry" not in err and "geometry 'geometry'" in err
    assert "--renderer mode-shape --mode K" in err and "--ods HZ --reference SENSOR" in err
