"""A diagnosis document (``Diagnosis.as_dict()``, ``odsuite diagnose --json``) read back from a file
or from a revision's metrics: the fields the report shows are checked where the document is read, so
one written by hand or by another program is refused in one line naming where, the field and the
value, not half-way through a report. Absent and null fields are not shown, so they pass."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from odsuite.domain.errors import ConfigError
from odsuite.store.stored_values import is_number


def _number_or_null(v: Any) -> bool:
    return v is None or is_number(v)


def _text(v: Any) -> bool:
    return isinstance(v, str)


def _table_of(value_ok: Callable[[Any], bool]) -> Callable[[Any], bool]:
    return lambda v: isinstance(v, Mapping) and all(isinstance(k, str) and value_ok(x) for k, x in v.items())


def _physical_row(r: Any) -> bool:
    """A quantity as ``physical.text`` and ``physical.moved`` read it."""
    return (isinstance(r, Mapping) and _text(r.get("label")) and is_number(r.get("value"))
            and _text(r.get("unit")) and "nominal" in r and _number_or_null(r["nominal"])
            and _number_or_null(r.get("uncertainty")))


#: field -> (its check, what it expects), at the top and in each candidate
TOP = {
    "baseline_error": (_number_or_null, "a number or null"),
    "noise_floor_error": (_number_or_null, "a number or null"),
    "revision": (lambda v: isinstance(v, (int, np.integer)) and not isinstance(v, bool), "a revision number or null"),
}
CANDIDATE = {
    "significant": (lambda v: isinstance(v, (bool, np.bool_)), "true or false"),
    "significance_decided": (lambda v: isinstance(v, (bool, np.bool_)), "true or false"),
    "error_after": (_number_or_null, "a number or null"),
    "validated_error": (_number_or_null, "a number or null"),
    "parameters": (_table_of(_number_or_null), "a table of numbers (or null) by parameter name"),
    "units": (_table_of(lambda v: v is None or _text(v)), "a table of unit texts (or null) by parameter name"),
    "evidence": (_text, "a text"),
    "physical": (lambda v: isinstance(v, list), "a list of quantities"),
}


def _bad(where: str, field: str, value: Any, expected: str) -> ConfigError:
    shown = repr(value)
    shown = shown if len(shown) <= 120 else shown[:117] + "..."
    return ConfigError(f"{where}{f' field {field!r}' if field else ''}: expected {expected}, got {shown}")


def _check_fields(where: str, prefix: str, table: Mapping[str, Any], fields: Mapping[str, tuple]) -> None:
    for name, (ok, expected) in fields.items():
        v = table.get(name)
        if v is not None and not ok(v):
            raise _bad(where, prefix + name, v, expected)


def check_diagnosis(doc: Any, where: str, prefix: str = "") -> dict[str, Any]:
    """``doc`` as a diagnosis document; else a ConfigError ``"{where} field '{prefix}...': expected
    ..., got ..."`` (``where`` names the file, or the project and the revision)."""
    if not isinstance(doc, Mapping):
        raise _bad(where, prefix.rstrip("."), doc, "a table (JSON object) from `odsuite diagnose --json`")
    _check_fields(where, prefix, doc, TOP)
    candidates = doc.get("candidates")
    if not isinstance(candidates, list):
        raise _bad(where, prefix + "candidates", candidates,
                   "a list of candidate tables (the output of `odsuite diagnose --json`)")
    for i, c in enumerate(candidates):
        at = f"{prefix}candidates[{i}]"
        if not isinstance(c, Mapping):
            raise _bad(where, at, c, "a candidate table")
        if not _text(c.get("effect")):
            raise _bad(where, at + ".effect", c.get("effect"), "an effect name")
        _check_fields(where, at + ".", c, CANDIDATE)
        for j, r in enumerate(c.get("physical") or []):
            if not _physical_row(r):
                raise _bad(where, f"{at}.physical[{j}]", r,
                           "a table of label and unit (texts), value (a number), nominal and uncertainty (numbers or null)")
    return dict(doc)
