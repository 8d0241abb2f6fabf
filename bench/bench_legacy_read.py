"""Speed of the legacy .DAT reader and writer against baselines measured in the same run.

Reading: odsuite's ``read_dat`` (numpy's C text parser plus checks) against a plain Python
split-and-float parser and ``numpy.genfromtxt``. Writing: ``write_dat`` (shortest repr, exact)
against ``numpy.savetxt`` with ``%.17g`` (exact, longer text). Run with
`.venv/bin/python bench/bench_legacy_read.py [N_SAMPLES]` (default 200 000 samples x 11 channels).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from odsuite_plugins.importers.legacy import read_dat, write_dat


def best_of(fn, repeat: int = 3) -> float:
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def python_parser(path: Path) -> np.ndarray:
    with path.open() as f:
        return np.array([[float(c) for c in line.split()] for line in f if line.strip()])


def main(n: int) -> None:
    data = np.random.default_rng(0).normal(scale=0.1, size=(n, 11))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.DAT"
        t_write = best_of(lambda: write_dat(path, data))
        t_savetxt = best_of(lambda: np.savetxt(Path(tmp) / "s.DAT", data, fmt="%.17g", delimiter="\t"))
        assert np.array_equal(read_dat(path, 11).data, data)
        t_read = best_of(lambda: read_dat(path, 11, 20000.0))
        t_python = best_of(lambda: python_parser(path))
        t_genfromtxt = best_of(lambda: np.genfromtxt(path), repeat=1)
        size = path.stat().st_size / 1e6
    print(f"{n} samples x 11 channels, {size:.1f} MB")
    print(f"read_dat       {t_read:8.3f} s")
    print(f"python split   {t_python:8.3f} s   read_dat is {t_python / t_read:5.2f}x faster")
    print(f"genfromtxt     {t_genfromtxt:8.3f} s   read_dat is {t_genfromtxt / t_read:5.2f}x faster")
    print(f"write_dat      {t_write:8.3f} s")
    print(f"savetxt %.17g  {t_savetxt:8.3f} s   write_dat takes {t_write / t_savetxt:5.2f}x its time")


if __name__ == "__main__":
    main(int(float(sys.argv[1])) if len(sys.argv) > 1 else 200_000)
