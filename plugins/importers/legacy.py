"""Codecs for the thesis's LabVIEW files (App. E, Table E.1): ``.DAT``/``.VIZ`` data and ``.COD``
generalized coordinates; the ``.CTR`` Systeminfo codec lives with the Systeminfo
(``odsuite.domain.systeminfo``) and is importable from here too.

All are "spreadsheet compatible" text: tab-delimited (whitespace is accepted too). ``.DAT``/``.VIZ``
hold the volts the DAQ recorded (App. D.1, Eq. 4.3: the signal processor converts them later with the
Systeminfo); ``.COD`` holds ``[x y z theta phi psi]`` per plate in metres and radians, platform first.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from odsuite.api import write_output
from odsuite.api import ConfigError, DimensionError
from odsuite.api import format_ctr, parse_ctr, read_ctr, write_ctr
from odsuite.api import check_text_file, read_text

__all__ = ["LegacyData", "format_ctr", "parse_ctr", "read_cod", "read_ctr", "read_dat", "read_table",
           "write_cod", "write_ctr", "write_dat"]

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
    check_text_file(path, what)
    if not path.is_file():
        read_text(path, what)  # raises the one-line "not found" / "is a directory" error
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data": checked below
            # numpy >= 1.23 parses text tables in C: as fast as a hand-written reader, and exact
            data = np.loadtxt(path, dtype=np.float64, comments=None, ndmin=2, encoding="latin-1")
    except ValueError:
        raise _diagnose(path, read_text(path, what)) from None
    if data.size == 0:
        raise ConfigError(f"{path}: empty file, expected a {what} table")
    bad = ~np.isfinite(data)
    if bad.any():
        row, col = (int(i) for i in np.argwhere(bad)[0])
        lines = [(i, line) for i, line in enumerate(read_text(path, what).splitlines(), start=1)
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
    text = _format_table(np.hstack(arrays)).encode("utf-8")
    write_output(Path(path), len(text), lambda tmp: tmp.write_bytes(text))
