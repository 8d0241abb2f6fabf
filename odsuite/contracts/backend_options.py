"""A DAQ backend's own options (``odsuite.contracts.daq.BackendOption``), in a module of their own:
a backend registered with its options (what `odsuite plugins` lists and `odsuite acquire` parses)
imports nothing of the acquisition contract."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class BackendOption:
    """An option a backend takes besides the common settings: the keyword ``record`` receives,
    its type (int, float, str; bool for a flag), its default and help. On the command line it is
    ``flag`` (default ``--name-with-dashes``); a flag gives ``when_given``."""

    name: str
    type: type
    default: Any
    help: str
    flag: str = ""
    when_given: Any = True

    @property
    def cli_flag(self) -> str:
        return self.flag or "--" + self.name.replace("_", "-")
