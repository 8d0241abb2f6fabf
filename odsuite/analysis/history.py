"""The error history of a project's model revisions, as a document (the renderers plugin's
``history`` figure draws it), and the errors the writing commands store for it.

A revision's stored error holds for the records it was computed on: it carries a stamp of those
records (``data_stamp``) and is read back only while the stamp matches. A revision without a valid
stored error gets it computed when read (reading never writes); ``process`` stores the current
revision's and ``add-effect`` the revision it started from and the new one, so that ``info`` reads
them instead of running a comparison."""

from __future__ import annotations

from typing import Any

try:  # hashlib loads OpenSSL, a few ms of every `info`: the lean built-in module first, as random.py does
    from _sha2 import sha256  # Python 3.12+
except ImportError:
    try:
        from _sha256 import sha256
    except ImportError:
        from hashlib import sha256

from odsuite.domain.errors import ConfigError, NoSignalError


#: derived kinds no comparison reads: the FRFs `frf` and `modes` store again at every run (that
#: dropped every revision's stored error and the kept diagnosis, as if the records had changed)
NOT_COMPARED = frozenset({"frf"})


def data_stamp(project) -> str:
    """A fingerprint of the records a comparison reads: each experiment's identity and that of its
    derived data (a record re-acquired, re-processed, added or deleted changes it)."""
    h = sha256()
    for name in project.experiment_names():
        record, derived = project.object_ids(name)
        h.update(f"{name}\0{record}\0".encode())
        for kind, object_id in derived.items():
            if kind in NOT_COMPARED:
                continue
            h.update(f"{kind}\0{object_id}\0".encode())
    return h.hexdigest()[:16]


def valid_metric(metrics: dict, key: str, stamp: str) -> Any:
    """A stored metric, if it was computed on the records the project holds now (a metric stored
    without a stamp, by an older odsuite, is taken as it is)."""
    if metrics.get(key) is None or metrics.get("data_stamp", stamp) != stamp:
        return None
    return metrics[key]


def history(project) -> dict[str, Any]:
    """Revisions with their effects and errors, and the noise floor (the error a perfect model
    would leave; it depends on the measurements only)."""
    revs = project.model_revisions()
    stamp = data_stamp(project) if revs else ""
    out = []
    exps = None
    floor = next((f for f in (valid_metric(r.get("metrics", {}), "noise_floor_error", stamp) for r in reversed(revs))
                  if f is not None), None)
    if floor is None and revs and project.rig is not None:
        # the comparison (scipy.signal: seconds to import) only where nothing valid was stored
        from odsuite.analysis.comparison import noise_floor_error
        from odsuite.analysis.modelrev import RevisionModel, base_model

        exps = _comparable(project)
        floor = noise_floor_error(exps, RevisionModel(base_model(project.rig, registries=project.registries))) if exps else None
    for r in revs:
        error = valid_metric(r.get("metrics", {}), "error", stamp)
        if error is None and project.rig is not None:
            from odsuite.analysis.comparison import compare

            exps = _comparable(project) if exps is None else exps
            error = compare(project, revision=r, prepared=exps, resonances=False).error if exps else None
        out.append({"revision": r["revision"], "parent": r["parent"], "effects": [e["effect"] for e in r["effects"]],
                    "error": error, "created": r["created"]})
    return {"current": project.current_revision, "revisions": out, "noise_floor_error": floor}


def store_current_error(project, left_out: list[str] | None = None) -> float | None:
    """Compare the current revision with the records and store its error and the noise floor,
    stamped (``process`` calls this after changing the records). Nothing is stored where nothing
    can be compared (no rig, no revision, no record with a force and a signal). ``left_out`` gets
    a line for each record left out as it holds no signal."""
    if project.rig is None or project.current_revision is None:
        return None
    from odsuite.analysis.comparison import compare

    exps = _comparable(project, left_out)
    if not exps:
        return None
    rev = next(r for r in project.model_revisions() if r["revision"] == project.current_revision)
    result = compare(project, revision=rev, prepared=exps, resonances=False)
    project.set_revision_metrics(rev["revision"], {"error": result.error,
                                                   "noise_floor_error": result.noise_floor_error,
                                                   "data_stamp": data_stamp(project)})
    return result.error


def _comparable(project, left_out: list[str] | None = None) -> list:
    """The experiments a model can be compared with; records it cannot be driven with (no force
    point, not on the rig's channels) or compared with (no signal: its line added to ``left_out``)
    are left out of a summary rather than failing it."""
    from odsuite.analysis.prediction import prepare_experiment

    exps = []
    for name in project.experiment_names():
        try:
            exps.append(prepare_experiment(project, name))
        except NoSignalError as exc:
            if left_out is not None:
                left_out.append(str(exc))
        except ConfigError:
            continue
    return exps
