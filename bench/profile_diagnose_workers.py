"""How well diagnose's worker processes share its work: each task's CPU seconds by process and by
stage on two workers, the main process's own stages, and the critical path (the main process's
CPU plus, per stage, the busiest worker's), whose ratio to the total CPU bounds the wall-time
speed-up two workers can give on a quiet machine. CPU seconds hold on a loaded machine, where wall
times do not.

Run with `.venv/bin/python bench/profile_diagnose_workers.py thesis|two-body`.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from collections import defaultdict
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "core"))
sys.path.insert(0, str(ROOT / "bench"))

import bench_diagnose  # noqa: E402
from hidden_effects import CASES, make_project  # noqa: E402

from odsuite.analysis.prediction import prepare  # noqa: E402
from odsuite.diagnosis import diagnose as D  # noqa: E402
from odsuite.store.project import open_project  # noqa: E402

#: the tasks the worker processes run, and the main process's stages, in diagnose's order
TASKS = ("_screen_job", "_fit_job", "_partner_job", "_pair_job")
STAGES = ("_baseline", "_screen", "_fit_best", "_refined", "_fit_pairs", "_ordered", "_conclude")


def _logged(name: str, log: Path, wrap_name: bool) -> None:
    f = getattr(D, name)

    def logged(*a, **k):
        c = time.process_time()
        out = f(*a, **k)
        with open(log, "a") as fh:  # one short line per task: appends from the processes do not mix
            fh.write(json.dumps([os.getpid(), name, time.process_time() - c]) + "\n")
        return out

    if wrap_name:  # the pool sends a task by its module and name: the wrapper takes its place
        logged.__module__, logged.__qualname__, logged.__name__ = f.__module__, f.__qualname__, f.__name__
    setattr(D, name, logged)


def main() -> None:
    which = sys.argv[1] if len(sys.argv) > 1 else "thesis"
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "tasks.log"
        for name in TASKS:
            if hasattr(D, name):  # (an older diagnose ran some in the main process)
                _logged(name, log, True)
        for name in STAGES:
            _logged(name, log, False)
        path = (make_project(Path(tmp) / "thesis.odsp", [("stiffness", CASES["stiffness"])]) if which == "thesis"
                else bench_diagnose.two_body_project(Path(tmp) / "two-body.odsp"))
        with open_project(path) as p:
            exps = prepare(p)
            log.write_text("")
            c0, t0 = bench_diagnose.cpu_seconds(), time.perf_counter()
            d = D.diagnose(p, prepared=[replace(e, _cache=None) for e in exps], workers=2)
            wall, cpu = time.perf_counter() - t0, bench_diagnose.cpu_seconds() - c0
        rows = [json.loads(line) for line in log.read_text().splitlines()]
    me = os.getpid()
    main_cpu = {name: sum(r[2] for r in rows if r[1] == name and r[0] == me) for name in STAGES}
    per: dict[str, dict[int, float]] = defaultdict(lambda: defaultdict(float))
    for pid, name, c in rows:
        if name in TASKS and pid != me:  # a task the main process ran is in its stage's CPU
            per[name][pid] += c
    total = sum(main_cpu.values()) + sum(sum(v.values()) for v in per.values())
    critical = sum(main_cpu.values()) + sum(max(v.values()) for v in per.values())
    print(f"{which}: diagnose on two workers {wall:.1f} s wall, {cpu:.1f} s CPU (load "
          f"{os.getloadavg()[0]:.1f}), {d.evaluations} evaluations, verdict {d.verdict!r}")
    print("  main process, CPU s: " + ", ".join(f"{n.lstrip('_')} {c:.2f}" for n, c in main_cpu.items()))
    for name, v in per.items():
        print(f"  {name.strip('_')} on the workers, CPU s: " + " / ".join(f"{c:.2f}" for c in v.values()))
    print(f"  tasks and stages {total:.1f} s CPU, critical path {critical:.1f} s CPU: two workers at most "
          f"{total / critical:.2f}x faster in wall than one")


if __name__ == "__main__":
    main()
