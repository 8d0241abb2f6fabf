"""The disturbances a record's quiet samples are fitted with besides its noise: an offset, a line
(drift) and the mains hum with its harmonics (noise_floor.split_noise fits them; noise_colour
gives back the noise they take)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: mains frequencies and harmonics fitted as hum (Hz): 50 Hz and 60 Hz grids, up to the 3rd
MAINS_HZ = (50.0, 60.0)
MAINS_HARMONICS = 3


def disturbance_basis(n: int, fs: float, mains: Sequence[float] = MAINS_HZ,
                      harmonics: int = MAINS_HARMONICS, line: bool = True) -> np.ndarray:
    """Columns: a constant, a line (``line``), and sine/cosine pairs at the mains frequencies and
    harmonics."""
    t = np.arange(n) / fs
    cols = [np.ones(n)] + ([t - t.mean()] if line else [])
    for f0 in mains:
        for h in range(1, harmonics + 1):
            if h * f0 < fs / 2:
                cols += [np.sin(2 * np.pi * h * f0 * t), np.cos(2 * np.pi * h * f0 * t)]
    return np.column_stack(cols)
