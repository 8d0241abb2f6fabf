"""Output-only modal analysis on the Palisaden building record (6 channels, 100 Hz, 90 min):
odsuite (SSI-cov with its settings from the record, segment standard errors and the EFDD
cross-check) against pyOMA2's SSI-cov as its documentation runs it on the same record (high-pass
0.1 Hz, decimation by 5, 30 block rows, orders to 30, modes picked at order 20), timed alternately
in the same run (median of ``--repeats``). Prints both times and the ratio odsuite / pyOMA2 (goal
<= 1.0), and each tool's frequencies.

pyOMA2 is a checking tool, not a dependency: it is imported if installed, or run in the Python
given by ``--pyoma2-python`` (a separate environment). Without it the bench says so and prints
odsuite's time against a numpy baseline measured in the same run: the correlations of the same
record at the same lags by direct sums (work any SSI-cov needs, without the FFT).

Run: .venv/bin/python bench/bench_oma.py [RECORD.npy] [--pyoma2-python PY] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

DEFAULT = Path(__file__).resolve().parents[1] / "tests" / "data" / "real" / "palisaden_building" / "Palisaden_dataset.npy"
FS = 100.0

PYOMA2 = r"""
import json, logging, sys, time, numpy as np
logging.disable(logging.WARNING)
from pyoma2.algorithms import SSI
from pyoma2.setup import SingleSetup
data = np.load(sys.argv[1])
t = time.perf_counter()
ss = SingleSetup(data, fs=float(sys.argv[2]))
ss.filter_data(Wn=0.1, order=8, btype="highpass")
ss.decimate_data(q=5)
ss.add_algorithms(SSI(name="SSIcov", method="cov", br=30, ordmax=30, calc_unc=False))
ss.run_by_name("SSIcov")
ss.mpe("SSIcov", sel_freq=[1.88, 2.42, 2.68], order_in=20)
dt = time.perf_counter() - t
print(json.dumps({"seconds": dt, "fn": np.asarray(ss["SSIcov"].result.Fn).tolist()}))
"""


def run_odsuite(y: np.ndarray) -> tuple[float, list[float]]:
    from odsuite.analysis.oma import identify_output_only

    t = time.perf_counter()
    res = identify_output_only(y, FS, max_order=50)
    return time.perf_counter() - t, res.frequency_hz.tolist()


def run_pyoma2(path: Path, python: str | None) -> tuple[float, list[float]] | None:
    if python is None:
        try:
            import pyoma2  # noqa: F401
        except ImportError:
            return None
        python = sys.executable
    out = subprocess.run([python, "-c", PYOMA2, str(path), str(FS)], capture_output=True, text=True)
    if out.returncode:
        raise SystemExit(f"pyOMA2 run failed: {out.stderr.strip().splitlines()[-1]}")
    doc = json.loads(out.stdout.strip().splitlines()[-1])
    return doc["seconds"], doc["fn"]


def numpy_baseline(y: np.ndarray, lags: int) -> float:
    t = time.perf_counter()
    n = y.shape[0]
    for k in range(lags):
        y[k:].T @ y[: n - k]
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("record", nargs="?", default=str(DEFAULT))
    ap.add_argument("--pyoma2-python", default=None, help="a Python with pyOMA2 installed")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    path = Path(args.record)
    y = np.load(path)
    ours, theirs, base = [], [], []
    for _ in range(args.repeats):
        t, f_ours = run_odsuite(y)
        ours.append(t)
        got = run_pyoma2(path, args.pyoma2_python)
        if got is not None:
            theirs.append(got[0])
            f_theirs = got[1]
        else:
            base.append(numpy_baseline(y, 90))
    a = statistics.median(ours)
    print(f"record {path.name}: {y.shape[0]} samples x {y.shape[1]} channels at {FS:g} Hz")
    print(f"odsuite output-only (SSI-cov + segments + EFDD): {a:.2f} s; modes {np.round(f_ours, 4).tolist()} Hz")
    if theirs:
        b = statistics.median(theirs)
        print(f"pyOMA2 SSI-cov (its example's settings): {b:.2f} s; modes {np.round(f_theirs, 4).tolist()} Hz")
        print(f"ratio odsuite / pyOMA2: {a / b:.2f} (goal <= 1.0; medians of {args.repeats} alternating runs)")
    else:
        b = statistics.median(base)
        print("pyOMA2 is not installed here (pip install pyoma-2 in a separate environment, then "
              "--pyoma2-python PATH); numpy baseline instead")
        print(f"numpy direct-sum correlations at 90 lags: {b:.2f} s; ratio odsuite / baseline: {a / b:.2f}")


if __name__ == "__main__":
    main()
