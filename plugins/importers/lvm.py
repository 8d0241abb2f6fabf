"""LabVIEW Measurement (``.lvm``) text files: header blocks, decimal comma, X columns, segments.

Layout: a file header (``key<sep>value`` lines up to ``***End_of_Header***``), then one or more
segments, each a channel header (Channels, Samples, Y_Unit_Label, X0, Delta_X, ... one column per
channel) closed by ``***End_of_Header***``, an optional column-name line (``X_Value ...``) and the
data rows. ``X_Columns`` says where time columns are: ``No`` (an empty first column), ``One`` (one
shared time column) or ``Multi`` (a time column before every channel). A trailing ``Comment``
column may be empty.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from odsuite.contracts.daq import MAX_RATE_HZ, MIN_RATE_HZ
from odsuite.api import ConfigError
from odsuite.api import MAX_CHANNELS
from odsuite.api import check_text_file, plain_number

END_OF_HEADER = "***End_of_Header***"
_SEPARATORS = {"tab": "\t", "comma": ",", "semicolon": ";", "space": " "}


@dataclass(frozen=True)
class LvmData:
    """The contents of one ``.lvm`` file; ``data`` is samples x channels (all segments, in order)."""

    path: Path
    header: dict[str, str]
    channel_names: list[str]
    units: list[str]
    delta_x: list[float]  # s per sample, per channel (rounded values snapped, see _snap_delta_x)
    x0: list[float]
    data: np.ndarray
    time: np.ndarray | None  # samples x channels when the file has X columns, else None
    declared_samples: list[int]  # "Samples" of the first segment, per channel
    segment_starts: list[int] = field(default_factory=list)  # row index where each segment starts

    @property
    def sampling_rate(self) -> float:
        """Hz, from the first channel's Delta_X (an integer rate when Delta_X is its reciprocal)."""
        rate = 1.0 / self.delta_x[0]
        return float(round(rate)) if abs(rate - round(rate)) < 1e-6 * rate else rate

    @property
    def n_samples(self) -> int:
        return int(self.data.shape[0])

    def channel(self, name: str) -> np.ndarray:
        """One channel's samples by name (ConfigError listing the names when absent)."""
        if name not in self.channel_names:
            raise ConfigError(
                f"{self.path}: no channel {name!r}; channels are {', '.join(self.channel_names)}"
            )
        return self.data[:, self.channel_names.index(name)]

    def check_complete(self) -> None:
        """Refuse a file cut off: fewer rows than the header's Samples, or a row missing values."""
        n = self.declared_samples[0] if self.declared_samples else 0
        if n > self.n_samples:
            raise ConfigError(f"{self.path}: header field Samples says {n} samples per channel, the file "
                              f"holds {self.n_samples} rows (cut off?)")
        missing = np.argwhere(np.isnan(self.data))
        if missing.size:
            row, ch = (int(v) for v in missing[0])
            raise ConfigError(f"{self.path}: data row {row + 1}, channel {self.channel_names[ch]!r}: value "
                              f"missing ({len(missing)} missing in all; cut off?)")

    def records(self) -> list[np.ndarray]:
        """Split into consecutive records of the declared sample count when the file holds a whole
        multiple of it (LabVIEW appends triggered records without a new header)."""
        n = self.declared_samples[0] if self.declared_samples else 0
        if n <= 0 or self.n_samples % n or self.n_samples == n:
            return [self.data]
        return [self.data[i : i + n] for i in range(0, self.n_samples, n)]


def _snap_delta_x(text: str, value: float) -> float:
    """LabVIEW prints Delta_X with few digits (1/1024 s as 0.000977). When an integer sampling rate
    reproduces the printed value to its last digit, use the exact 1/rate."""
    mantissa = re.split(r"[eE]", text)[0]
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    exponent = int(re.split(r"[eE]", text)[1]) if re.search(r"[eE]", text) else 0
    half_ulp = 0.5 * 10.0 ** (exponent - decimals)
    if value <= 0:
        return value
    rate = round(1.0 / value)
    if rate > 0 and abs(1.0 / rate - value) <= half_ulp * (1 + 1e-9):
        return 1.0 / rate
    return value


@dataclass
class _Block:
    """What the segments of an ``.lvm`` file hold: the (last) channel header's fields, the column
    names, the value and time rows and where each segment starts."""

    channel_header: dict[str, list[str]] = field(default_factory=dict)
    header_lines: dict[str, int] = field(default_factory=dict)  # each field's line, for its errors
    names: list[str] | None = None
    rows: list[list[float]] = field(default_factory=list)
    times: list[list[float]] = field(default_factory=list)
    segment_starts: list[int] = field(default_factory=list)
    n_channels: int = 0
    #: each segment's channel header, field lines, names and channel count, as it ended
    segments: list[_Block] = field(default_factory=list)

    def close_segment(self) -> None:
        self.segments.append(_Block(dict(self.channel_header), dict(self.header_lines), self.names,
                                    n_channels=self.n_channels))


def _lines(path: Path) -> list[str]:
    """The file's lines, refused when it is no ``.lvm`` file (first line)."""
    check_text_file(path, "LabVIEW (.lvm)")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read LabVIEW file ({exc.strerror})") from exc
    try:  # UTF-8 where it decodes ('m/s²' read as 'm/sÂ²' otherwise), else the system code page LabVIEW writes in
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    del raw
    lines = text.splitlines()
    if not lines or not lines[0].startswith("LabVIEW Measurement"):
        first = lines[0][:40] if lines else ""
        raise ConfigError(f"{path}: line 1 is {first!r}, not 'LabVIEW Measurement' (not an .lvm file)")
    return lines


def _file_header(path: Path, lines: list[str]) -> tuple[dict[str, str], int]:
    """The file header's fields and the index of the line after its ``***End_of_Header***``."""
    header: dict[str, str] = {}
    i = 1
    while i < len(lines) and not lines[i].startswith(END_OF_HEADER):
        parts = re.split(r"[\t,;]", lines[i], maxsplit=1)
        if parts[0]:
            header[parts[0]] = parts[1].strip() if len(parts) > 1 else ""
        i += 1
    if i >= len(lines):
        raise ConfigError(f"{path}: file header has no {END_OF_HEADER} line")
    return header, i + 1


def _layout(path: Path, header: dict[str, str]) -> tuple[str, str, str]:
    """The field separator, decimal separator and X_Columns the file header declares."""
    sep_name = header.get("Separator", "Tab")
    sep = _SEPARATORS.get(sep_name.lower())
    if sep is None:
        raise ConfigError(f"{path}: header field Separator has unknown value {sep_name!r}")
    decimal = header.get("Decimal_Separator", ".") or "."
    x_columns = header.get("X_Columns", "One")
    if x_columns not in ("No", "One", "Multi"):
        raise ConfigError(f"{path}: header field X_Columns has unknown value {x_columns!r}")
    return sep, decimal, x_columns


def _number(path: Path, decimal: str, field_text: str, lineno: int, what: str) -> float:
    """One cell's value (NaN when empty); LabVIEW writes no digit groups, so ``1_000`` (which
    Python's float() reads as 1000) is no number either."""
    s = field_text.strip()
    if decimal != ".":
        s = s.replace(decimal, ".")
    try:
        return plain_number(s) if s else float("nan")
    except ValueError:
        raise ConfigError(f"{path}: line {lineno}, {what}: {field_text[:40]!r} is not a number") from None


def _segment_columns(path: Path, block: _Block, x_columns: str, lineno: int) -> tuple[list[int], list[int]]:
    """At a segment header's end: the value and time columns of its channels."""
    if "Channels" not in block.channel_header:
        raise ConfigError(f"{path}: line {lineno}: segment header without 'Channels'")
    try:
        n_channels = int(block.channel_header["Channels"][0])
    except ValueError:
        raise ConfigError(f"{path}: field Channels is {block.channel_header['Channels'][0]!r}, not an integer") from None
    if not 1 <= n_channels <= MAX_CHANNELS:
        raise ConfigError(f"{path}: line {lineno}: field Channels is {n_channels}; it must be from 1 to {MAX_CHANNELS}")
    block.n_channels = n_channels
    step = 2 if x_columns == "Multi" else 1
    # column 0 is the (possibly empty) X column; Multi interleaves time and value
    value_cols = [1 + step * k for k in range(n_channels)]
    time_cols = [0] * n_channels if x_columns == "One" else [v - 1 for v in value_cols]
    return value_cols, time_cols


def _data_block(path: Path, lines: list[str], start: int, sep: str, decimal: str, x_columns: str) -> _Block:
    """The segments from line index ``start`` on: channel headers, column names and data rows."""
    block = _Block()
    value_cols: list[int] = []
    time_cols: list[int] = []
    in_data = False
    for lineno in range(start + 1, len(lines) + 1):
        line = lines[lineno - 1]
        if not line.strip(sep + " \r"):
            continue
        fields = line.split(sep)
        if not in_data or fields[0] == "Channels":
            if fields[0] == "Channels" and in_data:
                in_data = False  # a new segment header
                block.close_segment()
            if line.startswith(END_OF_HEADER):
                value_cols, time_cols = _segment_columns(path, block, x_columns, lineno)
                block.segment_starts.append(len(block.rows))
                in_data = True
                continue
            block.channel_header[fields[0]] = fields[1:]
            block.header_lines[fields[0]] = lineno
            continue
        if fields[0] == "X_Value":
            block.names = [fields[c] for c in value_cols if c < len(fields)]
            block.header_lines["X_Value"] = lineno
            continue
        # the channels' columns and one Comment column; more cells are no row LabVIEW wrote
        if len(fields) > value_cols[-1] + 2:
            raise ConfigError(f"{path}: line {lineno}: {len(fields)} cells, more than the {value_cols[-1] + 2} "
                              f"of {block.n_channels} channel(s) and a comment")
        if len(fields) <= value_cols[-1]:
            # a truncated last row: pad with NaN so the columns stay aligned
            fields = fields + [""] * (value_cols[-1] + 1 - len(fields))
        block.rows.append([_number(path, decimal, fields[c], lineno, f"column {c + 1}") for c in value_cols])
        if x_columns != "No":
            block.times.append([_number(path, decimal, fields[c], lineno, f"column {c + 1}") for c in time_cols])
    if not block.segment_starts:
        raise ConfigError(f"{path}: no channel header ({END_OF_HEADER} after 'Channels') found")
    if not block.rows:
        raise ConfigError(f"{path}: no data rows after the channel header")
    block.close_segment()
    return block


def _per_channel(block: _Block, x_columns: str, key: str, default: str) -> list[str]:
    """A channel-header field's cells, one per channel (``default`` where missing)."""
    vals = block.channel_header.get(key, [])
    if x_columns == "Multi":
        vals = vals[0::2]  # the header puts an empty cell over every time column
    vals = list(vals[: block.n_channels])
    return vals + [default] * (block.n_channels - len(vals))


def _delta_x(path: Path, block: _Block, x_columns: str, decimal: str) -> list[float]:
    """Each channel's sampling interval (s), checked against the sampling rates odsuite takes."""
    delta_x = []
    for k, s in enumerate(_per_channel(block, x_columns, "Delta_X", "1")):
        dx = _number(path, decimal, s, block.header_lines.get("Delta_X", 0), f"Delta_X of channel {k}")
        if not np.isfinite(dx) or dx <= 0:
            raise ConfigError(f"{path}: field Delta_X of channel {k} is {s!r}; it must be > 0")
        if not MIN_RATE_HZ <= 1.0 / dx <= MAX_RATE_HZ:
            raise ConfigError(f"{path}: field Delta_X of channel {k} is {s!r} s, a sampling rate outside "
                              f"{MIN_RATE_HZ:g}..{MAX_RATE_HZ:g} Hz")
        delta_x.append(_snap_delta_x(s.replace(decimal, "."), dx))
        if not math.isclose(delta_x[-1], delta_x[0], rel_tol=1e-9):  # one record has one rate
            raise ConfigError(f"{path}: line {block.header_lines.get('Delta_X', 0)}, Delta_X of channel {k}: {s!r} s "
                              f"differs from channel 0's {delta_x[0]:g} s; odsuite stores a record at one "
                              "sampling rate")
    return delta_x


def _channels(path: Path, block: _Block, x_columns: str, decimal: str) -> dict:
    """The channels' names, units, intervals, X0 and declared sample counts (LvmData's fields)."""
    x0 = [_number(path, decimal, s, block.header_lines.get("X0", 0), f"X0 of channel {k}")
          for k, s in enumerate(_per_channel(block, x_columns, "X0", "0"))]
    declared = []
    for s in _per_channel(block, x_columns, "Samples", "0"):
        try:
            declared.append(int(s))
        except ValueError:
            declared.append(0)
    names = block.names
    if names is None or len(names) != block.n_channels:
        names = [f"channel {k}" for k in range(block.n_channels)]
    return {"channel_names": names, "units": _per_channel(block, x_columns, "Y_Unit_Label", ""),
            "delta_x": _delta_x(path, block, x_columns, decimal), "x0": [v if np.isfinite(v) else 0.0 for v in x0],
            "declared_samples": declared}


def read_lvm(path: str | Path) -> LvmData:
    """Read a LabVIEW ``.lvm`` text file (Writer_Version 0.92 to 2, one or more segments)."""
    path = Path(path)
    lines = _lines(path)
    header, start = _file_header(path, lines)
    sep, decimal, x_columns = _layout(path, header)
    block = _data_block(path, lines, start, sep, decimal, x_columns)
    channels = _same_segments(path, block, x_columns, decimal)
    return LvmData(path=path, header=header, data=np.asarray(block.rows, dtype=float),
                   time=np.asarray(block.times, dtype=float) if block.times else None,
                   segment_starts=block.segment_starts, **channels)


def _same_segments(path: Path, block: _Block, x_columns: str, decimal: str) -> dict:
    """The channels (``_channels``) of every segment, which must agree: the segments' rows are read
    as one record (another rate, unit or channel order was read with the last segment's)."""
    first = _channels(path, block.segments[0], x_columns, decimal)
    for number, segment in enumerate(block.segments[1:], start=2):
        later = _channels(path, segment, x_columns, decimal)
        for key, header_field in (("channel_names", "X_Value"), ("units", "Y_Unit_Label"), ("delta_x", "Delta_X")):
            if later[key] != first[key]:
                what = "channel names (X_Value)" if key == "channel_names" else header_field
                raise ConfigError(f"{path}: line {segment.header_lines.get(header_field, 0)}: segment {number}'s "
                                  f"{what} {later[key]} differ from segment 1's {first[key]}; odsuite reads the "
                                  "segments as one record")
    return first
