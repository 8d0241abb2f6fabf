"""Records as arrays of numbers: CSV, NumPy ``.npy``, MATLAB ``.mat`` and NI TDMS files, read into
named columns with units and a sampling rate, checked, and stored through
:func:`~odsuite_plugins.importers.columns.import_columns` (onto the project's rig by channel name).

What a file does not say comes from a sidecar ``FILE.toml`` beside it (the file's name with
``.toml`` for its suffix) or from the importer's options (which win)::

    sampling_rate = 100.0                        # Hz
    channels = ["ch1", "ch2", "ch3"]             # one name per column
    units = "m/s^2"                              # one unit for all, or one per column
    variable = "data"                            # .mat: the array to read
    group = "Measurements"                       # TDMS: the group to read

Units: m/s^2 (m/s2, m/s²), g, N, V (see docs/importing.md).
"""

from __future__ import annotations

import csv
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from odsuite.api import ConfigError, DimensionError

#: unit labels a column may carry (lower case); the importers store them as columns.UNITS says
KNOWN_UNITS = ("m/s^2", "m/s2", "m/s²", "g", "n", "newtons", "v", "volts", "volt")
SIDECAR_FIELDS = ("sampling_rate", "channels", "units", "variable", "group")
#: .mat variables that give the rate (Hz), the channel names and their units
MAT_RATE = ("fs", "Fs", "sampling_rate", "rate")
MAT_NAMES = ("channels", "channel_names", "names")
MAT_UNITS = ("units",)


@dataclass(frozen=True)
class Columns:
    """A record as named columns: samples x columns in ``units`` at ``fs`` Hz."""

    names: list[str]
    units: list[str]
    data: np.ndarray
    fs: float


def sidecar(file: Path) -> dict:
    """The sidecar's fields (none when there is no sidecar); unknown fields refused."""
    side = file.with_suffix(".toml")
    if not side.exists():
        return {}
    try:
        doc = tomllib.loads(side.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"{side}: not a readable TOML file: {exc}") from None
    unknown = sorted(set(doc) - set(SIDECAR_FIELDS))
    if unknown:
        raise ConfigError(f"{side}: unknown field {unknown[0]!r} (fields: {', '.join(SIDECAR_FIELDS)})")
    return doc


def _list(value, n: int, where: str, field: str) -> list[str]:
    """A list of ``n`` strings from a list or a comma-separated string; one string for all."""
    if isinstance(value, str):
        value = [v.strip() for v in value.split(",")] if "," in value else [value.strip()] * (n if field == "units" else 1)
    items = [str(v).strip() for v in value]
    if len(items) != n:
        raise DimensionError(f"{where}: {field}: {len(items)} given for {n} column(s) ({', '.join(items)})")
    return items


def checked(where: str, data, names, units, fs, explicit: dict, may_transpose: bool = False) -> Columns:
    """The columns checked: a 2-D array of finite numbers with two or more samples, one name and one
    known unit per column, a finite rate > 0; ``explicit`` (options, sidecar) fill and override.
    ``may_transpose``: an unnamed array that is channels x samples is read transposed."""
    try:
        a = np.asarray(data, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: data: not an array of numbers (dtype {np.asarray(data).dtype})") from None
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise DimensionError(f"{where}: data: shape {a.shape}; expected samples x channels (2-D)")
    if may_transpose and a.shape[1] > a.shape[0] and a.shape[0] <= 64:  # channels x samples, as MATLAB users store
        a = a.T
    if a.shape[0] < 2 or a.shape[1] < 1:
        raise DimensionError(f"{where}: data: shape {a.shape}; a record needs 2 or more samples of 1 or more channels")
    n = a.shape[1]
    names = explicit.get("channels", names)
    names = [f"ch{k + 1}" for k in range(n)] if names is None else _list(names, n, where, "channels")
    dup = sorted({c for c in names if names.count(c) > 1})
    if dup or "" in names:
        raise ConfigError(f"{where}: channels: name {(dup or [''])[0]!r} is given twice or empty")
    units = explicit.get("units", units)
    if units is None:
        raise ConfigError(f"{where}: units: not given (channels {', '.join(names)}); give --units or "
                          f"a sidecar {Path(where).with_suffix('.toml').name} (units = \"m/s^2\")")
    units = _list(units, n, where, "units")
    for c, u in zip(names, units):
        if u.lower() not in KNOWN_UNITS:
            raise ConfigError(f"{where}: channel {c!r}: unit {u!r} is not one of m/s^2, g, N, V")
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        i, k = bad[0]
        raise ConfigError(f"{where}: channel {names[k]!r}: sample {i}: value {a[i, k]} is not a finite number")
    fs = explicit.get("sampling_rate", fs)
    if fs is None:
        raise ConfigError(f"{where}: sampling_rate: not given; give --rate or a sidecar "
                          f"{Path(where).with_suffix('.toml').name} (sampling_rate = ... in Hz)")
    try:
        fs = float(fs)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: sampling_rate: {fs!r} is not a number of Hz") from None
    if not (np.isfinite(fs) and fs > 0):
        raise ConfigError(f"{where}: sampling_rate: {fs!r} Hz; must be a finite rate > 0 Hz")
    return Columns(names, units, a, fs)


def _unit_suffix(name: str) -> tuple[str, str | None]:
    """'acc1 [m/s^2]' or 'acc1 (g)' -> ('acc1', 'm/s^2'); a name without one -> (name, None)."""
    name = name.strip()
    for o, c in (("[", "]"), ("(", ")")):
        if name.endswith(c) and o in name:
            k = name.rindex(o)
            return name[:k].strip(), name[k + 1:-1].strip()
    return name, None


def read_csv_columns(file: Path, explicit: dict) -> Columns:
    """A CSV record: a header row of channel names (each may end in its unit, ``acc1 [m/s^2]``),
    then one row per sample; a first column named time/t (s) gives the rate."""
    where = str(file)
    try:
        text = file.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{where}: not a readable text file: {exc}") from None
    rows = [r for r in csv.reader(text.splitlines()) if any(c.strip() for c in r)]
    if not rows:
        raise ConfigError(f"{where}: empty: no header and no samples")
    header = [c.strip() for c in rows[0]]
    parsed = [_unit_suffix(h) for h in header]
    names, units = [p[0] for p in parsed], [p[1] for p in parsed]
    values = []
    for line, r in enumerate(rows[1:], start=2):
        if len(r) != len(header):
            raise DimensionError(f"{where}: line {line}: {len(r)} fields, the header has {len(header)}")
        row = []
        for c, v in zip(names, r):
            try:
                row.append(float(v))
            except ValueError:
                raise ConfigError(f"{where}: line {line}: channel {c!r}: value {v.strip()!r} is not a number") from None
        values.append(row)
    if not values:
        raise ConfigError(f"{where}: empty: a header and no samples")
    data = np.array(values)
    fs = None
    if names[0].lower() in ("time", "t") and len(names) > 1:
        t = data[:, 0]
        dt = np.diff(t)
        if dt.size == 0 or not np.all(dt > 0) or np.ptp(dt) > 1e-6 * abs(dt.mean()) + 1e-12:
            raise ConfigError(f"{where}: channel {names[0]!r}: the time column is not evenly spaced "
                              f"(steps {dt.min() if dt.size else 0:g} to {dt.max() if dt.size else 0:g} s)")
        fs = 1.0 / float(dt.mean())
        names, units, data = names[1:], units[1:], data[:, 1:]
    given = None if all(u is None for u in units) else units
    if given is not None and any(u is None for u in units):
        k = units.index(None)
        raise ConfigError(f"{where}: channel {names[k]!r}: no unit in its header (e.g. '{names[k]} [m/s^2]') "
                          "while others have one")
    return checked(where, data, names, given, fs, explicit)


def read_npy_columns(file: Path, explicit: dict) -> Columns:
    where = str(file)
    try:
        data = np.load(file, allow_pickle=False)
    except (OSError, ValueError, EOFError) as exc:
        raise ConfigError(f"{where}: not a NumPy .npy array file: {exc}") from None
    if not np.issubdtype(data.dtype, np.number) or np.issubdtype(data.dtype, np.complexfloating):
        raise ConfigError(f"{where}: data: dtype {data.dtype} is not real numbers")
    return checked(where, data, None, None, None, explicit, may_transpose=True)


def _mat_text(value) -> list[str] | str:
    a = np.asarray(value)
    if a.dtype.kind in "US":
        return [str(v).strip() for v in a.ravel()] if a.size > 1 else str(a.ravel()[0]).strip()
    return [str(np.asarray(v).ravel()[0]).strip() for v in a.ravel()]  # a cell array of strings


def read_mat_columns(file: Path, explicit: dict) -> Columns:
    """A MATLAB .mat (v4-v7.2 via scipy.io; v7.3 is HDF5, via h5py): the array ``variable``, else
    the file's only 2-D numeric array; ``fs``/``sampling_rate``, ``channels`` and ``units``
    variables when present."""
    import scipy.io

    where = str(file)
    try:
        mat = {k: v for k, v in scipy.io.loadmat(file).items() if not k.startswith("__")}
    except NotImplementedError:  # v7.3: HDF5
        mat = _mat73(file)
    except (OSError, ValueError, TypeError) as exc:
        raise ConfigError(f"{where}: not a readable MATLAB .mat file: {exc}") from None
    numeric = {k: v for k, v in mat.items() if isinstance(v, np.ndarray) and v.dtype.kind in "fiu" and v.size > 1}
    variable = explicit.get("variable")
    if variable is not None:
        if variable not in mat:
            raise ConfigError(f"{where}: variable: no {variable!r} (variables: {', '.join(mat) or 'none'})")
        data = mat[variable]
    elif len(numeric) == 1:
        variable, data = next(iter(numeric.items()))
    else:
        raise ConfigError(f"{where}: variable: {'no numeric array' if not numeric else 'arrays ' + ', '.join(numeric)}"
                          f"{'' if not numeric else '; name one with --variable'}")
    if not isinstance(data, np.ndarray) or data.dtype.kind not in "fiu":
        raise ConfigError(f"{where}: variable {variable!r}: not an array of real numbers")
    fs = next((float(np.asarray(mat[k]).ravel()[0]) for k in MAT_RATE if k in mat and np.asarray(mat[k]).size == 1),
              None)
    names = next((_mat_text(mat[k]) for k in MAT_NAMES if k in mat), None)
    units = next((_mat_text(mat[k]) for k in MAT_UNITS if k in mat), None)
    return checked(f"{where}: variable {variable!r}", data, names, units, fs, explicit, may_transpose=True)


def _mat73(file: Path) -> dict:
    import h5py

    try:
        with h5py.File(file, "r") as f:
            out = {}
            for k, ds in f.items():
                if isinstance(ds, h5py.Dataset) and ds.dtype.kind in "fiu":
                    out[k] = np.asarray(ds[()]).T  # MATLAB stores column-major
            return out
    except OSError as exc:
        raise ConfigError(f"{file}: not a readable MATLAB .mat file (v7.3/HDF5): {exc}") from None


def read_tdms_columns(file: Path, explicit: dict) -> Columns:
    """An NI TDMS file (npTDMS): the channels of ``group`` (default: the file's only group), each
    with its ``unit_string`` and ``wf_increment`` (s) properties."""
    from nptdms import TdmsFile

    import logging

    where = str(file)
    # npTDMS reads a file cut short as far as it goes and only logs it: its warnings are caught
    heard: list[str] = []
    handler = logging.Handler(logging.WARNING)
    handler.emit = lambda record: heard.append(record.getMessage())
    log = logging.getLogger("nptdms")
    log.addHandler(handler)
    try:
        tdms = TdmsFile.read(file)
        groups = tdms.groups()
        cols_read = {g.name: [np.asarray(c[:]) for c in g.channels()] for g in groups}
    except Exception as exc:  # npTDMS raises ValueError, KeyError, EOFError... on a damaged file
        raise ConfigError(f"{where}: not a readable TDMS file (cut short or damaged?): {type(exc).__name__}: "
                          f"{str(exc)[:120]}") from None
    finally:
        log.removeHandler(handler)
    short = [m for m in heard if "less data than expected" in m or "not a multiple" in m]
    if short:
        raise ConfigError(f"{where}: the file is cut short (npTDMS: {short[0][:100]})")
    names = [g.name for g in groups]
    group = explicit.get("group")
    if group is None:
        if len(groups) != 1:
            raise ConfigError(f"{where}: group: {'none' if not groups else ', '.join(names)}; name one with --group")
        g = groups[0]
    elif group not in names:
        raise ConfigError(f"{where}: group: no {group!r} (groups: {', '.join(names) or 'none'})")
    else:
        g = tdms[group]
    chans = g.channels()
    if not chans:
        raise ConfigError(f"{where}: group {g.name!r}: no channels")
    cols = cols_read[g.name]
    lengths = {c.name: len(v) for c, v in zip(chans, cols)}
    if len(set(lengths.values())) > 1:
        raise DimensionError(f"{where}: group {g.name!r}: channels of different lengths "
                             f"({', '.join(f'{k} {v}' for k, v in lengths.items())} samples)")
    for c, v in zip(chans, cols):
        if v.dtype.kind not in "fiu":
            raise ConfigError(f"{where}: channel {c.name!r}: data type {v.dtype} is not real numbers")
    units = [str(c.properties.get("unit_string", "")).strip() for c in chans]
    steps = {c.name: c.properties.get("wf_increment") for c in chans}
    known = {k: float(v) for k, v in steps.items() if v is not None}
    fs = None
    if known:
        if len(set(known.values())) > 1:
            raise ConfigError(f"{where}: group {g.name!r}: channels sampled at different rates (wf_increment "
                              f"{', '.join(f'{k} {v:g} s' for k, v in known.items())})")
        step = next(iter(known.values()))
        fs = 1.0 / step if step > 0 else step
    missing = [c.name for c, u in zip(chans, units) if not u]
    return checked(f"{where}: group {g.name!r}", np.column_stack(cols), [c.name for c in chans],
                   None if missing and len(missing) == len(chans) else units, fs, explicit)


READERS = {".csv": read_csv_columns, ".npy": read_npy_columns, ".mat": read_mat_columns, ".tdms": read_tdms_columns}


def read_columns(file: str | Path, options: dict) -> Columns:
    """The file's record by its suffix, the sidecar's fields under the options given."""
    file = Path(file)
    if not file.is_file():
        raise ConfigError(f"{file}: no such file")
    explicit = sidecar(file) | {k: v for k, v in options.items() if v is not None}
    return READERS[file.suffix.lower()](file, explicit)
