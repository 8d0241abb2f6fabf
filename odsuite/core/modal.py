"""Modal parameters from FRFs: least-squares complex frequency (LSCF) poles over model orders, a
stabilisation diagram with automatic (or user-chosen) pole selection, least-squares frequency
domain (LSFD) residues and mode shapes; MAC, paired frequency/damping tables and ODS.

LSCF (Guillaume et al. 2003, the PolyMAX family): one common-denominator polynomial in
z = exp(i omega Ts), Ts = 1/(2 f_max), fitted to all outputs by linearised least squares; its roots
are the poles lambda = ln(z)/Ts. f = |lambda|/2pi, zeta = -Re lambda/|lambda|.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from odsuite.core.errors import ConfigError, DimensionError
from odsuite.core.frf import FORM_POWER


@dataclass(frozen=True)
class StabilisationDiagram:
    """Poles (positive frequency, stable in time) of every model order and their stability flags
    against the previous order: ``stable_f`` (frequency within ``tol_f``) and ``stable``
    (frequency and damping within ``tol_zeta``)."""

    orders: list[int]
    poles: list[np.ndarray]
    stable_f: list[np.ndarray]
    stable: list[np.ndarray]
    f_band: tuple[float, float]


@dataclass(frozen=True)
class ModalResult:
    """Identified modes, ascending in frequency. ``residues`` and ``shapes`` are outputs x modes;
    shapes are scaled to a largest entry of 1 (real, positive)."""

    poles: np.ndarray
    residues: np.ndarray
    shapes: np.ndarray
    output_names: list[str] = field(default_factory=list)
    diagram: StabilisationDiagram | None = None

    @property
    def frequency_hz(self) -> np.ndarray:
        return np.abs(self.poles) / (2 * np.pi)

    @property
    def damping_ratio(self) -> np.ndarray:
        return -self.poles.real / np.abs(self.poles)

    def to_dict(self) -> dict:
        """JSON-ready: {"modes": [{"frequency_hz", "damping_ratio", "shape": {name: [re, im]}}]}."""
        names = self.output_names or [f"response {k}" for k in range(self.shapes.shape[0])]
        return {
            "modes": [
                {
                    "frequency_hz": float(self.frequency_hz[r]),
                    "damping_ratio": float(self.damping_ratio[r]),
                    "shape": {n: [float(v.real), float(v.imag)] for n, v in zip(names, self.shapes[:, r])},
                }
                for r in range(self.poles.size)
            ]
        }


def _check(freq: np.ndarray, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    freq = np.asarray(freq, dtype=float)
    H = np.asarray(H, dtype=complex)
    H = H[None, :] if H.ndim == 1 else H
    if H.ndim != 2 or H.shape[1] != freq.size:
        raise DimensionError(f"FRFs have shape {H.shape}; expected outputs x {freq.size} frequency lines")
    if freq.size < 4 or np.any(np.diff(freq) <= 0):
        raise DimensionError("FRF frequencies must be at least 4 ascending lines")
    return freq, H


def lscf(
    freq: np.ndarray,
    H: np.ndarray,
    max_order: int = 60,
    *,
    min_order: int = 2,
    step: int = 1,
    tol_f: float = 0.01,
    tol_zeta: float = 0.05,
    max_damping: float = 0.2,
) -> StabilisationDiagram:
    """LSCF poles for model orders ``min_order..max_order`` (polynomial degree = order) on the
    given band (pass only the lines to fit, without 0 Hz)."""
    freq, H = _check(freq, H)
    if not 1 <= min_order <= max_order:
        raise ConfigError(f"model orders {min_order}..{max_order} are not a valid range")
    if max_order >= freq.size:
        raise ConfigError(f"model order {max_order} needs more than the {freq.size} frequency lines given")
    ts = 1.0 / (2 * freq[-1])
    X = np.exp(1j * 2 * np.pi * freq[:, None] * ts * np.arange(max_order + 1)[None, :])
    H = H / np.abs(H).max(axis=1, keepdims=True)  # equal weight per output; poles do not change
    R = (X.conj().T @ X).real
    S = [-(X.conj().T @ (h[:, None] * X)).real for h in H]
    T = sum((X.conj().T @ ((np.abs(h) ** 2)[:, None] * X)).real for h in H)
    orders, poles, stable_f, stable = [], [], [], []
    prev = np.array([], dtype=complex)
    for m in range(min_order, max_order + 1, step):
        k = m + 1
        Rm = R[:k, :k]
        Mm = T[:k, :k] - sum(s[:k, :k].T @ np.linalg.solve(Rm, s[:k, :k]) for s in S)
        alpha = np.append(np.linalg.lstsq(Mm[:m, :m], -Mm[:m, m], rcond=None)[0], 1.0)
        z = np.roots(alpha[::-1])
        z = z[np.isfinite(z) & (z != 0)]
        lam = np.log(z) / ts
        wn = np.abs(lam)
        zeta = -lam.real / np.where(wn > 0, wn, 1)
        keep = (lam.imag > 0) & (zeta > 0) & (zeta < max_damping)
        keep &= (wn / (2 * np.pi) >= freq[0]) & (wn / (2 * np.pi) <= freq[-1])
        lam = lam[keep][np.argsort(np.abs(lam[keep]))]
        sf = np.zeros(lam.size, bool)
        sz = np.zeros(lam.size, bool)
        if prev.size:
            for i, p in enumerate(lam):
                j = np.argmin(np.abs(np.abs(prev) - np.abs(p)))
                q = prev[j]
                sf[i] = abs(abs(p) - abs(q)) <= tol_f * abs(q)
                zp, zq = -p.real / abs(p), -q.real / abs(q)
                sz[i] = sf[i] and abs(zp - zq) <= tol_zeta * zq
        orders.append(m)
        poles.append(lam)
        stable_f.append(sf)
        stable.append(sz)
        prev = lam
    return StabilisationDiagram(orders, poles, stable_f, stable, (float(freq[0]), float(freq[-1])))


def _pole(f_hz: float, zeta: float) -> complex:
    wn = 2 * np.pi * f_hz
    return complex(-zeta * wn, wn * np.sqrt(1 - zeta**2))


def select_poles(
    diagram: StabilisationDiagram,
    *,
    frequencies: list[float] | None = None,
    tol: float = 0.005,
    min_fraction: float = 0.3,
) -> np.ndarray:
    """Poles picked from the diagram. Automatic: stable poles clustered in frequency (within
    ``tol``), clusters present in at least ``min_fraction`` of the orders, each represented by its
    median frequency and damping. With ``frequencies`` (Hz): the cluster of stable poles nearest
    each given frequency (within 2 %), so a user can override the choice."""
    f_all, z_all = [], []
    for poles, st in zip(diagram.poles, diagram.stable, strict=True):
        f_all.extend(np.abs(poles[st]) / (2 * np.pi))
        z_all.extend(-poles[st].real / np.abs(poles[st]))
    f_all, z_all = np.asarray(f_all), np.asarray(z_all)
    if frequencies is not None:
        out = []
        for fr in frequencies:
            near = np.abs(f_all - fr) <= 0.02 * fr
            if not near.any():
                raise ConfigError(f"no stable pole within 2 % of {fr} Hz in the stabilisation diagram")
            centre = f_all[near][np.argmin(np.abs(f_all[near] - fr))]
            cl = np.abs(f_all - centre) <= tol * centre
            out.append(_pole(np.median(f_all[cl]), np.median(z_all[cl])))
        out = np.asarray(out)
        return out[np.argsort(np.abs(out))]
    order = np.argsort(f_all)
    f_all, z_all = f_all[order], z_all[order]
    clusters: list[list[int]] = []
    for i, f in enumerate(f_all):
        if clusters and f - f_all[clusters[-1][0]] <= tol * f:
            clusters[-1].append(i)
        else:
            clusters.append([i])
    need = max(3, int(np.ceil(min_fraction * len(diagram.orders))))
    out = [_pole(np.median(f_all[c]), np.median(z_all[c])) for c in clusters if len(c) >= need]
    return np.asarray(out, dtype=complex)


def lsfd(
    freq: np.ndarray, H: np.ndarray, poles: np.ndarray, *, form: str = "accelerance", residuals: bool = True
) -> np.ndarray:
    """Complex residues (outputs x modes) of ``H = (i w)^p sum_r [A_r/(i w - l_r) + conj]`` plus
    real lower (1/(i w)^2) and upper (constant) residuals in receptance terms, p from ``form``."""
    freq, H = _check(freq, H)
    if form not in FORM_POWER:
        raise ConfigError(f"FRF form {form!r} is not one of {', '.join(FORM_POWER)}")
    poles = np.asarray(poles, dtype=complex)
    iw = 2j * np.pi * freq[:, None]
    a = 1 / (iw - poles[None, :])
    b = 1 / (iw - poles.conj()[None, :])
    cols = [a + b, 1j * (a - b)]  # real and imaginary part of A_r
    if residuals:
        cols.append(1 / iw**2)
        cols.append(np.ones_like(iw))
    P = np.hstack(cols) * iw ** FORM_POWER[form]
    A = np.vstack([P.real, P.imag])
    B = np.vstack([H.T.real, H.T.imag])
    coef = np.linalg.lstsq(A, B, rcond=None)[0]
    n = poles.size
    return (coef[:n] + 1j * coef[n : 2 * n]).T


def normalise_shapes(residues: np.ndarray) -> np.ndarray:
    """Scale each column to a largest entry of exactly 1 (rotates the phase too)."""
    r = np.asarray(residues, dtype=complex)
    idx = np.argmax(np.abs(r), axis=0)
    return r / r[idx, np.arange(r.shape[1])]


def identify_modes(
    freq: np.ndarray,
    H: np.ndarray,
    *,
    f_band: tuple[float, float] | None = None,
    max_order: int = 50,
    frequencies: list[float] | None = None,
    form: str = "accelerance",
    window_tau: float | None = None,
    output_names: list[str] | None = None,
) -> ModalResult:
    """LSCF stabilisation diagram -> pole selection -> LSFD residues on the band ``f_band``
    (default: the whole FRF without 0 Hz). ``window_tau`` (s): the FRFs were measured with an
    exponential window of that time constant; the reported poles have its damping removed."""
    freq, H = _check(freq, H)
    lo, hi = f_band if f_band is not None else (freq[freq > 0][0], freq[-1])
    keep = (freq >= lo) & (freq <= hi) & (freq > 0)
    if keep.sum() <= max_order:
        raise ConfigError(f"band {lo}..{hi} Hz holds {keep.sum()} lines; model order {max_order} needs more")
    f, h = freq[keep], H[:, keep]
    diagram = lscf(f, h, max_order)
    poles = select_poles(diagram, frequencies=frequencies)
    if poles.size == 0:
        raise ConfigError(f"no stable poles found in {lo}..{hi} Hz up to model order {max_order}")
    res = lsfd(f, h, poles, form=form)
    if window_tau is not None:
        poles = poles + 1.0 / window_tau  # the structure's own poles (see hammer.correct_exponential_window)
    return ModalResult(poles, res, normalise_shapes(res), list(output_names or []), diagram)


def mac(phi_a: np.ndarray, phi_b: np.ndarray) -> np.ndarray:
    """Modal assurance criterion between the columns of two shape matrices (dofs x modes):
    |a^H b|^2 / ((a^H a)(b^H b)), complex shapes allowed."""
    a = np.asarray(phi_a, dtype=complex)
    b = np.asarray(phi_b, dtype=complex)
    a = a[:, None] if a.ndim == 1 else a
    b = b[:, None] if b.ndim == 1 else b
    if a.shape[0] != b.shape[0]:
        raise DimensionError(f"shapes have {a.shape[0]} and {b.shape[0]} entries; MAC needs the same dofs")
    num = np.abs(a.conj().T @ b) ** 2
    return num / np.outer(np.sum(np.abs(a) ** 2, axis=0), np.sum(np.abs(b) ** 2, axis=0))


def pair_modes(
    f_a: np.ndarray,
    zeta_a: np.ndarray,
    f_b: np.ndarray,
    zeta_b: np.ndarray,
    *,
    shapes_a: np.ndarray | None = None,
    shapes_b: np.ndarray | None = None,
) -> list[dict]:
    """Pair modes of A (e.g. test) with modes of B (model or another test): by the best MAC when
    both shapes are given, else by nearest frequency; one-to-one, best pairs first. Rows hold both
    frequencies and dampings, their differences (B - A, relative to A) and the MAC."""
    f_a, f_b = np.asarray(f_a, float), np.asarray(f_b, float)
    zeta_a, zeta_b = np.asarray(zeta_a, float), np.asarray(zeta_b, float)
    if shapes_a is not None and shapes_b is not None:
        m = mac(shapes_a, shapes_b)
        score = m - 1e-3 * np.abs(np.log(f_b[None, :] / f_a[:, None]))  # ties go to the closer frequency
    else:
        m = None
        score = -np.abs(np.log(f_b[None, :] / f_a[:, None]))
    rows = []
    used_a, used_b = set(), set()
    for flat in np.argsort(score, axis=None)[::-1]:
        i, j = np.unravel_index(flat, score.shape)
        if i in used_a or j in used_b:
            continue
        used_a.add(i)
        used_b.add(j)
        rows.append(
            {
                "mode_a": int(i), "mode_b": int(j),
                "frequency_a_hz": float(f_a[i]), "frequency_b_hz": float(f_b[j]),
                "frequency_difference": float((f_b[j] - f_a[i]) / f_a[i]),
                "damping_a": float(zeta_a[i]), "damping_b": float(zeta_b[j]),
                "damping_difference": float((zeta_b[j] - zeta_a[i]) / zeta_a[i]) if zeta_a[i] else float("nan"),
                "mac": float(m[i, j]) if m is not None else None,
            }
        )
    return sorted(rows, key=lambda r: r["mode_a"])


def ods(freq: np.ndarray, H: np.ndarray, frequency_hz: float, force_amplitude: float = 1.0) -> np.ndarray:
    """Operating deflection shape: every output's complex response (amplitude and phase) to a
    harmonic force of ``force_amplitude`` at ``frequency_hz``, interpolated between lines."""
    freq, H = _check(freq, H)
    if not freq[0] <= frequency_hz <= freq[-1]:
        raise ConfigError(f"ODS frequency {frequency_hz} Hz lies outside the FRFs' {freq[0]}..{freq[-1]} Hz")
    re = np.array([np.interp(frequency_hz, freq, h.real) for h in H])
    im = np.array([np.interp(frequency_hz, freq, h.imag) for h in H])
    return force_amplitude * (re + 1j * im)
