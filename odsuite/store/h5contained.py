"""The check that a project file holds only itself: no external links, soft links, external
storage or virtual datasets, any of which would make HDF5 read another file when an object is read,
and no object under two names (hard links), which every walk over the file would read once per name."""

from __future__ import annotations

from pathlib import Path

import h5py

from odsuite.domain.errors import ProjectFileError

class ReachesOutsideError(ProjectFileError):
    """A project file with an object outside itself (refused: reading it would read another file)."""


_LINKS = {h5py.h5l.TYPE_SOFT: "a soft link", h5py.h5l.TYPE_EXTERNAL: "an external link"}


def _outside(f: h5py.File, name: bytes, info) -> str | None:
    """Why the object at ``name`` is not wholly inside ``f``, or None."""
    text = name.decode("utf-8", "replace")
    if info.type != h5py.h5l.TYPE_HARD:
        what = _LINKS.get(info.type, "a user-defined link")
        if info.type == h5py.h5l.TYPE_EXTERNAL:
            target = f.get(text, getlink=True)  # the link itself, never followed
            return f"{text!r} is {what} to {target.filename!r}:{target.path!r}"
        return f"{text!r} is {what}"
    obj = h5py.h5o.open(f.id, name)
    try:
        if not isinstance(obj, h5py.h5d.DatasetID):
            return None
        plist = obj.get_create_plist()
        if plist.get_layout() == h5py.h5d.VIRTUAL:
            return f"dataset {text!r} is a virtual dataset (its data are in other files)"
        if plist.get_external_count() > 0:
            return f"dataset {text!r} has external storage (its data are in other files)"
        return None
    finally:
        obj.close() if hasattr(obj, "close") else None


def refuse_outside(f: h5py.File, where: Path) -> None:
    """Walk the links of ``f`` once (never following any) and refuse the file if one object
    reaches outside it: one ProjectFileError line naming the object."""
    found: list[str] = []
    failed: list[Exception] = []
    twice: list[str] = []
    names: dict[int, bytes] = {}  # object address -> its first name

    def visit(name: bytes, info) -> int | None:
        if info.type == h5py.h5l.TYPE_HARD:
            first = names.setdefault(info.u, name)
            if first != name:  # odsuite writes one name per object; a second name would be read twice
                twice.append(f"{name.decode('utf-8', 'replace')!r} names the same object as "
                             f"{first.decode('utf-8', 'replace')!r} (a second hard link)")
                return 1
        try:
            why = _outside(f, name, info)
        except Exception as exc:  # noqa: BLE001 - damaged metadata: raised below, unwrapped by h5py
            failed.append(exc)
            return 1
        if why:
            found.append(why)
            return 1  # stops the walk
        return None

    f.id.links.visit(visit, info=True)
    if failed:
        raise failed[0]
    if found:
        raise ReachesOutsideError(f"{where}: refused: {found[0]}; an odsuite project holds only itself")
    if twice:
        raise ProjectFileError(f"{where}: refused: {twice[0]}; an odsuite project names each object once")
