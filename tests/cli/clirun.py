"""The command line run in the test's own process, its output read from ``capsys``: one helper for
the tests under tests/cli (tests/conftest.py has pytest rewrite its asserts, as in a test module)."""

from __future__ import annotations

from odsuite.cli import main


def run(capsys, *args) -> tuple[int, str, str]:
    """``odsuite ARGS`` (each argument passed through str): its exit code, stdout and stderr."""
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def run_ok(capsys, *args) -> str:
    """As :func:`run` for a command that must succeed (its stderr the failure's message): stdout."""
    code, out, err = run(capsys, *args)
    assert code == 0, err
    return out
