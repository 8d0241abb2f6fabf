"""The filter families and types a channel's chain may use (Table E.2 rows 5, 6 and 18)."""

from __future__ import annotations

from enum import IntEnum

#: Highest IIR filter order: elliptic and Butterworth designs above ~30 put poles within rounding
#: of each other even as second-order sections; the thesis uses 8
MAX_FILTER_ORDER = 30


class FilterType(IntEnum):
    """Table E.2 row 5."""

    LOWPASS = 0
    HIGHPASS = 1
    BANDPASS = 2
    BANDSTOP = 3


class FilterFamily(IntEnum):
    """Table E.2 row 18."""

    ELLIPTIC = 0
    BUTTERWORTH = 1
