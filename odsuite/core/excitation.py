"""The excitation of an experiment: where and how the hammer hit."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Excitation:
    """Where and how the hammer hit: force channel, point (m, from the platform's centre of mass,
    platform axes) and unit direction."""

    force_channel: int
    point: np.ndarray
    direction: np.ndarray
