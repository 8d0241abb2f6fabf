"""Peak volts and clipped samples of a stored record, scanned block by block (never all in memory)."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from odsuite.store.project_format import CHUNK_BYTES
from odsuite.domain.systeminfo import Systeminfo

#: A sample within this fraction of a channel's DAQ range (limit_high - limit_low) of a limit is
#: clipped: one step of a 12-bit converter.
CLIP_FRACTION = 1 / 2048


class Record(Protocol):
    """What the scan reads: a stored experiment's raw volts and its Systeminfo."""

    n_samples: int
    n_channels: int
    systeminfo: Systeminfo

    def raw(self, start: int = 0, stop: int | None = None) -> np.ndarray: ...


def scan(record: Record) -> tuple[np.ndarray, np.ndarray]:
    """Per channel: the peak |volts| and the number of clipped samples (see ``CLIP_FRACTION``)."""
    hi = np.array([c.limit_high for c in record.systeminfo.channels])
    lo = np.array([c.limit_low for c in record.systeminfo.channels])
    tol = (hi - lo) * CLIP_FRACTION
    peak = np.zeros(record.n_channels)
    clipped = np.zeros(record.n_channels, dtype=np.int64)
    step = max(1, 8 * CHUNK_BYTES // (8 * record.n_channels))  # rows of eight raw chunks
    for start in range(0, record.n_samples, step):
        block = record.raw(start, start + step)
        peak = np.maximum(peak, np.abs(block).max(axis=0))
        clipped += ((block >= hi - tol) | (block <= lo + tol)).sum(axis=0)
    return peak, clipped
