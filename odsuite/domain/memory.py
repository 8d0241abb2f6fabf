"""How much memory this machine has free: inputs that would not fit are refused before any
allocation, naming the size."""

from __future__ import annotations

import os

from odsuite.domain.errors import ConfigError


def free_memory() -> int | None:
    """Bytes of physical memory free now, or None where the system does not say (Windows)."""
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def check_record_fits(n_samples: int, n_channels: int, where: str) -> None:
    """Refuse, before anything is allocated, a record whose float64 samples exceed the memory
    this machine has free."""
    need = int(n_samples) * int(n_channels) * 8
    free = free_memory()
    if free is not None and need > free:
        raise ConfigError(f"{where}: a record of {n_samples} samples x {n_channels} channels needs "
                          f"{need / 2**20:.0f} MiB; only {free / 2**20:.0f} MiB of memory are free")
