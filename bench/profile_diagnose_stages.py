"""Where ``diagnose`` spends its model evaluations and CPU, by stage, on bench_diagnose's rigs (one
worker, in this process): screening every candidate, the full fits, the pairs (the partner search,
partners fitted alone, joint fits), validation, the baseline and the verdict; then by stage and
effect (screen, fit, validate). CPU in evaluations' worth against one evaluation measured in the
same run, as bench_diagnose. Stages nest (fit runs inside _fit_best and _fit_pairs).

Run with `.venv/bin/python bench/profile_diagnose_stages.py thesis|two-body [--top 30]`.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_diagnose as bench  # noqa: E402  (puts tests/core on the path)
from hidden_effects import CASES, make_project  # noqa: E402

import odsuite.diagnosis.diagnose as diag  # noqa: E402
import odsuite.diagnosis.fitting as fitting  # noqa: E402
from odsuite.analysis.prediction import prepare  # noqa: E402
from odsuite.store.project import open_project  # noqa: E402

STAGES = ("_baseline", "_screen", "_fit_best", "_refined", "_fit_pairs", "_partner", "_single", "_conclude",
          "_ordered")
PER_EFFECT = ("screen", "fit", "validate")


class Tally:
    """Evaluations and CPU seconds by stage, and by (function, effect, calling stage)."""

    def __init__(self) -> None:
        self.evaluations = 0
        self.stages: dict[str, list[float]] = {}
        self.effects: dict[tuple[str, str, str], list[float]] = {}
        self.stack: list[str] = []

    def count_predictions(self) -> None:
        original = fitting.Problem.predictions

        def predictions(problem, u, exps=None, keep=True):
            before = problem.evaluations
            out = original(problem, u, exps, keep)
            self.evaluations += problem.evaluations - before
            return out

        fitting.Problem.predictions = predictions

    def wrap(self, name: str, per_effect: bool = False) -> None:
        original = getattr(diag, name)

        def wrapped(*args, **kwargs):
            c0, n0 = time.process_time(), self.evaluations
            caller = self.stack[-1] if self.stack else "diagnose"
            self.stack.append(name)
            try:
                return original(*args, **kwargs)
            finally:
                self.stack.pop()
                key = (name, args[0].effect.name, caller) if per_effect else None
                for table, k in ((self.stages, name), (self.effects, key)):
                    if k is not None:
                        row = table.setdefault(k, [0.0, 0, 0])
                        row[0] += time.process_time() - c0
                        row[1] += self.evaluations - n0
                        row[2] += 1

        setattr(diag, name, wrapped)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rig", choices=["thesis", "two-body"])
    ap.add_argument("--top", type=int, default=30, help="rows of the per-effect table (default 30)")
    args = ap.parse_args()
    tally = Tally()
    tally.count_predictions()
    for name in STAGES:
        tally.wrap(name)
    for name in PER_EFFECT:
        tally.wrap(name, per_effect=True)
    with tempfile.TemporaryDirectory() as tmp:
        if args.rig == "thesis":
            path = make_project(Path(tmp) / "thesis.odsp", [("stiffness", CASES["stiffness"])])
        else:
            path = bench.two_body_project(Path(tmp) / "two-body.odsp")
        with open_project(path) as p:
            exps = prepare(p)
            _, one = bench.one_evaluation(p, exps)
            c0 = time.process_time()
            d = diag.diagnose(p, prepared=[replace(e, _cache=None) for e in exps], workers=1)
            cpu = time.process_time() - c0
    print(f"{args.rig}: diagnose {cpu:.1f} s CPU = {cpu / one:.0f} evaluations' worth (one evaluation "
          f"{1e3 * one:.1f} ms CPU), {d.evaluations} model evaluations; verdict {d.verdict!r}")
    for name, (t, n, calls) in sorted(tally.stages.items(), key=lambda kv: -kv[1][0]):
        print(f"  {name:12s} x{calls:<3d} {t:6.2f} s CPU = {t / one:5.0f} worth, {n:5d} evaluations")
    rows = sorted(tally.effects.items(), key=lambda kv: -kv[1][0])[:args.top]
    for (name, effect, caller), (t, n, calls) in rows:
        print(f"    {name:8s} {effect:40s} in {caller:10s} x{calls:<2d} {t / one:5.0f} worth, {n:4d} evaluations")


if __name__ == "__main__":
    main()
