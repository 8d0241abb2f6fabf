"""Figures of a modal test (matplotlib, no display): the stabilisation diagram with the chosen
modes, FRF magnitude/phase/coherence and a MAC matrix. Each function writes one file (the format
follows the suffix: .png, .svg, .pdf) and returns the matplotlib Figure for inspection; the core
computes what they draw (``odsuite frf``, ``odsuite modes``, ``compare``'s modal records)."""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from odsuite.api import ConfigError, DimensionError, frequency_labels, unit_text, write_output

_SUFFIXES = (".png", ".svg", ".pdf")

#: the share of the stabilisation diagram's height the poles take; the modes' labels sit above
POLE_SHARE = 0.55


def _new_figure(path: Path, size: tuple[float, float]):
    from matplotlib.figure import Figure

    if Path(path).suffix.lower() not in _SUFFIXES:
        raise ConfigError(f"figure {path}: the name must end in {', '.join(_SUFFIXES)}")
    return Figure(figsize=size, layout="constrained")


def _save(fig, path: Path, dpi: int = 130):
    try:
        write_output(Path(path), 0, lambda tmp: fig.savefig(tmp, dpi=dpi))  # a figure fits the reserve
    except OSError as exc:
        raise ConfigError(f"figure {path}: cannot write ({exc.strerror or exc})") from None
    return fig


def stabilisation_figure(result, path: str | Path, *, freq: np.ndarray, H: np.ndarray,
                         title: str = "stabilisation diagram",
                         background: str = "rms |H| of the outputs",
                         size: tuple[float, float] = (10, 6), dpi: int = 130, log_frequency: bool = False):
    """Poles per model order over the fit band (grey: new, blue: frequency stable, red: frequency
    and damping stable), the chosen modes as labelled lines with their stable-order counts, and
    the rms over outputs of ``H`` (FRFs, or amplitude spectra for output-only modes, named by
    ``background``) on a log axis behind them. ``size`` (inches), ``dpi``; ``log_frequency``: a
    logarithmic frequency axis (for a band over decades)."""
    if result.diagram is None or result.band_hz is None:
        raise ConfigError("stabilisation figure: the modal result holds no stabilisation diagram")
    d = result.diagram
    path = Path(path)
    fig = _new_figure(path, size)
    ax = fig.add_subplot()
    kinds = (("new pole", lambda sf, st: ~sf, {"facecolors": "none", "edgecolors": "0.6", "s": 10}),
             ("stable frequency", lambda sf, st: sf & ~st, {"c": "tab:blue", "marker": "x", "s": 14}),
             ("stable frequency and damping", lambda sf, st: st, {"c": "tab:red", "s": 12}))
    for label, pick, style in kinds:
        xs, ys = [], []
        for order, poles, sf, st in zip(d.orders, d.poles, d.stable_f, d.stable, strict=True):
            sel = pick(sf, st)
            xs.extend(np.abs(poles[sel]) / (2 * np.pi))
            ys.extend([order] * int(sel.sum()))
        ax.scatter(xs, ys, label=label, linewidths=0.8, **style)
    if log_frequency:  # a band over decades: the lowest modes are not squeezed into its first pixels
        ax.set_xscale("log")
    ax.set_xlim(*result.band_hz)
    # the poles in the lower 55 % of the axes, the modes' labels in the band above them (drawn
    # among the poles, the labels hid them)
    ax.set_ylim(0, (max(d.orders) + 2) / (POLE_SHARE if len(result.frequency_hz) else 1.0))
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("model order")
    ax.yaxis.get_major_locator().set_params(integer=True)  # orders are whole numbers
    ax.set_yticks([t for t in ax.get_yticks() if 0 <= t <= max(d.orders)])  # none in the labels' band
    labels = frequency_labels(result.frequency_hz)
    for k, (f, z) in enumerate(zip(result.frequency_hz, result.damping_ratio, strict=True)):
        ax.axvline(f, color="k", lw=0.8, ls="--")
        n = "" if result.stable_orders is None else f", {int(result.stable_orders[k])} orders"
        top = 0.99 - (k % 3) * 0.15  # staggered: close modes stay readable
        ax.annotate(f"{labels[k]}\nζ = {100 * z:.2f} %{n}", (f, top), xycoords=("data", "axes fraction"), fontsize=8,
                    ha="left", va="top", xytext=(3, 0), textcoords="offset points",
                    bbox={"boxstyle": "round", "fc": "white", "ec": "0.6", "alpha": 0.85})
    freq = np.asarray(freq, dtype=float)
    H = np.atleast_2d(np.asarray(H))
    keep = (freq >= result.band_hz[0]) & (freq <= result.band_hz[1])
    mag = ax.twinx()
    mag.semilogy(freq[keep], np.sqrt(np.mean(np.abs(H[:, keep]) ** 2, axis=0)), color="tab:green", lw=0.8)
    mag.set_ylabel(background, color="tab:green")
    ax.set_zorder(mag.get_zorder() + 1)
    ax.patch.set_visible(False)
    # under the axes, where it covers no pole (inside, at lower right, it hid the low orders' poles)
    fig.legend(handles=ax.get_legend_handles_labels()[0], loc="outside lower center", ncol=3, fontsize=8,
               frameon=False)
    n = len(result.frequency_hz)
    # a no-break space keeps the unit with its number when the title wraps
    ax.set_title(textwrap.fill(f"{title}: {n} mode{'' if n == 1 else 's'} in {result.band_hz[0]:.0f}-"
                               f"{result.band_hz[1]:.0f}\u00a0Hz", int(7 * size[0])), fontsize=10)
    return _save(fig, path, dpi)


#: the phase of an FRF is drawn only where its coherence reaches this (elsewhere it is noise)
COHERENCE_GOOD = 0.8


def frf_figure(frf, path: str | Path, *, band_hz: tuple[float, float] | None = None,
               outputs: Sequence[str] | None = None, title: str = "FRFs", model_hz: Sequence[float] = (),
               f_range: tuple[float, float] | None = None, size: tuple[float, float] = (10, 8), dpi: int = 130,
               model_H: dict[str, np.ndarray] | None = None):
    """Magnitude (log-log), phase (degrees) and coherence of each output's FRF above 0 Hz (within
    ``f_range`` when given: the axes then scale to that band, not to the noise beyond it);
    ``band_hz`` is shaded (e.g. the modal fit's usable band), ``model_hz`` (a model's modes) are
    dotted lines. ``model_H``: the model's FRF per output name at ``frf.frequency``, drawn black
    over the measured one (magnitude and phase). The measured phase is drawn only where the
    coherence reaches ``COHERENCE_GOOD``; the lines below it are shaded. ``size`` (inches) and
    ``dpi``: e.g. the width of a printed page."""
    names = list(outputs) if outputs is not None else frf.output_names
    missing = [n for n in names if n not in frf.output_names]
    if missing:
        raise ConfigError(f"FRF figure: no output {missing[0]!r}; outputs are {', '.join(frf.output_names)}")
    path = Path(path)
    frf, lowest, drawn = frf_drawn(frf, names)
    fig = _new_figure(path, size)
    mag, phase, coh = fig.subplots(3, 1, sharex=True, height_ratios=(3, 1.5, 1))
    pos = frf.frequency >= lowest
    if f_range is not None:
        pos &= (frf.frequency >= f_range[0]) & (frf.frequency <= f_range[1])
        if pos.sum() < 2:
            raise ConfigError(f"FRF figure: {f_range[0]:g}-{f_range[1]:g} Hz holds fewer than 2 lines above 0 Hz")
    f = frf.frequency[pos]
    units = {frf.units[frf.output_names.index(n)] for n in names}
    for name in names:
        k = frf.output_names.index(name)
        h = frf.H[k, pos]
        label = name if len(units) == 1 else f"{name} [{unit_text(frf.units[k])}]"
        line, = mag.loglog(f, np.abs(h), lw=0.8, label=label)
        good = frf.coherence[k, pos] >= COHERENCE_GOOD
        centre = _phase_centre(h) if len(names) == 1 else 0.0  # one axis for several outputs
        phase.semilogx(*_unjoined_wraps(f, np.where(good, _phase_degrees(h, centre), np.nan)), lw=0.6,
                       color=line.get_color())
        _shade_runs(phase, f, ~good)
        coh.semilogx(f, frf.coherence[k, pos], lw=0.6, color=line.get_color())
        if model_H is not None and name in model_H:
            hm = np.asarray(model_H[name])[pos]
            mag.loglog(f, np.abs(hm), lw=0.9, color="k", ls="--", label=f"model{'' if len(names) == 1 else ': ' + name}")
            phase.semilogx(*_unjoined_wraps(f, _phase_degrees(hm, centre)), lw=0.7, color="k", ls="--")
    for ax in (mag, phase, coh):
        if band_hz is not None:
            ax.axvspan(*band_hz, color="0.92", zorder=0)
        for j, fm in enumerate(m for m in model_hz if f[0] <= m <= f[-1]):
            ax.axvline(fm, color="0.45", lw=0.7, ls=":", label="model mode" if ax is mag and j == 0 else None)
        ax.grid(True, which="both", lw=0.3)
    mag.set_xlim(f[0], f[-1])
    mag.set_ylabel(f"|H| [{unit_text(units.pop())}]" if len(units) == 1 else "|H| [see legend]")
    mag.legend(fontsize=8, loc="best")
    phase.set_ylabel("phase [°]")
    from matplotlib.ticker import MultipleLocator

    phase.yaxis.set_major_locator(MultipleLocator(90))
    centre = _phase_centre(frf.H[frf.output_names.index(names[0]), pos]) if len(names) == 1 else 0.0
    phase.set_ylim(centre - 185.0, centre + 185.0)
    coh.set_ylabel("coherence [–]")
    coh.set_ylim(0, 1.05)
    coh.axhline(COHERENCE_GOOD, color="0.5", lw=0.6, ls="-.")
    if frf.n_averages == 1:
        coh.text(0.5, 0.5, "one hit: coherence is 1 by construction and says nothing", transform=coh.transAxes,
                 ha="center", va="center", fontsize=9, color="0.3")
    coh.set_xlabel("frequency [Hz]")
    shaded = "" if band_hz is None else f"; shaded: fit band {band_hz[0]:.0f}-{band_hz[1]:.0f} Hz"
    shaded += f"; phase only where coherence ≥ {COHERENCE_GOOD:g}" + (f"; {drawn}" if drawn else "")
    hits = f"{frf.n_averages} hit" + ("s averaged" if frf.n_averages > 1 else "")
    mag.set_title(textwrap.fill(f"{title}: {frf.estimator} estimator, {hits}{shaded}", int(7 * size[0])),
                  fontsize=10)  # about 7 characters per inch at 10 pt
    return _save(fig, path, dpi)


def frf_drawn(frf, names: Sequence[str]) -> tuple[object, float, str]:
    """The FRFs to draw, the lowest frequency (Hz) the records determine and the words saying so.

    An offset or a drift of an accelerometer, through a record that does not end where it began,
    leaks as 1/f into the lowest lines (``FrfSet.trend``: a hammer record's single-hit H1 rose to
    0.1 (m/s²)/N at 0.5 Hz on a 47 kg body from a drift of 0.009 m/s² per second). H1 is drawn with
    the records' straight lines removed, from ``TREND_FREE_LINE`` cycles per record up; another
    estimate from where the trend leaks at most ``TREND_SHARE`` of |H|."""
    from odsuite.api import TREND_FREE_LINE, TREND_SHARE

    f = frf.frequency[frf.frequency > 0]
    if not f.size or frf.trend is None or not np.any(frf.trend):
        return frf, float(f[0]) if f.size else 0.0, ""
    if frf.estimator == "H1" and f.size > TREND_FREE_LINE:
        lowest = float(f[TREND_FREE_LINE - 1])
        return frf.detrended(), lowest, (f"each record's straight line (offset, drift) removed, drawn from "
                                         f"{TREND_FREE_LINE} cycles per record ({lowest:.3g} Hz) up")
    lowest = frf.determined_from(names)
    return frf, lowest, (f"drawn from {lowest:.3g} Hz: below it the records' offset and drift make more "
                         f"than {100 * TREND_SHARE:.0f} % of |H|")


def _phase_degrees(h: np.ndarray, centre: float) -> np.ndarray:
    """The phase in degrees within ±180° of ``centre``: a phase sitting near ±180° (a mass line) is
    then one line, not a band of jumps between the two."""
    return (np.degrees(np.angle(h)) - centre + 180.0) % 360.0 - 180.0 + centre


def _unjoined_wraps(f: np.ndarray, degrees: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``f`` and ``degrees`` with a gap (NaN) where the phase wraps by a turn between two lines: a
    phase at the edge of the axis is then drawn at one edge or the other, not as a spike across."""
    wraps = np.flatnonzero(np.abs(np.diff(degrees)) > 180.0) + 1
    return (np.insert(np.asarray(f, float), wraps, np.nan), np.insert(np.asarray(degrees, float), wraps, np.nan))


def _phase_centre(h: np.ndarray) -> float:
    """Where the phase sits: the direction of the mean unit phasor, rounded to 90°."""
    mean = np.mean(h / np.maximum(np.abs(h), 1e-300))
    return 90.0 * np.round(np.degrees(np.angle(mean)) / 90.0) if abs(mean) > 0 else 0.0


def _shade_runs(ax, f: np.ndarray, mask: np.ndarray) -> None:
    """Shade each run of lines where ``mask`` holds (from the line before to the line after)."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    for a, b in zip(edges[::2], edges[1::2]):
        ax.axvspan(f[max(a - 1, 0)], f[min(b, len(f) - 1)], color="0.85", lw=0, zorder=0)


def mac_figure(mac_matrix: np.ndarray, path: str | Path, *, labels_a: Sequence[str] | None = None,
               labels_b: Sequence[str] | None = None, title: str = "MAC", xlabel: str = "", ylabel: str = "",
               dpi: int = 130):
    """The MAC matrix as a grey-scale grid (0 white, 1 black) with each value written in its cell;
    rows are ``labels_a`` (``ylabel``), columns ``labels_b`` (``xlabel``)."""
    m = np.asarray(mac_matrix, dtype=float)
    if m.ndim != 2 or m.size == 0:
        raise DimensionError(f"MAC figure: the matrix has shape {m.shape}; expected modes x modes")
    la = list(labels_a) if labels_a is not None else [str(k + 1) for k in range(m.shape[0])]
    lb = list(labels_b) if labels_b is not None else [str(k + 1) for k in range(m.shape[1])]
    if len(la) != m.shape[0] or len(lb) != m.shape[1]:
        raise DimensionError(f"MAC figure: {len(la)} x {len(lb)} labels for a {m.shape[0]} x {m.shape[1]} matrix")
    path = Path(path)
    width = max(4.0, 1.6 + 0.7 * m.shape[1])
    fig = _new_figure(path, (width, 1.2 + 0.6 * m.shape[0]))
    ax = fig.add_subplot()
    im = ax.imshow(m, cmap="Greys", vmin=0, vmax=1)
    for i in range(m.shape[0]):
        for j in range(m.shape[1]):
            ax.text(j, i, f"{m[i, j]:.2f}", ha="center", va="center", fontsize=8,
                    color="white" if m[i, j] > 0.5 else "black")
    ax.set_xticks(range(m.shape[1]), lb, rotation=45, ha="right")
    ax.set_yticks(range(m.shape[0]), la)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    fig.colorbar(im, ax=ax, shrink=0.8, label="MAC [–]")
    ax.set_title(textwrap.fill(title, int(7 * width)), fontsize=10)  # about 7 characters per inch at 10 pt
    return _save(fig, path, dpi)
