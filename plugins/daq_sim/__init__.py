"""odsuite built-in plugin: daq_sim, the simulated thesis rig (the embedded default acquisition)."""

from pathlib import Path

from odsuite.api import hookimpl


@hookimpl
def odsuite_register_daq_backends(registry):
    from odsuite_plugins.daq_sim.simulator import SimulatedRig

    registry.add("sim", SimulatedRig())


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

        from .demo import run_demo

        run_demo(out, console=Console())
