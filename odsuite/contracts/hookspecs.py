"""Hook specifications: the only way plugins, built-in or a lab's own, extend odsuite.

A plugin is a module (or object) with functions marked ``@odsuite.hookimpl`` and declared in the
``odsuite`` entry-point group of its distribution. Each registration hook receives a
:class:`~odsuite.contracts.registry.Registry` and calls ``registry.add(name, provider)``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import pluggy

if TYPE_CHECKING:
    import typer

    from odsuite.contracts.registry import Registry

hookspec = pluggy.HookspecMarker("odsuite")
hookimpl = pluggy.HookimplMarker("odsuite")


@hookspec
def odsuite_register_daq_backends(registry: Registry) -> None:
    """Add acquisition backends: ``registry.add(name, backend)``.

    :param registry: the DAQ-backend registry (a view that records your plugin as the source).
    :return: nothing; providers are added to ``registry``.

    A backend meets :class:`odsuite.contracts.daq.DaqBackend`: ``description``, ``options`` (the
    :class:`~odsuite.contracts.daq.BackendOption` keywords a user may set, each with its unit and
    default) and ``record(rig, settings, progress=None, **options) -> Recording`` (samples in volts
    as the card reads them; ``settings.sampling_rate`` in Hz). ``odsuite acquire --daq NAME`` uses it.

    Called once per process when the registries are built (before any command runs). Raise nothing
    here; a backend that cannot reach its hardware raises
    :class:`~odsuite.domain.errors.HardwareError` from ``record``, naming device and channel.

    Example::

        @hookimpl
        def odsuite_register_daq_backends(registry):
            registry.add("lab-pulse", PulseBackend())
    """


@hookspec
def odsuite_register_processing_steps(registry: Registry) -> None:
    """Add signal-processing steps by the name a chain specification uses.

    :param registry: the processing-step registry.
    :return: nothing.

    A step provider meets :class:`odsuite.contracts.steps.StepFactory`: called as
    ``provider(fs=..., **params)`` (``fs`` in Hz, the chain entry's parameters in SI) it returns a
    :class:`~odsuite.contracts.steps.Step` or a list of steps and markers; optionally
    ``linear_form(fs=..., **params)`` says what it does as gains, window means and filters, so a
    model's prediction runs through it in one call. Bad parameters raise ``TypeError`` or
    :class:`~odsuite.domain.errors.ConfigError` when the chain is built, not while it runs.

    Called once per process when the registries are built.

    Example::

        @hookimpl
        def odsuite_register_processing_steps(registry):
            registry.add("lab-highpass", StepProvider(make_highpass, linear=highpass_form))
    """


@hookspec
def odsuite_register_coordinate_solvers(registry: Registry) -> None:
    """Add solvers that turn processed sensor signals into a body's generalized coordinates.

    :param registry: the coordinate-solver registry.
    :return: nothing.

    A solver meets :class:`odsuite.contracts.solvers.CoordinateSolver`: ``name``, ``description``,
    ``suitability(rig, body, sensors) -> float | None`` (None: cannot solve from these sensors; the
    most suitable solver runs where the rig file names none) and ``solve(rig, body, signals) ->
    SolverResult`` (x, y, z in m and theta, phi, psi in rad at the body's centre of mass, rig axes,
    from signals along each sensor's positive axis); optionally ``rigidity_check``. ``solve`` raises
    :class:`~odsuite.domain.errors.ConfigError` naming rig, body and sensors when it cannot.

    Called once per process when the registries are built; solvers run in ``process``, ``compare``
    and every engine that needs coordinates.

    Example::

        @hookimpl
        def odsuite_register_coordinate_solvers(registry):
            registry.add("lab-two-point", TwoPointSolver())
    """


@hookspec
def odsuite_register_models(registry: Registry) -> None:
    """Add model factories by the name a rig file's ``default_model`` uses.

    :param registry: the model registry.
    :return: nothing.

    A factory meets :class:`odsuite.contracts.models.ModelFactory`: called with a rig (or None) it
    returns a :class:`~odsuite.domain.model.Model` in SI (kg, kg m^2, N/m, N s/m, m). Bad rigs raise
    :class:`~odsuite.domain.errors.ConfigError` naming the rig and field.

    Called once per process when the registries are built; factories run when a project's model is
    needed (``model``, ``compare``, ``diagnose``, ...), so they should be cheap.

    Example::

        @hookimpl
        def odsuite_register_models(registry):
            registry.add("lab-block", block_on_mounts)
    """


@hookspec
def odsuite_register_effects(registry: Registry) -> None:
    """Add physical effects the diagnosis can fit (a stiffness change, a missing mode, a gain...).

    :param registry: the effect registry.
    :return: nothing.

    An effect meets :class:`odsuite.contracts.effects.EffectProvider` (subclass
    :class:`~odsuite.contracts.effects.Effect`): ``name``, ``target`` ("model" or "chain"),
    ``description``, ``parameters(model)`` (SI units, nominal, bounds, optional plausible range; an
    empty list when it does not apply to this model) and ``apply(model, values) -> Model`` (pure and
    cheap: called in fitting loops); the optional members of that module's docstring add
    refinements, variable projection and repetition.

    Called once per process when the registries are built; ``diagnose`` screens every registered
    effect, ``add-effect NAME`` fits one.

    Example::

        @hookimpl
        def odsuite_register_effects(registry):
            registry.add("lab_amplifier_gain", AmplifierGain())
    """


@hookspec
def odsuite_register_renderers(registry: Registry) -> None:
    """Add renderers of movies, figures and pages.

    :param registry: the renderer registry.
    :return: nothing.

    A renderer meets :class:`odsuite.contracts.renderers.Renderer`: ``name``, ``description``,
    ``kind`` ("movie", "figure" or "page"), ``suffixes`` (".mp4", ".png", ...) and
    ``render(request) -> Rendered``; it opens the project with ``registries=request.registries``
    and refuses options it does not take in one line.

    Called once per process when the registries are built; ``render``, ``report`` and ``ods
    --movie`` choose a renderer by name, kind and the output's suffix.

    Example::

        @hookimpl
        def odsuite_register_renderers(registry):
            registry.add("lab-force-plot", ForcePlot())
    """


@hookspec
def odsuite_register_sensor_types(registry: Registry) -> None:
    """Add the sensor kinds a rig file's ``[[sensors]]`` entries may name.

    :param registry: the sensor-type registry.
    :return: nothing.

    A sensor type meets :class:`odsuite.contracts.sensor_types.SensorKind`: ``name`` (the ``kind``),
    ``description``, ``quantity`` and its SI ``unit``, and ``sensors(entry, where)`` returning one
    single-axis sensor per channel (positions in m, unit axes, sensitivities in V per SI unit); bad
    fields raise :class:`~odsuite.domain.errors.ConfigError` naming ``where``, field and value.

    Called once per process, before the rigs hook (rig files name sensor kinds).

    Example::

        @hookimpl
        def odsuite_register_sensor_types(registry):
            registry.add("lab_biaxial", Biaxial())
    """


@hookspec
def odsuite_register_rigs(registry: Registry) -> None:
    """Add rigs by name (``odsuite new P.h5 --rig NAME``).

    :param registry: the rig registry; ``registry.sensor_types`` holds every sensor kind registered.
    :return: nothing.

    A rig is a :class:`~odsuite.domain.rig.Rig` (bodies, plates, sensors, force channel, default
    model; metres in the rig frame), usually read from a TOML file the package ships with
    ``load_rig(path, registry.sensor_types)``. A bad rig file raises
    :class:`~odsuite.domain.errors.ConfigError` naming file, field and value, which stops start-up:
    ship only files your tests load.

    Called once per process when the registries are built, after the sensor-types hook.

    Example::

        @hookimpl
        def odsuite_register_rigs(registry):
            registry.add("lab-table", load_rig(RIG_DIR / "lab-table.toml", registry.sensor_types))
    """


@hookspec
def odsuite_register_importers(registry: Registry) -> None:
    """Add importers of measurement files (and writers of their format).

    :param registry: the importer registry.
    :return: nothing.

    An importer meets :class:`odsuite.contracts.importers.Importer`: ``name`` (the ``--format``),
    ``description``, ``suffixes``, ``options`` (:class:`~odsuite.contracts.importers.ImportOption`,
    each with its unit in its help) and ``import_file(project, file, name, **options) -> Imported``
    (the record stored once, atomically; a bad file raises one
    :class:`~odsuite.domain.errors.OdsuiteError` naming file, field, channel and value, and leaves the
    project unchanged); optionally ``export_file(project, out, experiment, **options)``.

    Called once per process when the registries are built; ``odsuite import`` chooses an importer
    by ``--format`` or the file's suffix.

    Example::

        @hookimpl
        def odsuite_register_importers(registry):
            registry.add("lab-npz", NpzImporter())
    """


@hookspec
def odsuite_register_commands(app: typer.Typer) -> None:
    """Add sub-commands to the ``odsuite`` command line.

    :param app: the command line's ``typer.Typer``; decorate functions with ``@app.command(NAME)``.
    :return: nothing.

    Called once per run of the command line, before its words are parsed: import heavy modules
    inside the command's function, not here (every command's start-up pays for this hook). A
    command reports bad input by raising :class:`~odsuite.domain.errors.OdsuiteError` (one line,
    exit code 1).

    Example::

        @hookimpl
        def odsuite_register_commands(app):
            @app.command("lab-summary")
            def lab_summary(project: Path) -> None:
                ...
    """
