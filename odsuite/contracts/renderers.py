"""The renderer contract, and the choice of a renderer for an output file.

A provider registered through ``odsuite_register_renderers`` has:

- ``name`` (str) and ``description`` (str);
- ``kind`` (str): ``"movie"`` (an animation of an experiment), ``"figure"`` (a still picture of an
  experiment) or ``"page"`` (a document about the whole project, e.g. the HTML report);
- ``suffixes`` (tuple of str): the output file suffixes it writes, lower case with the dot
  (".mp4", ".png", ...);
- ``render(request) -> Rendered``: draws ``request`` (a :class:`RenderRequest`) into
  ``request.output`` and says what it wrote. Options it does not know are refused with a
  :class:`~odsuite.domain.errors.ConfigError` naming them; so are experiments or projects it cannot
  draw (no rig geometry, no generalized coordinates, ...).

``odsuite render PROJECT EXPERIMENT -o FILE --figure NAME`` uses the renderer NAME;
without ``--figure`` the movie renderer that writes FILE's suffix. ``odsuite report`` uses the
page renderer ``report``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from odsuite.domain import arguments
from odsuite.domain.errors import ConfigError
from odsuite.domain.textfiles import plain_number

KINDS = ("movie", "figure", "page")


@dataclass(frozen=True)
class RenderRequest:
    """What to draw: a project file, one of its experiments (None for a page), the output file, and
    the renderer's options (e.g. ``model``, ``magnify`` (H_t, H_r), ``view``, ``workers``)."""

    project: Path
    experiment: str | None
    output: Path
    options: Mapping[str, Any] = field(default_factory=dict)
    progress: bool = True
    #: the providers to open the project with (``open_project(..., registries=)``); None: the
    #: installed plugins'
    registries: Any = None

    def __post_init__(self) -> None:
        if self.options is None:
            object.__setattr__(self, "options", {})
        elif not isinstance(self.options, Mapping):
            raise ConfigError(f"render options: expected a mapping of option names to values, "
                              f"got {type(self.options).__name__}")

    def checked_options(self, known: set[str] | frozenset[str], renderer: str) -> dict[str, Any]:
        """The set options after :meth:`unknown_options` and :func:`check_render_options`."""
        self.unknown_options(known, renderer)
        return {k: v for k, v in check_render_options(self.options).items() if v is not None}

    def unknown_options(self, known: set[str] | frozenset[str], renderer: str) -> None:
        """Refuse options the renderer does not take (set ones only; None means not given)."""
        extra = sorted(k for k, v in self.options.items() if v is not None and v is not False and k not in known)
        if extra:
            raise ConfigError(f"renderer {renderer!r} does not take option(s) {', '.join(extra)}")


@dataclass(frozen=True)
class Rendered:
    """What a renderer wrote: the file, one line saying what it shows, and notes for the user."""

    path: Path
    summary: str
    notes: tuple[str, ...] = ()


class Renderer(Protocol):
    """What every registered renderer has (checked when a plugin registers one)."""

    name: str
    description: str
    kind: str
    suffixes: tuple[str, ...]

    def render(self, request: RenderRequest) -> Rendered: ...


PROTOCOL = Renderer


def choose_renderer(registry, output: Path, name: str | None = None, kind: str | None = None):
    """The renderer ``name`` (checked to write ``output``'s suffix), or else the renderer of
    ``kind`` (default "movie") that writes that suffix."""
    suffix = Path(output).suffix.lower()
    if name is not None:
        if name not in registry:
            of_kind = [n for n, r in registry.items() if kind is None or r.kind == kind]
            raise ConfigError(f"--figure {name!r}: no such {kind or ''} renderer (registered: "
                              f"{', '.join(of_kind) or 'none'})".replace("  ", " "))
        renderer = registry.get(name)
        if suffix not in renderer.suffixes:
            raise ConfigError(f"renderer {name!r} writes {', '.join(renderer.suffixes)} files, not {output}")
        return renderer
    kind = kind or "movie"
    # the renderer named after its kind (the built-in "movie") is the default among several
    fits = sorted((r for _, r in registry.items() if r.kind == kind and suffix in r.suffixes),
                  key=lambda r: r.name != kind)
    if not fits:
        known = sorted({s for _, r in registry.items() if r.kind == kind for s in r.suffixes})
        raise ConfigError(f"no {kind} renderer writes {suffix or 'files without a suffix'} files "
                          f"({output}); {kind} renderers write {', '.join(known) or 'nothing'}")
    return fits[0]


def parse_pair(text: str | None, what: str) -> tuple[float, float] | None:
    """'A,B' -> (A, B) floats; None stays None."""
    if text is None:
        return None
    try:
        a, b = (plain_number(v) for v in text.split(","))
    except ValueError:
        raise ConfigError(f"{what}: expected two numbers 'A,B', got {text!r}") from None
    return (a, b)


def check_view_angles(angles: tuple[float, ...], text: str) -> tuple[float, ...]:
    """``--view`` angles (degrees) within a turn either way: NaN drew nothing, inf warned, and
    1e300 degrees names no direction at all."""
    if not all(math.isfinite(a) and abs(a) <= 360 for a in angles):
        raise ConfigError(f"--view: angles must be finite numbers of degrees from -360 to 360, got {text!r}")
    return angles


def parse_view(text: str | None) -> tuple[float, float] | None:
    """A movie's ``--view`` 'AZ,EL' -> (azimuth, elevation) in degrees, the elevation at most 90
    either way (beyond, the camera looks over the top); None stays None."""
    pair = parse_pair(text, "--view")
    if pair is not None and abs(check_view_angles(pair, text)[1]) > 90:
        raise ConfigError(f"--view: the elevation must be from -90 to 90 degrees, got {text!r}")
    return pair


def parse_magnify(text: str | None) -> tuple[float, float] | None:
    """``--magnify`` 'H_t,H_r' -> (H_t, H_r), both finite and >= 0 (a negative factor would mirror
    the motion); None stays None."""
    pair = parse_pair(text, "--magnify")
    return None if pair is None else check_magnify(pair, text)


def _shown(value: Any) -> str:
    """A value in a message: a number as typed (nan, 0.0), anything else quoted with its type's look."""
    return str(value) if isinstance(value, numbers.Real) and not isinstance(value, bool) else repr(value)


def _is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def check_render_options(options: Mapping[str, Any]) -> dict[str, Any]:
    """The experiment renderers' options as ``odsuite render`` checks them, named by its options, so
    a request from Python is refused with the same line (a NaN rate reached int(), a text duration
    compared with 0). Returns the options with ``magnify`` as a pair (text 'H_t,H_r' is parsed);
    other keys pass unchecked."""
    out = dict(options)
    for key, value in options.items():
        if value is None:
            continue
        flag = {"ods_hz": "--ods", "frame_step": "--frame-step"}.get(key, f"--{key}")
        if key in ("fps", "duration", "slowdown", "start", "end"):
            positive = key not in ("start", "end")
            if not (_is_number(value) and math.isfinite(value) and (not positive or value > 0)):
                raise ConfigError(f"{flag}: must be a finite number{' > 0' if positive else ''}, got {_shown(value)}")
        elif key == "ods_hz" and not (_is_number(value) and math.isfinite(value) and value >= 0.01):
            # as --cutoff: no line below 0.01 Hz
            raise ConfigError(f"--ods: must be a finite frequency >= 0.01 Hz, got {_shown(value)}")
        elif key in ("fmin", "fmax") and not (_is_number(value) and math.isfinite(value) and value >= 0):
            raise ConfigError(f"{flag}: must be a finite frequency >= 0 Hz, got {_shown(value)}")
        elif key in ("workers", "frame_step", "mode"):
            if not isinstance(value, numbers.Integral) or isinstance(value, bool):
                raise ConfigError(f"{flag}: expected a whole number, got {_shown(value)}")
            if key == "workers" and value < 1:
                raise ConfigError(f"--workers: at least 1 render process, got {value}")
            if key == "workers":
                arguments.check_workers(value)
            if key == "frame_step" and value < 1:
                raise ConfigError(f"--frame-step: at least 1 sample per frame, got {value}")
        elif key in ("view", "reference") and not isinstance(value, str):
            what = "'AZ,EL' or 'EYE[,THETA,PHI,PSI]'" if key == "view" else "a sensor name"
            raise ConfigError(f"{flag}: expected text, {what}, got {_shown(value)}")
        elif key == "model" and not isinstance(value, bool):
            raise ConfigError(f"--model: expected True or False, got {_shown(value)}")
        elif key == "magnify":
            out[key] = _magnify_pair(value)
    return out


def _magnify_pair(value: Any) -> tuple[float, float]:
    """``magnify`` as text 'H_t,H_r' or a pair of numbers -> (H_t, H_r), checked as --magnify."""
    if isinstance(value, str):
        return parse_magnify(value)
    try:
        pair = tuple(value)
    except TypeError:
        pair = ()
    if len(pair) != 2 or not all(_is_number(v) for v in pair):
        raise ConfigError(f"--magnify: expected two numbers 'A,B', got {_shown(value)}")
    return check_magnify((float(pair[0]), float(pair[1])), value)


def check_magnify(pair: tuple[float, float], given: Any) -> tuple[float, float]:
    """Magnification factors, both finite and >= 0 (a negative factor would mirror the motion)."""
    if not all(math.isfinite(v) and v >= 0 for v in pair):
        raise ConfigError(f"--magnify: magnification factors must be finite numbers >= 0, got {given!r}")
    return pair
