"""How units and errors are printed for people: one style in the pictures, the report and the
command line.

Units are stored as ASCII (``m/s^2``, ``(m/s^2)/N``: what readers and writers of files exchange);
what a user reads has superscripts (``m/s²``), and what a user writes is read back to ASCII. A model error (pooled NRMSE) is printed with four
decimals wherever it appears, so the text and the figures beside it show the same number.
"""

from __future__ import annotations

import re

_SUPERSCRIPTS = {"^2": "²", "^3": "³", "^-1": "⁻¹", "^-2": "⁻²"}


def unit_text(unit: str) -> str:
    """A stored unit as printed: ``m/s^2`` -> ``m/s²``, ``V/(m/s^2)`` -> ``V/(m/s²)``."""
    for ascii_, shown in sorted(_SUPERSCRIPTS.items(), key=lambda kv: -len(kv[0])):
        unit = unit.replace(ascii_, shown)
    return unit


def rms_label(what: str, units) -> str:
    """An axis label for the rms over outputs: ``rms |H| of the outputs [(m/s²)/N]``; outputs in
    different units share no unit, and the label names theirs."""
    shown = sorted({unit_text(u) for u in units})
    return f"rms {what} [{shown[0]}]" if len(shown) == 1 else f"rms {what} [units differ: {', '.join(shown)}]"


def ascii_unit(label: str) -> str:
    """A unit as people write it, in the stored ASCII spelling (``unit_text`` read back): ``m/s²``,
    ``m/s**2`` and ``m/s2`` -> ``m/s^2``; spaces around it dropped, anything else kept as written."""
    text = label.strip().replace("**", "^")
    for ascii_, shown in sorted(_SUPERSCRIPTS.items(), key=lambda kv: -len(kv[1])):
        text = text.replace(shown, ascii_)
    return re.sub(r"(?<=[A-Za-z])(\d)", r"^\1", text)  # a power written right after its unit: s2


def per_unit(numerator: str, unit: str) -> str:
    """``numerator`` per ``unit`` as printed, the unit in parentheses when it is itself a ratio:
    ``per_unit("V", "m/s^2")`` -> ``V/(m/s²)``."""
    shown = unit_text(unit)
    return f"{numerator}/({shown})" if "/" in shown or " " in shown else f"{numerator}/{shown}"


def fixed(value: float, decimals: int) -> str:
    """``value`` with ``decimals`` decimals, a value that rounds to zero without a sign: an
    undamped mode's damping ratio is 0.0000, not -0.0000."""
    text = f"{value:.{decimals}f}"
    return text[1:] if text.startswith("-") and not text.strip("-0.") else text


def error_text(error: float) -> str:
    """A model error (NRMSE) as printed everywhere: four decimals (0.0134, never 0.013)."""
    return f"{error:.4f}"
