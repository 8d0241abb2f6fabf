"""The fits' numerical kernels against the plain formulas they stand for: a residual written in
place into the whole (fitting.Problem._residual_of), a sensor's Jacobian columns written through
strided slices (fitting.Problem._sensor_slices), the score covariance's real product."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))


@pytest.fixture(scope="module")
def thesis(tmp_path_factory):
    """Two thesis records' fit windows and the rig's model."""
    from hidden_effects import CASES, make_project

    import odsuite.diagnosis.fitting as fitting
    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import prepare
    from odsuite.store.project import open_project

    path = make_project(tmp_path_factory.mktemp("kernels") / "s.odsp", [("stiffness", CASES["stiffness"])],
                        n_samples=2048)
    with open_project(path) as p:
        exps = prepare(p)[:2]
        yield fitting.fit_windows(exps), revision_model(p)


def _problem(thesis, effect: str, stride: int):
    import odsuite.diagnosis.fitting as fitting
    from odsuite.contracts.plugins import registries

    exps, base = thesis
    return fitting.Problem(base, registries().effects.get(effect), exps, stride=stride)


@pytest.mark.parametrize("stride", [1, 3])
def test_residual_is_each_records_weighted_difference_and_an_unstable_one_is_capped(thesis, stride):
    """Measured minus predicted, times each channel's weight, records one after the other; a
    prediction that blew up (inf, nan, far beyond the record) capped at UNSTABLE_RESIDUAL times
    the record's peak with its sign; a choice of channels keeps those columns only."""
    import odsuite.diagnosis.fitting as fitting

    problem = _problem(thesis, "stiffness", stride)
    exps = problem.exps
    preds = problem.predictions(problem.zero())
    expected = np.concatenate([((e.measured[::stride] - p[::stride]) * problem.weights[e.name]).ravel()
                               for e, p in zip(exps, preds)])
    assert np.array_equal(problem._residual_of(preds, exps, k=stride), expected)
    unweighted = np.concatenate([(e.measured[::stride] - p[::stride]).ravel() for e, p in zip(exps, preds)])
    assert np.array_equal(problem._residual_of(preds, exps, k=stride, weighted=False), unweighted)
    columns = [0, 2]
    chosen = np.concatenate([((e.measured[::stride] - p[::stride]) * problem.weights[e.name])[:, columns].ravel()
                             for e, p in zip(exps, preds)])
    assert np.array_equal(problem._residual_of(preds, exps, columns, k=stride), chosen)
    # the second record's prediction blown up: inf, -inf, nan and a large finite value
    wild = preds[1].copy()
    wild[0, 0], wild[1, 1], wild[2, 0], wild[3, 1] = np.inf, -np.inf, np.nan, 1e30
    cap = fitting.UNSTABLE_RESIDUAL * fitting._peak(exps[1].measured)
    got = problem._residual_of([preds[0], wild], exps, k=stride, weighted=False)
    second = got[exps[0].measured[::stride].size:].reshape(exps[1].measured[::stride].shape)
    assert np.array_equal(got[:exps[0].measured[::stride].size], unweighted[:exps[0].measured[::stride].size])
    if stride == 1:
        assert second[0, 0] == -cap and second[1, 1] == cap and second[2, 0] == cap and second[3, 1] == -cap
    assert np.abs(second).max() <= cap and np.isfinite(second).all()
    plain = exps[1].measured[::stride] - wild[::stride]
    plain = np.clip(np.nan_to_num(plain, nan=cap, posinf=cap, neginf=-cap), -cap, cap)
    assert np.array_equal(second, plain)


def test_sensor_jacobian_through_slices_equals_each_column_differenced_alone(thesis):
    """Parameters of different sensors differenced together (one evaluation moves one of each
    sensor), each column written into its sensor's rows through strided slices: the same column
    as the parameter's own difference there to the bit, zero in the other sensors' rows (where the
    own difference is rounding); the slices cover exactly
    the rows _sensor_batches names."""
    problem = _problem(thesis, "sensor_orientation", 3)
    exps = problem.exps
    batches, rows_of = problem._sensor_batches(exps)
    assert rows_of is not None and len(batches) < len(problem.free)  # batched
    slices = problem._sensor_slices(exps)
    n = sum(len(range(0, e.n_samples, 3)) * e.measured.shape[1] for e in exps)
    every = np.arange(n)
    for name, rows in rows_of.items():
        assert np.array_equal(np.sort(np.concatenate([every[s] for s in slices[name]])), np.sort(rows))
    lo, hi = problem.lower_upper()
    u = np.clip(np.random.default_rng(3).normal(0.0, 0.3, len(problem.free)), lo, hi)
    r0 = problem.residual(u)
    J = problem.jacobian(u, r0)
    assert J.flags.c_contiguous and J.shape == (n, len(u))
    for i, f in enumerate(problem.free):
        du = np.zeros_like(u)
        h = 1.0 if u[i] + 1.0 <= hi[i] else -1.0
        du[i] = h
        alone = -(problem.residual(u + du, keep=False) - r0) / h
        rows = rows_of[f.param.sensor]
        assert np.array_equal(J[rows, i], alone[rows]), f.label
        others = np.setdiff1d(every, rows)
        assert not J[others, i].any()
        # where the other sensors' rows are not the kept ones to the bit, the difference is their
        # rounding, against the residual's size
        assert np.abs(alone[others]).max() <= 1e-12 * np.abs(r0).max()
        assert np.abs(alone[rows]).max() > 0


def test_score_covariance_is_the_complex_sum_of_outer_products():
    """Var(J^T r) as sum over frequencies f and window offsets k of Re(a a^H), a = J(f)^T
    conj(R(f + k)), each frequency but zero and Nyquist twice, written out with complex outer
    products: the real product of the interleaved real and imaginary parts equals it."""
    from test_uncertainties import score_transform_length

    from odsuite.diagnosis.fitting import SPECTRAL_SMOOTHING_BINS, residual_score_covariance

    rng = np.random.default_rng(11)
    m, c, p = 400, 3, 5
    J = rng.standard_normal((m * c, p))
    r = np.convolve(rng.standard_normal(m * c), np.ones(5), "same")
    nfft = score_transform_length(m)  # 800
    R = np.fft.rfft(r.reshape(m, c), nfft, axis=0)
    G = np.fft.rfft(J.reshape(m, c, p), nfft, axis=0)
    n_f = len(R)
    width = 2 * int(round(SPECTRAL_SMOOTHING_BINS * nfft / m)) + 1
    expected = np.zeros((p, p), complex)
    for f in range(n_f):
        weight = 1.0 if f in (0, n_f - 1) else 2.0
        for k in range(-(width // 2), width // 2 + 1):
            g = f + k
            g = -g - 1 if g < 0 else (2 * n_f - 1 - g if g >= n_f else g)  # reflected at the edges
            a = G[f].T @ R[g].conj()
            expected += weight * np.outer(a, a.conj())
    expected = expected.real / (width * m * nfft)
    got = residual_score_covariance(J, r, [(0, m, c)])
    assert np.abs(got - expected).max() <= 1e-12 * np.abs(expected).max()
