"""Speed of ``odsuite catalog``: 50 projects (simulated rig, 2 experiments x 2048 samples each).

Prints the time of the first build, of a refresh with nothing changed, and of a refresh after two
projects were processed (only those two are read again), against the first build. Run with
`.venv/bin/python bench/bench_catalog.py [N_PROJECTS]`.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "core"))

from hidden_effects import make_project  # noqa: E402

from odsuite.ops.catalog import build_catalog  # noqa: E402
from odsuite.processing.pipeline import process_experiment  # noqa: E402
from odsuite.store.project import open_project  # noqa: E402

DISTINCT = 5  # simulated projects, each copied to make up the count


def main(n_projects: int = 50) -> None:
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        made = [make_project(tmp / f"made{i}.h5", [("stiffness", {"scale_z": 1.0 + 0.1 * i})], seed=50 + i,
                             n_samples=2048, scenarios=("T1", "T5")) for i in range(DISTINCT)]
        folder = tmp / "campaign"
        for k in range(n_projects):
            sub = folder / f"rig{k % 7}"
            sub.mkdir(parents=True, exist_ok=True)
            shutil.copy(made[k % DISTINCT], sub / f"project{k:03d}.h5")
        t0 = time.perf_counter()
        first = build_catalog(folder)
        t_first = time.perf_counter() - t0
        t0 = time.perf_counter()
        same = build_catalog(folder)
        t_same = time.perf_counter() - t0
        changed = sorted(folder.rglob("project*.h5"))[:2]
        for path in changed:
            with open_project(path, "a") as p:
                process_experiment(p, "T1", workers=1)
        t0 = time.perf_counter()
        after = build_catalog(folder)
        t_after = time.perf_counter() - t0
    print(f"catalog of {n_projects} projects (2 experiments x 2048 samples each)")
    print(f"first build: {t_first:.2f} s ({len(first.indexed)} read)")
    print(f"refresh, nothing changed: {t_same:.3f} s ({len(same.unchanged)} unchanged, {len(same.indexed)} read) "
          f"= {t_first / t_same:.0f}x faster")
    print(f"refresh after 2 projects were processed: {t_after:.2f} s ({len(after.indexed)} read: "
          f"{', '.join(after.indexed)}) = {t_first / t_after:.0f}x faster")
    if len(after.indexed) != 2 or same.indexed:
        sys.exit(1)


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:2]))
