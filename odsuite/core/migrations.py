"""Upgrades of older project files to the current format version, applied on read.

A migration is a function that edits an h5py file opened for writing, registered for the version
it upgrades from::

    @migration("1.0.0", "1.1.0")
    def _add_something(f):
        ...

``migrate`` chains them until the file reaches the target version. Readers never migrate the
original file in place: ``odsuite.core.project`` migrates a private copy (read mode) or the copy of
a write transaction (write mode), so a failed migration leaves the project untouched.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import h5py
import numpy as np

from odsuite.core import h5text
from odsuite.core.errors import ProjectVersionError, SchemaError


@dataclass(frozen=True)
class Migration:
    from_version: str
    to_version: str
    apply: Callable[[h5py.File], None]


#: Registered migrations, keyed by the version they upgrade from.
MIGRATIONS: dict[str, Migration] = {}


def parse_version(text: str, where: str = "project") -> tuple[int, int, int]:
    """``"1.2.3"`` -> ``(1, 2, 3)``; anything else is a SchemaError naming ``where``."""
    parts = str(text).split(".")
    if len(parts) != 3 or not all(p.isdigit() for p in parts):
        raise SchemaError(f"{where}: odsuite_format_version {text!r} is not a version like '1.0.0'")
    return int(parts[0]), int(parts[1]), int(parts[2])


def migration(from_version: str, to_version: str):
    """Register the decorated function as the upgrade from ``from_version`` to ``to_version``."""
    parse_version(from_version, "migration")
    parse_version(to_version, "migration")

    def register(func: Callable[[h5py.File], None]) -> Callable[[h5py.File], None]:
        MIGRATIONS[from_version] = Migration(from_version, to_version, func)
        return func

    return register


def migration_path(from_version: str, to_version: str, where: str = "project") -> list[Migration]:
    """The chain of migrations from ``from_version`` to ``to_version`` (empty when equal)."""
    steps: list[Migration] = []
    version = from_version
    while version != to_version:
        step = MIGRATIONS.get(version)
        if step is None or len(steps) > len(MIGRATIONS):
            raise ProjectVersionError(
                f"{where}: project format {from_version} is older than {to_version} and no migration "
                f"from {version} exists; open it with the odsuite version that wrote it and export it"
            )
        steps.append(step)
        version = step.to_version
    return steps


def migrate(f: h5py.File, to_version: str, where: str = "project") -> list[str]:
    """Upgrade the writable file ``f`` in place to ``to_version``; returns the versions passed."""
    from_version = h5text.text(f.attrs["odsuite_format_version"])
    passed = []
    for step in migration_path(from_version, to_version, where):
        step.apply(f)
        h5text.set_attrs(f, {"odsuite_format_version": step.to_version})
        passed.append(step.from_version)
    return passed


@migration("1.0.0", "1.1.0")
def _fixed_length_text(f: h5py.File) -> None:
    """1.1.0 stores text as fixed-length strings (see ``h5text``): rewrite every variable-length
    string attribute and every table with variable-length string columns."""
    objects: list[h5py.HLObject] = [f]
    f.visititems(lambda _name, obj: objects.append(obj))
    for obj in objects:
        for key in list(obj.attrs):
            if h5text.is_variable_text(obj.attrs.get_id(key).dtype):
                h5text.set_attrs(obj, {key: obj.attrs[key]})
        if isinstance(obj, h5py.Dataset) and h5text.is_variable_text(obj.dtype):
            _rewrite_table(obj)


def _rewrite_table(ds: h5py.Dataset) -> None:
    """Replace a compound dataset's variable-length string columns by fixed-length ones."""
    table, attrs = ds[()], {k: ds.attrs[k] for k in ds.attrs}
    names = table.dtype.names or ()
    columns = {n: [h5text.text(v) for v in table[n]] for n in names if h5text.is_variable_text(table.dtype[n])}
    dtype = np.dtype([(n, h5text.fixed_dtype(columns[n]) if n in columns else table.dtype[n]) for n in names])
    fixed = np.zeros(table.shape, dtype=dtype)
    for n in names:
        fixed[n] = [v.encode("utf-8") for v in columns[n]] if n in columns else table[n]
    parent, name = ds.parent, ds.name.rsplit("/", 1)[1]
    del parent[name]
    new = parent.create_dataset(name, data=fixed)
    h5text.set_attrs(new, attrs)
