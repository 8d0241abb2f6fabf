"""The plugin manager factory and the registries it fills.

Built-in plugins and a lab's own package are found the same way: entry points in the ``odsuite``
group. ``ODSUITE_DISABLE_PLUGINS`` (comma-separated entry-point names) blocks plugins.
"""

from __future__ import annotations

import contextlib
import functools
import io
import os
from dataclasses import dataclass, fields

import pluggy

from odsuite.contracts import hookspecs
from odsuite.domain import installed
from odsuite.domain.errors import PluginConflictError, PluginLoadError
from odsuite.contracts.registry import Contract, Registry, Source
from odsuite.contracts.timebound import PluginTimeout, plugin_seconds, time_bound

ENTRY_POINT_GROUP = "odsuite"
REQUIRED_BUILTINS = ("beam", "daq_ni", "daq_sim", "demo", "filters", "gencoord_padgaonkar", "importers", "models", "renderers")
#: built-in plugins the core cannot work without, and why: stored chains name their steps, stored
#: rigs their sensor kinds and models
ESSENTIAL = {
    "filters": "every processing chain odsuite writes names its steps (convert, offset, filters, integrate)",
    "models": "every rig file names its sensor kinds and default model, which it registers",
}


@dataclass(frozen=True)
class Registries:
    """Every kind of provider, keyed by name. Field name = hook name without the prefix."""

    daq_backends: Registry
    processing_steps: Registry
    coordinate_solvers: Registry
    models: Registry
    effects: Registry
    renderers: Registry
    sensor_types: Registry
    rigs: Registry
    importers: Registry


def disabled_plugins() -> set[str]:
    raw = os.environ.get("ODSUITE_DISABLE_PLUGINS", "")
    return {name.strip() for name in raw.split(",") if name.strip()}


class PluginManager(pluggy.PluginManager):
    """A pluggy manager that also remembers each plugin's distribution and version."""

    def __init__(self) -> None:
        super().__init__(ENTRY_POINT_GROUP)
        self.sources: dict[str, Source] = {}
        #: installed plugins left out because they failed (name -> one line naming its distribution)
        self.failures: dict[str, str] = {}

    def third_party(self, name: str) -> bool:
        """An installed plugin (an entry point) that is not one of odsuite's own."""
        source = self.sources.get(name)
        return (name not in REQUIRED_BUILTINS and source is not None
                and source.distribution not in (Source.distribution, "odsuite"))

    def leave_out(self, name: str, exc: BaseException, stage: str) -> None:
        """Record a third-party plugin that failed and unregister it: the rest of odsuite runs on."""
        first = (str(exc).strip().splitlines() or [""])[0]
        why = f"{type(exc).__name__}: {first}" if first else type(exc).__name__
        self.failures[name] = (f"plugin {name!r} (distribution {self.sources[name].distribution!r}) left out: "
                               f"it failed {stage}: {why}")
        if self.get_plugin(name) is not None:
            self.unregister(name=name)

    def source(self, name: str) -> Source:
        return self.sources.get(name, Source(name))


def make_plugin_manager(*, load_entry_points: bool = True, extra_plugins: tuple = ()) -> PluginManager:
    """Build a fresh manager: specs, blocked plugins, entry points, checks.

    ``extra_plugins`` registers plugin objects directly (tests, embedding applications).
    """
    pm = PluginManager()
    pm.add_hookspecs(hookspecs)
    blocked = disabled_plugins()
    essential = sorted(blocked & set(ESSENTIAL))
    if essential:
        name = essential[0]
        raise PluginLoadError(f"ODSUITE_DISABLE_PLUGINS: plugin {name!r} cannot be disabled: {ESSENTIAL[name]} "
                              f"(plugins that can: {', '.join(n for n in REQUIRED_BUILTINS if n not in ESSENTIAL)})")
    for name in blocked:
        pm.set_blocked(name)
    if load_entry_points:
        _load_entry_points(pm, blocked)
    for plugin in extra_plugins:
        name = pm.register(plugin, name=getattr(plugin, "__name__", None))
        pm.sources[name] = Source(name)
    while True:
        try:
            pm.check_pending()
            break
        except pluggy.PluginValidationError as exc:
            name = pm.get_name(exc.plugin) or repr(exc.plugin)
            if not pm.third_party(name):
                raise PluginLoadError(f"plugin {name!r}: {exc}") from None
            pm.leave_out(name, exc, "its hook check")
    if load_entry_points:
        missing = [n for n in REQUIRED_BUILTINS if n not in blocked and pm.get_plugin(n) is None]
        if missing:
            raise PluginLoadError(
                f"built-in plugin(s) {', '.join(missing)} not found among the installed entry points; "
                "the installation is stale: re-run `make venv`"
            )
    return pm


def _load_entry_points(pm: PluginManager, blocked: set[str]) -> None:
    """Register every entry point of the group; a name declared by two distributions is refused
    (pluggy would otherwise keep whichever it met first, and a stale or foreign package could
    silently stand in for a built-in)."""
    declared: dict[str, tuple[installed.EntryPoint, str]] = {}
    seconds = plugin_seconds()
    for ep in installed.entry_points(ENTRY_POINT_GROUP):
        dist = ep.dist_name
        seen = declared.get(ep.name)
        if seen is not None and seen[1] != dist:
            raise PluginConflictError(
                f"plugin name {ep.name!r} (entry-point group {ENTRY_POINT_GROUP!r}) is declared by both "
                f"distribution {seen[1]!r} ({seen[0].value}) and distribution {dist!r} ({ep.value}); "
                "uninstall one of them or rename its entry point"
            )
        declared.setdefault(ep.name, (ep, dist))
    for name, (ep, dist) in declared.items():
        if name in blocked:
            continue
        pm.sources[name] = Source(name, dist, ep.dist_version)
        try:
            # what a plugin prints at import is not odsuite's output (it would break --json)
            # a third-party plugin's import is time-bounded (an endless loop is left out, not a hang)
            with contextlib.redirect_stdout(io.StringIO()), time_bound(seconds if pm.third_party(name) else 0):
                plugin = ep.load()
            pm.register(plugin, name=name)
        # a broken third-party plugin names itself and is left out; sys.exit or a KeyboardInterrupt
        # raised by its own code too (a real Ctrl-C is the command line's own exception)
        except (Exception, SystemExit, KeyboardInterrupt, PluginTimeout) as exc:
            if not pm.third_party(name):
                raise PluginLoadError(f"plugin {name!r} ({ep.value}, distribution {dist!r}) failed to load: "
                                      f"{type(exc).__name__}: {exc}") from exc
            pm.leave_out(name, exc, "to load")


def _contracts() -> dict[str, Contract]:
    """Each registry's contract, from the core module that documents it (imported at its first check)."""
    def of(module: str) -> Contract:  # each contract module's Protocol and optional methods
        return Contract(module=f"odsuite.contracts.{module}")

    return {"daq_backends": of("daq"), "processing_steps": of("steps"), "coordinate_solvers": of("solvers"),
            "models": of("models"), "effects": of("effects"), "renderers": of("renderers"),
            "sensor_types": of("sensor_types"), "rigs": Contract(instance_of="odsuite.domain.rig:Rig"), "importers": of("importers")}


def build_registries(pm: PluginManager) -> Registries:
    """Call every registration hook through pluggy, one plugin at a time, so that each entry knows
    its plugin and distribution, and check each provider against its kind's contract."""
    contracts = _contracts()
    regs = {}
    for f in fields(Registries):
        registry = Registry(f.name.removesuffix("s").replace("_", " "), contracts[f.name])
        hook_name = f"odsuite_register_{f.name}"
        impls = getattr(pm.hook, hook_name).get_hookimpls()
        # pluggy calls implementations last-registered first; keep that order
        for impl in reversed(impls):
            others = [i.plugin for i in impls if i.plugin is not impl.plugin]
            call = pm.subset_hook_caller(hook_name, remove_plugins=others)
            # rig files name sensor kinds: the rigs hook sees the sensor types registered before it
            context = {"sensor_types": regs["sensor_types"]} if f.name == "rigs" else None
            if impl.plugin_name in getattr(pm, "failures", {}):
                continue
            try:
                third = isinstance(pm, PluginManager) and pm.third_party(impl.plugin_name)
                with time_bound(plugin_seconds() if third else 0):
                    call(registry=registry.for_plugin(pm.source(impl.plugin_name), context))
            except (Exception, PluginTimeout) as exc:  # noqa: BLE001 - a third-party hook that raises is left out
                if not (isinstance(pm, PluginManager) and pm.third_party(impl.plugin_name)):
                    raise
                pm.leave_out(impl.plugin_name, exc, f"in its hook {hook_name}")
        registry.apply_overrides()
        regs[f.name] = registry
    return Registries(**regs)


@functools.cache
def default_manager() -> PluginManager:
    """The manager of the installed plugins, built on first use (never at import time)."""
    return make_plugin_manager()


@functools.cache
def _default_registries() -> Registries:
    return build_registries(default_manager())


def registries(pm: PluginManager | None = None) -> Registries:
    """The registries of ``pm``, or of the installed plugins when ``pm`` is None."""
    return _default_registries() if pm is None else build_registries(pm)


def reset_default() -> None:
    """Forget the cached default manager (tests, or after installing a plugin at run time)."""
    default_manager.cache_clear()
    _default_registries.cache_clear()
