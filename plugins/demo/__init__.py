"""odsuite built-in plugin: demo, ``odsuite demo``: the whole story on the simulated rig (the
``sim`` DAQ backend, taken from the registry), no hardware."""

from pathlib import Path

from odsuite.api import hookimpl


@hookimpl
def odsuite_register_commands(app):
    import typer

    @app.command("demo")
    def demo_cmd(
        out: Path = typer.Option(Path("demo-output"), "--out",
                                 help="Directory for the project, report, movie and figures."),
    ) -> None:
        """The whole story on the simulated rig, no hardware: record, process, find two hidden effects."""
        from rich.console import Console

        from .story import run_demo

        run_demo(out, console=Console())
