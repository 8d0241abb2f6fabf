"""How far a fitted value moves between records: the leave-one-record-out jackknife of a fit.

The fit's own standard deviations (``fitting.uncertainties``) read the residual as noise, inflated
for its samples' correlation. A model that misses some physics leaves a residual that is not
noise: it pulls the fitted values, and pulls them differently in each record (another force
point, another force level excites the missing physics differently). The jackknife over records
sees that pull as the spread of the values refitted without each record in turn, so a value
reported with ``max(fit's sd, jackknife sd)`` is not more certain than the records agree. A
misfit every record shares alike (the same pull in all) stays unseen, as it would with any
number of records of the same test.
"""

from __future__ import annotations

import numpy as np

#: fewer records give a spread too uncertain to report (3 records: 2 degrees of freedom)
MIN_RECORDS = 3


def leave_one_record_out_sds(problem, res) -> np.ndarray | None:
    """Per free parameter (value units), the jackknife standard deviation over the problem's
    records: each record's rows left out in turn by one Gauss-Newton step from the joint fit
    (exact for a linear model), ``sqrt((n - 1) / n * sum((u_i - mean)^2))``. NaN for a parameter
    of one record (nothing refits it without that record); None for fewer than ``MIN_RECORDS``."""
    exps = problem.exps
    if len(exps) < MIN_RECORDS or not problem.free:
        return None
    n_data = res.fun.size - (len(problem.free) if problem.prior else 0)
    J, r = res.jac[:n_data], res.fun[:n_data]
    sizes = [len(range(0, e.n_samples, problem.stride)) * e.measured.shape[1] for e in exps]
    if sum(sizes) != n_data:
        return None
    starts = np.concatenate([[0], np.cumsum(sizes)])
    A = J.T @ J
    steps = []
    for i in range(len(exps)):
        Jh, rh = J[starts[i]:starts[i + 1]], r[starts[i]:starts[i + 1]]
        # r = measured - model and J = dr/du: at the joint fit the other records' gradient is
        # -J_h^T r_h, and their Gauss-Newton step (A - J_h^T J_h)^-1 J_h^T r_h
        steps.append(np.linalg.lstsq(A - Jh.T @ Jh, Jh.T @ rh, rcond=1e-10)[0])
    d = np.asarray(steps)
    n = len(exps)
    var = (n - 1) / n * np.sum((d - d.mean(axis=0)) ** 2, axis=0)
    scales = np.array([f.scale for f in problem.free])
    own = np.array([f.experiment is not None for f in problem.free])
    return np.where(own, np.nan, np.sqrt(var) * scales)


def reported_sds(fit_sds: np.ndarray, problem, res) -> np.ndarray:
    """The larger of the fit's standard deviation and the jackknife's over records, per parameter."""
    spread = leave_one_record_out_sds(problem, res)
    if spread is None:
        return fit_sds
    return np.where(np.isfinite(fit_sds), np.fmax(fit_sds, spread), fit_sds)  # undetermined stays so
