"""Simulation of a model to a sampled input record: a linear one by exact discretisation, one
with cubic springs by a fixed-step exponential integrator (:func:`simulate_nonlinear`).

The state space is split into its modes (x = V z); each mode and input is a first-order complex
recursion ``z[k+1] = p z[k] + ...`` with ``p = exp(lambda T)`` whose hold-exact coefficients are the phi
functions of ``lambda T``; scipy.signal.lfilter runs it in C as two real second-order filters. One
mode of each conjugate pair is run and its real part doubled. Zero-order hold (input constant over a sample, scipy
``lsim(..., interp=False)``) and first-order hold (linear between samples, ``lsim`` default) are
exact, not approximations. A sampled record stands for a band-limited signal (a recorder's
anti-aliasing filter makes it one); a hold loses part of its content near the top of the band (the
first-order hold sinc^2(f/fs): 7 % at 300 Hz at 2048 samples/s), so the ``band`` hold drives the
model with the band-limited signal itself (:func:`band_limited`). When the mode matrix is ill-conditioned (nearly repeated, defective
eigenvalues) the matrix-exponential discretisation (as in scipy.signal.lsim) is used, slowly.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import scipy  # scipy.signal and scipy.linalg load on first use: fast `odsuite plugins`

from odsuite.domain.errors import ConfigError, DimensionError, DivergedError
from odsuite.domain.model import Model, StateSpace

HOLDS = ("zoh", "foh", "band")
#: points per sample of the band-limited input: the first-order hold between them is equalised
#: exactly within the band, and what is left (its images near multiples of the fine rate, aliased
#: back) is 1e-4 of a 300 Hz oscillator's response at 2048 samples/s, 1.1e-3 at 800 Hz (4 points:
#: 7e-5 and 4.6e-4, for twice the simulation's cost; the first-order hold of the samples: 6.9 %
#: and 26 %)
BAND_OVERSAMPLE = 2
#: above this condition number of the mode matrix, fall back to the matrix exponential
MAX_MODAL_CONDITION = 1e8


def _phi(x: np.ndarray, k: int) -> np.ndarray:
    """phi_k(x) = sum_j x^j / (j + k)!, k = 1, 2 (phi_1 = (e^x - 1)/x, phi_2 = (e^x - 1 - x)/x^2),
    by series where the closed form cancels."""
    x = np.asarray(x, dtype=complex)
    small = np.abs(x) < 0.5
    out = np.empty_like(x)
    xs = x[small]
    term = np.full_like(xs, 1.0 / math.factorial(k))
    acc = term.copy()
    for j in range(1, 25):
        term = term * xs / (j + k)
        acc += term
    out[small] = acc
    xl = x[~small]
    e = np.exp(xl)
    out[~small] = (e - 1) / xl if k == 1 else (e - 1 - xl) / xl**2
    return out


def check_input_record(u, n_inputs: int) -> np.ndarray:
    """``u`` as an (n_samples, n_inputs) float array, or a DimensionError naming the shapes."""
    u = np.asarray(u, dtype=float)
    if u.ndim == 1:
        u = u[:, None]
    if u.ndim != 2 or u.shape[1] != n_inputs:
        raise DimensionError(f"input record has shape {u.shape}; expected (n_samples, {n_inputs}) for {n_inputs} input(s)")
    if not np.all(np.isfinite(u)):
        raise DimensionError("input record contains NaN or infinite values")
    return u


def band_limited(u: np.ndarray, factor: int) -> np.ndarray:
    """The samples ``u`` (n x inputs) as the band-limited signal they imply (ideal interpolation,
    by their zero-padded spectrum), at ``factor`` points per sample ((n - 1) factor + 1 rows; row
    k factor is sample k), each line divided by sinc^2(f / (factor fs)): driven linearly between
    these points, a model sees the band-limited signal's spectrum."""
    n = len(u)
    m = 2 * n  # zero padding: a hit's interpolation tails do not wrap onto the record's start
    spec = np.fft.rfft(u, n=m, axis=0)
    spec /= np.sinc(np.fft.rfftfreq(m) / factor)[:, None] ** 2
    spec[-1] *= 0.5  # the Nyquist line is half at +fs/2, half at -fs/2 in the longer spectrum
    return np.fft.irfft(spec, n=m * factor, axis=0)[: (n - 1) * factor + 1] * factor


#: the band-limited inputs last computed, by their samples: a fit simulates one force record
#: hundreds of times with other models, and the input's transforms were a tenth of its cost
_BAND_INPUTS: dict[tuple, np.ndarray] = {}
BAND_INPUTS_KEPT = 32


def _band_input(u: np.ndarray, factor: int) -> np.ndarray:
    """:func:`band_limited` of ``u``, kept (read-only) for the next simulation of the same record."""
    key = (u.shape, factor, u.tobytes())
    out = _BAND_INPUTS.pop(key, None)
    if out is None:
        out = band_limited(u, factor)
        out.flags.writeable = False
        while len(_BAND_INPUTS) >= BAND_INPUTS_KEPT:
            _BAND_INPUTS.pop(next(iter(_BAND_INPUTS)))
    _BAND_INPUTS[key] = out  # the most recent last: the oldest goes first
    return out


def _simulate_band(ss: StateSpace, u: np.ndarray, fs: float) -> np.ndarray:
    """Response at the samples to the band-limited signal ``u`` implies: the states by a
    first-order hold of :func:`band_limited` on the fine grid, the feed-through at the samples
    (there the band-limited signal is ``u`` itself)."""
    f = BAND_OVERSAMPLE
    T = 1.0 / (fs * f)
    modal = _modal(ss.A, T)
    states = StateSpace(ss.A, ss.B, ss.C, np.zeros_like(ss.D))
    fine = _band_input(u, f)
    y = (_simulate_expm(states, fine, T, "foh") if modal is None else _simulate_modal(states, fine, modal, "foh"))[::f]
    return y + u @ np.asarray(ss.D, float).T


#: the modal decompositions last computed, by their system matrix and sample time: the experiments
#: of a fit simulate one model each, every one with the same A (a tenth of an evaluation's CPU), and a
#: linearised Jacobian decomposes each of its columns' models for every experiment
_MODALS: dict[tuple, tuple | None] = {}
MODALS_KEPT = 32


def _modal(A: np.ndarray, T: float) -> tuple | None:
    """The balanced modal form of ``A`` at sample time ``T``: balancing scale, mode matrix, the
    modes kept (one of each conjugate pair), their weights, eigenvalues, poles and phi terms; None
    where the mode matrix is ill-conditioned (the matrix exponential then)."""
    key = (A.shape, A.tobytes(), T, MAX_MODAL_CONDITION)
    if key in _MODALS:
        return _MODALS[key]
    # balancing keeps the mode matrix well conditioned when states differ widely in scale
    Ab, (scale, _) = scipy.linalg.matrix_balance(A, permute=False, separate=True)
    lam, V = np.linalg.eig(Ab)
    out = None
    pair = lam.imag > 0
    real = lam.imag == 0
    # eig of a real matrix returns exact conjugates
    if np.linalg.cond(V) <= MAX_MODAL_CONDITION and 2 * pair.sum() + real.sum() == len(lam):
        keep = pair | real
        lk = lam[keep]
        x = lk * T
        # all modes at once: a call per mode costs more
        out = (scale, V, keep, np.where(pair[keep], 2.0, 1.0), lk, np.exp(x), T * _phi(x, 1), T * _phi(x, 2))
        for a in out:
            a.flags.writeable = False
    while len(_MODALS) >= MODALS_KEPT:
        _MODALS.pop(next(iter(_MODALS)))
    _MODALS[key] = out
    return out


#: the poles' relative step for the modes' derivative signals (central differences: the step's
#: error (step x record length x |pole|)^2 against the recursion's round-off over the step)
POLE_STEP = 1e-6
#: a change of the poles is linear while each pole moves by less than this fraction of its
#: distance to the nearest other (nearly repeated modes exchange their shapes: the first-order
#: change of each alone is no guide to their sum)
LINEAR_POLE_MOVE = 1e-3


def _residues(ss: StateSpace, modal: tuple) -> np.ndarray:
    """Each kept mode's residue (outputs x modes x inputs): invariant to balancing and to the
    eigenvectors' scaling, so comparable between two decompositions of nearby systems."""
    scale, V, keep, weight = modal[:4]
    Bm = np.linalg.solve(V, (ss.B / scale[:, None]).astype(complex))[keep]
    Cm = ((ss.C * scale) @ V)[:, keep] * weight
    return Cm[:, :, None] * Bm[None, :, :]


def _eigen_changes(ss0: StateSpace, modal: tuple, others: Sequence[StateSpace]
                   ) -> tuple[np.ndarray, np.ndarray] | None:
    """Each of ``others``' change of the kept modes' eigenvalues (systems x modes) and residues
    (systems x outputs x modes x inputs, as :func:`_residues`) from ``ss0``'s (``modal``: its
    decomposition), to first order in the change of A, B and C: with E = V^-1 dA V in the
    balanced coordinates, d lambda_i = E_ii and the mode matrix moves to V (I + F), F_ji = E_ji /
    (lambda_i - lambda_j), its inverse to (I - F) V^-1: products of the one decomposition instead
    of one per system. None where a mode's shape would turn by more than LINEAR_POLE_MOVE towards
    another's (nearly repeated modes: the first order is no guide)."""
    scale, V, keep, weight, lk = modal[:5]
    if not others:
        return np.empty((0, len(lk)), complex), np.empty((0, ss0.C.shape[0], len(lk), ss0.B.shape[1]), complex)
    W = np.linalg.inv(V)
    balanced = scale[None, :] / scale[:, None]  # D^-1 X D
    lam = np.einsum("ij,ji->i", W, (ss0.A * balanced) @ V)  # every eigenvalue, conjugates too
    lam[keep] = lk
    E = W @ (np.stack([ss.A - ss0.A for ss in others]) * balanced) @ V
    apart = lam[None, :] - lam[:, None]  # [j, i]: lambda_i - lambda_j
    np.fill_diagonal(apart, np.inf)
    F = E / apart
    if not np.max(np.abs(F)) <= LINEAR_POLE_MOVE:
        return None
    dlam = np.diagonal(E, axis1=1, axis2=2)[:, keep]
    Bb, Cb = ss0.B / scale[:, None], ss0.C * scale
    WB, CV = W @ Bb, Cb @ V
    dWB = W @ (np.stack([ss.B - ss0.B for ss in others]) / scale[:, None]) - F @ WB
    dCV = (np.stack([ss.C - ss0.C for ss in others]) * scale) @ V + CV @ F
    dR = (dCV[:, :, keep, None] * WB[None, None, keep, :] + CV[None, :, keep, None] * dWB[:, None, keep, :]
          ) * weight[None, None, :, None]
    return dlam, dR


#: _mode_signals' coefficients last computed, by poles, sample time and inputs: a linearised
#: Jacobian runs one structure's poles on every experiment's records (their series cost more than
#: the recursions on a short head)
_MODE_COEFFICIENTS: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
MODE_COEFFICIENTS_KEPT = 16


def _mode_coefficients(lam: np.ndarray, T: float, ni: int) -> tuple[np.ndarray, np.ndarray]:
    """Each mode's pole over a step, and its numerator [b0, b1] once per input (modes x inputs
    rows), of the first-order-hold recursion of :func:`_mode_signals` (kept)."""
    key = (lam.tobytes(), T, ni)
    got = _MODE_COEFFICIENTS.get(key)
    if got is None:
        x = lam * T
        p, g0, g1 = np.exp(x), T * _phi(x, 1), T * _phi(x, 2)
        num = np.empty((len(lam) * ni, 2), complex)
        for i in range(len(lam)):  # in scalars, as lfilter was given them
            b0, b1 = g1[i], g0[i] - g1[i]
            for j in range(ni):
                num[i * ni + j] = b0, b1
        while len(_MODE_COEFFICIENTS) >= MODE_COEFFICIENTS_KEPT:
            _MODE_COEFFICIENTS.pop(next(iter(_MODE_COEFFICIENTS)))
        got = _MODE_COEFFICIENTS[key] = (p, num)
    return got


def _mode_signals(lam: np.ndarray, T: float, ut: np.ndarray, every: int) -> np.ndarray:
    """Each mode's complex first-order-hold recursion on each input row of ``ut`` from rest
    (modes x inputs x samples), every ``every``-th sample kept: ``lfilter([b0, b1], [1, -p], u,
    zi=[-b0 u[0]])`` per mode and input in one compiled call (recursions.first_order_rows)."""
    from odsuite.domain.recursions import first_order_rows  # numba loads on first use

    nm, ni = len(lam), len(ut)
    p, num = _mode_coefficients(lam, T, ni)
    zi = np.empty(nm * ni, complex)
    # mode by mode in scalars, as lfilter was given them
    for i in range(nm):
        b0 = num[i * ni, 0]
        for j in range(ni):
            zi[i * ni + j] = -b0 * ut[j, 0]
    out = np.empty((nm, ni, len(range(0, ut.shape[1], every))), complex)
    first_order_rows(num, np.repeat(p, ni), zi, np.tile(np.arange(ni), nm), ut, every, out.reshape(nm * ni, -1))
    return out


def linearised_band(ss0: StateSpace, others, u, fs: float) -> tuple[np.ndarray, list[np.ndarray]] | None:
    """The change of the ``band``-hold response to ``u`` from ``ss0``'s to each of ``others``'
    (systems of its size near it), to first order in their poles and residues, as one set of
    signals and a matrix per system: change = basis @ matrix (samples x outputs). The basis is the
    modes' signals and their derivatives in the pole (real and imaginary parts) and ``u`` (the
    feed-through), run once for all systems (a finite-difference Jacobian's columns without a
    simulation each); the poles' and residues' changes from ``ss0``'s decomposition alone
    (:func:`_eigen_changes`). None where that decomposition is ill-conditioned or nearly repeated
    poles move or exchange shapes."""
    f = BAND_OVERSAMPLE
    T = 1.0 / (fs * f)
    u = check_input_record(u, ss0.B.shape[1])
    m0 = _modal(ss0.A, T)
    if m0 is None:
        return None
    lam0 = m0[4]
    poles = np.concatenate([lam0, np.conj(lam0[lam0.imag != 0])])
    dist = np.abs(lam0[:, None] - poles[None, :])
    dist[np.arange(len(lam0)), np.arange(len(lam0))] = np.inf
    gap = dist.min(axis=1)
    R0 = _residues(ss0, m0)
    others = list(others)
    changes = _eigen_changes(ss0, m0, others)
    if changes is None:
        return None
    matrices = []
    for ss, dlam, dR in zip(others, *changes):
        if np.any(np.abs(dlam) > LINEAR_POLE_MOVE * gap):
            return None
        no = R0.shape[0]
        dR = dR.reshape(no, -1).T  # (modes x inputs) x outputs
        dP = (R0 * dlam[None, :, None]).reshape(no, -1).T
        # Re(a z) = Re a Re z - Im a Im z
        matrices.append(np.vstack([dR.real, -dR.imag, dP.real, -dP.imag,
                                   (np.asarray(ss.D, float) - np.asarray(ss0.D, float)).T]))
    ut = np.ascontiguousarray(_band_input(u, f).T)
    Z = _mode_signals(lam0, T, ut, f)
    h = POLE_STEP * np.maximum(np.abs(lam0), POLE_STEP / T)
    dZ = (_mode_signals(lam0 + h, T, ut, f) - _mode_signals(lam0 - h, T, ut, f)) / (2 * h)[:, None, None]
    nm, ni, n = Z.shape
    Zf, dZf = Z.reshape(nm * ni, n).T, dZ.reshape(nm * ni, n).T
    return np.hstack([Zf.real, Zf.imag, dZf.real, dZf.imag, u]), matrices


def simulate_state_space(ss: StateSpace, u, fs: float, hold: str = "zoh") -> np.ndarray:
    """Response (n_samples, n_outputs) of ``ss`` from rest to samples ``u`` at ``fs`` Hz."""
    if hold not in HOLDS:
        raise ConfigError(f"hold: expected one of {HOLDS}, got {hold!r}")
    if not (np.isfinite(fs) and fs > 0):
        raise ConfigError(f"sampling rate: must be > 0 Hz, got {fs!r}")
    u = check_input_record(u, ss.B.shape[1])
    if hold == "band":
        return _simulate_band(ss, u, fs)
    T = 1.0 / fs
    modal = _modal(ss.A, T)
    if modal is None:
        return _simulate_expm(ss, u, T, hold)
    return _simulate_modal(ss, u, modal, hold)


def _simulate_modal(ss: StateSpace, u: np.ndarray, modal: tuple, hold: str) -> np.ndarray:
    """:func:`simulate_state_space` by ``_modal``'s decomposition."""
    scale, V, keep, weight, lk, p, g0, g1s = modal
    Bm = np.linalg.solve(V, (ss.B / scale[:, None]).astype(complex))[keep]  # modal input, n_modes x n_in
    Cm = ((ss.C * scale) @ V)[:, keep] * weight  # n_out x n_modes
    # per (mode, input): the complex first-order recursion b(q)/(1 - p q^-1) run as two real
    # second-order filters (its real and imaginary parts, denominator |1 - p q^-1|^2) on the real
    # input; the modal input weight is folded into the output weights. All in one compiled call,
    # lfilter's arithmetic (recursions.second_order_rows)
    ut = np.ascontiguousarray(u.T)
    nm, ni = len(lk), ut.shape[0]
    rows = 2 * nm * ni  # real parts (mode, input), then imaginary parts
    nums, dens, zi = np.empty((rows, 3)), np.empty((rows, 3)), np.zeros((rows, 2))
    # the coefficients mode by mode in scalars: numpy's vectorised complex products round
    # differently in the last bit
    for i in range(nm):
        if hold == "zoh":
            b0, b1 = 0.0, g0[i]
        else:
            g1 = g1s[i]
            b0, b1 = g1, g0[i] - g1
        pc = np.conj(p[i])
        num = np.array([b0, b1 - b0 * pc, -b1 * pc])
        den = np.array([1.0, -2 * p[i].real, abs(p[i]) ** 2])
        for j in range(ni):
            re, im = i * ni + j, (nm + i) * ni + j
            nums[re], nums[im], dens[re], dens[im] = num.real, num.imag, den, den
            if hold == "foh":
                # start from rest whatever u[0] is: cancel the homogeneous response b0 u0 p^n
                c = b0 * ut[j, 0]
                cp = c * p[i]
                zi[re] = -c.real, -cp.real - den[1] * c.real
                zi[im] = -c.imag, -cp.imag - den[1] * c.imag
    source = np.tile(np.arange(ni), 2 * nm)
    from odsuite.domain.recursions import second_order_rows  # numba loads on first use

    Zri = np.empty((rows, len(u)))
    second_order_rows(nums, dens, zi, source, ut, Zri)
    fold = (Cm[:, :, None] * Bm[None, :, :]).reshape(len(Cm), nm * ni)  # output x (mode, input)
    yt = np.hstack([fold.real, -fold.imag]) @ Zri  # Re(sum Cm Bm z), outputs x samples
    for k, j in zip(*np.nonzero(ss.D)):
        yt[k] += ss.D[k, j] * ut[j]
    return yt.T  # samples x outputs (a transposed view: no copy)


def simulate_many_inputs(ss: StateSpace, u, fs: float) -> np.ndarray | None:
    """:func:`simulate_state_space` with ``foh`` hold for a system of many inputs (a force at every
    coordinate): the inputs are combined into each mode's own input first, so one recursion runs
    per mode, not per mode and input; equal to it but for rounding. None where the modal form is
    ill-conditioned."""
    T = 1.0 / fs
    modal = _modal(ss.A, T)
    if modal is None:
        return None
    scale, V, keep, weight, _, p, g0, g1 = modal
    u = check_input_record(u, ss.B.shape[1])
    Bm = np.linalg.solve(V, (ss.B / scale[:, None]).astype(complex))[keep]
    Cm = ((ss.C * scale) @ V)[:, keep] * weight
    v = Bm @ u.T  # each mode's input, modes x samples
    z = np.empty_like(v)
    for i in range(len(p)):
        b0, b1 = g1[i], g0[i] - g1[i]
        z[i], _ = scipy.signal.lfilter([b0, b1], [1.0, -p[i]], v[i], zi=[-b0 * v[i, 0]])  # from rest
    return (Cm @ z).real.T + u @ np.asarray(ss.D, float).T


def _simulate_expm(ss: StateSpace, u: np.ndarray, T: float, hold: str) -> np.ndarray:
    """Matrix-exponential discretisation (as scipy.signal.lsim does it), run by dlsim."""
    n, m = ss.B.shape
    big = np.zeros((n + 2 * m, n + 2 * m))
    big[:n, :n] = ss.A * T
    big[:n, n:n + m] = ss.B * T
    big[n:n + m, n + m:] = np.eye(m)
    E = scipy.linalg.expm(big)
    phi, g1, g2 = E[:n, :n], E[:n, n:n + m], E[:n, n + m:]
    if hold == "zoh":
        sysd, x0 = (phi, g1, ss.C, ss.D, T), None
    else:
        # x[k+1] = phi x[k] + (g1 - g2) u[k] + g2 u[k+1]; xi = x - g2 u removes the u[k+1] term
        sysd = (phi, phi @ g2 + g1 - g2, ss.C, ss.D + ss.C @ g2, T)
        x0 = -g2 @ u[0]
    _, y, _ = scipy.signal.dlsim(sysd, u, x0=x0)
    return np.asarray(y).reshape(len(u), -1)


def simulate(model: Model, inputs, u, fs: float, outputs, hold: str = "zoh") -> np.ndarray:
    """Outputs (n_samples, n_outputs) of ``model`` to the input record ``u`` (n_samples, n_inputs;
    a 1-D array for one input) sampled at ``fs`` Hz, from rest, with a zero- or first-order hold or
    as the band-limited signal the samples imply (``band``)."""
    return simulate_state_space(model.state_space(inputs, outputs), u, fs, hold)


#: the phase shifts exp(j w tau) sampled_later applied last, by samples, rate and delays: a
#: diagnosis shifts every experiment's channels by the same delays in turn (a record that leaves a
#: channel out shifts the others)
_PHASES: dict[tuple, np.ndarray] = {}
PHASES_KEPT = 4
#: ... each of at most this many bytes (a long record's are left to go)
PHASE_BYTES_KEPT = 32e6


def delay_length(n: int) -> int:
    """The length sampled_later transforms ``n`` samples at: twice them (a shift's tails do not
    wrap onto the record), up to the next length whose factors are 2, 3 and 5. A length with a
    large prime factor costs the transform ten times as much (2 x 2141 samples: 1.4 ms against
    0.14 ms at 4096, 12 channels); the padding's length moves a shifted sample by about 1e-6 of
    the record's peak (up to 1.3e-6 on the thesis bench's windows, at a window's ends)."""
    import scipy.fft

    return int(scipy.fft.next_fast_len(2 * n, real=True))


def sampled_later(y: np.ndarray, fs: float, delays, spectrum: np.ndarray | None = None) -> np.ndarray:
    """Each column of ``y`` (samples x channels, sampled at ``fs`` Hz from rest) as it would be
    sampled ``delays[k]`` seconds later: a phase shift exp(j w tau) of its spectrum, zero-padded to
    at least twice its length so that nothing wraps around (exact for band-limited signals:
    delay_length). ``spectrum``: ``np.fft.rfft(y, n=delay_length(len(y)), axis=0)`` where the
    caller keeps it (a search over delays shifts the same signals again and again; each column's
    transform is its own, so the same numbers)."""
    n = y.shape[0]
    delays = np.asarray(delays, float)
    # columns sampled on time are left as they are (not through the transform's round-off): a
    # channel's delay then changes that channel alone
    moved = np.flatnonzero(delays)
    out = np.array(y, dtype=float)
    m = delay_length(n)
    spec = np.fft.rfft(out[:, moved], n=m, axis=0) if spectrum is None else spectrum[:, moved]
    key = (n, fs, delays[moved].tobytes())
    phase = _PHASES.get(key)
    if phase is None:
        if len(_PHASES) >= PHASES_KEPT:
            _PHASES.clear()
        w = 2 * np.pi * np.fft.rfftfreq(m, 1.0 / fs)
        # each distinct delay's column once (a search moves every channel to the same start): the
        # complex exponential costs more than the inverse transform; each entry the same product
        distinct, which = np.unique(delays[moved], return_inverse=True)
        phase = np.exp(1j * np.outer(w, distinct))
        if not np.array_equal(distinct, delays[moved]):  # repeated or out of order: each channel's own
            phase = phase[:, which]
        if phase.nbytes <= PHASE_BYTES_KEPT:
            _PHASES[key] = phase
    spec *= phase
    out[:, moved] = np.fft.irfft(spec, n=m, axis=0)[:n]
    return out


#: steps per sample of the nonlinear integration (second order in the step): at 20 kHz with modes
#: below 300 Hz one step per sample is within 6.4e-4 of the response where hardening changes it by
#: 25 % (against scipy's DOP853 in the tests), far below a record's noise
NONLINEAR_STEPS_PER_SAMPLE = 1


def load_nonlinear_loop() -> None:
    """Load the compiled time loop of :func:`simulate_nonlinear_many` (numba's start and its
    cache: ~0.8 s of CPU in each process that first needs it). Called before forking worker
    processes, which then inherit it instead of each loading it again."""
    from odsuite.domain.cubic_steps import cubic_steps

    z = np.zeros
    cubic_steps(z((3, 3)), z((1, 1, 3)), z((1, 2)), z((1, 1)), z(1), z((2, 1, 2)))


def simulate_nonlinear(structure, bf: np.ndarray, u, fs: float, hold: str = "foh") -> np.ndarray:
    """Coordinate accelerations q'' (n_samples x n_dof), from rest, of
    ``M q'' + C q' + K q + E^T (c (E q)^3) = bf u`` (``structure.cubic_rows()``: cubic springs),
    the input linear between samples (``foh``) or the band-limited signal they imply (``band``:
    linear between :func:`band_limited`'s points), as the linear simulation's holds."""
    return simulate_nonlinear_many(structure, [(bf, u)], fs, hold)[0]


#: the linear parts of the nonlinear simulations last set up (:func:`_nonlinear_setup`), by
#: structure and inputs; each holds the inputs' part of every step (megabytes)
_NONLINEAR_SETUPS: dict[tuple, tuple] = {}
NONLINEAR_SETUPS_KEPT = 2


def _nonlinear_setup(structure, E: np.ndarray, bfs, records, fs: float, hold: str, sub: int) -> tuple:
    """What :func:`simulate_nonlinear_many`'s time loop needs besides the cubic coefficients:
    the step's matrices and the inputs' part of every step (read-only)."""
    n = structure.n_dof
    h = 1.0 / (fs * sub)
    # first-order-hold discretisation of x' = A x + [0; I] w (w: an acceleration input)
    big = np.zeros((4 * n, 4 * n))
    big[:2 * n, :2 * n] = structure.A * h
    big[n:2 * n, 2 * n:3 * n] = np.eye(n) * h
    big[2 * n:3 * n, 3 * n:] = np.eye(n)
    X = scipy.linalg.expm(big)
    phi, g1, g2 = X[:2 * n, :2 * n], X[:2 * n, 2 * n:3 * n], X[:2 * n, 3 * n:]
    start, end = g1 - g2, g2  # weights of w at a step's start and end
    pull = structure.Minv @ E.T  # generalized acceleration per unit element force
    start_pull, end_pull = start @ pull, end @ pull
    Eq = np.hstack([E, np.zeros_like(E)])
    end_deflection = Eq @ end_pull  # element deflection per unit element force at a step's end
    longest = max(len(u) for u in records)
    steps = (longest - 1) * sub + 1
    drive = np.zeros((len(records), longest, n))  # input accelerations, zero after a record's end
    for i, (bf, u) in enumerate(zip(bfs, records)):
        drive[i, :len(u)] = u @ (structure.Minv @ bf).T
    grid = np.arange(steps) / sub
    step_t = np.vstack([phi.T, -start_pull.T])
    # the inputs' part of each step, the state's and the deflections' side by side (one product per
    # step gives both), written record by record: the whole records' temporaries, some 60 MB of fresh
    # pages, made the thesis bench's first set-up of five 8192-sample records 50 ms (now 9)
    inputs = np.empty((len(records), steps - 1, 2 * n + Eq.shape[0]))
    for i, (bf, u) in enumerate(zip(bfs, records)):
        if hold == "band":  # the transform is linear: of the force (kept between calls), then mapped
            padded = np.zeros((longest, u.shape[1]))
            padded[:len(u)] = u
            fine = _band_input(padded, sub) @ (structure.Minv @ bf).T
        else:  # the inputs on the fine grid, linear between samples
            fine = np.empty((steps, n))
            for j in range(n):
                fine[:, j] = np.interp(grid, np.arange(longest), drive[i, :, j])
        linear = fine[:-1] @ start.T
        linear += fine[1:] @ end.T
        inputs[i, :, :2 * n] = linear
        # the deflections' count given: a record of one sample has no step, and -1 reads nothing from none
        inputs[i, :, 2 * n:] = linear @ Eq.T
    out = (pull, drive, inputs, np.hstack([step_t, step_t @ Eq.T]),
           np.ascontiguousarray(end_pull.T), np.ascontiguousarray(end_deflection.T))
    for a in out:
        a.flags.writeable = False
    return out


def simulate_nonlinear_many(structure, drives, fs: float, hold: str = "foh") -> list[np.ndarray]:
    """:func:`simulate_nonlinear` for several inputs ``drives`` [(bf, u), ...] at once (records of
    any lengths, e.g. every experiment of a fit): one time loop advances them all, so its Python
    cost is paid once.

    An exponential integrator: the linear part is exact (the matrix exponential over a step, the
    input and the cubic force linear across it); the cubic force at the step's end comes from a
    predictor and one corrector. Written here because scipy.integrate's solvers cost a Python call
    per stage and step through each hit at a rate set by the input's kinks; this one costs a few
    small products per step, in compiled code (odsuite.domain.cubic_steps)."""
    from odsuite.domain.cubic_steps import cubic_steps

    records = [check_input_record(u, bf.shape[1]) for bf, u in drives]
    E, c = structure.cubic_rows()
    if hold not in ("foh", "band"):
        raise ConfigError(f"hold: expected 'foh' or 'band', got {hold!r}")
    sub = NONLINEAR_STEPS_PER_SAMPLE * (BAND_OVERSAMPLE if hold == "band" else 1)
    n = structure.n_dof
    # a fit of cubic coefficients alone simulates one linear structure with one set of inputs
    # again and again: all but the time loop is kept between calls
    key = (structure.A.tobytes(), structure.Minv.tobytes(), E.shape, E.tobytes(), fs, hold, sub,
           tuple((bf.shape, bf.tobytes(), u.shape, u.tobytes()) for (bf, _), u in zip(drives, records)))
    setup = _NONLINEAR_SETUPS.pop(key, None)
    if setup is None:
        setup = _nonlinear_setup(structure, E, [bf for bf, _ in drives], records, fs, hold, sub)
        while len(_NONLINEAR_SETUPS) >= NONLINEAR_SETUPS_KEPT:
            _NONLINEAR_SETUPS.pop(next(iter(_NONLINEAR_SETUPS)))
    _NONLINEAR_SETUPS[key] = setup  # the most recent last
    pull, drive, inputs, step_t, end_pull_t, end_deflection_t = setup
    states = np.empty((inputs.shape[1] + 1, len(records), 2 * n))
    cubic_steps(step_t, inputs, end_pull_t, end_deflection_t, np.ascontiguousarray(c, dtype=float), states)
    if not np.all(np.isfinite(states)):
        raise DivergedError("nonlinear simulation diverged (cubic springs too strong for this force)")
    out = []
    for i, u in enumerate(records):
        q = states[:(len(u) - 1) * sub + 1:sub, i]
        d = q[:, :n] @ E.T
        out.append(q @ structure.A[n:].T + drive[i, :len(u)] - (c * d * d * d) @ pull.T)
    return out
