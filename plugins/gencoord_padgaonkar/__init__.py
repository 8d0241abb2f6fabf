"""odsuite built-in plugin: gencoord_padgaonkar, the coordinate solvers.

``padgaonkar-nine``: the nine-accelerometer solver (thesis Eq. 4.13-4.14) with its rigidity check;
``least-squares``: any layout of at least six single-axis sensors on one body.
"""

from odsuite import hookimpl
from odsuite_plugins.gencoord_padgaonkar.solvers import LeastSquares, PadgaonkarNine, rigidity_check

__all__ = ["LeastSquares", "PadgaonkarNine", "rigidity_check"]


@hookimpl
def odsuite_register_coordinate_solvers(registry):
    registry.add(PadgaonkarNine.name, PadgaonkarNine())
    registry.add(LeastSquares.name, LeastSquares())
