"""`odsuite render` on a project: movie, projection and comparison figures, clear errors."""

from __future__ import annotations

import json
import os
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest
from PIL import Image

from odsuite.cli import main
from odsuite_plugins.importers.legacy import write_dat
from odsuite.store.project import DerivedArray, open_project
from tests.core.test_legacy_import import legacy_volts
from tests.core.test_systeminfo import TABLE_E3


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def project(tmp_path, capsys):
    data = legacy_volts()
    write_dat(tmp_path / "T5.DAT", data)
    path = tmp_path / "p.h5"
    assert run(capsys, "new", path)[0] == 0
    code, _, err = run(capsys, "import-legacy", path, tmp_path / "T5.DAT", "--systeminfo", TABLE_E3, "--name",
                       "T5", "--force-point=50.025,-75.761,-6.320", "--force-dir=-x")
    assert code == 0, err
    with open_project(path, "a") as p:
        n = p.experiment("T5").n_samples
        t = np.arange(n) / p.experiment("T5").sampling_rate
        d = np.zeros((n, 6))
        d[:, 0] = 1e-6 * np.sin(2 * np.pi * 150 * t)
        d[:, 5] = 1e-5 * np.sin(2 * np.pi * 210 * t)
        prov = {"plugin": "test", "version": "0", "parameters": {}}
        p.write_derived("T5", "gencoords", {"platform_at_g": DerivedArray(d, "m m m rad rad rad", ("sample", "coordinate"))},
                        provenance=prov)
    return path, d


@pytest.mark.render
def test_render_movie(project, tmp_path, capsys):
    path, d = project
    out = tmp_path / "T5.mp4"
    code, stdout, err = run(capsys, "render", path, "T5", "-o", out, "--magnify", "2000,3000", "--view", "30,20",
                            "--workers", "1", "--frame-step", "64", "--start", "0")
    assert code == 0, err
    assert "translations drawn 2,000 times, rotations 3,000 times larger than they are" in stdout
    frames, _ = imageio_ffmpeg.count_frames_and_secs(str(out))
    assert frames == -(-d.shape[0] // 64)


@pytest.mark.render
def test_render_magnify_zero_holds_that_motion_still(project, tmp_path, capsys):
    """A factor 0 draws the other motion alone, without the scale bar (a ruler of motion drawn x0 has
    no length: it divided by zero); --json stays one document."""
    path, _ = project
    for magnify, words in (("0,0", "motion held still (x0)"),
                           ("0,3000", "translations held still (x0), rotations drawn 3,000 times larger")):
        code, stdout, err = run(capsys, "render", path, "T5", "-o", tmp_path / "m.gif", "--magnify", magnify,
                                "--duration", "0.2", "--workers", "1", "--json")
        assert code == 0, err
        assert words in json.loads(stdout)["summary"]


@pytest.mark.render
def test_render_summary_tells_the_speed_and_rate_the_movie_plays_at(project, tmp_path, capsys):
    """Faster than real time reads 'N times faster' (it printed '0 times slower'); a GIF asked for
    30 fps plays at 33.33 (whole-centisecond delays), which the summary prints."""
    path, _ = project
    code, stdout, err = run(capsys, "render", path, "T5", "-o", tmp_path / "m.mp4", "--slowdown", "0.25",
                            "--start", "0", "--workers", "1")
    assert code == 0, err
    assert "4 times faster than real time" in stdout
    code, stdout, err = run(capsys, "render", path, "T5", "-o", tmp_path / "m.gif", "--fps", "30",
                            "--frame-step", "64", "--start", "0", "--workers", "1")
    assert code == 0, err
    assert "32 frames at 33.33 fps (0.96 s), 9.38 times slower than real time" in stdout
    assert "it plays at 33.33 fps (3/100 s a frame), not 30" in err and len(err.strip().splitlines()) == 1


def test_render_refuses_a_magnification_no_picture_can_show(project, tmp_path, capsys):
    """--magnify 1e300 drew overflowed geometry (a movie and a projection figure were written): a
    drawn motion beyond ten plate sizes is refused in one line giving the largest factor that fits,
    which is then drawn."""
    path, _ = project
    for out, extra in (("m.gif", ("--duration", "0.2", "--workers", "1")), ("p.png", ("--figure", "projection"))):
        code, _, err = run(capsys, "render", path, "T5", "-o", tmp_path / out, "--magnify", "1e300,1e300", *extra)
        assert code == 1 and len(err.strip().splitlines()) == 1, err
        assert "--magnify 1e+300,1e+300: draws the largest corner motion" in err
        assert "more than the 10 times a picture can show" in err and not (tmp_path / out).exists()
        most = err.split("at most --magnify ")[1].split(" ")[0]
        assert run(capsys, "render", path, "T5", "-o", tmp_path / out, "--magnify", most, *extra)[0] == 0


def test_an_output_link_that_loops_is_refused_and_kept(project, tmp_path, capsys):
    """-o naming a link to itself (or two links to each other) was replaced by the file written:
    refused in one line naming the option and the link, which stays a link to the same name."""
    path, _ = project
    (tmp_path / "loop.png").symlink_to("loop.png")
    (tmp_path / "a.uff").symlink_to("b.uff")
    (tmp_path / "b.uff").symlink_to("a.uff")
    for args, link in ((("render", path, "T5", "-o", tmp_path / "loop.png", "--figure", "projection"), "loop.png"),
                       (("export-uff", path, "T5", "-o", tmp_path / "a.uff"), "a.uff")):
        code, _, err = run(capsys, *args)
        assert code == 1 and len(err.strip().splitlines()) == 1, err
        assert f"-o {tmp_path / link}: is a symbolic link that leads back to itself (a loop)" in err
    assert (tmp_path / "loop.png").readlink() == Path("loop.png") and (tmp_path / "a.uff").readlink() == Path("b.uff")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["T5.DAT", "a.uff", "b.uff", "loop.png", "p.h5"]


def test_render_figures(project, tmp_path, capsys):
    path, d = project
    code, stdout, err = run(capsys, "render", path, "T5", "-o", tmp_path / "proj.png", "--figure", "projection",
                            "--view", "z,0,0,15")
    assert code == 0, err
    with Image.open(tmp_path / "proj.png") as im:
        assert im.format == "PNG"
    for fig in ("overlay", "residuals"):
        code, _, err = run(capsys, "render", path, "T5", "-o", tmp_path / f"{fig}.svg", "--figure", fig)
        assert code == 0, err
        assert (tmp_path / f"{fig}.svg").read_text().lstrip().startswith("<?xml")


def test_render_errors_are_one_line(project, tmp_path, capsys):
    path, _ = project
    for args, words in (((path, "T9", "-o", tmp_path / "m.mp4"), "T9"),
                        ((path, "T5", "-o", tmp_path / "m.avi"), "m.avi"),
                        ((path, "T5", "-o", tmp_path / "m.mp4", "--magnify", "10"), "--magnify"),
                        ((path, "T5", "-o", tmp_path / "m.png", "--figure", "bars"), "--figure")):
        code, _, err = run(capsys, "render", *args)
        assert code == 1 and words in err and len(err.strip().splitlines()) == 1, err


API_REFUSALS = [  # (renderer, output, options, the one line; the same as `odsuite render` where it has the option)
    ("movie", "m.gif", {"fps": float("nan")}, "--fps: must be a finite number > 0, got nan"),
    ("movie", "m.mp4", {"duration": "6"}, "--duration: must be a finite number > 0, got '6'"),
    ("movie", "m.gif", {"frame_step": 0}, "--frame-step: at least 1 sample per frame, got 0"),
    ("movie", "m.gif", {"workers": 2.5}, "--workers: expected a whole number, got 2.5"),
    # the per-core limit was the command line's alone
    ("movie", "m.gif", {"workers": 10**6}, f"--workers: at most {4 * (os.cpu_count() or 1)} processes (4 per core), got 1000000"),
    ("movie", "m.gif", {"magnify": (1.0, -2.0)}, "--magnify: magnification factors must be finite numbers >= 0, got (1.0, -2.0)"),
    ("movie", "m.gif", {"magnify": "5"}, "--magnify: expected two numbers 'A,B', got '5'"),
    ("projection", "p.png", {"view": 5}, "--view: expected text, 'AZ,EL' or 'EYE[,THETA,PHI,PSI]', got 5"),
    ("projection", "p.png", {"model": "yes"}, "--model: expected True or False, got 'yes'"),
]


@pytest.mark.parametrize("name,out,options,line", API_REFUSALS, ids=[f"{r[0]}-{next(iter(r[2]))}" for r in API_REFUSALS])
def test_the_renderer_api_refuses_bad_options_in_one_line(project, tmp_path, name, out, options, line):
    """Through RenderRequest a NaN rate reached int(), a text duration a comparison and a number as
    the projection's view .split(): each is the ConfigError `odsuite render` gives, nothing written."""
    from odsuite.contracts.plugins import registries
    from odsuite.contracts.renderers import RenderRequest
    from odsuite.domain.errors import ConfigError

    path, _ = project
    before = path.read_bytes()
    with pytest.raises(ConfigError) as info:
        registries().renderers.get(name).render(RenderRequest(path, "T5", tmp_path / out, options, progress=False))
    assert str(info.value) == line
    assert path.read_bytes() == before and not (tmp_path / out).exists()


def test_the_cli_and_the_api_give_the_same_line(project, tmp_path, capsys):
    from odsuite.contracts.plugins import registries
    from odsuite.contracts.renderers import RenderRequest
    from odsuite.domain.errors import ConfigError

    path, _ = project
    code, _, err = run(capsys, "render", path, "T5", "-o", tmp_path / "m.gif", "--fps", "nan")
    assert code == 1
    with pytest.raises(ConfigError) as info:
        registries().renderers.get("movie").render(RenderRequest(path, "T5", tmp_path / "m.gif", {"fps": float("nan")}))
    assert err == f"error: {info.value}\n"


def test_a_request_without_options_is_one_without_options(tmp_path):
    """options=None was read with .items() (AttributeError); anything but a mapping is refused."""
    from odsuite.contracts.renderers import RenderRequest
    from odsuite.domain.errors import ConfigError

    assert RenderRequest(tmp_path / "p.h5", "T5", tmp_path / "m.gif", None).options == {}
    with pytest.raises(ConfigError, match=r"^render options: expected a mapping of option names to values, got list$"):
        RenderRequest(tmp_path / "p.h5", "T5", tmp_path / "m.gif", ["fps"])
