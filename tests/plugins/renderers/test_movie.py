"""Movies: frame counts, decoding, frame order across processes, the GIF fallback, playback plans."""

from __future__ import annotations

from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest
from PIL import Image

from odsuite.domain.errors import ConfigError
from odsuite_plugins.renderers import movie
from odsuite_plugins.renderers.movie import frame_plan, render_movie

FS = 20000.0


def decaying_motion(n: int) -> dict[str, np.ndarray]:
    t = np.arange(n) / FS
    d = np.zeros((n, 6))
    env = np.exp(-60 * t)
    d[:, 2] = 2e-6 * env * np.sin(2 * np.pi * 150 * t)
    d[:, 3] = 3e-5 * env * np.sin(2 * np.pi * 220 * t)
    return {"platform": d}


def decode(path):
    gen = imageio_ffmpeg.read_frames(str(path))
    meta = next(gen)
    w, h = meta["size"]
    return meta, np.array([np.frombuffer(f, np.uint8).reshape(h, w, 3) for f in gen])


@pytest.mark.render
def test_mp4_has_expected_frames_and_decodes(thesis_rig, tmp_path):
    res = render_movie(thesis_rig, decaying_motion(300), FS, tmp_path / "m.mp4", frame_step=10,
                       size=(320, 240), workers=1, progress=False)
    assert res.format == "mp4" and res.n_frames == 30 and res.frame_step == 10
    assert res.slowdown == pytest.approx(FS / (25 * 10))
    meta, frames = decode(res.path)
    assert frames.shape == (30, 240, 320, 3)
    assert meta["fps"] == pytest.approx(25)
    # the plate moves: successive frames differ, and the first frame (rest) differs from a moving one
    assert np.abs(frames[0].astype(int) - frames[3].astype(int)).max() > 100


@pytest.mark.render
def test_two_processes_give_the_same_movie_in_order(thesis_rig, tmp_path):
    n_frames = 2 * movie.MIN_FRAMES_PER_WORKER
    coords = decaying_motion(n_frames * 4)
    one = render_movie(thesis_rig, coords, FS, tmp_path / "one.mp4", frame_step=4, size=(192, 128),
                       workers=1, progress=False)
    two = render_movie(thesis_rig, coords, FS, tmp_path / "two.mp4", frame_step=4, size=(192, 128),
                       workers=2, progress=False)
    _, a = decode(one.path)
    _, b = decode(two.path)
    assert a.shape == b.shape == (n_frames, 128, 192, 3)
    # same frames in the same order (H.264 is lossy: compare to the neighbours)
    diff = np.abs(a.astype(float) - b.astype(float)).mean(axis=(1, 2, 3))
    shifted = np.abs(a[1:].astype(float) - b[:-1].astype(float)).mean(axis=(1, 2, 3))
    assert diff.max() < 2.0
    assert shifted.mean() > 2 * diff.mean()


@pytest.mark.render
def test_gif_when_mp4_encoding_is_unavailable(thesis_rig, tmp_path, monkeypatch):
    monkeypatch.setattr(movie, "mp4_available", lambda: False)
    res = render_movie(thesis_rig, decaying_motion(60), FS, tmp_path / "m.mp4", frame_step=5,
                       size=(160, 120), workers=1, progress=False)
    assert res.format == "gif" and res.path == tmp_path / "m.gif" and "m.gif" in res.notes[0]
    assert not (tmp_path / "m.mp4").exists()
    with Image.open(res.path) as im:
        assert im.n_frames == 12 and im.size == (160, 120)
        assert im.info["duration"] == 40  # 25 fps


@pytest.mark.parametrize("existing", ["link", "project"])
def test_the_gif_fallback_never_replaces_a_file_the_user_did_not_name(thesis_rig, tmp_path, monkeypatch, existing):
    # -o m.mp4 without an H.264 encoder writes m.gif: a link there (to the user's talk.gif), or a
    # file that is no GIF (a project named m.gif), is refused in one line and left as it was
    monkeypatch.setattr(movie, "mp4_available", lambda: False)
    kept = tmp_path / ("talk.gif" if existing == "link" else "m.gif")
    kept.write_bytes(b"\x89HDF\r\n\x1a\n precious")
    if existing == "link":
        (tmp_path / "m.gif").symlink_to(kept)
    with pytest.raises(ConfigError, match=r"m\.mp4: no H\.264 encoder .* m\.gif, the GIF written instead, is "
                                          f"{'a link' if existing == 'link' else 'another file'}: give -o m\\.gif"):
        render_movie(thesis_rig, decaying_motion(60), FS, tmp_path / "m.mp4", frame_step=5, size=(160, 120),
                     workers=1, progress=False)
    assert kept.read_bytes() == b"\x89HDF\r\n\x1a\n precious"


@pytest.mark.render
def test_a_gif_plays_at_the_rate_it_reports(thesis_rig, tmp_path):
    """A GIF's frame delays are whole centiseconds: 30 fps asked plays at 100/3 (3 cs a frame),
    which the result, its note and the slowdown state; above 50 fps (delays under 2 cs, which
    players slow down) a GIF is refused and nothing is written."""
    res = render_movie(thesis_rig, decaying_motion(60), FS, tmp_path / "m.gif", frame_step=5, fps=30,
                       size=(160, 120), workers=1, progress=False)
    with Image.open(res.path) as im:
        assert im.info["duration"] == 30
    assert res.fps == pytest.approx(100 / 3) and res.slowdown == pytest.approx(FS / (100 / 3 * 5))
    assert res.notes == ["a GIF's frame delays are whole hundredths of a second: it plays at 33.33 fps "
                         "(3/100 s a frame), not 30"]
    with pytest.raises(ConfigError, match=r"^--fps 60: a GIF plays at most 50 frames per second .* or write an \.mp4$"):
        render_movie(thesis_rig, decaying_motion(60), FS, tmp_path / "fast.gif", frame_step=5, fps=60,
                     size=(160, 120), workers=1, progress=False)
    assert not (tmp_path / "fast.gif").exists()
    assert movie.playback_fps(60, "mp4") == (60, None) and movie.playback_fps(50, "gif") == (50, None)


def test_speed_words_read_right_on_both_sides_of_real_time():
    from odsuite_plugins.renderers.motion import speed_words

    assert speed_words(800.0) == "800 times slower than real time"
    assert speed_words(12345.0) == "12,345 times slower than real time"
    assert speed_words(1.5) == "1.5 times slower than real time"
    assert speed_words(0.25) == "4 times faster than real time"
    assert speed_words(0.3) == "3.33 times faster than real time"
    assert speed_words(1.002) == "real time"


def test_mp4_available_here():
    assert movie.mp4_available()


def test_frame_plan():
    frames, step, slow = frame_plan(1000, FS, fps=25, slowdown=200)
    assert step == 4 and slow == pytest.approx(200) and frames[:3].tolist() == [0, 4, 8]
    frames, step, slow = frame_plan(1000, FS, fps=25, start=0.01, stop=0.02)
    assert frames[0] == 200 and frames[-1] == 400 and step == 1 and slow == pytest.approx(800)
    with pytest.raises(ConfigError, match="slowdown"):
        frame_plan(1000, FS, fps=25, slowdown=5000)
    with pytest.raises(ConfigError, match="time window"):
        frame_plan(1000, FS, fps=25, start=1.0)
    with pytest.raises(ConfigError, match="either"):
        frame_plan(1000, FS, fps=25, slowdown=10, frame_step=2)
    # a 4 s movie of a 0.05 s window (1001 samples, the stop's included) at 25 fps: 100 frames, every
    # 10th sample (it wrote 101, 4.04 s)
    frames, step, slow = frame_plan(4000, FS, fps=25, start=0.05, stop=0.1, duration=4)
    assert step == 10 and len(frames) == 100 and slow == pytest.approx(80)


@pytest.mark.parametrize("stop, fps, duration, step, n", [
    (0.0055, 5, 1, 22, 5),      # 111 samples for 5 frames: it wrote 6 (1.2 s)
    (0.0187, 25, 10, 2, 250),   # 375 samples, 1.5 a frame: a step of 2 past the stop (it wrote 188, 7.52 s)
    (0.0499, 25, 10, 4, 250),   # the default 10 s of a 0.05 s window
])
def test_a_movie_lasts_the_duration_asked(stop, fps, duration, step, n):
    frames, got_step, _ = frame_plan(4000, FS, fps=fps, stop=stop, duration=duration)
    assert got_step == step and len(frames) == n == round(fps * duration)
    assert np.all(np.diff(frames) == step) and frames[0] == 0
    assert movie.duration_note(frames, fps, duration) is None


def test_a_window_of_fewer_samples_than_frames_is_not_stretched_and_says_so():
    # 9 samples for 25 frames (1 s at 25 fps): each sample once, and a note saying why 0.36 s
    frames, step, _ = frame_plan(4000, FS, fps=25, stop=0.0004, duration=1)
    assert frames.tolist() == list(range(9)) and step == 1
    assert movie.duration_note(frames, 25, 1) == ("the movie lasts 0.36 s, not the 1 s asked: the window's samples "
                                                  "give 9 frames at 25 fps (a lower --fps or a longer window "
                                                  "lengthens it)")


@pytest.mark.parametrize("n, fps, words", [(1, 25.0, "1 frame at 25 fps (0.04 s)"), (2, 50.0, "2 frames at 50 fps (0.04 s)"),
                                           (32, 100 / 3, "32 frames at 33.33 fps (0.96 s)"),
                                           (250, 25.0, "250 frames at 25 fps (10 s)"),
                                           (5000, 25.0, "5000 frames at 25 fps (200 s)")])
def test_the_summary_counts_frames_and_seconds_in_words(n, fps, words):
    # it read '1 frames ... (0.0 s)'
    from odsuite_plugins.renderers.movie import MovieResult
    from odsuite_plugins.renderers.providers import _frames

    assert _frames(MovieResult(Path("m.gif"), "gif", n, fps, (1.0, 1.0), 1, 1.0)) == words


def test_event_window_spans_the_hit_and_the_decay(thesis_rig):
    """Still until sample 1000, then a decay e^(-a t): the window opens 5 ms before the hit and
    closes 5 ms after the envelope falls to a tenth, t = ln(10) / a."""
    from odsuite_plugins.renderers.motion import event_window

    n, hit, a = 8000, 1000, 60.0
    t = np.clip(np.arange(n) - hit, 0, None) / FS
    d = np.zeros((n, 6))
    d[hit:, 2] = 1e-6 * np.exp(-a * t[hit:])  # a pure translation: every corner moves alike
    start, end = event_window(thesis_rig, {"platform": d}, FS)
    assert start == pytest.approx((hit - 100) / FS)
    assert end == pytest.approx(hit / FS + np.log(10) / a + 0.005, abs=2 / FS)


def test_labels_tell_time_from_the_hit_and_the_force(thesis_rig):
    from odsuite_plugins.renderers.motion import magnification_words
    from odsuite_plugins.renderers.movie import frame_labels
    from odsuite_plugins.renderers.scene import Hammer

    force = np.zeros(100)
    force[40:43] = [5.0, 12.46, 4.0]
    hammer = Hammer("platform", np.zeros(3), np.array([0, 0, 1.0]), force)
    labels = frame_labels(np.array([20, 41, 60]), FS, time_zero=40 / FS, hammer=hammer)
    assert labels == ["t = -1.00 ms from the hit", "t = +0.05 ms from the hit    hammer force 12.5 N",
                      "t = +1.00 ms from the hit"]
    assert frame_labels(np.array([5]), 4000.0, ods_hz=100.0) == ["phase 45 deg of the cycle at 100 Hz"]
    assert magnification_words((5780.0, 5780.0)) == "motion drawn 5,780 times larger than it is"
    assert magnification_words((2.5, 40.0)) == "translations drawn 2.5 times, rotations 40 times larger than they are"
    assert magnification_words((0.0, 40.0)) == "translations held still (x0), rotations drawn 40 times larger than they are"
    assert magnification_words((1e300, 1e300)) == "motion drawn 1e+300 times larger than it is"


@pytest.mark.render
def test_gif_frames_stream_to_the_file(thesis_rig, tmp_path, monkeypatch):
    """The GIF's frames go to the file as they are rendered, by two processes with one palette:
    the same frames, in the same order, as one process writes."""
    monkeypatch.setattr(movie, "mp4_available", lambda: False)
    n_frames = 2 * movie.MIN_FRAMES_PER_WORKER
    coords = decaying_motion(n_frames * 4)

    def frames(workers):
        res = render_movie(thesis_rig, coords, FS, tmp_path / f"m{workers}.gif", frame_step=4, size=(192, 128),
                           workers=workers, progress=False)
        with Image.open(res.path) as im:
            assert im.n_frames == n_frames and im.info["loop"] == 0 and im.size == (192, 128)
            out = []
            for k in range(im.n_frames):
                im.seek(k)
                out.append(np.asarray(im.convert("RGB"), dtype=int))
        return np.array(out)

    a, b = frames(2), frames(1)
    assert np.array_equal(a, b)
    assert np.abs(a[0] - a[3]).max() > 100  # the plate moves
