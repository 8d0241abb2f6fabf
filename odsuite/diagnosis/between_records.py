"""How far a fitted value moves between records: the leave-one-record-out jackknife of a fit, in
its infinitesimal (cluster-robust) form.

The fit's own standard deviations (``fitting.uncertainties``) read the residual as noise, coloured
as its spectra say. A model that misses some physics leaves a residual that is not
noise: it pulls the fitted values, and pulls them differently in each record (another force
point, another force level excites the missing physics differently). The spread between records
sees that pull, so a value reported with ``max(fit's sd, between-records sd)`` is not more certain
than the records agree. A misfit every record shares alike (the same pull in all) stays unseen, as
it would with any number of records of the same test.

Each record's pull is its gradient at the joint fit, ``g_h = J_h^T r_h``, turned into a step by the
joint fit's information ``A = J^T J``, ``d_h = A^-1 g_h``: ``cov = n / (n - 1) * sum (d_h - mean)(d_h -
mean)^T`` (the mean is zero at an unbounded optimum without a prior). For
records of equal information this is the jackknife of refits without each record to first order;
unlike those refits it does not blow up where one record alone determines a direction (the rest
then leave it undetermined, and a refit without that record moves along it anywhere): the
jackknife's spread there is that of the refits' freedom, not of the records' disagreement.
"""

from __future__ import annotations

import numpy as np

#: fewer records give a spread too uncertain to report (3 records: 2 degrees of freedom)
MIN_RECORDS = 3


def between_records_covariance(problem, res) -> np.ndarray | None:
    """The between-records covariance of the problem's free parameters (value units, module
    docstring). NaN rows and columns for a parameter of one record (no other record holds it);
    None for fewer than ``MIN_RECORDS``. Its off-diagonal terms matter: parameters the data do not
    separate (a scale per axis times one per spring) move together, their determined products not."""
    exps = problem.exps
    if len(exps) < MIN_RECORDS or not problem.free:
        return None
    n_data = res.fun.size - (len(problem.free) if problem.prior else 0)
    J, r = res.jac[:n_data], res.fun[:n_data]
    sizes = [len(range(0, e.n_samples, problem.stride)) * e.measured.shape[1] for e in exps]
    if sum(sizes) != n_data:
        return None
    starts = np.concatenate([[0], np.cumsum(sizes)])
    pulls = np.array([J[a:b].T @ r[a:b] for a, b in zip(starts[:-1], starts[1:])])
    steps = np.linalg.lstsq(J.T @ J, pulls.T, rcond=1e-10)[0].T  # A^-1 g_h, undetermined directions left out
    scales = np.array([f.scale for f in problem.free])
    # centred: the pulls sum to zero only at an unbounded optimum without a prior; a parameter held
    # at a bound is pulled alike by every record, which is no disagreement between them
    d = (steps - steps.mean(axis=0)) * scales
    n = len(exps)
    cov = n / (n - 1) * d.T @ d
    own = np.array([f.experiment is not None for f in problem.free])
    cov[own, :] = np.nan
    cov[:, own] = np.nan
    return cov


def reported_with_covariance(fit_sds: np.ndarray, problem, res) -> tuple[np.ndarray, np.ndarray | None]:
    """Per parameter the larger of the fit's standard deviation and the one between records
    (:func:`larger_sds`), and the covariance between records it took them from (None: the fit's
    alone), from which physical quantities take theirs: what diagnose prints and add-effect stores."""
    if res is None:
        return fit_sds, None
    cov = between_records_covariance(problem, res)  # once: the sds and the quantities both read it
    return larger_sds(fit_sds, cov), cov


def larger_sds(fit_sds: np.ndarray, cov: np.ndarray | None) -> np.ndarray:
    """The larger of the fit's standard deviation and the one between records (the square root of
    ``cov``'s diagonal, between_records_covariance), per parameter (None: the fit's)."""
    if cov is None:
        return fit_sds
    spread = np.sqrt(np.diag(cov))
    return np.where(np.isfinite(fit_sds), np.fmax(fit_sds, spread), fit_sds)  # undetermined stays so
