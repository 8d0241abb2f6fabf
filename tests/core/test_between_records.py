"""The jackknife over records (``diagnosis.between_records``) against exact refits and against the
truth: on a linear model whose records each carry their own systematic misfit, the fit's own
standard deviation (the residual read as noise) claims far too much, the jackknife's covers the
truth as often as a t-distribution with n - 1 degrees of freedom says."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from scipy import stats

from odsuite.diagnosis.between_records import leave_one_record_out_sds, reported_sds

N_RECORDS, N_SAMPLES, THETA = 5, 400, 2.0


def _records(rng, misfit_sd: float, noise_sd: float):
    """Five records y = theta x + s_i z + noise: x a decaying ring at each record's own phase (its
    own force point), z a misfit shaped like part of x whose size s_i each record has its own."""
    t = np.arange(N_SAMPLES) / 1000.0
    xs, ys = [], []
    for _ in range(N_RECORDS):
        phase = rng.uniform(0, 2 * np.pi)
        x = np.exp(-8 * t) * np.sin(2 * np.pi * 37 * t + phase)
        z = np.exp(-8 * t) * np.sin(2 * np.pi * 37 * t + phase + 0.7)
        xs.append(x)
        ys.append(THETA * x + rng.normal(0, misfit_sd) * z + rng.normal(0, noise_sd, N_SAMPLES))
    return xs, ys


def _fit(xs, ys):
    x, y = np.concatenate(xs), np.concatenate(ys)
    theta = float(x @ y / (x @ x))
    r = y - theta * x  # measured - model
    problem = SimpleNamespace(exps=[SimpleNamespace(n_samples=N_SAMPLES, measured=np.zeros((N_SAMPLES, 1)))
                                    for _ in xs],
                              stride=1, prior=False, free=[SimpleNamespace(experiment=None, scale=1.0)])
    res = SimpleNamespace(jac=-x[:, None], fun=r)
    white = np.sqrt(r @ r / (r.size - 1) / (x @ x))
    return theta, problem, res, white


def test_leaving_a_record_out_is_the_exact_refit_for_a_linear_model():
    rng = np.random.default_rng(0)
    xs, ys = _records(rng, 0.3, 0.01)
    theta, problem, res, _ = _fit(xs, ys)
    refits = [_fit(xs[:i] + xs[i + 1:], ys[:i] + ys[i + 1:])[0] for i in range(N_RECORDS)]
    expected = np.sqrt((N_RECORDS - 1) / N_RECORDS * np.sum((np.array(refits) - np.mean(refits)) ** 2))
    np.testing.assert_allclose(leave_one_record_out_sds(problem, res), [expected], rtol=1e-10)


def test_the_jackknife_covers_the_truth_where_the_fits_own_sd_does_not():
    rng = np.random.default_rng(1)
    inside_fit, inside_reported, n = 0, 0, 400
    t2 = stats.t.ppf(0.975, N_RECORDS - 1)  # a 95 % interval with 4 degrees of freedom
    for _ in range(n):
        theta, problem, res, white = _fit(*_records(rng, 0.3, 0.01))
        sd = reported_sds(np.array([white]), problem, res)[0]
        inside_fit += abs(theta - THETA) <= t2 * white
        inside_reported += abs(theta - THETA) <= t2 * sd
    assert inside_fit / n < 0.5  # the residual read as noise: overconfident
    assert 0.90 <= inside_reported / n <= 0.99  # 95 % promised


def test_no_misfit_keeps_the_fits_own_sd_near_its_truth():
    """White noise alone: the fit's sd is right, and the reported one (the larger of the two)
    covers at about its promise, not much wider."""
    rng = np.random.default_rng(2)
    covered, ratios, n = 0, [], 300
    for _ in range(n):
        theta, problem, res, white = _fit(*_records(rng, 0.0, 0.05))
        sd = reported_sds(np.array([white]), problem, res)[0]
        covered += abs(theta - THETA) <= 1.96 * sd
        ratios.append(sd / white)
    assert 0.94 <= covered / n <= 1.0
    assert np.median(ratios) < 1.3


def test_too_few_records_or_a_records_own_parameter_report_the_fits_sd():
    rng = np.random.default_rng(3)
    xs, ys = _records(rng, 0.3, 0.01)
    _, problem, res, white = _fit(xs[:2], ys[:2])
    assert leave_one_record_out_sds(problem, res) is None
    assert reported_sds(np.array([white]), problem, res)[0] == white
    _, problem, res, white = _fit(xs, ys)
    problem.free[0].experiment = "T1"
    assert np.isnan(leave_one_record_out_sds(problem, res)[0])
    assert reported_sds(np.array([white]), problem, res)[0] == white
    assert np.isnan(reported_sds(np.array([np.nan]), problem, res)[0])  # undetermined stays so
