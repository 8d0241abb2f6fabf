"""Text in HDF5 attributes and tables, stored as fixed-length UTF-8 strings.

HDF5 keeps variable-length strings in its global heap; when a damaged file's heap is read, the
library can loop forever (found by fuzzing the project reader), and nothing in Python can stop it.
Fixed-length strings sit in the object header or the table row itself, so odsuite writes every
text that way (format 1.1.0; ``migrations`` rewrites the variable-length text of 1.0.0 files).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import h5py
import numpy as np


def _encoded(values: Iterable[str]) -> tuple[list[bytes], int]:
    data = [str(v).encode("utf-8") for v in values]
    return data, max((len(b) for b in data), default=0) or 1  # HDF5 strings hold at least one byte


def fixed_dtype(values: Iterable[str]) -> np.dtype:
    """The fixed-length UTF-8 string type that holds every one of ``values``."""
    return h5py.string_dtype("utf-8", _encoded(values)[1])


def fixed(value: str | Iterable[str]) -> np.ndarray:
    """``value`` (a string, or a sequence of strings) as a fixed-length UTF-8 array."""
    scalar = isinstance(value, str)
    data, width = _encoded([value] if scalar else value)
    return np.array(data[0] if scalar else data, dtype=h5py.string_dtype("utf-8", width))


def _string_array(value: Any) -> bool:
    if not isinstance(value, np.ndarray):
        return False
    return value.dtype.kind in "US" or h5py.check_string_dtype(value.dtype) is not None


def stored(value: Any) -> Any:
    """``value`` as odsuite stores it in an attribute: text (str, bytes, a list of str, a string
    array) as fixed-length UTF-8, anything else unchanged."""
    if isinstance(value, bytes):
        value = value.decode("utf-8")
    if isinstance(value, str):
        return fixed(value)
    if isinstance(value, list | tuple) and value and all(isinstance(v, str) for v in value):
        return fixed(value)
    if _string_array(value):
        if value.ndim == 0:
            return fixed(text(value[()]))
        return fixed([text(v) for v in value.ravel()]).reshape(value.shape)
    return value


def set_attrs(obj: h5py.HLObject, values: Mapping[str, Any]) -> None:
    """Set attributes of ``obj`` (text as fixed-length UTF-8, see ``stored``)."""
    for key, value in values.items():
        obj.attrs[key] = stored(value)


def text(value: Any) -> str:
    """A stored string as ``str`` (fixed-length strings read as bytes, variable-length as str)."""
    return value.decode("utf-8") if isinstance(value, bytes) else str(value)


def readable(value: Any) -> Any:
    """An attribute value with its text as ``str`` (a list of ``str`` for an array of strings)."""
    if isinstance(value, bytes):
        return text(value)
    if _string_array(value):
        return [text(v) for v in value.ravel()]
    return value


def is_variable_text(dtype: np.dtype) -> bool:
    """A variable-length string type, alone or as a field of a compound type."""
    if dtype.names:
        return any(is_variable_text(dtype.fields[n][0]) for n in dtype.names)
    info = h5py.check_string_dtype(dtype)
    return info is not None and info.length is None
