"""A rig file's ``[processing]`` table: the chain of records that come without a .CTR (an .lvm, a
UFF file, the simulated rig), as overrides of a channel's Table E.2 settings, with a per-sensor
``processing`` table on top. Without the table a rig keeps the thesis's Table E.3 settings.
"""

from __future__ import annotations

import difflib
import math
from typing import Any

from odsuite.domain.errors import ConfigError
from odsuite.domain.filter_kinds import MAX_FILTER_ORDER, FilterFamily, FilterType

#: where a filter runs: on the measured signal, after the first and after the second integration
#: (Table E.2 row 12's three filters, Ch. 4.3)
FILTER_STAGES = ("signal", "integral", "double_integral")
INTEGRATION_RULES = ("thesis", "trapezoid")
KEYS = ("offset_samples", "filter", "filter_at", "integration", "zero_phase")


def _filter(where: str, value: Any) -> dict[str, Any]:
    if value == "none":
        return {"filters_on": 0, "filter_order": 0, "cutoff_low": None, "cutoff_high": None}
    if not isinstance(value, dict):
        raise ConfigError(f"{where}: expected \"none\" or a table {{family, type, order, cutoff_hz}}, got {value!r}")
    unknown = sorted(set(value) - {"family", "type", "order", "cutoff_hz", "ripple_db", "attenuation_db"})
    if unknown:
        raise ConfigError(f"{where}: unknown field(s) {', '.join(unknown)}")
    family = value.get("family", "butterworth")
    if not isinstance(family, str) or family.upper() not in FilterFamily.__members__:
        raise ConfigError(f"{where}.family: expected one of {[f.name.lower() for f in FilterFamily]}, got {family!r}")
    kind = value.get("type", "highpass")
    if not isinstance(kind, str) or kind.upper() not in FilterType.__members__:
        raise ConfigError(f"{where}.type: expected one of {[t.name.lower() for t in FilterType]}, got {kind!r}")
    order = value.get("order", 4)
    if isinstance(order, bool) or not isinstance(order, int) or not 1 <= order <= MAX_FILTER_ORDER:
        raise ConfigError(f"{where}.order: expected an integer 1-{MAX_FILTER_ORDER}, got {order!r}")
    kind = FilterType[kind.upper()]
    cutoff = value.get("cutoff_hz")
    edges = cutoff if isinstance(cutoff, list) else [cutoff]
    n_edges = 2 if kind in (FilterType.BANDPASS, FilterType.BANDSTOP) else 1
    if (len(edges) != n_edges or any(isinstance(c, bool) or not isinstance(c, (int, float)) for c in edges)
            or any(not math.isfinite(c) or c <= 0 for c in edges) or edges != sorted(edges)):
        shape = "[low, high] Hz, low < high" if n_edges == 2 else "one frequency in Hz"
        raise ConfigError(f"{where}.cutoff_hz: expected {shape} (> 0) for a {kind.name.lower()} filter, got {cutoff!r}")
    if kind is FilterType.LOWPASS:
        low, high = None, float(edges[0])
    elif kind is FilterType.HIGHPASS:
        low, high = float(edges[0]), None
    else:
        low, high = float(edges[0]), float(edges[1])
    out = {"filter_family": FilterFamily[family.upper()], "filter_type": kind, "filter_order": order,
           "cutoff_low": low, "cutoff_high": high}
    for key in ("ripple_db", "attenuation_db"):
        if key in value:
            v = value[key]
            if not filter_db_ok(v):
                raise ConfigError(f"{where}.{key}: expected {FILTER_DB_TEXT}, got {v!r}")
            out[key] = float(v)
    if out["filter_family"] is FilterFamily.ELLIPTIC:
        check_ripple(where, out.get("ripple_db", DEFAULT_RIPPLE_DB), out.get("attenuation_db", DEFAULT_ATTENUATION_DB))
    return out


#: the pass-band ripple and stop-band attenuation a filter table leaves out (Table E.2 rows 10-11's)
DEFAULT_RIPPLE_DB, DEFAULT_ATTENUATION_DB = 0.1, 60.0


#: a filter's ripple and attenuation (dB): 1e300 left scipy's elliptic design failing, 1e-300 made
#: an analog design's poles NaN
FILTER_DB_RANGE = (1e-6, 200.0)
FILTER_DB_TEXT = f"dB from {FILTER_DB_RANGE[0]:g} to below {FILTER_DB_RANGE[1]:g}"


def filter_db_ok(value: Any) -> bool:
    """Whether ``value`` may be a filter's ripple or attenuation (FILTER_DB_RANGE)."""
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and FILTER_DB_RANGE[0] <= value < FILTER_DB_RANGE[1])


def check_ripple(where: str, ripple_db: float, attenuation_db: float) -> None:
    """An elliptic filter's ripple must stay below its attenuation (scipy finds no such filter)."""
    if ripple_db >= attenuation_db:
        raise ConfigError(f"{where}: ripple_db {ripple_db:g} must be below attenuation_db {attenuation_db:g}")


def parse_processing(table: Any, where: str) -> dict[str, Any]:
    """The ChannelInfo fields a ``[processing]`` table sets (only those it names)."""
    if not isinstance(table, dict):
        raise ConfigError(f"{where}: expected a table, got {table!r}")
    unknown = sorted(set(table) - set(KEYS))
    if unknown:
        near = difflib.get_close_matches(str(unknown[0]), KEYS, n=1)
        hint = f"; did you mean {near[0]!r}?" if near else ""
        raise ConfigError(f"{where}: unknown field(s) {', '.join(unknown)} (known: {', '.join(KEYS)}){hint}")
    out: dict[str, Any] = {}
    if "offset_samples" in table:
        v = table["offset_samples"]
        if (not isinstance(v, list) or len(v) != 2 or any(isinstance(x, bool) or not isinstance(x, int) for x in v)
                or min(v) < 0):
            raise ConfigError(f"{where}.offset_samples: expected [first sample, count] (integers >= 0), got {v!r}")
        out["offset_start"], out["offset_length"] = v
    if "filter" in table:
        out.update(_filter(f"{where}.filter", table["filter"]))
    if "filter_at" in table:
        v = table["filter_at"]
        if not isinstance(v, list) or any(s not in FILTER_STAGES for s in v):
            raise ConfigError(f"{where}.filter_at: expected a list from {list(FILTER_STAGES)}, got {v!r}")
        out["filters_on"] = sum(1 << FILTER_STAGES.index(s) for s in set(v))
    if "integration" in table:
        v = table["integration"]
        if v not in INTEGRATION_RULES:
            raise ConfigError(f"{where}.integration: expected one of {list(INTEGRATION_RULES)}, got {v!r}")
        out["integration_rule"] = v
    if "zero_phase" in table:
        v = table["zero_phase"]
        if not isinstance(v, bool):
            raise ConfigError(f"{where}.zero_phase: expected true or false, got {v!r}")
        out["zero_phase"] = v
    return out
