"""User data made printable on one line: every command's output and the console print through it."""

from __future__ import annotations


def shown(value: object) -> str:
    """User data as one printable line: control characters (newlines, ANSI escapes) and bytes that
    were not UTF-8 (surrogate escapes of argv and file names) written as Python escapes."""
    text = str(value)
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else
                   f"\\x{ord(c) - 0xDC00:02x}" if 0xDC80 <= ord(c) <= 0xDCFF else repr(c)[1:-1]
                   for c in text)
