"""odsuite built-in plugin: gencoord_padgaonkar, the coordinate solvers.

``padgaonkar-nine``: the nine-accelerometer solver (thesis Eq. 4.13-4.14) with its rigidity check;
``least-squares``: any layout of at least six single-axis sensors on one body.
"""

from odsuite.api import hookimpl

__all__ = ["LeastSquares", "PadgaonkarNine", "rigidity_check"]


def __getattr__(name: str):
    """The solvers module's names, imported on first use (`odsuite --help` starts fast)."""
    if name in __all__:
        from odsuite_plugins.gencoord_padgaonkar import solvers

        return getattr(solvers, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


@hookimpl
def odsuite_register_coordinate_solvers(registry):
    from odsuite_plugins.gencoord_padgaonkar.solvers import LeastSquares, PadgaonkarNine

    registry.add(PadgaonkarNine.name, PadgaonkarNine())
    registry.add(LeastSquares.name, LeastSquares())
