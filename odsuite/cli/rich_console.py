"""The console rich draws with, made on a command's first use of ``app.console`` (rich is a
tenth of ``import numpy, h5py``; a command printing plain text never imports it)."""

from __future__ import annotations

from rich.console import Console
from rich.text import Text

from odsuite.cli.printable import shown


class DataConsole(Console):
    """A console that never reads markup and prints every string through ``shown`` (tables,
    progress descriptions and messages alike); styles come from ``Text`` objects only."""

    def __init__(self, **kwargs) -> None:
        # no emoji codes either: a name ":x:" prints as itself (and rich's table of them is not imported)
        super().__init__(markup=False, emoji=False, **kwargs)

    def render_str(self, text: str, **kwargs) -> Text:
        return super().render_str(shown(text), **{**kwargs, "markup": False, "emoji": False})
