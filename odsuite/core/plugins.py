"""The plugin manager factory and the registries it fills.

Built-in plugins and a lab's own package are found the same way: entry points in the ``odsuite``
group. ``ODSUITE_DISABLE_PLUGINS`` (comma-separated entry-point names) blocks plugins.
"""

from __future__ import annotations

import functools
import importlib.metadata
import os
from dataclasses import dataclass, fields

import pluggy

from odsuite.core import hookspecs
from odsuite.core.errors import PluginLoadError
from odsuite.core.registry import Registry

ENTRY_POINT_GROUP = "odsuite"
REQUIRED_BUILTINS = ("daq_ni", "daq_sim", "filters", "gencoord_padgaonkar", "models", "renderers")


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
    """A pluggy manager that also remembers each entry-point plugin's distribution version."""

    def __init__(self) -> None:
        super().__init__(ENTRY_POINT_GROUP)
        self.versions: dict[str, str] = {}


def make_plugin_manager(*, load_entry_points: bool = True, extra_plugins: tuple = ()) -> PluginManager:
    """Build a fresh manager: specs, blocked plugins, entry points, checks.

    ``extra_plugins`` registers plugin objects directly (tests, embedding applications).
    """
    pm = PluginManager()
    pm.add_hookspecs(hookspecs)
    blocked = disabled_plugins()
    for name in blocked:
        pm.set_blocked(name)
    if load_entry_points:
        _load_entry_points(pm, blocked)
    for plugin in extra_plugins:
        pm.register(plugin, name=getattr(plugin, "__name__", None))
    try:
        pm.check_pending()
    except pluggy.PluginValidationError as exc:
        name = pm.get_name(exc.plugin) or repr(exc.plugin)
        raise PluginLoadError(f"plugin {name!r}: {exc}") from None
    if load_entry_points:
        missing = [n for n in REQUIRED_BUILTINS if n not in blocked and pm.get_plugin(n) is None]
        if missing:
            raise PluginLoadError(
                f"built-in plugin(s) {', '.join(missing)} not found among the installed entry points; "
                "the installation is stale: re-run `make venv`"
            )
    return pm


def _load_entry_points(pm: PluginManager, blocked: set[str]) -> None:
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        if ep.name in blocked or pm.get_plugin(ep.name) is not None:
            continue
        try:
            plugin = ep.load()
        except Exception as exc:  # a broken third-party plugin must name itself
            raise PluginLoadError(
                f"plugin {ep.name!r} ({ep.value}) failed to load: {type(exc).__name__}: {exc}"
            ) from exc
        pm.register(plugin, name=ep.name)
        pm.versions[ep.name] = ep.dist.version if ep.dist is not None else "?"


def build_registries(pm: PluginManager) -> Registries:
    """Call every registration hook, one plugin at a time, so each entry knows its plugin."""
    regs = {}
    for f in fields(Registries):
        registry = Registry(f.name.removesuffix("s").replace("_", " "))
        hook = getattr(pm.hook, f"odsuite_register_{f.name}")
        # pluggy calls implementations last-registered first; keep that order
        for impl in reversed(hook.get_hookimpls()):
            registry.current_plugin = impl.plugin_name
            impl.function(registry=registry)
        registry.current_plugin = "?"
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
