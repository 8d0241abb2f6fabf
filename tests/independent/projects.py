"""odsuite projects holding the independent generator's cases, built through the command line as a
new user would: the case's rig file, one LabVIEW record per hit, processed."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

from odsuite.cli import main

from . import cases


def _run(*args) -> str:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    if code != 0:
        raise RuntimeError(f"odsuite {' '.join(map(str, args))} exited {code}: {err.getvalue().strip()}")
    return out.getvalue()


def case_project(case: cases.Case, folder: Path) -> tuple[Path, dict]:
    """A processed project of ``case`` in ``folder`` and the case's truth document: the thesis rig
    from .DAT + .CTR records on the shipped rig (its .DAT has the thesis's unused channel 1), any
    other rig from LabVIEW records on the case's rig file."""
    thesis = case.rig_name == "thesis"
    files = case.write(folder / "lab", formats=("dat",) if thesis else ("lvm",))
    truth = json.loads(next(f for f in files if f.name.endswith("-truth.json")).read_text())
    project = folder / "p.h5"
    _run("new", project, "--rig", "thesis-dynamometer" if thesis else next(f for f in files if f.name.endswith("-rig.toml")))
    records = sorted(f for f in files if f.suffix == (".DAT" if thesis else ".lvm"))
    for i, (record, hits) in enumerate(zip(records, truth["records"])):
        point = ",".join(f"{1e3 * v!r}" for v in hits[0]["point_m"])  # the CLI takes mm
        direction = ",".join(f"{v!r}" for v in hits[0]["direction"])
        extra = ["--systeminfo", record.with_suffix(".CTR")] if thesis else []
        _run("import-legacy" if thesis else "import", project, record, *extra, "--name", f"r{i}",
             f"--force-point={point}", f"--force-dir={direction}")
    _run("process", project)
    return project, truth
