"""Start-up time of the command line, against importing numpy and h5py measured in the same run.

Each command runs as a whole process, as a user starts it: ``odsuite --version``, ``odsuite
plugins`` and ``odsuite info P`` on a small project (the thesis rig, one simulated hammer test of
4096 samples, processed; made first, not timed). The baseline is ``python -c "import numpy,
h5py"``: what any command that reads a project has to import anyway. The commands are run in turns
(baseline, each command, again), after one warm-up round, so that a machine shared with other work
slows all of them alike. Prints min/median/max wall seconds of each and its median over the
baseline's median (target: at most 1.5x), and the median CPU seconds and their ratio, which hold
better than wall times on a loaded machine. The interpreter is the one the script runs under and
``odsuite`` the one beside it: run with `.venv/bin/python bench/bench_startup.py [--runs N] [--check]`
(``--check``: exit 1 when a command misses the target).
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
PYTHON = sys.executable
ODSUITE = str(Path(sys.executable).with_name("odsuite"))
#: as a user's install runs: byte-code caches written and used (an environment that turns them off
#: would make every run compile odsuite's modules from source)
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(cmd: list[str], cwd: Path) -> tuple[float, float]:
    """Wall and CPU seconds of one whole process; its failure stops the benchmark with its output."""
    c0, t0 = children_cpu(), time.perf_counter()
    res = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=ENV)
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
        }
        times: dict[str, list[tuple[float, float]]] = {label: [] for label in commands}
        for label, cmd in commands.items():  # warm-up: byte-code caches and the page cache
            run(cmd, tmp)
        for _ in range(args.runs):
            for label, cmd in commands.items():
                times[label].append(run(cmd, tmp))
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
        verdict = "" if label == base_label else f"  (target {TARGET:g}x: {'met' if ratio <= TARGET else 'missed'})"
        if label != base_label and ratio > TARGET:
            missed.append(label)
        print(f"{label:44s} {min(ts):7.2f} {med:9.2f} {max(ts):7.2f} {ratio:6.2f}x {cpu:7.2f} {cpu / base_cpu:6.2f}x"
              f"{verdict}")
    if args.check and missed:
        sys.exit(1)


if __name__ == "__main__":
    main()
