"""How well can output-only analysis find a rig's modes, and how long must the record be?

Prints, for a rig file (default: the thesis rig as modelled and with a tenth of its isolators'
damping), per mode and record length over several random seeds:

1. the Cramer-Rao bound on the relative standard deviation of |lambda| for one unmeasured white
   force (the record reduces to an AR process in the system's denominator once the responses'
   numerators are known, so no output-only method can beat this bound; it is a linearised bound,
   meaningful where it is small against the modes' spacing);
2. the scatter of the efficient estimate of that AR process (least squares on the exact AR
   record, i.e. with more knowledge than any output-only method has), and how many seeds give all
   modes within 1 % (one-to-one pairing);
3. SSI-cov at the true order (oracle: no order selection) on the noise-free responses to one force
   at a corner, and to random base motion in all six directions, with the same pairing.

Run: .venv/bin/python bench/oma_limits.py [RIG.toml ...] [--seeds 6] [--lengths 60,600,3600]
"""

from __future__ import annotations

import argparse
import re
import tempfile
from pathlib import Path

import numpy as np
import scipy.linalg
import scipy.signal
from scipy.optimize import linear_sum_assignment

from odsuite.domain.model import Input, Output
from odsuite.contracts.plugins import registries
from odsuite.domain.rig import load_rig
from odsuite.domain.simulation import simulate_state_space

RIGS = Path(__file__).resolve().parents[1] / "projects" / "rigs"
#: the thesis rig and its Systeminfo ship once, with the models plugin that registers them
PLUGIN_RIGS = Path(__file__).resolve().parents[1] / "plugins" / "models" / "rigs"
FS = 1000.0  # Hz: the thesis rig's rate
CORNER = np.array([35.7, 76.4, -11.4]) * 1e-3  # m: near the thesis platform's far corner
FORCE_DIR = np.array([1.0, 1.0, 0.3])


def rig_model(path: Path):
    reg = registries()
    rig = load_rig(path, reg.sensor_types)
    return rig, reg.models.get(rig.default_model)(rig)


def poles(ss) -> np.ndarray:
    lam = np.linalg.eigvals(ss.A)
    lam = lam[lam.imag > 0]
    return lam[np.argsort(np.abs(lam))]


def paired_errors(found: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """Relative |lambda| error per true mode after one-to-one pairing (inf: no partner)."""
    err = np.full(lam.size, np.inf)
    if found.size:
        cost = np.abs(np.abs(found)[None, :] - np.abs(lam)[:, None]) / np.abs(lam)[:, None]
        r, c = linear_sum_assignment(cost)
        err[r] = cost[r, c]
    return err


def crb(lam: np.ndarray, seconds: float) -> np.ndarray:
    """Cramer-Rao bound on the relative std of |lambda| from ``seconds`` of the AR process."""
    mu = np.exp(np.concatenate([lam, lam.conj()]) / FS)
    a = np.real(np.poly(mu))
    p = a.size - 1
    imp = scipy.signal.lfilter([1.0], a, np.r_[1.0, np.zeros(20000)])
    r = np.array([imp[k:] @ imp[: imp.size - k] for k in range(p)])
    cov = np.linalg.inv(scipy.linalg.toeplitz(r)) / (seconds * FS)
    out = []
    for m in mu[: lam.size]:
        dmu = -np.array([m ** (p - k) for k in range(1, p + 1)]) / np.polyval(np.polyder(a), m)
        lm = FS * np.log(m)
        g = np.real(np.conj(lm) / abs(lm) * FS / m * dmu)
        out.append(np.sqrt(g @ cov @ g) / abs(lm))
    return np.array(out)


def ar_estimate(lam: np.ndarray, seconds: float, rng) -> np.ndarray:
    mu = np.exp(np.concatenate([lam, lam.conj()]) / FS)
    a = np.real(np.poly(mu))
    p, n = a.size - 1, int(seconds * FS)
    w = scipy.signal.lfilter([1.0], a, rng.standard_normal(n + 5000))[5000:]
    X = np.column_stack([w[p - k - 1:n - k - 1] for k in range(p)])
    coef = np.linalg.lstsq(X, w[p:], rcond=None)[0]
    found = FS * np.log(np.roots(np.r_[1.0, -coef]).astype(complex))
    return found[found.imag > 0]


def responses(ss, seconds: float, rng) -> np.ndarray:
    """Exact sampled responses to independent white zero-order-hold inputs, after a settling second."""
    n = int((seconds + 1) * FS)
    return simulate_state_space(ss, rng.standard_normal((n, ss.B.shape[1])), FS)[int(FS):]


def ssi_at_order(y: np.ndarray, order: int, block_rows: int = 10) -> np.ndarray:
    y = (y - y.mean(0)) / y.std(0)
    n, m = y.shape
    R = [np.einsum("ti,tj->ij", y[k:], y[: n - k]) / (n - k) for k in range(2 * block_rows)]
    T = np.block([[R[block_rows + a - b] for b in range(block_rows)] for a in range(block_rows)])
    U, S, _ = np.linalg.svd(T)
    obs = U[:, :order] * np.sqrt(S[:order])
    A = np.linalg.lstsq(obs[:-m], obs[m:], rcond=None)[0]
    found = FS * np.log(np.linalg.eigvals(A).astype(complex))
    return found[found.imag > 0]


def light_copy(path: Path, folder: Path) -> Path:
    """The thesis rig with a tenth of its isolators' damping."""
    text = re.sub(r"damping = \[140\.0, 125\.0, 275\.0\]", "damping = [14.0, 12.5, 27.5]", path.read_text())
    (folder / "thesis-table-e3.CTR").write_bytes((path.parent / "thesis-table-e3.CTR").read_bytes())
    out = folder / "thesis-light.toml"
    out.write_text(text)
    return out


def report(name: str, path: Path, lengths: list[float], seeds: int) -> None:
    rig, model = rig_model(path)
    acc = [Output.sensor(s) for s in rig.accelerometers]
    vel = [Output.sensor(s, "velocity") for s in rig.accelerometers]
    force = model.state_space([Input.force(CORNER, FORCE_DIR)], acc)
    base = model.state_space([Input.base_translation(np.eye(3)[k]) for k in range(3)]
                             + [Input.base_rotation(np.eye(3)[k]) for k in range(3)], vel)
    lam = poles(force)
    print(f"\n{name}: modes {', '.join(f'{f:.2f}' for f in np.abs(lam) / (2 * np.pi))} Hz, damping ratios "
          f"{', '.join(f'{z:.3f}' for z in -lam.real / np.abs(lam))}")
    print("record (s) | method | rms relative error per mode (%) | seeds with all within 1 %")
    for seconds in lengths:
        print(f"{seconds:8.0f}   | Cramer-Rao bound, one force | {np.round(100 * crb(lam, seconds), 2)} |")
        cases = [("AR oracle, one force", lambda rng: ar_estimate(lam, seconds, rng))]
        if seconds <= 600:  # SSI on simulated responses: memory and time grow with the record
            cases += [("SSI-cov order 2n, one force", lambda rng: ssi_at_order(responses(force, seconds, rng), 2 * lam.size)),
                      ("SSI-cov order 2n, base 6 axes", lambda rng: ssi_at_order(responses(base, seconds, rng), 2 * lam.size))]
        for label, estimate in cases:
            errs = np.array([paired_errors(estimate(np.random.default_rng(seed)), lam) for seed in range(seeds)])
            rms = np.sqrt(np.mean(np.minimum(errs, 1.0) ** 2, axis=0))
            print(f"{seconds:8.0f}   | {label} | {np.round(100 * rms, 2)} | {int(np.sum(errs.max(1) < 0.01))}/{seeds}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rigs", nargs="*", type=Path)
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--lengths", default="60,600,3600", help="record lengths, s")
    args = ap.parse_args()
    lengths = [float(v) for v in args.lengths.split(",")]
    thesis = PLUGIN_RIGS / "thesis-dynamometer.toml"
    with tempfile.TemporaryDirectory() as tmp:
        rigs = [(p.stem, p) for p in args.rigs] or [("thesis rig as modelled", thesis),
                                                     ("thesis rig, isolator damping / 10", light_copy(thesis, Path(tmp)))]
        for name, path in rigs:
            report(name, path, lengths, args.seeds)


if __name__ == "__main__":
    main()
