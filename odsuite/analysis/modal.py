"""Modal parameters from FRFs: least-squares complex frequency (LSCF) poles over model orders, a
stabilisation diagram with automatic (or user-chosen) pole selection, least-squares frequency
domain (LSFD) residues and mode shapes; MAC, paired frequency/damping tables and ODS.

LSCF (Guillaume et al. 2003, the PolyMAX family): one common-denominator polynomial in
z = exp(i omega Ts), Ts = 1/(2 f_max), fitted to all outputs by linearised least squares; its roots
are the poles lambda = ln(z)/Ts. f = |lambda|/2pi, zeta = -Re lambda/|lambda|.

Written here rather than taken from sdypy-EMA: its LSCF is the same algorithm, but its pole choice
is interactive or by given frequencies, while odsuite needs per-order stability flags, automatic
selection and the synthesis checks below on several outputs at once (reduced normal equations:
the 50-order diagram of a 5000-line FRF takes under a second).

A pole is reported as a mode only when it is stable over model orders and its own term explains
the measured FRF at its resonance (not an anti-resonance or a noise fit): see ``check_poles``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import math

import numpy as np
import scipy.linalg

from odsuite.domain import arguments
from odsuite.domain.errors import ConfigError, DimensionError
from odsuite.analysis.frf import FORM_POWER, usable_band


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
class Unresolved:
    """A stable pole that is not reported as a mode: ``reason`` says why (its scatter overlaps a
    neighbour's, or too few segments of the record hold it)."""

    frequency_hz: float
    damping_ratio: float
    frequency_std_hz: float
    reason: str

    def to_dict(self) -> dict:
        std = self.frequency_std_hz
        return {"frequency_hz": self.frequency_hz, "damping_ratio": self.damping_ratio,
                "frequency_std_hz": std if np.isfinite(std) else None, "reason": self.reason}


@dataclass(frozen=True)
class ModalResult:
    """Identified modes, ascending in frequency. ``residues`` and ``shapes`` are outputs x modes;
    shapes are scaled to a largest entry of 1 (real, positive)."""

    poles: np.ndarray
    residues: np.ndarray
    shapes: np.ndarray
    output_names: list[str] = field(default_factory=list)
    diagram: StabilisationDiagram | None = None
    band_hz: tuple[float, float] | None = None
    stable_orders: np.ndarray | None = None  # per mode: model orders with a stable pole there
    rejected: list[str] = field(default_factory=list)  # stable poles not reported, with the reason
    output_only: bool = False  # identified from responses alone (shapes unscaled)
    # output-only: per mode the standard error of frequency (Hz) and damping ratio from the
    # scatter over the record's segments, and poles not reported as modes (``Unresolved``)
    frequency_std_hz: np.ndarray | None = None
    damping_std: np.ndarray | None = None
    unresolved: list[Unresolved] = field(default_factory=list)
    settings: object | None = None  # output-only: oma.OmaSettings, how the record was analysed
    fdd: object | None = None  # output-only: fdd.FddResult, the independent EFDD estimate

    @property
    def frequency_hz(self) -> np.ndarray:
        return np.abs(self.poles) / (2 * np.pi)

    @property
    def damping_ratio(self) -> np.ndarray:
        return -self.poles.real / np.abs(self.poles)

    def to_dict(self) -> dict:
        """JSON-ready: {"band_hz": [lo, hi], "output_only": bool, "modes": [{"frequency_hz",
        "damping_ratio", "stable_orders", "shape": {name: [re, im]}}]}; output-only modes add
        "frequency_std_hz" and "damping_std" per mode and "unresolved": [{"frequency_hz",
        "damping_ratio", "frequency_std_hz", "reason"}]. Every mode carries "mpc" and "mpd_deg"
        (its shape's complexity); output-only results add "settings" and "fdd" (EFDD modes, each
        with its MPC and the MAC to its SSI partner)."""
        names = self.output_names or [f"response {k}" for k in range(self.shapes.shape[0])]
        doc = {
            "band_hz": None if self.band_hz is None else [float(v) for v in self.band_hz],
            "output_only": self.output_only,
            "modes": [
                {
                    "frequency_hz": float(self.frequency_hz[r]),
                    "damping_ratio": float(self.damping_ratio[r]),
                    "stable_orders": None if self.stable_orders is None else int(self.stable_orders[r]),
                    "shape": {n: [float(v.real), float(v.imag)] for n, v in zip(names, self.shapes[:, r])},
                    "mpc": float(mpc(self.shapes[:, r])),
                    "mpd_deg": float(mpd(self.shapes[:, r])),
                }
                for r in range(self.poles.size)
            ],
        }
        if self.frequency_std_hz is not None:
            for r, m in enumerate(doc["modes"]):
                m["frequency_std_hz"] = float(self.frequency_std_hz[r])
                m["damping_std"] = float(self.damping_std[r])
            doc["unresolved"] = [u.to_dict() for u in self.unresolved]
        if self.settings is not None:
            doc["settings"] = self.settings.to_dict()
        if self.fdd is not None:
            doc["fdd"] = fdd_doc(self, names)
        return doc


#: an EFDD mode and an SSI mode are the same mode only within this relative frequency difference
PAIR_TOL = 0.05


def fdd_doc(res: "ModalResult", names: list[str]) -> dict:
    """The EFDD modes of an output-only result as JSON, each paired with an SSI mode (``pair_modes``
    by MAC): frequency and damping with their standard errors, MPC, the shape, and the partner's
    index, frequency difference and MAC (null when it has none)."""
    fd = res.fdd
    pairs = {}
    if fd.frequency_hz.size and res.poles.size:
        for row in pair_modes(fd.frequency_hz, fd.damping_ratio, res.frequency_hz, res.damping_ratio,
                              shapes_a=fd.shapes, shapes_b=res.shapes):
            if abs(row["frequency_difference"]) <= PAIR_TOL:  # further apart: different modes
                pairs[row["mode_a"]] = row

    def num(v):
        return float(v) if np.isfinite(v) else None

    modes = []
    for r in range(fd.frequency_hz.size):
        p = pairs.get(r)
        modes.append({"frequency_hz": float(fd.frequency_hz[r]), "damping_ratio": float(fd.damping_ratio[r]),
                      "frequency_std_hz": num(fd.frequency_std_hz[r]), "damping_std": num(fd.damping_std[r]),
                      "mpc": float(mpc(fd.shapes[:, r])), "mpd_deg": float(mpd(fd.shapes[:, r])),
                      "shape": {n: [float(v.real), float(v.imag)] for n, v in zip(names, fd.shapes[:, r])},
                      "ssi_mode": None if p is None else p["mode_b"],
                      "frequency_difference": None if p is None else p["frequency_difference"],
                      "mac_ssi": None if p is None else p["mac"],
                      "damping_apart": None if p is None else _apart(res, fd, r, p["mode_b"])})
    return {"resolution_hz": fd.resolution_hz, "modes": modes}


def _apart(res: "ModalResult", fd, r: int, k: int) -> float | None:
    """How many of their combined standard errors EFDD's damping ratio of mode ``r`` lies from its
    SSI partner ``k``'s. Both errors are scatters between the record's segments, not either
    method's bias: far apart, the damping is uncertain by their difference (a UFF ambient record's
    182 Hz mode: 0.00108 and 0.00462, each stated to 2.5 %)."""
    if res.damping_std is None:
        return None
    var = float(fd.damping_std[r]) ** 2 + float(res.damping_std[k]) ** 2
    if not (np.isfinite(var) and var > 0):
        return None
    return abs(float(fd.damping_ratio[r]) - float(res.damping_ratio[k])) / float(np.sqrt(var))


def _check(freq: np.ndarray, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    freq = np.asarray(freq, dtype=float)
    H = np.asarray(H, dtype=complex)
    H = H[None, :] if H.ndim == 1 else H
    if H.ndim != 2 or H.shape[1] != freq.size:
        raise DimensionError(f"FRFs have shape {H.shape}; expected outputs x {freq.size} frequency lines")
    if freq.size < 4 or np.any(np.diff(freq) <= 0):
        raise DimensionError("FRF frequencies must be at least 4 ascending lines")
    return freq, H


def physical_poles(lam: np.ndarray, f_band: tuple[float, float], max_damping: float) -> np.ndarray:
    """The poles of positive frequency inside ``f_band`` (Hz) with 0 < zeta < ``max_damping``,
    ascending in frequency."""
    lam = np.asarray(lam, dtype=complex)
    wn = np.abs(lam)
    zeta = -lam.real / np.where(wn > 0, wn, 1)
    keep = (lam.imag > 0) & (zeta > 0) & (zeta < max_damping)
    keep &= (wn / (2 * np.pi) >= f_band[0]) & (wn / (2 * np.pi) <= f_band[1])
    return lam[keep][np.argsort(wn[keep])]


def stability_flags(prev: np.ndarray, lam: np.ndarray, tol_f: float, tol_zeta: float,
                    bandwidth: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Per pole of this order: frequency within ``tol_f`` (or ``bandwidth`` x its damping ratio
    when larger, as ``cluster_tol``) of the nearest pole of the previous order, and (then) damping
    within ``tol_zeta`` of that pole's too."""
    if not prev.size or not lam.size:
        return np.zeros(lam.size, bool), np.zeros(lam.size, bool)
    a, b = np.abs(lam), np.abs(prev)
    q = prev[np.argmin(np.abs(b[None, :] - a[:, None]), axis=1)]  # nearest in |pole|, first of equals
    aq = np.abs(q)
    zq = -q.real / aq
    sf = np.abs(a - aq) <= np.maximum(tol_f, bandwidth * zq) * aq
    return sf, sf & (np.abs(-lam.real / a - zq) <= tol_zeta * zq)


def normal_matrices(X: np.ndarray, H: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """LSCF's normal matrices for the basis ``X`` (lines x terms, ``X[n, j] = e^{i w_n ts j}``) and
    the outputs' FRFs ``H`` (outputs x lines): ``R = Re X^H X``, ``S_o = -Re X^H diag(h_o) X`` and
    ``T = Re sum_o X^H diag(|h_o|^2) X``. Each entry depends only on the lag k - j of its two terms
    (Toeplitz), so one product per output gives them all instead of a terms x terms product each."""
    ahead, behind = H @ X, H @ X.conj()  # sum_n h_n e^{+-i w_n ts d}, d = 0..terms-1
    R = scipy.linalg.toeplitz(X.sum(axis=0).real)
    S = np.stack([-scipy.linalg.toeplitz(b.real, a.real) for a, b in zip(ahead, behind)])
    T = scipy.linalg.toeplitz(((np.abs(H) ** 2).sum(axis=0) @ X).real)
    return R, S, T


def _reduced_normal(R: np.ndarray, S: np.ndarray, T: np.ndarray):
    """``k -> T_k - sum_o S_o,k^T R_k^-1 S_o,k`` (the leading k x k blocks): LSCF's reduced normal
    matrix of every order from one Cholesky factor. R_k = L_k L_k^T with L_k the leading block of
    R's factor L, and the first k rows of L^-1 S_o need only its first k rows, so the sum is a
    running sum over the rows of Y_o = L^-1 S_o: no solve per order (a solve per order and output
    was half of LSCF's time); where R is not positive definite, the solve per order."""
    try:
        L = np.linalg.cholesky(R)
    except np.linalg.LinAlgError:
        return lambda k: T[:k, :k] - np.einsum("oji,ojl->il", S[:, :k, :k], np.linalg.solve(R[None, :k, :k], S[:, :k, :k]))
    Y = scipy.linalg.solve_triangular(L, S.transpose(1, 0, 2).reshape(R.shape[0], -1), lower=True)
    Y = Y.reshape(R.shape[0], S.shape[0], S.shape[2])  # row j, output o, column
    rows = np.cumsum(np.einsum("joi,jol->jil", Y, Y), axis=0)  # rows[j] = sum over rows 0..j, outputs
    return lambda k: T[:k, :k] - rows[k - 1, :k, :k]


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
    # each output weighed by its signal-to-noise ratio (divided by its noise, the least-squares
    # weight) up to MAX_SNR, beyond which outputs weigh alike (as clean ones always did): at equal
    # weight per output, the 15 in-plane channels of an axis blow on the three-body stand, noise
    # at 6-8x their own scatter, hid its vertical modes (SNR 300-600) from every model order; an
    # output that never responds carries nothing
    peak = np.abs(H).max(axis=1, keepdims=True)
    H, peak = H[peak[:, 0] > 0], peak[peak[:, 0] > 0]
    H = H / np.maximum(frf_noise(H), peak / MAX_SNR)
    if not H.shape[0]:
        raise ConfigError("no output responds on the given band")
    R, S, T = normal_matrices(X, H)
    reduced = _reduced_normal(R, S, T)
    orders, poles, stable_f, stable = [], [], [], []
    prev = np.array([], dtype=complex)
    for m in range(min_order, max_order + 1, step):
        k = m + 1
        Mm = reduced(k)
        alpha = np.append(np.linalg.lstsq(Mm[:m, :m], -Mm[:m, m], rcond=None)[0], 1.0)
        z = np.roots(alpha[::-1])
        z = z[np.isfinite(z) & (z != 0)]
        lam = physical_poles(np.log(z.astype(complex)) / ts, (freq[0], freq[-1]), max_damping)
        sf, sz = stability_flags(prev, lam, tol_f, tol_zeta)
        orders.append(m)
        poles.append(lam)
        stable_f.append(sf)
        stable.append(sz)
        prev = lam
    return StabilisationDiagram(orders, poles, stable_f, stable, (float(freq[0]), float(freq[-1])))


#: an output's peak over its noise (``frf_noise``) beyond which LSCF weighs it as any other: a
#: noise-free or smooth FRF (median second difference near 0) does not take the whole fit
MAX_SNR = 1000.0


def frf_noise(H: np.ndarray) -> np.ndarray:
    """Per output (rows of ``H``), the noise's standard deviation per line (outputs x 1), from the
    median second difference between neighbouring lines: a resonance resolved over several lines
    changes smoothly there, independent noise of std s per line gives a complex second difference
    of std sqrt(6) s, whose magnitude (Rayleigh) has median sqrt(6 ln 4 / 2) s."""
    d2 = np.abs(H[:, 2:] - 2 * H[:, 1:-1] + H[:, :-2])
    return np.median(d2, axis=1, keepdims=True) / np.sqrt(3 * np.log(4))


def zeta_of(pole: complex) -> float:
    return -pole.real / abs(pole)


def pole_of(f_hz: float, zeta: float) -> complex:
    wn = 2 * np.pi * f_hz
    return complex(-zeta * wn, wn * np.sqrt(1 - zeta**2))


def select_poles(
    diagram: StabilisationDiagram,
    *,
    frequencies: list[float] | None = None,
    tol: float = 0.005,
    min_fraction: float = 0.3,
    bandwidth: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Poles picked from the diagram and, per pole, the number of model orders with a stable pole
    in its cluster. Automatic: stable poles clustered in frequency (within ``tol``), clusters
    stable in at least ``min_fraction`` of the orders (and 3), each represented by its median
    frequency and damping: a physical pole reappears as the order grows, numerical poles wander.
    With ``frequencies`` (Hz): the cluster of stable poles nearest each given frequency (within
    2 %), so a user can override the choice. Automatic picks drop poles whose half-power band
    reaches past the diagram's band (``half_power_inside``)."""
    f_all, z_all, o_all, _ = stable_points(diagram)
    if frequencies is not None:
        out, counts = [], []
        for fr in frequencies:
            near = np.abs(f_all - fr) <= 0.02 * fr
            if not near.any():
                raise ConfigError(f"no stable pole within 2 % of {fr} Hz in the stabilisation diagram")
            centre = f_all[near][np.argmin(np.abs(f_all[near] - fr))]
            cl = np.abs(f_all - centre) <= tol * centre
            out.append(pole_of(np.median(f_all[cl]), np.median(z_all[cl])))
            counts.append(np.unique(o_all[cl]).size)
        out, counts = np.asarray(out), np.asarray(counts)
        order = np.argsort(np.abs(out))
        return out[order], counts[order]
    out, counts, _ = stable_clusters(f_all, z_all, o_all, len(diagram.orders), tol, min_fraction, bandwidth)
    inside = half_power_inside(out, diagram.f_band)
    return distinct_poles(out[inside], counts[inside], tol, bandwidth)


def stable_points(diagram: StabilisationDiagram, shapes: list[np.ndarray] | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """The diagram's stable poles as frequencies (Hz), damping ratios and model orders, and with
    ``shapes`` (per order, outputs x poles) their shapes (outputs x stable poles; else None)."""
    f_all, z_all, o_all, phi = [], [], [], []
    for k, (order, poles, st) in enumerate(zip(diagram.orders, diagram.poles, diagram.stable, strict=True)):
        f_all.extend(np.abs(poles[st]) / (2 * np.pi))
        z_all.extend(-poles[st].real / np.abs(poles[st]))
        o_all.extend([order] * int(st.sum()))
        if shapes is not None:
            phi.extend(shapes[k][:, i] for i in np.flatnonzero(st))
    if shapes is not None:
        phi = np.column_stack(phi) if phi else np.empty((shapes[0].shape[0], 0), complex)
    return np.asarray(f_all), np.asarray(z_all), np.asarray(o_all), phi if shapes is not None else None


#: neighbouring poles whose shapes agree this well (MAC) and whose frequencies lie within each
#: other's half-power band are one mode: a heavily damped pole's estimates spread over several
#: orders' worth of frequency and the clusters can split it (the thesis rig's 16 %-damped 227 Hz
#: mode as 227.0 and 228.3 Hz, MAC 1.00), while two close modes have distinct shapes (its 97.4 and
#: 98.3 Hz pair: MAC 0.33)
SAME_MODE_MAC = 0.9


def stable_clusters(f_all, z_all, o_all, n_orders: int, tol: float, min_fraction: float,
                    bandwidth: float, shapes: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """``select_poles``' clusters of stable poles (frequencies ``f_all`` Hz, damping ratios
    ``z_all`` at orders ``o_all``) that are stable in enough of ``n_orders`` orders, as poles and
    their counts of orders, before the band-edge rule (``half_power_inside``). In ascending
    frequency a pole joins the cluster begun nearest below it within ``tol``, else within
    ``cluster_tol`` (a wide pole's estimates wander by a fraction of its half-power band).

    With ``shapes`` (outputs x stable poles, as ``stable_points``) a pole beyond ``tol`` joins a
    cluster only when its shape agrees with the cluster's at its highest order (``SAME_MODE_MAC``;
    a low order's shape of a close pair is a mixture), the best agreeing of those in reach: two
    close modes have distinct shapes (the thesis rig's 97.4 / 98.3 Hz pair: MAC 0.06-0.33) and stay
    two clusters however close. The third value is then each cluster's shape (outputs x poles, from
    its highest order within ``tol`` of its median frequency: a wanderer's ends may be mixtures);
    without shapes it is None."""
    order = np.argsort(f_all, kind="stable")
    f_all, z_all, o_all = f_all[order], z_all[order], o_all[order]
    phi = None if shapes is None else shapes[:, order]
    clusters: list[list[int]] = []
    for i, f in enumerate(f_all):
        if clusters and f - f_all[clusters[-1][0]] <= tol * f:
            clusters[-1].append(i)  # within tol: one pole whatever its shape
            continue
        best, best_mac = None, SAME_MODE_MAC
        for c in reversed(clusters):  # begun in ascending frequency: the nearest first
            if f - f_all[c[0]] > cluster_tol(tol, z_all[i], bandwidth) * f:
                break
            m = 1.0 if phi is None else mac(phi[:, i], phi[:, max(c, key=lambda k: o_all[k])])[0, 0]
            if m > best_mac or (best is None and m >= best_mac):  # ties: the nearest
                best, best_mac = c, m
        if best is None:
            clusters.append([i])
        else:
            best.append(i)
    need = max(3, int(np.ceil(min_fraction * n_orders)))
    out, counts, rep = [], [], []
    for c in map(np.asarray, clusters):
        n = np.unique(o_all[c]).size
        if n >= need and cluster_consistent(f_all[c], z_all[c], tol):
            f_mid = np.median(f_all[c])
            out.append(pole_of(f_mid, np.median(z_all[c])))
            counts.append(n)
            if phi is not None:
                near = c[np.abs(f_all[c] - f_mid) <= tol * f_mid]
                near = near if near.size else c
                rep.append(phi[:, near[np.argmax(o_all[near])]])
    if phi is not None:
        rep = np.column_stack(rep) if rep else np.empty((phi.shape[0], 0), complex)
    return np.asarray(out, dtype=complex), np.asarray(counts, dtype=int), rep if phi is not None else None


def half_power_band(poles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each pole's half-power band f (1 -+ 2 zeta), Hz."""
    f, z = np.abs(poles) / (2 * np.pi), zeta_of(poles)
    return f * (1 - 2 * z), f * (1 + 2 * z)


def half_power_inside(poles: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    """Which poles have their half-power band inside ``band``: a resonance is seen in the fit only
    then; a 12 %-damped pole 10 Hz above the bottom of the LADISK beam's 50-500 Hz fit is an edge
    effect."""
    a, b = half_power_band(np.asarray(poles, dtype=complex))
    return (band[0] <= a) & (b <= band[1])


#: a pole's estimates over model orders scatter by a fraction of its half-power bandwidth
#: (2 zeta f), not by a fixed fraction of f: the thesis rig's 16 %-damped 222 Hz mode wanders
#: 219.7-225.0 Hz over 19 stable orders, far beyond 0.5 %. Clusters span up to this fraction of
#: the half-bandwidth zeta f (0.25: 4 % of f at 16 % damping, 0.5 % stays the floor below 2 %).
CLUSTER_BANDWIDTH = 0.25


def cluster_tol(tol: float, zeta, bandwidth: float) -> float:
    """Relative frequency tolerance of a cluster of stable poles of damping ratio ``zeta``
    (``bandwidth``: the fraction of the half-bandwidth a cluster may span; 0: ``tol`` alone, as
    output-only analysis keeps it: there merged poles of a record too short must not pass as one)."""
    return max(tol, bandwidth * float(np.max(zeta)))


#: a cluster wider than the fixed tolerance is a pole only when its damping agrees over the orders
#: (interquartile range within this fraction of the median): the thesis rig's 222 Hz mode 2 %; a
#: numerical pole near the LADISK beam's 50 Hz band edge drifts from 6 to 10 % (32 %)
CLUSTER_DAMPING_SPREAD = 0.2


def cluster_consistent(f: np.ndarray, zeta: np.ndarray, tol: float) -> bool:
    if f[-1] - f[0] <= tol * f[-1]:
        return True
    q1, q3 = np.percentile(zeta, [25, 75])
    return q3 - q1 <= CLUSTER_DAMPING_SPREAD * np.median(zeta)


def distinct_poles(poles: np.ndarray, stable_orders: np.ndarray, tol: float, bandwidth: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """One pole per cluster: clusters are chained from their lowest member, so one physical pole
    whose estimates spread over more than ``tol`` can come out twice, a hair apart (the thesis
    rig's 222 Hz mode as 221.9 and 222.9 Hz); of neighbours within ``cluster_tol`` the one stable
    over more orders stays."""
    keep: list[int] = []
    zeta = -poles.real / np.maximum(np.abs(poles), np.finfo(float).tiny)
    for r in range(poles.size):
        near = cluster_tol(tol, (zeta[r], zeta[keep[-1]]) if keep else zeta[r], bandwidth)
        if keep and abs(abs(poles[r]) - abs(poles[keep[-1]])) <= near * abs(poles[r]):
            if stable_orders[r] > stable_orders[keep[-1]]:
                keep[-1] = r
            continue
        keep.append(r)
    return poles[keep], stable_orders[keep]


def _lsfd_basis(freq: np.ndarray, poles: np.ndarray, form: str, residuals: bool = True) -> np.ndarray:
    """Real-coefficient basis (lines x columns, complex): Re A_r, Im A_r per pole, then the lower
    (1/(i w)^2) and upper (constant) residuals in receptance terms, times (i w)^p."""
    if form not in FORM_POWER:
        raise ConfigError(f"FRF form {form!r} is not one of {', '.join(FORM_POWER)}")
    iw = 2j * np.pi * np.asarray(freq, dtype=float)[:, None]
    a = 1 / (iw - poles[None, :])
    b = 1 / (iw - poles.conj()[None, :])
    cols = [a + b, 1j * (a - b)]  # real and imaginary part of A_r
    if residuals:
        cols.append(1 / iw**2)
        cols.append(np.ones_like(iw))
    return np.hstack(cols) * iw ** FORM_POWER[form]


def _line_weights(H: np.ndarray) -> np.ndarray:
    """1 / the FRFs' level smoothed over 20 % of the lines: every part of the band counts alike in
    the least squares (a receptance of a free structure is 10^4 times larger at 1 Hz than at its
    modes, and its low-frequency noise would otherwise decide the residues)."""
    import scipy.ndimage

    level = np.sqrt(np.mean(np.abs(H) ** 2, axis=0))
    level = scipy.ndimage.median_filter(level, max(3, H.shape[1] // 5) | 1, mode="nearest")
    return 1.0 / np.maximum(level, np.finfo(float).tiny)


def _lsfd_coefficients(freq, H, poles, form, residuals: bool = True) -> np.ndarray:
    w = _line_weights(H)[:, None]
    P = _lsfd_basis(freq, poles, form, residuals) * w
    A = np.vstack([P.real, P.imag])
    B = np.vstack([(H.T * w).real, (H.T * w).imag])
    return np.linalg.lstsq(A, B, rcond=None)[0]


def _residues(coef: np.ndarray, n: int) -> np.ndarray:
    return (coef[:n] + 1j * coef[n : 2 * n]).T


def lsfd(
    freq: np.ndarray, H: np.ndarray, poles: np.ndarray, *, form: str = "accelerance", residuals: bool = True
) -> np.ndarray:
    """Complex residues (outputs x modes) of ``H = (i w)^p sum_r [A_r/(i w - l_r) + conj]`` plus
    real lower (1/(i w)^2) and upper (constant) residuals in receptance terms, p from ``form``."""
    freq, H = _check(freq, H)
    poles = np.asarray(poles, dtype=complex)
    return _residues(_lsfd_coefficients(freq, H, poles, form, residuals), poles.size)


def modal_terms(freq: np.ndarray, poles: np.ndarray, residues: np.ndarray, form: str = "accelerance") -> np.ndarray:
    """Each mode's own FRF term (outputs x frequencies x modes) in the given form:
    (i w)^p [A_r/(i w - l_r) + conj(A_r)/(i w - conj l_r)]."""
    iw = 2j * np.pi * np.asarray(freq, dtype=float)[:, None]
    poles = np.asarray(poles, dtype=complex)[None, :]
    A = np.asarray(residues, dtype=complex)[:, None, :]
    terms = A / (iw - poles)[None] + A.conj() / (iw - poles.conj())[None]
    return terms * (iw ** FORM_POWER[form])[None]


#: A pole's own term must make up at least this fraction of the measured |H| at its resonance
#: (largest over the outputs): a lone mode gives 1, two equal modes a bandwidth apart 0.79; a
#: pole fitted to noise explains little.
MIN_DOMINANCE = 0.5
#: |H| at the pole over |H| at 3 half-power bandwidths either side, largest over the outputs,
#: must reach this: a lone mode's own term has fallen to 16 % there, so a measured FRF that is
#: higher on a side rises away from the pole (anti-resonance flank: 0.37 for the spurious
#: 1202 Hz pole of the LADISK beam, 1.4 for its weakest real mode at 2777 Hz).
MIN_PROMINENCE = 1.0
#: Largest relative rms misfit of the synthesised FRF within +-3 half-power bandwidths of a pole
#: (measured modes of the LADISK beam fit to 1-6 %).
MAX_SYNTHESIS_ERROR = 0.3


def check_poles(
    freq: np.ndarray, H: np.ndarray, poles: np.ndarray, form: str = "accelerance"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """FRF-synthesis check per pole: (dominance, synthesis error, prominence). Dominance is the
    largest over the outputs of |own term| / |measured H| at the pole's frequency; the synthesis
    error is ||H_synth - H|| / ||H|| over the lines within 3 half-power bandwidths (at least 3
    lines) of it, H_synth being the sum of every selected pole's term plus the LSFD residual
    terms; prominence: see ``MIN_PROMINENCE``."""
    freq, H = _check(freq, H)
    poles = np.asarray(poles, dtype=complex)
    coef = _lsfd_coefficients(freq, H, poles, form)
    synth = (_lsfd_basis(freq, poles, form) @ coef).T
    terms = modal_terms(freq, poles, _residues(coef, poles.size), form)
    tiny = np.finfo(float).tiny
    dominance, error, prominence = np.zeros(poles.size), np.zeros(poles.size), np.zeros(poles.size)
    for r, p in enumerate(poles):
        f0 = abs(p) / (2 * np.pi)
        i = int(np.argmin(np.abs(freq - f0)))
        dominance[r] = np.max(np.abs(terms[:, i, r]) / np.maximum(np.abs(H[:, i]), tiny))
        half = max(3 * (-p.real / (2 * np.pi)) * 2, 1.5 * np.median(np.diff(freq)))  # 3 bandwidths 2 zeta f
        near = np.abs(freq - f0) <= half
        error[r] = np.linalg.norm(synth[:, near] - H[:, near]) / max(np.linalg.norm(H[:, near]), tiny)
        at = [np.interp(f0 + d, freq, np.abs(h)) for h in H for d in (-half, 0.0, half)]
        at = np.reshape(at, (H.shape[0], 3))
        prominence[r] = np.max(at[:, 1] / np.maximum(at[:, [0, 2]].max(axis=1), tiny))
    return dominance, error, prominence


def normalise_shapes(residues: np.ndarray) -> np.ndarray:
    """Scale each column to a largest entry of exactly 1 (rotates the phase too)."""
    r = np.asarray(residues, dtype=complex)
    idx = np.argmax(np.abs(r), axis=0)
    return r / r[idx, np.arange(r.shape[1])]


#: each fit band's top is this factor below the previous one's while the next band holds 2 x the
#: model order in lines; below that, halved while its fit still holds more lines than the order
#: (see ``nested_fits``)
NEST_RATIO = 4.0


def nested_fits(f: np.ndarray, h: np.ndarray, max_order: int, frequencies: list[float] | None = None
                ) -> tuple[StabilisationDiagram, np.ndarray, np.ndarray]:
    """LSCF on the whole band and on bands from its bottom to a top ``NEST_RATIO`` lower each time
    (while one holds 2 x ``max_order`` lines), then half as high each time while a band's fit, up to
    sqrt(ratio) x its top, holds more lines than ``max_order`` (LSCF's own need); each fit keeps the
    poles between its top and the next fit's top. One common denominator over 0.5-900 Hz misses the
    plate-and-motor rig's suspension modes at 10-30 Hz (z = exp(i w Ts) crowded near 1,
    accelerance 100 x lower there) that a fit up to 56 Hz finds; the block rig's 5-10 %-damped
    modes at 22-60 Hz (2.27 Hz lines, 0.3 % noise) come from no order of the fit up to 510 Hz and
    from one up to 180 Hz. Returns the joined diagram and the selected poles."""
    tops, ratios = [f[-1]], [NEST_RATIO]
    while np.count_nonzero(f <= tops[-1] / NEST_RATIO) >= 2 * max_order:
        tops.append(tops[-1] / NEST_RATIO)
        ratios.append(NEST_RATIO)
    while np.count_nonzero(f <= tops[-1] / np.sqrt(2.0)) > max_order:
        tops.append(tops[-1] / 2.0)
        ratios.append(2.0)
    parts, poles, counts, wider = [], [], [], []
    for k, top in enumerate(tops):
        floor = tops[k + 1] if k + 1 < len(tops) else -np.inf
        n = f <= top * np.sqrt(ratios[k])  # beyond its top: a pole just below it keeps its flanks
        top = top if k else np.inf  # frequencies asked for outside the band: the whole band's fit says so
        d = lscf(f[n], h[:, n], max_order)
        own = [(np.abs(p) / (2 * np.pi) > floor) & (np.abs(p) / (2 * np.pi) <= top) for p in d.poles]
        parts.append([(p[o], sf[o], st[o]) for p, sf, st, o in zip(d.poles, d.stable_f, d.stable, own)])
        asked = None if frequencies is None else [v for v in frequencies if floor < v <= top]
        if asked is not None and not asked:
            continue
        p, c = select_poles(d, frequencies=asked, bandwidth=CLUSTER_BANDWIDTH)
        mine = (np.abs(p) / (2 * np.pi) > floor) & (np.abs(p) / (2 * np.pi) <= top)
        if asked is None:
            p[mine], c[mine] = _steadiest(p[mine], c[mine], wider)
            wider.append((p, c))
        poles.append(p[mine])
        counts.append(c[mine])
    orders = list(range(2, max_order + 1))
    joined = [[np.concatenate(x) for x in zip(*[part[i] for part in parts[::-1]])] for i in range(len(orders))]
    diagram = StabilisationDiagram(orders, [j[0] for j in joined], [j[1] for j in joined], [j[2] for j in joined],
                                   (float(f[0]), float(f[-1])))
    poles, counts = np.concatenate(poles), np.concatenate(counts).astype(int)
    order = np.argsort(np.abs(poles))
    return diagram, poles[order], counts[order]


#: a narrower band's pole and a wider band's within this fraction of each other are one pole: the
#: clusters' own width (``select_poles``' tol)
SAME_POLE = 0.005


def _steadiest(poles: np.ndarray, counts: np.ndarray, wider: list[tuple[np.ndarray, np.ndarray]]
               ) -> tuple[np.ndarray, np.ndarray]:
    """Each pole of a band, or the same pole (within ``SAME_POLE``) as a wider band's fit selected
    it where that fit is stable over at least as many orders: a mode is taken from the diagram that
    shows it most steadily (the thesis rig's 15 %-damped 217 Hz mode: 45 of 49 orders over its
    whole band, 19 over 0-390 Hz); a narrower band only adds what the wider ones miss. Not within
    ``cluster_tol``: a wide fit's cluster 2 % below the block rig's 43.8 Hz mode (8 % damped, 30
    orders) blends it with its 40.0 Hz neighbour."""
    poles, counts = poles.copy(), counts.copy()
    for r, p in enumerate(poles):
        for wp, wc in wider:
            near = np.abs(np.abs(wp) - abs(p)) <= SAME_POLE * abs(p)
            if near.any():
                j = np.flatnonzero(near)[np.argmax(wc[near])]
                if wc[j] >= counts[r]:
                    poles[r], counts[r] = wp[j], wc[j]
    return poles, counts


def identify_modes(
    freq: np.ndarray,
    H: np.ndarray,
    *,
    f_band: tuple[float | None, float | None] | None = None,
    max_order: int = 50,
    frequencies: list[float] | None = None,
    form: str = "accelerance",
    window_tau: float | None = None,
    output_names: list[str] | None = None,
    force_autospectrum: np.ndarray | None = None,
    coherence: np.ndarray | None = None,
    n_averages: int = 1,
    where: str = "identify_modes",
) -> ModalResult:
    """LSCF stabilisation diagram -> pole selection -> LSFD residues on the band ``f_band``
    (default, also for an edge given as None: ``frf.usable_band`` of the force autospectrum and
    coherence when given, else the whole FRF without 0 Hz). Automatic selection then drops poles that fail ``check_poles`` (named
    in ``rejected``); poles asked for with ``frequencies`` are kept. ``window_tau`` (s): the FRFs
    were measured with an exponential window of that time constant; the reported poles have its
    damping removed. ``where``: the function named when an argument is refused."""
    max_order, frequencies, f_band = fit_arguments(where, max_order, frequencies, f_band)
    freq, H = _check(freq, H)
    lo, hi = f_band if f_band is not None else (None, None)
    if lo is None or hi is None:
        data_lo, data_hi = usable_band(freq, force_autospectrum, coherence, n_averages)
        lo, hi = data_lo if lo is None else lo, data_hi if hi is None else hi
    # a band edge past the last line (at the Nyquist frequency, within a line) was cut there without a word
    if len(freq) > 1 and max(lo, hi) > freq[-1] + (freq[-1] - freq[-2]):
        raise ConfigError(f"band {lo:.5g}-{hi:.5g} Hz: the FRFs end at {freq[-1]:.5g} Hz, the Nyquist frequency; "
                          f"give --fmin and --fmax within it")
    keep = (freq >= lo) & (freq <= hi) & (freq > 0)
    if keep.sum() <= max_order:
        raise ConfigError(f"band {lo:.4g}-{hi:.4g} Hz holds {keep.sum()} lines; model order {max_order} needs more")
    f, h = freq[keep], H[:, keep]
    diagram, poles, stable_orders = nested_fits(f, h, max_order, frequencies)
    rejected: list[str] = []
    while frequencies is None and poles.size:
        dominance, error, prominence = check_poles(f, h, poles, form)
        # how far each pole is from passing (> 1: fails); drop the worst only, as its removal
        # changes the others' fit
        shortfall = np.stack([MIN_DOMINANCE / np.maximum(dominance, 1e-12), error / MAX_SYNTHESIS_ERROR,
                              MIN_PROMINENCE / np.maximum(prominence, 1e-12)])
        if shortfall.max() <= 1:
            break
        worst = int(np.argmax(shortfall.max(axis=0)))
        why = [f"its own term explains {100 * dominance[worst]:.0f} % of |H| there",
               f"synthesis misfit {100 * error[worst]:.0f} % near it",
               f"|H| there is {prominence[worst]:.2f} x its level 3 bandwidths away (no peak: anti-resonance "
               "flank or noise)"][int(np.argmax(shortfall[:, worst]))]
        rejected.append(f"{abs(poles[worst]) / (2 * np.pi):.2f} Hz: {why}")
        poles, stable_orders = np.delete(poles, worst), np.delete(stable_orders, worst)
    if poles.size == 0 and rejected:
        # stable poles were found: said "no stable poles", it read as if the record held nothing
        raise ConfigError(f"no mode passed its checks in {lo:.4g}-{hi:.4g} Hz (lines {f[1] - f[0]:.3g} Hz apart: "
                          f"modes closer than a few lines are not separated); stable poles rejected: "
                          f"{'; '.join(rejected)}")
    if poles.size == 0:
        raise ConfigError(f"no stable poles found in {lo:.4g}-{hi:.4g} Hz up to model order {max_order}")
    res = lsfd(f, h, poles, form=form)
    if window_tau is not None:
        poles = poles + 1.0 / window_tau  # the structure's own poles (see hammer.correct_exponential_window)
    return ModalResult(poles, res, normalise_shapes(res), list(output_names or []), diagram,
                       (float(f[0]), float(f[-1])), stable_orders, rejected)


def fit_arguments(where: str, max_order: Any, frequencies: Any, f_band: Any
                  ) -> tuple[int, list[float] | None, tuple[float | None, float | None] | None]:
    """The fit's options checked before it runs: an order below 2 grew the nested bands without end
    (memory too), a text order, a NaN or a negative frequency raised inside the fit."""
    max_order = arguments.whole(where, "max_order", max_order, low=2)
    if frequencies is not None:
        frequencies = [arguments.real(where, "frequencies", f, positive=True)
                       for f in arguments.listed(where, "frequencies", frequencies, "frequencies in Hz")]
    if f_band is not None:
        edges = arguments.listed(where, "f_band", f_band, "two frequencies (low, high) in Hz")
        if len(edges) != 2:
            arguments.refuse(where, "f_band", f_band, "two frequencies (low, high) in Hz, either may be None")
        f_band = tuple(None if v is None else arguments.real(where, "f_band", v, minimum=0) for v in edges)
    return max_order, frequencies, f_band


def frequency_labels(freqs) -> list[str]:
    """"f Hz" labels with four significant digits of the lowest frequency (a building's "1.882 Hz",
    a plate's "279.3 Hz") and more decimals where two labels would be the same (2.7771 and
    2.7774 Hz), 1 to 4 decimals."""
    f = [float(v) for v in np.atleast_1d(freqs)]
    text: list[str] = []
    lowest = min((abs(v) for v in f if v), default=1.0)
    for d in range(min(4, max(1, 3 - math.floor(math.log10(lowest)))), 5):
        text = [f"{v:.{d}f}" for v in f]
        if len(set(text)) == len(text):
            break
    return [f"{t} Hz" for t in text]


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


def mpc(phi: np.ndarray) -> float:
    """Modal phase collinearity (Pappa, Elliott & Schenk 1993): ((l1 - l2) / (l1 + l2))^2 of the
    eigenvalues of the real and imaginary parts' 2 x 2 scatter matrix; 1 for a real (normal) mode,
    0 for a travelling wave."""
    phi = np.asarray(phi, dtype=complex)
    x, y = phi.real, phi.imag
    sxx, syy, sxy = x @ x, y @ y, x @ y
    l1, l2 = np.linalg.eigvalsh(np.array([[sxx, sxy], [sxy, syy]]))[::-1]
    return float(((l1 - l2) / (l1 + l2)) ** 2) if l1 + l2 > 0 else 1.0


def mpd(phi: np.ndarray) -> float:
    """Mean phase deviation (degrees): the amplitude-weighted mean angle between each entry and
    the shape's best straight line through the origin in the complex plane (0 for a real mode)."""
    phi = np.asarray(phi, dtype=complex)
    w = np.abs(phi)
    if not w.sum():
        return 0.0
    _, _, vt = np.linalg.svd(np.c_[phi.real, phi.imag], full_matrices=False)
    d = vt[0]  # the best line's direction
    cos = np.abs(phi.real * d[0] + phi.imag * d[1]) / np.maximum(w, np.finfo(float).tiny)
    return float(np.degrees(np.sum(w * np.arccos(np.clip(cos, 0, 1))) / w.sum()))


def pair_modes(
    f_a: np.ndarray,
    zeta_a: np.ndarray,
    f_b: np.ndarray,
    zeta_b: np.ndarray,
    *,
    shapes_a: np.ndarray | None = None,
    shapes_b: np.ndarray | None = None,
    within: float | None = None,
) -> list[dict]:
    """Pair modes of A (e.g. test) with modes of B (model or another test): by the best MAC when
    both shapes are given, else by nearest frequency; one-to-one, best pairs first. Rows hold both
    frequencies and dampings, their differences (B - A, relative to A) and the MAC. ``within``: only
    modes whose frequencies differ by at most this fraction pair (a mode of B far away, alike in
    shape, otherwise took a measured mode from its partner 0.4 % away)."""
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
        if within is not None and abs(f_b[j] - f_a[i]) > within * f_a[i]:
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
