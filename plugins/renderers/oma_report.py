"""The report of a project without a rig: operating (ambient) records of a structure, analysed from
their responses alone, and hammer records, analysed from their FRFs. The records (channels, rate,
length, units), the singular values of each operating record's PSD matrix with the EFDD peaks, the
SSI-cov stabilisation diagram, the table of modes (SSI-cov against EFDD), the modes merged over
setups that share reference channels; each hammer record's FRFs, stabilisation diagram and modes;
and the modes moving on the structure's geometry in the interactive 3-D view (``mode_view``).

Every number comes from ``odsuite modes --output-only`` (``experiment_output_only_modes``), for
several setups from the same merging as ``odsuite modes`` with several experiments, and for a
hammer record from its FRFs as ``odsuite modes --experiment NAME`` fits them: the page shows the
modes those commands print.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from odsuite.api import ConfigError, unit_text

from .report import FIGURE_DPI, PRINT_WIDTH_IN, _draw, _esc, _fmt, _img, _table

#: singular values drawn per line (the first carries the modes; the next show close or repeated ones)
SINGULAR_VALUES = 3

LEFT_OUT = ("Comparison with a model, the diagnosis of candidate effects, the error across model revisions "
            "and the movie with the model need a rig with its model and hammer records; this project has no "
            "rig, so they are left out.")
#: what the records section calls each kind of record
OPERATING, HAMMER = "operating (no force)", "hammer (force channel): modes from its FRFs"


def _unit(unit: str | None) -> str:
    return unit_text(unit) if unit else "–"


def _records(project) -> list[str]:
    """The operating records: experiments without a force channel (a hammer record's modes come from
    its FRFs: ``odsuite modes --experiment NAME``)."""
    return [n for n in project.experiment_names() if project.experiment(n).excitation is None]


def _hammer_records(project) -> list[str]:
    """The hammer records: experiments with a force channel."""
    return [n for n in project.experiment_names() if project.experiment(n).excitation is not None]


def _records_section(project, names: list[str], geometry) -> str:
    from odsuite.api import physical, response_columns

    info = project.info()["experiments"]
    placed = {} if geometry is None else {s.channel: s for s in geometry.sensors}
    rows, chans = [], []
    for n in project.experiment_names():
        exp, d = project.experiment(n), info[n]
        outs = response_columns(exp)
        units = sorted({_unit(exp.systeminfo.channels[k].unit) for k in outs})
        kind = OPERATING if n in names else HAMMER
        rows.append([n, kind, d.get("source") or "–", len(outs), f"{exp.sampling_rate:g}", d["n_samples"],
                     f"{d['n_samples'] / exp.sampling_rate:.1f}", ", ".join(units)])
        data = physical(exp)
        for k in outs:
            name, x = exp.channel_names[k], data[:, k]
            unit = _unit(exp.systeminfo.channels[k].unit)
            s = placed.get(name)
            where = "–" if s is None else (f"node {s.node}, direction ("
                                          + ", ".join(f"{v:+.2f}" for v in s.direction) + ")")
            chans.append([n, name, unit, f"{np.std(x):.4g} {unit}", f"{np.max(np.abs(x)):.4g} {unit}", where])
    return (_table(["record", "kind", "source", "channels", "rate [Hz]", "samples", "length [s]", "units"], rows,
                   id="records")
            + _table(["record", "channel", "unit", "rms", "peak", "on the geometry"], chans, id="record-channels",
                     caption="each response channel: rms and peak over the record (mean removed in rms), "
                             "and where the geometry places it"))


def _singular_values_figure(project, name: str, res, path: Path) -> str:
    """The singular values of the PSD matrix of the record as both estimators saw it (high-passed
    and decimated as ``res.settings`` say; EFDD's line spacing), the EFDD peaks marked and the
    SSI-cov modes dashed."""
    from matplotlib.figure import Figure

    from odsuite.api import physical, prepare_output_only, response_columns, spectral_matrix

    exp = project.experiment(name)
    outs = response_columns(exp)
    st, fd = res.settings, res.fdd
    y = prepare_output_only(physical(exp)[:, outs], exp.sampling_rate, st)
    nperseg = int(round(st.rate_hz / fd.resolution_hz)) if fd is not None else min(1024, y.shape[0])
    freq, G = spectral_matrix(y, st.rate_hz, nperseg)
    sv = np.linalg.eigvalsh(G)[:, ::-1][:, :SINGULAR_VALUES]  # G is Hermitian: its eigenvalues are its SVs
    units = {exp.systeminfo.channels[k].unit for k in outs}
    unit = units.pop() if len(units) == 1 else "unit"
    lo, hi = st.band_hz
    keep = (freq >= max(lo, st.highpass_hz or 0.0)) & (freq <= hi) & (freq > 0)
    fig = Figure(figsize=(PRINT_WIDTH_IN * 1.5, 4.2), layout="constrained")
    ax = fig.add_subplot()
    tiny = np.finfo(float).tiny
    for j in range(sv.shape[1]):
        ax.plot(freq[keep], 10 * np.log10(np.maximum(sv[keep, j], tiny)), lw=1.0 if j == 0 else 0.7,
                color=("tab:blue", "tab:orange", "0.55")[j % 3], label=f"singular value {j + 1}")
    for k, f in enumerate(res.frequency_hz):
        ax.axvline(f, color="k", lw=0.7, ls="--", label="SSI-cov mode" if k == 0 else None)
    if fd is not None and fd.frequency_hz.size:
        level = np.interp(fd.frequency_hz, freq, 10 * np.log10(np.maximum(sv[:, 0], tiny)))
        ax.plot(fd.frequency_hz, level, "v", color="tab:red", ms=7, label="EFDD peak")
        for k, (f, v) in enumerate(zip(fd.frequency_hz, level)):
            ax.annotate(f"{f:.3f} Hz", (f, v), xytext=(0, 9 + 10 * (k % 2)), textcoords="offset points", ha="center",
                        fontsize=7, color="tab:red")
    ax.set_xlim(freq[keep][0] if keep.any() else lo, hi)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel(f"dB re 1 ({unit_text(unit)})²/Hz")
    ax.set_title(f"{name}: singular values of the PSD matrix ({len(outs)} channels)", fontsize=10)
    ax.grid(True, color="0.9")
    # channels that see the same motion leave singular values at round-off: draw 50 dB below the first
    first = 10 * np.log10(np.maximum(sv[keep, 0], tiny)) if keep.any() else np.zeros(1)
    ax.set_ylim(float(first.min()) - 50, float(first.max()) + 10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.savefig(path, dpi=FIGURE_DPI)
    spacing = f"{fd.resolution_hz:.4g} Hz lines" if fd is not None else "no EFDD (record too short)"
    return _img(path, f"{name}: singular values of the cross-spectral (PSD) matrix, Welch with Hann windows, "
                f"{spacing}, of the record {st.describe()}; red: the peaks EFDD took as modes, dashed: SSI-cov modes")


def _modes_table(name: str, res) -> str:
    from odsuite.api import fdd_doc, mpc, mpd

    fdd = fdd_doc(res, res.output_names)["modes"] if res.fdd is not None else []
    by_ssi = {m["ssi_mode"]: m for m in fdd if m["ssi_mode"] is not None}
    rows = []
    for k, (f, z) in enumerate(zip(res.frequency_hz, res.damping_ratio)):
        phi, e = res.shapes[:, k], by_ssi.get(k)
        rows.append([k + 1, f"{f:.4f}", _fmt(res.frequency_std_hz[k], ".2g"), f"{100 * z:.2f}",
                     _fmt(100 * res.damping_std[k], ".2g"), f"{mpc(phi):.3f}", f"{mpd(phi):.1f}",
                     int(res.stable_orders[k]),
                     "–" if e is None else f"{e['frequency_hz']:.4f}",
                     "–" if e is None else f"{100 * e['damping_ratio']:.2f}",
                     "–" if e is None else f"{100 * e['frequency_difference']:+.2f} %",
                     "–" if e is None else f"{e['mac_ssi']:.3f}"])
    table = _table(["mode", "f [Hz]", "± f [Hz]", "damping [%]", "± damping [%]", "MPC", "MPD [°]", "stable orders",
                    "EFDD f [Hz]", "EFDD damping [%]", "Δf EFDD", "MAC SSI–EFDD"], rows, id=f"modes-{name}",
                   caption=f"{name}: SSI-cov modes (± standard errors from 4 segments of the record), and the EFDD "
                           "mode paired with each (within 5 %, best MAC); – where EFDD has none")
    alone = [m for m in fdd if m["ssi_mode"] is None]
    extra = ("<p>EFDD peaks without an SSI-cov mode: "
             + ", ".join(f"{m['frequency_hz']:.3f} Hz (damping {100 * m['damping_ratio']:.2f} %, MPC {m['mpc']:.3f})"
                         for m in alone) + ".</p>") if alone else ""
    unres = ("<p>Stable poles not reported as modes: "
             + "; ".join(f"{u.frequency_hz:.3f} Hz: {_esc(u.reason)}" for u in res.unresolved) + ".</p>"
             if res.unresolved else "")
    return table + extra + unres


def _hammer_section(project, name: str, tag: int, tmp: Path, notes: list[str]) -> tuple[object | None, str]:
    """One hammer record: its FRFs over every response channel, its stabilisation diagram, its modes
    (as ``odsuite modes --experiment NAME`` prints them) and their AutoMAC; the modes (None where
    they could not be identified) and the HTML."""
    from odsuite.api import RecordModes, identified_record, mac, mpc

    from .report import _stabilisation_html

    frf, res, said = identified_record(project, name)
    notes += said
    html = "".join(f"<p class='notes'>{_esc(n)}</p>" for n in said)
    if frf is None:
        return None, html
    band = res.band_hz if res is not None else None
    outputs = list(frf.output_names)
    _draw(project, "frf", name, tmp / f"ema-frf-{tag}.png", frf=frf, f_range=band, band_hz=band, outputs=outputs,
          title=f"record {name}", size=(PRINT_WIDTH_IN, 5.2), dpi=FIGURE_DPI)
    html += _img(tmp / f"ema-frf-{tag}.png", f"{name}: FRF of each response channel to the hammer force (magnitude "
                 "on log-log axes, phase where the coherence is good, coherence)"
                 + (f" over the band the modes are fitted in, {band[0]:.0f}-{band[1]:.0f} Hz" if band else ""))
    if res is None:
        return None, html
    measured = np.asarray(res.frequency_hz, dtype=float)
    html += _stabilisation_html(project, RecordModes(name, frf, band, measured, np.empty(0), None, res), f"ema-{tag}",
                                tmp)
    rows = [[k + 1, f"{f:.2f}", f"{100 * z:.3f}", int(res.stable_orders[k]), f"{mpc(res.shapes[:, k]):.3f}"]
            for k, (f, z) in enumerate(zip(res.frequency_hz, res.damping_ratio))]
    html += _table(["mode", "f [Hz]", "damping [%]", "stable orders", "MPC"], rows, id=f"ema-modes-{name}",
                   caption=f"{name}: modes identified from the hammer FRFs (LSCF, stable poles checked by FRF "
                           "synthesis, as odsuite modes does)", empty=f"{name}: no mode identified in the band.")
    if res.rejected:
        html += "<p>Stable poles not taken as modes: " + "; ".join(_esc(r) for r in res.rejected) + ".</p>"
    if len(outputs) > 1 and measured.size > 1:
        labels = [f"{f:.1f} Hz" for f in measured]
        _draw(project, "mac", name, tmp / f"ema-mac-{tag}.png", mac=mac(res.shapes, res.shapes), labels_a=labels,
              labels_b=labels, title=f"{name}: AutoMAC of the modes", dpi=FIGURE_DPI)
        html += _img(tmp / f"ema-mac-{tag}.png", f"{name}: MAC of every mode's shape at the response channels with "
                     "every other's (near 0 off the diagonal: distinct modes)")
    return res, html


def _merged(project, results: dict) -> tuple[object | None, str]:
    """The setups merged through the channels they share, as ``odsuite modes`` with several
    experiments does, or None with the sentence saying why not."""
    from odsuite.api import check_references, merge_setups

    if len(results) < 2:
        return None, "<p>One record: no setups to merge.</p>"
    names = list(results)
    try:
        refs = check_references([(n, list(results[n].output_names)) for n in names], None, str(project.path))
        return merge_setups([results[n] for n in names], names, refs, str(project.path)), ""
    except ConfigError as exc:
        return None, f"<p>The records are not merged as setups of one survey: {_esc(exc)}.</p>"


def _merged_section(merged) -> str:
    from odsuite.api import mpc

    rows = [[k + 1, f"{f:.4f}", _fmt(merged.frequency_spread_hz[k], ".2g"), f"{100 * z:.2f}",
             _fmt(100 * merged.damping_spread[k], ".2g"), f"{mpc(merged.shapes[:, k]):.3f}",
             ", ".join(f"{s} {v[0]:.4f} Hz (ref. MAC {v[2]:.3f})" for s, v in merged.per_setup[k].items())]
            for k, (f, z) in enumerate(zip(merged.frequency_hz, merged.damping_ratio))]
    text = (f"<p>Setups {_esc(', '.join(merged.setups))} share the reference channels "
            f"<b>{_esc(', '.join(merged.references))}</b>: each setup's modes are paired by frequency (3 %) and "
            "reference MAC, and their shapes scaled to the first setup's through the references (PoSER), giving "
            f"shapes over {len(merged.channels)} channels ({_esc(', '.join(merged.channels))}).</p>")
    unpaired = ("<p>Not merged: " + "; ".join(_esc(u) for u in merged.unpaired) + ".</p>") if merged.unpaired else ""
    return text + _table(["mode", "f [Hz]", "spread f [Hz]", "damping [%]", "spread damping [%]", "MPC",
                          "each setup"], rows, id="merged-modes",
                         caption="modes merged over the setups: means over the setups, spread = sample standard "
                                 "deviation over them") + unpaired


def _view_section(geometry, results: dict, merged, hammer: dict) -> str:
    from odsuite.api import mpc

    from .mode_view import geometry_modes, mode_label, mode_view_data, mode_view_html

    if geometry is None:
        return ("<p>No 3-D view: the project has no geometry of nodes and lines; <code>odsuite import P.h5 "
                "FILE.toml --name geometry</code> adds one (docs/geometry.md).</p>")
    sets = [("merged OMA", "setups " + ", ".join(merged.setups), list(merged.channels), merged)] if merged else \
        [("OMA", n, list(r.output_names), r) for n, r in results.items()]
    sets += [("EMA", n, list(r.output_names), r) for n, r in hammer.items() if r.frequency_hz.size]
    placed = set(geometry.channels)
    nodes = lines = fixed = sensors = None
    modes, skipped = [], []
    for kind, label, names, res in sets:
        if not placed.intersection(names):
            skipped.append(label)
            continue
        labels = [mode_label(kind, label, k + 1, f, z, mpc(res.shapes[:, k]))
                  for k, (f, z) in enumerate(zip(res.frequency_hz, res.damping_ratio))]
        nodes, lines, these, fixed, sensors = geometry_modes(geometry, names, res.shapes, labels)
        modes += these
    note = (f"<p>Not on the geometry {_esc(geometry.name)!s} (none of their channels has a sensor there): "
            f"{_esc(', '.join(skipped))}.</p>") if skipped else ""
    if not modes:
        return note or "<p>No mode to show.</p>"
    data = mode_view_data(nodes, lines, modes, fixed=fixed, sensors=sensors)
    return (f"<p>The modes on the geometry <b>{_esc(geometry.name)}</b>: sensors move as measured, the other nodes "
            "follow by the documented rule (rigid groups, then inverse-distance weighting; docs/geometry.md).</p>"
            + note + mode_view_html(data))


def oma_sections(project, tmp: Path, say: Callable[[str], None], notes: list[str]
                 ) -> tuple[list[tuple[str, str, str]], int]:
    """The sections of a rig-less project's report (key, heading, html) and the number of modes
    identified. Refuses a project with no record in one line."""
    from odsuite.api import experiment_output_only_modes, project_geometry

    names, hammer_names = _records(project), _hammer_records(project)
    if not names and not hammer_names:
        raise ConfigError(f"{project.path}: the project has no rig and no record to analyse; "
                          "`odsuite import` adds one (docs/importing.md)")
    geometry = project_geometry(project)
    results, spectra, stab, tables = {}, [], [], []
    for n in names:
        say(f"identifying the modes of {n}")
        try:
            res, freq, spectrum, unit = experiment_output_only_modes(project.path, n)
        except ConfigError as exc:
            notes.append(f"{n}: no modes: {exc}")
            tables.append(f"<h3>{_esc(n)}</h3><p class='notes'>No modes: {_esc(exc)}</p>")
            continue
        results[n] = res
        tag = len(results)
        spectra.append(f"<h3>{_esc(n)}</h3>" + _singular_values_figure(project, n, res, tmp / f"sv-{tag}.png"))
        _draw(project, "stabilisation", n, tmp / f"stab-{tag}.png", modes=res, freq=freq, H=spectrum,
              title=f"SSI-cov of {n}", background=f"rms amplitude spectral density of the outputs [{unit_text(unit)}]")
        stab.append(f"<h3>{_esc(n)}</h3><p>Settings: {_esc(res.settings.describe())} (chosen from the record as "
                    "<code>odsuite modes --output-only</code> does).</p>"
                    + _img(tmp / f"stab-{tag}.png", f"{n}: SSI-cov poles per model order (grey: new, blue: "
                           "frequency stable, red: frequency and damping stable), the modes dashed, the outputs' "
                           "rms spectrum behind"))
        tables.append(f"<h3>{_esc(n)}</h3>" + _modes_table(n, res))
    merged, why = _merged(project, results)
    merged_html = _merged_section(merged) if merged is not None else why
    hammer, hammer_html = {}, []
    for tag, n in enumerate(hammer_names):
        say(f"identifying the modes of {n} from its FRFs")
        res, html = _hammer_section(project, n, tag, tmp, notes)
        hammer_html.append(f"<h3>{_esc(n)}</h3>" + html)
        if res is not None:
            hammer[n] = res
    say("the 3-D view")
    view = _view_section(geometry, results, merged, hammer)
    count = (len(merged.frequency_hz) if merged is not None else sum(len(r.frequency_hz) for r in results.values())) \
        + sum(len(r.frequency_hz) for r in hammer.values())
    listed = "; ".join(f"{n}: " + ", ".join(f"{f:.3f}" for f in r.frequency_hz) + " Hz"
                       for n, r in (results | hammer).items() if r.frequency_hz.size)
    analysed = ([f"{len(names)} operating record(s) analysed from their responses alone (SSI-cov, checked by EFDD)"]
                if names else []) + ([f"{len(hammer_names)} hammer record(s) analysed from their FRFs"]
                                     if hammer_names else [])
    summary = (f"<p>Project <b>{_esc(project.path.name)}</b>: {'; '.join(analysed)}; "
               + (f"geometry <b>{_esc(geometry.name)}</b> ({len(geometry.node_ids)} nodes, "
                  f"{len(geometry.sensors)} sensors)." if geometry is not None else "no geometry.")
               + f"</p><p id='oma-modes'>Modes: {_esc(listed) or 'none identified'}.</p><p>{_esc(LEFT_OUT)}</p>")
    sections = [("summary", "Summary", summary),
                ("records", "Records", _records_section(project, names, geometry))]
    if names:
        sections += [
            ("spectra", "Spectra (FDD)", "".join(spectra) or "<p>No spectra: no record gave modes.</p>"),
            ("stabilisation", "Stabilisation diagram (SSI-cov)", "".join(stab) or "<p>No diagram.</p>"),
            ("modes", "Modes", "".join(tables)),
            ("merged", "Setups merged", merged_html)]
    if hammer_names:
        sections.append(("hammer", "Hammer records: FRFs and modes", "".join(hammer_html)))
    sections.append(("view3d", "Interactive 3-D view of the modes", view))
    return sections, count


def oma_report(project, output: Path, tmp: Path, say: Callable[[str], None], notes: list[str]):
    """Write the page of a rig-less project (``build_report`` routes it here); its ``error`` is NaN:
    there is no model to have one."""
    from odsuite.api import write_output

    from .report import SIZE_BUDGET, ReportResult, _page

    sections, _ = oma_sections(project, tmp, say, notes)
    page = _page(f"odsuite report: {project.path.name}", sections, notes)
    output.parent.mkdir(parents=True, exist_ok=True)
    text = page.encode("utf-8")
    write_output(output, len(text), lambda t: t.write_bytes(text))
    size = output.stat().st_size
    if size > SIZE_BUDGET:
        notes.append(f"the page is {size / 2**20:.1f} MiB (budget {SIZE_BUDGET / 2**20:.0f} MiB)")
    return ReportResult(path=output, size_bytes=size, error=float("nan"), sections=[s[0] for s in sections],
                        notes=notes)
