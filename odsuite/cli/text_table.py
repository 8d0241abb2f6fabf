"""Tables as plain aligned text, for commands that print a summary without rich (``info``): a
title line, a header underlined with dashes, one row per line. When the table is wider than the
console, the widest column wraps: a header at its spaces, a cell after its commas only, so that a
name, or a number and its unit, is never split; a column of prose (a parameter's meaning) at its
spaces."""

from __future__ import annotations

from odsuite.cli.app import console_width
from odsuite.cli.printable import shown


def _wrap(text: str, width: int, sep: str) -> list[str]:
    """``text`` in lines of at most ``width`` characters (where its pieces allow), broken at ``sep``."""
    lines: list[str] = []
    pieces = text.split(sep)
    for n, piece in enumerate(pieces):
        mark = len(sep.rstrip()) if n < len(pieces) - 1 else 0  # room for the comma, were the line to end here
        if lines and len(lines[-1]) + len(sep) + len(piece) + mark <= width:
            lines[-1] += sep + piece
        elif lines:
            lines[-1] += sep.rstrip()  # the comma stays at the end of the line it closes
            lines.append(piece)
        else:
            lines.append(piece)
    return lines


def text_table(title: str, columns: list[str], rows: list[list[str]], width: int | None = None,
               prose: tuple[str, ...] = ()) -> str:
    """The table as lines of text ending in a newline; every cell goes through ``shown``. The
    columns named in ``prose`` wrap their cells at spaces, the others after commas only."""
    header = [shown(c) for c in columns]
    body = [[shown(c) for c in row] for row in rows]
    width = console_width() if width is None else width
    seps = [" " if c in prose else ", " for c in columns]

    def wrapped(i: int, w: int) -> list[list[str]]:  # column i's header and cells at width w
        return [_wrap(header[i], w, " "), *(_wrap(row[i], w, seps[i]) for row in body)]

    def used(i: int, w: int) -> int:
        return max(len(line) for cell in wrapped(i, w) for line in cell)

    n = len(columns)
    widths = [used(i, 10**6) for i in range(n)]
    floor = [used(i, 0) for i in range(n)]  # the longest piece that cannot break
    while sum(widths) + 2 * (n - 1) > width:
        narrowable = [i for i in range(n) if widths[i] > floor[i]]
        if not narrowable:
            break  # as narrow as the pieces allow: the terminal wraps what is left
        i = max(narrowable, key=lambda k: widths[k])
        widths[i] = used(i, widths[i] - 1)
    out = [shown(title)]
    for k, cells in enumerate([[wrapped(i, widths[i])[0] for i in range(n)],
                               *([_wrap(row[i], widths[i], seps[i]) for i in range(n)] for row in body)]):
        for j in range(max(len(c) for c in cells)):
            out.append("  ".join((c[j] if j < len(c) else "").ljust(w) for c, w in zip(cells, widths)).rstrip())
        if k == 0:
            out.append("  ".join("-" * w for w in widths))
    return "\n".join(out) + "\n"
