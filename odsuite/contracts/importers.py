"""The importer contract, and the choice of an importer for a measurement file.

A provider registered through ``odsuite_register_importers`` has:

- ``name`` (str, the ``--format`` value) and ``description`` (str);
- ``suffixes`` (tuple of str): the file suffixes it reads, lower case with the dot (".lvm");
- ``options`` (tuple of :class:`ImportOption`): the options it takes besides the file and the
  experiment's name, with the unit or form of each in its help (e.g. a force point in mm);
- ``import_file(project, file, name, **options) -> Imported``: adds the file's record to the project
  file ``project`` as experiment ``name`` (raw data written once, atomically: on any error the
  project is unchanged) and says what it stored. Bad files and options raise
  :class:`~odsuite.domain.errors.OdsuiteError` subclasses naming the file, field, channel and value;
- optionally ``export_file(project, out, experiment, **options)``: writes experiment ``experiment``
  of the project file ``project`` to the file ``out`` in this format (``odsuite export-legacy``,
  ``odsuite export-uff``); a format that only reads has none.

``odsuite import PROJECT FILE --name NAME`` picks the importer by ``--format`` or by FILE's suffix
(a plugin's importer before a built-in one reading the same suffix).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from odsuite.domain.errors import ConfigError


@dataclass(frozen=True)
class ImportOption:
    """An option of an importer: its keyword, whether it must be given, and its help text."""

    name: str
    help: str
    required: bool = False


@dataclass(frozen=True)
class Imported:
    """What an importer stored: the experiment's name and notes for the user (warnings)."""

    experiment: str
    summary: str
    notes: tuple[str, ...] = ()


class Importer(Protocol):
    """What every registered importer has (checked when a plugin registers one)."""

    name: str
    description: str
    suffixes: tuple[str, ...]
    options: tuple[ImportOption, ...]

    def import_file(self, project: Path, file: Path, name: str, **options: Any) -> Imported: ...


PROTOCOL = Importer
#: optional members that, where given, must be methods
OPTIONAL_METHODS = ("export_file",)


def exporter(registry, name: str):
    """The registered format ``name`` that can write, or one line saying which can."""
    fmt = registry.get(name)
    if not callable(getattr(fmt, "export_file", None)):
        writers = [n for n, i in registry.items() if callable(getattr(i, "export_file", None))]
        raise ConfigError(f"format {name!r} reads only (formats that write: {', '.join(writers) or 'none'})")
    return fmt


def choose_importer(registry, file: Path, name: str | None = None):
    """The importer ``name``, or the one reading ``file``'s suffix."""
    if name is not None:
        return registry.get(name)
    suffix = Path(file).suffix.lower()
    fits = [imp for _, imp in registry.items() if suffix in imp.suffixes]
    if len(fits) > 1:  # a lab's importer for a suffix goes before the built-in one (e.g. its own .csv)
        labs = [imp for imp in fits if registry.entry(imp.name).distribution != "odsuite"]
        fits = labs or fits
    if not fits:
        known = ", ".join(f"{n} ({', '.join(i.suffixes)})" for n, i in registry.items())
        raise ConfigError(f"{file}: no importer reads {suffix or 'files without a suffix'} files; give --format "
                          f"(importers: {known or 'none'})")
    if len(fits) > 1:
        raise ConfigError(f"{file}: importers {', '.join(i.name for i in fits)} all read {suffix} files; "
                          "choose one with --format")
    return fits[0]


def check_options(importer, given: Mapping[str, Any]) -> dict[str, Any]:
    """The options given (None: not given) checked against the importer's: none unknown, none missing."""
    given = {k: v for k, v in given.items() if v is not None}
    known = {o.name for o in importer.options}
    unknown = sorted(set(given) - known)
    if unknown:
        raise ConfigError(f"importer {importer.name!r} does not take {', '.join('--' + u.replace('_', '-') for u in unknown)}"
                          f" (it takes: {', '.join('--' + k.replace('_', '-') for k in sorted(known)) or 'nothing'})")
    missing = [o.name for o in importer.options if o.required and o.name not in given]
    if missing:
        raise ConfigError(f"importer {importer.name!r} needs {', '.join('--' + m.replace('_', '-') for m in missing)}")
    return given
