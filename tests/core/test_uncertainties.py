"""A fit's own standard deviations (``fitting.uncertainties``) against Monte Carlo refits of a
linear problem: two modes' amplitudes seen by two channels, under noise that rings at one of the
modes and is shared by the channels (a force channel's noise through the structure) plus white
noise of each channel. The white-noise formula, even with the residual's effective samples, is
off by a factor of two and more; the sandwich is within 10 % of the refits' spread."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import scipy.signal

from odsuite.diagnosis.checks import effective_samples
from odsuite.diagnosis.fitting import residual_score_covariance, uncertainties

FS, M, C = 1000.0, 1024, 2  # Hz, samples, channels
MODES_HZ, DAMPING = (80.0, 200.0), 0.03


def _jacobian() -> np.ndarray:
    """Rows: samples, channels within a sample (the fit's layout); columns: each mode's decaying
    ring, seen by the two channels with their own participations."""
    t = np.arange(M) / FS
    cols = []
    for f, share in zip(MODES_HZ, ((1.0, 0.7), (0.4, -1.0))):
        w = 2 * np.pi * f
        ring = np.exp(-DAMPING * w * t) * np.sin(w * t)
        cols.append(np.stack([share[0] * ring, share[1] * ring], axis=1).ravel())
    return np.stack(cols, axis=1)


def _noise(rng, white_sd: float = 0.3, ringing_sd: float = 3.0) -> np.ndarray:
    b, a = scipy.signal.iirpeak(MODES_HZ[0], 8, FS)
    shared = scipy.signal.lfilter(b, a, rng.standard_normal(M + 500))[500:]  # settled
    return (ringing_sd * np.stack([shared, 0.7 * shared], axis=1) + white_sd * rng.standard_normal((M, C))).ravel()


def _problem(p: int):
    return SimpleNamespace(exps=[SimpleNamespace(n_samples=M, measured=np.zeros((M, C)))], stride=1, prior=False,
                           at_rest=lambda e: e.measured[:0],
                           free=[SimpleNamespace(label=f"a{i}", scale=1.0, experiment=None) for i in range(p)])


def _fits(J, rng, draws, **noise):
    """Each draw's fitted amplitudes (truth zero) and residual (measured - model)."""
    Ainv = np.linalg.inv(J.T @ J)
    out = []
    for _ in range(draws):
        y = _noise(rng, **noise)
        u = Ainv @ J.T @ y
        out.append((u, y - J @ u))
    return out


def test_sandwich_matches_refits_under_ringing_shared_noise_where_the_white_formula_does_not():
    rng = np.random.default_rng(0)
    J = _jacobian()
    problem = _problem(J.shape[1])
    fits = _fits(J, rng, 1500)
    refits = np.std([u for u, _ in fits], axis=0)
    sandwich, white, with_neff = [], [], []
    Ainv = np.linalg.inv(J.T @ J)
    for _, r in fits[:150]:
        # res.jac is d r / d u = -J; n_eff as diagnose and add-effect pass it
        n_eff = effective_samples(r.reshape(M, C))
        sandwich.append(uncertainties(problem, SimpleNamespace(jac=-J, fun=r), n_eff)[0])
        s2 = r @ r / (r.size - J.shape[1])
        white.append(np.sqrt(s2 * np.diag(Ainv)))
        with_neff.append(np.sqrt(s2 * r.size / n_eff * np.diag(Ainv)))
    ratio = np.mean(sandwich, axis=0) / refits
    assert np.all(np.abs(ratio - 1) < 0.10), ratio
    # the ringing mode's amplitude: the white formula claims several times too much certainty,
    # the effective samples still three times; the other mode's, which the ringing does not
    # reach, both claim too little (measured: 0.18 and 1.8, 0.30 and 2.9)
    assert np.mean(white, axis=0)[0] / refits[0] < 0.5 and np.mean(white, axis=0)[1] / refits[1] > 1.5
    assert np.mean(with_neff, axis=0)[0] / refits[0] < 0.5 and np.mean(with_neff, axis=0)[1] / refits[1] > 1.5


def test_white_noise_gives_the_white_noise_covariance():
    """Var(J^T r) of white noise is s2 J^T J: the sandwich is the usual formula there, on average
    over draws (one draw's estimate rests on the few frequencies a ring's band holds)."""
    rng = np.random.default_rng(1)
    J = _jacobian()
    B = np.mean([residual_score_covariance(J, 0.5 * rng.standard_normal(M * C), [(0, M, C)])
                 for _ in range(200)], axis=0)
    expected = 0.25 * J.T @ J
    assert np.allclose(np.diag(B), np.diag(expected), rtol=0.05)
    assert abs(B[0, 1] - expected[0, 1]) < 0.02 * np.sqrt(expected[0, 0] * expected[1, 1])


def test_undetermined_directions_stay_out_and_are_named():
    """Two identical columns: their sum is determined, each alone not; the pseudo-inverse keeps the
    determined sum's sd (that of a one-column fit) and names the pair."""
    rng = np.random.default_rng(2)
    J1 = _jacobian()[:, :1]
    J = np.hstack([J1, J1])
    r = _noise(rng, ringing_sd=0.0)
    r = r - J1[:, 0] * (J1[:, 0] @ r) / (J1[:, 0] @ J1[:, 0])
    sds, corr, groups, nulls = uncertainties(_problem(2), SimpleNamespace(jac=-J, fun=r), n_eff=r.size)
    one = uncertainties(_problem(1), SimpleNamespace(jac=-J1, fun=r), n_eff=r.size)[0]
    assert groups == [["a0", "a1"]]
    # the direction the data cannot see: a0 up, a1 down, equally (search units, unit length)
    assert nulls.shape == (2, 1) and np.allclose(np.abs(nulls[:, 0]), np.sqrt(0.5)) and nulls[0, 0] * nulls[1, 0] < 0
    # var(a0 + a1) from the pseudo-inverse covariance: the one-column fit's
    var_sum = sds[0] ** 2 + sds[1] ** 2 + 2 * corr[0, 1] * sds[0] * sds[1]
    assert np.sqrt(var_sum) == np.float64(np.sqrt(var_sum))
    assert abs(np.sqrt(var_sum) / one[0] - 1) < 0.02


def test_the_effective_samples_are_asked_for_only_where_the_rows_are_laid_out_otherwise():
    """The N / N_eff fallback reads ``n_eff`` (a number or a function); the sandwich does not ask."""
    rng = np.random.default_rng(3)
    J = _jacobian()[:, :1]
    r = _noise(rng, ringing_sd=0.0)
    asked = []

    def n_eff() -> float:
        asked.append(1)
        return r.size / 4

    problem = _problem(1)
    sandwich = uncertainties(problem, SimpleNamespace(jac=-J, fun=r), n_eff)[0]
    assert asked == []
    other_layout = SimpleNamespace(**{**vars(problem), "stride": 2})  # rows no longer every sample
    fallback = uncertainties(other_layout, SimpleNamespace(jac=-J, fun=r), n_eff)[0]
    assert asked == [1]
    assert fallback[0] == uncertainties(other_layout, SimpleNamespace(jac=-J, fun=r), r.size / 4)[0][0]
    assert sandwich[0] > 0


def score_transform_length(m: int) -> int:
    """The least even number of at least 2 m (no lag of m samples wraps) with no prime factor
    above 5, by trial: the score covariance's transform length for records of m samples."""
    def smooth(n: int) -> bool:
        for q in (2, 3, 5):
            while n % q == 0:
                n //= q
        return n == 1

    return next(n for n in range(2 * m, 4 * m + 4, 2) if smooth(n))


def test_score_covariance_equals_the_smoothed_cross_spectral_matrices_formed_explicitly():
    """The rank-one form (no cross-spectral matrix formed) against S(f) built and smoothed as
    written: per frequency J(f)^H S(f) J(f), S the periodogram R R^H / m smoothed by
    scipy.ndimage over the window, edges reflected, at the transform length
    score_transform_length (517 samples: 1080, where the power of two above 2 m is 2048); two
    records of 3 channels, coloured noise."""
    import scipy.ndimage

    from odsuite.diagnosis.fitting import SPECTRAL_SMOOTHING_BINS, residual_score_covariance

    rng = np.random.default_rng(4)
    blocks, start, p = [], 0, 4
    for m in (300, 517, 2):  # the last: a window wider than the record's spectrum, mirrored twice
        blocks.append((start, m, 3))
        start += m * 3
    J = rng.standard_normal((start, p))
    r = np.convolve(rng.standard_normal(start), np.ones(7), "same")
    expected = np.zeros((p, p))
    for first, m, c in blocks:
        rows = slice(first, first + m * c)
        nfft = score_transform_length(m)
        R = np.fft.rfft(r[rows].reshape(m, c), nfft, axis=0)
        G = np.fft.rfft(J[rows].reshape(m, c, p), nfft, axis=0)
        P = R[:, :, None] * R[:, None, :].conj() / m
        width = 2 * int(round(SPECTRAL_SMOOTHING_BINS * nfft / m)) + 1
        S = (scipy.ndimage.uniform_filter1d(P.real, width, axis=0, mode="reflect")
             + 1j * scipy.ndimage.uniform_filter1d(P.imag, width, axis=0, mode="reflect"))
        twice = np.full(len(R), 2.0)
        twice[[0, -1]] = 1.0
        for f in range(len(R)):
            expected += twice[f] * (G[f].conj().T @ S[f] @ G[f]).real / nfft
    got = residual_score_covariance(J, r, blocks)
    assert np.allclose(got, (expected + expected.T) / 2, rtol=1e-12, atol=1e-12 * np.abs(expected).max())


def test_score_covariance_counts_the_rows_at_rest_a_window_cut_as_rows_of_zero_jacobian():
    """Rows at rest cut from a window (Problem.at_rest) count in the residual's spectrum as they
    did in the window that kept them, where the Jacobian's rows are zero: the same covariance
    (their transform differs from J's own by a phase that J(f)^H S(f) J(f) does not see)."""
    from odsuite.diagnosis.fitting import residual_score_covariance

    rng = np.random.default_rng(11)
    p, c = 3, 2
    sizes, rests = (400, 257), (120, 37)
    J_cut, r_cut, J_whole, r_whole, blocks_cut, blocks_whole, at_rest = [], [], [], [], [], [], []
    for m, m0 in zip(sizes, rests):
        J = rng.standard_normal((m * c, p))
        r = np.convolve(rng.standard_normal(m * c), np.ones(5), "same")
        rest = rng.standard_normal((m0, c))
        blocks_cut.append((sum(x.shape[0] for x in J_cut), m, c))
        blocks_whole.append((sum(x.shape[0] for x in J_whole), m + m0, c))
        J_cut.append(J), r_cut.append(r), at_rest.append(rest)
        J_whole.append(np.concatenate([np.zeros((m0 * c, p)), J])), r_whole.append(np.concatenate([rest.ravel(), r]))
    got = residual_score_covariance(np.concatenate(J_cut), np.concatenate(r_cut), blocks_cut, at_rest)
    want = residual_score_covariance(np.concatenate(J_whole), np.concatenate(r_whole), blocks_whole)
    assert np.allclose(got, want, rtol=1e-10, atol=1e-12 * np.abs(want).max())
    without = residual_score_covariance(np.concatenate(J_cut), np.concatenate(r_cut), blocks_cut)
    assert not np.allclose(without, want, rtol=0.05)


def test_a_quantity_along_a_direction_the_data_cannot_see_is_not_determined():
    # two parameters whose difference the data cannot see (null direction (1, -1)): each alone is
    # one of many values that fit alike, their sum is determined; a product of two factors traded
    # off in logarithms (a stiffness scale per axis times one per group) stays determined
    from odsuite.diagnosis.physical import mark_undetermined

    class Effect:
        @staticmethod
        def values(model, v):
            return dict(v)

        @staticmethod
        def physical(model, v):
            return [("a", v["a"], "N/m"), ("b", v["b"], "N/m"), ("a + b", v["a"] + v["b"], "N/m"),
                    ("a b", np.exp(v["la"] + v["lb"]), "N/m")]

    def values_at(x):
        return {"a": 1.0 + x[0], "b": 2.0 + x[1], "la": x[2], "lb": x[3]}

    nulls = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]) / np.sqrt(2)
    rows = [{"label": k, "value": v, "unit": u, "uncertainty": 0.1, "nominal": v}
            for k, v, u in Effect.physical(None, values_at(np.zeros(4)))]
    mark_undetermined(rows, Effect, None, values_at, np.zeros(4), nulls)
    assert [r.get("determined", True) for r in rows] == [False, False, True, True]
    assert [r["uncertainty"] for r in rows] == [None, None, 0.1, 0.1]
