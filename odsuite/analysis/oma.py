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

from odsuite.domain.errors import ConfigError, DimensionError
from odsuite.analysis.modal import (
    ModalResult,
    StabilisationDiagram,
    Unresolved,
    normalise_shapes,
    physical_poles,
    select_poles,
    stability_flags,
)


def _correlations(y: np.ndarray, lags: int) -> np.ndarray:
    """Unbiased output correlations R_k (lags x outputs x outputs), k = 0 .. lags - 1."""
    n = y.shape[0]
    # einsum's own loop, not BLAS: these skinny products gain nothing from BLAS threads, which on a
    # busy machine made them a hundred times slower (77 s against 1.4 s for 51200 x 18, 40 lags)
    return np.array([np.einsum("ti,tj->ij", y[k:], y[: n - k]) / (n - k) for k in range(lags)])


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


#: the record is also cut into this many segments, each identified on its own: the scatter of a
#: pole over them gives its standard error (batch means; 4 segments, 3 degrees of freedom, keep
#: each segment a quarter of a record that is long enough for the whole)
SEGMENTS = 4
#: a segment's pole counts for a full-record pole within this relative distance (a pole further
#: away is a different pole or none)
MATCH_TOL = 0.05
#: two neighbouring poles are told apart when their frequencies differ by more than this many
#: combined standard errors (about 95 % for a normal scatter)
SEPARATION_SIGMAS = 2.0


def _segment_scatter(y: np.ndarray, fs: float, poles: np.ndarray, band: tuple[float, float],
                     max_order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per pole: standard errors of frequency (Hz) and damping ratio from the scatter of its
    matched poles over ``SEGMENTS`` segments (sample std / sqrt(segments)), and the number of
    segments that hold it (a one-to-one match within ``MATCH_TOL``)."""
    from scipy.optimize import linear_sum_assignment

    f0 = np.abs(poles) / (2 * np.pi)
    found_f = [[] for _ in poles]
    found_z = [[] for _ in poles]
    n = y.shape[0] // SEGMENTS
    for k in range(SEGMENTS):
        try:
            diagram, _ = ssi_cov(y[k * n:(k + 1) * n], fs, max_order=max_order, f_band=band)
        except DimensionError:
            break  # segments too short to identify anything: no scatter
        seg, _ = select_poles(diagram)
        if seg.size == 0:
            continue
        fs_seg = np.abs(seg) / (2 * np.pi)
        cost = np.abs(fs_seg[None, :] - f0[:, None]) / f0[:, None]
        for r, c in zip(*linear_sum_assignment(cost)):
            if cost[r, c] <= MATCH_TOL:
                found_f[r].append(fs_seg[c])
                found_z[r].append(-seg[c].real / abs(seg[c]))
    count = np.array([len(v) for v in found_f])
    with np.errstate(invalid="ignore"):
        f_std = np.array([np.std(v, ddof=1) / np.sqrt(len(v)) if len(v) > 1 else np.inf for v in found_f])
        z_std = np.array([np.std(v, ddof=1) / np.sqrt(len(v)) if len(v) > 1 else np.inf for v in found_z])
    return f_std, z_std, count


def _resolved(poles: np.ndarray, f_std: np.ndarray, count: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Which poles are modes, and for the others why not: a pole held by fewer than half the
    segments is not confirmed; two neighbours closer than ``SEPARATION_SIGMAS`` combined standard
    errors cannot be told apart from this record, so neither is called a mode."""
    f = np.abs(poles) / (2 * np.pi)
    ok = np.ones(poles.size, bool)
    reasons = [""] * poles.size
    for r in range(poles.size):
        if count[r] < SEGMENTS / 2:
            ok[r] = False
            reasons[r] = f"found in only {count[r]} of {SEGMENTS} segments of the record"
    confirmed = np.flatnonzero(ok)  # neighbours among the confirmed poles (the others have no scatter)
    for r, q in zip(confirmed[:-1], confirmed[1:]):
        gap, spread = f[q] - f[r], np.hypot(f_std[r], f_std[q])
        if not gap > SEPARATION_SIGMAS * spread:
            for a, b in ((r, q), (q, r)):
                ok[a] = False
                reasons[a] = reasons[a] or (
                    f"cannot be told apart from the pole at {f[b]:.2f} Hz: {gap:.2f} Hz apart, "
                    f"standard errors {f_std[r]:.2f} and {f_std[q]:.2f} Hz (a longer record or "
                    "more independent inputs separate them)")
    return ok, reasons


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
    pole. Each pole's standard errors come from its scatter over ``SEGMENTS`` segments of the
    record; poles that are not confirmed by the segments or that cannot be told apart from a
    neighbour are reported in ``unresolved``, not as modes. Residues are not defined without a
    force: ``residues`` holds the unscaled shapes."""
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
        raise ConfigError(f"no pole in {lo:g}..{hi:g} Hz is stable over enough model orders (2..{max_order}): "
                          "this record does not determine the modes (too short or noisy, or modes too damped "
                          "and close for the inputs that drove it; see docs/operating.md)")
    phi = np.empty((shapes[0].shape[0], poles.size), dtype=complex)
    for r, p in enumerate(poles):
        # highest order where a pole lies within 0.5 % (select_poles' cluster width)
        for k in range(len(diagram.orders) - 1, -1, -1):
            cand = diagram.poles[k]
            if cand.size and np.min(np.abs(np.abs(cand) - abs(p))) <= 0.005 * abs(p):
                phi[:, r] = shapes[k][:, int(np.argmin(np.abs(np.abs(cand) - abs(p))))]
                break
    f_std, z_std, count = _segment_scatter(y, fs, poles, (lo, hi), max_order)
    ok, reasons = _resolved(poles, f_std, count)
    unresolved = [Unresolved(float(abs(p) / (2 * np.pi)), float(-p.real / abs(p)), float(f_std[r]), reasons[r])
                  for r, p in enumerate(poles) if not ok[r]]
    shapes_n = normalise_shapes(phi[:, ok])
    return ModalResult(poles[ok], shapes_n, shapes_n, list(output_names or []), diagram, (lo, hi),
                       stable_orders[ok], [], output_only=True, frequency_std_hz=f_std[ok], damping_std=z_std[ok],
                       unresolved=unresolved)
