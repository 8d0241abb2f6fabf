"""Encoders and decoders between odsuite's objects and the HDF5 objects of a project file: typed
groups, datasets with units and dims, JSON attributes, the Systeminfo table, the rig, model
revisions and a new file's root (see ``odsuite.store.project`` for the layout)."""

from __future__ import annotations

import dataclasses
import json
import math
import operator
import typing
import uuid
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping
from enum import IntEnum
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from odsuite.store import diskspace
from odsuite.store import h5text
from odsuite.domain.errors import ConfigError
from odsuite.store.h5damage import first_line
from odsuite.store.project_format import FORMAT_NAME, FORMAT_VERSION, now
from odsuite.domain.rig import COORDINATES, Rig
from odsuite.domain.systeminfo import ChannelInfo, RigInfo, Systeminfo, parse_ctr
from odsuite.domain.textfiles import read_text
from odsuite.domain.version import __version__


class Attrs(Mapping):
    """An object's attributes for reading: a missing or unreadable one is a KeyError naming it
    (HDF5's message for attributes in dense storage does not)."""

    def __init__(self, obj: h5py.HLObject) -> None:
        self._attrs = obj.attrs

    def __getitem__(self, key: str) -> Any:
        try:
            return self._attrs[key]
        except KeyError as exc:
            raise KeyError(f"attribute {key!r}: {first_line(exc)}") from None

    def __contains__(self, key: object) -> bool:
        return key in self._attrs

    def __iter__(self) -> Iterator[str]:
        return iter(self._attrs)

    def __len__(self) -> int:
        return len(self._attrs)


def typed_group(parent: h5py.Group, name: str, odsuite_type: str, **kw) -> h5py.Group:
    """A new group with its odsuite_type and a fresh object_id."""
    g = parent.create_group(name, **kw)
    h5text.set_attrs(g, {"odsuite_type": odsuite_type, "object_id": str(uuid.uuid4())})
    return g


def dataset(parent: h5py.Group, name: str, data: Any, units: str, dims: Iterable[str], **kw) -> h5py.Dataset:
    """A new dataset with its units and dimension names; refused before writing when the disk has no
    room for it."""
    if data is not None:
        nbytes = np.asarray(data).nbytes
    else:
        nbytes = int(np.prod(kw.get("shape") or (), dtype=np.int64)) * np.dtype(kw.get("dtype", "f4")).itemsize
    diskspace.ensure_room_in(parent.file, nbytes)
    ds = parent.create_dataset(name, data=data, **kw)
    h5text.set_attrs(ds, {"units": units, "dims": h5text.fixed(list(dims))})
    return ds


def to_json(where: str, value: Any) -> str:
    """``value`` as JSON text (arrays as lists); anything else is a ConfigError naming ``where``."""
    def default(o: Any) -> Any:
        if isinstance(o, np.ndarray | np.generic):
            return o.tolist()
        raise TypeError(type(o).__name__)

    try:
        return json.dumps(value, default=default)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{where}: value is not JSON-serialisable ({exc}): {value!r}") from None


# ----------------------------------------------------------------------------- Systeminfo table

_CHANNEL_HINTS = typing.get_type_hints(ChannelInfo)
#: Units of the numeric ChannelInfo columns ("1" = dimensionless or a count/index).
_CHANNEL_UNITS = {
    "sensitivity": "V per unit (column 'unit')", "sampling_rate": "Hz", "cutoff_high": "Hz",
    "cutoff_low": "Hz", "ripple_db": "dB", "attenuation_db": "dB", "limit_high": "V",
    "limit_low": "V", "filter_order": "1", "filters_on": "1", "offset_start": "1",
    "offset_length": "1", "daq_gain": "1",
}


def _column_dtype(hint: Any) -> Any:
    if isinstance(hint, type) and issubclass(hint, IntEnum):
        return h5py.enum_dtype({m.name: m.value for m in hint}, basetype="i1")
    if hint is bool:
        return np.bool_
    if hint is int:
        return np.int64
    return np.float64  # float and float | None (None stored as NaN)


def write_systeminfo(parent: h5py.Group, si: Systeminfo, names: list[str]) -> None:
    g = typed_group(parent, "systeminfo", "systeminfo")
    fields = [f.name for f in dataclasses.fields(ChannelInfo)]
    text_columns = {"name": names, "unit": [ch.unit for ch in si.channels]}
    text_columns |= {n: [getattr(ch, n) for ch in si.channels] for n in fields if _CHANNEL_HINTS[n] is str}
    dtype = np.dtype([(n, h5text.fixed_dtype(text_columns[n])) for n in ("name", "unit")]
                     + [(n, h5text.fixed_dtype(text_columns[n]) if n in text_columns
                         else _column_dtype(_CHANNEL_HINTS[n])) for n in fields])
    table = np.zeros(len(si.channels), dtype=dtype)
    for i, ch in enumerate(si.channels):
        row = [names[i].encode(), ch.unit.encode()]
        for n in fields:
            v = getattr(ch, n)
            row.append(v.encode() if isinstance(v, str) else np.nan if v is None
                       else int(v) if isinstance(v, IntEnum) else v)
        table[i] = tuple(row)
    dataset(g, "channels", table, "", ["channel"])
    g["channels"].attrs["units"] = h5text.fixed(["", ""] + [_CHANNEL_UNITS.get(n, "") for n in fields])

    r = si.rig
    rg = typed_group(g, "rig", "riginfo")
    h5text.set_attrs(rg, {"use_in_gcc": r.use_in_gcc, "use_in_ag": r.use_in_ag,
                          "plot_from_corner": r.plot_from_corner})
    for n in ("plate_sizes", "plate_origins"):
        dataset(rg, n, np.asarray(getattr(r, n), dtype=float).reshape(-1, 3), "m", ["plate", "xyz"])
    for n in ("coordinate_columns", "nine_channels"):
        dataset(rg, n, np.asarray(getattr(r, n), dtype=np.int64).reshape(-1), "1", ["column"])
    for n in ("rx", "ry", "rz"):
        v = getattr(r, n)
        dataset(rg, n, np.nan if v is None else float(v), "m", [])


def _expected(hint: Any) -> str:
    if isinstance(hint, type) and issubclass(hint, IntEnum):
        return "one of " + ", ".join(f"{m.value} ({m.name.lower()})" for m in hint)
    return {bool: "true or false", int: "an integer", str: "text"}.get(hint, "a number")


def read_systeminfo(g: h5py.Group, refuse: Callable[[int, str, Any, str], Exception],
                    refuse_rig: Callable[[str, Any, str], Exception]) -> Systeminfo:
    """The stored Systeminfo; a value of another type, outside its table's codes or a unit other
    than its sensor type's is ``refuse(channel, field, value, expected)``, raised, and one of the
    rig's ``refuse_rig(field, value, expected)``."""
    table = g["channels"][()]
    column = {name: i for i, name in enumerate(table.dtype.names or ())}
    # a column added after the file was written is left out: its default
    read = [(f.name, _CHANNEL_HINTS[f.name], column[f.name]) for f in dataclasses.fields(ChannelInfo)
            if f.name in column]
    channels = []
    for k, row in enumerate(table.tolist()):  # Python values: a numpy record's fields cost more to read than the file
        kw = {}
        for name, hint, i in read:
            v = row[i]
            try:
                if isinstance(hint, type) and issubclass(hint, IntEnum):
                    kw[name] = hint(v)
                elif hint is bool:
                    kw[name] = bool(v)
                elif hint is int:
                    kw[name] = operator.index(v)  # not a float, nor a text of digits
                elif hint is str:
                    kw[name] = h5text.text(v)
                elif hint is float:
                    if isinstance(v, bytes | str):  # float() would read a text of digits
                        raise TypeError(v)
                    kw[name] = float(v)
                else:  # float | None
                    kw[name] = None if math.isnan(v) else float(v)
            except (TypeError, ValueError, AttributeError, UnicodeDecodeError):
                raise refuse(k, name, v, _expected(hint)) from None
        ch = ChannelInfo(**kw)
        # the unit odsuite writes for the channel's sensor type: another would be shown, not converted
        if "unit" in column and row[column["unit"]] != ch.unit.encode():
            raise refuse(k, "unit", h5text.readable(row[column["unit"]]), f"{ch.unit!r} (its sensor type's unit)")
        channels.append(ch)
    rig = _read_riginfo(g["rig"], refuse_rig)
    return Systeminfo(channels=channels, rig=rig)


def _read_riginfo(rg: h5py.Group, refuse: Callable[[str, Any, str], Exception]) -> RigInfo:
    """The rig rows of a stored Systeminfo as write_systeminfo writes them: flags, rows of x, y, z
    in m, column indices and rx, ry, rz (NaN: not given)."""
    def stored(n: str, in_attrs: bool) -> Any:
        if n not in (rg.attrs if in_attrs else rg):
            raise refuse(n, "(missing)", "a stored value")
        return rg.attrs[n] if in_attrs else rg[n][()]

    kw: dict[str, Any] = {}
    for n in ("use_in_gcc", "use_in_ag", "plot_from_corner"):
        v = stored(n, True)
        # bool() would take any text or number: 'no' and 7 read as true
        if not (isinstance(v, bool | np.bool_) or (isinstance(v, int | np.integer) and v in (0, 1))):
            raise refuse(n, v, "true or false")
        kw[n] = bool(v)
    for n in ("plate_sizes", "plate_origins"):
        v = stored(n, False)
        if not (isinstance(v, np.ndarray) and v.dtype.kind in "fiu" and v.ndim == 2 and v.shape[1] == 3
                and np.all(np.isfinite(v))):
            raise refuse(n, v, "rows of 3 finite numbers (x, y, z in m)")
        kw[n] = [tuple(float(x) for x in row) for row in v]
    for n in ("coordinate_columns", "nine_channels"):
        v = stored(n, False)
        if not (isinstance(v, np.ndarray) and v.dtype.kind in "iu" and v.ndim == 1):
            raise refuse(n, v, "a list of whole column numbers")
        kw[n] = [int(x) for x in v]
    for n in ("rx", "ry", "rz"):
        v = stored(n, False)
        if not (isinstance(v, float | np.floating | np.integer) and not isinstance(v, bool | np.bool_)
                and not np.isinf(v)):
            raise refuse(n, v, "a finite number (m) or NaN (not given)")
        kw[n] = None if math.isnan(v) else float(v)
    return RigInfo(**kw)


# ----------------------------------------------------------------------------- rig, revisions, root


def rig_to_dict(rig: Rig) -> dict[str, Any]:
    """The parsed-TOML form of a rig built in code (``rig_from_dict`` reads it back)."""

    def vec(a: Any) -> list:
        return np.asarray(a, dtype=float).tolist()

    bodies = []
    for b in rig.bodies:
        d: dict[str, Any] = {"name": b.name, "com": vec(b.com)}
        if b.mass is not None:
            d["mass"] = b.mass
            d["inertia"] = vec(b.inertia)
        if b.plate is not None:
            d["plate"] = {"size": vec(b.plate.size), "corner": vec(b.plate.corner)}
        if b.nine_sensor_set is not None:
            n = b.nine_sensor_set
            d["nine_sensor_set"] = {"corner": vec(n.corner), "rx": n.rx, "ry": n.ry, "rz": n.rz,
                                    "sensors": dict(n.sensors)}
        if b.solver is not None:
            d["solver"] = b.solver
        if tuple(b.dofs) != COORDINATES:
            d["dofs"] = list(b.dofs)
        bodies.append(d)
    sensors = []
    for s in rig.sensors:
        d = {"name": s.name, "channel": s.channel, "sign": int(s.sign), "kind": s.kind, "serial": s.serial}
        if s.body is not None:  # a hammer's force sensor has no body, position or axis
            d.update(body=s.body, position=vec(s.position), axis=vec(s.axis))
        if s.sensitivity is not None:
            d["sensitivity"] = s.sensitivity
        if s.group:
            d["group"] = s.group
        if s.uff_node is not None:
            d["uff_node"] = s.uff_node
        if s.name in rig.processing_tables:
            d["processing"] = rig.processing_tables[s.name]
        sensors.append(d)
    springs = [{"name": s.name, "body": s.body, "other": s.other or "ground", "position": vec(s.position),
                "stiffness": vec(s.stiffness), "damping": vec(s.damping), "rot_stiffness": vec(s.rot_stiffness),
                "rot_damping": vec(s.rot_damping), "group": s.group} for s in rig.springs]
    out: dict[str, Any] = {"name": rig.name, "description": rig.description, "frame": rig.frame,
                           "channel_count": rig.channel_count, "bodies": bodies, "springs": springs,
                           "sensors": sensors,
                           **rig.extra}
    if rig.force_channel is not None:
        out["force_channel"] = rig.force_channel
    if rig.default_model is not None:
        out["default_model"] = rig.default_model
    if rig.systeminfo_file is not None:
        out["systeminfo"] = Path(rig.systeminfo_file).name  # its text is kept beside (write_rig)
    if "" in rig.processing_tables:
        out["processing"] = rig.processing_tables[""]
    out["up"] = vec(rig.up)
    return out


def write_rig(f: h5py.File, rig: Rig) -> None:
    """The rig as parsed (JSON: every sensor one channel of a single-axis kind), so that the project
    reads back without the plugins whose sensor kinds the rig file named; the file's own text is
    kept beside it."""
    g = typed_group(f, "rig", "rig")
    from_file = rig.source is not None and Path(rig.source).is_file()
    # the rig's .CTR, read once as the project is made: the project keeps its text and never reads the path again
    ctr = rig.systeminfo_text
    if ctr is None and rig.systeminfo_file is not None:
        ctr = read_text(rig.systeminfo_file, "Systeminfo (.CTR)")
        with warnings.catch_warnings():  # its codes are checked as every recording reads them
            warnings.simplefilter("ignore")
            parse_ctr(ctr, source=rig.systeminfo_file)  # a file that is no .CTR refused now, not at each acquire
    h5text.set_attrs(g, {"name": rig.name, "definition": to_json(f"rig {rig.name!r}", rig_to_dict(rig)),
                         "definition_format": "json", "source": str(rig.source) if from_file else "",
                         "source_text": Path(rig.source).read_text(encoding="utf-8") if from_file else "",
                         "systeminfo_text": ctr or ""})


def write_revision(f: h5py.File, n: int, model: str | None, parent: int | None, texts: dict[str, str]) -> None:
    """Model revision ``n`` (effects, parameters, metrics as JSON text), made current."""
    if "models" not in f:
        typed_group(typed_group(f, "models", "models"), "revisions", "model_revisions", track_order=True)
    g = typed_group(f["models"]["revisions"], str(n), "model_revision")
    h5text.set_attrs(g, {"model": model or "", "parent": -1 if parent is None else int(parent),
                         "created": now(), **texts})
    f["models"].attrs["current_revision"] = n


def write_skeleton(f: h5py.File, rig: Rig | None) -> None:
    """The root of a new project: file attributes, /experiments and, with a rig, /rig and model
    revision 0."""
    created = now()
    h5text.set_attrs(f, {"odsuite_format": FORMAT_NAME, "odsuite_format_version": FORMAT_VERSION,
                         "creator": "odsuite", "creator_version": __version__,
                         "hdf5_version": h5py.version.hdf5_version, "h5py_version": h5py.version.version,
                         "file_time": created, "file_update_time": created, "object_id": str(uuid.uuid4()),
                         "odsuite_type": "project"})
    typed_group(f, "experiments", "experiments", track_order=True)
    if rig is not None:
        write_rig(f, rig)
        write_revision(f, 0, rig.default_model, None, {"effects": "[]", "parameters": "{}", "metrics": "{}"})

