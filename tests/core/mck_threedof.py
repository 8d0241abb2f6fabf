"""A 3-DOF mass-spring-damper chain with known modes: exact FRFs and simulated hammer records.

Independent reference for the FRF and modal tests: the analytic FRF is a direct solve of
(K - w^2 M + i w C) x = f, the modes are the state matrix's eigenvalues, and the time records come
from an exact first-order-hold modal recursion on a 16x finer grid (checked against
scipy.signal.lsim), decimated with the same filter on force and response.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

M = np.diag([2.0, 1.5, 1.0])
_k = (4.0e5, 3.0e5, 2.0e5)
K = np.array([[_k[0] + _k[1], -_k[1], 0], [-_k[1], _k[1] + _k[2], -_k[2]], [0, -_k[2], _k[2]]])
# proportional damping plus a local dashpot on mass 3 (complex modes)
C = 2e-5 * K + 1.0 * M + np.diag([0.0, 0.0, 8.0])
INPUT = 2  # hammer on mass 3 (index 2)


def state_space(input_dof: int = INPUT):
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    B = np.concatenate([np.zeros(n), Minv[:, input_dof]])[:, None]
    Cout = np.hstack([-Minv @ K, -Minv @ C])  # accelerations
    D = Minv[:, input_dof][:, None]
    return A, B, Cout, D


def modes():
    """Poles with positive imaginary part (ascending frequency) and complex displacement shapes."""
    A = state_space()[0]
    lam, vec = np.linalg.eig(A)
    keep = lam.imag > 0
    lam, vec = lam[keep], vec[:3, keep]
    order = np.argsort(np.abs(lam))
    return lam[order], vec[:, order]


def accelerance(freq_hz: np.ndarray, input_dof: int = INPUT) -> np.ndarray:
    """Exact accelerance FRFs (outputs x frequencies), (m/s^2)/N."""
    out = np.empty((3, len(freq_hz)), dtype=complex)
    for i, f in enumerate(freq_hz):
        w = 2 * np.pi * f
        x = np.linalg.solve(K - w**2 * M + 1j * w * C, np.eye(3)[:, input_dof])
        out[:, i] = -(w**2) * x
    return out


def hann_pulse(t: np.ndarray, t0: float, width: float, amplitude: float) -> np.ndarray:
    x = (t - t0) / width
    return np.where((x >= 0) & (x <= 1), amplitude * np.sin(np.pi * x) ** 2, 0.0)


def lsim_exact(u: np.ndarray, dt: float, input_dof: int = INPUT) -> np.ndarray:
    """Accelerations for an input linear between samples (first-order hold), exact: each complex
    mode z' = lam z + b u is a first-order recursion run by scipy.signal.lfilter."""
    A, B, Cout, D = state_space(input_dof)
    lam, V = np.linalg.eig(A)
    b = np.linalg.solve(V, B[:, 0])
    e = np.exp(lam * dt)
    i0 = (e - 1) / lam
    i1 = (e - 1 - lam * dt) / (lam**2 * dt)
    z = np.array([signal.lfilter([bk * c1, bk * (c0 - c1)], [1, -ek], u) for bk, ek, c0, c1 in zip(b, e, i0, i1)])
    return ((Cout @ V) @ z).real.T + u[:, None] * D[:, 0]


def simulate(
    fs: float, duration: float, pulses: list[tuple[float, float, float]], *, oversample: int = 16,
    input_dof: int = INPUT,
) -> tuple[np.ndarray, np.ndarray]:
    """Force and accelerations at ``fs`` for a sum of Hann pulses (t0, width, amplitude)."""
    fine = fs * oversample
    t = np.arange(int(round(duration * fine))) / fine
    f = np.zeros_like(t)
    for t0, width, amplitude in pulses:
        k = slice(int(t0 * fine), int((t0 + width) * fine) + 2)
        f[k] += hann_pulse(t[k], t0, width, amplitude)
    y = lsim_exact(f, 1.0 / fine, input_dof)
    force = signal.resample_poly(f, 1, oversample)
    acc = signal.resample_poly(y, 1, oversample, axis=0)
    return force, acc
