"""A revision's last full diagnosis, stored with it for the report (a diagnosis takes tens of
seconds; the report shows it rather than running it again).

Like a revision's stored error (``history``), it carries a stamp and is read back only while the
stamp matches: the same records (``data_stamp``), the same registered effects and the same odsuite
version (another version may rank the candidates differently)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from odsuite.analysis.diagnosis_document import check_diagnosis
from odsuite.analysis.history import data_stamp

#: the revision metrics' key the diagnosis is stored under
KEY = "diagnosis"


def diagnosis_stamp(project) -> dict[str, Any]:
    """What a stored diagnosis holds for: the records, the effects tried, the odsuite version."""
    from odsuite.domain.version import __version__

    return {"data_stamp": data_stamp(project), "effects": sorted(project.registries.effects.names()),
            "odsuite": __version__}


def store_diagnosis(project, doc: Mapping[str, Any], stamp: Mapping[str, Any]) -> bool:
    """Store ``doc`` (``Diagnosis.as_dict()`` of every registered effect) with its revision, if the
    project still is as ``stamp`` (taken before diagnosing) says: records processed or a revision
    made meanwhile leave nothing stored. Returns whether it was stored."""
    from odsuite.analysis.modelrev import current_revision

    revision = doc.get("revision")
    if revision is None or revision != current_revision(project)["revision"] or dict(stamp) != diagnosis_stamp(project):
        return False
    project.set_revision_metrics(revision, {KEY: {"stamp": dict(stamp), "document": dict(doc)}})
    return True


def stored_diagnosis(project, revision: int | None) -> dict[str, Any] | None:
    """The diagnosis stored with ``revision``, if it holds for the project as it is now; else None."""
    rev = next((r for r in project.model_revisions() if r["revision"] == revision), None)
    entry = rev["metrics"].get(KEY) if rev is not None else None
    if not isinstance(entry, dict) or entry.get("stamp") != diagnosis_stamp(project):
        return None
    # the report shows it: a document changed by hand is refused here, in one line
    return check_diagnosis(entry.get("document"), f"{project.path}: model revision {revision}",
                           f"metrics.{KEY}.document.")
