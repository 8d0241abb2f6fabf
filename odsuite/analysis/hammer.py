"""Impact-hammer test quality: split a record into hits, reject double hits and overloads, and the
force and exponential windows (with the pole shift the exponential window adds).

Conventions: ``force`` is 1-D (samples), ``responses`` is samples x channels, both in physical
units; indices are samples.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from odsuite.domain import arguments
from odsuite.domain.errors import ConfigError, DimensionError


@dataclass(frozen=True)
class Hit:
    """One hammer hit: its record ``[start, stop)``, force peak and acceptance with reasons."""

    start: int
    stop: int
    peak_index: int  # absolute sample of the force peak
    time: float  # s from the data's first sample to the force peak: how a hit is named
    peak_force: float
    pulse_width: int  # samples the main pulse stays above 5 % of its peak
    accepted: bool
    reasons: tuple[str, ...]  # why it was rejected (empty when accepted)
    notes: tuple[str, ...] = ()  # warnings that do not reject it
    #: (response channel, its level at the record's end over its peak) where it has not decayed
    #: below the limit: leakage, the notes' numbers
    undecayed: tuple[tuple[int, float], ...] = ()
    #: its record does not fit in the data, or its peak is their last sample: never averaged, not
    #: even where every hit is flagged (its record would be shorter than the others', its blow cut)
    left_out: bool = False
    #: what the data's ends did with this hit, one line with its time in s ("" when nothing): left
    #: out, or every record cut short to fit it
    data_end: str = ""
    #: s from the force peak to its rebound's for a double hit, else None
    double_hit_after: float | None = None

    @property
    def trigger(self) -> int:
        """Sample of the force peak relative to ``start``."""
        return self.peak_index - self.start


#: where a hit's pulse ends, as a share of the hit threshold: a quarter of it, 5 % of the record's
#: largest excursion at the default threshold (``pulse_width``'s level for the largest hit)
PULSE_END = 0.25


def hit_name(time: float) -> str:
    """A hit as every line names it: by its force peak's time (s)."""
    return f"hit at {time:.4g} s"


def _as_2d(responses: np.ndarray, n: int) -> np.ndarray:
    r = np.asarray(responses, dtype=float)
    if r.ndim == 1:
        r = r[:, None]
    if r.ndim != 2 or r.shape[0] != n:
        raise DimensionError(
            f"responses have shape {np.shape(responses)}; expected {n} samples x channels like the force"
        )
    return r


def find_hits(force: np.ndarray, *, threshold: float = 0.2, min_gap: int) -> list[int]:
    """Sample of the force peak of every hit (``hit_pulses``)."""
    return [peak for _, peak, _ in hit_pulses(force, threshold=threshold, min_gap=min_gap)]


def hit_pulses(force: np.ndarray, *, threshold: float = 0.2, min_gap: int) -> list[tuple[int, int, int]]:
    """First sample, peak sample and one-past-last sample of every hit's pulse: a hit starts where
    force - baseline, taken in the sign of its largest excursion, first exceeds ``threshold`` x that
    excursion, and hits closer than ``min_gap`` samples merge into one (a close second impact is
    then a double hit of the first). The baseline is the median. The pulse is the run of samples
    around that crossing that stay above ``PULSE_END`` x the threshold (where the force is back
    near zero); its largest sample is the peak, and the next hit starts after it."""
    f = np.asarray(force, dtype=float)
    if f.ndim != 1 or f.size == 0:
        raise DimensionError(f"force must be a non-empty 1-D signal, got shape {f.shape}")
    if not 0 < threshold < 1:
        raise ConfigError(f"hit threshold {threshold} must lie between 0 and 1 (fraction of the peak)")
    signed = f - np.median(f)
    # a hammer pushes one way: a filtered pulse's opposite lobe (an 8th-order 1 kHz low-pass rings
    # for over a thousand samples at 1 MHz) is no second hit
    dev = signed * (1.0 if signed.max() >= -signed.min() else -1.0)
    level = threshold * dev.max()
    above = np.flatnonzero(dev > level)
    # the pulse's own shape bounds the peak's search, not a count of samples: a soft tip's 5 ms blow
    # sampled at 1 MHz peaks 2500 samples after it starts, while a bounce after the force came back
    # near zero is a pulse of its own
    near_zero = np.flatnonzero(dev <= PULSE_END * level)
    pulses: list[tuple[int, int, int]] = []
    i = 0
    while i < above.size:
        crossing = int(above[i])
        a, b = _run_around(near_zero, crossing, f.size)
        pulses.append((a, a + int(np.argmax(dev[a:b])), b))
        i = int(np.searchsorted(above, max(b, crossing + min_gap)))
    return pulses


def _run_around(low: np.ndarray, at: int, n: int) -> tuple[int, int]:
    """First and one-past-last sample of the run around ``at`` (itself included) that holds none of
    the sorted sample indices ``low`` (where a signal of ``n`` samples is at or below a level)."""
    k = int(np.searchsorted(low, at))
    j = int(np.searchsorted(low, at, side="right"))
    return (int(low[k - 1]) + 1 if k > 0 else 0), (int(low[j]) if j < low.size else n)


def pulse_width(force: np.ndarray, peak: int, level: float = 0.05) -> tuple[int, int]:
    """First and one-past-last sample around ``peak`` where |force - baseline| stays above ``level``
    x the peak excursion (baseline: the median of the signal)."""
    f = np.asarray(force, dtype=float)
    dev = np.abs(f - np.median(f))
    return _run_around(np.flatnonzero(dev <= level * dev[peak]), peak, f.size)


def is_double_hit(force: np.ndarray, peak: int, *, level: float = 0.25, guard: int = 2) -> bool:
    """True when, after the main pulse has ended, the force again pushes the same way by more than
    ``level`` x the peak (a second impact on the rebound). Excursions of the other sign are the
    anti-aliasing filter's ringing (about 30 % of the peak for a 0.5 ms blow through an 8th-order
    1 kHz low-pass, with a same-sign lobe of about 15 %), not a hammer: a hammer only pushes."""
    return second_push(force, peak, level=level, guard=guard) is not None


def second_push(force: np.ndarray, peak: int, *, level: float = 0.25, guard: int = 2) -> int | None:
    """The sample of the largest same-way push after the main pulse when it makes a double hit
    (``is_double_hit``), else None."""
    f = np.asarray(force, dtype=float)
    dev = f - np.median(f)
    _, end = pulse_width(f, peak)
    rest = dev[end + guard :] * np.sign(dev[peak])
    if not (rest.size and rest.max() > level * abs(dev[peak])):
        return None
    return end + guard + int(np.argmax(rest))


def quantisation_step(signal: np.ndarray) -> float:
    """The smallest difference between distinct sample values: the ADC code width of a converted
    record (a finer number for unquantised data; 0 for a constant signal)."""
    values = np.unique(np.asarray(signal, dtype=float))
    return float(np.diff(values).min()) if values.size > 1 else 0.0


def _steep_codes(run: int) -> float:
    """How many codes a clipped flat top's neighbours must lie below it. A smooth (parabolic)
    peak held within one code over ``run`` samples has curvature at most 1 code per ((run-1)/2)^2
    samples^2, so its nearer neighbour lies at most ((run+1)/(run-1))^2 + 1 codes below (the +1:
    rounding of both); twice that leaves room for noise (10 codes for run = 3)."""
    return 2.0 * (((run + 1) / (run - 1)) ** 2 + 1.0)


def held_range(signal: np.ndarray, low: float, high: float) -> tuple[float, float] | None:
    """The converter range (low, high) a record declares, in the signal's units, when the signal
    stays inside it; None when samples lie beyond it. A card picks the smallest hardware range that
    holds the limits the operator asked for (NI: 0.05..10 V), so samples beyond the declared limits
    show the real range is wider and not known (clipping is then told by flat tops alone)."""
    lo, hi = sorted((low, high))
    x = np.asarray(signal, dtype=float)
    return (lo, hi) if x.size and x.min() >= lo and x.max() <= hi else None


def is_clipped(signal: np.ndarray, *, limits: tuple[float, float] | None = None, run: int = 3) -> bool:
    """True when the signal reaches its converter's range or shows a clipped flat top.

    ``limits``: the ADC's input range (low, high) in the signal's own units, None when unknown
    (files in engineering units): clipped when a sample lies within 1.5 codes of a limit (the top
    code of an n-bit converter is one code below its high limit). Flat top: the record's largest
    or smallest value held for ``run`` (>= 3) or more consecutive samples and entered and left
    steeply (``_steep_codes``), at least half as far from the median as the largest excursion
    (a hammer pulse's quiet side is its baseline): an amplifier or sensor saturating below the
    converter's range. A
    quantised but unclipped peak also sits on its top code for several samples, with neighbours
    a code or two away, and passes."""
    x = np.asarray(signal, dtype=float)
    if run < 3:
        raise ConfigError(f"flat-top run {run} must be at least 3 samples")
    if x.size == 0:
        return False
    step = quantisation_step(x)
    if limits is not None and (x.min() <= limits[0] + 1.5 * step or x.max() >= limits[1] - 1.5 * step):
        return True
    steep = _steep_codes(run) * step
    baseline = np.median(x)
    reach = np.abs(x - baseline).max()
    if reach == 0.0:
        return False  # a constant signal away from the limits: no response, not a cut-off one
    for extreme, sign in ((x.max(), 1.0), (x.min(), -1.0)):
        if sign * (extreme - baseline) < 0.5 * reach:
            continue  # the quiet side of a one-sided pulse: its extreme is the baseline, not a limit
        at = np.concatenate(([0], (x == extreme).astype(np.int8), [0]))
        edges = np.diff(at)
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
            if b - a < run:
                continue
            # neighbours outside the record count as steep: the data end inside the flat top
            before = sign * (extreme - x[a - 1]) if a > 0 else np.inf
            after = sign * (extreme - x[b]) if b < x.size else np.inf
            if min(before, after) > steep:
                return True
    return False


def force_window(n: int, start: int, stop: int, taper: int = 0) -> np.ndarray:
    """1 on ``[start, stop)``, half-cosine tapers of ``taper`` samples outside it, 0 elsewhere:
    keeps the hammer pulse and removes the force channel's noise after it."""
    if not 0 <= start < stop <= n:
        raise ConfigError(f"force window [{start}, {stop}) does not fit a record of {n} samples")
    w = np.zeros(n)
    w[start:stop] = 1.0
    if taper > 0:
        ramp = 0.5 * (1 + np.cos(np.pi * np.arange(1, taper + 1) / (taper + 1)))
        right = w[stop : stop + taper]
        w[stop : stop + taper] = ramp[: right.size]
        left = ramp[::-1][max(taper - start, 0) :]
        w[start - left.size : start] = left
    return w


def exponential_window(n: int, fs: float, *, trigger: int = 0, end_value: float = 0.01) -> tuple[np.ndarray, float]:
    """``w[k] = exp(-(k - trigger)/(fs tau))`` with tau chosen so that ``w[n-1] = end_value``.
    Applied to force and response alike it is exact: the FRF becomes that of the system with every
    pole shifted by -1/tau. Returns (window, tau in s)."""
    if not 0 < end_value < 1:
        raise ConfigError(f"exponential window end value {end_value} must lie between 0 and 1")
    if not 0 <= trigger < n - 1:
        raise ConfigError(f"exponential window trigger {trigger} must lie inside the {n}-sample record")
    tau = -((n - 1 - trigger) / fs) / np.log(end_value)
    return np.exp(-(np.arange(n) - trigger) / (fs * tau)), float(tau)


def correct_exponential_window(poles: np.ndarray, tau: float) -> np.ndarray:
    """Undo the damping an exponential window of time constant ``tau`` (s) added: the identified
    poles lie 1/tau further left than the structure's, so lambda = lambda_w + 1/tau. Frequency and
    damping follow as f = |lambda|/2pi, zeta = -Re lambda/|lambda|."""
    return np.asarray(poles, dtype=complex) + 1.0 / tau


def assess_hits(
    force: np.ndarray,
    responses: np.ndarray,
    fs: float,
    *,
    record_length: int | None = None,
    pretrigger: int | None = None,
    threshold: float = 0.2,
    double_hit_level: float = 0.25,
    force_limits: tuple[float, float] | None = None,
    response_limits: tuple[float, float] | Sequence[tuple[float, float] | None] | None = None,
    decay_limit: float | None = 0.01,
) -> list[Hit]:
    """Split a record into hits and judge each: rejected for a double hit, a clipped or overloaded
    force or response channel, or a record cut short by the data's end; noted (not rejected) when
    the response has not decayed below ``decay_limit`` x its peak at the record end, nor into its
    noise (leakage: use an exponential window). Defaults: pretrigger 1 % of the record, or the
    longest pulse's rise when longer (at most the samples before the first hit; a given length the
    last hit's data miss by at most that: its record starts earlier); records as long as the closest
    hits allow (to each pulse's end at least) and the last hit's data reach, unless those end before
    half that length: that hit is then left out (``Hit.left_out``, as is a hit whose record runs
    past the data or whose peak is their last sample; ``Hit.data_end`` says so). Limits are the
    converters' ranges in the signals' units (``is_clipped``); ``response_limits`` is one range for
    every response or one per response channel."""
    f = np.asarray(force, dtype=float)
    r = _as_2d(responses, f.size)
    n = f.size
    if response_limits is None or all(isinstance(v, (int, float, np.number)) for v in response_limits):
        response_limits = [response_limits] * r.shape[1]
    if len(response_limits) != r.shape[1]:
        raise DimensionError(f"{len(response_limits)} response limits for {r.shape[1]} response channels")
    if record_length is not None and record_length < 8:
        raise ConfigError(f"record length {record_length} samples is too short for a hit")
    if pretrigger is not None:
        arguments.whole("assess_hits", "pretrigger", pretrigger, 0)
        # the record would end at or before the hit's peak (an IndexError followed)
        if record_length is not None and pretrigger >= record_length:
            raise ConfigError(f"assess_hits: pretrigger {pretrigger} samples leaves nothing of the "
                              f"{record_length}-sample record after the hit's peak")
    gap = record_length if record_length is not None else max(n // 64, 8)
    pulses = hit_pulses(f, threshold=threshold, min_gap=gap)
    if not pulses:
        return []
    peaks = [peak for _, peak, _ in pulses]
    chosen_pretrigger = pretrigger is None
    if pretrigger is None:
        # a soft tip's blow at 1 MHz rises over more samples than 1 % of the record, which began on
        # its rising edge: from the last near-zero sample before the pulse at least
        rise = max(peak - first for first, peak, _ in pulses) + 1
        pretrigger = min(peaks[0], max((record_length or n) // 100, rise))
        if record_length is not None:
            pretrigger = min(pretrigger, record_length - 1)
    cut_short = ""
    if record_length is None:
        # equal records for averaging: as long as the closest hits allow, and the last one fits ...
        record_length = n - peaks[-1] + pretrigger
        if len(peaks) > 1:
            spacing = int(np.diff(peaks).min())
            if 2 * record_length < spacing:
                # ... unless the data end so soon after it that every record would lose more than half
                # (its lines more than twice as far apart): it is left out instead
                record_length = spacing
            elif record_length < spacing:
                cut_short = (f"every hit's record cut short to {record_length / fs:.4g} s by the data's end after "
                             f"it (FRF lines {fs / record_length:.4g} Hz apart, not {fs / spacing:.4g} Hz)")
            else:
                record_length = spacing
        elif record_length < gap:  # shorter than find_hits lets two hits' records be
            cut_short = (f"its record cut short to {record_length / fs:.4g} s by the data's end (FRF lines "
                         f"{fs / record_length:.4g} Hz apart)")
        # a broad pulse's peak lies late: after a quick one close behind, the records overlap
        # rather than end before a peak or cut a pulse short
        record_length = max(record_length, pretrigger + max(stop - peak for _, peak, stop in pulses))
    # each response's level and noise before the first blow (a pulse width before it starts): its
    # median and rms about it. A record whose last tenth swings about its mean within twice that
    # rms, or two converter codes, ends in noise, not ringing (a 12-bit thesis record's horizontal
    # channels under a vertical blow end 1-3 codes off their level, 5-8 % of their peaks), or in a
    # sensor's drift away from the level (the plate-and-motor rig's, 47 % of a peak after 4 s)
    first, last = pulse_width(f, peaks[0])
    quiet = r[: max(2 * first - last, 0)]
    level = np.median(quiet, axis=0) if len(quiet) else None
    noise = np.sqrt(np.mean((quiet - level) ** 2, axis=0)) if len(quiet) else np.zeros(r.shape[1])
    hits = []
    for p in peaks:
        start = p - pretrigger
        stop = start + record_length
        if chosen_pretrigger and 0 < stop - n <= min(pretrigger, start):
            # a length given (records of several experiments made equal) that the last hit misses by
            # a few samples: the record starts that much earlier, in the quiet before the hit
            start, stop = start - (stop - n), n
        reasons: list[str] = []
        undecayed: list[tuple[int, float]] = []
        left_out = ""
        if start < 0 or stop > n:
            edge = f"begin {p / fs:.4g} s before" if start < 0 else f"end {(n - p) / fs:.4g} s after"
            left_out = f"left out: its {record_length / fs:.4g} s record runs past the data, which {edge} its peak"
        a, b = max(start, 0), min(stop, n)
        fseg = f[a:b]
        local_peak = p - a
        pw = pulse_width(fseg, local_peak)
        if not left_out and p == n - 1:  # the force may still rise: the blow's spectrum is not in the data
            left_out = "left out: its peak is the data's last sample (its blow is cut)"
        if left_out:
            reasons.append(left_out)
        rebound = second_push(fseg, local_peak, level=double_hit_level)
        if rebound is not None:
            reasons.append(f"double hit {1e3 * (rebound - local_peak) / fs:.3g} ms after its peak")
        if is_clipped(fseg, limits=force_limits):
            reasons.append("force clipped/overloaded")
        for c in range(r.shape[1]):
            seg = r[a:b, c]
            if is_clipped(seg, limits=response_limits[c]):
                reasons.append(f"response channel {c} clipped/overloaded")
            if decay_limit is not None and seg.size > 20:
                # the level: before the first blow, else the record's samples before its peak
                base = level[c] if level is not None else np.median(seg[: max(local_peak, 1)])
                tail = np.abs(seg[-max(seg.size // 50, 4) :] - base)
                ratio = tail.max() / max(np.abs(seg).max(), 1e-300)
                swing = np.std(seg[-(seg.size // 10):])  # about its mean: a drift's offset is no ringing
                if ratio > decay_limit and swing > 2 * max(noise[c], quantisation_step(seg)):
                    undecayed.append((c, float(ratio)))
        said = left_out or (cut_short if p == peaks[-1] else "")
        hits.append(
            Hit(
                start=start,
                stop=stop,
                peak_index=p,
                time=p / fs,
                peak_force=float(f[p]),
                pulse_width=pw[1] - pw[0],
                accepted=not reasons,
                reasons=tuple(reasons),
                notes=tuple(f"response channel {c} at {100 * ratio:.1f} % of its peak at record end"
                            for c, ratio in undecayed),
                undecayed=tuple(undecayed),
                left_out=bool(left_out),
                data_end=f"{hit_name(p / fs)}: {said}" if said else "",
                double_hit_after=None if rebound is None else (rebound - local_peak) / fs,
            )
        )
    return hits
