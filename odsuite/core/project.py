"""The odsuite project file (HDF5, schema 1.0.0).

Layout (every group has ``odsuite_type`` and ``object_id``; numeric datasets have ``units``, ``dims``)::

    /                         odsuite_format="odsuite.project", odsuite_format_version="1.0.0", ...
    /rig                      the rig definition the project was created on (TOML text + name)
    /experiments/<name>/      odsuite_type="experiment"
        raw                   float64 volts, samples x channels, fletcher32, written once
        systeminfo            per-channel table + rig rows (readable without odsuite)
        attrs: sampling_rate (Hz), pretrigger (samples), rig, force_channel, force_point (m),
               force_direction (unit vector), created, source
        derived/<kind>/       odsuite_type="derived", provenance attrs (plugin, version,
                              parameters JSON, inputs, created)
    /models/revisions/<n>/    model revisions (effects, parameters, metrics, parent)

IMPLEMENTATION CONTRACT (filled in by the implementation; signatures are fixed):
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from odsuite.core.rig import Rig
from odsuite.core.systeminfo import Systeminfo

FORMAT_NAME = "odsuite.project"
FORMAT_VERSION = "1.0.0"


@dataclass(frozen=True)
class Excitation:
    """Where and how the hammer hit: force channel, point (m, from the platform's centre of mass,
    platform axes) and unit direction."""

    force_channel: int
    point: np.ndarray
    direction: np.ndarray


@dataclass(frozen=True)
class DerivedArray:
    """An array to store in a derived group, with its SI units and dimension names."""

    data: np.ndarray
    units: str
    dims: tuple[str, ...]


class Experiment:
    """Read-only view of one stored experiment (raw data are read lazily)."""

    name: str
    sampling_rate: float  # Hz
    pretrigger: int  # samples before the trigger
    systeminfo: Systeminfo
    excitation: Excitation | None
    rig_name: str | None
    channel_names: list[str]
    n_samples: int
    n_channels: int

    def raw(self, start: int = 0, stop: int | None = None, channels=None) -> np.ndarray:
        """Raw volts, samples x channels (a slice of rows and optionally of channels)."""
        raise NotImplementedError


class Project:
    path: Path
    mode: str
    rig: Rig | None  # None for projects created with --rig none

    def experiment_names(self) -> list[str]:
        raise NotImplementedError

    def experiment(self, name: str) -> Experiment:
        raise NotImplementedError

    def add_experiment(
        self,
        name: str,
        raw: np.ndarray | Iterator[np.ndarray],
        *,
        sampling_rate: float,
        systeminfo: Systeminfo,
        excitation: Excitation | None,
        pretrigger: int = 0,
        n_samples: int | None = None,
        source: str = "",
        channel_names: list[str] | None = None,
    ) -> Experiment:
        """Add an experiment atomically. ``raw`` is an array (samples x channels) or an iterator of
        row-chunks (then ``n_samples`` may be given); a crash at any point leaves no half experiment."""
        raise NotImplementedError

    def write_derived(
        self,
        experiment: str,
        kind: str,
        arrays: Mapping[str, DerivedArray],
        *,
        provenance: Mapping[str, Any],
        attrs: Mapping[str, Any] | None = None,
    ) -> None:
        """Store (or replace, atomically) the derived group ``kind`` of an experiment."""
        raise NotImplementedError

    @contextmanager
    def derived_writer(self, experiment: str, kind: str, *, provenance: Mapping[str, Any]):
        """Stream a large derived group: yields a writer with
        ``create(name, shape, dtype, units, dims) -> h5py-like dataset`` supporting ``ds[a:b] = x``.
        The group becomes visible only when the block exits without error."""
        raise NotImplementedError
        yield

    def read_derived(self, experiment: str, kind: str) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def derived_kinds(self, experiment: str) -> list[str]:
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError


def create_project(path: str | Path, rig: Rig | str | None = "thesis-dynamometer") -> Project:
    """Create a new project file (refuses to overwrite) and return it open for writing."""
    raise NotImplementedError


def open_project(path: str | Path, mode: str = "r") -> Project:
    """Open a project for reading ("r") or reading and writing ("a"). Usable as a context manager."""
    raise NotImplementedError
