"""A hammer record's measured modes, identified once and stored with its derived data.

``compare`` (and the report through it) pairs every record's measured modes with the model's; the
identification (LSCF on the record's FRFs) depends on the record alone, not on the model, yet cost
0.2 s of CPU per record at every comparison. ``process`` stores it (``store_record_modes``) as the
derived group ``KIND``; ``identified_modes`` reads it back while it holds: computed from this
record (its object id, which a re-acquired record changes), with these settings, by this odsuite
version and the same identification code (a fingerprint of its modules' source and of numpy's and
scipy's versions: an edited source tree keeps its version). Otherwise, as in a project written
before modes were stored, they are identified again (a reader writes nothing). A record whose modes
cannot be identified stores why, so that the same note is printed without fitting again."""

from __future__ import annotations

import hashlib
import importlib.util
import json
from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from odsuite.analysis.frf import FrfSet
from odsuite.analysis.modal import ModalResult, StabilisationDiagram
from odsuite.analysis.modal_project import all_flagged, data_end_notes, frf_modes, hit_notes, hits_frf, record_hits
from odsuite.domain.errors import ConfigError, OdsuiteError
from odsuite.domain.version import __version__
from odsuite.store.project import DerivedArray

#: the derived group the modes are stored as, and what it records as its source
KIND = "hammer_modes"
PLUGIN = "odsuite.hammer_modes"
#: how the modes were identified (``hits_frf`` over every hit when all are flagged, then
#: ``frf_modes`` with its defaults on the channels that respond): a stored group with other
#: settings is not read
PARAMETERS = {"estimator": "H1", "flagged_too": True, "max_order": 50, "band": "usable"}
#: the modules whose code the identification runs (their source is part of the stamp)
CODE = ("odsuite.analysis.frf", "odsuite.analysis.hammer", "odsuite.analysis.modal", "odsuite.analysis.modal_project",
        "odsuite.analysis.stored_modes")
#: errors an identification may end in; their message is the record's note
IDENTIFICATION_ERRORS = (ConfigError, np.linalg.LinAlgError)


def responding(frf: FrfSet) -> FrfSet:
    """The FRFs of the outputs that respond (a channel a record leaves empty has H = 0)."""
    keep = [k for k in range(frf.H.shape[0]) if np.any(frf.H[k] != 0)]
    if len(keep) == frf.H.shape[0]:
        return frf
    if not keep:
        raise ConfigError("no response channel responds to the hammer")
    return replace(frf, H=frf.H[keep], coherence=frf.coherence[keep], units=[frf.units[k] for k in keep],
                   output_names=[frf.output_names[k] for k in keep],
                   trend=None if frf.trend is None else frf.trend[keep])


def identify(frf: FrfSet) -> ModalResult:
    """A record's modes from its hammer FRFs (raises one of ``IDENTIFICATION_ERRORS``)."""
    return frf_modes(responding(frf))


def identified_modes(project, exp, frf: FrfSet) -> ModalResult:
    """The modes of record ``exp`` (an experiment as read from ``project``, whose FRFs are ``frf``):
    the stored ones while they hold, else identified now. A stored failure raises a ConfigError
    with the message it was stored with."""
    stored = stored_modes(project, exp)
    return identify(frf) if stored is None else stored.modes()


@dataclass(frozen=True)
class StoredModes:
    """What ``process`` stored for a record: its modes or why they could not be identified, what
    the hammer checks found wrong with its hits when every hit was flagged ("" otherwise) and what
    its hits are told (``modal_project.hit_notes``: the data's end, leakage)."""

    result: ModalResult | str
    flagged: str
    hit_notes: tuple[str, ...] = ()

    def modes(self) -> ModalResult:
        """The modes; a stored failure raises a ConfigError with its message."""
        if isinstance(self.result, str):
            raise ConfigError(self.result)
        return self.result


def store_record_modes(project, name: str) -> list[str]:
    """Identify record ``name``'s modes and store them (or why they cannot be identified) as
    ``KIND``. A record without a force channel or a usable hit has no hammer modes: nothing is
    stored (``compare`` says why when it reads the record). Returns what the data's end did with
    its hits and their leakage (``modal_project.hit_notes``), for the caller to say."""
    where = f"{project.path}: experiment {name!r}"
    # one BLAS thread, as ``compare`` runs: the stored result is the one it would compute
    with threadpool_limits(1):
        try:
            frf, hits = hits_frf(project.experiment(name), where, flagged_too=True)
        except OdsuiteError:
            try:  # a hit the data's end left out may be the only one: said all the same
                return data_end_notes(record_hits(project.experiment(name), where)[2])
            except OdsuiteError:
                return []
        try:
            res = identify(frf)
        except IDENTIFICATION_ERRORS as exc:
            res = str(exc)
        except OdsuiteError:  # what compare does not note: left to it, as before
            return hit_notes(hits, frf)
    flagged = all_flagged(hits)
    notes = hit_notes(hits, frf)
    if isinstance(res, str):
        project.write_derived(name, KIND, {}, provenance=_provenance(),
                              attrs={"failure": res, "flagged": flagged, "hit_notes": json.dumps(notes)})
        return notes
    project.write_derived(name, KIND, _arrays(res, frf), provenance=_provenance(),
                          attrs={"failure": "", "flagged": flagged, "hit_notes": json.dumps(notes),
                                 "output_names": json.dumps(res.output_names),
                                 "rejected": json.dumps(res.rejected),
                                 "band_hz": json.dumps(list(res.band_hz)),
                                 "diagram_band_hz": json.dumps(list(res.diagram.f_band))})
    return notes


def _provenance() -> dict:
    return {"plugin": PLUGIN, "version": __version__, "parameters": {**PARAMETERS, "code": code_stamp()}}


@cache
def code_stamp() -> str:
    """A fingerprint of the identification's code: its modules' source, numpy's and scipy's versions."""
    import scipy

    h = hashlib.sha256(f"numpy {np.__version__} scipy {scipy.__version__}".encode())
    for name in CODE:
        h.update(Path(importlib.util.find_spec(name).origin).read_bytes())
    return h.hexdigest()[:16]


def _arrays(res: ModalResult, frf: FrfSet) -> dict[str, DerivedArray]:
    d = res.diagram
    units = dict(zip(frf.output_names, frf.units))
    residue_units = ";".join(f"{units.get(n, '1')}*rad/s" for n in res.output_names)
    mode_dims, out_dims = ("mode",), ("output", "mode")
    return {
        "poles_real": DerivedArray(res.poles.real, "rad/s", mode_dims),
        "poles_imag": DerivedArray(res.poles.imag, "rad/s", mode_dims),
        "residues_real": DerivedArray(res.residues.real, residue_units, out_dims),
        "residues_imag": DerivedArray(res.residues.imag, residue_units, out_dims),
        "shapes_real": DerivedArray(res.shapes.real, "1", out_dims),
        "shapes_imag": DerivedArray(res.shapes.imag, "1", out_dims),
        "stable_orders": DerivedArray(np.asarray(res.stable_orders), "1", mode_dims),
        # the stabilisation diagram: every order's poles one after the other, ``diagram_counts`` per order
        "diagram_orders": DerivedArray(np.asarray(d.orders), "1", ("order",)),
        "diagram_counts": DerivedArray(np.array([len(p) for p in d.poles]), "1", ("order",)),
        "diagram_poles_real": DerivedArray(np.concatenate(d.poles).real, "rad/s", ("pole",)),
        "diagram_poles_imag": DerivedArray(np.concatenate(d.poles).imag, "rad/s", ("pole",)),
        "diagram_stable_f": DerivedArray(np.concatenate(d.stable_f), "1", ("pole",)),
        "diagram_stable": DerivedArray(np.concatenate(d.stable), "1", ("pole",)),
    }


def stored_modes(project, exp) -> StoredModes | None:
    """What ``process`` stored for record ``exp`` (an experiment as read from ``project``), if it
    holds for the record as it is."""
    name = exp.name
    if KIND not in project.derived_kinds(name):
        return None
    info = project.derived_info(name, KIND)
    prov = info["provenance"]
    if (prov["plugin"] != PLUGIN or prov["version"] != __version__ or prov["inputs"] != [exp.object_id]
            or prov["parameters"] != _provenance()["parameters"]):
        return None
    attrs = info["attrs"]
    flagged = str(attrs.get("flagged", ""))
    where = f"{project.path}: experiment {name!r}: derived {KIND!r}"
    try:
        notes = tuple(str(n) for n in json.loads(attrs.get("hit_notes", "[]")))
        if attrs.get("failure"):
            return StoredModes(str(attrs["failure"]), flagged, notes)
        return StoredModes(_decoded(project.read_derived(name, KIND), attrs), flagged, notes)
    except (KeyError, ValueError, TypeError) as exc:  # a group edited by hand or damaged: not modes
        raise ConfigError(f"{where}: cannot be read as modes ({type(exc).__name__}: {exc}); "
                          "run process again to store them anew") from None


def _decoded(a: dict, attrs) -> ModalResult:
    """The stored arrays and attributes as a ModalResult, each checked against the others (a
    ValueError naming the field where they disagree or are not finite)."""
    z = lambda part: _complex(a[f"{part}_real"], a[f"{part}_imag"])  # noqa: E731
    poles, residues, shapes = z("poles"), z("residues"), z("shapes")
    names = json.loads(attrs["output_names"])
    m = poles.shape[0] if poles.ndim == 1 else -1
    for field, arr, shape in (("poles", poles, (m,)), ("residues", residues, (len(names), m)),
                              ("shapes", shapes, (len(names), m)), ("stable_orders", a["stable_orders"], (m,))):
        if arr.shape != shape or not np.all(np.isfinite(arr)):
            raise ValueError(f"field {field!r} has shape {arr.shape}, expected {shape} of finite numbers")
    if not all(isinstance(n, str) for n in names):
        raise ValueError(f"field 'output_names' is {names!r}, expected names")
    counts = a["diagram_counts"]
    n_poles = a["diagram_poles_real"].shape
    if counts.ndim != 1 or np.any(counts < 0) or (int(counts.sum()),) != n_poles or counts.shape != a[
            "diagram_orders"].shape or any(a[k].shape != n_poles for k in (
            "diagram_poles_imag", "diagram_stable_f", "diagram_stable")):
        raise ValueError(f"field 'diagram_counts' sums to {int(counts.sum())} poles, stored {n_poles}")
    cuts = np.cumsum(counts)[:-1]
    split = lambda x: np.split(x, cuts)  # noqa: E731
    diagram = StabilisationDiagram([int(o) for o in a["diagram_orders"]],
                                   split(z("diagram_poles")),
                                   split(a["diagram_stable_f"]), split(a["diagram_stable"]),
                                   tuple(float(v) for v in json.loads(attrs["diagram_band_hz"])))
    return ModalResult(poles, residues, shapes, names, diagram,
                       tuple(float(v) for v in json.loads(attrs["band_hz"])),
                       a["stable_orders"], json.loads(attrs["rejected"]))


def _complex(re: np.ndarray, im: np.ndarray) -> np.ndarray:
    """The complex array stored as its parts, bit for bit (``re + 1j * im`` can flip a zero's sign)."""
    out = np.empty(re.shape, dtype=complex)
    out.real, out.imag = re, im
    return out
