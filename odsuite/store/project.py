"""The odsuite project file (HDF5, schema 1.1.0).

Layout (every group has ``odsuite_type`` and ``object_id``; numeric datasets have ``units``, ``dims``;
all text is fixed-length UTF-8, see ``h5text``: 1.0.0 files stored it variable-length and are
migrated on open)::

    /                         odsuite_format="odsuite.project", odsuite_format_version="1.1.0",
                              creator, creator_version, hdf5_version, h5py_version, file_time,
                              file_update_time (ISO 8601, tz-aware)
    /rig                      the rig definition the project was created on: attrs name,
                              definition (the parsed rig as JSON, every sensor one channel;
                              files before 1.1.0's rig format may hold TOML text),
                              definition_format ("json" | "toml"), source (the rig file it was
                              read from, if any) and source_text (that file's text)
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

Writes are copy-on-write transactions: the committed file is copied to ``.<name>.h5.odsuite-tmp-<pid>``,
changed there, fsynced and atomically renamed over the project, so a killed process leaves either
the old or the new committed state. One writer at a time holds the writer lock
(``odsuite.store.writer_lock``). The format itself, its HDF5 codecs and the migration of older files are
in ``odsuite.store.project_format``, ``odsuite.store.h5codecs`` and ``odsuite.store.project_migration``.
"""

from __future__ import annotations

import os

import functools
import inspect
import json
import math
import unicodedata
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import IO, Any

import h5py
import numpy as np

from odsuite.store import clipping
from odsuite.store import diskspace
from odsuite.store import h5text
from odsuite.store import migrations
from odsuite.domain.errors import (
    ConfigError,
    DimensionError,
    DiskFullError,
    ProjectFileError,
    ProjectVersionError,
    SchemaError,
)
from odsuite.domain.arguments import shown
from odsuite.domain.excitation import Excitation
from odsuite.domain.memory import check_record_fits, free_memory
from odsuite.store.h5codecs import (
    Attrs,
    dataset,
    read_systeminfo,
    to_json,
    typed_group,
    write_revision,
    write_skeleton,
    write_systeminfo,
)
from odsuite.store.h5damage import open_h5, reading
from odsuite.store.stored_values import (EXPERIMENT_UNITS, RATE_RANGE, RAW_MAX, as_number, as_vector,
                                          check_experiment, check_experiment_units, check_raw_block,
                                          check_parent, check_revision, check_systeminfo,
                                          revision_number, rig_refusal, systeminfo_refusal)
from odsuite.store.project_format import (
    CHUNK_BYTES,
    FORMAT_VERSION,
    LIBVER,
    check_format,
    now,
    open_checked,
)
from odsuite.store.project_migration import migrate_in_place, migrated_copy
from odsuite.domain.rig import Rig, load_rig, printable_name, rig_from_dict
from odsuite.store.storage import (
    acquire_lock,
    copy_on_write,
    crash_point,
    release_lock,
    replace_atomically,
    reserve_private,
    tmp_path,
)
from odsuite.domain.systeminfo import Systeminfo


#: odsuite compresses nothing (its raw records carry only a checksum) and no measurement compresses
#: this far: a dataset stored this many times smaller is a "bomb" made by hand (10^7 rows of zeros
#: in a few MB), which would be read for minutes and gigabytes ...
MAX_COMPRESSION = 100
#: ... once it declares this many bytes (smaller ones cost nothing to read)
COMPRESSION_CHECKED_BYTES = 2**26


def check_written(ds: h5py.Dataset, where: str) -> None:
    """Refuse a dataset odsuite did not write, from its storage alone (before a value is read):
    chunks never written (odsuite writes every value, and a shape of 10^9 rows made by hand would be
    read as fill values, for minutes and gigabytes) or values stored in far fewer bytes than they
    take (MAX_COMPRESSION)."""
    size, stored = ds.size * ds.dtype.itemsize, ds.id.get_storage_size()
    if ds.id.get_create_plist().get_nfilters() == 0 and stored < size:
        raise ProjectFileError(f"{where}: shape {ds.shape} of {size} bytes, of which {stored} are stored "
                               "(not written by odsuite)")
    if ds.chunks is not None:  # compressed chunks say nothing by their bytes: count them
        expected = math.prod(-(-n // c) for n, c in zip(ds.shape, ds.chunks, strict=True))
        if ds.id.get_num_chunks() < expected:
            raise ProjectFileError(f"{where}: shape {ds.shape} of {size} bytes in {expected} chunks, of which "
                                   f"{ds.id.get_num_chunks()} are stored (not written by odsuite)")
    if size > COMPRESSION_CHECKED_BYTES and stored * MAX_COMPRESSION < size:
        raise ProjectFileError(f"{where}: shape {ds.shape} of {size} bytes stored in {stored} bytes, compressed "
                               f"{size / max(stored, 1):.0f}:1 (no measurement compresses beyond "
                               f"{MAX_COMPRESSION}:1; not written by odsuite)")


@dataclass(frozen=True)
class DerivedArray:
    """An array to store in a derived group, with its SI units and dimension names."""

    data: np.ndarray
    units: str
    dims: tuple[str, ...]


# ----------------------------------------------------------------------------- small helpers


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
    if not name.isprintable():  # newlines, escape sequences, undecodable bytes: not storable as text
        raise ConfigError(f"{where}: {what} name must be printable text without control characters or "
                          f"undecodable bytes, got {name!r}")
    if len(name) > MAX_NAME:
        raise ConfigError(f"{where}: {what} name must be at most {MAX_NAME} characters, got {len(name)}: "
                          f"{name[:40]!r}...")
    # one spelling of an accented letter: 'é' typed as one character or as 'e' and its accent (a
    # file name from macOS) names the same experiment
    return unicodedata.normalize("NFC", name)


#: the longest name of an experiment, import or dataset (as a rig's names: they head tables and files)
MAX_NAME = 200


def _stored_name(group: h5py.Group, name: Any) -> Any:
    """``name`` as ``group`` holds it: the composed (NFC) spelling where only that is stored."""
    if isinstance(name, str) and name not in group:
        composed = unicodedata.normalize("NFC", name)
        if composed in group:
            return composed
    return name


def _resolve_rig(rig: Rig | str | Path | None, regs) -> Rig | None:
    if rig is None or isinstance(rig, Rig):
        return rig
    if isinstance(rig, str) and rig.lower() == "none":
        return None
    rigs = regs.rigs
    if isinstance(rig, str) and rig in rigs:
        return rigs.get(rig)
    try:
        rig_file = Path(rig).suffix == ".toml" or Path(rig).is_file()
    except (OSError, ValueError):  # a name too long for a path, or with a NUL byte: no file
        rig_file = False
    if rig_file:
        loaded = load_rig(rig, regs.sensor_types)
        if not loaded.bodies:  # nothing to place sensors on, model or draw ('none' is the rig-less project)
            raise ConfigError(f"{rig}: field 'bodies': no [[bodies]] table; a rig needs at least one body "
                              "(a project without geometry: --rig none)")
        check_asked_solvers(loaded, regs.coordinate_solvers)
        if loaded.default_model is not None and loaded.default_model not in regs.models:
            raise ConfigError(f"{rig}: field 'default_model': no model named {loaded.default_model!r} "
                              f"(known: {', '.join(regs.models.names())})")
        return loaded
    raise ConfigError(f"unknown rig {str(rig)!r}: not a registered rig (known: {', '.join(rigs.names()) or 'none'}) "
                      "and not a .toml rig file")


def _integer(value: Any) -> bool:
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


#: annotations of the reading methods' arguments checked by ``_reads``: the test, and the words for it
_ARGUMENT_TYPES: dict[str, tuple[Callable[[Any], bool], str]] = {
    "str": (lambda v: isinstance(v, str), "text"),
    "int": (_integer, "an integer"),
    "int | None": (lambda v: v is None or _integer(v), "an integer or None"),
}


def _reads(what: str = "") -> Callable:
    """Decorator: run a reading method of Project/Experiment under :func:`reading`; ``what`` is
    formatted with the call's arguments, e.g. ``"experiment {experiment!r}"``."""

    def wrap(fn: Callable) -> Callable:
        signature = inspect.signature(fn)
        checked = {k: p.annotation for k, p in signature.parameters.items() if p.annotation in _ARGUMENT_TYPES}

        @functools.wraps(fn)
        def method(self, *args, **kw):
            bound = signature.bind(self, *args, **kw).arguments
            # a wrong argument is the caller's, not the file's: refused before anything is read
            for key, annotation in checked.items():
                if key in bound and not _ARGUMENT_TYPES[annotation][0](bound[key]):
                    raise ConfigError(f"{type(self).__name__}.{fn.__name__}: {key!r} must be "
                                      f"{_ARGUMENT_TYPES[annotation][1]}, got {shown(bound[key])}")
            project = self if isinstance(self, Project) else bound.get("project", getattr(self, "_project", None))
            with reading(project.path, what.format(**bound)):
                return fn(self, *args, **kw)

        return method

    return wrap


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
        a = Attrs(g)
        self.object_id = h5text.text(a["object_id"])
        self.sampling_rate = as_number(a["sampling_rate"])  # a text or complex number: named by the check
        self.pretrigger = a["pretrigger"]  # an integer: a text or float is named by the check
        self.created = h5text.text(a["created"])
        self.source = h5text.text(a.get("source", ""))
        self.rig_name = h5text.text(a["rig"]) or None
        names = a["channel_names"]
        self.channel_names = ([h5text.text(n) for n in names] if isinstance(names, np.ndarray) and names.ndim == 1
                              else h5text.readable(names))
        raw = g["raw"]
        if not isinstance(raw, h5py.Dataset):
            raise ProjectFileError(f"{project.path}: experiment {name!r} field 'raw': expected a dataset, got a group")
        check_written(raw, f"{project.path}: experiment {name!r} field 'raw'")
        self.n_samples, self.n_channels = (tuple(raw.shape) + (0, 0))[:2]
        self.excitation = None
        if "force_channel" in a:
            self.excitation = Excitation(a["force_channel"], as_vector(a["force_point"]),
                                         as_vector(a["force_direction"]),
                                         h5text.text(a["force_body"]) if "force_body" in a else None)
        check_experiment(project.path, name, sampling_rate=self.sampling_rate, pretrigger=self.pretrigger,
                         channel_names=self.channel_names, shape=raw.shape, excitation=self.excitation,
                         dtype=raw.dtype)
        self.pretrigger = int(self.pretrigger)
        if self.excitation is not None:
            self.excitation = replace(self.excitation, force_channel=int(self.excitation.force_channel))
        raw_attrs = Attrs(raw)
        check_experiment_units(project.path, name, {k: h5text.text(a[k]) for k in EXPERIMENT_UNITS if k in a},
                               h5text.text(raw_attrs["units"]) if "units" in raw_attrs else None)
        # every format version keeps the record's rate on the experiment; a Systeminfo written
        # without one (row 7 left at 0 Hz, as API callers could) takes it from there
        # every dataset of the table from its storage first, as the raw record: a column list of 10^8
        # rows made by hand and never written took info minutes and gigabytes
        if isinstance(g["systeminfo"], h5py.Group):
            g["systeminfo"].visititems(lambda n, o: check_written(
                o, f"{project.path}: experiment {name!r} field 'systeminfo/{n}'") if isinstance(o, h5py.Dataset) else None)
        self.systeminfo = read_systeminfo(
            g["systeminfo"], lambda k, *bad: systeminfo_refusal(project.path, name, k, *bad),
            lambda *bad: rig_refusal(project.path, name, *bad)).with_rate(self.sampling_rate)
        check_systeminfo(project.path, name, self.systeminfo.channels, self.n_channels, self.systeminfo.rig)

    def _group(self) -> h5py.Group:
        return self._project._file()["experiments"][self.name]

    def channel_index(self, channel: int | str) -> int:
        """Index of a channel given by index or name."""
        if not isinstance(channel, str) and not _integer(channel):  # 1.5 was read as channel 1
            raise ConfigError(f"Experiment.channel_index: 'channel' must be a channel's index or name, "
                              f"got {shown(channel)}")
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
        # the channels asked for are the caller's: checked before the file is read
        if channels is None or isinstance(channels, int | np.integer | str):
            columns = None if channels is None else self.channel_index(channels)
        elif isinstance(channels, Iterable) and not isinstance(channels, bytes | Mapping):
            columns = [self.channel_index(c) for c in channels]
        else:
            raise ConfigError(f"Experiment.raw: 'channels' must be a channel's index or name or a list of them, "
                              f"got {shown(channels)}")
        # refused before it is read (as an acquisition of that size): compressed, its stored bytes
        # say nothing of the memory reading takes
        check_record_fits(len(range(self.n_samples)[start:stop]), self.n_channels,
                          f"{self._project.path}: experiment {self.name!r} field 'raw'")
        raw = self._group()["raw"]  # a closed project is said so, not taken for a corrupted record
        try:
            # volts as float64, whatever real type a file written elsewhere holds (float16 has no linalg)
            block = np.asarray(raw[start:stop], dtype=np.float64)
        except OSError as exc:
            raise ProjectFileError(f"{self._project.path}: experiment {self.name!r}: raw data cannot be read "
                                   f"(corrupted?): {exc}") from None
        check_raw_block(self._project.path, self.name, block, range(self.n_samples)[start:stop].start,
                        self.channel_names)
        return block if columns is None else block[:, columns]

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
    big = np.abs(arr) > RAW_MAX  # what the reader refuses (stored_values.check_raw_block)
    if big.any():
        i, c = np.argwhere(big)[0]
        label = f" ({names[c]})" if names else ""
        raise ConfigError(f"{where}: raw sample {row0 + i}, channel {c}{label} is {float(arr[i, c]):g}; "
                          f"raw values must lie within {RAW_MAX:g}")
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
        return dataset(self._group, name, None, units, dims, shape=shape, dtype=dtype,
                        fletcher32=bool(np.prod(shape)))


# ----------------------------------------------------------------------------- the project


class Project:
    """An open project file. Use ``create_project``/``open_project``; close it (or use ``with``)."""

    path: Path
    mode: str
    rig: Rig | None  # None for projects created with --rig none

    def __init__(self, path: Path, mode: str, lock: IO[str] | None, read_path: Path | None = None,
                 registries=None, h5: h5py.File | None = None) -> None:
        self.path = path
        self._registries = registries
        self.mode = mode
        self._lock = lock
        self._read_path = read_path or path  # a private migrated copy for old versions in read mode
        # ``h5``: the file as ``open_checked`` left it open (each open walks the file)
        self._h5: h5py.File | None = h5 if h5 is not None else open_h5(self._read_path, path)
        self._tx: h5py.File | None = None
        self._rig_cache: tuple[Rig | None] | None = None

    @property
    def registries(self):
        """The providers this project is worked with (``odsuite.contracts.plugins.Registries``): those
        given to ``open_project``/``create_project``, else the installed plugins'. Engines take their
        providers from here, so a lab's plugin passed as registries works without installing it."""
        if self._registries is None:
            from odsuite.contracts.plugins import registries

            self._registries = registries()
        return self._registries

    # -- plumbing

    def _file(self) -> h5py.File:
        if self._tx is not None:
            return self._tx
        if self._h5 is None:
            raise ProjectFileError(f"{self.path}: project is closed (open_project again to read it)")
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
        with copy_on_write(self.path) as tx:
            self._tx = tx
            try:
                yield self
            finally:
                self._tx = None
        self._h5.close()
        self._h5 = open_h5(self.path, self.path)

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
            release_lock(self._lock)
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
                a = Attrs(f["rig"])
                text, fmt = h5text.text(a["definition"]), h5text.text(a["definition_format"])
                if fmt not in ("json", "toml"):  # decoded as JSON, another format would be read as a different rig
                    raise ProjectFileError(f"{self.path}: rig field 'definition_format': expected 'json' or 'toml' "
                                           f"(the formats odsuite writes), got {fmt!r}")
                if fmt == "toml":  # only rigs stored before the JSON definitions: tomllib imported for them alone
                    import tomllib

                    decode, malformed = tomllib.loads, tomllib.TOMLDecodeError
                else:
                    decode, malformed = json.loads, json.JSONDecodeError
                try:
                    data = decode(text)
                except malformed as exc:
                    raise SchemaError(f"{self.path}: /rig definition is not valid {fmt}: {exc}") from None
                source = h5text.text(a.get("source", ""))
                data = migrations.rig_up_filled(data, text if fmt == "toml" else h5text.text(a.get("source_text", "")))
                try:
                    rig = rig_from_dict(data, self.registries.sensor_types, source=Path(source) if source else None)
                except ConfigError as exc:  # the stored copy is at fault, not the file it came from
                    raise SchemaError(f"{self.path}: stored rig definition (/rig): {exc}") from None
                rig = self._kept_systeminfo(rig, h5text.text(a.get("systeminfo_text", "")))
            self._rig_cache = (rig,)
        return self._rig_cache[0]

    def _kept_systeminfo(self, rig: Rig, text: str) -> Rig:
        """The stored rig with its .CTR's text as the project keeps it. A project never reads
        outside itself: the path its definition names is not read, but for one stored before the
        text was kept, whose file is a registered rig's own (the thesis rig's table, shipped with
        the plugins: found there on any machine); otherwise the rig's channels are described from
        its sensors."""
        if rig.systeminfo_file is None:
            return rig
        if text:
            return replace(rig, systeminfo_text=text)
        name = Path(rig.systeminfo_file).name
        shipped = next((r.systeminfo_file for _, r in self.registries.rigs.items()
                        if getattr(r, "systeminfo_file", None) is not None and Path(r.systeminfo_file).name == name),
                       None)
        return replace(rig, systeminfo_file=shipped, systeminfo_text=None)

    @property
    @_reads("root attributes")
    def format_version(self) -> str:
        return h5text.text(Attrs(self._file())["odsuite_format_version"])

    @property
    @_reads("root attributes")
    def file_times(self) -> tuple[str, str]:
        """When the file was created and last updated (ISO 8601), without reading any record."""
        a = Attrs(self._file())
        created = h5text.text(a["file_time"])
        return created, h5text.text(a.get("file_update_time", "")) or created

    # -- experiments

    @_reads("/experiments")
    def experiment_names(self) -> list[str]:
        """Names of the stored experiments, in the order they were added."""
        experiments = self._file()["experiments"]
        if not isinstance(experiments, h5py.Group):
            raise ProjectFileError(f"{self.path}: field 'experiments': expected a group, got a dataset")
        return list(experiments.keys())

    @_reads("experiment {name!r}")
    def experiment(self, name: str) -> Experiment:
        name = _stored_name(self._file()["experiments"], name)
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
        name = _check_name(str(self.path), "experiment", name)
        where = f"{self.path}: experiment {name!r}"
        if name in self._file()["experiments"]:
            raise ConfigError(f"{where} already exists; choose another name")
        if isinstance(sampling_rate, bool) or not isinstance(sampling_rate, int | float | np.number) \
                or not np.isfinite(sampling_rate) or sampling_rate <= 0:
            raise ConfigError(f"{where}: sampling_rate must be a finite number > 0 Hz, got {sampling_rate!r}")
        # the range the project's reader accepts: a rate outside it would store a project that no longer opens
        if not RATE_RANGE[0] <= sampling_rate <= RATE_RANGE[1]:
            raise ConfigError(f"{where}: sampling_rate must be {RATE_RANGE[0]:g} to {RATE_RANGE[1]:g} Hz, "
                              f"got {sampling_rate!r}")
        if not isinstance(pretrigger, int | np.integer) or pretrigger < 0:
            raise ConfigError(f"{where}: pretrigger must be an integer >= 0 samples, got {pretrigger!r}")
        if n_samples is not None and (not isinstance(n_samples, int | np.integer) or n_samples <= 0):
            raise ConfigError(f"{where}: n_samples must be an integer > 0, got {n_samples!r}")
        if n_samples is not None and pretrigger > n_samples:
            raise ConfigError(f"{where}: pretrigger must be 0 to {n_samples} samples (the record's length), "
                              f"got {pretrigger}")
        if not isinstance(systeminfo, Systeminfo):
            raise ConfigError(f"{where}: systeminfo must be a Systeminfo, got {type(systeminfo).__name__}")
        for i, ch in enumerate(systeminfo.channels):
            # row 7 is the channel's rate; a record stored at another rate would be read wrongly
            if ch.sampling_rate and not np.isclose(ch.sampling_rate, sampling_rate, rtol=1e-9, atol=0.0):
                raise ConfigError(f"{where}: systeminfo channel {i} row 7 (sampling rate) is "
                                  f"{ch.sampling_rate:g} Hz but the record is sampled at {float(sampling_rate):g} Hz")
        systeminfo = systeminfo.with_rate(sampling_rate)

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
            if pretrigger > n_samples:
                raise ConfigError(f"{where}: pretrigger must be 0 to {n_samples} samples (the record's length), "
                                  f"got {pretrigger}")
        if first.shape[0] == 0 and not streamed:
            raise DimensionError(f"{where}: raw data have no samples (shape {first.shape})")
        if len(systeminfo.channels) != n_ch:
            raise DimensionError(f"{where}: systeminfo describes {len(systeminfo.channels)} channels but the "
                                 f"raw data have {n_ch}")
        if len(names) != n_ch or len(set(names)) != n_ch:
            raise DimensionError(f"{where}: channel_names must be {n_ch} distinct names, got {channel_names!r}")
        for k, c in enumerate(names):
            printable_name(f"{where}: channel {k} name", c)
        exc_attrs = self._excitation_attrs(where, excitation, n_ch)

        with self.transaction():
            experiments = self._tx["experiments"]
            g = typed_group(experiments, name, "experiment")
            try:
                self._write_raw(g, where, first, chunks, n_ch, n_samples, names)
                for k, v in {"sampling_rate": float(sampling_rate), "sampling_rate_units": "Hz",
                             "pretrigger": int(pretrigger), "rig": self.rig.name if self.rig else "",
                             "channel_names": h5text.fixed(names), "created": now(), "source": source,
                             **exc_attrs}.items():
                    h5text.set_attrs(g, {k: v})
                write_systeminfo(g, systeminfo, names)
                # what the reader would refuse is never stored (a streamed record's length is known
                # only now): read back with every check of the reader
                try:
                    Experiment(self, name)
                except ProjectFileError as exc:
                    raise ConfigError(str(exc)) from None
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
        out = {"force_channel": int(fc), "force_point": point, "force_point_units": "m",
               "force_direction": direction / norm}
        if excitation.body is not None:
            out["force_body"] = str(excitation.body)
        return out

    @staticmethod
    def _write_raw(g: h5py.Group, where: str, first: np.ndarray, rest: Iterator[Any], n_ch: int,
                   n_samples: int | None, names: list[str]) -> None:
        rows = max(1, CHUNK_BYTES // (8 * n_ch))
        if n_samples is not None:
            rows = min(rows, n_samples)
        diskspace.ensure_room_in(g.file, 8 * n_ch * (n_samples or first.shape[0]))
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
            if n_samples is None:  # a stream of unknown length: room checked chunk by chunk
                diskspace.ensure_room_in(g.file, chunk.nbytes)
            ds[row:end] = chunk
            row, k = end, k + 1
            crash_point(f"chunk-{k}")
            chunk = next(rest, None)
        if row == 0 or (n_samples is not None and row != n_samples):
            raise DimensionError(f"{where}: raw chunks hold {row} rows, expected "
                                 f"{n_samples if n_samples is not None else 'at least 1'}")

    # -- derived data

    def _experiment_group(self, name: str) -> h5py.Group:
        """The group of experiment ``name``, without reading its Systeminfo as ``experiment`` does."""
        name = _stored_name(self._file()["experiments"], name)
        if name not in self._file()["experiments"]:
            self.experiment(name)  # the unknown name's error
        return self._file()["experiments"][name]

    def _derived_group(self, experiment: str, kind: str) -> h5py.Group:
        g = self._experiment_group(experiment)
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
        params = to_json(f"{where} provenance parameters", provenance.get("parameters", {}))
        inputs = list(provenance.get("inputs") or [exp.object_id])
        with self.transaction():
            eg = self._tx["experiments"][experiment]
            derived = eg["derived"] if "derived" in eg else typed_group(eg, "derived", "derived_set")
            partial = "." + kind  # written aside so an enclosing transaction keeps the old group on error
            if partial in derived:
                del derived[partial]
            g = typed_group(derived, partial, "derived")
            h5text.set_attrs(g, {"plugin": plugin, "plugin_version": str(provenance.get("version", "")),
                                 "parameters": params, "inputs": h5text.fixed([str(i) for i in inputs]),
                                 "created": now()})
            writer = DerivedWriter(g, where)
            try:
                yield writer
                h5text.set_attrs(g, {k: to_json(f"{where} attr {k!r}", v) if isinstance(v, dict | None) else v
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
        for n, ds in g.items():
            if isinstance(ds, h5py.Dataset):
                check_written(ds, f"{self.path}: experiment {experiment!r} derived {kind!r} field {n!r}")
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
                "units": {n: h5text.text(Attrs(ds)["units"]) for n, ds in g.items()},
                "dims": {n: tuple(h5text.text(d) for d in Attrs(ds)["dims"]) for n, ds in g.items()}}

    @_reads("experiment {name!r} object ids")
    def object_ids(self, name: str) -> tuple[str, dict[str, str]]:
        """The object id of experiment ``name`` and of each of its derived kinds, read from their
        attributes alone (``experiment`` and ``derived_info`` read its Systeminfo and every dataset's)."""
        g = self._experiment_group(name)
        return h5text.text(Attrs(g)["object_id"]), {
            kind: h5text.text(Attrs(self._derived_group(name, kind))["object_id"]) for kind in self.derived_kinds(name)}

    @_reads("experiment {experiment!r} derived")
    def derived_kinds(self, experiment: str) -> list[str]:
        g = self._experiment_group(experiment)
        return [k for k in g["derived"] if not k.startswith(".")] if "derived" in g else []

    # -- imported data that are not records (nodes, FRFs, modes of a file without time data)

    def write_import(self, name: str, kind: str, arrays: Mapping[str, DerivedArray], *, source: str,
                     attrs: Mapping[str, Any] | None = None) -> None:
        """Store, atomically, what a file held besides records as ``imports/<name>``: ``kind``
        ("nodes", "frf", "modes"), numeric ``arrays`` with units and dims, text ``attrs``."""
        self._require_writable()
        name = _check_name(str(self.path), "import", name)
        where = f"{self.path}: import {name!r}"
        with self.transaction():
            root = self._tx["imports"] if "imports" in self._tx else typed_group(self._tx, "imports", "import_set")
            if name in root:
                raise ConfigError(f"{where} already exists; choose another --name")
            g = typed_group(root, name, "import")
            try:
                h5text.set_attrs(g, {"kind": kind, "source": source, "created": now()})
                w = DerivedWriter(g, where)
                for key, a in arrays.items():
                    data = np.asarray(a.data)
                    w.create(key, data.shape, data.dtype, a.units, a.dims)[...] = data
                attrs = dict(attrs or {})
                as_json = sorted(k for k, v in attrs.items() if isinstance(v, dict | list | None))
                h5text.set_attrs(g, {k: to_json(f"{where} attr {k!r}", v) if k in as_json else v
                                     for k, v in attrs.items()} | {"json_attrs": to_json(where, as_json)})
            except BaseException:
                del root[name]
                raise

    @_reads("imports")
    def import_names(self) -> dict[str, str]:
        """Every stored import and its kind."""
        f = self._file()
        return {n: h5text.text(g.attrs["kind"]) for n, g in f["imports"].items()} if "imports" in f else {}

    @_reads("import {name!r}")
    def read_import(self, name: str) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """The datasets and the attributes of an import."""
        if name not in self.import_names():
            raise ConfigError(f"{self.path}: no import {name!r} (imports: {', '.join(self.import_names()) or 'none'})")
        g = self._file()["imports"][name]
        attrs = {k: h5text.readable(v) for k, v in g.attrs.items()}
        for k in json.loads(attrs.pop("json_attrs", "[]")):
            attrs[k] = json.loads(attrs[k])
        arrays = {}
        for k, ds in g.items():
            where = f"{self.path}: import {name!r} field {k!r}"
            if not isinstance(ds, h5py.Dataset):
                raise ProjectFileError(f"{where}: expected a dataset, got a group")
            check_written(ds, where)
            free, size = free_memory(), ds.size * ds.dtype.itemsize
            if free is not None and size > free:  # compressed: what is stored says nothing of what reading takes
                raise ProjectFileError(f"{where}: shape {ds.shape} needs {size / 2**20:.0f} MiB to read; only "
                                       f"{free / 2**20:.0f} MiB of memory are free")
            arrays[k] = ds[()]
        return arrays, attrs

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
        texts = {k: to_json(f"{where} {k}", v) for k, v in
                 (("effects", list(effects)), ("parameters", dict(parameters)), ("metrics", dict(metrics)))}
        n = max(known, default=-1) + 1
        with self.transaction():
            write_revision(self._tx, n, model, parent, texts)
        return n

    @_reads("model revisions")
    def model_revisions(self) -> list[dict]:
        """Every revision as a dict: revision, model, effects, parameters, metrics, parent, created."""
        revs = self._revisions()
        if revs is None:
            return []
        out = []
        keys = set(revs)
        for key, g in revs.items():
            number = revision_number(self.path, key)  # before check_parent, which compares numbers
            a = Attrs(g)
            parent = check_parent(self.path, key, a["parent"], keys)
            rev = {"revision": number, "model": h5text.text(a["model"]) or None,
                   "effects": json.loads(h5text.text(a["effects"])),
                   "parameters": json.loads(h5text.text(a["parameters"])),
                   "metrics": json.loads(h5text.text(a["metrics"])),
                   "parent": None if parent < 0 else parent, "created": h5text.text(a["created"]),
                   "object_id": h5text.text(a["object_id"])}
            check_revision(self.path, key, rev["effects"], rev["parameters"], rev["metrics"])
            out.append(rev)
        return sorted(out, key=lambda r: r["revision"])

    @property
    @_reads("/models")
    def current_revision(self) -> int | None:
        f = self._file()
        n = int(f["models"].attrs.get("current_revision", -1)) if "models" in f else -1
        if n < 0:
            return None
        revs = self._revisions()
        if revs is None or str(n) not in revs:  # every command would look for it
            raise ProjectFileError(f"{self.path}: models field 'current_revision': expected a stored revision "
                                   f"({', '.join(revs.keys() if revs is not None else []) or 'none'}), got {n}")
        return n

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
        if not isinstance(metrics, Mapping):
            raise ConfigError(f"Project.set_revision_metrics: 'metrics' must be a dict of metrics, got {shown(metrics)}")
        for key, value in metrics.items():  # a NaN error was stored, and history showed it
            if isinstance(value, float | np.floating) and not math.isfinite(value):
                raise ConfigError(f"Project.set_revision_metrics: metric {key!r} must be a finite number, got {value}")
        revs = {r["revision"]: r for r in self.model_revisions()}
        if n not in revs:
            raise ConfigError(f"{self.path}: no model revision {n!r} (revisions: {sorted(revs) or 'none'})")
        text = to_json(f"{self.path}: model revision {n} metrics", {**revs[n]["metrics"], **metrics})
        with self.transaction():
            h5text.set_attrs(self._tx["models"]["revisions"][str(n)], {"metrics": text})

    # -- checks and summaries

    @_reads()
    def verify(self) -> dict[str, int]:
        """Read every checksummed dataset, after every check the readers make of the model
        revisions and of each experiment (a missing record, a field out of range: what `info` would
        refuse is never "intact"); ProjectFileError names the first fault.

        Returns the number of datasets checked per experiment.
        """
        self.model_revisions()
        checked: dict[str, int] = {}
        for name in self.experiment_names():
            datasets: list[h5py.Dataset] = []
            group = self._file()["experiments"][name]
            if not isinstance(group, h5py.Group):
                raise ProjectFileError(f"{self.path}: experiment {name!r} is a {type(group).__name__}, "
                                       "not an experiment group")
            self.experiment(name)
            unchecked: list[str] = []
            # odsuite writes every record and every derived dataset that holds a value with a checksum
            group.visititems(lambda n, o: unchecked.append(o.name) if isinstance(o, h5py.Dataset) and not o.fletcher32
                             and (n == "raw" or n.startswith("derived/") and o.size) else None)
            if unchecked:
                raise ProjectFileError(f"{self.path}: experiment {name!r}: dataset {unchecked[0]} has no checksum, "
                                       "so it cannot be verified (not written by odsuite)")
            group.visititems(
                lambda _n, o: datasets.append(o) if isinstance(o, h5py.Dataset) and o.fletcher32 else None)
            for ds in datasets:
                check_written(ds, f"{self.path}: experiment {name!r}: dataset {ds.name}")
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
        sampling rate, samples, duration, per channel its peak |value| in SI with its unit
        ([value, unit]) and clipped channels.

        A channel is clipped when a sample lies within (limit_high - limit_low) / 2048 (one step of
        a 12-bit converter) of its Systeminfo DAQ limits (``clipping.scan``).
        """
        a = Attrs(self._file())
        out: dict[str, Any] = {
            "path": str(self.path), "format_version": h5text.text(a["odsuite_format_version"]),
            "creator": f"{h5text.text(a['creator'])} {h5text.text(a['creator_version'])}",
            "file_time": h5text.text(a["file_time"]), "file_update_time": h5text.text(a.get("file_update_time", "")),
            "rig": self.rig.name if self.rig else None, "experiments": {},
            "revisions": len(self.model_revisions()), "current_revision": self.current_revision,
            "imports": self.import_names(),
        }
        for name in self.experiment_names():
            e = self.experiment(name)
            peak, clipped = clipping.scan(e)
            out["experiments"][name] = {
                "channels": e.channel_names, "sampling_rate": e.sampling_rate, "n_samples": e.n_samples,
                "duration": e.n_samples / e.sampling_rate, "pretrigger": e.pretrigger,
                # in each channel's SI unit: an imported record's raw column is the file's m/s^2,
                # g or N, not volts
                "peak": {n: [float(v / abs(c.sensitivity * c.daq_gain)), c.unit]
                         for n, v, c in zip(e.channel_names, peak.tolist(), e.systeminfo.channels, strict=True)},
                "clipped": [n for n, c in zip(e.channel_names, clipped, strict=True) if c],
                "clipped_samples": {n: int(c) for n, c in zip(e.channel_names, clipped, strict=True) if c},
                "excitation": None if e.excitation is None else {
                    "force_channel": e.excitation.force_channel, "point": e.excitation.point.tolist(),
                    "direction": e.excitation.direction.tolist(), "body": e.excitation.body},
                "derived": self.derived_kinds(name), "source": e.source, "created": e.created,
            }
        return out


# ----------------------------------------------------------------------------- entry points

def check_asked_solvers(rig: Rig, solvers) -> None:
    """A body whose rig file asks for a coordinate solver must get it from its sensors: refused
    when the project is created, not at the first ``process``."""
    from odsuite.domain.rigidbody import body_sensors
    from odsuite.contracts.solvers import choose_solver

    for body in rig.bodies:
        if body.solver is not None:
            choose_solver(rig, body, [s.name for s in body_sensors(rig, body)], solvers)


def _path_argument(where: str, path: Any) -> Path:
    """A project file's path; anything else named (pathlib said "expected str, bytes or os.PathLike")."""
    if not isinstance(path, str | os.PathLike):
        raise ConfigError(f"{where}: 'path' must be a project file's path, got {shown(path)}")
    return Path(path)


def create_project(path: str | Path, rig: Rig | str | None = "thesis-dynamometer", *, registries=None) -> Project:
    """Create a new project file (refuses to overwrite) and return it open for writing.

    ``rig`` is a Rig, a registered rig name, a path to a .toml rig file, or None/"none". With a rig,
    model revision 0 (no effects, the rig's default model) is created too. ``registries``: the
    providers to work with (default: the installed plugins'; see ``Project.registries``).
    """
    path = _path_argument("create_project", path)
    if rig is not None and not isinstance(rig, Rig | str | os.PathLike):
        raise ConfigError(f"create_project: 'rig' must be a Rig, a registered rig's name, a .toml rig file or None, "
                          f"got {shown(rig)}")
    if registries is None:
        from odsuite.contracts.plugins import registries as installed

        registries = installed()
    rig = _resolve_rig(rig, registries)
    if not path.parent.is_dir():
        raise ProjectFileError(f"{path}: directory {path.parent} does not exist")
    if path.is_dir():  # the writer lock read a folder's links as a file's hard links
        raise ProjectFileError(f"{path}: is a folder; give the new project's file name")
    if path.is_symlink():
        # a new project is a new file: writing it would replace the user's link with it
        raise ProjectFileError(f"{path}: is a symbolic link (to {os.readlink(path)}); a new project is created "
                               "only as a new file: give the name it should have, or remove the link")
    if rig is not None and rig.default_model and rig.default_model in registries.models:
        # the rig's model built once: a [beam] table it refuses is refused now, not at every later command
        registries.models.get(rig.default_model)(rig)
    lock = acquire_lock(path)
    try:
        if path.exists():
            raise ProjectFileError(f"{path}: file already exists; choose another name or delete it first")
        tmp = tmp_path(path)
        diskspace.ensure_space(tmp, 0, path)
        reserve_private(tmp, path)  # before the try: a file in the way is not ours to delete
        try:
            with h5py.File(tmp, "w", libver=LIBVER, fs_strategy="fsm", fs_persist=True,
                           track_order=True, locking=False) as f:
                write_skeleton(f, rig)
            replace_atomically(tmp, path)
        except Exception as exc:
            if diskspace.is_disk_full(exc) and not isinstance(exc, DiskFullError):
                raise DiskFullError(diskspace.full_message(path, path.parent, diskspace.written_so_far(tmp),
                                                           outcome="no project created")) from None
            raise
        finally:
            tmp.unlink(missing_ok=True)
        project = Project(path, "a", lock, registries=registries)
    except BaseException:
        release_lock(lock)
        raise
    return project


def open_project(path: str | Path, mode: str = "r", *, registries=None) -> Project:
    """Open a project for reading ("r") or reading and writing ("a"). Usable as a context manager.
    ``registries``: the providers to work with (default: the installed plugins'; see
    ``Project.registries``).

    Readers never block and see only committed states; a second writer gets ProjectLockedError.
    Files of an older format version are migrated on read (a private copy in read mode; the
    project itself, atomically, in write mode).
    """
    path = _path_argument("open_project", path)
    if mode not in ("r", "a"):
        raise ConfigError(f"{path}: open mode must be 'r' or 'a', got {mode!r}")
    if mode == "r":
        version, h5 = open_checked(path)
        if migrations.parse_version(version) >= migrations.parse_version(FORMAT_VERSION):
            try:
                return Project(path, "r", None, registries=registries, h5=h5)
            except BaseException:
                h5.close()
                raise
        if h5 is not None:
            h5.close()
        tmp = migrated_copy(path, version)
        try:
            return Project(path, "r", None, read_path=tmp, registries=registries)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
    check_format(path)  # before locking: no lock file beside a file that is not a project
    lock = acquire_lock(path)
    try:
        version = check_format(path)
        if migrations.parse_version(version) > migrations.parse_version(FORMAT_VERSION):
            raise ProjectVersionError(f"{path}: project format {version} is newer than {FORMAT_VERSION}: "
                                      "this odsuite can read it but not change it; upgrade odsuite")
        if version != FORMAT_VERSION:
            migrate_in_place(path, version)
        return Project(path, "a", lock, registries=registries)
    except BaseException:
        release_lock(lock)
        raise
