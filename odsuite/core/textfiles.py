"""Reading the text files the thesis's LabVIEW programs wrote (``.CTR``, ``.DAT``, ``.COD``)."""

from __future__ import annotations

from pathlib import Path

from odsuite.core.errors import ConfigError


def read_text(path: str | Path, what: str) -> str:
    """The text of ``path``; a missing file or a directory is a one-line ConfigError naming
    ``what`` the file should hold."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise ConfigError(f"{path}: {what} file not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, expected a {what} file") from None
    # LabVIEW on Windows wrote ANSI text; latin-1 decodes any byte
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw.decode("latin-1")
