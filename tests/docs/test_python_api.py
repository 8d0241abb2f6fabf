"""docs/python-api.md is executed: its worked example must keep running and printing what it says."""

from __future__ import annotations

import doctest

from tests.conftest import REPO


def test_python_api_page_runs(tmp_path):
    result = doctest.testfile(str(REPO / "docs" / "python-api.md"), module_relative=False,
                              globs={"workdir": tmp_path}, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 10 and result.failed == 0, result
