"""What is installed: the entry points of a group and a distribution's version, read through a
cache so that a command imports neither ``importlib.metadata`` nor the email parser it reads
metadata with, and scans no distribution's files (together a tenth of ``import numpy, h5py``).

The cache is one JSON file per Python environment in the user's cache folder
(``$ODSUITE_CACHE_DIR``, else ``$XDG_CACHE_HOME/odsuite``, else ``~/.cache/odsuite``). Its key is
what ``importlib.metadata`` reads: ``sys.path`` in order and, in each folder on it, every
``*.dist-info``/``*.egg-info`` with the modification times of itself, its entry points and its
metadata. Installing, upgrading, removing or editing a distribution changes the key and the
answers are read again from ``importlib.metadata``; a cache that cannot be written (a read-only
home) only costs that reading each time. Where ``importlib.metadata`` was loaded before odsuite
(a test that patches it, an application using it) it is asked directly and nothing is cached.
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import sys
import zlib
from importlib import import_module
from pathlib import Path
from typing import NamedTuple

_FORMAT = 1
#: importlib.metadata loaded before odsuite: asked directly (what it answers may be patched)
_LIVE = "importlib.metadata" in sys.modules


class EntryPoint(NamedTuple):  # not a dataclass: that would compile six methods at each start
    """One entry point and the distribution declaring it (``importlib.metadata``'s, without it)."""

    name: str
    value: str  # "module" or "module:attribute.path"
    dist_name: str
    dist_version: str

    def load(self):
        """The object named: ``importlib.metadata.EntryPoint.load``'s rule (extras are not read)."""
        module, _, attrs = self.value.partition(":")
        obj = import_module(module.split("[")[0].strip())
        for attr in filter(None, attrs.split("[")[0].strip().split(".")):
            obj = getattr(obj, attr)
        return obj


def entry_points(group: str) -> list[EntryPoint]:
    """The entry points of ``group`` as ``importlib.metadata.entry_points(group=...)`` gives them."""
    if _LIVE:
        return _read_entry_points(group)
    return [EntryPoint(*ep) for ep in _cached(f"entry_points {group}", lambda: [
        [ep.name, ep.value, ep.dist_name, ep.dist_version] for ep in _read_entry_points(group)], _entry_rows)]


def _entry_rows(answer) -> bool:
    return isinstance(answer, list) and all(
        isinstance(ep, list) and len(ep) == 4 and all(isinstance(v, str) for v in ep) for ep in answer)


def version(distribution: str) -> str | None:
    """The installed version of ``distribution``, None when it is not installed."""
    if _LIVE:
        return _read_version(distribution)
    return _cached(f"version {distribution}", lambda: _read_version(distribution),
                   lambda answer: answer is None or isinstance(answer, str))


def _read_entry_points(group: str) -> list[EntryPoint]:
    import importlib.metadata

    out = []
    about: dict[int, tuple[str, str]] = {}  # a distribution's metadata are parsed at each read: once each
    for ep in importlib.metadata.entry_points(group=group):
        dist = getattr(ep, "dist", None)
        if dist is None:
            name_version = ("?", "?")
        else:
            name_version = about.setdefault(id(dist), (dist.name, dist.version))
        out.append(EntryPoint(ep.name, ep.value, *name_version))
    return out


def _read_version(distribution: str) -> str | None:
    import importlib.metadata

    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return None


def _mtime(path: str) -> int | None:
    try:
        return os.stat(path).st_mtime_ns
    except OSError:
        return None


def installed_key() -> list:
    """What the answers depend on: the ``sys.path`` entries holding distributions, in order, with
    their distributions' times (an entry without any, such as a script's folder, changes nothing)."""
    key: list = [_FORMAT, sys.version]
    for entry in sys.path:
        try:
            listing = os.scandir(entry or ".")
        except NotADirectoryError:  # a zip file on the path
            key.append([entry, _mtime(entry)])
            continue
        except OSError:
            continue
        with listing:
            dists = sorted([d.name, _mtime(d.path), _mtime(os.path.join(d.path, "entry_points.txt")),
                            _mtime(os.path.join(d.path, "METADATA")), _mtime(os.path.join(d.path, "PKG-INFO"))]
                           for d in listing if d.name.lower().endswith((".dist-info", ".egg-info")))
        if dists:
            key.append([os.path.abspath(entry or "."), dists])
    return key


def _absolute(variable: str) -> str | None:
    """An environment variable naming a folder; a relative one is ignored (XDG's rule), as a cache
    must not follow the working folder into a project's or a user's files."""
    value = os.environ.get(variable)
    return value if value and os.path.isabs(value) else None


def cache_file() -> Path:
    folder = _absolute("ODSUITE_CACHE_DIR") or os.path.join(
        _absolute("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "odsuite")
    # one file per environment: two virtual environments used in turn do not evict each other
    return Path(folder) / f"installed-{zlib.crc32(sys.prefix.encode(errors='surrogateescape')):08x}.json"


@functools.cache
def _doc() -> dict:
    key = installed_key()
    try:
        doc = json.loads(cache_file().read_text(encoding="utf-8"))
        if isinstance(doc, dict) and doc.get("key") == key and isinstance(doc.get("answers"), dict):
            return doc
    except (OSError, ValueError):
        pass
    return {"key": key, "answers": {}}


def _cached(question: str, read, valid):
    """The cached answer to ``question``; ``read()`` when there is none or it is not of the form
    ``valid`` accepts (a file edited by hand or by another version)."""
    doc = _doc()
    if question not in doc["answers"] or not valid(doc["answers"][question]):
        doc["answers"][question] = read()
        _write(doc)
    return doc["answers"][question]


def _write(doc: dict) -> None:
    path = cache_file()
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        # a new file, never an existing one nor through a link planted at its (guessable) name
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
        with open(fd, "w", encoding="utf-8") as out:
            out.write(json.dumps(doc))
        os.replace(tmp, path)  # readers see the old file or the new one, never half of one
    except OSError:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
