"""Output-only (operational) modal analysis: covariance-driven stochastic subspace identification
(SSI-cov, Peeters & De Roeck 1999) of responses to unmeasured broadband forces.

Output correlations R_k = E[y_{t+k} y_t^T] of a linear system driven by white noise are
R_k = C A^(k-1) G, so the block Toeplitz matrix of R_1 .. R_(2i-1) factors into observability
times controllability; its SVD truncated to order n gives C and A (shift invariance of the
observability matrix), and A's eigenvalues mu give the poles lambda = fs ln(mu), C's eigenvector
image the (unscaled) mode shapes. Poles are stabilised over orders and picked like LSCF's
(``modal.select_poles``).

Written here: sdypy-EMA has no output-only method, and the SSI-cov core is a few lines of numpy.
"""

from __future__ import annotations

import numpy as np
import scipy.signal

from odsuite.core.errors import ConfigError, DimensionError
from odsuite.core.modal import (
    ModalResult,
    StabilisationDiagram,
    normalise_shapes,
    physical_poles,
    select_poles,
    stability_flags,
)


def _correlations(y: np.ndarray, lags: int) -> np.ndarray:
    """Unbiased output correlations R_k (lags x outputs x outputs), k = 0 .. lags - 1."""
    n = y.shape[0]
    return np.array([y[k:].T @ y[: n - k] / (n - k) for k in range(lags)])


def ssi_cov(
    y: np.ndarray,
    fs: float,
    *,
    max_order: int = 40,
    block_rows: int | None = None,
    f_band: tuple[float, float] | None = None,
    tol_f: float = 0.01,
    tol_zeta: float = 0.05,
    max_damping: float = 0.2,
) -> tuple[StabilisationDiagram, list[np.ndarray]]:
    """Stabilisation diagram of SSI-cov for model orders 2, 4 .. ``max_order`` (state dimension)
    and, per order, the shapes (outputs x poles) of its kept poles. ``block_rows`` i: the Toeplitz
    matrix holds lags 1 .. 2i - 1 and needs i x outputs >= max_order (default: that, and at least
    20: lags to 39 samples, about 15 periods of the band's top at ``identify_output_only``'s
    decimated rate; more rows cost time and add noise poles without moving the modes)."""
    y = np.asarray(y, dtype=float)
    y = y[:, None] if y.ndim == 1 else y
    if y.ndim != 2 or y.shape[0] < 10 * y.shape[1]:
        raise DimensionError(f"responses have shape {y.shape}; expected samples x outputs, many more samples")
    if not np.all(np.isfinite(y)):
        raise ConfigError("responses hold NaN or infinite samples")
    n_out = y.shape[1]
    band = f_band if f_band is not None else (0.0, fs / 2)
    if block_rows is None:
        block_rows = max(int(np.ceil(max_order / n_out)) + 1, 20)
    if block_rows * n_out < max_order:
        raise ConfigError(f"SSI-cov: {block_rows} block rows x {n_out} outputs cannot hold model order {max_order}")
    y = y - y.mean(axis=0)
    y = y / np.maximum(y.std(axis=0), np.finfo(float).tiny)  # equal weight per output; poles unchanged
    R = _correlations(y, 2 * block_rows)
    # T[a, b] = R_(i + a - b), a, b = 0 .. i-1 (lags 1 .. 2i-1)
    T = np.block([[R[block_rows + a - b] for b in range(block_rows)] for a in range(block_rows)])
    U, S, _ = np.linalg.svd(T)
    orders, poles, shapes, stable_f, stable = [], [], [], [], []
    prev = np.array([], dtype=complex)
    for n in range(2, max_order + 1, 2):
        obs = U[:, :n] * np.sqrt(S[:n])
        A = np.linalg.lstsq(obs[:-n_out], obs[n_out:], rcond=None)[0]
        mu, psi = np.linalg.eig(A)
        lam = np.log(mu.astype(complex)) * fs
        phi = obs[:n_out] @ psi
        kept = physical_poles(lam, band, max_damping)
        idx = [int(np.argmin(np.abs(lam - k))) for k in kept]
        sf, sz = stability_flags(prev, kept, tol_f, tol_zeta)
        orders.append(n)
        poles.append(kept)
        shapes.append(phi[:, idx])
        stable_f.append(sf)
        stable.append(sz)
        prev = kept
    return StabilisationDiagram(orders, poles, stable_f, stable, (float(band[0]), float(band[1]))), shapes


def identify_output_only(
    y: np.ndarray,
    fs: float,
    *,
    f_band: tuple[float | None, float | None] | None = None,
    max_order: int = 40,
    output_names: list[str] | None = None,
) -> ModalResult:
    """Modes from responses alone: SSI-cov on the record (decimated so that the band's top lies
    at 40 % of the new sampling rate, which keeps the anti-aliasing filter's own poles out),
    poles stable over orders (``modal.select_poles``), shapes from the highest order holding each
    pole. Residues are not defined without a force: ``residues`` holds the unscaled shapes."""
    lo, hi = f_band if f_band is not None else (None, None)
    lo, hi = (0.0 if lo is None else float(lo)), (fs / 2 if hi is None else float(hi))
    if not 0 <= lo < hi <= fs / 2:
        raise ConfigError(f"output-only band {lo:g}..{hi:g} Hz must lie within 0..{fs / 2:g} Hz")
    y = np.asarray(y, dtype=float)
    q = int(fs // (2.5 * hi)) if hi < fs / 2 else 1
    if q > 1:
        y = scipy.signal.decimate(y, q, ftype="fir", axis=0, zero_phase=True)
        fs = fs / q
    diagram, shapes = ssi_cov(y, fs, max_order=max_order, f_band=(lo, hi))
    poles, stable_orders = select_poles(diagram)
    if poles.size == 0:
        raise ConfigError(f"no stable poles found in {lo:g}..{hi:g} Hz up to model order {max_order}")
    phi = np.empty((shapes[0].shape[0], poles.size), dtype=complex)
    for r, p in enumerate(poles):
        # highest order where a pole lies within 0.5 % (select_poles' cluster width)
        for k in range(len(diagram.orders) - 1, -1, -1):
            cand = diagram.poles[k]
            if cand.size and np.min(np.abs(np.abs(cand) - abs(p))) <= 0.005 * abs(p):
                phi[:, r] = shapes[k][:, int(np.argmin(np.abs(np.abs(cand) - abs(p))))]
                break
    shapes_n = normalise_shapes(phi)
    return ModalResult(poles, shapes_n, shapes_n, list(output_names or []), diagram, (lo, hi),
                       stable_orders, [], output_only=True)
