"""Output-only (operational) modal analysis: covariance-driven stochastic subspace identification
(SSI-cov, Peeters & De Roeck 1999) of responses to unmeasured broadband forces.

Output correlations R_k = E[y_{t+k} y_t^T] of a linear system driven by white noise are
R_k = C A^(k-1) G, so the block Toeplitz matrix of R_1 .. R_(2i-1) factors into observability
times controllability; its SVD truncated to order n gives C and A (shift invariance of the
observability matrix), and A's eigenvalues mu give the poles lambda = fs ln(mu), C's eigenvector
image the (unscaled) mode shapes. Poles are stabilised over orders and picked like LSCF's
(``modal.select_poles``), with clusters as wide as a heavily damped pole wanders when their shapes
agree (``_select``).

Written here: sdypy-EMA has no output-only method, and the SSI-cov core is a few lines of numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft
import scipy.signal
from threadpoolctl import threadpool_limits

from odsuite.domain.errors import ConfigError, DimensionError
from odsuite.analysis.fdd import spectral_peaks
from odsuite.analysis.modal import (
    ModalResult,
    StabilisationDiagram,
    CLUSTER_BANDWIDTH,
    CLUSTER_DAMPING_SPREAD,
    SAME_MODE_MAC,
    Unresolved,
    distinct_poles,
    cluster_tol,
    half_power_band,
    half_power_inside,
    mac,
    normalise_shapes,
    physical_poles,
    stability_flags,
    stable_clusters,
    stable_points,
    zeta_of,
)

#: the highest SSI-cov state size unless given: every entry point (modes, render, report) uses it,
#: since it also sets the band (max_order / ORDERS_PER_PEAK peaks) and so which modes are found
MAX_ORDER = 40


def _correlations(y: np.ndarray, lags: int) -> np.ndarray:
    """Unbiased output correlations R_k (lags x outputs x outputs), k = 0 .. lags - 1, through the
    FFT (the direct sums cost lags x samples x outputs^2: 30 s for a building's 90 min at 130 lags)."""
    n, m = y.shape
    nfft = scipy.fft.next_fast_len(n + lags)
    Y = scipy.fft.rfft(y, nfft, axis=0)
    R = np.empty((lags, m, m))
    for i in range(m):  # row by row: the full outputs^2 spectrum would not fit in memory for long records
        R[:, i, :] = scipy.fft.irfft(Y[:, i, None] * Y.conj(), nfft, axis=0)[:lags]
    return R / (n - np.arange(lags))[:, None, None]


def checked_responses(y) -> np.ndarray:
    """Responses as samples x outputs (floats), refused in one line when they are not that, too
    short for their outputs, or not finite."""
    y = np.asarray(y, dtype=float)
    y = y[:, None] if y.ndim == 1 else y
    if y.ndim != 2 or y.shape[0] < 10 * y.shape[1]:
        raise DimensionError(f"responses have shape {y.shape}; expected samples x outputs, many more samples")
    if not np.all(np.isfinite(y)):
        raise ConfigError("responses hold NaN or infinite samples")
    if y.shape[1] == 0:
        raise ConfigError("responses: no response channel (a force channel alone): no motion to identify modes from")
    still = [j for j in range(y.shape[1]) if np.ptp(y[:, j]) == 0]
    if len(still) == y.shape[1]:
        raise ConfigError(f"responses: every channel is constant ({y.shape[1]} of {y.shape[1]}): no motion to "
                          "identify modes from")
    return y


def ssi_cov(
    y: np.ndarray,
    fs: float,
    *,
    max_order: int = MAX_ORDER,
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
    y = checked_responses(y)
    n_out = y.shape[1]
    band = f_band if f_band is not None else (0.0, fs / 2)
    if block_rows is None:
        block_rows = max(int(np.ceil(max_order / n_out)) + 1, 20)
    if block_rows * n_out < max_order:
        raise ConfigError(f"SSI-cov: {block_rows} block rows x {n_out} outputs cannot hold model order {max_order}")
    if y.shape[0] < 2 * block_rows:  # a lag as long as the record has no product to average: R / 0
        raise DimensionError(f"SSI-cov: {y.shape[0]} samples hold no lags up to {2 * block_rows - 1} "
                             f"({block_rows} block rows)")
    y = y - y.mean(axis=0)
    scale = np.maximum(y.std(axis=0), np.finfo(float).tiny)
    y = y / scale  # equal weight per output in the SVD; poles unchanged, shapes scaled back below
    R = _correlations(y, 2 * block_rows)
    # T[a, b] = R_(i + a - b), a, b = 0 .. i-1 (lags 1 .. 2i-1)
    T = np.block([[R[block_rows + a - b] for b in range(block_rows)] for a in range(block_rows)])
    U, S, _ = np.linalg.svd(T)
    # A = pinv(O_up) O_down for O = U_n S_n^(1/2): its normal equations' blocks for every order n
    # are the leading n x n blocks of two matrices formed once (a least-squares solve per order
    # cost 30 s of 55 s on a busy 2-core machine)
    Un = U[:, :max_order]
    M, N = Un[:-n_out].T @ Un[:-n_out], Un[:-n_out].T @ Un[n_out:]
    orders, poles, shapes, stable_f, stable = [], [], [], [], []
    prev = np.array([], dtype=complex)
    for n in range(2, max_order + 1, 2):
        sq = np.sqrt(S[:n])
        A = np.linalg.solve(M[:n, :n], N[:n, :n]) * sq[None, :] / sq[:, None]
        mu, psi = np.linalg.eig(A)
        lam = np.log(mu.astype(complex)) * fs
        phi = scale[:, None] * ((Un[:n_out, :n] * sq) @ psi)  # in the data's units
        kept = physical_poles(lam, band, max_damping)
        idx = [int(np.argmin(np.abs(lam - k))) for k in kept]
        # a heavily damped pole's estimate moves by a fraction of its half-power bandwidth per order
        sf, sz = stability_flags(prev, kept, tol_f, tol_zeta, CLUSTER_BANDWIDTH)
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
#: ... and shape: a segment's pole of another shape (MAC below this) is another mode or a
#: noise pole, whose frequency would inflate the scatter
MATCH_MAC = 0.5
#: two neighbouring poles are told apart when their frequencies differ by more than this many
#: combined standard errors (about 95 % for a normal scatter)
SEPARATION_SIGMAS = 2.0


def _segment_scatter(y: np.ndarray, fs: float, poles: np.ndarray, band: tuple[float, float],
                     max_order: int, block_rows: int | None = None, phi: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per pole: standard errors of frequency (Hz) and damping ratio from the scatter of its
    matched poles over ``SEGMENTS`` segments (sample std / sqrt(segments)), the number of
    segments that hold it (a one-to-one match within ``MATCH_TOL`` whose shape has MAC >=
    ``MATCH_MAC`` with the pole's ``phi``), and per pole (columns) the range of the segments'
    damping ratios over their median when their frequencies spread beyond ``CLUSTER_TOL`` (as
    ``modal.cluster_consistent`` asks of a cluster over orders; else 0) and the range allowed
    (``damping_range_allowed``)."""
    from scipy.optimize import linear_sum_assignment

    f0 = np.abs(poles) / (2 * np.pi)
    found_f = [[] for _ in poles]
    found_z = [[] for _ in poles]
    n = y.shape[0] // SEGMENTS
    for k in range(SEGMENTS):
        try:
            diagram, shapes = ssi_cov(y[k * n:(k + 1) * n], fs, max_order=max_order, block_rows=block_rows,
                                      f_band=band)
        except DimensionError:
            break  # segments too short to identify anything: no scatter
        seg, orders, seg_phi, _ = _select(diagram, shapes, edges=False)
        if seg.size == 0:
            continue
        one = _one_per_mode(seg, seg_phi, orders)  # as the whole record's
        seg, seg_phi = seg[one], seg_phi[:, one]
        fs_seg = np.abs(seg) / (2 * np.pi)
        cost = np.abs(fs_seg[None, :] - f0[:, None]) / f0[:, None]
        agree = mac(phi, seg_phi) >= MATCH_MAC if phi is not None else np.ones(cost.shape, bool)
        cost = np.where(agree, cost, cost + 1.0)  # another mode's shape is no match
        for r, c in zip(*linear_sum_assignment(cost)):
            if cost[r, c] <= MATCH_TOL:
                found_f[r].append(fs_seg[c])
                found_z[r].append(-seg[c].real / abs(seg[c]))
    count = np.array([len(v) for v in found_f])
    with np.errstate(invalid="ignore"):
        f_std = np.array([np.std(v, ddof=1) / np.sqrt(len(v)) if len(v) > 1 else np.inf for v in found_f])
        z_std = np.array([np.std(v, ddof=1) / np.sqrt(len(v)) if len(v) > 1 else np.inf for v in found_z])
        z_range = np.array([np.ptp(z) / np.median(z) if len(z) > 1 and np.ptp(f) > CLUSTER_TOL * np.median(f) else 0.0
                            for f, z in zip(found_f, found_z)])
    return f_std, z_std, count, np.column_stack([z_range, damping_range_allowed(poles, n / fs)])


#: segments' damping ratios of one pole may spread by this many of a segment's relative standard
#: deviations: the range of 4 normal samples exceeds 3.6 of them in 5 % of cases, and the scatter's
#: formula (``damping_range_allowed``) is an order of magnitude, not SSI-cov's own (a 2.2 %-damped
#: 8.1 Hz mode of a 3-channel roving setup, 75 s segments, spread by 62 %, 4.1 of them)
DAMPING_RANGE_SIGMAS = 6.0


def damping_range_allowed(poles: np.ndarray, seconds: float) -> np.ndarray:
    """Relative range of damping ratios that segments of ``seconds`` may give one pole: a damping
    estimate's relative scatter is about 1 / sqrt(pi zeta f T) (one over the root of the record's
    independent half-power bandwidths: 11 % for a 2 %-damped 8 Hz mode in 150 s, 1.2 % for a
    15 %-damped 98 Hz mode), ``DAMPING_RANGE_SIGMAS`` of those, and never less than
    ``modal.CLUSTER_DAMPING_SPREAD``."""
    bandwidths = np.pi * zeta_of(poles) * np.abs(poles) / (2 * np.pi) * seconds
    return np.maximum(CLUSTER_DAMPING_SPREAD, DAMPING_RANGE_SIGMAS / np.sqrt(bandwidths))


#: stable poles join one cluster within ``select_poles``' 0.5 %, or a fraction of the half-power
#: bandwidth when wider (``modal.cluster_tol``), and at least ``select_poles``' 30 % of the orders
CLUSTER_TOL, MIN_FRACTION = 0.005, 0.3


def _select(diagram: StabilisationDiagram, shapes: list[np.ndarray], edges: bool = True
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``select_poles``' clusters of stable poles, with shapes (``modal.stable_clusters`` given the
    shapes): a heavily damped pole's estimates wander over the orders by a fraction of its
    half-power bandwidth 2 zeta f (the thesis rig's 16 %-damped 228 Hz mode over 225.7-229.4 Hz in
    a 2.5 min segment, MAC >= 0.93 with the record's shape at every order), so a cluster spans
    ``CLUSTER_BANDWIDTH`` of zeta f where the shapes agree. Returns the poles whose half-power band
    lies inside the diagram's band (ascending), their counts of orders, their shapes (outputs x
    poles) and the poles dropped at the band's edges (``edges=False``: none dropped; a segment
    asked whether it holds the record's poles, whose band was chosen to hold them, is not cut by it
    again)."""
    f, z, o, phi = stable_points(diagram, shapes)
    out, counts, rep = stable_clusters(f, z, o, len(diagram.orders), CLUSTER_TOL, MIN_FRACTION, CLUSTER_BANDWIDTH,
                                       phi)
    order = np.argsort(np.abs(out))
    out, counts, rep = out[order], counts[order], rep[:, order]
    inside = half_power_inside(out, diagram.f_band) if edges else np.ones(out.size, bool)
    kept, _ = distinct_poles(out[inside], counts[inside], CLUSTER_TOL, 0.0)  # clusters split a hair apart
    keep = np.isin(out, kept)
    return out[keep], counts[keep], rep[:, keep], out[~inside]


def _one_per_mode(poles: np.ndarray, phi: np.ndarray, stable_orders: np.ndarray) -> np.ndarray:
    """Which poles stay when neighbours that are one mode (``SAME_MODE_MAC``) are merged: of
    those, the pole stable over more model orders."""
    keep: list[int] = []
    lo, hi = half_power_band(poles)
    f = np.abs(poles) / (2 * np.pi)
    for r in range(poles.size):
        q = keep[-1] if keep else None
        if q is not None and f[r] <= hi[q] and f[q] >= lo[r] and mac(phi[:, [r]], phi[:, [q]])[0, 0] >= SAME_MODE_MAC:
            if stable_orders[r] > stable_orders[q]:
                keep[-1] = r
            continue
        keep.append(r)
    return np.array(keep, dtype=int)


def _resolved(poles: np.ndarray, f_std: np.ndarray, count: np.ndarray,
              phi: np.ndarray | None = None, z_range: np.ndarray | None = None) -> tuple[np.ndarray, list[str]]:
    """Which poles are modes, and for the others why not: a pole held by fewer than half the
    segments is not confirmed, nor one damped enough for ``_select``'s wider clusters (the rules
    that admit it are wider; below, they are ``select_poles``' own) whose segments' frequencies
    spread beyond ``CLUSTER_TOL`` while their damping ratios spread by more than the segments
    allow (``z_range``: relative range and allowed range per pole, ``damping_range_allowed``; a
    pole has one damping; an estimate that
    stands for several modes of one unmeasured force moves with their mixture: the thesis rig as
    modelled, 150 s of one force, gives 104.1 Hz from segments at 12.3-15.9 % damping); two neighbours closer than ``SEPARATION_SIGMAS`` combined standard
    errors whose shapes ``phi`` (outputs x poles; None: not known) agree (``SAME_MODE_MAC``)
    cannot be told apart from this record, so neither is called a mode. Distinct shapes are two
    modes however close: a heavily damped mode's frequency is uncertain by a fraction of its
    half-power band, but its shape is fixed by every channel (the thesis rig's 97.4 / 98.3 Hz
    pair, 1.05 Hz apart with standard errors 0.21 and 0.49 Hz, has shapes of MAC 0.06-0.33)."""
    f = np.abs(poles) / (2 * np.pi)
    ok = np.ones(poles.size, bool)
    reasons = [""] * poles.size
    for r in range(poles.size):
        if count[r] < SEGMENTS / 2:
            ok[r] = False
            reasons[r] = f"found in only {count[r]} of {SEGMENTS} segments of the record"
        elif (z_range is not None and z_range[r, 0] > z_range[r, 1]
              and cluster_tol(CLUSTER_TOL, zeta_of(poles[r]), CLUSTER_BANDWIDTH) > CLUSTER_TOL):
            ok[r] = False
            reasons[r] = (f"its damping ratio disagrees over the segments of the record (range {100 * z_range[r, 0]:.0f} % "
                          f"of its median, at most {100 * z_range[r, 1]:.0f} %)")
    confirmed = np.flatnonzero(ok)  # neighbours among the confirmed poles (the others have no scatter)
    for r, q in zip(confirmed[:-1], confirmed[1:]):
        gap, spread = f[q] - f[r], np.hypot(f_std[r], f_std[q])
        same = phi is None or mac(phi[:, [r]], phi[:, [q]])[0, 0] >= SAME_MODE_MAC
        if same and not gap > SEPARATION_SIGMAS * spread:
            for a, b in ((r, q), (q, r)):
                ok[a] = False
                reasons[a] = reasons[a] or (
                    f"cannot be told apart from the pole at {f[b]:.2f} Hz: {gap:.2f} Hz apart, "
                    f"standard errors {f_std[r]:.2f} and {f_std[q]:.2f} Hz (a longer record or "
                    "more independent inputs separate them)")
    return ok, reasons


#: the correlations' lags span this many periods of the record's lowest spectral peak (a lag span
#: shorter than one period cannot show the mode's decay; pyOMA2's building example spans 5.6)
LAG_PERIODS = 5
#: the decimated rate is at least this many times the band's top (the top at 40 % of the rate keeps
#: the anti-aliasing filter's own poles out of the band)
RATE_PER_BAND = 2.5
#: the Toeplitz matrix's rows at most (block rows x outputs): its SVD's cost grows with their cube;
#: when the lag span needs more, the band's top comes down instead (fewer samples per period)
MAX_ROWS = 1200
#: the most Toeplitz rows a given --block-rows may make (an SVD of 4800 rows takes about a minute)
GIVEN_ROWS_MAX = 4 * MAX_ROWS
#: the highest model order SSI-cov is asked for: it solves an eigenproblem per even order, so its
#: time grows with the order's fourth power (order 400 took 41 s on 3 outputs, 1000 would take half an hour)
MAX_GIVEN_ORDER = 400
#: the fewest samples a given --decimate may leave: the segments' scatter and the lags need them
MIN_DECIMATED = 256
#: the band holds at most one spectral peak per this many model orders (each mode takes two
#: states, and noise takes about as many again)
ORDERS_PER_PEAK = 4
#: without --fmin the record is high-passed at this fraction of its lowest spectral peak: drift and
#: sensor offsets below it carry no mode but would take model order and weight
HIGHPASS_FRACTION = 0.25


@dataclass(frozen=True)
class OmaSettings:
    """How an output-only record is analysed, and why: ``band_hz`` (poles kept), ``highpass_hz``
    (None: not filtered), ``decimation`` (integer factor) and ``rate_hz`` after it, ``block_rows``
    (the correlations' lags 1 .. 2 block_rows - 1, i.e. ``lag_span_s``), the record's spectral
    peaks that chose them, and per setting whether it was "given" or chosen "from the record"."""

    band_hz: tuple[float, float]
    highpass_hz: float | None
    decimation: int
    rate_hz: float
    block_rows: int
    lag_span_s: float
    peaks_hz: tuple[float, ...]
    source: dict[str, str]
    note: str = ""  # why a setting chosen from the record was changed after a first fit

    def to_dict(self) -> dict:
        return {"band_hz": [float(v) for v in self.band_hz], "highpass_hz": self.highpass_hz,
                "decimation": self.decimation, "rate_hz": self.rate_hz, "block_rows": self.block_rows,
                "lag_span_s": self.lag_span_s, "peaks_hz": [float(v) for v in self.peaks_hz],
                "source": dict(self.source), "note": self.note}

    def describe(self) -> str:
        """One line: what was used, with units."""
        hp = f"high-passed at {self.highpass_hz:.3g} Hz, " if self.highpass_hz else ""
        return (f"band {self.band_hz[0]:.3g}-{self.band_hz[1]:.3g} Hz, {hp}decimated by {self.decimation} to "
                f"{self.rate_hz:.4g} Hz, {self.block_rows} block rows (lags to {self.lag_span_s:.3g} s)"
                + (f"; {self.note}" if self.note else ""))


#: peaks' half-power widths are measured on the spectrum averaged over this relative bandwidth
#: either side of each line (a 1 %-damped peak, 2 % wide, is widened by about a third)
WIDTH_SMOOTHING = 0.005


def record_peaks(y: np.ndarray, fs: float, lo: float = 0.0, hi: float | None = None) -> np.ndarray:
    """Frequencies (Hz) of the record's resonance peaks within lo..hi: each channel's own spectrum's
    peaks that stand ``fdd.PEAK_PROMINENCE`` above their surroundings (Welch with at least 31
    half-overlapping segments), pooled over channels; peaks of different channels inside one
    another's half-power width are one resonance, at its strongest channel's peak. Per channel, not
    summed: a mode that moves only some channels (a heave among rocking modes) would stand less
    than the prominence above a sum that the other channels dominate."""
    n = y.shape[0]
    nperseg = int(2 ** np.clip(np.floor(np.log2(n / 16)), 8, 16))
    if nperseg > n:
        return np.array([])
    freq, P = scipy.signal.welch(y, fs, nperseg=nperseg, axis=0)
    band = (max(lo, 2 * freq[1]), fs / 2 if hi is None else hi)
    # a peak's upper half-power edge: where the spectrum averaged over +-WIDTH_SMOOTHING of each
    # line's frequency falls below half the peak (the raw lines scatter by a quarter, so a heavily
    # damped hump's noisy top would halve within a few lines)
    cum = np.vstack([np.zeros(P.shape[1]), np.cumsum(P, axis=0)])
    left = np.searchsorted(freq, freq * (1 - WIDTH_SMOOTHING))
    right = np.maximum(np.searchsorted(freq, freq * (1 + WIDTH_SMOOTHING), side="right"), left + 1)
    smooth = (cum[right] - cum[left]) / (right - left)[:, None]
    found = []  # (frequency, upper half-power edge, height above the channel's median)
    for c in range(P.shape[1]):
        idx = spectral_peaks(freq, P[:, c], band)
        level = P[idx, c] / max(float(np.median(P[:, c])), np.finfo(float).tiny)
        for i, v in zip(idx, level):
            above = np.flatnonzero(smooth[i:, c] < P[i, c] / 2)  # a narrow line's average is below at once
            edge = freq[i + above[0]] if above.size else freq[-1]
            found.append((freq[i], max(edge, freq[i] * (1 + WIDTH_SMOOTHING)), v))  # no finer than the average
    found.sort()
    peaks: list[tuple[float, float, float]] = []  # (frequency, upper edge, level) per resonance
    for f, b, level in found:
        if peaks and f <= peaks[-1][1]:
            g, edge, top = peaks[-1]
            peaks[-1] = (f if level > top else g, max(b, edge), max(level, top))
        else:
            peaks.append((f, b, level))
    return np.array([p[0] for p in peaks])


def _order_fits(max_order: int, n_out: int, samples: int, rate: float) -> None:
    """Refuse a model order the record cannot hold, before any matrix is made: its block rows (the
    fewest that hold it, ``ceil(order / outputs) + 1``) need lags of twice their number in a record
    of at least four times as many samples (as a given --block-rows), and at most MAX_GIVEN_ORDER."""
    rows = int(np.ceil(max_order / n_out)) + 1
    if 4 * rows > samples:
        raise ConfigError(f"--max-order {max_order}: {rows} block rows x {n_out} outputs hold it, whose lags "
                          f"(2 x {rows}) need at least {4 * rows} samples at {rate:g} Hz; the record has {samples} "
                          "(give a lower --max-order)")
    if max_order > MAX_GIVEN_ORDER:
        raise ConfigError(f"--max-order {max_order}: at most {MAX_GIVEN_ORDER} (SSI-cov solves an eigenproblem per "
                          "even order, its time grows with the order's fourth power)")


def choose_settings(y: np.ndarray, fs: float, *, f_band: tuple[float | None, float | None] | None = None,
                    block_rows: int | None = None, decimation: int | None = None,
                    max_order: int = MAX_ORDER) -> OmaSettings:
    """Band, high-pass, decimation and block rows for SSI-cov from the record: its spectral peaks
    (``record_peaks``) give the lowest mode f1 and the band of interest (up to the
    ``max_order / ORDERS_PER_PEAK``-th peak, its top midway to the next, geometrically); the rate
    is decimated to ``RATE_PER_BAND`` x the band's top, and the lags span ``LAG_PERIODS`` periods
    of f1 (at most ``MAX_ROWS`` Toeplitz rows: the band's top comes down to fit). Anything given
    is kept as given."""
    n_out = y.shape[1]
    _order_fits(max_order, n_out, len(y), fs)  # before the spectra: no decimation leaves more samples
    lo, hi = f_band if f_band is not None else (None, None)
    source = {"fmin": "given" if lo is not None else "from the record",
              "fmax": "given" if hi is not None else "from the record",
              "decimation": "given" if decimation is not None else "from the record",
              "block_rows": "given" if block_rows is not None else "from the record"}
    peaks = record_peaks(y, fs, lo or 0.0, hi)
    f1 = float(peaks[0]) if peaks.size else None
    if hi is None:
        if peaks.size and decimation is None:
            k = max(1, max_order // ORDERS_PER_PEAK)
            top = 1.25 * peaks[min(k, peaks.size) - 1]
            if peaks.size > k:
                top = min(top, float(np.sqrt(peaks[k - 1] * peaks[k])))
            if block_rows is None:  # the lag span must fit in MAX_ROWS rows at the decimated rate
                top = min(top, MAX_ROWS / n_out * 2 * f1 / (LAG_PERIODS * RATE_PER_BAND))
            hi = float(min(top, fs / 2))
        else:
            hi = fs / 2 if decimation is None else fs / (decimation * RATE_PER_BAND)
    lo = 0.0 if lo is None else float(lo)
    if not 0 <= lo < hi <= fs / 2:
        raise ConfigError(f"output-only band {lo:g}..{hi:g} Hz must lie within 0..{fs / 2:g} Hz (--fmin, --fmax)")
    if decimation is None:
        decimation = max(1, int(fs // (RATE_PER_BAND * hi))) if hi < fs / 2 else 1
    elif decimation < 1 or fs / decimation < 2 * hi:
        raise ConfigError(f"--decimate {decimation}: the rate {fs / max(decimation, 1):g} Hz must stay above twice "
                          f"the band's top {hi:g} Hz (give a smaller factor or a lower --fmax)")
    rate = fs / decimation
    left = len(y) // decimation
    if source["decimation"] == "given" and left < MIN_DECIMATED:
        raise ConfigError(f"--decimate {decimation}: leaves {left} samples of the record's {len(y)} (at least "
                          f"{MIN_DECIMATED} are needed: give a smaller factor)")
    if block_rows is None:
        _order_fits(max_order, n_out, left, rate)
        need = int(np.ceil(LAG_PERIODS * rate / f1 / 2)) if f1 else 20
        block_rows = max(need, int(np.ceil(max_order / n_out)) + 1)
    elif block_rows * n_out < max_order:
        raise ConfigError(f"--block-rows {block_rows}: {block_rows} x {n_out} outputs cannot hold model order "
                          f"{max_order} (give at least {int(np.ceil(max_order / n_out))} or a lower --max-order)")
    elif 4 * block_rows > left:
        raise ConfigError(f"--block-rows {block_rows}: its lags (2 x {block_rows}) need at least {4 * block_rows} "
                          f"samples at {rate:g} Hz; the record has {left}")
    elif block_rows * n_out > GIVEN_ROWS_MAX:
        raise ConfigError(f"--block-rows {block_rows}: {block_rows} x {n_out} outputs = {block_rows * n_out} "
                          f"Toeplitz rows, at most {GIVEN_ROWS_MAX} (its SVD grows with their cube)")
    highpass = 0.5 * lo if lo > 0 else (HIGHPASS_FRACTION * f1 if f1 else None)
    return OmaSettings((lo, float(hi)), highpass, int(decimation), float(rate), int(block_rows),
                       float((2 * block_rows - 1) / rate), tuple(float(v) for v in peaks), source)


#: at most this many fits: the first, and refits with the band's top widened (``_widened``)
WIDEN_TRIES = 3


def _widened(settings: OmaSettings, first: OmaSettings, dropped: np.ndarray, fs: float,
             block_rows: int | None, n_out: int) -> tuple[float, str] | None:
    """Settings for a refit when the band's top was chosen from the record (``choose_settings``
    places it by the peaks' frequencies alone) and the fit found stable poles that
    ``select_poles`` drops because their half-power band f (1 + 2 zeta) reaches past it (a mode
    more than 12.5 % damped under the 1.25 x peak top): the top goes up to hold them, but not past
    the record's next spectral peak above the first top (its own mode would then need room), the
    Nyquist frequency or the rows the lag span allows. Returns the new top (Hz) and why, or
    None: no refit."""
    if first.source["fmax"] != "from the record" or first.source["decimation"] != "from the record":
        return None
    lo, hi = settings.band_hz
    a, b = half_power_band(dropped)
    above = [p for p in first.peaks_hz if p > first.band_hz[1]]
    limit = min(above[0] if above else fs / 2, fs / 2)
    if block_rows is None and first.peaks_hz:
        limit = min(limit, MAX_ROWS / n_out * 2 * first.peaks_hz[0] / (LAG_PERIODS * RATE_PER_BAND))
    fits = (a >= lo) & (b > hi) & (b <= limit)
    if not fits.any():
        return None
    # room for the refit's own estimate of the pole, which moves by a fraction of its bandwidth
    # (a top exactly at the edge keeps it or not by the last digit)
    room = CLUSTER_BANDWIDTH * zeta_of(dropped) * np.abs(dropped) / (2 * np.pi)
    top = float(min(np.max((b + room)[fits]), limit))
    held = ", ".join(f"{abs(p) / (2 * np.pi):.4g} Hz ({100 * zeta_of(p):.3g} % damped)" for p in dropped[fits])
    return top, (f"band's top widened from {first.band_hz[1]:.3g} Hz (chosen from the record's peaks) to hold "
                 f"the half-power band f(1 + 2 zeta) of the stable poles at {held}")


def _edge_advice(dropped: np.ndarray, lo: float, hi: float, fs: float) -> str:
    """The refusal's words on stable poles dropped at the band's edges and the band that keeps them."""
    if dropped.size == 0:
        return ""
    a, b = half_power_band(dropped)
    names = ", ".join(f"{abs(p) / (2 * np.pi):.4g} Hz ({100 * zeta_of(p):.3g} % damped, half-power band "
                      f"{x:.3g}-{y:.3g} Hz)" for p, x, y in zip(dropped, a, b))
    keep = []
    if (a < lo).any():
        keep.append(f"--fmin {max(0.0, np.floor(float(np.min(a)))):.0f}")  # rounded outwards: it must hold them
    if (b > hi).any():
        keep.append(f"--fmax {np.ceil(float(np.max(b))):.0f}" if np.max(b) <= fs / 2 else
                    f"no --fmax below the Nyquist frequency {fs / 2:.4g} Hz")
    return (f" (stable but dropped because their half-power band reaches past the band's edge: {names}; "
            f"{' and '.join(keep)} would keep them)")


def prepare(y: np.ndarray, fs: float, settings: OmaSettings) -> np.ndarray:
    """The record as SSI-cov and FDD see it: mean removed, high-passed (zero phase, 4th-order
    Butterworth) and decimated (zero-phase FIR) as ``settings`` say."""
    y = np.asarray(y, dtype=float)
    y = y - y.mean(axis=0)
    if settings.highpass_hz:
        sos = scipy.signal.butter(4, settings.highpass_hz, "highpass", fs=fs, output="sos")
        y = scipy.signal.sosfiltfilt(sos, y, axis=0)
    if settings.decimation > 1:
        y = scipy.signal.decimate(y, settings.decimation, ftype="fir", axis=0, zero_phase=True)
    return y


def identify_output_only(
    y: np.ndarray,
    fs: float,
    *,
    f_band: tuple[float | None, float | None] | None = None,
    max_order: int = MAX_ORDER,
    block_rows: int | None = None,
    decimation: int | None = None,
    output_names: list[str] | None = None,
    cross_check: bool = True,
) -> ModalResult:
    """Modes from responses alone: settings from the record (``choose_settings``, each overridable),
    SSI-cov on the prepared record (``prepare``), poles stable over orders
    (``modal.select_poles``), shapes (in the data's units) from the highest order holding each
    pole. Each pole's standard errors come from its scatter over ``SEGMENTS`` segments of the
    record; poles that are not confirmed by the segments or that cannot be told apart from a
    neighbour are reported in ``unresolved``, not as modes. With ``cross_check`` the same prepared
    record also goes through EFDD (``fdd.efdd``), an independent estimator, kept in ``fdd``.
    Residues are not defined without a force: ``residues`` holds the unscaled shapes."""
    y = checked_responses(y)
    if int(max_order) != max_order or max_order < 2:
        raise ConfigError(f"output-only modes: max_order is a model order of at least 2, got {max_order}")
    if decimation is not None and (int(decimation) != decimation or decimation < 1):
        raise ConfigError(f"output-only modes: decimation is a whole factor of at least 1, got {decimation}")
    # one BLAS thread: the matrices are a few hundred wide, and threads spinning against a busy
    # machine made each SVD 4 s instead of 0.05 s
    with threadpool_limits(1):
        return _identify(y, fs, f_band, max_order, block_rows, decimation, output_names, cross_check)


def _identify(y, fs, f_band, max_order, block_rows, decimation, output_names, cross_check) -> ModalResult:
    settings = choose_settings(y, fs, f_band=f_band, block_rows=block_rows, decimation=decimation,
                               max_order=max_order)
    raw, fs_raw, first = y, fs, settings
    for attempt in range(WIDEN_TRIES):
        lo, hi = settings.band_hz
        y = prepare(raw, fs_raw, settings)
        fs = settings.rate_hz
        diagram, shapes = ssi_cov(y, fs, max_order=max_order, block_rows=settings.block_rows, f_band=(lo, hi))
        poles, stable_orders, phi, dropped = _select(diagram, shapes)
        wider = _widened(settings, first, dropped, fs_raw, block_rows, y.shape[1])
        if wider is None or attempt == WIDEN_TRIES - 1:
            break  # the last fit's settings stay with its diagram
        new = choose_settings(raw, fs_raw, f_band=(f_band[0] if f_band else None, wider[0]),
                              block_rows=block_rows, max_order=max_order)
        settings = OmaSettings(new.band_hz, new.highpass_hz, new.decimation, new.rate_hz, new.block_rows,
                               new.lag_span_s, first.peaks_hz, dict(first.source, fmax="widened"), wider[1])
    advice = ("try more --block-rows (a longer lag span), a higher --max-order, or --fmin/--fmax around the "
              "modes you expect; if none helps, this record does not determine the modes (too short or noisy, "
              "or modes too damped and close for the inputs that drove it; see docs/operating.md)")
    if poles.size == 0:
        raise ConfigError(f"no pole in {lo:.3g}..{hi:.3g} Hz is stable over enough model orders (2..{max_order}) "
                          f"with {settings.describe()}{_edge_advice(dropped, lo, hi, fs_raw)}: {advice}")
    one = _one_per_mode(poles, phi, stable_orders)
    poles, phi, stable_orders = poles[one], phi[:, one], stable_orders[one]
    f_std, z_std, count, z_range = _segment_scatter(y, fs, poles, (lo, hi), max_order, settings.block_rows, phi)
    ok, reasons = _resolved(poles, f_std, count, phi, z_range)
    if not ok.any():
        found = "; ".join(f"{abs(p) / (2 * np.pi):.4g} Hz {reasons[r]}" for r, p in enumerate(poles))
        raise ConfigError(f"no stable pole in {lo:.3g}..{hi:.3g} Hz is confirmed as a mode with {settings.describe()} "
                          f"({found}): {advice}")
    unresolved = [Unresolved(float(abs(p) / (2 * np.pi)), float(-p.real / abs(p)), float(f_std[r]), reasons[r])
                  for r, p in enumerate(poles) if not ok[r]]
    shapes_n = normalise_shapes(phi[:, ok])
    fdd = None
    if cross_check:
        from odsuite.analysis.fdd import efdd, resolution_segment

        f1 = abs(poles[ok][0]) / (2 * np.pi) if ok.any() else (settings.peaks_hz or (hi / 4,))[0]
        try:
            fdd = efdd(y, fs, (lo, hi), resolution_segment(f1, fs, y.shape[0]))
        except ConfigError:
            fdd = None  # too short a record for a spectrum fine enough: SSI's result stands alone
    return ModalResult(poles[ok], shapes_n, shapes_n, list(output_names or []), diagram, (lo, hi),
                       stable_orders[ok], [], output_only=True, frequency_std_hz=f_std[ok], damping_std=z_std[ok],
                       unresolved=unresolved, settings=settings, fdd=fdd)
