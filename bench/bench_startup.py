"""Start-up time of the command line, against importing numpy and h5py measured in the same run.

Each command runs as a whole process, as a user starts it: ``odsuite --version``, ``odsuite
plugins`` and ``odsuite info P`` on a small project (the thesis rig, one simulated hammer test of
4096 samples, processed; made first, not timed). The baseline is ``python -c "import numpy,
h5py"``: what any command that reads a project has to import anyway. The commands are run in turns
(baseline, each command, again), after one warm-up round, so that a machine shared with other work
slows all of them alike. Prints min/median/max wall seconds of each and its median over the
baseline's median (target: at most 1.5x), and the median CPU seconds and their ratio, which hold
better than wall times on a loaded machine. numpy's OpenBLAS starts a worker thread at import
that spins about 0.1 s of CPU (the baseline's CPU exceeds its wall time on two cores); ``info``
starts none (``odsuite.cli.app``), so one more row times the baseline with
``OPENBLAS_NUM_THREADS=1`` (no target): against it, ``info``'s ratios count the main thread's
work alone. The interpreter is the one the script runs under and
``odsuite`` the one beside it: run with `.venv/bin/python bench/bench_startup.py [--runs N] [--check]`
(``--check``: exit 1 when a command misses the target).

Measured with ``--runs 7`` three times on two cores shared with other work (load 7.9-12.6),
alternating with the code before ``info`` opened its file once and started no BLAS worker (wall /
CPU ratios): ``--version`` 0.59-0.67x / 0.62-0.67x, ``plugins`` 0.63-0.73x / 0.70-0.71x, ``info
P`` 1.43-1.55x / 1.48-1.55x (before: 1.59-1.73x / 1.50-1.70x); ``info P`` against the baseline with
one BLAS thread 1.73-2.03x wall, 1.59-2.12x CPU. On a quiet machine the worker costs no wall time
and ``info`` was 1.74-1.75x wall (load 0.9-1.3, baseline 0.23-0.24 s): its main thread's own
work, not a wait, is what misses the target (docs/architecture.md, the start-up paragraph).

Since ``info`` prints plain-text tables and imports no rich (four runs at load 10.0-11.1, two of
them alternating with the code before): ``--version`` 0.66-0.67x wall / 0.65-0.74x CPU,
``plugins`` 0.68-0.70x / 0.71-0.78x, ``info P`` 1.14-1.37x / 1.17-1.34x; against the baseline
with one BLAS thread 1.51-1.53x wall, 1.48-1.54x CPU, where the code before gave 1.56-1.79x /
1.52-1.76x in the alternating runs. With hashlib off ``info``'s path as well, CPU seconds with
``OPENBLAS_NUM_THREADS=1`` for both, 15 runs alternating with the code before (load 9.1-9.6,
twice): ``info P`` 1.41x the baseline against 1.69-1.70x before, the ratio that was the quiet
machine's wall ratio (1.74x). No quiet machine was available to repeat the quiet figure.

Quiet (load 0.2-0.9, ``--runs 11``, four runs) after summary commands end without the
interpreter's teardown and with the collector off: ``info P`` 1.31-1.40x wall (1.37-1.42x against
the one-thread baseline), ``--version`` 0.74-0.79x, ``plugins`` 0.87-0.91x.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET = 1.5
ONE_THREAD = "the baseline, OPENBLAS_NUM_THREADS=1"
PYTHON = sys.executable
ODSUITE = str(Path(sys.executable).with_name("odsuite"))
#: as a user's install runs: byte-code caches written and used (an environment that turns them off
#: would make every run compile odsuite's modules from source)
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(cmd: list[str], cwd: Path, env: dict[str, str] = ENV) -> tuple[float, float]:
    """Wall and CPU seconds of one whole process; its failure stops the benchmark with its output."""
    c0, t0 = children_cpu(), time.perf_counter()
    res = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    wall, cpu = time.perf_counter() - t0, children_cpu() - c0
    if res.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({res.returncode}):\n{res.stdout}")
    return wall, cpu


def small_project(tmp: Path) -> Path:
    path = tmp / "small.h5"
    for cmd in ([ODSUITE, "new", str(path), "--rig", "thesis-dynamometer"],
                [ODSUITE, "acquire", str(path), "--name", "T1", "--daq", "sim", "--scenario", "T1", "--seed", "1"],
                [ODSUITE, "process", str(path)]):
        run(cmd, tmp)
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7, help="timed runs of each command (default 7)")
    ap.add_argument("--check", action="store_true", help="exit 1 when a command is slower than the target")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        project = small_project(tmp)
        commands = {
            "python -c 'import numpy, h5py' (baseline)": [PYTHON, "-c", "import numpy, h5py"],
            "odsuite --version": [ODSUITE, "--version"],
            "odsuite plugins": [ODSUITE, "plugins"],
            "odsuite info P": [ODSUITE, "info", str(project)],
            # not a target: the baseline without the BLAS worker, which info does not start either
            ONE_THREAD: [PYTHON, "-c", "import numpy, h5py"],
        }
        envs = {ONE_THREAD: {**ENV, "OPENBLAS_NUM_THREADS": "1"}}
        times: dict[str, list[tuple[float, float]]] = {label: [] for label in commands}
        for label, cmd in commands.items():  # warm-up: byte-code caches and the page cache
            run(cmd, tmp, envs.get(label, ENV))
        for _ in range(args.runs):
            for label, cmd in commands.items():
                times[label].append(run(cmd, tmp, envs.get(label, ENV)))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    base_label = next(iter(commands))
    base = statistics.median(w for w, _ in times[base_label])
    base_cpu = statistics.median(c for _, c in times[base_label])
    print(f"start-up, {args.runs} runs each in turns after a warm-up; load average {load:.2f} over the last "
          f"minute on {os.cpu_count()} cores; {PYTHON}")
    print(f"{'command':44s} {'min s':>7s} {'median s':>9s} {'max s':>7s} {'ratio':>7s} {'CPU s':>7s} {'ratio':>7s}")
    missed = []
    for label, runs in times.items():
        ts = [w for w, _ in runs]
        med, cpu = statistics.median(ts), statistics.median(c for _, c in runs)
        ratio = med / base
        timed = label not in (base_label, ONE_THREAD)
        verdict = f"  (target {TARGET:g}x: {'met' if ratio <= TARGET else 'missed'})" if timed else ""
        if timed and ratio > TARGET:
            missed.append(label)
        print(f"{label:44s} {min(ts):7.2f} {med:9.2f} {max(ts):7.2f} {ratio:6.2f}x {cpu:7.2f} {cpu / base_cpu:6.2f}x"
              f"{verdict}")
    info, one = times["odsuite info P"], times[ONE_THREAD]
    print(f"odsuite info P against the baseline without a BLAS worker: "
          f"{statistics.median(w for w, _ in info) / statistics.median(w for w, _ in one):.2f}x wall, "
          f"{statistics.median(c for _, c in info) / statistics.median(c for _, c in one):.2f}x CPU")
    if args.check and missed:
        sys.exit(1)


if __name__ == "__main__":
    main()
