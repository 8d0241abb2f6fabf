"""How much memory this machine has free: inputs that would not fit are refused before any
allocation, naming the size."""

from __future__ import annotations

import os


def free_memory() -> int | None:
    """Bytes of physical memory free now, or None where the system does not say (Windows)."""
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None
