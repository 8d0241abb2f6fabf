"""Registries of named providers, filled by the plugins' registration hooks."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from odsuite.core.errors import ConfigError, PluginConflictError


@dataclass(frozen=True)
class Entry:
    name: str
    provider: Any
    plugin: str


class Registry:
    """Named providers of one kind (processing steps, models, effects, ...).

    ``add`` refuses a name that is already taken unless ``override=True``, naming both plugins, so
    a lab's plugin never silently replaces a built-in.
    """

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._entries: dict[str, Entry] = {}
        self._overrides: list[Entry] = []
        # set by the plugin manager while it calls one plugin's hook, so entries know their plugin
        self.current_plugin = "?"

    def add(self, name: str, provider: Any, *, override: bool = False) -> None:
        """Register ``provider`` as ``name``; ``override=True`` replaces another plugin's entry.

        Overrides are applied after every plugin has registered, so the outcome does not depend on
        the order in which plugins are loaded.
        """
        if not isinstance(name, str) or not name:
            raise ConfigError(f"{self.kind}: provider name must be a non-empty string, got {name!r}")
        entry = Entry(name, provider, self.current_plugin)
        if override:
            self._overrides.append(entry)
            return
        old = self._entries.get(name)
        if old is not None:
            raise PluginConflictError(
                f"{self.kind} {name!r} is registered by both plugin {old.plugin!r} and plugin "
                f"{entry.plugin!r}; pass override=True in one of them to replace the other"
            )
        self._entries[name] = entry

    def apply_overrides(self) -> None:
        for entry in self._overrides:
            self._entries[entry.name] = entry
        self._overrides.clear()

    def get(self, name: str) -> Any:
        try:
            return self._entries[name].provider
        except KeyError:
            known = ", ".join(sorted(self._entries)) or "none"
            raise ConfigError(f"unknown {self.kind} {name!r} (known: {known})") from None

    def entry(self, name: str) -> Entry:
        self.get(name)
        return self._entries[name]

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(sorted(self._entries))

    def __len__(self) -> int:
        return len(self._entries)

    def names(self) -> list[str]:
        return sorted(self._entries)

    def items(self) -> list[tuple[str, Any]]:
        return [(n, self._entries[n].provider) for n in self.names()]

    def by_plugin(self, plugin: str) -> list[str]:
        return sorted(n for n, e in self._entries.items() if e.plugin == plugin)
