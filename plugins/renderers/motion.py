"""Magnified plate motion shared by the movie and the figures (thesis Eq. 4.15, Table 4.1)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from odsuite.api import ConfigError, DimensionError
from odsuite.api import Body, Rig
from odsuite.api import body_corners, plate_corners, point_displacements

#: Default largest corner excursion on screen, as a fraction of the largest moving plate's size.
DEFAULT_EXCURSION = 0.15


#: the largest generalized coordinate drawn (m, rad): a plate moving further does not vibrate
MOTION_MAX = 1e3


def check_coords(rig: Rig, coords: Mapping[str, np.ndarray], what: str = "coords") -> dict[str, np.ndarray]:
    """Validate ``{body: (n, 6)}`` against the rig: known bodies with plates, finite, equal lengths."""
    out: dict[str, np.ndarray] = {}
    lengths = set()
    for name, d in coords.items():
        body = rig.body(name)
        if body.plate is None:
            raise ConfigError(f"{what}: body {name!r} of rig {rig.name!r} has no plate to draw")
        d = np.asarray(d, dtype=float)
        if d.ndim != 2 or d.shape[1] != 6:
            raise DimensionError(f"{what}[{name!r}]: expected generalized coordinates (n, 6), got {d.shape}")
        if not np.all(np.isfinite(d)):
            bad = int(np.argwhere(~np.isfinite(d))[0, 0])
            raise ConfigError(f"{what}[{name!r}]: non-finite value at sample {bad}")
        if np.abs(d).max(initial=0.0) > MOTION_MAX:
            bad = np.unravel_index(int(np.argmax(np.abs(d))), d.shape)
            raise ConfigError(f"{what}[{name!r}]: {d[bad]:g} ({'m' if bad[1] < 3 else 'rad'}) at sample {bad[0]}: "
                              f"not a vibration (beyond {MOTION_MAX:g}); the stored coordinates are damaged")
        out[name] = d
        lengths.add(d.shape[0])
    if not out:
        raise ConfigError(f"{what}: no body to animate")
    if len(lengths) != 1:
        raise DimensionError(f"{what}: bodies have different sample counts {sorted(lengths)}")
    return out


def magnified(d: np.ndarray, magnify: tuple[float, float]) -> np.ndarray:
    """``H o d`` of Eq. 4.15: translations times H_t, rotations times H_r."""
    out = np.array(d, dtype=float, copy=True)
    out[..., :3] *= magnify[0]
    out[..., 3:] *= magnify[1]
    return out


def corners(body: Body, d: np.ndarray, magnify: tuple[float, float]) -> np.ndarray:
    """Rig-frame plate corners (n, 8, 3) of a body moving with ``d`` (n, 6) at G, magnified."""
    return body_corners(body, magnified(d, magnify))


def plate_scale(rig: Rig, bodies: list[str] | None = None) -> float:
    """Largest plate dimension among ``bodies`` (default: those with plates that move)."""
    names = bodies or [b.name for b in rig.moving_bodies if b.plate is not None]
    sizes = [float(rig.body(n).plate.size.max()) for n in names if rig.body(n).plate is not None]
    if not sizes:
        sizes = [float(b.plate.size.max()) for b in rig.bodies if b.plate is not None]
    if not sizes:
        raise ConfigError(f"rig {rig.name!r} has no plate to draw")
    return max(sizes)


#: With a slow drift under the vibration, the default lets the drift carry the plates this many
#: plate sizes at most (the vibration is drawn at ``DEFAULT_EXCURSION`` where that allows).
DRIFT_DRAWN = 1.0
#: a slow part this many times the vibration's amplitude is a drift, not the motion to show
DRIFT_RATIO = 2.0


def _vibration(disp: np.ndarray) -> float:
    """The amplitude of the oscillating part of corner displacements (samples x corners x 3): the
    largest step from one sample to the next over the steps' frequency, 2 sin(w/2) per sample,
    from the ratio of second to first differences. A slow drift (the high-pass filter's start
    transient in displacements integrated from a record without pre-trigger) barely steps."""
    first = np.diff(disp, axis=0)
    second = np.diff(disp, 2, axis=0)
    energy = float(np.sum(first**2))
    if energy == 0.0 or second.size == 0:
        return 0.0
    per_sample = np.sqrt(float(np.sum(second**2)) / energy)  # 2 sin(w/2) of a sinusoid
    return float(np.linalg.norm(first, axis=-1).max()) / per_sample if per_sample > 0 else 0.0


def default_magnification(rig: Rig, *coord_sets: Mapping[str, np.ndarray],
                          excursion: float = DEFAULT_EXCURSION) -> tuple[float, float]:
    """(H_t, H_r), equal, so that the largest corner excursion is ``excursion`` x the plate size.

    The excursion is measured with the small-angle form (the magnified drawing uses finite
    rotations, which are close for the 15 % default). Where a slow drift exceeds the vibration
    (``DRIFT_RATIO``), the vibration's amplitude sets it instead, as far as the drift stays within
    ``DRIFT_DRAWN`` plate sizes: a record starting at its hit drew its drift at 15 % and its
    vibration at a hundredth of the plate. No motion at all gives (1, 1).
    """
    peak = vibration = 0.0
    for coords in coord_sets:
        for name, d in coords.items():
            body = rig.body(name)
            r = plate_corners(body.plate) - body.com
            disp = point_displacements(np.asarray(d, dtype=float), r, linear=True)
            peak = max(peak, float(np.linalg.norm(disp, axis=-1).max(initial=0.0)))
            vibration = max(vibration, _vibration(disp))
    if peak == 0.0:
        return (1.0, 1.0)
    scale = plate_scale(rig, list(coord_sets[0]))
    h = excursion * scale / peak
    if 0.0 < vibration and peak > DRIFT_RATIO * vibration:
        h = max(h, min(excursion * scale / vibration, DRIFT_DRAWN * scale / peak))
    return (h, h)


#: The largest corner excursion drawn, in plate sizes: the camera frames the plates with a fifth of a
#: plate to spare, so a plate drawn moving ten times its size is outside the picture nearly always.
DRAWN_MAX = 10.0


def check_magnification(rig: Rig, magnify: tuple[float, float], *coord_sets: Mapping[str, np.ndarray]) -> None:
    """Refuse a magnification (H_t, H_r) whose drawn motion of ``coord_sets`` (the samples drawn) is
    not finite or reaches more than ``DRAWN_MAX`` plate sizes (small-angle form, as the default's),
    naming --magnify and the largest pair in the same ratio that stays within."""
    given = f"--magnify {magnify[0]:g},{magnify[1]:g}"
    if not all(np.isfinite(h) and h >= 0 for h in magnify):
        raise ConfigError(f"{given}: magnification factors must be finite numbers >= 0")
    top = max(magnify)
    if top == 0:
        return
    # the drawn excursion is linear in (H_t, H_r): measured at the largest factor 1, it cannot overflow
    unit = 0.0
    for coords in coord_sets:
        for name, d in coords.items():
            body = rig.body(name)
            disp = point_displacements(magnified(d, (magnify[0] / top, magnify[1] / top)),
                                       plate_corners(body.plate) - body.com, linear=True)
            unit = max(unit, float(np.linalg.norm(disp, axis=-1).max(initial=0.0)))
    scale = plate_scale(rig, list(coord_sets[0]))
    drawn = unit * top  # inf when it overflows: refused as well
    if drawn > DRAWN_MAX * scale:
        most = DRAWN_MAX * scale / unit
        times = f"{drawn / scale:.3g} times" if np.isfinite(drawn / scale) else "beyond any number of times"
        raise ConfigError(f"{given}: draws the largest corner motion {times} the plate's {1e3 * scale:.0f} mm "
                          f"size, more than the {DRAWN_MAX:g} times a picture can show; at most --magnify "
                          f"{most * (magnify[0] / top):.3g},{most * (magnify[1] / top):.3g} for this motion")


def _times(h: float) -> str:
    """A magnification as a reader counts it: 18,221 with digit groups; a huge one as 1e+300 (it
    printed 301 digits)."""
    return f"{h:,.0f}" if 100 <= h < 1e7 else f"{h:.3g}"


def speed_words(slowdown: float) -> str:
    """Playback speed (movie time / real time) as a reader says it: '40 times slower than real
    time', '4 times faster than real time' (a factor below 1 printed as '0 times slower')."""
    if abs(np.log(slowdown)) < 0.005:  # within half a percent: 3 digits would print 1
        return "real time"
    factor = slowdown if slowdown > 1 else 1 / slowdown
    return f"{_times(factor)} times {'slower' if slowdown > 1 else 'faster'} than real time"


def magnification_words(magnify: tuple[float, float]) -> str:
    """The magnification (H_t, H_r) as a reader understands it: how much larger than life."""
    h_t, h_r = magnify
    if np.isclose(h_t, h_r, rtol=1e-6):
        return f"motion drawn {_times(h_t)} times larger than it is" if h_t > 0 else "motion held still (x0)"
    if 0 in (h_t, h_r):  # x0 shows the other motion alone ("0 times larger" read as a mistake)
        still, moving, h = ("translations", "rotations", h_r) if h_t == 0 else ("rotations", "translations", h_t)
        return f"{still} held still (x0), {moving} drawn {_times(h)} times larger than they are"
    return f"translations drawn {_times(h_t)} times, rotations {_times(h_r)} times larger than they are"


def event_window(rig: Rig, coords: Mapping[str, np.ndarray], fs: float, *, contact: int | None = None,
                 before: float = 0.005, settle: float = 0.1, minimum: float = 0.02) -> tuple[float, float]:
    """Default movie window (start, end) in s around the hammer hit.

    From ``before`` s ahead of the contact (default: where the largest corner excursion first
    reaches 5 % of its maximum) to the last sample at which the excursion is still ``settle`` x
    its maximum, plus ``before``, at least ``minimum`` s after the contact; clipped to the record.
    The still pre-trigger stretch and the decayed tail show nothing.
    """
    excursion = _excursion(rig, coords)
    n = excursion.size
    peak = excursion.max(initial=0.0)
    if peak == 0.0:
        return 0.0, (n - 1) / fs
    start = contact if contact is not None else int(np.argmax(excursion >= 0.05 * peak))
    late = np.flatnonzero(excursion[start:] >= settle * peak)
    last = start + (int(late[-1]) if late.size else 0)
    i0 = max(0, start - int(round(before * fs)))
    i1 = min(n - 1, max(last + int(round(before * fs)), start + int(round(minimum * fs))))
    return i0 / fs, i1 / fs


def _excursion(rig: Rig, coords: Mapping[str, np.ndarray]) -> np.ndarray:
    """Largest corner excursion (m, small-angle form) of the moving plates at each sample."""
    excursion = None
    for name, d in coords.items():
        body = rig.body(name)
        disp = point_displacements(np.asarray(d, dtype=float), plate_corners(body.plate) - body.com,
                                   linear=True)
        e = np.linalg.norm(disp, axis=-1).max(axis=-1)
        excursion = e if excursion is None else np.maximum(excursion, e)
    return excursion


def contact_index(force: np.ndarray, fraction: float = 0.1) -> int:
    """First sample where |force| reaches ``fraction`` of its peak: the hammer's contact."""
    f = np.abs(np.asarray(force, dtype=float))
    if f.ndim != 1 or f.size == 0 or f.max() == 0:
        raise ConfigError("force: expected a non-zero 1-D force signal to find the hammer contact")
    return int(np.argmax(f >= fraction * f.max()))


def characteristic_instant(rig: Rig, coords: Mapping[str, np.ndarray], *, contact: int | None = None,
                           prominence: float = 0.1) -> int:
    """Sample of the Characteristic Forced Response (Table 5.2, Fig. 5.7).

    The first peak, after the hammer contact, of the largest corner excursion of the moving
    plates; a peak counts when its prominence is at least ``prominence`` x the record's maximum.
    Without ``contact`` the contact is taken where the excursion first reaches 5 % of its maximum.
    """
    from scipy.signal import find_peaks

    excursion = _excursion(rig, coords)
    if excursion is None or excursion.max() == 0:
        raise ConfigError("coords: the plates do not move; there is no forced response to show")
    start = contact if contact is not None else int(np.argmax(excursion >= 0.05 * excursion.max()))
    peaks, _ = find_peaks(excursion[start:], prominence=prominence * excursion.max())
    if peaks.size == 0:
        return start + int(np.argmax(excursion[start:]))
    return start + int(peaks[0])
