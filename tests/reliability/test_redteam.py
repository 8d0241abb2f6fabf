"""The red team (see redteam.py): no traceback, no hang, one error line, no file changed by a
failing command, no link or user file touched, no sidecar left. Every 12th try in the default run;
all of them (821) behind the slow marker."""

from __future__ import annotations

import pytest

from tests.reliability.redteam import run_redteam, summary

pytestmark = pytest.mark.filterwarnings("ignore::odsuite.domain.errors.OdsuiteWarning")


def test_redteam_subset(tmp_path):
    results = run_redteam(tmp_path, every=12)
    assert len(results) >= 50
    assert [r.problems for r in results] == [[]] * len(results), summary(results)
    assert sum(r.code == 1 for r in results) >= len(results) // 2  # most tries are refused, not ignored


@pytest.mark.slow
def test_redteam_full(tmp_path):
    results = run_redteam(tmp_path)
    assert len(results) >= 400
    assert [r.problems for r in results] == [[]] * len(results), summary(results)
