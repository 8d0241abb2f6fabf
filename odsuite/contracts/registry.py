"""Registries of named providers, filled by the plugins' registration hooks.

Each registry has a :class:`Contract`: what a provider of its kind must have. ``add`` checks it, so
a provider that does not meet it is refused when the plugins are loaded, in one line naming the
plugin, its distribution, the provider and what is missing, never in the middle of a diagnosis.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

from odsuite.domain.errors import ConfigError, PluginConflictError, PluginError


def protocol_members(protocol: type) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The attributes (annotated) and methods (defined, ``__call__`` included) a ``typing.Protocol``
    requires, its protocol bases' included."""
    attributes: dict[str, None] = {}
    methods: dict[str, None] = {}
    for klass in reversed(protocol.__mro__):
        if klass is Protocol or not getattr(klass, "_is_protocol", False):
            continue
        for name in vars(klass).get("__annotations__", {}):
            if not name.startswith("_"):
                attributes[name] = None
        for name, value in vars(klass).items():
            if callable(value) and (name == "__call__" or not name.startswith("_")):
                methods[name] = None
    return tuple(attributes), tuple(methods)


@dataclass(frozen=True)
class Contract:
    """What a provider of one kind must be: the members of a ``typing.Protocol`` (each contract
    module defines one), optional methods that must be callable where given, or a type."""

    protocol: type | None = None
    optional_methods: tuple[str, ...] = ()
    #: a type, or "module:Type" imported at the first check
    instance_of: type | str | None = None
    #: the contract module whose ``PROTOCOL`` and ``OPTIONAL_METHODS`` these are, imported at the
    #: first check (contract modules import numpy and the domain: building registries need not)
    module: str | None = None

    def missing(self, provider: Any) -> list[str]:
        kind = self.instance_of
        if isinstance(kind, str):
            module, _, name = kind.partition(":")
            kind = getattr(importlib.import_module(module), name)
        if kind is not None and not isinstance(provider, kind):
            return [f"to be a {kind.__module__}.{kind.__qualname__}"]
        protocol, optional = self.protocol, self.optional_methods
        if self.module is not None:
            module = importlib.import_module(self.module)
            protocol, optional = module.PROTOCOL, getattr(module, "OPTIONAL_METHODS", ())
        attributes, methods = protocol_members(protocol) if protocol is not None else ((), ())
        out = [f"attribute {a!r}" for a in attributes if not hasattr(provider, a)]
        out += [f"method {m}()" for m in methods if not callable(getattr(provider, m, None))]
        out += [f"its optional {m} to be a method" for m in optional
                if getattr(provider, m, None) is not None and not callable(getattr(provider, m))]
        return out


@dataclass(frozen=True)
class Source:
    """Where an entry comes from: the plugin (entry-point name) and its distribution."""

    plugin: str
    distribution: str = "-"
    version: str = "-"

    def __str__(self) -> str:
        return f"plugin {self.plugin!r} ({self.distribution} {self.version})"


@dataclass(frozen=True)
class Entry:
    """One registered provider: its name, the provider (or what makes it) and where it came from."""

    name: str
    provider: Any
    source: Source
    #: set for a provider added with ``add_deferred``: what makes it, called on first use, and
    #: attributes of it given at registration (read by ``attribute`` without making it)
    load: Callable[[], Any] | None = None
    known: Mapping[str, Any] = field(default_factory=dict, compare=False)  # compare=False: entries stay hashable

    @property
    def plugin(self) -> str:
        return self.source.plugin

    @property
    def distribution(self) -> str:
        return self.source.distribution

    @property
    def version(self) -> str:
        return self.source.version


class Registry:
    """Named providers of one kind (processing steps, models, effects, ...).

    Plugins add through a view that knows their :class:`Source` (``for_plugin``). ``add`` refuses a
    name that is already taken unless ``override=True``, naming both plugins, so a lab's plugin never
    silently replaces a built-in.
    """

    def __init__(self, kind: str, contract: Contract | None = None) -> None:
        self.kind = kind
        self.contract = contract or Contract()
        self._entries: dict[str, Entry] = {}
        self._overrides: list[Entry] = []

    def for_plugin(self, source: Source, context: dict[str, Registry] | None = None) -> PluginRegistry:
        """The view a plugin's registration hook receives."""
        return PluginRegistry(self, source, context)

    def add(self, name: str, provider: Any, *, override: bool = False, source: Source | None = None) -> None:
        """Register ``provider`` as ``name``; ``override=True`` replaces another plugin's entry.

        Overrides are applied after every plugin has registered, so the outcome does not depend on
        the order in which plugins are loaded.
        """
        source = source or Source("?")
        self._check(name, provider, source)
        self._put(Entry(name, provider, source), override)

    def add_deferred(self, name: str, load: Callable[[], Any], *, override: bool = False,
                     source: Source | None = None, **known: Any) -> None:
        """Register as ``name`` the provider ``load()`` returns, made (and checked against the
        contract) on first use: a registration that imports nothing, so every command starts at once.
        ``known``: attributes of the provider that ``attribute`` reads without making it (a DAQ
        backend's ``options`` for `odsuite plugins`); the provider made must have the same."""
        source = source or Source("?")
        self._check(name, None, source)
        self._put(Entry(name, None, source, load, dict(known)), override)

    def _check(self, name: str, provider: Any, source: Source) -> None:
        """Refuse a bad name, or (``provider`` given) a provider that does not meet the contract."""
        if not isinstance(name, str) or not name:
            raise ConfigError(f"{source}: {self.kind} provider name must be a non-empty string, got {name!r}")
        missing = [] if provider is None else self.contract.missing(provider)
        if missing:
            raise PluginError(
                f"{source}: {self.kind} {name!r} ({type(provider).__qualname__}) does not meet the "
                f"{self.kind} contract: it needs {', '.join(missing)}; fix the plugin or start without it "
                f"(ODSUITE_DISABLE_PLUGINS={source.plugin})"
            )

    def _put(self, entry: Entry, override: bool) -> None:
        name = entry.name
        if override:
            self._overrides.append(entry)
            return
        old = self._entries.get(name)
        if old is not None:
            raise PluginConflictError(
                f"{self.kind} {name!r} is registered by both {old.source} and {entry.source}; "
                "pass override=True in one of them to replace the other"
            )
        self._entries[name] = entry

    def apply_overrides(self) -> None:
        for entry in self._overrides:
            self._entries[entry.name] = entry
        self._overrides.clear()

    def get(self, name: str) -> Any:
        return self.entry(name).provider

    def entry(self, name: str) -> Entry:
        try:
            entry = self._entries[name]
        except KeyError:
            known = ", ".join(sorted(self._entries)) or "none"
            raise ConfigError(f"unknown {self.kind} {name!r} (known: {known})") from None
        if entry.load is None:
            return entry
        provider = entry.load()
        self._check(name, provider, entry.source)
        differ = [a for a, value in entry.known.items() if getattr(provider, a, None) != value]
        if differ:
            raise PluginError(f"{entry.source}: {self.kind} {name!r} has other {', '.join(differ)} than it "
                              "registered; fix the plugin")
        self._entries[name] = entry = Entry(name, provider, entry.source)
        return entry

    def attribute(self, name: str, attribute: str) -> Any:
        """``attribute`` of provider ``name``: as registered with ``add_deferred`` (the provider is
        not made), else the provider's own."""
        known = self._entries[name].known if name in self._entries else {}
        return known[attribute] if attribute in known else getattr(self.get(name), attribute)

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(sorted(self._entries))

    def __len__(self) -> int:
        return len(self._entries)

    def names(self) -> list[str]:
        return sorted(self._entries)

    def items(self) -> list[tuple[str, Any]]:
        return [(n, self.get(n)) for n in self.names()]

    def by_plugin(self, plugin: str) -> list[str]:
        return sorted(n for n, e in self._entries.items() if e.plugin == plugin)


class PluginRegistry:
    """One plugin's view of a registry: ``add(name, provider, override=False)``; ``context`` holds
    registries built before this one that its providers may need (rigs: ``sensor_types``)."""

    def __init__(self, registry: Registry, source: Source, context: dict[str, Registry] | None = None) -> None:
        self._registry = registry
        self.source = source
        self.kind = registry.kind
        self._context = context or {}

    def __getattr__(self, name: str) -> Registry:
        try:
            return self.__dict__["_context"][name]
        except KeyError:
            raise AttributeError(f"the {self.kind} registry a plugin receives has no {name!r}") from None

    def add(self, name: str, provider: Any, *, override: bool = False) -> None:
        self._registry.add(name, provider, override=override, source=self.source)

    def add_deferred(self, name: str, load: Callable[[], Any], *, override: bool = False, **known: Any) -> None:
        self._registry.add_deferred(name, load, override=override, source=self.source, **known)
