"""Ctrl-C through real ``odsuite`` subprocesses (see interrupts.py): exit 130, one truthful line,
no temporary copy or worker process left, the project changed only by what the line says."""

from __future__ import annotations

import pytest

from tests.reliability.interrupts import COMMANDS, run_interrupts, summary

pytestmark = pytest.mark.filterwarnings("ignore::odsuite.domain.errors.OdsuiteWarning")


def test_one_interrupt_per_command(tmp_path):
    outcomes = run_interrupts(tmp_path, len(COMMANDS), seed_value=3)
    assert [o.problems for o in outcomes] == [[]] * len(COMMANDS), summary(outcomes)
    assert any(o.code == 130 for o in outcomes), summary(outcomes)


@pytest.mark.slow
def test_thirty_two_interrupts(tmp_path):
    outcomes = run_interrupts(tmp_path, 32, seed_value=19)
    assert [o.problems for o in outcomes] == [[]] * 32, summary(outcomes)
    # most runs are really interrupted, not finished before the signal
    assert sum(o.code == 130 for o in outcomes) >= 24, summary(outcomes)


def test_a_held_interrupt_reaches_the_handler_when_the_block_ends():
    """interrupts_held: a SIGINT inside the block runs the handler in place only after the block
    (a VTK call is never left by an exception), once; nothing held, nothing raised."""
    import signal

    from odsuite.store.storage import interrupts_held

    calls = []

    def handler(signum, frame):
        calls.append("handler")
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGINT, handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            with interrupts_held():
                signal.raise_signal(signal.SIGINT)
                calls.append("rest of the block")
        assert calls == ["rest of the block", "handler"]
        with interrupts_held():
            calls.append("quiet block")
        assert calls[-1] == "quiet block" and signal.getsignal(signal.SIGINT) is handler
    finally:
        signal.signal(signal.SIGINT, previous)


def test_the_interrupt_line_imports_nothing_heavy():
    """A Ctrl-C that cuts numpy's import short makes any later import of numpy fail ("cannot load
    module more than once"): the line printed then must not import storage, h5py or numpy."""
    import subprocess
    import sys

    code = ("import sys; from odsuite import cli; print(cli._ledger.line()); "
            "print(sorted(m for m in ('numpy', 'h5py', 'odsuite.store.storage') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.splitlines() == ["interrupted: nothing stored", "[]"]
