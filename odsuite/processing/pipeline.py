"""Processing an experiment of a project: every channel's chain, then the coordinate solver of
every moving body, stored as derived data with their provenance."""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from odsuite.processing.chain_spec import (
    build_chain,
    channel_chain_spec,
    channel_unit,
    stage_names,
)
from odsuite.domain import arguments
from odsuite.domain.errors import ConfigError
from odsuite.processing.executor import DEFAULT_CHUNK, run_chains
from odsuite.domain.systeminfo import ChannelInfo

#: Samples of the record the rigidity check reads at most (from the pretrigger on), so that its
#: memory stays bounded on long records.
RIGIDITY_WINDOW = 1 << 20


def _sensor_chain_spec(specs: Sequence[Mapping[str, Any]], ch: ChannelInfo) -> list[dict]:
    """A user chain for one channel: a "convert" step without a sensitivity takes the channel's."""
    out = []
    for s in specs:
        s = dict(s)
        if s.get("step") == "convert" and "sensitivity" not in s:
            s.update(sensitivity=ch.sensitivity, daq_gain=s.get("daq_gain", ch.daq_gain))
        out.append(s)
    return out


def process_experiment(project, name: str, *, chain: Sequence[Mapping[str, Any]] | None = None,
                       progress: Callable[[int, int], None] | None = None,
                       chunk: int = DEFAULT_CHUNK, workers: int | None = None) -> dict[str, Any]:
    """Process one experiment of an open (writable) project and store the results.

    Stores derived kind "processed": "acceleration", "velocity", "displacement" (samples x
    accelerometer channels, SI) and "force" (N, when the experiment has a force channel), with the
    chains in the provenance; then, for every rig body whose sensors determine its motion, derived
    kind "gencoords": "<body>_at_g", "<body>_at_c" where the body has a corner (samples x 6: x y z
    in m, theta phi psi in rad, by the body's coordinate solver on the displacements) and
    "<body>_rigidity" where the solver checks rigidity (the Eq. 4.12 check on the accelerations). ``chain`` replaces the Table E.2 chain of every accelerometer channel by
    an explicit step list (taps "acceleration", "velocity", "displacement" name the outputs).
    ``workers`` threads share the channels (default: one per core; the results do not change).
    Returns a summary (datasets, channels, solver and rigidity per body, notes on bodies whose
    motion cannot be solved).
    """
    from odsuite import __version__
    from odsuite.domain.systeminfo import SensorType

    # before the record is read: a text chunk raised inside, and workers=0 ran on every core
    chunk = arguments.whole("process_experiment", "chunk", chunk, low=1)
    if workers is not None:
        workers = arguments.whole("process_experiment", "workers", workers, low=1)
    if chain is not None:
        chain = arguments.listed("process_experiment", "chain", chain, "steps {'step': NAME, ...}")
        for step in chain:
            if not isinstance(step, Mapping):
                raise ConfigError(f"process_experiment: 'chain' must be a list of steps {{'step': NAME, ...}}, "
                                  f"got an entry {arguments.shown(step)}")
    regs = project.registries
    exp = project.experiment(name)
    si = exp.systeminfo
    where = f"{project.path}: experiment {name!r}"
    si.validate(n_samples=exp.n_samples, source=f"{where} systeminfo")
    n = exp.n_samples
    accel = [k for k, ch in enumerate(si.channels) if ch.sensor_type == SensorType.ACCELEROMETER]
    force_ch = exp.excitation.force_channel if exp.excitation is not None else next(
        (k for k, ch in enumerate(si.channels) if ch.sensor_type == SensorType.LOADCELL), None)
    used = accel + ([force_ch] if force_ch is not None and force_ch not in accel else [])
    if not used:
        raise ConfigError(f"{where}: no accelerometer or load-cell channel to process (Table E.2 row 0)")
    chains, specs = [], {}
    for k in used:
        ch = si.channels[k]
        spec = (_sensor_chain_spec(chain, ch) if chain is not None and k in accel
                else channel_chain_spec(ch))
        chains.append(build_chain(spec, fs=exp.sampling_rate, registry=regs.processing_steps,
                                  where=f"{where} channel {k} ({exp.channel_names[k]})"))
        specs[str(k)] = spec
    names = stage_names("acceleration")
    targets: dict[str, list[tuple[int, str]]] = {}
    units: dict[str, str] = {}
    for stage, tap in enumerate(names):
        if all(tap in chains[i].taps for i in range(len(accel))) and accel:
            targets[tap] = [(i, tap) for i in range(len(accel))]
            found = {channel_unit(si.channels[k], stage) for k in accel}
            if len(found) > 1:
                raise ConfigError(f"{where}: accelerometer channels mix units {sorted(found)} (row 13 micro-units)")
            units[tap] = found.pop()
    if force_ch is not None:
        i = used.index(force_ch)
        tap = stage_names(si.channels[force_ch].quantity)[0]
        if tap not in chains[i].taps:
            raise ConfigError(f"{where}: force channel {force_ch} chain has no {tap!r} tap")
        targets["force"] = [(i, tap)]
        units["force"] = channel_unit(si.channels[force_ch], 0)
    provenance = {"plugin": "filters", "version": __version__, "inputs": [exp.object_id],
                  "parameters": {"chains": specs, "chunk": int(chunk),
                                 "channels": accel, "force_channel": force_ch}}
    summary: dict[str, Any] = {"experiment": name, "datasets": sorted(targets), "channels": accel,
                               "force_channel": force_ch, "bodies": {}, "notes": []}
    cols = [exp.channel_index(k) for k in used]
    with project.transaction():
        with project.derived_writer(name, "processed", provenance=provenance) as w:
            dsets = {}
            for tap in targets:
                shape = (n,) if tap == "force" else (n, len(accel))
                dims = ("sample",) if tap == "force" else ("sample", "channel")
                dsets[tap] = w.create(tap, shape, np.float64, units[tap], dims)

            def write(tap: str, start: int, block: np.ndarray) -> None:
                dsets[tap][start:start + block.shape[0]] = block[:, 0] if tap == "force" else block

            run_chains(chains, n, lambda a, b: exp.raw(a, b)[:, cols], targets, write,
                       chunk=chunk, progress=progress, workers=workers or os.cpu_count() or 1)
            w.attrs.update({"channels": np.asarray(accel, dtype=np.int64),
                            "channel_names": ", ".join(exp.channel_names[k] for k in accel)})
            if project.rig is not None and "displacement" in dsets and "acceleration" in dsets:
                bodies = _gencoords(project, name, exp, dsets, accel, regs, chunk, where, __version__)
                summary["notes"] = bodies.pop("notes")
                summary["bodies"] = bodies
    left_out = project.rig.left_out_note(used, "processing") if project.rig is not None else None
    summary["notes"] += [left_out] if left_out else []
    return summary


def _gencoords(project, name, exp, dsets, accel, regs, chunk, where, version) -> dict[str, Any]:
    """Generalized coordinates of every body whose sensors determine its motion (the rig's solver
    for the body, else the most suitable registered one), chunk by chunk from the stored
    displacements, and the solver's rigidity check (where it has one) on a bounded window of the
    accelerations. Bodies whose motion cannot be solved are named in ``notes``."""
    from odsuite.contracts.solvers import body_solvers

    rig = project.rig
    column = {s.name: accel.index(s.channel) for s in rig.sensors if s.channel in accel}
    chosen, notes = body_solvers(rig, column, regs.coordinate_solvers)
    out: dict[str, Any] = {"notes": notes}
    if not chosen:
        return out
    n = exp.n_samples
    provenance = {"plugin": "coordinate solvers", "version": version,
                  "parameters": {"from": "processed displacement",
                                 "solvers": {c.body.name: c.name for c in chosen},
                                 "providers": {c.body.name: _provider(regs.coordinate_solvers, c.name)
                                               for c in chosen}}}
    with project.derived_writer(name, "gencoords", provenance=provenance) as w:
        for c in chosen:
            body, solver = c.body, c.solver
            cols = {s: column[s] for s in c.sensors}
            at_g = w.create(f"{body.name}_at_g", (n, 6), np.float64, "m m m rad rad rad", ("sample", "coordinate"))
            at_c = None
            for a in range(0, n, chunk):
                block = dsets["displacement"][a:min(a + chunk, n)]
                res = solver.solve(rig, body, {s: block[:, j] for s, j in cols.items()})
                at_g[a:a + block.shape[0]] = res.at_g
                if res.at_c is not None:
                    if at_c is None:
                        at_c = w.create(f"{body.name}_at_c", (n, 6), np.float64, "m m m rad rad rad",
                                        ("sample", "coordinate"))
                    at_c[a:a + block.shape[0]] = res.at_c
            w.attrs[f"{body.name}_solver"] = c.name
            summary: dict[str, Any] = {"solver": c.name, "sensors": list(c.sensors)}
            if hasattr(solver, "rigidity_check"):
                lo = min(exp.pretrigger, max(n - RIGIDITY_WINDOW, 0))
                acc = dsets["acceleration"][lo:lo + RIGIDITY_WINDOW]
                rig_check = solver.rigidity_check(rig, body, {s: acc[:, j] for s, j in cols.items()})
                frac = np.array([rig_check.fractions[a] for a in "xyz"])
                w.create(f"{body.name}_rigidity", (3,), np.float64, "1", ("axis",))[:] = frac
                w.attrs.update({f"{body.name}_rigidity_threshold": rig_check.threshold,
                                f"{body.name}_rigidity_flagged": ",".join(rig_check.flagged),
                                f"{body.name}_rigidity_worst": rig_check.worst,
                                f"{body.name}_rigidity_window": f"samples {lo}..{lo + acc.shape[0] - 1}"})
                summary.update(rigidity=rig_check.fractions, flagged=list(rig_check.flagged),
                               worst=rig_check.worst)
            out[body.name] = summary
    return out


def _provider(registry, name: str) -> dict[str, str]:
    entry = registry.entry(name)
    return {"plugin": entry.plugin, "distribution": entry.distribution, "version": entry.version}
