"""Speed of odsuite's exact-discretisation simulation against scipy.signal.lsim (same run).

The thesis dynamometer, a hammer-like force, nine accelerometer outputs, zero- and first-order
hold. Prints seconds and the speed-up ratio; run with `.venv/bin/python bench/bench_simulation.py
[N_SAMPLES]` (default 1e6).
"""

from __future__ import annotations

import sys
import time

import numpy as np
import scipy.signal

from odsuite.contracts.plugins import registries
from odsuite.domain.model import Input, Output
from odsuite.domain.simulation import simulate

FS = 20_000.0


def best_of(fn, repeat: int) -> tuple[float, np.ndarray]:
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main(n: int = 1_000_000) -> None:
    regs = registries()
    rig = regs.rigs.get("thesis-dynamometer")
    model = regs.models.get("thesis-dynamometer")(rig)
    inputs = [Input.force((0.0, 0.004122, -0.011399), (0, 0, 1))]
    outputs = [Output.sensor(s) for s in rig.sensors]
    t = np.arange(n) / FS
    u = np.zeros(n)
    for start in range(100, n, 4000):  # a hammer hit every 0.2 s
        k = np.arange(8)
        u[start:start + 8] = 300 * np.sin(np.pi * k / 8)
    ss = model.state_space(inputs, outputs)
    print(f"thesis dynamometer, {len(outputs)} accelerometer outputs, {n} samples at {FS:.0f} Hz")
    for hold in ("zoh", "foh"):
        t_ours, y = best_of(lambda: simulate(model, inputs, u, FS, outputs, hold=hold), 3)
        t_lsim, (_, ref, _) = best_of(
            lambda: scipy.signal.lsim((ss.A, ss.B, ss.C, ss.D), u, t, interp=(hold == "foh")), 2)
        err = np.max(np.abs(y - ref)) / np.abs(ref).max()
        print(f"{hold}: odsuite {t_ours:.3f} s, scipy.signal.lsim {t_lsim:.3f} s, "
              f"ratio {t_lsim / t_ours:.1f}x, max relative difference {err:.1e}")


if __name__ == "__main__":
    main(int(float(sys.argv[1])) if len(sys.argv) > 1 else 1_000_000)
