"""The ``odsuite`` command line: every command is a thin call into the Python API.

Only ``OdsuiteError`` is caught: it is printed as one line and the exit code is 1. Any other
exception is a bug and keeps its traceback.
"""

from __future__ import annotations

import sys

import typer
from rich.console import Console
from rich.table import Table

from odsuite.core.errors import OdsuiteError

app = typer.Typer(
    name="odsuite",
    help="Experimental vibration analysis: impact tests, rigid-plate motion, model comparison.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
console = Console()
err_console = Console(stderr=True)


@app.callback()
def _root() -> None:
    """Experimental vibration analysis: impact tests, rigid-plate motion, model comparison."""


@app.command("plugins")
def plugins_cmd() -> None:
    """List registered plugins, their versions and what each registers."""
    from dataclasses import fields

    from odsuite.core.plugins import Registries, default_manager, registries

    pm = default_manager()
    regs = registries()
    table = Table(title="odsuite plugins")
    table.add_column("plugin")
    table.add_column("version")
    table.add_column("registers")
    for name, _plugin in sorted(pm.list_name_plugin()):
        provided = []
        for f in fields(Registries):
            names = getattr(regs, f.name).by_plugin(name)
            if names:
                provided.append(f"{f.name.replace('_', ' ')}: {', '.join(names)}")
        table.add_row(name, pm.versions.get(name, "-"), "\n".join(provided) or "-")
    console.print(table)


def _register_plugin_commands() -> None:
    from odsuite.core.plugins import default_manager

    default_manager().hook.odsuite_register_commands(app=app)


def main(argv: list[str] | None = None) -> int:
    try:
        _register_plugin_commands()
        app(args=argv, standalone_mode=False)
    except OdsuiteError as exc:
        err_console.print(f"error: {exc}", style="bold red", highlight=False, soft_wrap=True)
        return 1
    except typer.Exit as exc:
        return exc.exit_code
    except typer.Abort:
        err_console.print("aborted")
        return 1
    except typer.TyperException as exc:
        # usage errors (unknown option, missing argument) carry their own exit code
        exc.show()
        return exc.exit_code
    return 0


if __name__ == "__main__":
    sys.exit(main())
