"""Reading the text files the thesis's LabVIEW programs wrote (``.CTR``, ``.DAT``, ``.COD``)."""

from __future__ import annotations

import stat
from pathlib import Path

from odsuite.domain.errors import ConfigError
from odsuite.domain.memory import free_memory


#: Memory a text file needs per byte while read and parsed (bytes, decoded text, lines, numbers)
TEXT_MEMORY_FACTOR = 8


def check_text_file(path: Path, what: str) -> None:
    """Refuse, before reading, what is no regular file (a pipe would block, a device never ends)
    and a file whose text would not fit in the free memory."""
    try:
        st = path.stat()
    except OSError:
        return  # missing or unreadable: the read names it
    if stat.S_ISDIR(st.st_mode):
        return
    if not stat.S_ISREG(st.st_mode):
        raise ConfigError(f"{path}: not a regular file (a pipe or device), expected a {what} file")
    free = free_memory()
    if free is not None and st.st_size * TEXT_MEMORY_FACTOR > free:
        raise ConfigError(f"{path}: {st.st_size / 2**20:.0f} MiB of text need about "
                          f"{st.st_size * TEXT_MEMORY_FACTOR / 2**20:.0f} MiB to read; only "
                          f"{free / 2**20:.0f} MiB of memory are free")


def read_text(path: str | Path, what: str) -> str:
    """The text of ``path``; a missing file or a directory is a one-line ConfigError naming
    ``what`` the file should hold."""
    path = Path(path)
    check_text_file(path, what)
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


def plain_number(text: str) -> float:
    """A number as measurement software (or a person at a terminal) writes it: ASCII digits
    without digit groups; Python's float() also reads ``1_000`` as 1000 and other scripts' digits
    (``١٢``), which no DAQ writes (ValueError)."""
    if "_" in text or not text.isascii():
        raise ValueError(text)
    return float(text)
