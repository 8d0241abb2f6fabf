"""Ctrl-C through real ``odsuite`` subprocesses (see interrupts.py): exit 130, one truthful line,
no temporary copy or worker process left, the project changed only by what the line says."""

from __future__ import annotations

import pytest

from tests.reliability.interrupts import COMMANDS, run_interrupts, summary

pytestmark = pytest.mark.filterwarnings("ignore::odsuite.core.errors.OdsuiteWarning")


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
