"""Multi-setup output-only analysis: a roving survey is several records (setups), each with the same
reference channels and its own roving ones. Each setup's modes are identified on their own
(``oma.identify_output_only``), paired across setups by frequency and by the MAC of their reference
components, and merged by post-separate estimation re-scaling (PoSER): each setup's shape is scaled
by the complex factor that best fits (least squares) its reference components to the first setup's,
so a setup measured at another excitation level, or with its shape's arbitrary scale and phase,
joins the others in one shape over every measured channel.

PoSER as in Döhler, Andersen & Mevel (2010) and pyOMA2's multi-setup ("MultiSetup_PoSER").
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from odsuite.domain.errors import ConfigError
from odsuite.analysis.modal import ModalResult, mac, mpc, mpd, normalise_shapes

#: a setup's mode pairs with the first setup's only within this relative frequency distance
PAIR_TOL = 0.03
#: a pair whose reference components agree less than this (MAC) is not the same mode
MIN_REFERENCE_MAC = 0.5


@dataclass
class MergedModes:
    """Modes merged over setups, ascending in frequency. ``shapes`` is channels x modes over
    ``channels`` (references first, then each setup's roving channels in setup order), scaled to a
    largest entry of 1; ``per_setup[k]`` per mode: setup name -> (frequency Hz, damping ratio,
    MAC of the reference components against the first setup's, complex PoSER factor)."""

    setups: list[str]
    references: list[str]
    channels: list[str]
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    frequency_spread_hz: np.ndarray  # sample standard deviation over setups (NaN for one setup)
    damping_spread: np.ndarray
    shapes: np.ndarray
    per_setup: list[dict[str, tuple[float, float, float, complex]]]
    unpaired: list[str] = field(default_factory=list)  # modes not found in every setup, and why
    results: dict[str, ModalResult] = field(default_factory=dict)  # each setup's own modes

    def to_dict(self) -> dict:
        """JSON-ready: {"multi_setup": true, "setups", "references", "channels", "modes": [{
        "frequency_hz", "frequency_spread_hz", "damping_ratio", "damping_spread", "shape": {channel:
        [re, im]}, "mpc", "mpd_deg", "setups": {setup: {"frequency_hz", "damping_ratio",
        "reference_mac", "scale": [re, im]}}}], "unpaired": [text], "settings": {setup: ...}}."""
        def num(v):
            return float(v) if np.isfinite(v) else None

        modes = []
        for k in range(self.frequency_hz.size):
            phi = self.shapes[:, k]
            modes.append({
                "frequency_hz": float(self.frequency_hz[k]), "frequency_spread_hz": num(self.frequency_spread_hz[k]),
                "damping_ratio": float(self.damping_ratio[k]), "damping_spread": num(self.damping_spread[k]),
                "shape": {c: [float(v.real), float(v.imag)] for c, v in zip(self.channels, phi)},
                "mpc": float(mpc(phi)), "mpd_deg": float(mpd(phi)),
                "setups": {s: {"frequency_hz": f, "damping_ratio": z, "reference_mac": m,
                               "scale": [float(a.real), float(a.imag)]}
                           for s, (f, z, m, a) in self.per_setup[k].items()},
            })
        return {"multi_setup": True, "output_only": True, "setups": list(self.setups),
                "references": list(self.references), "channels": list(self.channels), "modes": modes,
                "unpaired": list(self.unpaired),
                "settings": {s: r.settings.to_dict() for s, r in self.results.items() if r.settings is not None}}


def check_references(setups: Sequence[tuple[str, Sequence[str]]], references: Sequence[str] | None,
                     where: str) -> list[str]:
    """The reference channels: those given, each present in every setup (name, channel names), or
    without them the channels common to every setup. A missing or differently spelt reference is
    one line naming the setup and the channel."""
    if len(setups) < 2:
        raise ConfigError(f"{where}: multi-setup merging needs at least two setups (records), got {len(setups)}")
    if references is None:
        common = [c for c in setups[0][1] if all(c in names for _, names in setups[1:])]
        if not common:
            raise ConfigError(f"{where}: the setups {', '.join(s for s, _ in setups)} share no channel name, so no "
                              "reference channel: name them alike in every record, or give --reference")
        references = common
    references = list(references)
    if len(set(references)) != len(references) or not references:
        raise ConfigError(f"{where}: --reference {','.join(references)}: name each reference channel once")
    for setup, names in setups:
        for ref in references:
            if ref not in names:
                alike = [c for c in names if c.strip().lower() == ref.strip().lower()]
                hint = (f" (it has {alike[0]!r}: reference names must match exactly)" if alike
                        else f" (its channels: {', '.join(names)})")
                raise ConfigError(f"{where}: setup {setup!r} has no reference channel {ref!r}{hint}")
        if len(names) == len(references):
            raise ConfigError(f"{where}: setup {setup!r} has only the reference channels "
                              f"{', '.join(references)}: it adds no roving channel")
    return references


def _pairs(first: ModalResult, other: ModalResult, ref_first: list[int], ref_other: list[int]) -> dict[int, int]:
    """First setup's mode -> the other setup's: one-to-one, within ``PAIR_TOL`` in frequency and
    ``MIN_REFERENCE_MAC`` on the reference components, nearest in frequency and MAC combined."""
    from scipy.optimize import linear_sum_assignment

    fa, fb = first.frequency_hz, other.frequency_hz
    if fa.size == 0 or fb.size == 0:
        return {}
    df = np.abs(np.log(fb[None, :] / fa[:, None]))
    m = mac(first.shapes[ref_first], other.shapes[ref_other])
    cost = df / PAIR_TOL + (1 - m)
    ok = (df <= PAIR_TOL) & (m >= MIN_REFERENCE_MAC)
    rows, cols = linear_sum_assignment(np.where(ok, cost, 1e6))
    return {int(r): int(c) for r, c in zip(rows, cols) if ok[r, c]}


def merge_setups(results: Sequence[ModalResult], setups: Sequence[str], references: Sequence[str],
                 where: str = "multi-setup") -> MergedModes:
    """Merge each setup's modes (``results``, one per setup, with ``output_names``) through the
    ``references`` channels: modes of the first setup found in every other one (``_pairs``) are
    kept; frequency and damping are the setups' means with their spread; the shape is the
    PoSER-scaled union (references averaged over setups, each roving channel from its setup; a
    roving name used by several setups becomes "name @ setup")."""
    refs = list(references)
    idx = [[list(r.output_names).index(c) for c in refs] for r in results]
    roving = [[c for c in r.output_names if c not in refs] for r in results]
    seen: dict[str, int] = {}
    for names in roving:
        for c in names:
            seen[c] = seen.get(c, 0) + 1
    rov_names = [[c if seen[c] == 1 else f"{c} @ {s}" for c in names] for names, s in zip(roving, setups)]
    channels = refs + [c for names in rov_names for c in names]
    pairs = [_pairs(results[0], r, idx[0], i) for r, i in zip(results[1:], idx[1:])]
    unpaired = []
    first = results[0]
    keep = []
    for k, f in enumerate(first.frequency_hz):
        missing = [s for s, p in zip(setups[1:], pairs) if k not in p]
        if missing:
            unpaired.append(f"the mode at {f:.4g} Hz of setup {setups[0]!r} has no partner in setup(s) "
                            f"{', '.join(repr(s) for s in missing)} (within {100 * PAIR_TOL:g} % and reference "
                            f"MAC {MIN_REFERENCE_MAC:g})")
        else:
            keep.append(k)
    for s, r, p in zip(setups[1:], results[1:], pairs):
        taken = set(p.values())
        unpaired += [f"the mode at {f:.4g} Hz of setup {s!r} has no partner in setup {setups[0]!r}"
                     for j, f in enumerate(r.frequency_hz) if j not in taken]
    if not keep:
        raise ConfigError(f"{where}: no mode is found in every setup ({'; '.join(unpaired)}); give --fmin/--fmax "
                          "around the modes, or check that the reference channels measure the same points")
    n = len(keep)
    F, Z = np.empty((len(results), n)), np.empty((len(results), n))
    shapes = np.zeros((len(channels), n), dtype=complex)
    per_setup = [dict() for _ in range(n)]
    for col, k in enumerate(keep):
        js = [k] + [p[k] for p in pairs]
        target = first.shapes[idx[0], k]
        refsum = np.zeros(len(refs), dtype=complex)
        row = len(refs)
        for s, (r, j, i) in enumerate(zip(results, js, idx)):
            phi = r.shapes[:, j]
            ref = phi[i]
            alpha = np.vdot(ref, target) / np.vdot(ref, ref).real  # least squares: alpha ref ~ target
            refsum += alpha * ref
            rov = [c for c in range(len(r.output_names)) if c not in i]
            shapes[row:row + len(rov), col] = alpha * phi[rov]
            row += len(rov)
            F[s, col], Z[s, col] = r.frequency_hz[j], r.damping_ratio[j]
            per_setup[col][setups[s]] = (float(F[s, col]), float(Z[s, col]),
                                         float(mac(ref, target)[0, 0]), complex(alpha))
        shapes[:len(refs), col] = refsum / len(results)
    spread = (lambda a: a.std(axis=0, ddof=1)) if len(results) > 1 else (lambda a: np.full(n, np.nan))
    f = F.mean(axis=0)
    order = np.argsort(f)
    return MergedModes(list(setups), refs, channels, f[order], Z.mean(axis=0)[order], spread(F)[order],
                       spread(Z)[order], normalise_shapes(shapes[:, order]), [per_setup[k] for k in order],
                       unpaired, dict(zip(setups, results)))


def project_setups_modes(project: str | Path, experiments: Sequence[str], *, references: Sequence[str] | None = None,
                         f_band: tuple[float | None, float | None] | None = None, max_order: int | None = None,
                         block_rows: int | None = None, decimation: int | None = None) -> MergedModes:
    """Modes of a roving survey stored as one experiment per setup: each setup's response channels
    (``modal_project.response_columns``) identified alone (``modal_project.experiment_output_only_modes``,
    same options for every setup), then merged (``merge_setups``) through ``references`` (default:
    the channel names common to every setup)."""
    from odsuite.analysis.modal_project import experiment_output_only_modes, response_columns
    from odsuite.store.project import open_project

    where = str(project)
    if len(set(experiments)) != len(experiments):
        raise ConfigError(f"{where}: an experiment is named twice in {', '.join(experiments)}")
    with open_project(project) as p:
        missing = [e for e in experiments if e not in p.experiment_names()]
        if missing:
            raise ConfigError(f"{where}: no experiment {missing[0]!r} "
                              f"(experiments: {', '.join(p.experiment_names()) or 'none'})")
        names = []
        for e in experiments:
            exp = p.experiment(e)
            names.append((e, [exp.channel_names[k] for k in response_columns(exp)]))
    refs = check_references(names, references, where)
    results = []
    for e in experiments:  # a refusal names the project and the setup's experiment
        results.append(experiment_output_only_modes(project, e, f_band=f_band, max_order=max_order,
                                                    block_rows=block_rows, decimation=decimation)[0])
    return merge_setups(results, experiments, refs, where)
