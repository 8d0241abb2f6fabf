"""Upgrades of older project files to the current format version, applied on read.

A migration is a function that edits an h5py file opened for writing, registered for the version
it upgrades from::

    @migration("1.0.0", "1.1.0")
    def _add_something(f):
        ...

``migrate`` chains them until the file reaches the target version. Readers never migrate the
original file in place: ``odsuite.store.project_migration`` migrates a private copy (read mode) or
a copy that then replaces the project atomically (write mode), so a failed migration leaves the
project untouched.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import h5py
import numpy as np

from odsuite.store import h5text
from odsuite.domain.errors import ProjectVersionError, SchemaError


@dataclass(frozen=True)
class Migration:
    """One step of the project format: the file upgraded in place from one version to the next."""

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


#: Bytes of an attribute that still fits an object header as HDF5 1.6 wrote it (messages < 64 KiB).
_OLD_HEADER_LIMIT = 60_000


@migration("1.0.0", "1.1.0")
def _fixed_length_text(f: h5py.File) -> None:
    """1.1.0 stores text as fixed-length strings (see ``h5text``): rewrite every variable-length
    string attribute, text dataset and table with text columns. ``f`` must be open with
    ``libver=("v110", "v110")``: a group whose text outgrows its old-style object header is
    recreated (its members moved over) with a header that stores large attributes."""
    names = [""]
    f.visit(names.append)
    for name in names:
        obj = f[name] if name else f
        if isinstance(obj, h5py.Dataset) and h5text.is_variable_text(obj.dtype):
            _recreate_dataset(obj, _fixed_data(obj))
            continue
        text = {k: h5text.stored(obj.attrs[k]) for k in obj.attrs if h5text.is_variable_text(obj.attrs.get_id(k).dtype)}
        if isinstance(obj, h5py.Group) and name and any(v.nbytes > _OLD_HEADER_LIMIT for v in text.values()):
            _recreate_group(obj)
        else:
            h5text.set_attrs(obj, text)


def _fixed_data(ds: h5py.Dataset) -> np.ndarray:
    """The data of a text dataset or a table with text columns, text as fixed-length UTF-8."""
    data = ds[()]
    if not ds.dtype.names:
        return h5text.fixed([h5text.text(v) for v in np.ravel(data)]).reshape(np.shape(data))
    fields = []
    for n in ds.dtype.names:
        field = ds.dtype[n]
        if h5text.is_variable_text(field) and (field.names or field.subdtype):
            raise SchemaError(f"{ds.name}: column {n!r} nests variable-length text; odsuite never wrote such a table")
        fields.append((n, h5text.fixed_dtype([h5text.text(v) for v in data[n]])
                       if h5text.is_variable_text(field) else field))
    fixed = np.zeros(data.shape, dtype=np.dtype(fields))
    for n, field in fields:
        fixed[n] = [h5text.text(v).encode("utf-8") for v in data[n]] if field.kind == "S" else data[n]
    return fixed


def _recreate_dataset(ds: h5py.Dataset, data: np.ndarray) -> None:
    """Replace ``ds`` by a dataset of ``data`` with the same storage settings and attributes."""
    parent, name = ds.parent, ds.name.rsplit("/", 1)[1]
    attrs = {k: h5text.stored(ds.attrs[k]) for k in ds.attrs}
    layout = {"chunks": ds.chunks, "maxshape": ds.maxshape, "fletcher32": ds.fletcher32, "shuffle": ds.shuffle,
              "compression": ds.compression, "compression_opts": ds.compression_opts} if ds.chunks else {}
    new = parent.create_dataset(name + ".migrating", data=data, **layout)
    h5text.set_attrs(new, attrs)
    del parent[name]
    parent.move(new.name, name)


def _recreate_group(g: h5py.Group) -> None:
    """Replace ``g`` by a new group (a current object header) holding its members and attributes."""
    parent, name = g.parent, g.name.rsplit("/", 1)[1]
    track_order = bool(g.id.get_create_plist().get_link_creation_order())
    new = parent.create_group(name + ".migrating", track_order=track_order)
    h5text.set_attrs(new, {k: h5text.stored(g.attrs[k]) for k in g.attrs})
    for member in list(g):
        g.move(member, f"{new.name}/{member}")
    del parent[name]
    parent.move(new.name, name)


#: SHA-256 of the texts of the shipped thesis rig file (thesis-dynamometer.toml) as released before
#: rig files had the field ``up``. A project keeps the text of the rig file it was made from (the
#: TOML ``definition`` before the JSON one, then ``source_text``): one of these texts identifies
#: the thesis rig, whose z points down into the platform.
THESIS_RIG_TEXTS_BEFORE_UP = frozenset({
    "9015c3d79e691ff0c3c690859b72e9ce8515d123cbdf5e7aa25b6008644afc67",
    "258506ce14745b8176c25a0874ed472696df6e89d4aab8c18740dda869f880d9",
})
THESIS_RIG_UP = [0.0, 0.0, -1.0]


def rig_up_filled(data: dict, file_text: str) -> dict:
    """A stored rig definition with ``up`` filled in when it has none and ``file_text`` (the rig
    file it was made from) is a pre-``up`` release of the thesis rig; otherwise ``data`` as it is
    (a rig without ``up`` has z up, and nothing in the file says otherwise)."""
    if "up" in data:
        return data
    import hashlib  # here: OpenSSL's load would cost every reading of a rig that has its `up`

    if hashlib.sha256(file_text.encode("utf-8")).hexdigest() not in THESIS_RIG_TEXTS_BEFORE_UP:
        return data
    return {**data, "up": list(THESIS_RIG_UP)}
