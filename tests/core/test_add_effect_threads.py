"""The revision add-effect stores does not depend on how many BLAS threads the process was
started with (OPENBLAS_NUM_THREADS inherited or not): a product's rounding depends on the threads
that share it, and a fit on two threads ended 4e-9 from one on one."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

from hidden_effects import CASES, make_project


def test_add_effect_stores_the_same_revision_on_one_or_two_blas_threads(tmp_path):
    path = make_project(tmp_path / "p.odsp", [("stiffness", CASES["stiffness"])], n_samples=2048,
                        scenarios=("T1", "T5"))
    odsuite = Path(sys.executable).with_name("odsuite")
    stored = []
    for threads in ("1", "2"):
        copy = tmp_path / f"p{threads}.odsp"
        shutil.copy(path, copy)
        env = {**os.environ, "OPENBLAS_NUM_THREADS": threads, "OMP_NUM_THREADS": threads}
        out = subprocess.run([str(odsuite), "add-effect", str(copy), "stiffness", "--json"], env=env,
                             capture_output=True, text=True, check=True).stdout
        doc = json.loads(out)
        stored.append((doc["error"], doc["effects"][0]["values"]))
    assert stored[0] == stored[1]  # to the bit
    assert stored[0][1]["scale_z"] > 1.2  # and the fit found the stiffer mounts
