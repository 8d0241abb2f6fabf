"""``acquire``: one record from an acquisition backend streamed into a project, so that the stored
layout is the same whichever backend produced it."""

from __future__ import annotations

from typing import Any

from odsuite.contracts.daq import (AcquisitionSettings, DaqBackend, Progress, Recording, check_backend_options,
                                   check_record_fits)
from odsuite.domain.errors import ConfigError
from odsuite.domain.excitation import check_force_point
from odsuite.domain.systeminfo import Systeminfo
from odsuite.store.project import Experiment, Project


def acquire(
    project: Project,
    backend: DaqBackend,
    name: str,
    settings: AcquisitionSettings | None = None,
    *,
    progress: Progress | None = None,
    **options: Any,
) -> tuple[Experiment, Recording]:
    """Record one experiment with ``backend`` and stream it into ``project`` as ``name``.

    ``options`` go to the backend (the simulator's scenario and seed, NI device names, a force point
    and direction, ...). Chunks are written as they arrive; the experiment becomes visible only
    once complete. Returns the stored experiment and the recording (its clipping counts, notes).
    """
    check_backend_options(backend, options)
    if not isinstance(name, str):
        raise ConfigError(f"acquire: the experiment name must be text, got {name!r}")
    if settings is not None and not isinstance(settings, AcquisitionSettings):
        raise ConfigError(f"acquire: settings must be an AcquisitionSettings, got {type(settings).__name__}")
    if name in project.experiment_names():
        raise ConfigError(f"{project.path}: experiment {name!r} already exists; choose another --name")
    settings = settings or AcquisitionSettings()
    if options.get("point") is not None and project.rig is not None:
        check_force_point(project.rig, options["point"], "--force-point")
        project.rig.force_body(options["point"], options.get("force_body"))  # a known body; no ambiguity
    elif options.get("force_body") is not None:
        raise ConfigError("--force-body needs --force-point and --force-dir")
    channels = project.rig.channel_count if project.rig is not None else 1
    check_record_fits(settings.n_samples, channels, f"{project.path}: --samples {settings.n_samples}")
    if project.rig is not None:
        # a rig's offset window or filter the record cannot hold is refused before it is recorded
        # (compare refused it after, naming no file, experiment or channel)
        Systeminfo.for_rig(project.rig, settings.sampling_rate).validate(
            n_samples=settings.n_samples, source=f"{project.path}: rig {project.rig.name!r} for --samples {settings.n_samples}")
    rec = backend.record(project.rig, settings, progress=progress, **options)
    exp = project.add_experiment(
        name,
        raw=rec.chunks,
        n_samples=rec.n_samples,
        sampling_rate=rec.sampling_rate,
        systeminfo=rec.systeminfo,
        excitation=rec.excitation,
        pretrigger=rec.pretrigger,
        source=rec.source,
        channel_names=rec.channel_names,
    )
    return exp, rec
