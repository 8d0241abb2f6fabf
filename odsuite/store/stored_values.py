"""Checks of the values a project stores, made when they are read: a project written by hand or
by another program gets one line naming the object, the field and the value, never a traceback
deep in an analysis."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from odsuite.domain.errors import ProjectFileError
from odsuite.domain.excitation import MAX_POINT_M

#: sampling rates odsuite records and reads (as acquisition and .lvm import allow)
RATE_RANGE = (0.1, 1e8)  # Hz
#: raw values beyond this are no measurement (no DAQ input, no sensor in its SI unit reads them): a
#: record written by hand, read as refused rather than overflowing in the processing
RAW_MAX = 1e12
#: metrics that are numbers (or null) wherever they are stored
NUMERIC_METRICS = ("error", "noise_floor_error", "previous_error")


def _bad(path: Path, where: str, field: str, value: Any, expected: str) -> ProjectFileError:
    if isinstance(value, np.ndarray | np.generic):  # as stored: [1, 2], 512.7, not array(...), np.float64(...)
        value = value.tolist()
    shown = repr(value)
    shown = shown if len(shown) <= 120 else shown[:117] + "..."
    return ProjectFileError(f"{path}: {where} field {field!r}: expected {expected}, got {shown}")


def is_number(x: Any) -> bool:
    """A real number a float can hold (not a bool, not a JSON integer past a float's range)."""
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        return False
    try:  # JSON's integers have no bound: one past a float's range is no number the analyses can use
        float(x)
    except OverflowError:
        return False
    return True


def is_integer(x: Any) -> bool:
    """An integer as odsuite stores counts and indices (not a bool, a float or a text of digits)."""
    return isinstance(x, int | np.integer) and not isinstance(x, bool)


def as_vector(value: Any) -> Any:
    """A stored attribute as a float array when it holds numbers, else as it is (for the check to name)."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return value


def as_number(value: Any) -> Any:
    """A stored attribute as a float when it is a real number, else as it is (for the check to name)."""
    return float(value) if is_number(value) else value


def check_raw_block(path: Path, name: str, block: np.ndarray, row0: int, channel_names: list[str]) -> None:
    """Raw values read back: finite and within RAW_MAX (a NaN stored by hand would run through every
    analysis)."""
    # two reductions without temporaries (a fifth of an abs() pass); NaN propagates through min and max
    if block.size == 0 or (-RAW_MAX <= block.min() and block.max() <= RAW_MAX):
        return
    bad = ~(np.abs(block) <= RAW_MAX)  # NaN compares false
    if bad.any():
        i, c = np.argwhere(bad)[0]
        label = channel_names[c] if block.shape[1] == len(channel_names) else c
        raise _bad(path, f"experiment {name!r}", "raw", float(block[i, c]),
                   f"finite values within {RAW_MAX:g} (sample {row0 + i}, channel {label!r})")


def systeminfo_refusal(path: Path, name: str, channel: int, field: str, value: Any, expected: str) -> ProjectFileError:
    """The error for a stored channel table's ``field`` of ``channel``."""
    return _bad(path, f"experiment {name!r} systeminfo channel {channel}", field, value, expected)


def revision_number(path: Path, key: str) -> int:
    """A stored revision's number from its group's name (odsuite names them 0, 1, 2, ...)."""
    if not (key.isascii() and key.isdigit() and str(int(key)) == key):
        raise _bad(path, "models", "revisions", key, "revisions named by whole numbers 0, 1, 2, ...")
    return int(key)


def rig_refusal(path: Path, name: str, field: str, value: Any, expected: str) -> ProjectFileError:
    """The error for a stored channel table's rig ``field`` (Table E.2 rows 21-33)."""
    return _bad(path, f"experiment {name!r} systeminfo rig", field, value, expected)


def check_systeminfo(path: Path, name: str, channels: list, n_channels: int, rig: Any) -> None:
    """The stored channel table: one channel per raw column, divisors (sensitivity and DAQ gain
    finite and not 0, the sensitivity within what any writer stores), filter orders within the
    writers' range (an order of 10^12 asked a filter design for terabytes) and the rig's column
    lists within range."""
    from odsuite.domain.filter_kinds import MAX_FILTER_ORDER
    from odsuite.domain.rig import SENSITIVITY_RANGE
    from odsuite.domain.systeminfo import MAX_COORDINATE_COLUMN, column_in_range

    if len(channels) != n_channels:
        raise _bad(path, f"experiment {name!r}", "systeminfo.channels", len(channels),
                   f"{n_channels} rows (one per raw column)")
    # as Systeminfo.validate: accepted here, they failed `process` later (or a .CTR written from them)
    for field in ("coordinate_columns", "nine_channels"):
        columns = getattr(rig, field)
        if not all(column_in_range(field, c, n_channels) for c in columns):
            raise rig_refusal(path, name, field, columns, f"channel numbers 0 to {n_channels - 1}"
                              if field == "nine_channels" else f"column numbers from 0 to {MAX_COORDINATE_COLUMN}")
    # the widest writer's range: a rig file's V per SI unit, per micro-unit on a micro-units channel
    lowest, highest = 1e-6 * SENSITIVITY_RANGE[0], SENSITIVITY_RANGE[1]
    for k, ch in enumerate(channels):
        where = f"experiment {name!r} systeminfo channel {k}"
        for field in ("sensitivity", "daq_gain"):
            v = getattr(ch, field)
            if not (is_number(v) and math.isfinite(v) and v != 0):
                raise _bad(path, where, field, v, "a finite number other than 0")
        if not lowest <= abs(ch.sensitivity) <= highest:
            raise _bad(path, where, "sensitivity", ch.sensitivity, f"{lowest:g} to {highest:g} V per unit in magnitude")
        # (as the .CTR reader: an order is read only where the channel's filters are on)
        if ch.filters_on and not (is_number(ch.filter_order) and 0 <= ch.filter_order <= MAX_FILTER_ORDER):
            raise _bad(path, where, "filter_order", ch.filter_order, f"0 to {MAX_FILTER_ORDER}")


def check_experiment(path: Path, name: str, *, sampling_rate: Any, pretrigger: Any, channel_names: list,
                     shape: tuple, excitation: Any, dtype: Any = None) -> None:
    where = f"experiment {name!r}"
    if len(shape) != 2:
        raise _bad(path, where, "raw", shape, "a table of samples x channels")
    if dtype is not None and np.dtype(dtype).kind not in "fiu":
        raise _bad(path, where, "raw", f"dtype {np.dtype(dtype)}", "real numbers (floating point or integer)")
    n_samples, n_channels = shape
    if not (is_number(sampling_rate) and math.isfinite(sampling_rate)
            and RATE_RANGE[0] <= sampling_rate <= RATE_RANGE[1]):
        raise _bad(path, where, "sampling_rate", sampling_rate, f"{RATE_RANGE[0]:g} to {RATE_RANGE[1]:g} Hz")
    if not (is_integer(pretrigger) and 0 <= pretrigger <= n_samples):
        raise _bad(path, where, "pretrigger", pretrigger, f"an integer 0 to {n_samples} samples")
    if (not isinstance(channel_names, list) or len(channel_names) != n_channels
            or len(set(channel_names)) != n_channels):
        raise _bad(path, where, "channel_names", channel_names, f"{n_channels} distinct names (one per raw column)")
    if excitation is not None:
        if not (is_integer(excitation.force_channel) and 0 <= excitation.force_channel < n_channels):
            raise _bad(path, where, "force_channel", excitation.force_channel, f"a channel 0 to {n_channels - 1}")
        for field, vec in (("force_point", excitation.point), ("force_direction", excitation.direction)):
            if (not isinstance(vec, np.ndarray) or vec.shape != (3,) or not np.all(np.isfinite(vec))
                    or (field == "force_direction" and not np.any(vec))):
                raise _bad(path, where, field, vec, "3 finite numbers (m; a direction not zero)")
        if np.max(np.abs(excitation.point)) > MAX_POINT_M:
            raise _bad(path, where, "force_point", np.asarray(excitation.point).tolist(),
                       f"coordinates within {MAX_POINT_M:g} m of the rig's origin")


#: the units odsuite stores an experiment's numbers in; another unit (a file written elsewhere, an
#: older tool's "kHz" or "mm") would be read as these, silently wrong by its factor
EXPERIMENT_UNITS = {"sampling_rate_units": "Hz", "force_point_units": "m"}
RAW_UNITS = "V"


def check_experiment_units(path: Path, name: str, units: dict[str, Any], raw_units: Any) -> None:
    """The unit attributes of an experiment (``units``: the ones it holds of EXPERIMENT_UNITS) and
    of its raw dataset (None where absent) are the ones odsuite reads its numbers in."""
    where = f"experiment {name!r}"
    for field, value in units.items():
        if value != EXPERIMENT_UNITS[field]:
            raise _bad(path, where, field, value, f"{EXPERIMENT_UNITS[field]!r} (the unit odsuite reads it in)")
    if raw_units is not None and raw_units != RAW_UNITS:
        raise _bad(path, where, "raw.units", raw_units, f"{RAW_UNITS!r} (raw records are volts)")


def check_parent(path: Path, key: str, parent: Any, keys: set[str]) -> int:
    """A revision's stored parent: -1 (none) or a stored revision before it (odsuite numbers a
    revision after its parent: one that is its own or a later one's child is a loop)."""
    if not (is_integer(parent) and (parent == -1 or str(parent) in keys and parent < int(key))):
        before = sorted(int(k) for k in keys if k.isdigit() and int(k) < int(key))
        raise _bad(path, f"model revision {key}", "parent", parent,
                   f"-1 (none) or a stored revision before it ({', '.join(map(str, before)) or 'none'})")
    return int(parent)


def check_revision(path: Path, key: str, effects: Any, parameters: Any, metrics: Any) -> None:
    where = f"model revision {key}"
    if not isinstance(metrics, dict):
        raise _bad(path, where, "metrics", metrics, "a table (JSON object)")
    for k in NUMERIC_METRICS:
        v = metrics.get(k)
        if v is not None and not is_number(v):
            raise _bad(path, where, f"metrics.{k}", v, "a number or null")
        if v is not None and float(v) < 0:  # an error is a root of sums of squares
            raise _bad(path, where, f"metrics.{k}", v, "a number >= 0 or null")
    # a fitted value is finite (an uncertainty may be unknown: null)
    if not isinstance(parameters, dict) or not all(is_number(v) and math.isfinite(v) for v in parameters.values()):
        raise _bad(path, where, "parameters", parameters, "a table of finite numbers")
    if not isinstance(effects, list):
        raise _bad(path, where, "effects", effects, "a list of effect tables")
    for e in effects:
        if not isinstance(e, dict) or not isinstance(e.get("effect"), str):
            raise _bad(path, where, "effects", e, "a table naming its 'effect'")
        for table in ("values", "uncertainties"):
            values = e.get(table, {})
            if not isinstance(values, dict) or not all(v is None or is_number(v) for v in values.values()):
                raise _bad(path, where, f"effects[{e['effect']!r}].{table}", values, "a table of numbers")
        if not all(v is None or math.isfinite(v) for v in e.get("values", {}).values()):
            raise _bad(path, where, f"effects[{e['effect']!r}].values", e["values"], "a table of finite numbers")
        per = e.get("per_experiment", {})
        if not isinstance(per, dict) or not all(isinstance(v, dict) and all(is_number(x) for x in v.values())
                                                for v in per.values()):
            raise _bad(path, where, f"effects[{e['effect']!r}].per_experiment", per,
                       "a table of experiments' tables of numbers")
