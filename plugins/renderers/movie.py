"""Wireframe movies of the rig's plates (thesis Sec. 4.6, App. D.4): MP4 (H.264) or GIF.

Frames are rendered off-screen by pyvista and piped raw into imageio-ffmpeg's ffmpeg, which
encodes H.264 in its own process while the next frame renders. With ``workers`` > 1 the frame range
is split into contiguous parts rendered by separate processes, each encoding its own segment; the
segments are joined without re-encoding. One process already keeps two cores busy (the software
rasteriser is multi-threaded), so the default is one worker per two cores. GIF is the fallback
when no H.264 encoder is available; its frames are quantised to one palette (taken from a few
frames spread over the movie) and appended to the file one by one, so memory stays flat in the
number of frames for both formats.
"""

from __future__ import annotations

import functools
import multiprocessing as mp
import os
import queue
import shutil
import subprocess
import tempfile
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from odsuite.api import ensure_space, write_output
from odsuite.api import ConfigError, OdsuiteError
from odsuite.api import Rig
from odsuite.api import interrupts_deferred, interrupts_held

from .motion import check_coords, check_magnification, default_magnification, magnification_words, speed_words
from .scene import Hammer, Scene, Style

FORMATS = ("mp4", "gif")
#: Below this many frames per worker, starting a process costs more than it saves.
MIN_FRAMES_PER_WORKER = 40
#: Seconds render processes get to stop after their current frame (a frame takes well under one
#: on an idle machine, several on a loaded one) before they are terminated.
STOP_WAIT = 30.0
#: Frames rendered ahead to choose a GIF's palette: enough to see every colour of the scene.
GIF_PALETTE_FRAMES = 6
#: Bytes per pixel of a frame, for the room a movie needs: about twice what the wireframe scene
#: measured (1280 x 720: GIF 23 kB a frame, H.264 3 kB).
MOVIE_BYTES_PER_PIXEL = {"gif": 0.05, "mp4": 0.008}
#: Frame rates a movie can have: a GIF frame lasts at most 655.35 s (its delay is a 16-bit count of
#: 10 ms); ffmpeg takes the rate as a fraction of 32-bit integers, and no screen shows 1000 a second.
FPS_RANGE = (1 / 655.35, 1000.0)
#: A GIF frame's delay is a whole number of hundredths of a second, and browsers and viewers play a
#: delay under 2/100 s as 1/10 s: no GIF plays faster than 50 frames per second.
GIF_MAX_FPS = 50.0


@dataclass(frozen=True)
class MovieResult:
    """What was written: the file (a .gif when MP4 encoding was unavailable), its frame count and
    rate, the magnification (H_t, H_r) and the sample step between frames."""

    path: Path
    format: str
    n_frames: int
    fps: float
    magnify: tuple[float, float]
    frame_step: int
    slowdown: float
    notes: list[str] = field(default_factory=list)


@functools.cache
def mp4_available() -> bool:
    """True when imageio-ffmpeg's ffmpeg exists and has the libx264 H.264 encoder."""
    try:
        import imageio_ffmpeg

        exe = imageio_ffmpeg.get_ffmpeg_exe()
        out = subprocess.run([exe, "-hide_banner", "-encoders"], capture_output=True, text=True, timeout=30)
    except (ImportError, RuntimeError, OSError, subprocess.SubprocessError):
        return False
    return "libx264" in out.stdout


def frame_plan(n_samples: int, fs: float, *, fps: float, start: float = 0.0, stop: float | None = None,
               frame_step: int | None = None, slowdown: float | None = None,
               duration: float | None = None) -> tuple[np.ndarray, int, float]:
    """Sample indices of the frames, the step between them and the slow-motion factor.

    ``slowdown`` = movie seconds per second of the record; it sets the step as fs / (fps x
    slowdown). ``duration`` (s) = the movie's length: round(fps x duration) frames at the whole
    step nearest to the window's samples per frame, so the last frame may lie a little past
    ``stop`` (less than half a step per frame); fewer when the window holds fewer samples than
    that or the record ends first. Default: every sample is a frame.
    """
    if fs <= 0 or not np.isfinite(fs):
        raise ConfigError(f"sampling rate: must be > 0 Hz, got {fs!r}")
    if fps <= 0:
        raise ConfigError(f"fps: must be > 0, got {fps!r}")
    if sum(v is not None for v in (frame_step, slowdown, duration)) > 1:
        raise ConfigError("give either frame_step, slowdown or duration, not several")
    i0 = int(round(start * fs))
    i1 = n_samples if stop is None else min(n_samples, int(round(stop * fs)) + 1)
    if not 0 <= i0 < i1:
        raise ConfigError(f"time window: start {start:g} s, stop {stop} s select no sample of a "
                          f"{n_samples / fs:g} s record")
    wanted = None
    if duration is not None:
        if not duration > 0:
            raise ConfigError(f"duration: must be > 0 s, got {duration!r}")
        wanted = max(1, round(fps * duration))
        # a window of fewer samples than frames is shown sample by sample, not stretched past its end
        frame_step = max(1, int(round((i1 - i0) / wanted)))
        wanted = min(wanted, i1 - i0)
    if slowdown is not None:
        if slowdown <= 0:
            raise ConfigError(f"slowdown: must be > 0, got {slowdown!r}")
        exact = fs / (fps * slowdown)
        if exact < 0.5:
            raise ConfigError(f"slowdown {slowdown:g} needs {1 / exact:.3g} frames per sample at {fps:g} fps "
                              f"and {fs:g} Hz; the largest is {fs / fps:g}")
        frame_step = max(1, int(round(exact)))
    step = 1 if frame_step is None else int(frame_step)
    if step < 1:
        raise ConfigError(f"frame_step: must be >= 1 sample, got {frame_step!r}")
    frames = np.arange(i0, i1, step)
    if wanted is not None:
        frames = np.arange(i0, min(n_samples, i0 + wanted * step), step)[:wanted]
    return frames, step, fs / (fps * step)


def duration_note(frames: np.ndarray, fps: float, duration: float | None) -> str | None:
    """Why a movie is shorter than the ``duration`` asked (the window or the record has too few
    samples for that many frames), or None."""
    if duration is None or len(frames) >= round(fps * duration):
        return None
    return (f"the movie lasts {seconds_text(len(frames) / fps)}, not the {duration:g} s asked: the window's "
            f"samples give {len(frames)} frames at {fps:.4g} fps (a lower --fps or a longer window lengthens it)")


def seconds_text(seconds: float) -> str:
    """A movie's length: three significant digits below 100 s (0.04 s, 1.2 s), whole seconds above."""
    return f"{seconds:.0f} s" if seconds >= 100 else f"{seconds:.3g} s"


def _gif_delay(fps: float) -> int:
    """A GIF frame's delay (hundredths of a second) nearest to 1/fps."""
    return min(65535, max(2, round(100.0 / fps)))


def playback_fps(fps: float, fmt: str, *, fallback: bool = False) -> tuple[float, str | None]:
    """The rate a movie of format ``fmt`` plays at when ``fps`` is asked, and a note when the two
    differ: an MP4 plays any rate, a GIF the nearest of 100/k (its delays are whole centiseconds:
    30 asked plays at 33.33). Refused outside ``FPS_RANGE`` and a GIF above ``GIF_MAX_FPS``
    (``fallback``: the GIF stands in for an MP4 this machine cannot encode)."""
    if not FPS_RANGE[0] <= fps <= FPS_RANGE[1]:
        raise ConfigError(f"fps: expected {FPS_RANGE[0]:.4g} to {FPS_RANGE[1]:g} frames per second (a GIF frame "
                          f"lasts at most 655.35 s), got {fps:.6g}")
    if fmt != "gif":
        return float(fps), None
    # refused rather than written slower: the movie and its summary would disagree by the ratio
    if fps > GIF_MAX_FPS:
        instead = ("; there is no H.264 encoder here for the .mp4" if fallback else ", or write an .mp4")
        raise ConfigError(f"--fps {fps:g}: a GIF plays at most {GIF_MAX_FPS:g} frames per second (its frame "
                          f"delays are whole hundredths of a second and players slow delays under 2/100 s "
                          f"down); give --fps {GIF_MAX_FPS:g} or less{instead}")
    delay = _gif_delay(fps)
    real = 100.0 / delay
    if abs(real - fps) <= 1e-9 * fps:
        return real, None
    return real, (f"a GIF's frame delays are whole hundredths of a second: it plays at {real:.4g} fps "
                  f"({delay}/100 s a frame), not {fps:g}")


def _even(size: tuple[int, int]) -> tuple[int, int]:
    w, h = (int(v) for v in size)
    if w < 16 or h < 16:
        raise ConfigError(f"size: at least 16 x 16 pixels, got {w} x {h}")
    return (w - w % 2, h - h % 2)  # yuv420p needs even sizes


def _mp4_writer(path: Path, size: tuple[int, int], fps: float):
    import imageio_ffmpeg

    writer = imageio_ffmpeg.write_frames(
        str(path), size, fps=fps, codec="libx264", pix_fmt_out="yuv420p", quality=None,
        macro_block_size=2, ffmpeg_log_level="error",
        output_params=["-preset", "veryfast", "-crf", "20", "-tune", "animation"])
    writer.send(None)
    return writer


class _GifFrames:
    """GIF frame blocks (graphic control extension, image descriptor, LZW data) appended to a file
    one frame at a time; :func:`_join_gif` puts the header with the shared palette in front.

    Pillow's own multi-frame GIF writer keeps every frame until the end (GBs for a long movie);
    its documented per-frame ``getdata`` lets us stream instead.
    """

    def __init__(self, target: Path, palette: "Image.Image", fps: float) -> None:  # noqa: F821
        self._fp = open(target, "wb")
        self._palette = palette
        self._delay = 10 * _gif_delay(fps)  # ms, a whole number of centiseconds as the GIF stores it

    def send(self, frame: np.ndarray) -> None:
        from PIL import GifImagePlugin, Image

        im = Image.fromarray(frame).quantize(palette=self._palette, dither=Image.Dither.NONE)
        self._fp.write(b"".join(GifImagePlugin.getdata(im, duration=self._delay, disposal=1)))

    def close(self) -> None:
        self._fp.close()


def _gif_palette(scene: Scene, frames: np.ndarray, labels: list[str]) -> "Image.Image":  # noqa: F821
    """One 256-colour palette from a few frames spread over the movie."""
    from PIL import Image

    picks = np.unique(np.linspace(0, len(frames) - 1, min(GIF_PALETTE_FRAMES, len(frames))).round().astype(int))
    sample = np.concatenate([scene.frame(int(frames[k]), labels[k], (k + 1) / len(frames)) for k in picks])
    return Image.fromarray(sample).quantize(colors=256, method=Image.Quantize.MEDIANCUT)


def gif_from_mp4(mp4: Path, gif: Path, fps: float) -> Path:
    """The GIF of an MP4's frames (for players without H.264), streamed: one pass picks the
    palette from a few frames, a second quantises and appends each frame."""
    import imageio_ffmpeg
    from PIL import Image

    n, _ = imageio_ffmpeg.count_frames_and_secs(str(mp4))
    picks = set(np.linspace(0, max(0, n - 1), min(GIF_PALETTE_FRAMES, max(1, n))).round().astype(int).tolist())
    reader = imageio_ffmpeg.read_frames(str(mp4))
    size = next(reader)["size"]
    sample = [np.frombuffer(f, np.uint8).reshape(size[1], size[0], 3) for k, f in enumerate(reader) if k in picks]
    palette = Image.fromarray(np.concatenate(sample)).quantize(colors=256, method=Image.Quantize.MEDIANCUT)
    body = gif.with_suffix(".gifdata")
    writer = _GifFrames(body, palette, fps)
    reader = imageio_ffmpeg.read_frames(str(mp4))
    next(reader)
    for f in reader:
        writer.send(np.frombuffer(f, np.uint8).reshape(size[1], size[0], 3))
    writer.close()
    _join_gif([body], gif, palette, tuple(size))
    body.unlink()
    return gif


def _join_gif(parts: list[Path], path: Path, palette: "Image.Image", size: tuple[int, int]) -> None:  # noqa: F821
    from PIL import GifImagePlugin

    first = palette.crop((0, 0, *size))
    header, _ = GifImagePlugin.getheader(first, None, {"loop": 0})
    with open(path, "wb") as out:
        out.write(b"".join(header))
        for part in parts:
            with open(part, "rb") as src:
                shutil.copyfileobj(src, out, 1 << 20)
        out.write(b";")  # the GIF trailer


class _Stopped(Exception):
    """The parent asked a render process to stop (Ctrl-C, or another process failed)."""


def _render_part(job: dict, frames: np.ndarray, first: int, sink: str, target: str,
                 report: Callable[[int], None], stopped: Callable[[], bool] = lambda: False) -> None:
    """Render ``frames`` (sample indices) and stream them to ``target``, checking ``stopped()``
    before each frame.

    ``sink`` "mp4": an H.264 file; "gif": GIF frame blocks in the job's palette.
    """
    scene = _scene(job)
    writer = None
    try:
        if sink == "mp4":
            writer = _mp4_writer(Path(target), scene.size, job["fps"])
        else:
            writer = _GifFrames(Path(target), job["palette"], job["fps"])
        for k, i in enumerate(frames):
            if stopped():
                raise _Stopped()
            writer.send(scene.frame(int(i), job["labels"][first + k], (first + k + 1) / job["n_frames"]))
            report(1)
        writer, done = None, writer
        done.close()
    finally:
        if writer is not None:
            _abandon(writer)
        scene.close()


def _scene(job: dict):
    """The job's scene: the rig's plates, or another scene class (``scene_type``: a picklable
    class taking ``scene_args`` and the ``scene`` options, with ``size`` and ``frame``)."""
    return job.get("scene_type", Scene)(*job.get("scene_args", (job.get("rig"), job.get("coords"))), **job["scene"])


def _abandon(writer) -> None:
    """End a writer half-way. Its ffmpeg encoder runs in a process group of its own (Ctrl-C does
    not reach it) and would go on writing into a folder about to be removed: it is killed."""
    if isinstance(writer, _GifFrames):
        writer.close()
        return
    try:
        writer.throw(SystemExit)  # imageio-ffmpeg kills its encoder on SystemExit
    except SystemExit:
        pass


def _worker(job, frames, first, sink, target, q, stop) -> None:
    # one software-rasteriser thread per process: the processes already fill the cores
    os.environ.setdefault("LP_NUM_THREADS", "1")
    try:
        _render_part(job, frames, first, sink, target, lambda n: q.put(("done", n)), stop.is_set)
        q.put(("finished", first))
    except BaseException as exc:  # the parent re-raises it with the worker's traceback
        q.put(("error", f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}",
               str(exc) if isinstance(exc, OdsuiteError) else None))


def _concat(parts: list[Path], path: Path, tmp: Path, shown: Path) -> None:
    """Join the MP4 ``parts`` into ``path`` (``shown`` in messages)."""
    import imageio_ffmpeg

    listing = tmp / "parts.txt"
    # absolute: ffmpeg reads relative names from the listing's own folder
    listing.write_text("".join(f"file '{p.resolve().as_posix()}'\n" for p in parts))
    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-hide_banner", "-loglevel", "error", "-f", "concat",
           "-safe", "0", "-i", str(listing), "-c", "copy", "-movflags", "+faststart", str(path)]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        raise OdsuiteError(f"{shown}: joining the movie segments failed: {run.stderr.strip()[:300]}")


def render_movie(
    rig: Rig,
    coords: Mapping[str, np.ndarray],
    fs: float,
    path: str | Path,
    *,
    model_coords: Mapping[str, np.ndarray] | None = None,
    layout: str = "overlay",
    magnify: tuple[float, float] | None = None,
    view: tuple[float, float] = (60.0, 25.0),
    parallel: bool = False,
    solid: bool = False,
    axes: bool = True,
    ghost: bool = True,
    start: float = 0.0,
    stop: float | None = None,
    frame_step: int | None = None,
    slowdown: float | None = None,
    duration: float | None = None,
    fps: float = 25.0,
    size: tuple[int, int] = (1280, 720),
    workers: int | None = None,
    progress: bool = True,
    style: Style = Style(),
    sensors: bool = True,
    hammer: Hammer | None = None,
    title: str = "",
    time_zero: float | None = None,
    ods_hz: float | None = None,
    corrected_coords: Mapping[str, np.ndarray] | None = None,
) -> MovieResult:
    """Animate every plate of ``rig`` from generalized coordinates and write an MP4 or GIF.

    ``coords``: ``{body: (n, 6)}`` at each body's centre of mass (m, rad; rig frame), sampled at
    ``fs`` Hz. ``model_coords``: the model's motion, overlaid in another colour or shown
    side by side (``layout``). ``magnify`` (H_t, H_r): default makes the largest corner excursion
    15 % of the moving plate's size. ``view`` (azimuth, elevation) in degrees; ``parallel`` for a
    parallel projection. ``start``/``stop`` (s) choose the window; ``frame_step`` (samples per
    frame), ``slowdown`` (movie time / real time) or ``duration`` (movie length, s) the playback
    speed at ``fps``. A path ending in .mp4 falls back to a .gif beside it when no H.264 encoder is
    available (see ``notes``). ``sensors`` marks and names the sensors; ``hammer`` draws the hit.
    ``title`` heads every frame; the clock counts from ``time_zero`` (s, the hit) when given, and
    for an operating deflection shape (``ods_hz``, the coordinates one cycle after another) gives
    the phase instead. ``corrected_coords``: the motion with the measurement's diagnosed
    distortions removed (``process --corrected``), overlaid in a third colour.
    """
    path, fmt, fps, notes = movie_target(Path(path), fps)
    coords = check_coords(rig, coords)
    n = next(iter(coords.values())).shape[0]
    if model_coords is not None:
        model_coords = check_coords(rig, model_coords, "model_coords")
        if next(iter(model_coords.values())).shape[0] != n:
            raise ConfigError(f"model_coords: {next(iter(model_coords.values())).shape[0]} samples, "
                              f"the measurement has {n}")
    if corrected_coords is not None:
        corrected_coords = check_coords(rig, corrected_coords, "corrected_coords")
        if next(iter(corrected_coords.values())).shape[0] != n:
            raise ConfigError(f"corrected_coords: {next(iter(corrected_coords.values())).shape[0]} samples, "
                              f"the measurement has {n}")
    if magnify is None:
        magnify = default_magnification(rig, coords, *[c for c in (model_coords, corrected_coords) if c])
    magnify = (float(magnify[0]), float(magnify[1]))
    # the rate the movie plays at plans the frames: a duration or slowdown asked is what is seen
    frames, step, slow = frame_plan(n, fs, fps=fps, start=start, stop=stop, frame_step=frame_step,
                                    slowdown=slowdown, duration=duration)
    short = duration_note(frames, fps, duration)
    notes += [short] if short else []
    check_magnification(rig, magnify, *({b: d[frames] for b, d in c.items()}
                                        for c in (coords, model_coords, corrected_coords) if c))
    size = _even(size)
    labels = frame_labels(frames, fs, time_zero=time_zero, ods_hz=ods_hz, hammer=hammer)
    speed = speed_words(slow)
    title = "\n".join(t for t in (title, f"{speed if ods_hz is None else ''}"
                                          f"{'; ' if ods_hz is None else ''}{magnification_words(magnify)}") if t)
    job = {"rig": rig, "coords": coords, "fps": fps, "labels": labels, "n_frames": len(frames),
           "scene": dict(model_coords=model_coords, corrected_coords=corrected_coords, layout=layout, magnify=magnify, view=tuple(view),
                         parallel=parallel, solid=solid, axes=axes, ghost=ghost, size=size, style=style,
                         sensors=sensors, hammer=hammer, title=title)}
    if workers is None:
        # one process keeps about two cores busy (multi-threaded rasteriser + the encoder process)
        workers = max(1, min(4, (os.cpu_count() or 1) // 2))
    path = write_movie(job, frames, path, fmt, size, workers, progress)
    return MovieResult(path=path, format=fmt, n_frames=len(frames), fps=fps, magnify=magnify,
                       frame_step=step, slowdown=slow, notes=notes)


def movie_target(path: Path, fps: float) -> tuple[Path, str, float, list[str]]:
    """Where a movie asked as ``path`` (.mp4 or .gif) is written, its format, the rate it plays at
    for ``fps`` asked and notes: a .gif beside an .mp4 when no H.264 encoder is available."""
    fmt = path.suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise ConfigError(f"{path}: movie format must be .mp4 or .gif, got {path.suffix or 'no suffix'!r}")
    no_h264 = fmt == "mp4" and not mp4_available()
    fps, note = playback_fps(fps, "gif" if no_h264 else fmt, fallback=no_h264)
    notes = [note] if note else []
    if no_h264:
        fallback = path.with_suffix(".gif")
        # a name the user did not give: never through a link, never over a file that is no GIF (a
        # project named run.gif); an earlier fallback's GIF is replaced, as the .mp4 would be
        if fallback.is_symlink() or (fallback.exists() and not _is_gif(fallback)):
            raise ConfigError(f"{path}: no H.264 encoder (imageio-ffmpeg with libx264) here, and {fallback.name}, "
                              f"the GIF written instead, is {'a link' if fallback.is_symlink() else 'another file'}: "
                              f"give -o {fallback.name} to replace it, or another name")
        path, fmt = fallback, "gif"
        notes.append(f"no H.264 encoder (imageio-ffmpeg with libx264) available: wrote {path.name} instead")
    return path, fmt, fps, notes


def _is_gif(path: Path) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(6) in (b"GIF87a", b"GIF89a")
    except OSError:
        return False


def write_movie(job: dict, frames: np.ndarray, path: Path, fmt: str, size: tuple[int, int], workers: int,
                progress: bool) -> Path:
    """Render ``job``'s scene at ``frames`` (its sample indices) into ``path`` (``fmt`` "mp4" or
    "gif", the fallback already chosen) with ``workers`` processes; ``job`` holds the scene, the
    frame ``labels``, ``fps`` and ``n_frames``."""
    playback_fps(job["fps"], fmt)
    labels = job["labels"]
    workers = max(1, min(int(workers), len(frames) // MIN_FRAMES_PER_WORKER or 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    needed = int(len(frames) * size[0] * size[1] * MOVIE_BYTES_PER_PIXEL[fmt])
    # the rendered parts and the joined movie beside them, before a frame is drawn
    ensure_space(path, 2 * needed, path, outcome="nothing written")
    with tempfile.TemporaryDirectory(prefix="odsuite-movie-", dir=path.parent) as tmpdir:
        tmp = Path(tmpdir)
        parts = np.array_split(np.arange(len(frames)), workers)
        if fmt == "mp4":
            targets = [str(tmp / f"part{k}.mp4") for k in range(workers)] if workers > 1 else [str(tmp / "movie.mp4")]
        else:
            targets = [str(tmp / f"part{k}.gifdata") for k in range(workers)]
            scene = _scene(job)
            try:
                job["palette"] = _gif_palette(scene, frames, labels)
            finally:
                scene.close()
        with _progress_bar(progress, len(frames), path.name) as advance:
            if workers == 1:
                _render_part(job, frames, 0, fmt, targets[0], advance)
            else:
                _run_workers(job, frames, parts, fmt, targets, advance)

        def join(out: Path) -> None:
            if fmt == "mp4" and workers == 1:
                shutil.move(targets[0], out)
            elif fmt == "mp4":
                _concat([Path(t) for t in targets], out, tmp, path)
            else:
                _join_gif([Path(t) for t in targets], out, job["palette"], size)

        write_output(path, needed, join)
    return path


def frame_labels(frames: np.ndarray, fs: float, *, time_zero: float | None = None, ods_hz: float | None = None,
                 hammer: Hammer | None = None) -> list[str]:
    """The changing line of each frame: the clock (or the ODS phase) and, while the hammer
    touches, its force."""
    out = []
    peak = 0.0 if hammer is None else float(np.abs(hammer.force).max(initial=0.0))
    for i in frames:
        if ods_hz is not None:
            text = f"phase {(360.0 * ods_hz * i / fs) % 360.0:.0f} deg of the cycle at {ods_hz:g} Hz"
        elif time_zero is not None:
            text = f"t = {1e3 * (i / fs - time_zero):+.2f} ms from the hit"
        else:
            text = f"t = {1e3 * i / fs:.2f} ms"
        if hammer is not None:
            f = abs(float(hammer.force[i]))
            if f > 0 and f >= Hammer.CONTACT_FRACTION * peak:
                text += f"    hammer force {f:.1f} N"
        out.append(text)
    return out


def _start_method() -> str:
    """Fork where this process has drawn nothing (a spawned worker imports Python, numpy and
    odsuite again: about a second of CPU each); spawn once it has, as a forked child would inherit
    its OpenGL state (a GIF's palette is drawn here first)."""
    import sys

    drawn = "vtkmodules.vtkRenderingOpenGL2" in sys.modules
    return "fork" if not drawn and "fork" in mp.get_all_start_methods() else "spawn"


def _run_workers(job, frames, parts, sink, targets, advance) -> None:
    ctx = mp.get_context(_start_method())
    q, stop = ctx.Queue(), ctx.Event()
    procs = [ctx.Process(target=_worker, args=(job, frames[p], int(p[0]), sink, targets[k], q, stop), daemon=True)
             for k, p in enumerate(parts)]
    finished = 0
    try:
        # Ctrl-C reaches the whole process group: workers start with SIGINT blocked (they inherit
        # the block) and the parent, which gets it once they are started, ends them; held in
        # Python too, as another thread of the parent (VTK's) may receive it meanwhile
        with interrupts_held(), interrupts_deferred():
            for p in procs:
                p.start()
        while finished < len(procs):
            try:
                msg = q.get(timeout=1.0)
            except queue.Empty:
                dead = [p for p in procs if p.exitcode not in (None, 0)]
                if dead:
                    raise OdsuiteError(f"a render process exited with code {dead[0].exitcode}") from None
                continue
            if msg[0] == "done":
                advance(msg[1])
            elif msg[0] == "finished":
                finished += 1
            else:
                if msg[2] is not None:
                    raise OdsuiteError(msg[2])
                raise RuntimeError(f"render process failed: {msg[1]}")
    finally:
        _stop_workers([p for p in procs if p.pid is not None], q, stop)


def _stop_workers(procs: list, q, stop) -> None:
    """Ask the render processes to stop after their frame (each ends its encoder) and wait for
    them, reading their last messages meanwhile (a process cannot exit with messages unsent);
    end the ones still running after ``STOP_WAIT``."""
    stop.set()
    deadline = time.monotonic() + STOP_WAIT
    while any(p.is_alive() for p in procs) and time.monotonic() < deadline:
        try:
            q.get(timeout=0.1)
        except queue.Empty:
            pass
    for p in procs:
        if p.is_alive():
            p.terminate()
        p.join()


class _progress_bar:
    """A rich progress bar (or nothing) exposing ``advance(n)``."""

    def __init__(self, show: bool, total: int, name: str) -> None:
        self.show, self.total, self.name = show, total, name

    def __enter__(self) -> Callable[[int], None]:
        if not self.show:
            return lambda n: None
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

        self._p = Progress(TextColumn("rendering {task.description}"), BarColumn(), MofNCompleteColumn(),
                           TimeRemainingColumn(), transient=True, console=Console(stderr=True))
        self._p.__enter__()
        task = self._p.add_task(self.name, total=self.total)
        return lambda n: self._p.advance(task, n)

    def __exit__(self, *exc) -> None:
        if self.show:
            self._p.__exit__(*exc)
