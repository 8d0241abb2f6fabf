"""Speed of ``diagnose``: every built-in effect on 5 experiments x 8192 samples (simulated rig,
16-bit ADC, a hidden stiffness change), against the cost of one model evaluation (the same run).

Prints the wall and CPU time of the diagnosis, its number of model evaluations, the time of one
evaluation of a structure-changing effect over all experiments, and their ratio. The target is a
diagnosis within 20 s. Run with `.venv/bin/python bench/bench_diagnose.py [EFFECT]`.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "core"))

from hidden_effects import CASES, make_project  # noqa: E402

from odsuite.core.prediction import predict, prepare  # noqa: E402
from odsuite.core.diagnosis import diagnose  # noqa: E402
from odsuite.core.modelrev import revision_model  # noqa: E402
from odsuite.core.plugins import registries  # noqa: E402
from odsuite.core.project import open_project  # noqa: E402


def main(effect: str = "stiffness") -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = make_project(Path(tmp) / "bench.odsp", [(effect, CASES[effect])])
        with open_project(path) as p:
            exps = prepare(p)
            base = revision_model(p).shared
            stiff = registries().effects.get("stiffness")
            # one evaluation: a new structure (its eigen-decomposition) simulated for every experiment
            t0 = time.perf_counter()
            reps = 10
            for k in range(reps):
                model = stiff.apply(base, {"scale_z": 1.0 + 0.01 * (k + 1)})
                for e in exps:
                    predict(model, e)
            one = (time.perf_counter() - t0) / reps
            c0, t0 = time.process_time(), time.perf_counter()
            d = diagnose(p, prepared=exps)
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    n_eff = len(registries().effects.names())
    print(f"diagnose: {len(exps)} experiments x {exps[0].n_samples} samples, {n_eff} effects, hidden {effect}")
    print(f"diagnose {wall:.1f} s wall ({cpu:.1f} s CPU), {d.evaluations} model evaluations; "
          f"one evaluation {1e3 * one:.1f} ms; diagnose = {wall / one:.0f} evaluations' time "
          f"(target 20 s: {'met' if wall <= 20 else 'missed'})")
    print(f"top: {d.candidates[0].effect} (significant {d.candidates[0].significant}), "
          f"error {d.baseline_error:.4g} -> {d.candidates[0].error_after:.4g}, noise floor {d.noise_floor_error:.4g}")


if __name__ == "__main__":
    main(*sys.argv[1:2])
