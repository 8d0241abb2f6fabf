"""Modal and operating analysis: frf, modes, ods."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from odsuite.domain.display import fixed, rms_label, unit_text
from odsuite.domain.errors import ConfigError
from odsuite.cli.app import _check_output, _figure_renderer, _print_json, _rendered_doc, app, console, err_console, shown


@app.command("frf")
def frf_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    experiment: str = typer.Option(..., "--experiment", help="Experiment name."),
    estimator: str = typer.Option("H1", "--estimator", help="H1, H2 or Hv."),
    figure: Path = typer.Option(None, "--figure", help="Write magnitude, phase and coherence (.png, .svg, .pdf)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """FRFs over the accepted hammer hits of an experiment (stored as derived 'frf'); a record whose
    every hit is flagged uses them all, with a note, as modes and compare do."""
    from odsuite.domain.errors import ConfigError, DimensionError
    from odsuite.analysis.frf import usable_band
    from odsuite.analysis.hammer import hit_name
    from odsuite.analysis.modal_project import all_flagged, experiment_frf, flagged_note, hit_notes, unrecorded_notes
    from odsuite.contracts.renderers import RenderRequest

    renderer = _figure_renderer("frf", figure, project, "--figure") if figure is not None else None
    frf, hits = experiment_frf(project, experiment, estimator=estimator, flagged_too=True)
    flagged = all_flagged(hits)
    for note in (hit_notes(hits, frf) + ([flagged_note(flagged, "FRFs are estimated")] if flagged else [])
                 + list(unrecorded_notes(project, {experiment: frf}).values())):
        err_console.print(f"note: {project}: experiment {experiment!r}: {note}", highlight=False, soft_wrap=True)
    for h in hits if not as_json else ():
        state = "accepted" if h.accepted else "rejected: " + ", ".join(h.reasons)
        console.print(f"{hit_name(h.time)} ({h.peak_force:.4g} N): {state}", highlight=False)
    try:
        band = usable_band(frf.frequency, frf.force_autospectrum, frf.coherence, frf.n_averages)
        usable = f"usable band {band[0]:.1f}-{band[1]:.1f} Hz"
    except (ConfigError, DimensionError) as exc:  # the FRFs are stored all the same: say why no band, do not fail
        band, usable = None, str(exc).split(";")[0]
    if renderer is not None:
        renderer.render(RenderRequest(project, experiment, figure, {"frf": frf, "band_hz": band,
                                                                    "title": f"FRFs of {experiment}"}))
    if as_json:
        _print_json({"experiment": experiment, "estimator": estimator, "channels": list(frf.output_names),
                     "n_averages": frf.n_averages, "lines": int(frf.frequency.size),
                     "resolution_hz": float(frf.frequency[1] - frf.frequency[0]) if frf.frequency.size > 1 else None,
                     "usable_band_hz": None if band is None else [float(band[0]), float(band[1])],
                     "usable_band_note": None if band is not None else usable,
                     "hits": [{"sample": int(h.peak_index), "time_s": float(h.time), "peak_force_n": float(h.peak_force),
                               "accepted": bool(h.accepted), "reasons": list(h.reasons),
                               "double_hit_after_s": h.double_hit_after} for h in hits],
                     "flagged_hits": {experiment: flagged} if flagged else {},
                     "figure": None if figure is None else str(figure)})
        return
    averaged = "1 hit" if frf.n_averages == 1 else f"{frf.n_averages} hits averaged"
    channels = "1 channel" if len(frf.output_names) == 1 else f"{len(frf.output_names)} channels"
    console.print(f"{estimator} FRFs of {channels}, {averaged}, "
                  f"{frf.frequency.size} lines, {usable}", highlight=False)
    if figure is not None:
        console.print(f"wrote {figure}", highlight=False, soft_wrap=True)


@app.command("modes")
def modes_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    experiments: list[str] = typer.Option(..., "--experiment", help="Experiment name; give it several times for "
                                          "an FRF matrix across experiments (roving hammer, several references)."),
    f_min: float = typer.Option(None, "--fmin", help="Lowest frequency of the fit band (Hz)."),
    f_max: float = typer.Option(None, "--fmax", help="Highest frequency of the fit band (Hz)."),
    max_order: int = typer.Option(None, "--max-order", help="Highest model order (LSCF, default 50; SSI-cov state "
                                  "size with --output-only, default 40 as in render and report)."),
    at: str = typer.Option(None, "--at", help="Pick poles nearest these frequencies: f1,f2,... (Hz)."),
    figure: Path = typer.Option(None, "--figure", help="Write the stabilisation diagram (.png, .svg, .pdf)."),
    mac_figure: Path = typer.Option(None, "--mac-figure", help="Write the modes' MAC matrix (AutoMAC; .png, .svg, .pdf)."),
    output_only: bool = typer.Option(False, "--output-only", help="From the responses alone (SSI-cov, checked by EFDD): operating data, no force."),
    block_rows: int = typer.Option(None, "--block-rows", help="--output-only: SSI-cov block rows (lags 1..2i-1; default: "
                                   "5 periods of the record's lowest spectral peak)."),
    decimate: int = typer.Option(None, "--decimate", help="--output-only: decimation factor (default: to 2.5 x the band's top)."),
    reference: str = typer.Option(None, "--reference", help="--output-only with several experiments (setups of a "
                                  "roving survey): the reference channels ch,ch,... (default: the channels every setup has)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """Natural frequencies, damping ratios and mode shapes identified from measured FRFs (default
    band: where the hammer's force spectrum and the coherence are usable), of one experiment or of
    the FRF matrix of several, or with --output-only from the responses alone (several experiments:
    the setups of a roving survey, merged through their reference channels)."""
    from odsuite.analysis.modal_project import (all_flagged, experiment_modes, experiment_output_only_modes,
                                                experiments_modes, flagged_note, hit_notes, unrecorded_notes)
    from odsuite.contracts.renderers import RenderRequest

    freqs = _modes_options(at, f_min, f_max, reference, output_only, len(experiments), block_rows, decimate, figure,
                           max_order)
    band = None if f_min is None and f_max is None else (f_min, f_max)
    if max_order is None:  # output-only: the library's default, so render and report find the same modes
        from odsuite.analysis.oma import MAX_ORDER

        max_order = MAX_ORDER if output_only else 50
    drawers = {name: _figure_renderer(name, path, project, option)
               for name, path, option in (("stabilisation", figure, "--figure"), ("mac", mac_figure, "--mac-figure"))
               if path is not None}
    references = None
    hits = {}  # per experiment, for the FRF fits: those whose every hit is flagged are named
    frfs = {}  # per experiment, for the FRF fits: the channels they leave out are named
    name = ", ".join(experiments)
    if output_only:
        if len(experiments) > 1:
            _merged_modes(project, experiments, reference, band, max_order, block_rows, decimate, drawers,
                          mac_figure, as_json)
            return
        res, freq, spectrum, unit = experiment_output_only_modes(project, experiments[0], f_band=band,
                                                                 max_order=max_order, block_rows=block_rows,
                                                                 decimation=decimate)
        background = f"rms amplitude spectral density of the outputs [{unit_text(unit)}]"
    elif len(experiments) > 1:
        res, freq, spectrum, references, hits, frfs = experiments_modes(
            project, experiments, f_band=band, max_order=max_order, frequencies=freqs, flagged_too=True)
        background = rms_label("|H| of the FRF matrix", [u for f in frfs.values() for u in f.units])
    else:
        # a record whose every hit is flagged still has modes to show, as compare shows them: named below
        res, frf, hits[experiments[0]] = experiment_modes(project, experiments[0], f_band=band, max_order=max_order,
                                                          frequencies=freqs, flagged_too=True)
        frfs[experiments[0]] = frf
        freq, spectrum, background = frf.frequency, frf.H, rms_label("|H| of the outputs", frf.units)
    flagged = {e: f for e, h in hits.items() if (f := all_flagged(h))}
    unrecorded = unrecorded_notes(project, frfs)
    for e, h in hits.items():
        for note in hit_notes(h, frfs[e]) + ([flagged_note(flagged[e])] if e in flagged else []) + (
                [unrecorded[e]] if e in unrecorded else []):
            err_console.print(f"note: {project}: experiment {e!r}: {note}", highlight=False, soft_wrap=True)
    if figure is not None:
        drawers["stabilisation"].render(RenderRequest(project, name, figure, {
            "modes": res, "freq": freq, "H": spectrum, "title": f"stabilisation diagram of {name}",
            "background": background}))
    if mac_figure is not None:
        from odsuite.analysis.modal import frequency_labels, mac

        labels = frequency_labels(res.frequency_hz)
        drawers["mac"].render(RenderRequest(project, name, mac_figure, {
            "mac": mac(res.shapes, res.shapes), "labels_a": labels, "labels_b": labels,
            "title": f"AutoMAC of the modes of {name}"}))
    for note in res.rejected:
        err_console.print(f"note: stable pole not taken as a mode: {note}", highlight=False, soft_wrap=True)
    if as_json:
        doc = res.to_dict()
        if references is not None:
            doc["references"] = references
        if not output_only:
            doc["flagged_hits"] = flagged
        _print_json(doc)  # NaN and inf as null, as every --json
        return
    _print_modes(res, name)
    for path in (figure, mac_figure):
        if path is not None:
            console.print(f"wrote {path}", highlight=False, soft_wrap=True)


def _modes_options(at, f_min, f_max, reference, output_only, n_experiments, block_rows, decimate, figure, max_order=None):
    """The modes command's options checked before anything is computed; returns --at's frequencies (Hz)."""
    from odsuite.domain.errors import ConfigError
    from odsuite.domain.textfiles import plain_number

    try:
        freqs = [plain_number(v) for v in at.split(",")] if at is not None else None  # "" is no frequency
    except ValueError:
        raise ConfigError(f"--at {at!r}: expected comma-separated frequencies in Hz") from None
    if freqs is not None and not all(math.isfinite(f) and f > 0 for f in freqs):  # nan, -inf: a traceback in the fit
        raise ConfigError(f"--at {at!r}: frequencies must be finite and > 0 Hz")
    for option, value in (("--fmin", f_min), ("--fmax", f_max)):
        if value is not None and not (math.isfinite(value) and value >= 0):  # before the FRF is stored
            raise ConfigError(f"{option}: must be a finite frequency >= 0 Hz, got {value}")
    # orders below 2 and a decimation below 1 left the fits looping or indexing nothing
    if max_order is not None and max_order < 2:
        raise ConfigError(f"--max-order: a model order of at least 2, got {max_order}")
    if decimate is not None and decimate < 1:
        raise ConfigError(f"--decimate: a factor of at least 1, got {decimate}")
    if reference is not None and not (output_only and n_experiments > 1):
        raise ConfigError("--reference names the reference channels of several --output-only setups: give "
                          "--output-only and more than one --experiment")
    if not output_only and (block_rows is not None or decimate is not None):
        raise ConfigError("--block-rows and --decimate set up the output-only analysis: give --output-only too")
    if output_only and freqs is not None:
        raise ConfigError("--at picks poles of the FRF fit; it does not combine with --output-only")
    if output_only and n_experiments > 1 and figure is not None:
        raise ConfigError("--figure: a stabilisation diagram is per record; merged setups have none "
                          "(run each setup alone for its diagram)")
    return freqs


#: standard errors apart beyond which SSI-cov's and EFDD's damping of one mode are said to disagree
DAMPING_APART = 3.0


def _print_modes(res, name: str) -> None:
    """The identified modes as tables: SSI or LSCF modes, and the EFDD cross-check of output-only ones."""
    from rich.table import Table

    from odsuite.analysis.modal import fdd_doc, mpc

    lo, hi = res.band_hz
    if res.settings is not None:
        console.print(f"output-only analysis: {res.settings.describe()}", highlight=False, soft_wrap=True)
    table = Table(title=f"modes of {shown(name)} ({lo:.1f}-{hi:.1f} Hz)")
    scatter = res.frequency_std_hz is not None  # output-only: standard errors from the record's segments
    for col in ("mode", "f (Hz)", "damping ratio", "stable orders") + (("± f (Hz)", "± damping") if scatter else ()) \
            + ("MPC",):
        table.add_column(col)
    digits = _frequency_digits(res.frequency_hz)
    of_orders = f" of {len(res.diagram.orders)}" if res.diagram is not None else ""
    for k, (f, z) in enumerate(zip(res.frequency_hz, res.damping_ratio), start=1):
        extra = (f"{res.frequency_std_hz[k - 1]:.2g}", f"{res.damping_std[k - 1]:.2g}") if scatter else ()
        table.add_row(str(k), f"{f:.{digits}f}", fixed(z, 5), f"{res.stable_orders[k - 1]}{of_orders}", *extra,
                      f"{mpc(res.shapes[:, k - 1]):.3f}")
    console.print(table)
    if res.fdd is not None:
        fdd = fdd_doc(res, res.output_names)
        ft = Table(title=f"EFDD cross-check ({fdd['resolution_hz']:.4g} Hz lines)")
        for col in ("f (Hz)", "damping ratio", "± f (Hz)", "± damping", "MPC", "SSI mode", "Δf", "MAC"):
            ft.add_column(col)
        for m in fdd["modes"]:
            std = ["-" if v is None else f"{v:.2g}" for v in (m["frequency_std_hz"], m["damping_std"])]
            paired = m["ssi_mode"] is not None
            ft.add_row(f"{m['frequency_hz']:.{digits}f}", fixed(m["damping_ratio"], 5), *std, f"{m['mpc']:.3f}",
                       str(m["ssi_mode"] + 1) if paired else "-",
                       f"{100 * m['frequency_difference']:+.2f} %" if paired else "-",
                       f"{m['mac_ssi']:.3f}" if paired else "-")
        console.print(ft)
        for m in fdd["modes"]:
            if m["damping_apart"] is not None and m["damping_apart"] > DAMPING_APART:
                k = m["ssi_mode"]
                err_console.print(
                    f"note: mode {k + 1} ({res.frequency_hz[k]:.{digits}f} Hz): SSI-cov's damping ratio "
                    f"{res.damping_ratio[k]:.3g} and EFDD's {m['damping_ratio']:.3g} lie {m['damping_apart']:.0f} times "
                    "their standard errors apart, which measure the scatter between the record's segments, not "
                    "either method's bias: read its damping as uncertain within that range",
                    highlight=False, soft_wrap=True)
    for u in res.unresolved:
        err_console.print(f"note: the pole at {u.frequency_hz:.{digits}f} Hz (damping ratio {u.damping_ratio:.3f}) is not "
                          f"reported as a mode: {u.reason}", highlight=False, soft_wrap=True)


def _merged_modes(project, experiments, reference, band, max_order, block_rows, decimate, drawers, mac_figure,
                  as_json) -> None:
    """modes --output-only over several setups: each identified alone, merged by PoSER."""
    from rich.table import Table

    from odsuite.analysis.modal import frequency_labels, mac, mpc
    from odsuite.analysis.multisetup import project_setups_modes
    from odsuite.contracts.renderers import RenderRequest

    refs = None if reference is None else [c.strip() for c in reference.split(",") if c.strip()]
    res = project_setups_modes(project, experiments, references=refs, f_band=band, max_order=max_order,
                               block_rows=block_rows, decimation=decimate)
    name = ", ".join(experiments)
    if mac_figure is not None:
        labels = frequency_labels(res.frequency_hz)
        drawers["mac"].render(RenderRequest(project, experiments[0], mac_figure, {
            "mac": mac(res.shapes, res.shapes), "labels_a": labels, "labels_b": labels,
            "title": f"AutoMAC of the merged modes of {name}"}))
    for note in res.unpaired:
        err_console.print(f"note: not merged: {note}", highlight=False, soft_wrap=True)
    if as_json:
        _print_json(res.to_dict())
        return
    console.print(f"{len(experiments)} setups merged through reference channels {', '.join(res.references)} "
                  f"(PoSER); shapes over {len(res.channels)} channels", highlight=False, soft_wrap=True)
    table = Table(title=f"merged modes of {shown(name)}")
    for col in ("mode", "f (Hz)", "spread f (Hz)", "damping ratio", "spread damping", "MPC", "reference MAC (min)",
                *[f"f {shown(e)} (Hz)" for e in experiments]):
        table.add_column(col)
    digits = _frequency_digits(res.frequency_hz)
    for k, (f, z) in enumerate(zip(res.frequency_hz, res.damping_ratio)):
        per = res.per_setup[k]
        table.add_row(str(k + 1), f"{f:.{digits}f}", f"{res.frequency_spread_hz[k]:.2g}", fixed(z, 5),
                      f"{res.damping_spread[k]:.2g}", f"{mpc(res.shapes[:, k]):.3f}",
                      f"{min(v[2] for v in per.values()):.3f}", *[f"{per[e][0]:.{digits}f}" for e in experiments])
    console.print(table)
    if mac_figure is not None:
        console.print(f"wrote {mac_figure}", highlight=False, soft_wrap=True)


def _frequency_digits(freqs) -> int:
    """Decimals of the frequency labels (four significant digits of the lowest, every frequency
    told apart), at least 2."""
    from odsuite.analysis.modal import frequency_labels

    return max(2, len(frequency_labels(freqs)[0].split()[0].split(".")[1]) if len(freqs) else 2)


@app.command("ods")
def ods_cmd(
    project: Path = typer.Argument(..., help="Project file."),
    experiment: str = typer.Argument(..., help="Experiment name (an operating record, or any record)."),
    reference: str = typer.Option(..., "--reference", help="Reference sensor: phases are relative to it."),
    at: float = typer.Option(..., "--at", help="Frequency of the shape, Hz (the nearest spectral line is used)."),
    movie: Path = typer.Option(None, "--movie", help="Also animate the shape on the rig (.mp4, .gif)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
) -> None:
    """Operating deflection shape: every response's cross-spectrum to the reference sensor, scaled by
    the reference's autospectrum (rms amplitude and phase per sensor), and on a rig the bodies'
    generalized coordinates."""
    from rich.table import Table

    import numpy as np

    from odsuite.analysis.ods import operating_shape
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project
    from odsuite.contracts.renderers import RenderRequest, choose_renderer
    from odsuite.domain.rigidbody import COORDINATE_UNITS, COORDINATES

    if not math.isfinite(at) or at <= 0:
        raise ConfigError(f"--at: must be a finite frequency > 0 Hz, got {at}")
    renderer = None
    if movie is not None:
        _check_output(movie, project, "--movie")
        renderer = choose_renderer(registries().renderers, movie, None, "movie")
    with open_project(project) as p:
        if experiment not in p.experiment_names():
            raise ConfigError(f"{project}: no experiment {experiment!r} "
                              f"(experiments: {', '.join(p.experiment_names()) or 'none'})")
        res = operating_shape(p, experiment, reference, at)
    rendered = None
    if renderer is not None:
        rendered = renderer.render(RenderRequest(project, experiment, movie, {"ods_hz": at, "reference": reference},
                                                 progress=err_console.is_terminal and not as_json))
    if as_json:
        doc = res.to_dict()
        doc["notes"] = list(res.notes)
        if rendered is not None:
            doc["movie"] = _rendered_doc(renderer, rendered)
        _print_json(doc)
        return
    for note in res.notes:
        err_console.print(f"note: {note}", highlight=False, soft_wrap=True)
    console.print(f"{shown(experiment)}: operating deflection shape at {res.frequency_hz:.3f} Hz (line nearest "
                  f"{res.requested_hz:g} Hz; {res.resolution_hz:.3g} Hz lines, {res.n_segments} segment"
                  f"{'s' if res.n_segments != 1 else ''}), "
                  f"phases relative to {shown(reference)}", highlight=False, soft_wrap=True)
    table = Table(box=None)
    for col in ("sensor", "amplitude (rms)", "phase (°)", "coherence"):
        table.add_column(col)
    for name, v in res.shape.items():
        table.add_row(shown(name), f"{abs(v):.4g} {unit_text(res.units[name])}", f"{np.degrees(np.angle(v)):+.1f}",
                      f"{res.coherence[name]:.3f}")
    console.print(table)
    for body, d in res.coordinates.items():
        parts = [f"{c} {_small(abs(v), u)} ∠{np.degrees(np.angle(v)):+.0f}°"
                 for c, v, u in zip(COORDINATES, d, COORDINATE_UNITS)]
        console.print(f"{shown(body)} at G (rms displacement): " + ", ".join(parts), highlight=False, soft_wrap=True)
    if rendered is not None:
        console.print(f"wrote {rendered.path} ({rendered.summary})", highlight=False, soft_wrap=True)


def _small(value: float, unit: str) -> str:
    """A small amplitude as an engineer writes it: 36 nm, 4.41 µrad, 1.2 mm (not 3.6e-08 m)."""
    for factor, prefix in ((1.0, ""), (1e-3, "m"), (1e-6, "µ")):
        if value >= factor:
            return f"{value / factor:.3g} {prefix}{unit}"
    return f"{value / 1e-9:.3g} n{unit}"

