"""Codecs for the thesis's LabVIEW files (App. E, Table E.1): ``.CTR`` Systeminfo, ``.DAT``/``.VIZ``
data and ``.COD`` generalized coordinates.

All are "spreadsheet compatible" text: tab-delimited (whitespace is accepted too). Units at this edge:
``.CTR`` sensitivities are mV per unit and lengths (rows 22-27, 30-32) are mm; inside they are V per
SI unit and metres. ``.DAT``/``.VIZ`` hold the volts the DAQ recorded (App. D.1, Eq. 4.3: the signal
processor converts them later with the Systeminfo); ``.COD`` holds ``[x y z theta phi psi]`` per plate
in metres and radians, platform first.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace
from decimal import Decimal
from pathlib import Path

import numpy as np

from odsuite.core.errors import ConfigError, DimensionError
from odsuite.core.systeminfo import (
    CHANNEL_FIELDS,
    ChannelInfo,
    FilterFamily,
    FilterType,
    Integration,
    RigInfo,
    Systeminfo,
    enum_code,
    filters_on_code,
    sensor_type_code,
    where,
)

N_ROWS = 34
#: Rows odsuite adds after Table E.2's 34, per channel, written only when a channel departs from
#: the thesis's behaviour (so thesis files stay 34 rows): 34 zero-phase filtering (0 no, 1 yes),
#: 35 integration rule (0 the thesis's Eq. 4.5, 1 trapezoid).
EXTRA_ROWS = ("zero_phase", "integration_rule")
INTEGRATION_RULES = ("thesis", "trapezoid")
NO_VALUE = ("", "-")

_SEPARATOR_LINE = re.compile(r"^[\s|:+-]*-{3,}[\s|:+-]*$")


# ---------------------------------------------------------------------------------------------
# .CTR (Systeminfo, Table E.2)


def _separator(text: str) -> str | None:
    """The file's cell separator: ``|`` (a table copied from the thesis), a tab (the LabVIEW
    spreadsheet format) or None (whitespace). Decided once per file: a tab-delimited cell may
    hold spaces (a sensor location such as "corner C x")."""
    return "|" if "|" in text else "\t" if "\t" in text else None


def _split(line: str, sep: str | None) -> list[str]:
    """Cells of one line; with a separator, empty cells are kept."""
    if sep == "|":
        body = line.strip()
        body = body[1:] if body.startswith("|") else body
        body = body[:-1] if body.endswith("|") else body
        return [c.strip() for c in body.split("|")]
    if sep == "\t":
        return [c.strip() for c in line.split("\t")]
    return line.split()


def _ctr_rows(text: str, source: str | Path) -> list[list[str]]:
    """The 34 rows of cells, from either the bare 34 x n array or the table as printed in the thesis
    (a header line starting with "Row" and each row led by its number)."""
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    while lines and not lines[0].strip():
        lines.pop(0)
    if not lines:
        raise ConfigError(f"{source}: empty file")
    sep = _separator(text)
    labelled = next((i for i, line in enumerate(lines)
                     if (_split(line, sep) or [""])[0].lower() == "row"), None)
    if labelled is None:
        if len(lines) not in (N_ROWS, N_ROWS + len(EXTRA_ROWS)):
            raise ConfigError(f"{source}: expected {N_ROWS} rows (Table E.2), found {len(lines)}")
        return [_split(line, sep) for line in lines]
    rows: dict[int, list[str]] = {}
    for number, line in enumerate(lines[labelled + 1:], start=labelled + 2):
        if not line.strip() or _SEPARATOR_LINE.match(line):
            continue
        cells = _split(line, sep)
        if not cells[0].isdigit() or int(cells[0]) != len(rows):
            raise ConfigError(f"{source}: line {number}: expected row number {len(rows)}, "
                              f"got {cells[0]!r}")
        rows[len(rows)] = cells[1:]
    if len(rows) != N_ROWS:
        raise ConfigError(f"{source}: expected {N_ROWS} rows (Table E.2), found {len(rows)}")
    return [rows[r] for r in range(N_ROWS)]


def _number(cell: str, place: str) -> float | None:
    if cell in NO_VALUE:
        return None
    try:
        value = float(cell)
    except ValueError:
        raise ConfigError(f"{place}: not a number: {cell!r}") from None
    if not np.isfinite(value):
        raise ConfigError(f"{place}: not a finite number: {cell!r}")
    return value


def _from_milli(cell: str, place: str) -> float | None:
    """A mV or mm cell in V or m: the decimal point moved exactly, then rounded once to a float."""
    if _number(cell, place) is None:
        return None
    return float(Decimal(cell).scaleb(-3))


def _flag(cell: str, place: str) -> bool | None:
    value = _number(cell, place)
    if value not in (None, 0.0, 1.0):
        raise ConfigError(f"{place}: expected 0 (no) or 1 (yes), got {cell!r}")
    return None if value is None else bool(value)


def _channel(cells: list[str], k: int, source: str | Path) -> ChannelInfo:
    """Column ``k`` of rows 0-20; a cell without a value keeps the Table E.2 default."""
    values: dict[str, object] = {}
    for row, name in enumerate(CHANNEL_FIELDS):
        cell = cells[row]
        place = where(source, row, k)
        if row in (1, 2):
            values[name] = "" if cell in NO_VALUE else cell
            continue
        if row in (13, 14):
            value = _flag(cell, place)
        elif row == 3:
            value = _from_milli(cell, place)
        else:
            value = _number(cell, place)
        if value is None:
            continue
        if row == 0:
            value = sensor_type_code(value, place)
        elif row == 4:
            value = enum_code(Integration, value, place)
        elif row == 5:
            value = enum_code(FilterType, value, place)
        elif row == 18:
            value = enum_code(FilterFamily, value, place)
        elif row == 12:
            value = filters_on_code(value, place)
        elif row in (6, 15, 16):
            if not value.is_integer():
                raise ConfigError(f"{place}: expected an integer, got {cell!r}")
            value = int(value)
        values[name] = value
    return ChannelInfo(**values)


def _rig(rows: list[list[str]], source: str | Path) -> RigInfo:
    """Rows 21-33: only their first columns are used (Table E.2); later cells are ignored."""

    def cell(row: int, col: int) -> str:
        return rows[row][col] if col < len(rows[row]) else ""

    def num(row: int, col: int) -> float | None:
        return _number(cell(row, col), where(source, row, col))

    def mm(row: int, col: int) -> float | None:
        return _from_milli(cell(row, col), where(source, row, col))

    def required(row: int, col: int, value: float | None) -> float:
        if value is None:
            raise ConfigError(f"{where(source, row, col)}: missing value")
        return value

    def integer(row: int, col: int) -> int | None:
        value = num(row, col)
        if value is not None and not value.is_integer():
            raise ConfigError(f"{where(source, row, col)}: expected an integer, got {cell(row, col)!r}")
        return None if value is None else int(value)

    info = RigInfo()
    info.use_in_gcc = bool(_flag(cell(21, 0), where(source, 21, 0)))
    info.use_in_ag = bool(_flag(cell(21, 1), where(source, 21, 1)))
    n_plates = 0
    while n_plates < 3 and num(22, n_plates) is not None:
        n_plates += 1
    info.plate_sizes = [tuple(required(r, j, mm(r, j)) for r in (22, 23, 24)) for j in range(n_plates)]
    if any(num(r, j) is not None for r in (25, 26, 27) for j in range(3)):
        info.plate_origins = [tuple(required(r, j, mm(r, j)) for r in (25, 26, 27))
                              for j in range(n_plates)]
    info.plot_from_corner = bool(_flag(cell(28, 0), where(source, 28, 0)))
    columns = [integer(29, j) for j in range(2)]
    info.coordinate_columns = [c for c in columns if c is not None]
    info.rx, info.ry, info.rz = mm(30, 0), mm(31, 0), mm(32, 0)
    nine = [integer(33, j) for j in range(9)]
    if any(c is not None for c in nine):
        info.nine_channels = [int(required(33, j, c)) for j, c in enumerate(nine)]
    return info


def parse_ctr(text: str, source: str | Path = "systeminfo") -> Systeminfo:
    """Parse the text of a ``.CTR`` file (34 rows x n channels, Table E.2) into SI units."""
    rows = _ctr_rows(text, source)
    head = rows[0]
    n = len(head)
    while n and head[n - 1] in NO_VALUE:
        n -= 1
    if n == 0:
        raise ConfigError(f"{where(source, 0)}: no channels")
    for r in range(21):
        extra = [c for c in rows[r][n:] if c not in NO_VALUE]
        if extra:
            raise ConfigError(f"{where(source, r, n)}: row 0 has {n} channels but this row has a value "
                              f"{extra[0]!r} beyond them")
        rows[r] = rows[r] + [""] * (n - len(rows[r]))
    channels = [_channel([rows[r][k] for r in range(21)], k, source) for k in range(n)]
    if len(rows) > N_ROWS:
        channels = [_extra(ch, [rows[r][k] if k < len(rows[r]) else "" for r in range(N_ROWS, len(rows))],
                           k, source) for k, ch in enumerate(channels)]
    return Systeminfo(channels=channels, rig=_rig(rows, source))


def _extra(ch: ChannelInfo, cells: list[str], k: int, source: str | Path) -> ChannelInfo:
    """Rows 34-35 (see EXTRA_ROWS) of column ``k``; an empty cell keeps the thesis's behaviour."""
    zero_phase = _flag(cells[0], where(source, N_ROWS, k)) if cells[0] not in NO_VALUE else False
    rule = ch.integration_rule
    if cells[1] not in NO_VALUE:
        place = where(source, N_ROWS + 1, k)
        code = _number(cells[1], place)
        if code not in (0, 1):
            raise ConfigError(f"{place}: integration rule must be 0 (thesis Eq. 4.5) or 1 (trapezoid), "
                              f"got {cells[1]!r}")
        rule = INTEGRATION_RULES[int(code)]
    return replace(ch, zero_phase=bool(zero_phase), integration_rule=rule)


def _read_text(path: str | Path, what: str) -> str:
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise ConfigError(f"{path}: {what} file not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, expected a {what} file") from None
    # LabVIEW on Windows wrote ANSI text; latin-1 decodes any byte
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw.decode("latin-1")


def read_ctr(path: str | Path) -> Systeminfo:
    """Read a ``.CTR`` Systeminfo file (tab-, whitespace- or ``|``-separated)."""
    return parse_ctr(_read_text(path, "Systeminfo (.CTR)"), source=path)


def _fmt(value: float | int | bool | None) -> str:
    """Shortest text that reads back to exactly ``value``."""
    if value is None:
        return "-"
    if isinstance(value, (bool, int)):
        return str(int(value))
    value = float(value)
    if value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return repr(value)


def _fmt_milli(value: float | None) -> str:
    """``value`` (SI) in milli-units: its shortest repr shifted three decimal places, which
    :func:`_from_milli` reads back to exactly ``value``."""
    if value is None:
        return "-"
    shifted = Decimal(repr(float(value))).scaleb(3).normalize()
    return format(shifted, "f") if 1e-6 <= abs(shifted) < 1e15 or shifted == 0 else str(shifted)


def _text_cell(value: str, row: int, k: int) -> str:
    if not value:
        return "-"
    if any(c in value for c in "\t\r\n|") or value.strip() != value or value == "-":
        raise ConfigError(f"{where('systeminfo', row, k)}: {value!r} cannot be written to a .CTR cell")
    return value


def format_ctr(si: Systeminfo) -> str:
    """The ``.CTR`` text of ``si``: 34 tab-separated rows, one column per channel."""
    n = len(si.channels)
    rows: list[list[str]] = []
    for row, name in enumerate(CHANNEL_FIELDS):
        cells = []
        for k, ch in enumerate(si.channels):
            value = getattr(ch, name)
            if row in (1, 2):
                cells.append(_text_cell(value, row, k))
            elif row == 3:
                cells.append(_fmt_milli(value))
            else:
                cells.append(_fmt(value))
        rows.append(cells)
    rig = si.rig
    plates = rig.plate_sizes
    origins = rig.plate_origins
    rig_rows: list[list[str]] = [
        [_fmt(rig.use_in_gcc), _fmt(rig.use_in_ag)],
        *[[_fmt_milli(p[i]) for p in plates] for i in range(3)],
        *[[_fmt_milli(o[i]) for o in origins] for i in range(3)],
        [_fmt(rig.plot_from_corner)],
        [_fmt(c) for c in rig.coordinate_columns],
        [_fmt_milli(rig.rx)], [_fmt_milli(rig.ry)], [_fmt_milli(rig.rz)],
        [_fmt(c) for c in rig.nine_channels],
    ]
    for cells in rig_rows:
        rows.append(cells + ["-"] * (n - len(cells)))
    if any(ch.zero_phase or ch.integration_rule != "thesis" for ch in si.channels):
        rows.append([_fmt(ch.zero_phase) for ch in si.channels])
        rows.append([_fmt(INTEGRATION_RULES.index(ch.integration_rule)) for ch in si.channels])
    return "".join("\t".join(cells) + "\n" for cells in rows)


def write_ctr(si: Systeminfo, path: str | Path) -> None:
    """Write ``si`` as a ``.CTR`` file (mV/unit sensitivities, mm lengths)."""
    Path(path).write_text(format_ctr(si), encoding="utf-8")


# ---------------------------------------------------------------------------------------------
# numeric tables: .DAT / .VIZ (samples x channels), .COD (samples x 6 per plate)


def _diagnose(path: Path, text: str) -> ConfigError:
    """Find the first bad line of a table the fast reader refused (runs only on error)."""
    expected = None
    for number, line in enumerate(text.splitlines(), start=1):
        cells = line.split()
        if not cells:
            continue
        if expected is None:
            expected = len(cells)
        for col, cell in enumerate(cells):
            try:
                float(cell)
            except ValueError:
                return ConfigError(f"{path}: line {number}, column {col}: not a number: {cell!r}")
        if len(cells) != expected:
            return ConfigError(f"{path}: line {number}: ragged row, expected {expected} cells "
                               f"(as line 1), found {len(cells)}")
    return ConfigError(f"{path}: cannot read the numeric table")


def read_table(path: str | Path, what: str = "data") -> np.ndarray:
    """Read a whitespace/tab-delimited numeric table (rows x columns, float64). Missing file, empty
    file, ragged rows, non-numeric cells and NaN/Inf raise one-line ConfigErrors."""
    path = Path(path)
    if not path.is_file():
        _read_text(path, what)  # raises the one-line "not found" / "is a directory" error
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data": checked below
            # numpy >= 1.23 parses text tables in C: as fast as a hand-written reader, and exact
            data = np.loadtxt(path, dtype=np.float64, comments=None, ndmin=2, encoding="latin-1")
    except ValueError:
        raise _diagnose(path, _read_text(path, what)) from None
    if data.size == 0:
        raise ConfigError(f"{path}: empty file, expected a {what} table")
    bad = ~np.isfinite(data)
    if bad.any():
        row, col = (int(i) for i in np.argwhere(bad)[0])
        lines = [(i, line) for i, line in enumerate(_read_text(path, what).splitlines(), start=1)
                 if line.strip()]
        number, line = lines[row]
        raise ConfigError(f"{path}: line {number}, column {col}: not a finite number: {line.split()[col]!r}")
    return data


def _format_table(data: np.ndarray) -> str:
    return "".join("\t".join(map(repr, row)) + "\n" for row in data.tolist())


@dataclass(frozen=True)
class LegacyData:
    """A ``.DAT``/``.VIZ`` record: ``data`` (samples x channels, volts) and the optional time
    column LabVIEW's DAC program can append (s)."""

    data: np.ndarray
    time: np.ndarray | None = None


def _is_time_column(t: np.ndarray, sampling_rate: float) -> bool:
    """Monotonic with step 1/fs, allowing for the rounding of the digits LabVIEW wrote."""
    if t.size < 2:
        return False
    dt = 1.0 / sampling_rate
    steps = np.diff(t)
    ideal = t[0] + dt * np.arange(t.size)
    return bool(np.all(steps > 0) and np.max(np.abs(t - ideal)) <= 0.5 * dt)


def read_dat(path: str | Path, n_channels: int | None = None,
             sampling_rate: float | None = None) -> LegacyData:
    """Read a ``.DAT``/``.VIZ`` file (samples x channels, volts).

    With ``n_channels`` the column count is checked; one extra column is taken as LabVIEW's time
    column when ``sampling_rate`` is given and it rises in steps of 1/fs."""
    path = Path(path)
    data = read_table(path, "data (.DAT/.VIZ)")
    if n_channels is None or data.shape[1] == n_channels:
        return LegacyData(data=data)
    if (data.shape[1] == n_channels + 1 and sampling_rate
            and _is_time_column(data[:, -1], sampling_rate)):
        return LegacyData(data=np.ascontiguousarray(data[:, :-1]), time=data[:, -1].copy())
    raise DimensionError(f"{path}: {data.shape[1]} columns, but the Systeminfo describes "
                         f"{n_channels} channels")


def write_dat(path: str | Path, data: np.ndarray, time: np.ndarray | None = None) -> None:
    """Write samples x channels (volts), tab-delimited, every number repr-exact; ``time`` (s)
    becomes a last column as LabVIEW's DAC program wrote it."""
    data = np.asarray(data, dtype=np.float64)
    if data.ndim != 2:
        raise DimensionError(f"{path}: expected samples x channels, got shape {data.shape}")
    if time is not None:
        time = np.asarray(time, dtype=np.float64)
        if time.shape != (data.shape[0],):
            raise DimensionError(f"{path}: time has shape {time.shape}, data has {data.shape[0]} samples")
        data = np.column_stack([data, time])
    Path(path).write_text(_format_table(data), encoding="utf-8")


def read_cod(path: str | Path) -> list[np.ndarray]:
    """Read a ``.COD`` file: one (samples, 6) array ``[x y z theta phi psi]`` (m, rad) per plate,
    platform first."""
    path = Path(path)
    data = read_table(path, "generalized coordinates (.COD)")
    if data.shape[1] % 6:
        raise DimensionError(f"{path}: {data.shape[1]} columns, expected 6 per plate "
                             "(x y z theta phi psi)")
    return [np.ascontiguousarray(data[:, i:i + 6]) for i in range(0, data.shape[1], 6)]


def write_cod(path: str | Path, plates: Sequence[np.ndarray]) -> None:
    """Write generalized coordinates, 6 tab-separated columns per plate (m, rad), platform first."""
    arrays = [np.asarray(p, dtype=np.float64) for p in plates]
    if not arrays:
        raise DimensionError(f"{path}: no generalized coordinates to write")
    for i, a in enumerate(arrays):
        if a.ndim != 2 or a.shape[1] != 6 or a.shape[0] != arrays[0].shape[0]:
            raise DimensionError(f"{path}: plate {i} has shape {a.shape}, expected "
                                 f"({arrays[0].shape[0]}, 6)")
    Path(path).write_text(_format_table(np.hstack(arrays)), encoding="utf-8")
