"""What a Ctrl-C leaves, in a command's own words: a plugin's command writes files the command
line's record of stored units does not see (the demo's folder), and says so here; the command
line prints that line in place of its own."""

from __future__ import annotations

_line: str | None = None


def say_on_interrupt(line: str | None) -> None:
    """The one line a Ctrl-C from now on prints ('interrupted: ...'); None: the command line's own."""
    global _line
    _line = line


def said_on_interrupt() -> str | None:
    """The line a command gave say_on_interrupt, if any."""
    return _line
