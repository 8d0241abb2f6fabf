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


#: each solver's ``name``, so that registering imports neither
SOLVERS = {"padgaonkar-nine": "PadgaonkarNine", "least-squares": "LeastSquares"}


def _solver(name: str):
    from odsuite_plugins.gencoord_padgaonkar import solvers

    return getattr(solvers, SOLVERS[name])()


@hookimpl
def odsuite_register_coordinate_solvers(registry):
    for name in SOLVERS:  # imported on first use: every command starts at once
        registry.add_deferred(name, lambda name=name: _solver(name))
