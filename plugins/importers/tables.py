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

Units: m/s^2, g, N, V, in any spelling ``odsuite.api.ascii_unit`` reads (see docs/importing.md).
"""

from __future__ import annotations

import csv
import io
import re
import struct
import tomllib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from odsuite.api import (MAX_CHANNELS, ConfigError, DimensionError, SensorType, ascii_unit, check_text_file,
                         free_memory, plain_number, printable_name)
from odsuite.contracts.daq import MAX_RATE_HZ, MIN_RATE_HZ

G = 9.80665
#: unit labels a column may carry, as ``unit_key`` spells them -> (sensor type, volts per SI unit of
#: the stored value): every importer reads its columns' units here
UNITS = {
    "n": (SensorType.LOADCELL, 1.0), "newtons": (SensorType.LOADCELL, 1.0),
    "m/s^2": (SensorType.ACCELEROMETER, 1.0), "g": (SensorType.ACCELEROMETER, 1.0 / G),
    "volts": (SensorType.VOLTAGE, 1.0), "v": (SensorType.VOLTAGE, 1.0), "volt": (SensorType.VOLTAGE, 1.0),
}


def unit_key(label: str) -> str:
    """A unit label as ``UNITS`` spells it: in the stored spelling (``ascii_unit``: m/s2, m/s**2 and
    m/s² are m/s^2, as estimate_frf reads them), in lower case (N, n)."""
    return ascii_unit(label).lower()

SIDECAR_FIELDS = ("sampling_rate", "channels", "units", "variable", "group")
#: .mat variables that give the rate (Hz), the channel names and their units
MAT_RATE = ("fs", "Fs", "sampling_rate", "rate")
MAT_NAMES = ("channels", "channel_names", "names")
MAT_UNITS = ("units",)
#: no accelerometer, load cell or voltage input reads beyond this (in the file's unit): such a value
#: is a wrong column or a fill value, and in g it would turn into an infinity in SI
MAX_VALUE = 1e12
#: names a message lists before it cuts the list (5,000 --channels names made a 34 kB line)
LISTED = 8


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
    check_text_file(side, "TOML sidecar")
    try:
        doc = tomllib.loads(side.read_text(encoding="utf-8"))
    except RecursionError:  # tomllib recurses per nesting level
        raise ConfigError(f"{side}: not a sidecar: arrays or tables nested too deeply") from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"{side}: not a readable TOML file: {exc}") from None
    unknown = sorted(set(doc) - set(SIDECAR_FIELDS))
    if unknown:
        raise ConfigError(f"{side}: unknown field {unknown[0]!r} (fields: {', '.join(SIDECAR_FIELDS)})")
    for k, v in doc.items():
        if k == "sampling_rate":
            ok = isinstance(v, int | float) and not isinstance(v, bool)
        elif k in ("channels", "units"):
            ok = isinstance(v, str) or isinstance(v, list) and all(isinstance(x, str) for x in v)
        else:
            ok = isinstance(v, str)
        if not ok:
            want = {"sampling_rate": "a number of Hz", "channels": "a text or a list of texts",
                    "units": "a text or a list of texts"}.get(k, "a text")
            raise ConfigError(f"{side}: field {k!r}: expected {want}, got {_brief(v)}")
    return doc


def _listed(names: list[str]) -> str:
    """Names for a message, the first ``LISTED`` of a long list and their count."""
    return ", ".join(names[:LISTED]) + (f", ... ({len(names)} in all)" if len(names) > LISTED else "")


def _list(value, n: int, where: str, field: str) -> list[str]:
    """A list of ``n`` strings from a list or a comma-separated string; one string for all."""
    if isinstance(value, str):
        value = [v.strip() for v in value.split(",")] if "," in value else [value.strip()] * (n if field == "units" else 1)
    items = [str(v).strip() for v in value]
    if len(items) != n:
        raise DimensionError(f"{where}: {field}: {len(items)} given for {n} column(s) ({_listed(items)})")
    return items


def check_names(where: str, names: list[str]) -> None:
    """One name per column, none given twice or empty."""
    dup = sorted({c for c in names if names.count(c) > 1})
    if dup or "" in names:
        raise ConfigError(f"{where}: channels: name {(dup or [''])[0]!r} is given twice or empty")


def check_values(where: str, names: list[str], units: list[str], a: np.ndarray) -> None:
    """Every sample (samples x columns) a finite number within what a sensor reads, ``where`` the
    file: else the project the record goes into was named, and the file not."""
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        i, k = bad[0]
        raise ConfigError(f"{where}: channel {names[k]!r}: sample {i}: value {a[i, k]} is not a finite number")
    big = np.argwhere(np.abs(a) > MAX_VALUE)
    if big.size:
        i, k = big[0]
        unit = f" {units[k]}" if units[k] else ""
        raise ConfigError(f"{where}: channel {names[k]!r}: sample {i}: value {a[i, k]:g}{unit} is beyond "
                          f"{MAX_VALUE:g}{unit}, which no sensor reads")


def checked(where: str, data, names, units, fs, explicit: dict, may_transpose: bool = False) -> Columns:
    """The columns checked: a 2-D array of finite numbers with two or more samples, one name and one
    known unit per column, a finite rate > 0; ``explicit`` (options, sidecar) fill and override.
    ``may_transpose``: an unnamed array that is channels x samples is read transposed."""
    try:
        with np.errstate(over="ignore"):  # a float128 of 1e400 becomes inf, refused below in one line
            a = np.asarray(data, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: data: not an array of numbers (dtype {np.asarray(data).dtype})") from None
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise DimensionError(f"{where}: data: shape {a.shape}; expected samples x channels (2-D)")
    if may_transpose and a.shape[1] > a.shape[0] and 0 < a.shape[0] <= 64:  # channels x samples, as MATLAB users store
        a = a.T
    if a.shape[0] < 2 or a.shape[1] < 1:
        raise DimensionError(f"{where}: data: shape {a.shape}; a record needs 2 or more samples of 1 or more channels")
    n = a.shape[1]
    if n > MAX_CHANNELS:
        raise DimensionError(f"{where}: data: {n} channels; odsuite records at most {MAX_CHANNELS}")
    names = explicit.get("channels", names)
    names = [f"ch{k + 1}" for k in range(n)] if names is None else _list(names, n, where, "channels")
    for k, c in enumerate(names):
        printable_name(f"{where}: channels: column {k + 1} name", c)
    check_names(where, names)
    units = explicit.get("units", units)
    fs = explicit.get("sampling_rate", fs)
    sidecar = Path(where).with_suffix('.toml').name
    if units is None and fs is None:  # both at once: the first try learns all a bare array lacks
        raise ConfigError(f"{where}: units and sampling_rate: not given (channels {_listed(names)}); give --units "
                          f"and --rate or a sidecar {sidecar} (units = \"m/s^2\" and sampling_rate = ... in Hz)")
    if units is None:
        raise ConfigError(f"{where}: units: not given (channels {_listed(names)}); give --units or "
                          f"a sidecar {sidecar} (units = \"m/s^2\")")
    units = _list(units, n, where, "units")
    for c, u in zip(names, units):
        if unit_key(u) not in UNITS:
            raise ConfigError(f"{where}: channel {c!r}: unit {u!r} is not one of m/s^2, g, N, V")
    check_values(where, names, units, a)
    if fs is None:
        raise ConfigError(f"{where}: sampling_rate: not given; give --rate or a sidecar {sidecar} "
                          "(sampling_rate = ... in Hz)")
    try:
        if isinstance(fs, bool):
            raise TypeError(fs)
        fs = float(fs)
    except (TypeError, ValueError, OverflowError):
        raise ConfigError(f"{where}: sampling_rate: {_brief(fs)} is not a number of Hz") from None
    if not (np.isfinite(fs) and fs > 0):
        raise ConfigError(f"{where}: sampling_rate: {fs!r} Hz; must be a finite rate > 0 Hz")
    if not MIN_RATE_HZ <= fs <= MAX_RATE_HZ:  # what a project stores and reads
        raise ConfigError(f"{where}: sampling_rate: {fs:g} Hz is outside {MIN_RATE_HZ:g} to {MAX_RATE_HZ:g} Hz")
    return Columns(names, units, a, fs)


def _unit_suffix(name: str) -> tuple[str, str | None]:
    """'acc1 [m/s^2]' or 'acc1 (g)' -> ('acc1', 'm/s^2'); a name without one -> (name, None)."""
    name = name.strip()
    for o, c in (("[", "]"), ("(", ")")):
        if name.endswith(c) and o in name:
            k = name.rindex(o)
            return name[:k].strip(), name[k + 1:-1].strip()
    return name, None


def _delimiter(text: str) -> str:
    """The header line's field separator: a semicolon or a tab where it has one (spreadsheets in
    locales that write decimal commas separate fields so), else a comma."""
    header = next((line for line in text.splitlines() if line.strip()), "")
    return ";" if ";" in header else "\t" if "\t" in header else ","


_SEPARATOR_WORDS = {",": "commas", ";": "semicolons", "\t": "tabs"}


def _field_count_message(where: str, line: int, fields: int, header_fields: int, delimiter: str) -> str:
    """A row whose field count differs from the header's, naming the separator both were split by
    (the header chose it: a header without any separator is the usual cause)."""
    counted = f"{fields} field{'s' if fields != 1 else ''} separated by {_SEPARATOR_WORDS[delimiter]}"
    if header_fields == 1:
        return (f"{where}: line {line}: {counted}, the header has 1 (it holds no comma, semicolon or tab: "
                "separate its names as the data are)")
    return f"{where}: line {line}: {counted} (the header's separator), the header has {header_fields}"


_DECIMAL_COMMA = re.compile(r"[+-]?[0-9]*,[0-9]+([eE][+-]?[0-9]+)?")


def _decimal_point(value: str, delimiter: str) -> str:
    """A number written with a decimal comma (``-0,125``, ``1,5e-3``) with a point instead, where
    the fields are not separated by commas; anything else as it is."""
    return value.replace(",", ".") if delimiter != "," and _DECIMAL_COMMA.fullmatch(value) else value


_NUMBER_TEXT = re.compile(r"[+-]?([0-9]*)(?:\.([0-9]*))?(?:[eE]([+-]?[0-9]+))?")


def _shown_digits(text: str) -> tuple[int, int]:
    """The decimals and significant digits a number's text shows: '0.000244' -> (6, 3),
    '2.44141e-04' -> (9, 6), '0' -> (0, 0)."""
    m = _NUMBER_TEXT.fullmatch(text)
    if m is None:
        return 0, 0
    whole, frac, exp = m.group(1), m.group(2) or "", int(m.group(3) or 0)
    return len(frac) - exp, len((whole + frac).lstrip("0"))


def _rate_of_time_column(where: str, column: str, texts: list[str], t: np.ndarray, lines: list[int],
                         time_unit: str = "s") -> float:
    """The sampling rate (per ``time_unit``) of an evenly spaced time column (in ``time_unit``), from its
    whole span.

    A lab's file rounds its times (``%.6f`` at 4096 Hz has steps of 0.000244 and 0.000245 s), so
    each time may lie off the even grid by half a unit of its last printed digit. That unit comes
    from the column itself: the most decimals and the most significant digits any row shows (a
    fixed-decimals format and a significant-digits one alike; a row whose trailing zeros were
    dropped keeps the others' precision), plus the float's own rounding. Steps or times off the
    grid by more are uneven sampling, refused naming the row (``lines``: each time's line in the file)."""
    n = t.size - 1
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        k = int(bad[0])
        raise ConfigError(f"{where}: line {lines[k]}: channel {column!r}: value {texts[k]!r} is not a finite time")
    if n < 1:
        raise ConfigError(f"{where}: channel {column!r}: one time only; the rate needs two or more")
    decimals, significant = map(max, zip(*(_shown_digits(x) for x in texts)))
    with np.errstate(divide="ignore"):
        magnitude = np.floor(np.log10(np.abs(t)))
    unit = np.maximum(10.0 ** -decimals, np.where(t == 0, 0.0, 10.0 ** (magnitude + 1 - significant)))
    half = 0.5 * unit + 2 * np.spacing(np.abs(t).max())
    steps = np.diff(t)
    if not np.all(steps > 0):
        k = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise ConfigError(f"{where}: line {lines[k]}: channel {column!r}: value {texts[k]!r} does not come after "
                          f"the time before it ({texts[k - 1]!r})")
    span = t[-1] - t[0]
    dt = span / n
    # a step between two rounded times, against the mean step between the two rounded ends
    allowed = half[:-1] + half[1:] + (half[0] + half[-1]) / n
    off = np.flatnonzero(np.abs(steps - dt) > allowed)
    if off.size:
        k = int(off[0]) + 1
        raise ConfigError(f"{where}: line {lines[k]}: channel {column!r}: value {texts[k]!r} is {steps[k - 1]:.6g} {time_unit} "
                          f"after the time before it, the mean step {dt:.6g} {time_unit} (the column's rounding allows "
                          f"{allowed[k - 1]:.2g} {time_unit} either way): not evenly spaced")
    # every time against the grid through the ends: a slowly changing rate
    allowed = half + half[0] + half[-1] + n * np.spacing(np.abs(t).max())
    deviation = np.abs(t - (t[0] + dt * np.arange(n + 1)))
    off = np.flatnonzero(deviation > allowed)
    if off.size:
        k = int(off[0])
        raise ConfigError(f"{where}: line {lines[k]}: channel {column!r}: value {texts[k]!r} lies {deviation[k]:.2g} {time_unit} "
                          f"off the even spacing from the first time to the last (the column's rounding allows "
                          f"{allowed[k]:.2g} {time_unit}): not evenly spaced")
    # the rate as the fewest digits the rounded ends allow: a 4096 Hz file of 6 decimals is 4096 Hz
    lo = n / (span + half[0] + half[-1])
    hi = n / (span - half[0] - half[-1]) if span > half[0] + half[-1] else np.inf
    fs = n / span
    return next((r for r in (float(f"{fs:.{d}g}") for d in range(1, 18)) if lo <= r <= hi), fs)


def _first_nul_line(file: Path, block: int = 1 << 20) -> int | None:
    """The line of a byte-oriented file's first NUL byte (None: none, or UTF-16, whose text holds
    them): read block by block, so a binary or sparse file named .csv is refused at its first
    block, not after the whole of it has been read (a sparse 2 GiB file: 10 s)."""
    try:
        with open(file, "rb") as f:
            if f.read(2) in (b"\xff\xfe", b"\xfe\xff"):
                return None
            f.seek(0)
            lines = 1
            while chunk := f.read(block):
                at = chunk.find(b"\x00")
                if at >= 0:
                    return lines + chunk.count(b"\n", 0, at)
                lines += chunk.count(b"\n")
    except OSError:
        return None  # the read below names it
    return None


#: a time column's units (its header's ``[unit]``): how many make a second (a rate per unit times
#: it is per second, exactly where the rate is a whole number)
TIME_UNITS = {"s": 1.0, "ms": 1e3, "us": 1e6, "\u00b5s": 1e6, "ns": 1e9}


def read_csv_columns(file: Path, explicit: dict) -> Columns:
    """A CSV record: a header row of channel names (each may end in its unit, ``acc1 [m/s^2]``),
    then one row per sample; a first column named time/t (s) gives the rate. Fields separated by
    commas, or by semicolons or tabs (then numbers may have a decimal comma)."""
    where = str(file)
    check_text_file(file, "CSV")
    nul = _first_nul_line(file)
    if nul is not None:
        raise ConfigError(f"{where}: not a CSV table: a NUL character at line {nul} (binary data)")
    try:
        raw = file.read_bytes()
        # UTF-8, or UTF-16 where its byte-order mark says so (a spreadsheet's "Unicode text")
        text = raw.decode("utf-16" if raw[:2] in (b"\xff\xfe", b"\xfe\xff") else "utf-8-sig")
        del raw
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{where}: not a readable text file: {exc}") from None
    # no text holds NUL characters (a UTF-16 file's bytes do: its text is checked), refused before
    # the csv module holds it as one field (a sparse 2 GiB file took 12 GB and 40 s to refuse)
    nul = text.find("\x00")
    if nul >= 0:
        raise ConfigError(f"{where}: not a CSV table: a NUL character at line {text.count(chr(10), 0, nul) + 1} "
                          "(binary data)")
    delimiter = _delimiter(text)
    try:
        # the text as a stream: a quoted name that holds a line break keeps it (and is then refused)
        reader = csv.reader(io.StringIO(text, newline=""), delimiter=delimiter)
        rows, lines, read = [], [], 0
        for r in reader:  # blank lines skipped, each row with its first line in the file (refusals name it)
            if any(c.strip() for c in r):
                rows.append(r)
                lines.append(read + 1)
            read = reader.line_num
    except csv.Error as exc:  # a field over the csv module's limit (131072 characters)
        raise ConfigError(f"{where}: not a CSV table: {exc}") from None
    if not rows:
        raise ConfigError(f"{where}: empty: no header and no samples")
    header = [c.strip() for c in rows[0]]
    parsed = [_unit_suffix(h) for h in header]
    names, units = [p[0] for p in parsed], [p[1] for p in parsed]
    values = []
    for line, r in zip(lines[1:], rows[1:]):
        if len(r) != len(header):
            raise DimensionError(_field_count_message(where, line, len(r), len(header), delimiter))
        row = []
        for c, v in zip(names, r):
            try:
                row.append(plain_number(_decimal_point(v.strip(), delimiter)))
            except ValueError:
                raise ConfigError(f"{where}: line {line}: channel {c!r}: value {v.strip()!r} is not a number") from None
        values.append(row)
    if not values:
        raise ConfigError(f"{where}: empty: a header and no samples")
    data = np.array(values)
    fs = None
    if names[0].lower() in ("time", "t") and len(names) > 1:
        unit = (units[0] or "s").strip()
        if unit not in TIME_UNITS:
            raise ConfigError(f"{where}: channel {names[0]!r}: time unit {unit!r} is not one of "
                              f"{', '.join(TIME_UNITS)}")
        texts = [_decimal_point(r[0].strip(), delimiter) for r in rows[1:]]
        # the rate in the column's own unit, then per second (a rounding check needs its printed digits)
        fs = _rate_of_time_column(where, names[0], texts, data[:, 0], lines[1:], unit) * TIME_UNITS[unit]
        names, units, data = names[1:], units[1:], data[:, 1:]
    given = None if all(u is None for u in units) else units
    if given is not None and any(u is None for u in units):
        k = units.index(None)
        raise ConfigError(f"{where}: channel {names[k]!r}: no unit in its header (e.g. '{names[k]} [m/s^2]') "
                          "while others have one")
    return checked(where, data, names, given, fs, explicit)


def _npy_size_checked(file: Path, where: str) -> None:
    """Refuse, before numpy allocates it, an array whose header promises other bytes than the file
    holds (a header saying 10^11 rows makes np.load ask for terabytes)."""
    import math

    import numpy.lib.format as fmt

    with open(file, "rb") as f:
        try:
            version = fmt.read_magic(f)
            read = fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0
            shape, _, dtype = read(f)
        except OSError:
            raise
        except Exception as exc:  # noqa: BLE001 - numpy parses a damaged header with tokenize and ast
            raise ConfigError(f"{where}: not a NumPy .npy array file: header: {_library_message(exc)}") from None
        have = file.stat().st_size - f.tell()
    if dtype.hasobject:
        return  # np.load refuses object arrays itself (no pickles)
    need = math.prod(shape) * dtype.itemsize
    if need != have:
        raise ConfigError(f"{where}: header says shape {shape} of {dtype} ({need} bytes), the file holds {have} "
                          "bytes after it (cut short, or not written by numpy)")


def read_npy_columns(file: Path, explicit: dict) -> Columns:
    where = str(file)
    try:
        _npy_size_checked(file, where)
        data = np.load(file, allow_pickle=False)
    except ConfigError:
        raise
    except (OSError, ValueError, EOFError) as exc:
        raise ConfigError(f"{where}: not a NumPy .npy array file: {_library_message(exc)}") from None
    if data.dtype.kind not in "fiu":  # not bool, complex, datetime64 or timedelta64
        raise ConfigError(f"{where}: data: dtype {data.dtype} is not real numbers")
    return checked(where, data, None, None, None, explicit, may_transpose=True)


def _mat_text(value, where: str, variable: str) -> list[str] | str:
    """Names or units: a char array, a cell array of char arrays (or of numbers)."""
    a = np.asarray(value)
    if a.size == 0:
        raise ConfigError(f"{where}: variable {variable!r}: empty")
    if a.dtype.kind in "US":
        return [str(v).strip() for v in a.ravel()] if a.size > 1 else str(a.ravel()[0]).strip()
    out = []
    for v in a.ravel():  # a cell array
        e = np.asarray(v)
        if e.size == 0 or e.dtype.kind not in "USfiu":
            raise ConfigError(f"{where}: variable {variable!r}: expected text in each cell, got {_brief(v)}")
        out.append(str(e.ravel()[0]).strip())
    return out


def _library_message(exc: BaseException) -> str:
    """A reader library's message about a damaged file as a short printable line (scipy quotes the
    damaged bytes themselves, line breaks included)."""
    text = str(exc).strip() or type(exc).__name__
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
    return text if len(text) <= 120 else text[:117] + "..."


def _brief(value) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


#: a variable named as a rate in a longer name (the vibration toolbox's ``Time_Sample_Rate``)
MAT_RATE_SUFFIX = re.compile(r"(?:^|_)(?:sample|sampling)_?rate$", re.IGNORECASE)


def _mat_rate(mat: dict, where: str) -> float | None:
    """The sampling rate a .mat file holds (Hz): one real number under one of MAT_RATE's names, else
    under the one variable whose name ends as a rate does (``Time_Sample_Rate``); several such
    names are refused, as nothing tells which is the records'."""
    names = [k for k in MAT_RATE if k in mat]
    if not names:
        names = [k for k in mat if not k.startswith("__") and MAT_RATE_SUFFIX.search(k)]
        if len(names) > 1:
            raise ConfigError(f"{where}: variables {', '.join(map(repr, sorted(names)))} each name a sampling "
                              f"rate: give --rate")
    for k in names:
        if k in mat:
            a = mat[k]
            if not isinstance(a, np.ndarray) or a.size != 1 or a.dtype.kind not in "fiu":
                raise ConfigError(f"{where}: variable {k!r} (sampling rate): expected one real number of Hz, "
                                  f"got {_brief(a)}")
            return float(a.ravel()[0])
    return None


def _refuse_cut(file: Path, cut_of, kind: str) -> None:
    """Refuse ``file`` in one line where ``cut_of`` (_tdms_cut) finds it cut short: the
    readers take a file cut inside a tag or a lead-in for a shorter, whole one."""
    try:
        cut = cut_of(file)
    except OSError as exc:
        raise ConfigError(f"{file}: not a readable {kind} file: {exc.strerror or exc}") from None
    if cut is not None:
        raise ConfigError(f"{file}: {cut}")


#: a MATLAB v5-v7.2 file: a header of this many bytes, then one element per variable, each a tag
#: (type, byte count) and its bytes
MAT_HEADER = 128


class _MatRefused(Exception):
    """A .mat file cut short of what its tags declare, or holding an element scipy cannot read
    safely; the message says which and where."""


def _mat_order(f, size: int) -> str | None:
    """The byte order ('<' or '>') of the v5-v7.2 .mat file open as ``f``; None for another version
    (v4, v7.3: HDF5) or no .mat at all (scipy's read names it). Raises _MatRefused for a header cut
    short."""
    from scipy.io.matlab import matfile_version

    if f.read(6) == b"MATLAB" and size < MAT_HEADER:  # v5 or v7.3 (HDF5 behind this header)
        raise _MatRefused(f"cut short at byte {size}: its header has {size} of its {MAT_HEADER} bytes")
    f.seek(0)
    try:
        if matfile_version(f)[0] != 1:
            return None
    except Exception:  # noqa: BLE001 - not a .mat file at all: scipy's read names it
        return None
    return "<" if f.seek(126) == 126 and f.read(2) == b"IM" else ">"


def _mat_variables(f, size: int, order: str) -> Iterator[io.BytesIO]:
    """Each variable of the v5 .mat file open as ``f``, checked (``_mat_damage``), as a file of one
    variable for scipy to read (the file's header, then the variable as stored, or a compressed one
    decompressed: once, scipy reads the bytes the check saw). Raises _MatRefused where the file stops
    short of what its tags declare (scipy reads a file cut inside a tag as if it ended before it:
    without its later variables) or holds an element scipy cannot read safely."""
    f.seek(0)
    header = f.read(MAT_HEADER)
    pos, k = MAT_HEADER, 1
    while pos < size:
        f.seek(pos)
        tag = f.read(8)
        if len(tag) < 8:
            raise _MatRefused(f"cut short at byte {size}: variable {k}'s tag at byte {pos} has {len(tag)} of its 8 bytes")
        kind, count = struct.unpack(order + "II", tag)
        end = pos + 8 + count
        if end > size:
            raise _MatRefused(f"cut short at byte {size}: variable {k} at byte {pos} declares its data up to byte {end}")
        damage = _mat_damage(f, pos, end, order)
        one = io.BytesIO()
        one.write(header)
        if damage is None and kind == 15:
            f.seek(pos + 8)
            damage = _mat_inflated(f.read(count), one, order, f"variable {k} at byte {pos}")
        elif damage is None:
            f.seek(pos)
            _copied(f, one, end - pos)
        if damage is not None:
            raise _MatRefused(f"damaged: variable {k} at byte {pos}: {damage}")
        one.seek(0)
        yield one
        pos = end + (-count % 8 if kind != 15 else 0)  # all but compressed ones padded to 8 bytes
        k += 1


#: bytes a variable is decompressed and copied by at a time (no second copy of it in memory)
CHUNK = 1 << 20


def _copied(f, out: io.BytesIO, count: int) -> None:
    """``count`` bytes of ``f`` from where it stands onto ``out``."""
    while count > 0:
        chunk = f.read(min(count, CHUNK))
        if not chunk:  # shortened since its size was read
            raise _MatRefused(f"cut short at byte {f.tell()} while it was read")
        count -= out.write(chunk)


def _mat_inflated(data: bytes, out: io.BytesIO, order: str, where: str) -> str | None:
    """A compressed variable's ``data`` decompressed onto the end of ``out`` and what is wrong with
    the element they hold (None: nothing). They may expand to at most the memory free (a few kB of
    zeros expand to gigabytes): beyond it _MatRefused names the variable (``where``)."""
    import zlib

    free = free_memory()
    start = out.tell()
    inflate = zlib.decompressobj()
    try:
        while data:
            out.write(inflate.decompress(data, CHUNK))
            data = inflate.unconsumed_tail
            if free is not None and out.tell() - start > free:
                raise _MatRefused(f"{where}: its compressed data expand beyond the {free / 2**20:.0f} MiB of "
                                  "memory free")
        out.write(inflate.flush())
        if not inflate.eof:  # what zlib.decompress raises on a stream cut short
            raise zlib.error("Error -5 while decompressing data: incomplete or truncated stream")
    except zlib.error as exc:
        return f"its compressed data cannot be decompressed ({exc})"
    end = out.tell()
    if end - start < 8:
        return f"its compressed data hold {end - start} bytes, not an element"
    return _mat_damage(out, start, end, order, 1)


#: the data types of a v5 element's tag and their item sizes (None: elements inside; 8, 10 and 11
#: are reserved). scipy's reader crashes the process (a segmentation fault) on a type not listed.
MAT_TYPES = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 4, 9: 8, 12: 8, 13: 8, 14: None, 15: None, 16: 1, 17: 2, 18: 4}
#: cells of cells nested deeper than this are no record (and would exhaust Python's recursion)
MAT_DEPTH = 64


def _mat_damage(f, start: int, end: int, order: str, depth: int = 0) -> str | None:
    """What is wrong with the v5 element at byte ``start`` of stream ``f`` (the file, or a compressed
    variable's data) and the elements inside it, up to byte ``end``; None: nothing."""
    if depth > MAT_DEPTH:
        return f"elements nested deeper than {MAT_DEPTH} levels"
    f.seek(start)
    tag = f.read(8)
    if len(tag) < 8:
        return f"an element's tag has {len(tag)} of its 8 bytes"
    kind, count = struct.unpack(order + "II", tag)
    small = kind >> 16  # a small element: type and byte count in the tag's first 4 bytes, data in the others
    if small:
        kind, count = kind & 0xFFFF, small
    if kind not in MAT_TYPES or (kind == 15 and depth):
        return f"an element of data type {kind}, which MATLAB does not write"
    if MAT_TYPES[kind] and count % MAT_TYPES[kind]:
        return f"an element of data type {kind} of {count} bytes, not a whole number of {MAT_TYPES[kind]}-byte values"
    if start + 8 + (0 if small else count) > end:
        return f"an element of {count} bytes runs past the end of the element holding it"
    # a compressed variable's own elements are checked once decompressed (``_mat_variables``)
    pos, stop = start + 8, start + 8 + count
    while kind == 14 and pos < stop:  # a matrix: its flags, dimensions, name and data, each an element
        if pos + 8 > stop:
            return "an element cut short by the end of the matrix holding it"
        damage = _mat_damage(f, pos, stop, order, depth + 1)
        if damage is not None:
            return damage
        f.seek(pos)
        head, size = struct.unpack(order + "II", f.read(8))
        pos += 8 if head >> 16 else 8 + size + (-size % 8)
    return None


def _loadmat_checked(file: Path) -> dict:
    """scipy.io.loadmat(file), a v5-v7.2 file's variables each checked first (``_mat_variables``)
    and read from the bytes checked, each after the file's header as scipy's ``varmats_from_mat``
    splits a file: a compressed variable is decompressed once, and one variable at a time."""
    import scipy.io

    size = file.stat().st_size
    with open(file, "rb") as f:
        order = _mat_order(f, size)
        if order is None:
            return scipy.io.loadmat(file)
        variables: dict = {}
        for one in _mat_variables(f, size, order):
            variables.update(scipy.io.loadmat(one))
        return variables


def _loadmat_apart(file: Path) -> dict:
    """``_loadmat_checked(file)`` run in a forked child: scipy's compiled reader crashes the process
    on some damaged files (a char array's dimensions past its data, a complex flag without imaginary
    part), which is then refused naming the signal instead of ending odsuite without a word, and a
    compressed variable expands in the child's memory, not odsuite's."""
    import os
    import pickle
    import signal

    if not hasattr(os, "fork"):
        return _loadmat_checked(file)
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: the variables or the exception, pickled, then out without cleanup
        os.close(read_end)
        try:
            try:
                payload = pickle.dumps(("ok", _loadmat_checked(file)), protocol=pickle.HIGHEST_PROTOCOL)
            except Exception as exc:  # noqa: BLE001 - sent to the parent, which decides
                payload = pickle.dumps(("error", exc if isinstance(exc, NotImplementedError | _MatRefused | OSError)
                                        else ValueError(_library_message(exc))))
            with os.fdopen(write_end, "wb") as out:
                out.write(payload)
        finally:
            os._exit(0)
    os.close(write_end)
    with os.fdopen(read_end, "rb") as pipe:
        data = pipe.read()
    status = os.waitpid(pid, 0)[1]
    if os.WIFSIGNALED(status) or not data:
        code = os.WTERMSIG(status) if os.WIFSIGNALED(status) else os.WEXITSTATUS(status)
        name = signal.Signals(code).name if os.WIFSIGNALED(status) else f"exit code {code}"
        raise ValueError(f"scipy's reader crashed on it ({name}): the file is damaged")
    kind, value = pickle.loads(data)
    if kind == "error":
        raise value
    return value


def read_mat_columns(file: Path, explicit: dict) -> Columns:
    """A MATLAB .mat (v4-v7.2 via scipy.io; v7.3 is HDF5, via h5py): the array ``variable``, else
    the file's only 2-D numeric array; ``fs``/``sampling_rate``, ``channels`` and ``units``
    variables when present."""
    where = str(file)
    try:
        mat = {k: v for k, v in _loadmat_apart(file).items() if not k.startswith("__")}
    except _MatRefused as exc:
        raise ConfigError(f"{where}: {exc}") from None
    except OSError as exc:
        raise ConfigError(f"{where}: not a readable MATLAB .mat file: {exc.strerror or exc}") from None
    except NotImplementedError:  # v7.3: HDF5
        mat = _mat73(file)
    except Exception as exc:  # noqa: BLE001 - scipy raises MatReadError, IndexError, ValueError... on a damaged file
        raise ConfigError(f"{where}: not a readable MATLAB .mat file: {_library_message(exc)}") from None
    numeric = {k: v for k, v in mat.items() if isinstance(v, np.ndarray) and v.dtype.kind in "fiu" and v.size > 1}
    variable = explicit.get("variable")
    names = None
    if variable is not None:
        # several vectors of one length, one channel each (an analyser's export: force and response
        # stored apart, Time_chan_1 and Time_chan_2), named after them
        parts = [v.strip() for v in variable.split(",")]
        for v in parts:
            if v not in mat:
                raise ConfigError(f"{where}: variable: no {v!r} (variables: {_listed(list(mat)) or 'none'})")
        data = mat[parts[0]]
        if len(parts) > 1:
            columns = [np.asarray(mat[v]) for v in parts]
            if any(c.dtype.kind not in "fiu" or c.squeeze().ndim != 1 for c in columns) \
                    or len({c.size for c in columns}) != 1:
                raise DimensionError(f"{where}: variable {variable!r}: several variables are read as one column "
                                     f"each, so each must be a vector of real numbers of one length, got shapes "
                                     f"{', '.join(str(c.shape) for c in columns)}")
            data, names = np.column_stack([c.reshape(-1) for c in columns]), parts
    elif len(numeric) == 1:
        variable, data = next(iter(numeric.items()))
    else:
        raise ConfigError(f"{where}: variable: {'no numeric array' if not numeric else f'{len(numeric)} arrays ({_listed(list(numeric))})'}"
                          f"{'' if not numeric else '; name one with --variable'}")
    if not isinstance(data, np.ndarray) or data.dtype.kind not in "fiu":
        raise ConfigError(f"{where}: variable {variable!r}: not an array of real numbers")
    fs = None if "sampling_rate" in explicit else _mat_rate(mat, where)
    names = names or next((_mat_text(mat[k], where, k) for k in MAT_NAMES if k in mat), None)
    units = next((_mat_text(mat[k], where, k) for k in MAT_UNITS if k in mat), None)
    return checked(f"{where}: variable {variable!r}", data, names, units, fs, explicit, may_transpose=True)


def _mat73(file: Path) -> dict:
    import h5py

    free = free_memory()
    try:
        with h5py.File(file, "r") as f:
            out = {}
            for k in f:
                # only the file's own datasets: a link, external storage or a virtual dataset would
                # make HDF5 read another file (MATLAB writes none of them)
                if not isinstance(f.get(k, getlink=True), h5py.HardLink):
                    continue
                ds = f[k]
                if not isinstance(ds, h5py.Dataset) or ds.dtype.kind not in "fiu":
                    continue
                if ds.external or ds.is_virtual:
                    raise ConfigError(f"{file}: variable {k!r}: its data are stored in other files (HDF5 "
                                      "external storage or a virtual dataset); refused")
                if free is not None and ds.size * 8 > free:
                    raise ConfigError(f"{file}: variable {k!r}: shape {ds.shape} needs {ds.size * 8 / 2**20:.0f} "
                                      f"MiB; only {free / 2**20:.0f} MiB of memory are free")
                value = np.asarray(ds[()]).T  # MATLAB stores column-major
                if ds.attrs.get("MATLAB_class") in (b"char", "char"):  # text as UTF-16 code units
                    value = "".join(map(chr, value.ravel()))
                out[k] = value
            return out
    except ConfigError:
        raise
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as exc:  # h5py on a damaged file
        raise ConfigError(f"{file}: not a readable MATLAB .mat file (v7.3/HDF5): {_library_message(exc)}") from None


#: a TDMS segment's lead-in: tag, table of contents, version, then the offsets of the next segment
#: and of the raw data, each counted from the lead-in's end
TDMS_LEAD_IN = 28
TDMS_UNSET = 0xFFFFFFFFFFFFFFFF


def _tdms_cut(file: Path) -> str | None:
    """How a TDMS file stops short of what its segments' lead-ins declare (None: it holds them all).
    npTDMS reads a file cut inside a lead-in as if it ended before it (a record of fewer samples),
    and one cut inside the first segment's metadata as a file of no groups."""
    size = file.stat().st_size
    if size == 0:
        return "empty: 0 bytes, no TDMS segment"
    pos = 0
    with open(file, "rb") as f:
        while pos < size:
            f.seek(pos)
            lead = f.read(TDMS_LEAD_IN)
            if lead[:4] != b"TDSm"[:len(lead)]:
                return (f"not a TDMS file: it starts with {lead[:4]!r}, not b'TDSm'" if pos == 0 else
                        f"damaged: the segment at byte {pos} starts with {lead[:4]!r}, not b'TDSm'")
            if len(lead) < TDMS_LEAD_IN:
                return (f"cut short at byte {size}: the segment at byte {pos} has {len(lead)} of its "
                        f"{TDMS_LEAD_IN} lead-in bytes")
            toc = struct.unpack("<l", lead[4:8])[0]
            nxt, meta = struct.unpack((">" if toc & (1 << 6) else "<") + "QQ", lead[12:28])
            start = pos + TDMS_LEAD_IN
            if nxt == TDMS_UNSET:  # the writer stopped before it closed the segment
                return f"cut short: the segment at byte {pos} was never completed (its length is unset)"
            if start + meta > size:
                return (f"cut short at byte {size}: the segment at byte {pos} declares metadata up to byte "
                        f"{start + meta}")
            if start + nxt > size:
                return (f"cut short at byte {size}: the segment at byte {pos} declares data up to byte "
                        f"{start + nxt}")
            pos = start + nxt
    return None


def read_tdms_columns(file: Path, explicit: dict) -> Columns:
    """An NI TDMS file (npTDMS): the channels of ``group`` (default: the file's only group), each
    with its ``unit_string`` and ``wf_increment`` (s) properties."""
    from nptdms import TdmsFile

    import logging

    where = str(file)
    _refuse_cut(file, _tdms_cut, "TDMS")
    # npTDMS reads a file cut short as far as it goes and only logs it: its warnings are caught
    heard: list[str] = []
    handler = logging.Handler(logging.WARNING)
    handler.emit = lambda record: heard.append(record.getMessage())
    log = logging.getLogger("nptdms")
    # npTDMS gives each of its loggers a console handler: its warnings would be printed besides our line
    own = [(lg, lg.handlers[:]) for n, lg in logging.root.manager.loggerDict.items()
           if n.startswith("nptdms") and isinstance(lg, logging.Logger)]
    for lg, _ in own:
        lg.handlers = []
    log.addHandler(handler)
    try:
        tdms = TdmsFile.read(file)
        groups = tdms.groups()
        cols_read = {g.name: [np.asarray(c[:]) for c in g.channels()] for g in groups}
    except Exception as exc:  # npTDMS raises ValueError, KeyError, EOFError... on a damaged file
        raise ConfigError(f"{where}: not a readable TDMS file (cut short or damaged?): {type(exc).__name__}: "
                          f"{_library_message(exc)}") from None
    finally:
        log.removeHandler(handler)
        for lg, handlers in own:
            lg.handlers = handlers
    short = [m for m in heard if any(w in m for w in ("less data than expected", "not a multiple", "incomplete"))]
    if short:
        raise ConfigError(f"{where}: the file is cut short (npTDMS: {short[0][:100]})")
    names = [g.name for g in groups]
    group = explicit.get("group")
    if not groups:
        raise ConfigError(f"{where}: no groups, so no channels")
    if group is None:
        if len(groups) != 1:
            raise ConfigError(f"{where}: group: {len(names)} groups ({_listed(names)}); name one with --group")
        g = groups[0]
    elif group not in names:
        raise ConfigError(f"{where}: group: no {group!r} (groups: {_listed(names)})")
    else:
        g = tdms[group]
    chans = g.channels()
    if not chans:
        raise ConfigError(f"{where}: group {g.name!r}: no channels")
    cols = cols_read[g.name]
    lengths = {c.name: len(v) for c, v in zip(chans, cols)}
    if len(set(lengths.values())) > 1:
        raise DimensionError(f"{where}: group {g.name!r}: channels of different lengths "
                             f"({_listed([f'{k} {v}' for k, v in lengths.items()])} samples)")
    for c, v in zip(chans, cols):
        if v.dtype.kind not in "fiu":
            raise ConfigError(f"{where}: channel {c.name!r}: data type {v.dtype} is not real numbers")
    units = [str(c.properties.get("unit_string", "")).strip() for c in chans]
    steps = {c.name: c.properties.get("wf_increment") for c in chans}
    known = {}
    for k, v in steps.items():
        if v is None:
            continue
        if isinstance(v, bool | np.bool_) or not isinstance(v, int | float | np.integer | np.floating):
            raise ConfigError(f"{where}: channel {k!r}: property wf_increment is {_brief(v)}, not a number of "
                              "seconds")
        known[k] = float(v)
    fs = None
    if known:
        if len(set(known.values())) > 1:
            raise ConfigError(f"{where}: group {g.name!r}: channels sampled at different rates (wf_increment "
                              f"{_listed([f'{k} {v:g} s' for k, v in known.items()])})")
        step = next(iter(known.values()))
        fs = 1.0 / step if step > 0 else step
    missing = [c.name for c, u in zip(chans, units) if not u]
    return checked(f"{where}: group {g.name!r}", np.column_stack(cols), [c.name for c in chans],
                   None if missing and len(missing) == len(chans) else units, fs, explicit)


READERS = {".csv": read_csv_columns, ".npy": read_npy_columns, ".mat": read_mat_columns, ".tdms": read_tdms_columns}


def read_columns(file: str | Path, options: dict, suffix: str | None = None) -> Columns:
    """The file's record by ``suffix`` (the importer's, when --format chose it) or the file's own,
    the sidecar's fields under the options given."""
    file = Path(file)
    if file.is_dir():
        raise ConfigError(f"{file}: a folder, not a file")
    if not file.is_file():
        raise ConfigError(f"{file}: no such file")
    kind = (suffix or file.suffix).lower()
    if kind not in READERS:
        raise ConfigError(f"{file}: suffix {kind!r} is none of {', '.join(READERS)}")
    explicit = sidecar(file) | {k: v for k, v in options.items() if v is not None}
    return READERS[kind](file, explicit)
