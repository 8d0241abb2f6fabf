"""The odsuite project file (HDF5, schema 1.1.0).

Layout (every group has ``odsuite_type`` and ``object_id``; numeric datasets have ``units``, ``dims``;
all text is fixed-length UTF-8, see ``h5text``: 1.0.0 files stored it variable-length and are
migrated on open)::

    /                         odsuite_format="odsuite.project", odsuite_format_version="1.1.0",
                              creator, creator_version, hdf5_version, h5py_version, file_time,
                              file_update_time (ISO 8601, tz-aware)
    /rig                      the rig definition the project was created on: attrs name,
                              definition (the TOML source text, or JSON for a rig built in code),
                              definition_format ("toml" | "json"), source (where it was read from)
    /experiments/<name>/      odsuite_type="experiment"
        raw                   float64 volts, samples x channels, chunked, fletcher32, written once
        systeminfo/           odsuite_type="systeminfo"
            channels          compound table, one row per channel, columns named like the fields
                              of ChannelInfo (enums as HDF5 enums, None cut-offs as NaN), plus
                              name and unit; attr units (one per column)
            rig/              RigInfo: plate_sizes, plate_origins, coordinate_columns,
                              nine_channels, rx, ry, rz datasets (NaN = None); booleans as attrs
        attrs: sampling_rate (Hz), pretrigger (samples), rig, force_channel, force_point (m),
               force_direction (unit vector), channel_names, created, source
        derived/<kind>/       odsuite_type="derived", provenance attrs (plugin, plugin_version,
                              parameters JSON, inputs, created)
    /models/                  attr current_revision (-1: none)
        revisions/<n>/        odsuite_type="model_revision": attrs model, effects, parameters,
                              metrics (JSON), parent (-1: none), created

Writes are copy-on-write transactions: the committed file is copied to ``<name>.h5.tmp-<pid>``,
changed there, fsynced and atomically renamed over the project, so a killed process leaves either
the old or the new committed state. One writer at a time holds an flock on ``<name>.h5.lock``.
"""

from __future__ import annotations

import dataclasses
import fcntl
import functools
import inspect
import json
import logging
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import tomllib
import typing
import uuid
import weakref
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime, timezone
from enum import IntEnum
from pathlib import Path
from typing import IO, Any

import h5py
import numpy as np

from odsuite.core import errors, h5text, migrations
from odsuite.core.errors import (
    ConfigError,
    DimensionError,
    NotAProjectError,
    OdsuiteError,
    ProjectFileError,
    ProjectLockedError,
    ProjectVersionError,
    SchemaError,
)
from odsuite.core.rig import Rig, load_rig, rig_from_dict
from odsuite.core.systeminfo import ChannelInfo, RigInfo, Systeminfo

FORMAT_NAME = "odsuite.project"
FORMAT_VERSION = "1.1.0"
#: Object headers that hold attributes over 64 KiB (dense attribute storage), for every object a
#: write creates: fixed-length text is stored in the header itself.
LIBVER = ("v110", "v110")

#: Tests set this to a crash-point name (see ``_crash_point``) to SIGKILL the writer there.
CRASH_ENV = "ODSUITE_TEST_CRASH_AT"
#: Target size of one raw-data chunk (the unit of checksumming and of partial reads).
CHUNK_BYTES = 1 << 20

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Excitation:
    """Where and how the hammer hit: force channel, point (m, from the platform's centre of mass,
    platform axes) and unit direction."""

    force_channel: int
    point: np.ndarray
    direction: np.ndarray


@dataclass(frozen=True)
class DerivedArray:
    """An array to store in a derived group, with its SI units and dimension names."""

    data: np.ndarray
    units: str
    dims: tuple[str, ...]


# ----------------------------------------------------------------------------- small helpers


def _now() -> str:
    return datetime.now(timezone.utc).astimezone().isoformat(timespec="seconds")


def _crash_point(name: str) -> None:
    """Kill this process here when the test hook asks for it (crash-safety tests)."""
    if os.environ.get(CRASH_ENV) == name:
        os.kill(os.getpid(), signal.SIGKILL)


class _Attrs(Mapping):
    """An object's attributes for reading: a missing or unreadable one is a KeyError naming it
    (HDF5's message for attributes in dense storage does not)."""

    def __init__(self, obj: h5py.HLObject) -> None:
        self._attrs = obj.attrs

    def __getitem__(self, key: str) -> Any:
        try:
            return self._attrs[key]
        except KeyError as exc:
            raise KeyError(f"attribute {key!r}: {_first_line(exc)}") from None

    def __contains__(self, key: object) -> bool:
        return key in self._attrs

    def __iter__(self) -> Iterator[str]:
        return iter(self._attrs)

    def __len__(self) -> int:
        return len(self._attrs)


def _typed_group(parent: h5py.Group, name: str, odsuite_type: str, **kw) -> h5py.Group:
    g = parent.create_group(name, **kw)
    h5text.set_attrs(g, {"odsuite_type": odsuite_type, "object_id": str(uuid.uuid4())})
    return g


def _dataset(parent: h5py.Group, name: str, data: Any, units: str, dims: Iterable[str], **kw) -> h5py.Dataset:
    ds = parent.create_dataset(name, data=data, **kw)
    h5text.set_attrs(ds, {"units": units, "dims": h5text.fixed(list(dims))})
    return ds


def _to_json(where: str, value: Any) -> str:
    def default(o: Any) -> Any:
        if isinstance(o, np.ndarray | np.generic):
            return o.tolist()
        raise TypeError(type(o).__name__)

    try:
        return json.dumps(value, default=default)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{where}: value is not JSON-serialisable ({exc}): {value!r}") from None


def _show(value: Any) -> str:
    """A value for a one-line message (arrays as plain lists)."""
    try:
        return str(np.asarray(value, dtype=float).tolist())
    except (TypeError, ValueError):
        return repr(value)


def _check_name(where: str, what: str, name: Any) -> str:
    if not isinstance(name, str) or not name.strip() or "/" in name or name.startswith("."):
        raise ConfigError(f"{where}: {what} name must be a non-empty string without '/' and not "
                          f"starting with '.', got {name!r}")
    return name


def _fsync_path(path: Path, directory: bool = False) -> None:
    fd = os.open(path, os.O_RDONLY | (os.O_DIRECTORY if directory else 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


# ----------------------------------------------------------------------------- Systeminfo codec

_CHANNEL_HINTS = typing.get_type_hints(ChannelInfo)
_RIGINFO_HINTS = typing.get_type_hints(RigInfo)
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


def _write_systeminfo(parent: h5py.Group, si: Systeminfo, names: list[str]) -> None:
    g = _typed_group(parent, "systeminfo", "systeminfo")
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
    _dataset(g, "channels", table, "", ["channel"])
    g["channels"].attrs["units"] = h5text.fixed(["", ""] + [_CHANNEL_UNITS.get(n, "") for n in fields])

    r = si.rig
    rg = _typed_group(g, "rig", "riginfo")
    h5text.set_attrs(rg, {"use_in_gcc": r.use_in_gcc, "use_in_ag": r.use_in_ag,
                          "plot_from_corner": r.plot_from_corner})
    for n in ("plate_sizes", "plate_origins"):
        _dataset(rg, n, np.asarray(getattr(r, n), dtype=float).reshape(-1, 3), "m", ["plate", "xyz"])
    for n in ("coordinate_columns", "nine_channels"):
        _dataset(rg, n, np.asarray(getattr(r, n), dtype=np.int64).reshape(-1), "1", ["column"])
    for n in ("rx", "ry", "rz"):
        v = getattr(r, n)
        _dataset(rg, n, np.nan if v is None else float(v), "m", [])


def _read_systeminfo(g: h5py.Group) -> Systeminfo:
    table = g["channels"][()]
    present = set(table.dtype.names or ())
    channels = []
    for row in table:
        kw = {}
        for f in dataclasses.fields(ChannelInfo):
            if f.name not in present:  # a column added after the file was written: default
                continue
            hint, v = _CHANNEL_HINTS[f.name], row[f.name]
            if isinstance(hint, type) and issubclass(hint, IntEnum):
                kw[f.name] = hint(int(v))
            elif hint is bool:
                kw[f.name] = bool(v)
            elif hint is int:
                kw[f.name] = int(v)
            elif hint is str:
                kw[f.name] = h5text.text(v)
            elif hint is float:
                kw[f.name] = float(v)
            else:  # float | None
                kw[f.name] = None if np.isnan(v) else float(v)
        channels.append(ChannelInfo(**kw))
    rg = g["rig"]
    opt = {n: (None if np.isnan(rg[n][()]) else float(rg[n][()])) for n in ("rx", "ry", "rz")}
    rig = RigInfo(
        use_in_gcc=bool(_Attrs(rg)["use_in_gcc"]), use_in_ag=bool(_Attrs(rg)["use_in_ag"]),
        plot_from_corner=bool(_Attrs(rg)["plot_from_corner"]),
        plate_sizes=[tuple(float(x) for x in row) for row in rg["plate_sizes"][()]],
        plate_origins=[tuple(float(x) for x in row) for row in rg["plate_origins"][()]],
        coordinate_columns=[int(x) for x in rg["coordinate_columns"][()]],
        nine_channels=[int(x) for x in rg["nine_channels"][()]],
        **opt,
    )
    return Systeminfo(channels=channels, rig=rig)


# ----------------------------------------------------------------------------- rig storage


def _rig_to_dict(rig: Rig) -> dict[str, Any]:
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
        bodies.append(d)
    sensors = []
    for s in rig.sensors:
        d = {"name": s.name, "channel": s.channel, "body": s.body, "position": vec(s.position),
             "axis": vec(s.axis), "sign": int(s.sign), "kind": s.kind, "serial": s.serial}
        if s.sensitivity is not None:
            d["sensitivity"] = s.sensitivity
        sensors.append(d)
    out: dict[str, Any] = {"name": rig.name, "description": rig.description, "frame": rig.frame,
                           "channel_count": rig.channel_count, "bodies": bodies, "sensors": sensors,
                           **rig.extra}
    if rig.force_channel is not None:
        out["force_channel"] = rig.force_channel
    if rig.default_model is not None:
        out["default_model"] = rig.default_model
    if rig.systeminfo_file is not None:
        out["systeminfo"] = str(rig.systeminfo_file)
    return out


def _resolve_rig(rig: Rig | str | Path | None) -> Rig | None:
    if rig is None or isinstance(rig, Rig):
        return rig
    if isinstance(rig, str) and rig.lower() == "none":
        return None
    from odsuite.core.plugins import registries

    rigs = registries().rigs
    if isinstance(rig, str) and rig in rigs:
        return rigs.get(rig)
    if Path(rig).suffix == ".toml" or Path(rig).is_file():
        return load_rig(rig)
    raise ConfigError(f"unknown rig {str(rig)!r}: not a registered rig (known: {', '.join(rigs.names()) or 'none'}) "
                      "and not a .toml rig file")


def _write_rig(f: h5py.File, rig: Rig) -> None:
    g = _typed_group(f, "rig", "rig")
    if rig.source is not None and Path(rig.source).is_file():
        h5text.set_attrs(g, {"name": rig.name, "definition": Path(rig.source).read_text(encoding="utf-8"),
                             "definition_format": "toml", "source": str(rig.source)})
    else:
        h5text.set_attrs(g, {"name": rig.name, "definition": _to_json(f"rig {rig.name!r}", _rig_to_dict(rig)),
                             "definition_format": "json", "source": ""})


# ----------------------------------------------------------------------------- file checks


def _lock_path(path: Path) -> Path:
    return path.with_name(path.name + ".lock")


def _tmp_path(path: Path) -> Path:
    return path.with_name(f"{path.name}.tmp-{os.getpid()}")


#: Lock files this process holds open. A forked child shares their flock, which would outlive a
#: killed parent, so the child closes its copies (closing never unlocks the parent's descriptor).
_HELD_LOCKS: weakref.WeakSet[IO[str]] = weakref.WeakSet()


def _close_inherited_locks() -> None:
    for fh in list(_HELD_LOCKS):
        fh.close()
    _HELD_LOCKS.clear()


os.register_at_fork(after_in_child=_close_inherited_locks)


def _acquire_lock(path: Path) -> IO[str]:
    """Take the writer lock of ``path`` (flock: released by the OS if the process dies)."""
    try:
        fh = open(_lock_path(path), "a+", encoding="utf-8")
    except OSError as exc:
        raise ProjectFileError(f"{path}: cannot create lock file {_lock_path(path)}: {exc.strerror}") from None
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        fh.seek(0)
        holder = fh.read().split()
        fh.close()
        pid = holder[0] if holder else "?"
        host = f" on host {holder[1]}" if len(holder) > 1 and holder[1] != socket.gethostname() else ""
        raise ProjectLockedError(
            f"{path}: project is open in another process (pid {pid}{host}); close it there first"
        ) from None
    fh.truncate(0)
    fh.write(f"{os.getpid()} {socket.gethostname()}\n")
    fh.flush()
    _HELD_LOCKS.add(fh)
    for stale in sorted(path.parent.glob(f"{path.name}.tmp-*")):
        log.warning("%s: removing %s left by an interrupted write", path, stale.name)
        stale.unlink(missing_ok=True)
    return fh


def _release_lock(fh: IO[str]) -> None:
    _HELD_LOCKS.discard(fh)
    if fh.closed:  # closed in a forked child: the lock belongs to the parent
        return
    fh.truncate(0)
    fh.flush()
    fcntl.flock(fh.fileno(), fcntl.LOCK_UN)
    fh.close()


def _open_h5(path: Path, where: Path, mode: str = "r") -> h5py.File:
    try:
        return h5py.File(path, mode, locking=False)
    except OSError as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ProjectFileError(f"{where}: file is truncated or damaged and cannot be opened ({first})") from None


#: What h5py raises on damaged bytes: an object that cannot be found or opened (KeyError), an HDF5
#: read error (OSError, RuntimeError), metadata of the wrong type or shape (ValueError, TypeError,
#: IndexError; JSON and UTF-8 decoding errors are ValueErrors).
_DAMAGE = (KeyError, OSError, RuntimeError, ValueError, TypeError, IndexError)


@contextmanager
def _reading(path: Path, what: str = "") -> Iterator[None]:
    """Turn h5py/HDF5 errors raised while reading ``path`` into a one-line ProjectFileError
    "<path>: project file is damaged (<what>: <error>)"; odsuite's own errors pass unchanged."""
    try:
        yield
    except OdsuiteError:
        raise
    except _DAMAGE as exc:
        where = f"{what}: " if what else ""
        raise ProjectFileError(f"{path}: project file is damaged ({where}{_first_line(exc)})") from None


def _first_line(exc: BaseException) -> str:
    """The first line of an exception's message (a KeyError's without its quotes)."""
    text = exc.args[0] if len(exc.args) == 1 and isinstance(exc.args[0], str) else str(exc)
    return (text.strip().splitlines() or [type(exc).__name__])[0]


def _reads(what: str = "") -> Callable:
    """Decorator: run a reading method of Project/Experiment under :func:`_reading`; ``what`` is
    formatted with the call's arguments, e.g. ``"experiment {experiment!r}"``."""

    def wrap(fn: Callable) -> Callable:
        signature = inspect.signature(fn)

        @functools.wraps(fn)
        def method(self, *args, **kw):
            bound = signature.bind(self, *args, **kw).arguments
            project = self if isinstance(self, Project) else bound.get("project", getattr(self, "_project", None))
            with _reading(project.path, what.format(**bound)):
                return fn(self, *args, **kw)

        return method

    return wrap


#: The one format that kept its text in HDF5's global heap (variable-length strings).
HEAP_TEXT_VERSION = "1.0.0"
#: Seconds a child process may take to migrate a format-1.0.0 file's text.
HEAP_TEXT_TIMEOUT = 60.0


def _migrate_heap_text(copy: str, where: str) -> None:
    """The child process of ``_migrate_heap_text_aside``: migrate ``copy`` to format 1.1.0; any
    error is one line "<class>\t<message>" on stderr and exit code 1."""
    try:
        with h5py.File(copy, "r+", locking=False, libver=LIBVER) as f:
            fmt = f.attrs.get("odsuite_format")
            if fmt is None or h5text.text(fmt) != FORMAT_NAME:
                raise NotAProjectError(f"{where}: HDF5 file without the root attribute "
                                       f"odsuite_format={FORMAT_NAME!r}; not an odsuite project")
            migrations.migrate(f, migrations.MIGRATIONS[HEAP_TEXT_VERSION].to_version, where)
    except Exception as exc:  # noqa: BLE001 - reported to the parent, which names the damage
        print(f"{type(exc).__name__}\t{_first_line(exc)}", file=sys.stderr)
        sys.exit(1)


def _migrate_heap_text_aside(copy: Path, path: Path) -> None:
    """Migrate ``copy`` of the format-1.0.0 project ``path`` to 1.1.0 in a child process that can be
    stopped: damaged heap bytes can send the HDF5 library into an endless loop or crash it."""
    code = "import sys; from odsuite.core.project import _migrate_heap_text; _migrate_heap_text(*sys.argv[1:])"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}  # this very odsuite
    try:
        done = subprocess.run([sys.executable, "-P", "-c", code, str(copy), str(path)], capture_output=True,
                              text=True, timeout=HEAP_TEXT_TIMEOUT, check=False, env=env)
    except subprocess.TimeoutExpired:
        raise ProjectFileError(f"{path}: project file is damaged (reading its format-1.0.0 text did not finish "
                               f"within {HEAP_TEXT_TIMEOUT:g} s)") from None
    if done.returncode == 0:
        return
    kind, _, message = ((done.stderr.strip().splitlines() or [""])[-1]).partition("\t")
    error = getattr(errors, kind, None)
    if done.returncode == 1 and isinstance(error, type) and issubclass(error, OdsuiteError) and message:
        raise error(message)
    if done.returncode < 0:
        raise ProjectFileError(f"{path}: project file is damaged (reading its format-1.0.0 text crashed the HDF5 "
                               f"library with signal {-done.returncode})")
    why = f"{kind}: {message}" if message else kind or f"exit code {done.returncode}"
    raise ProjectFileError(f"{path}: cannot migrate format {HEAP_TEXT_VERSION}, project left unchanged ({why})")


def _has_heap_text(path: Path) -> bool:
    """Whether ``path`` keeps its root text in the global heap (format 1.0.0); reads no heap."""
    with _open_h5(path, path) as f, _reading(path, "root attributes"):
        return "odsuite_format" in f.attrs and h5text.is_variable_text(f.attrs.get_id("odsuite_format").dtype)


def _check_format(path: Path) -> str:
    """Check that ``path`` is an odsuite project this version can read; returns its version
    (format 1.0.0 without reading its text: the migration checks it)."""
    if not path.exists():
        raise ProjectFileError(f"{path}: no such project file")
    if not path.is_file():
        raise ProjectFileError(f"{path}: not a file")
    if not h5py.is_hdf5(path):
        raise NotAProjectError(f"{path}: not an HDF5 file, so not an odsuite project")
    if _has_heap_text(path):
        return HEAP_TEXT_VERSION  # read in a child process, see _migrate_heap_text_aside
    with _open_h5(path, path) as f, _reading(path, "root attributes"):
        fmt = f.attrs.get("odsuite_format")
        version = f.attrs.get("odsuite_format_version")
    if fmt is None or h5text.text(fmt) != FORMAT_NAME:
        raise NotAProjectError(
            f"{path}: HDF5 file without the root attribute odsuite_format={FORMAT_NAME!r} "
            f"(found {None if fmt is None else h5text.text(fmt)!r}); not an odsuite project"
        )
    if version is None:
        raise SchemaError(f"{path}: root attribute odsuite_format_version is missing")
    version = h5text.text(version)
    have, ours = migrations.parse_version(version, str(path)), migrations.parse_version(FORMAT_VERSION)
    if have[0] > ours[0]:
        raise ProjectVersionError(
            f"{path}: project format {version} is newer than the format this odsuite reads "
            f"({FORMAT_VERSION}); upgrade odsuite"
        )
    return version


def _write_revision(f: h5py.File, n: int, model: str | None, parent: int | None, texts: dict[str, str]) -> None:
    """Model revision ``n`` (effects, parameters, metrics as JSON text), made current."""
    if "models" not in f:
        _typed_group(_typed_group(f, "models", "models"), "revisions", "model_revisions", track_order=True)
    g = _typed_group(f["models"]["revisions"], str(n), "model_revision")
    h5text.set_attrs(g, {"model": model or "", "parent": -1 if parent is None else int(parent),
                         "created": _now(), **texts})
    f["models"].attrs["current_revision"] = n


# ----------------------------------------------------------------------------- experiments


class Experiment:
    """Read-only view of one stored experiment (raw data are read lazily)."""

    name: str
    sampling_rate: float  # Hz
    pretrigger: int  # samples before the trigger
    systeminfo: Systeminfo
    excitation: Excitation | None
    rig_name: str | None
    channel_names: list[str]
    n_samples: int
    n_channels: int

    @_reads("experiment {name!r}")
    def __init__(self, project: Project, name: str) -> None:
        self._project = project
        self.name = name
        g = self._group()
        a = _Attrs(g)
        self.object_id = h5text.text(a["object_id"])
        self.sampling_rate = float(a["sampling_rate"])
        self.pretrigger = int(a["pretrigger"])
        self.created = h5text.text(a["created"])
        self.source = h5text.text(a.get("source", ""))
        self.rig_name = h5text.text(a["rig"]) or None
        self.channel_names = [h5text.text(n) for n in a["channel_names"]]
        self.n_samples, self.n_channels = g["raw"].shape
        self.excitation = None
        if "force_channel" in a:
            self.excitation = Excitation(int(a["force_channel"]), np.asarray(a["force_point"], dtype=float),
                                         np.asarray(a["force_direction"], dtype=float))
        self.systeminfo = _read_systeminfo(g["systeminfo"])

    def _group(self) -> h5py.Group:
        return self._project._file()["experiments"][self.name]

    def channel_index(self, channel: int | str) -> int:
        """Index of a channel given by index or name."""
        if isinstance(channel, str):
            if channel not in self.channel_names:
                raise ConfigError(f"{self._project.path}: experiment {self.name!r} has no channel {channel!r} "
                                  f"(channels: {', '.join(self.channel_names)})")
            return self.channel_names.index(channel)
        if not 0 <= int(channel) < self.n_channels:
            raise ConfigError(f"{self._project.path}: experiment {self.name!r} has no channel {channel!r} "
                              f"(0..{self.n_channels - 1})")
        return int(channel)

    @_reads("experiment {self.name!r} raw data")
    def raw(self, start: int = 0, stop: int | None = None, channels=None) -> np.ndarray:
        """Raw volts, samples x channels (a slice of rows and optionally of channels, by index or name)."""
        try:
            block = self._group()["raw"][start:stop]
        except OSError as exc:
            raise ProjectFileError(f"{self._project.path}: experiment {self.name!r}: raw data cannot be read "
                                   f"(corrupted?): {exc}") from None
        if channels is None:
            return block
        if isinstance(channels, int | np.integer | str):
            return block[:, self.channel_index(channels)]
        return block[:, [self.channel_index(c) for c in channels]]

    def __repr__(self) -> str:
        return (f"Experiment({self.name!r}, {self.n_samples} samples x {self.n_channels} channels, "
                f"{self.sampling_rate:g} Hz)")


def _check_chunk(where: str, chunk: Any, n_channels: int | None, row0: int, names: list[str] | None) -> np.ndarray:
    """Validate a block of raw volts: 2-D, real numbers, finite, the expected channel count."""
    arr = np.asarray(chunk)
    if arr.dtype.kind not in "iuf":
        raise ConfigError(f"{where}: raw data must be real numbers (volts), got dtype {arr.dtype}")
    if arr.ndim != 2:
        raise DimensionError(f"{where}: raw data must be 2-D (samples x channels), got shape {arr.shape}")
    if n_channels is not None and arr.shape[1] != n_channels:
        raise DimensionError(f"{where}: raw chunk at sample {row0} has {arr.shape[1]} channels, "
                             f"expected {n_channels}")
    arr = arr.astype(np.float64, copy=False)
    bad = ~np.isfinite(arr)
    if bad.any():
        i, c = np.argwhere(bad)[0]
        label = f" ({names[c]})" if names else ""
        raise ConfigError(f"{where}: raw sample {row0 + i}, channel {c}{label} is {float(arr[i, c])}; "
                          "raw volts must be finite numbers")
    return arr


class DerivedWriter:
    """Creates the datasets of a derived group being written (see ``Project.derived_writer``)."""

    def __init__(self, group: h5py.Group, where: str) -> None:
        self._group = group
        self._where = where
        #: Extra attributes of the group (dicts and None are stored as JSON text).
        self.attrs: dict[str, Any] = {}

    def create(self, name: str, shape: tuple[int, ...], dtype: Any, units: str,
               dims: tuple[str, ...] | list[str]) -> h5py.Dataset:
        """A new dataset ``name``; write it with ``ds[a:b] = x``."""
        _check_name(self._where, "dataset", name)
        shape = tuple(int(n) for n in shape)
        if not isinstance(units, str):
            raise ConfigError(f"{self._where}: dataset {name!r}: units must be a string, got {units!r}")
        if len(dims) != len(shape):
            raise DimensionError(f"{self._where}: dataset {name!r}: {len(dims)} dims {tuple(dims)} "
                                 f"for a {len(shape)}-D shape {shape}")
        if name in self._group:
            raise ConfigError(f"{self._where}: dataset {name!r} created twice")
        dtype = np.dtype(dtype)
        if dtype.kind not in "biufc":
            raise ConfigError(f"{self._where}: dataset {name!r}: derived datasets hold numbers, got dtype "
                              f"{dtype} (put text in the group's attrs)")
        return _dataset(self._group, name, None, units, dims, shape=shape, dtype=dtype,
                        fletcher32=bool(np.prod(shape)))


# ----------------------------------------------------------------------------- the project


class Project:
    """An open project file. Use ``create_project``/``open_project``; close it (or use ``with``)."""

    path: Path
    mode: str
    rig: Rig | None  # None for projects created with --rig none

    def __init__(self, path: Path, mode: str, lock: IO[str] | None, read_path: Path | None = None) -> None:
        self.path = path
        self.mode = mode
        self._lock = lock
        self._read_path = read_path or path  # a private migrated copy for old versions in read mode
        self._h5: h5py.File | None = _open_h5(self._read_path, path)
        self._tx: h5py.File | None = None
        self._rig_cache: tuple[Rig | None] | None = None

    # -- plumbing

    def _file(self) -> h5py.File:
        if self._tx is not None:
            return self._tx
        if self._h5 is None:
            raise ProjectFileError(f"{self.path}: project is closed")
        return self._h5

    def _require_writable(self) -> None:
        if self.mode != "a" or self._lock is None:
            raise ProjectFileError(f"{self.path}: project is open read-only; open it with mode 'a' to change it")

    @contextmanager
    def transaction(self) -> Iterator[Project]:
        """Group several writes into one atomic commit (one file copy). Nested calls join the outer one.

        Everything written inside becomes visible together when the outermost block exits without
        error; on error or a crash nothing of it is kept.
        """
        self._require_writable()
        if self._tx is not None:
            yield self
            return
        tmp = _tmp_path(self.path)
        try:
            shutil.copyfile(self.path, tmp)
            _crash_point("copied")
            self._tx = h5py.File(tmp, "r+", locking=False, libver=LIBVER)
        except OSError as exc:
            self._tx = None
            tmp.unlink(missing_ok=True)
            raise ProjectFileError(f"{self.path}: cannot start a write ({exc})") from None
        try:
            yield self
            h5text.set_attrs(self._tx, {"file_update_time": _now()})
            self._tx.close()
            _crash_point("written")
            _fsync_path(tmp)
            _crash_point("synced")
            os.replace(tmp, self.path)
            _crash_point("replaced")
            _fsync_path(self.path.parent, directory=True)
        except BaseException as exc:
            if self._tx:
                self._tx.close()
            tmp.unlink(missing_ok=True)
            if isinstance(exc, OSError) and not isinstance(exc, OdsuiteError):  # e.g. disk full
                raise ProjectFileError(f"{self.path}: write failed, project left unchanged: {exc}") from exc
            raise
        finally:
            self._tx = None
        self._h5.close()
        self._h5 = _open_h5(self.path, self.path)

    def __enter__(self) -> Project:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the file and release the writer lock (idempotent)."""
        if self._h5 is not None:
            self._h5.close()
            self._h5 = None
        if self._read_path != self.path:
            self._read_path.unlink(missing_ok=True)
            self._read_path = self.path
        if self._lock is not None:
            _release_lock(self._lock)
            self._lock = None

    def __repr__(self) -> str:
        return f"Project({str(self.path)!r}, mode={self.mode!r})"

    # -- file-level information

    @property
    @_reads("/rig")
    def rig(self) -> Rig | None:
        if self._rig_cache is None:
            f = self._file()
            rig = None
            if "rig" in f:
                a = _Attrs(f["rig"])
                text, fmt = h5text.text(a["definition"]), h5text.text(a["definition_format"])
                try:
                    data = tomllib.loads(text) if fmt == "toml" else json.loads(text)
                except (tomllib.TOMLDecodeError, json.JSONDecodeError) as exc:
                    raise SchemaError(f"{self.path}: /rig definition is not valid {fmt}: {exc}") from None
                source = h5text.text(a.get("source", ""))
                rig = rig_from_dict(data, source=Path(source) if source else None)
            self._rig_cache = (rig,)
        return self._rig_cache[0]

    @property
    @_reads("root attributes")
    def format_version(self) -> str:
        return h5text.text(_Attrs(self._file())["odsuite_format_version"])

    # -- experiments

    @_reads("/experiments")
    def experiment_names(self) -> list[str]:
        """Names of the stored experiments, in the order they were added."""
        return list(self._file()["experiments"].keys())

    @_reads("experiment {name!r}")
    def experiment(self, name: str) -> Experiment:
        if name not in self._file()["experiments"]:
            known = ", ".join(self.experiment_names()) or "none"
            raise ConfigError(f"{self.path}: no experiment named {name!r} (experiments: {known})")
        return Experiment(self, name)

    def _default_channel_names(self, n: int) -> list[str]:
        rig = self.rig
        names = []
        for i in range(n):
            sensor = rig.sensor_on_channel(i) if rig else None
            if sensor is not None:
                names.append(sensor.name)
            elif rig is not None and rig.force_channel == i:
                names.append("force")
            else:
                names.append(f"ch{i}")
        return names

    def add_experiment(
        self,
        name: str,
        raw: np.ndarray | Iterator[np.ndarray],
        *,
        sampling_rate: float,
        systeminfo: Systeminfo,
        excitation: Excitation | None,
        pretrigger: int = 0,
        n_samples: int | None = None,
        source: str = "",
        channel_names: list[str] | None = None,
    ) -> Experiment:
        """Add an experiment atomically. ``raw`` is an array (samples x channels) or an iterator of
        row-chunks (then ``n_samples`` may be given); a crash at any point leaves no half experiment."""
        self._require_writable()
        where = f"{self.path}: experiment {name!r}"
        _check_name(str(self.path), "experiment", name)
        if name in self._file()["experiments"]:
            raise ConfigError(f"{where} already exists; choose another name")
        if isinstance(sampling_rate, bool) or not isinstance(sampling_rate, int | float | np.number) \
                or not np.isfinite(sampling_rate) or sampling_rate <= 0:
            raise ConfigError(f"{where}: sampling_rate must be a finite number > 0 Hz, got {sampling_rate!r}")
        if not isinstance(pretrigger, int | np.integer) or pretrigger < 0:
            raise ConfigError(f"{where}: pretrigger must be an integer >= 0 samples, got {pretrigger!r}")
        if n_samples is not None and (not isinstance(n_samples, int | np.integer) or n_samples <= 0):
            raise ConfigError(f"{where}: n_samples must be an integer > 0, got {n_samples!r}")
        if not isinstance(systeminfo, Systeminfo):
            raise ConfigError(f"{where}: systeminfo must be a Systeminfo, got {type(systeminfo).__name__}")

        streamed = not isinstance(raw, np.ndarray | list | tuple)
        chunks: Iterator[Any] = iter(raw) if streamed else iter([raw])
        first = next(chunks, None)
        if first is None:
            raise DimensionError(f"{where}: raw data are empty (no chunks)")
        first = np.asarray(first)
        n_ch = first.shape[1] if first.ndim == 2 else 0
        names = self._default_channel_names(n_ch) if channel_names is None else [str(c) for c in channel_names]
        first = _check_chunk(where, first, None, 0, names if len(names) == n_ch else None)
        if not streamed:
            n_samples = first.shape[0]
        if first.shape[0] == 0 and not streamed:
            raise DimensionError(f"{where}: raw data have no samples (shape {first.shape})")
        if len(systeminfo.channels) != n_ch:
            raise DimensionError(f"{where}: systeminfo describes {len(systeminfo.channels)} channels but the "
                                 f"raw data have {n_ch}")
        if len(names) != n_ch or len(set(names)) != n_ch:
            raise DimensionError(f"{where}: channel_names must be {n_ch} distinct names, got {channel_names!r}")
        exc_attrs = self._excitation_attrs(where, excitation, n_ch)

        with self.transaction():
            experiments = self._tx["experiments"]
            g = _typed_group(experiments, name, "experiment")
            try:
                self._write_raw(g, where, first, chunks, n_ch, n_samples, names)
                for k, v in {"sampling_rate": float(sampling_rate), "sampling_rate_units": "Hz",
                             "pretrigger": int(pretrigger), "rig": self.rig.name if self.rig else "",
                             "channel_names": h5text.fixed(names), "created": _now(), "source": source,
                             **exc_attrs}.items():
                    h5text.set_attrs(g, {k: v})
                _write_systeminfo(g, systeminfo, names)
            except BaseException:
                del experiments[name]  # keep an enclosing transaction free of a half experiment
                raise
        return Experiment(self, name)

    @staticmethod
    def _excitation_attrs(where: str, excitation: Excitation | None, n_ch: int) -> dict[str, Any]:
        if excitation is None:
            return {}
        fc = excitation.force_channel
        if isinstance(fc, bool) or not isinstance(fc, int | np.integer) or not 0 <= fc < n_ch:
            raise ConfigError(f"{where}: force channel must be a channel index 0..{n_ch - 1}, got {fc!r}")
        point = np.asarray(excitation.point, dtype=float)
        if point.shape != (3,) or not np.all(np.isfinite(point)):
            raise ConfigError(f"{where}: force point must be 3 finite numbers (m), got {_show(excitation.point)}")
        direction = np.asarray(excitation.direction, dtype=float)
        norm = np.linalg.norm(direction) if direction.shape == (3,) else np.nan
        if not np.isfinite(norm) or norm == 0:
            raise ConfigError(f"{where}: force direction must be a non-zero vector of 3 finite numbers, "
                              f"got {_show(excitation.direction)}")
        return {"force_channel": int(fc), "force_point": point, "force_point_units": "m",
                "force_direction": direction / norm}

    @staticmethod
    def _write_raw(g: h5py.Group, where: str, first: np.ndarray, rest: Iterator[Any], n_ch: int,
                   n_samples: int | None, names: list[str]) -> None:
        rows = max(1, CHUNK_BYTES // (8 * n_ch))
        if n_samples is not None:
            rows = min(rows, n_samples)
        ds = g.create_dataset("raw", shape=(n_samples or 0, n_ch), maxshape=(n_samples, n_ch),
                              chunks=(rows, n_ch), dtype=np.float64, fletcher32=True)
        h5text.set_attrs(ds, {"units": "V", "dims": h5text.fixed(["sample", "channel"]),
                              "channel_names": h5text.fixed(names)})
        row, k, chunk = 0, 0, first
        while chunk is not None:
            if k:
                chunk = _check_chunk(where, chunk, n_ch, row, names)
            end = row + chunk.shape[0]
            if n_samples is None:
                ds.resize(end, axis=0)
            elif end > n_samples:
                raise DimensionError(f"{where}: raw chunks hold more than n_samples={n_samples} rows")
            ds[row:end] = chunk
            row, k = end, k + 1
            _crash_point(f"chunk-{k}")
            chunk = next(rest, None)
        if row == 0 or (n_samples is not None and row != n_samples):
            raise DimensionError(f"{where}: raw chunks hold {row} rows, expected "
                                 f"{n_samples if n_samples is not None else 'at least 1'}")

    # -- derived data

    def _derived_group(self, experiment: str, kind: str) -> h5py.Group:
        g = self.experiment(experiment)._group()
        if "derived" not in g or kind not in g["derived"]:
            raise ConfigError(f"{self.path}: experiment {experiment!r} has no derived data {kind!r} "
                              f"(has: {', '.join(self.derived_kinds(experiment)) or 'none'})")
        return g["derived"][kind]

    def write_derived(
        self,
        experiment: str,
        kind: str,
        arrays: Mapping[str, DerivedArray],
        *,
        provenance: Mapping[str, Any],
        attrs: Mapping[str, Any] | None = None,
    ) -> None:
        """Store (or replace, atomically) the derived group ``kind`` of an experiment.

        ``provenance`` holds ``plugin`` (required), ``version``, ``parameters`` (JSON-able) and
        ``inputs`` (object ids; the experiment's id when omitted).
        """
        with self.derived_writer(experiment, kind, provenance=provenance) as w:
            for name, a in arrays.items():
                if not isinstance(a, DerivedArray):
                    raise ConfigError(f"{self.path}: derived {kind!r} array {name!r} must be a DerivedArray")
                data = np.asarray(a.data)
                w.create(name, data.shape, data.dtype, a.units, a.dims)[...] = data
            w.attrs.update(attrs or {})

    @contextmanager
    def derived_writer(self, experiment: str, kind: str, *, provenance: Mapping[str, Any]):
        """Stream a large derived group: yields a writer with
        ``create(name, shape, dtype, units, dims) -> h5py-like dataset`` supporting ``ds[a:b] = x``.
        The group becomes visible only when the block exits without error."""
        self._require_writable()
        where = f"{self.path}: experiment {experiment!r} derived {kind!r}"
        _check_name(where, "derived", kind)
        exp = self.experiment(experiment)
        plugin = provenance.get("plugin")
        if not isinstance(plugin, str) or not plugin:
            raise ConfigError(f"{where}: provenance needs the plugin name, got {plugin!r}")
        params = _to_json(f"{where} provenance parameters", provenance.get("parameters", {}))
        inputs = list(provenance.get("inputs") or [exp.object_id])
        with self.transaction():
            eg = self._tx["experiments"][experiment]
            derived = eg["derived"] if "derived" in eg else _typed_group(eg, "derived", "derived_set")
            partial = "." + kind  # written aside so an enclosing transaction keeps the old group on error
            if partial in derived:
                del derived[partial]
            g = _typed_group(derived, partial, "derived")
            h5text.set_attrs(g, {"plugin": plugin, "plugin_version": str(provenance.get("version", "")),
                                 "parameters": params, "inputs": h5text.fixed([str(i) for i in inputs]),
                                 "created": _now()})
            writer = DerivedWriter(g, where)
            try:
                yield writer
                h5text.set_attrs(g, {k: _to_json(f"{where} attr {k!r}", v) if isinstance(v, dict | None) else v
                                     for k, v in writer.attrs.items()})
            except BaseException:
                del derived[partial]
                raise
            if kind in derived:
                del derived[kind]
            derived.move(partial, kind)

    @_reads("experiment {experiment!r} derived {kind!r}")
    def read_derived(self, experiment: str, kind: str) -> dict[str, np.ndarray]:
        """Every dataset of a derived group, read into memory."""
        g = self._derived_group(experiment, kind)
        try:
            return {n: ds[()] for n, ds in g.items()}
        except OSError as exc:
            raise ProjectFileError(f"{self.path}: experiment {experiment!r} derived {kind!r} cannot be read "
                                   f"(corrupted?): {exc}") from None

    @_reads("experiment {experiment!r} derived {kind!r}")
    def derived_info(self, experiment: str, kind: str) -> dict[str, Any]:
        """Provenance, extra attributes, units and dims of a derived group."""
        g = self._derived_group(experiment, kind)
        a = dict(g.attrs)
        prov = {"plugin": h5text.text(a.pop("plugin")), "version": h5text.text(a.pop("plugin_version")),
                "parameters": json.loads(h5text.text(a.pop("parameters"))),
                "inputs": [h5text.text(i) for i in a.pop("inputs")], "created": h5text.text(a.pop("created"))}
        object_id = h5text.text(a.pop("object_id"))
        a.pop("odsuite_type")
        return {"object_id": object_id, "provenance": prov,
                "attrs": {k: h5text.readable(v) for k, v in a.items()},
                "units": {n: h5text.text(_Attrs(ds)["units"]) for n, ds in g.items()},
                "dims": {n: tuple(h5text.text(d) for d in _Attrs(ds)["dims"]) for n, ds in g.items()}}

    @_reads("experiment {experiment!r} derived")
    def derived_kinds(self, experiment: str) -> list[str]:
        g = self.experiment(experiment)._group()
        return [k for k in g["derived"] if not k.startswith(".")] if "derived" in g else []

    # -- model revisions

    def _revisions(self) -> h5py.Group | None:
        f = self._file()
        return f["models"]["revisions"] if "models" in f else None

    def add_model_revision(self, effects: list[dict], parameters: dict, metrics: dict,
                           parent: int | None, *, model: str | None = None) -> int:
        """Store a new model revision and make it current; returns its number.

        ``model`` defaults to the parent's model (or the rig's default model without a parent).
        """
        self._require_writable()
        where = f"{self.path}: model revision"
        known = {r["revision"]: r for r in self.model_revisions()}
        if parent is not None and parent not in known:
            raise ConfigError(f"{where}: parent revision {parent!r} does not exist "
                              f"(revisions: {sorted(known) or 'none'})")
        if model is None:
            model = known[parent]["model"] if parent is not None else (self.rig.default_model if self.rig else None)
        texts = {k: _to_json(f"{where} {k}", v) for k, v in
                 (("effects", list(effects)), ("parameters", dict(parameters)), ("metrics", dict(metrics)))}
        n = max(known, default=-1) + 1
        with self.transaction():
            _write_revision(self._tx, n, model, parent, texts)
        return n

    @_reads("model revisions")
    def model_revisions(self) -> list[dict]:
        """Every revision as a dict: revision, model, effects, parameters, metrics, parent, created."""
        revs = self._revisions()
        if revs is None:
            return []
        out = []
        for key, g in revs.items():
            a = _Attrs(g)
            parent = int(a["parent"])
            out.append({"revision": int(key), "model": h5text.text(a["model"]) or None,
                        "effects": json.loads(h5text.text(a["effects"])),
                        "parameters": json.loads(h5text.text(a["parameters"])),
                        "metrics": json.loads(h5text.text(a["metrics"])),
                        "parent": None if parent < 0 else parent, "created": h5text.text(a["created"]),
                        "object_id": h5text.text(a["object_id"])})
        return sorted(out, key=lambda r: r["revision"])

    @property
    @_reads("/models")
    def current_revision(self) -> int | None:
        f = self._file()
        n = int(f["models"].attrs.get("current_revision", -1)) if "models" in f else -1
        return None if n < 0 else n

    def set_current_revision(self, n: int) -> None:
        self._require_writable()
        revs = self._revisions()
        if revs is None or str(n) not in revs:
            raise ConfigError(f"{self.path}: no model revision {n!r} "
                              f"(revisions: {[r['revision'] for r in self.model_revisions()] or 'none'})")
        with self.transaction():
            self._tx["models"].attrs["current_revision"] = int(n)

    def set_revision_metrics(self, n: int, metrics: Mapping[str, Any]) -> None:
        """Merge ``metrics`` (e.g. the comparison error) into revision ``n``'s metrics."""
        self._require_writable()
        revs = {r["revision"]: r for r in self.model_revisions()}
        if n not in revs:
            raise ConfigError(f"{self.path}: no model revision {n!r} (revisions: {sorted(revs) or 'none'})")
        text = _to_json(f"{self.path}: model revision {n} metrics", {**revs[n]["metrics"], **metrics})
        with self.transaction():
            h5text.set_attrs(self._tx["models"]["revisions"][str(n)], {"metrics": text})

    # -- checks and summaries

    @_reads()
    def verify(self) -> dict[str, int]:
        """Read every checksummed dataset; ProjectFileError names the first corrupted experiment.

        Returns the number of datasets checked per experiment.
        """
        checked: dict[str, int] = {}
        for name in self.experiment_names():
            datasets: list[h5py.Dataset] = []
            self._file()["experiments"][name].visititems(
                lambda _n, o: datasets.append(o) if isinstance(o, h5py.Dataset) and o.fletcher32 else None)
            for ds in datasets:
                try:
                    for sel in ds.iter_chunks():
                        ds[sel]
                except OSError as exc:
                    raise ProjectFileError(f"{self.path}: experiment {name!r}: dataset {ds.name} is corrupted "
                                           f"(checksum failed: {str(exc).splitlines()[0]})") from None
            checked[name] = len(datasets)
        return checked

    @_reads()
    def info(self) -> dict[str, Any]:
        """A plain-dict summary: file attributes, rig, revisions and per experiment: channels,
        sampling rate, samples, duration, peak |volts| per channel and clipped channels.

        A channel is clipped when a sample lies within (limit_high - limit_low) / 2048 (one step of
        a 12-bit converter) of its Systeminfo DAQ limits.
        """
        a = _Attrs(self._file())
        out: dict[str, Any] = {
            "path": str(self.path), "format_version": h5text.text(a["odsuite_format_version"]),
            "creator": f"{h5text.text(a['creator'])} {h5text.text(a['creator_version'])}",
            "file_time": h5text.text(a["file_time"]), "file_update_time": h5text.text(a.get("file_update_time", "")),
            "rig": self.rig.name if self.rig else None, "experiments": {},
            "revisions": len(self.model_revisions()), "current_revision": self.current_revision,
        }
        for name in self.experiment_names():
            e = self.experiment(name)
            hi = np.array([c.limit_high for c in e.systeminfo.channels])
            lo = np.array([c.limit_low for c in e.systeminfo.channels])
            tol = (hi - lo) / 2048
            peak = np.zeros(e.n_channels)
            clipped = np.zeros(e.n_channels, dtype=np.int64)
            step = max(1, 8 * CHUNK_BYTES // (8 * e.n_channels))
            for start in range(0, e.n_samples, step):
                block = e.raw(start, start + step)
                peak = np.maximum(peak, np.abs(block).max(axis=0))
                clipped += ((block >= hi - tol) | (block <= lo + tol)).sum(axis=0)
            out["experiments"][name] = {
                "channels": e.channel_names, "sampling_rate": e.sampling_rate, "n_samples": e.n_samples,
                "duration": e.n_samples / e.sampling_rate, "pretrigger": e.pretrigger,
                "peak_volts": dict(zip(e.channel_names, peak.tolist(), strict=True)),
                "clipped": [n for n, c in zip(e.channel_names, clipped, strict=True) if c],
                "clipped_samples": {n: int(c) for n, c in zip(e.channel_names, clipped, strict=True) if c},
                "excitation": None if e.excitation is None else {
                    "force_channel": e.excitation.force_channel, "point": e.excitation.point.tolist(),
                    "direction": e.excitation.direction.tolist()},
                "derived": self.derived_kinds(name), "source": e.source, "created": e.created,
            }
        return out


# ----------------------------------------------------------------------------- entry points


def _write_skeleton(f: h5py.File, rig: Rig | None) -> None:
    from odsuite.core.version import __version__

    now = _now()
    h5text.set_attrs(f, {"odsuite_format": FORMAT_NAME, "odsuite_format_version": FORMAT_VERSION,
                         "creator": "odsuite", "creator_version": __version__,
                         "hdf5_version": h5py.version.hdf5_version, "h5py_version": h5py.version.version,
                         "file_time": now, "file_update_time": now, "object_id": str(uuid.uuid4()),
                         "odsuite_type": "project"})
    _typed_group(f, "experiments", "experiments", track_order=True)
    if rig is not None:
        _write_rig(f, rig)
        _write_revision(f, 0, rig.default_model, None, {"effects": "[]", "parameters": "{}", "metrics": "{}"})


def create_project(path: str | Path, rig: Rig | str | None = "thesis-dynamometer") -> Project:
    """Create a new project file (refuses to overwrite) and return it open for writing.

    ``rig`` is a Rig, a registered rig name, a path to a .toml rig file, or None/"none". With a rig,
    model revision 0 (no effects, the rig's default model) is created too.
    """
    path = Path(path)
    rig = _resolve_rig(rig)
    if not path.parent.is_dir():
        raise ProjectFileError(f"{path}: directory {path.parent} does not exist")
    lock = _acquire_lock(path)
    try:
        if path.exists():
            raise ProjectFileError(f"{path}: file already exists; choose another name or delete it first")
        tmp = _tmp_path(path)
        try:
            with h5py.File(tmp, "w", libver=LIBVER, fs_strategy="fsm", fs_persist=True,
                           track_order=True, locking=False) as f:
                _write_skeleton(f, rig)
            _fsync_path(tmp)
            os.replace(tmp, path)
            _fsync_path(path.parent, directory=True)
        finally:
            tmp.unlink(missing_ok=True)
        project = Project(path, "a", lock)
    except BaseException:
        _release_lock(lock)
        raise
    return project


def open_project(path: str | Path, mode: str = "r") -> Project:
    """Open a project for reading ("r") or reading and writing ("a"). Usable as a context manager.

    Readers never block and see only committed states; a second writer gets ProjectLockedError.
    Files of an older format version are migrated on read (a private copy in read mode; the
    project itself, atomically, in write mode).
    """
    path = Path(path)
    if mode not in ("r", "a"):
        raise ConfigError(f"{path}: open mode must be 'r' or 'a', got {mode!r}")
    if mode == "r":
        version = _check_format(path)
        if migrations.parse_version(version) >= migrations.parse_version(FORMAT_VERSION):
            return Project(path, "r", None)
        migrations.migration_path(version, FORMAT_VERSION, str(path))  # refuse before copying
        fd, tmp_name = tempfile.mkstemp(prefix=path.name + ".", suffix=".migrated.h5")
        os.close(fd)
        tmp = Path(tmp_name)
        try:
            shutil.copyfile(path, tmp)
            _migrate(tmp, path, version)
            return Project(path, "r", None, read_path=tmp)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
    _check_format(path)  # before locking: no lock file beside a file that is not a project
    lock = _acquire_lock(path)
    try:
        version = _check_format(path)
        if migrations.parse_version(version) > migrations.parse_version(FORMAT_VERSION):
            raise ProjectVersionError(f"{path}: project format {version} is newer than {FORMAT_VERSION}: "
                                      "this odsuite can read it but not change it; upgrade odsuite")
        if version != FORMAT_VERSION:
            migrations.migration_path(version, FORMAT_VERSION, str(path))  # refuse before copying
            tmp = _tmp_path(path)
            try:  # a transaction: the migrated copy replaces the project atomically
                shutil.copyfile(path, tmp)
                _migrate(tmp, path, version, updated=True)
                _fsync_path(tmp)
                os.replace(tmp, path)
                _fsync_path(path.parent, directory=True)
            except OSError as exc:
                if isinstance(exc, OdsuiteError):
                    raise
                raise ProjectFileError(f"{path}: migration from format {version} failed, project left "
                                       f"unchanged: {exc}") from exc  # e.g. disk full
            finally:
                tmp.unlink(missing_ok=True)
        return Project(path, "a", lock)
    except BaseException:
        _release_lock(lock)
        raise


def _migrate(copy: Path, path: Path, version: str, *, updated: bool = False) -> None:
    """Migrate ``copy`` of the project ``path`` (format ``version``) to this odsuite's format;
    ``updated``: the copy will replace the project (its file_update_time is set)."""
    if version == HEAP_TEXT_VERSION:
        _migrate_heap_text_aside(copy, path)
        version = migrations.MIGRATIONS[HEAP_TEXT_VERSION].to_version
    with h5py.File(copy, "r+", locking=False, libver=LIBVER) as f, _reading(path, f"migrating format {version}"):
        migrations.migrate(f, FORMAT_VERSION, str(path))
        if updated:
            h5text.set_attrs(f, {"file_update_time": _now()})
