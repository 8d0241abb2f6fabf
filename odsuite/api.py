"""What a lab's plugin or a notebook imports from odsuite: the names here, and the provider
contracts in ``odsuite.contracts``. Everything else is internal and may change between versions.

Names load on first use (``odsuite.api.compare`` imports the comparison then), so a plugin that
imports this module at registration costs nothing at start-up.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import os

#: public name -> the module that defines it (``module:attribute`` where the name differs)
_WHERE: dict[str, str] = {
    # errors and version
    "ConfigError": "odsuite.domain.errors",
    "DimensionError": "odsuite.domain.errors",
    "HardwareError": "odsuite.domain.errors",
    "OdsuiteError": "odsuite.domain.errors",
    "OdsuiteWarning": "odsuite.domain.errors",
    "__version__": "odsuite.domain.version",
    # plugins: the hook marker and the registries (notebooks and tests build their own)
    "hookimpl": "odsuite.contracts.hookspecs",
    # a plugin's command: the one line a Ctrl-C prints, where it wrote files of its own
    "say_on_interrupt": "odsuite.contracts.interrupts",
    "make_plugin_manager": "odsuite.contracts.plugins",
    "registries": "odsuite.contracts.plugins",
    "Registries": "odsuite.contracts.plugins",
    # rigs, sensors and where the hammer hit
    "Body": "odsuite.domain.rig",
    "load_rig": "odsuite.domain.rig",
    "MAX_CHANNELS": "odsuite.domain.rig",
    "NINE_ROLES": "odsuite.domain.rig",
    "NineSensorSet": "odsuite.domain.rig",
    "printable_name": "odsuite.domain.rig",
    "Rig": "odsuite.domain.rig",
    "rig_from_dict": "odsuite.domain.rig",
    "Sensor": "odsuite.domain.rig",
    "single_axis_sensor": "odsuite.domain.rig",
    "known_keys": "odsuite.domain.rig",
    "SENSOR_KEYS": "odsuite.domain.rig",
    "Excitation": "odsuite.domain.excitation",
    # a structure's geometry: nodes, lines, faces, sensors on nodes (docs/geometry.md)
    "Geometry": "odsuite.domain.geometry",
    "GeometrySensor": "odsuite.domain.geometry",
    "GEOMETRY_KIND": "odsuite.domain.geometry",
    "geometry_from_record": "odsuite.domain.geometry",
    "geometry_record": "odsuite.domain.geometry",
    "parse_direction": "odsuite.domain.geometry",
    "project_geometry": "odsuite.domain.geometry",
    "parse_force_direction": "odsuite.domain.excitation",
    "parse_force_point": "odsuite.domain.excitation",
    "ChannelInfo": "odsuite.domain.systeminfo",
    "format_ctr": "odsuite.domain.systeminfo",
    "parse_ctr": "odsuite.domain.systeminfo",
    "read_ctr": "odsuite.domain.systeminfo",
    "SensorType": "odsuite.domain.systeminfo",
    "SENSOR_UNITS": "odsuite.domain.systeminfo",
    "Systeminfo": "odsuite.domain.systeminfo",
    "write_ctr": "odsuite.domain.systeminfo",
    # rigid-body kinematics (SI: m, rad; rig frame)
    "body_corners": "odsuite.domain.rigidbody",
    "body_sensors": "odsuite.domain.rig",
    "com_to_corner": "odsuite.domain.rigidbody",
    "COORDINATE_UNITS": "odsuite.domain.rigidbody",
    "COORDINATES": "odsuite.domain.rig",
    "corner_to_com": "odsuite.domain.rigidbody",
    "CORNERS": "odsuite.domain.rigidbody",
    "plate_corners": "odsuite.domain.rigidbody",
    "PLOT_INDEX": "odsuite.domain.rigidbody",
    "point_displacements": "odsuite.domain.rigidbody",
    "Rigidity": "odsuite.domain.rigidbody",
    "rotation_matrix": "odsuite.domain.rigidbody",
    "SolverResult": "odsuite.domain.rigidbody",
    "stack_signals": "odsuite.domain.rigidbody",
    "transform_points": "odsuite.domain.rigidbody",
    # the linear multibody model and its simulation
    "FlexibleMode": "odsuite.domain.model",
    "Input": "odsuite.domain.model",
    "LinearStructure": "odsuite.domain.model",
    "Model": "odsuite.domain.model",
    "Output": "odsuite.domain.model",
    "RigidBody": "odsuite.domain.model",
    "SensorDynamics": "odsuite.domain.model",
    "skew": "odsuite.domain.model",
    "rotated": "odsuite.domain.model",
    "cross": "odsuite.domain.model",
    "SpringDamper": "odsuite.domain.model",
    "Structure": "odsuite.domain.model",
    "simulate": "odsuite.domain.simulation",
    "simulate_nonlinear": "odsuite.domain.simulation",
    "sampled_later": "odsuite.domain.simulation",
    # units and errors as printed for people (one style in pictures, report and command line)
    "ascii_unit": "odsuite.domain.display",
    "error_text": "odsuite.domain.display",
    "fixed": "odsuite.domain.display",
    "per_unit": "odsuite.domain.display",
    "rms_label": "odsuite.domain.display",
    "unit_text": "odsuite.domain.display",
    # text files and outputs (room checked before writing)
    "check_text_file": "odsuite.domain.textfiles",
    "plain_number": "odsuite.domain.textfiles",
    "free_memory": "odsuite.domain.memory",
    "read_text": "odsuite.domain.textfiles",
    "ensure_space": "odsuite.store.diskspace",
    "write_output": "odsuite.store.diskspace",
    # the project file
    "create_project": "odsuite.store.project",
    "DerivedArray": "odsuite.store.project",
    "open_project": "odsuite.store.project",
    "Project": "odsuite.store.project",
    "interrupts_deferred": "odsuite.store.storage",
    "interrupts_held": "odsuite.store.storage",
    # recording and processing
    "acquire": "odsuite.processing.acquisition",
    "build_chain": "odsuite.processing.chain_spec",
    "process_experiment": "odsuite.processing.pipeline",
    # what the model predicts and how it compares
    "coordinate_series": "odsuite.analysis.prediction",
    "experiment_coordinates": "odsuite.analysis.prediction",
    "experiment_force": "odsuite.analysis.prediction",
    "flexible_mode_change": "odsuite.analysis.prediction",
    "predict": "odsuite.analysis.prediction",
    "sensor_filter": "odsuite.analysis.prediction",
    "prepare": "odsuite.analysis.prediction",
    "current_revision": "odsuite.analysis.modelrev",
    "revision_model": "odsuite.analysis.modelrev",
    "ideal_chain_model": "odsuite.analysis.correction",
    "stored_correction": "odsuite.analysis.correction",
    "compare": "odsuite.analysis.comparison",
    "resolve": "odsuite.analysis.resolved",
    "COORDINATE_NAMES": "odsuite.analysis.comparison",
    "history": "odsuite.analysis.history",
    # FRFs, modes and operating shapes
    "estimate_frf": "odsuite.analysis.frf",
    "TREND_FREE_LINE": "odsuite.analysis.frf",
    "TREND_SHARE": "odsuite.analysis.frf",
    "assess_hits": "odsuite.analysis.hammer",
    "pair_modes": "odsuite.analysis.modal",
    "PAIR_TOLERANCE": "odsuite.analysis.modal_comparison",
    "identified_record": "odsuite.analysis.modal_comparison",
    "RecordModes": "odsuite.analysis.modal_comparison",
    "frf_modes": "odsuite.analysis.modal_project",
    "ods_coordinates": "odsuite.analysis.modal_project",
    "ods_motion": "odsuite.analysis.modal_project",
    "physical": "odsuite.analysis.modal_project",
    "experiment_output_only_modes": "odsuite.analysis.modal_project",
    "project_setups_modes": "odsuite.analysis.multisetup",
    # output-only pieces the report shows: the prepared record's spectral matrix, EFDD against
    # SSI-cov, setups merged from modes already identified
    "check_references": "odsuite.analysis.multisetup",
    "merge_setups": "odsuite.analysis.multisetup",
    "fdd_doc": "odsuite.analysis.modal",
    "mac": "odsuite.analysis.modal",
    "mpd": "odsuite.analysis.modal",
    "prepare_output_only": "odsuite.analysis.oma:prepare",
    "response_columns": "odsuite.analysis.modal_project",
    "spectral_matrix": "odsuite.analysis.fdd",
    "operating_shape": "odsuite.analysis.ods",
    "frequency_labels": "odsuite.analysis.modal",
    "mpc": "odsuite.analysis.modal",
    # diagnosis
    "diagnose": "odsuite.diagnosis.diagnose",
    "add_effect": "odsuite.diagnosis.add_effect",
    "physical_text": "odsuite.diagnosis.physical:text",
    "moved_quantities": "odsuite.diagnosis.physical:moved",
    "check_diagnosis": "odsuite.analysis.diagnosis_document",
    "store_diagnosis": "odsuite.analysis.stored_diagnosis",
    "stored_diagnosis": "odsuite.analysis.stored_diagnosis",
    # work over many projects
    "run_batch": "odsuite.ops.batch",
    "build_catalog": "odsuite.ops.catalog",
    "catalog_connect": "odsuite.ops.catalog:connect",
    "catalog_query": "odsuite.ops.catalog:query",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    try:
        module, _, attribute = _WHERE[name].partition(":")
    except KeyError:
        raise AttributeError(f"module 'odsuite.api' has no attribute {name!r}") from None
    value = _checked(getattr(importlib.import_module(module), attribute or name))
    globals()[name] = value  # later lookups skip this function
    return value


#: arguments of a project's functions that name one experiment, and that name several
_ONE_EXPERIMENT = ("name", "experiment")
_EXPERIMENTS = ("experiments",)
#: functions whose ``name`` is not an experiment's: what it names instead
_NAMES_OTHER = {"add_effect": "an effect", "project_geometry": "a geometry"}


def _checked(function):
    """A function whose first argument is a project, checking what a notebook most often gets wrong
    before it runs: a path given for the open project (or an open project where its path is asked), a number for an experiment's name, one name
    for a list of them. Inside, a path read as a project said "'str' object has no attribute
    'model_revisions'", and a name's letters were taken for names."""
    if not inspect.isfunction(function):
        return function
    parameters = inspect.signature(function).parameters
    if next(iter(parameters), None) != "project":
        return function
    signature = inspect.signature(function)
    # a few open the project themselves (their own worker processes read it): they take its path
    by_path = "Path" in str(parameters["project"].annotation)

    @functools.wraps(function)
    def call(*args, **kwargs):
        from odsuite.domain.arguments import shown
        from odsuite.domain.errors import ConfigError
        from odsuite.store.project import Project

        try:
            bound = signature.bind(*args, **kwargs).arguments
        except TypeError as exc:
            raise ConfigError(f"{function.__name__}: {exc}") from None
        project = bound["project"]
        if by_path and not isinstance(project, str | os.PathLike):
            raise ConfigError(f"{function.__name__}: expected a project file's path as its first argument, got "
                              f"{type(project).__name__} {shown(project)}")
        if not by_path and not isinstance(project, Project):
            raise ConfigError(f"{function.__name__}: expected an open project (open_project(path)) as its first "
                              f"argument, got {type(project).__name__} {shown(project)}")
        for key in _ONE_EXPERIMENT:
            if key in bound and bound[key] is not None and not isinstance(bound[key], str):
                what = _NAMES_OTHER.get(function.__name__, "an experiment") if key == "name" else "an experiment"
                raise ConfigError(f"{function.__name__}: {key!r} names {what} (text), got {shown(bound[key])}")
        for key in _EXPERIMENTS:
            value = bound.get(key)
            # a list's members are checked; another iterable is left unread for the function
            if isinstance(value, str | bytes) or isinstance(value, list | tuple) and not all(isinstance(v, str) for v in value):
                raise ConfigError(f"{function.__name__}: {key!r} is a list of experiment names, got {shown(value)}")
        return function(*args, **kwargs)

    return call


def __dir__() -> list[str]:
    return __all__
