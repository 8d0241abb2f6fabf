"""The ``odsuite`` command line: one module per command group, all registered on one typer app
(``odsuite.cli.app``, which also holds what every command shares: the consoles, the Ctrl-C ledger,
``main``). Each command is a thin call into the engines."""

from odsuite.cli.app import _ledger, app, console, err_console, main, shown
from odsuite.cli import (file_commands, loop_commands, modal_commands, ops_commands,  # noqa: F401 (registers)
                         project_commands, record_commands, render_commands)

__all__ = ["app", "console", "err_console", "main", "shown", "_ledger"]
