"""The spread between records (``diagnosis.between_records``) against exact refits and against the
truth: on a linear model whose records each carry their own systematic misfit, the fit's own
standard deviation (the residual read as noise) claims far too much, the jackknife's covers the
truth as often as a t-distribution with n - 1 degrees of freedom says."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from scipy import stats

from odsuite.diagnosis.between_records import between_records_covariance, reported_with_covariance


def between_records_sds(problem, res):
    """The between-records standard deviations: the covariance's diagonal, square-rooted."""
    cov = between_records_covariance(problem, res)
    return None if cov is None else np.sqrt(np.diag(cov))


def reported_sds(fit_sds, problem, res):
    """The standard deviations diagnose and add-effect report."""
    return reported_with_covariance(fit_sds, problem, res)[0]

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


def test_leaving_a_record_out_is_the_refit_to_first_order_for_a_linear_model():
    """The cluster-robust closed form, and within a percent of the jackknife of exact refits
    without each record (records of about equal information)."""
    rng = np.random.default_rng(0)
    xs, ys = _records(rng, 0.3, 0.01)
    theta, problem, res, _ = _fit(xs, ys)
    a = sum(x @ x for x in xs)
    pulls = [x @ (y - theta * x) for x, y in zip(xs, ys)]
    sandwich = np.sqrt(N_RECORDS / (N_RECORDS - 1) * sum(g * g for g in pulls)) / a
    np.testing.assert_allclose(between_records_sds(problem, res), [sandwich], rtol=1e-10)
    refits = [_fit(xs[:i] + xs[i + 1:], ys[:i] + ys[i + 1:])[0] for i in range(N_RECORDS)]
    jackknife = np.sqrt((N_RECORDS - 1) / N_RECORDS * np.sum((np.array(refits) - np.mean(refits)) ** 2))
    np.testing.assert_allclose(between_records_sds(problem, res), [jackknife], rtol=0.01)


def test_a_direction_one_record_alone_determines_does_not_blow_up():
    """Two parameters, the second's own part of the prediction seen well by one record only (a
    spring only one blow excites) and barely by the rest: refits without that record move freely
    along it, and their jackknife is 29x the fit's sd on pure noise; the spread between records
    stays within the fit's, as it should with nothing but noise in the records."""
    rng = np.random.default_rng(0)
    t = np.arange(N_SAMPLES) / 1000.0
    cols, ys = [], []
    for k in range(N_RECORDS):
        x = np.exp(-8 * t) * np.sin(2 * np.pi * 37 * t + rng.uniform(0, 2 * np.pi))
        w = 0.5 * x + (3e-2 if k == 0 else 1e-3) * np.exp(-8 * t) * np.cos(2 * np.pi * 53 * t)
        cols.append(np.column_stack([x, w]))
        ys.append(cols[-1] @ [THETA, 1.0] + rng.normal(0, 0.01, N_SAMPLES))

    def fitted(keep):
        X, y = np.vstack([cols[i] for i in keep]), np.concatenate([ys[i] for i in keep])
        return X, y, np.linalg.lstsq(X, y, rcond=None)[0]

    X, y, u = fitted(range(N_RECORDS))
    problem = SimpleNamespace(exps=[SimpleNamespace(n_samples=N_SAMPLES, measured=np.zeros((N_SAMPLES, 1)))
                                    for _ in ys], stride=1, prior=False,
                              free=[SimpleNamespace(experiment=None, scale=1.0) for _ in range(2)])
    res = SimpleNamespace(jac=-X, fun=y - X @ u)
    fit_sd = np.sqrt(np.diag(np.linalg.inv(X.T @ X)) * np.sum(res.fun ** 2) / (y.size - 2))
    refits = np.array([fitted([j for j in range(N_RECORDS) if j != i])[2] for i in range(N_RECORDS)])
    jackknife = np.sqrt((N_RECORDS - 1) / N_RECORDS * np.sum((refits - refits.mean(axis=0)) ** 2, axis=0))
    assert np.all(jackknife > 10 * fit_sd)  # the case: refits without record 0 are free along it
    between = np.sqrt(np.diag(between_records_covariance(problem, res)))
    assert np.all(between < fit_sd)
    np.testing.assert_array_equal(reported_sds(fit_sd, problem, res), fit_sd)


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
    assert between_records_sds(problem, res) is None
    assert reported_sds(np.array([white]), problem, res)[0] == white
    _, problem, res, white = _fit(xs, ys)
    problem.free[0].experiment = "T1"
    assert np.isnan(between_records_sds(problem, res)[0])
    assert reported_sds(np.array([white]), problem, res)[0] == white
    assert np.isnan(reported_sds(np.array([np.nan]), problem, res)[0])  # undetermined stays so


def test_a_parameter_held_at_a_bound_is_not_spread_by_its_pull():
    """Held at a bound 0.1 below where the records put it: every record pulls the same way, which is
    no disagreement between them (uncentred, that pull alone read as a spread of 0.05 in 2)."""
    rng = np.random.default_rng(5)
    xs, ys = _records(rng, 0.0, 0.01)
    _, problem, res, white = _fit(xs, ys)
    x, y = np.concatenate(xs), np.concatenate(ys)
    res.fun = y - (THETA - 0.1) * x  # the fit at its lower bound
    assert between_records_sds(problem, res)[0] < 3 * white
