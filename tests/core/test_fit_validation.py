"""The validated (held-out) error of a fit (odsuite.diagnosis.fitting.validate): each fold
refitted towards its own minimum (as far as the full fit went; its search may end on its
Broyden-updated Jacobian), so that it does not depend on where in the full fit's flat valley the
fit ended, against each fold fitted by scipy's least_squares."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import least_squares

from odsuite.diagnosis.fitting import _Free, fit, validate

T = np.linspace(0.0, 1.0, 400)
PHASES = (0.0, 1.1, 2.3)
SIGMA = 0.01


#: how much each experiment's amplitude sees u1: the first most
SEES = (3e-2, 1e-3, 1e-3)
#: the valley's curvature
CURVE = 0.3
#: what the model cannot fit (a tone at another frequency): a large residual, as a candidate
#: that explains part of the data leaves
MISFIT = 0.3


def _prediction(u: np.ndarray, i: int) -> np.ndarray:
    # a frequency set by u0 + u1^2 (a curved valley of equal error: u0 = c - u1^2) and an
    # amplitude that sees u1 weakly: the valley is flat along it
    return (1.0 + SEES[i] * u[1]) * np.sin(2 * np.pi * (3.0 + u[0] + CURVE * u[1] ** 2) * T + PHASES[i])


class _Curve:
    """The part of fitting.Problem that validation and fit use, for a model in closed form:
    three experiments of one channel, two shared parameters, no prior."""

    linear = False
    prior = 0.0
    stride = 1

    def __init__(self, truth: np.ndarray, seed: int) -> None:
        rng = np.random.default_rng(seed)
        self.exps = [SimpleNamespace(name=f"e{i}", n_samples=T.size, fs=T.size / T[-1],
                                     measured=(_prediction(truth, i) + MISFIT * np.sin(2 * np.pi * 4.1 * T + 2 * ph)
                                               + SIGMA * rng.normal(size=T.size))[:, None])
                     for i, ph in enumerate(PHASES)]
        param = [SimpleNamespace(name=n, lower=-10.0, upper=10.0, nominal=0.0, unit="", sensor=None)
                 for n in ("u0", "u1")]
        self.free = [_Free(p, None, 1.0) for p in param]
        self.pull = np.zeros(2)
        self.noise_scale = SIGMA ** 2
        self.evaluations = 0

    def row_weights(self, k=1):
        return np.ones(sum(e.n_samples for e in self.exps))

    def lower_upper(self):
        return np.full(2, -10.0), np.full(2, 10.0)

    def residual(self, u, exps=None, stride=None, weighted=True):
        self.evaluations += 1
        return np.concatenate([e.measured[:, 0] - _prediction(u, self.exps.index(e))
                               for e in (exps or self.exps)])

    def jacobian(self, u, r0, exps=None, step=1.0):
        cols = []
        for i in range(2):
            h = np.zeros(2)
            h[i] = step
            cols.append((self.residual(u + h, exps) - r0) / step)
        return -np.stack(cols, axis=1)  # fit negates: d residual / d u


def _fitted(problem: _Curve, u: np.ndarray) -> SimpleNamespace:
    """What a fit ending at ``u`` returns: its residual and its Jacobian (d residual / d u)."""
    r = problem.residual(u)
    J = np.stack([(problem.residual(u + h) - r) / 1e-7 for h in 1e-7 * np.eye(2)], axis=1)
    return SimpleNamespace(x=u, fun=r, jac=J)


def _reference(problem: _Curve, u: np.ndarray) -> float:
    """Each experiment held out in turn, the others fitted to convergence by scipy from ``u``."""
    total = 0.0
    for e in problem.exps:
        rest = [x for x in problem.exps if x is not e]
        fold = least_squares(lambda x: problem.residual(x, rest), u, xtol=1e-14, ftol=1e-14, gtol=1e-14)
        total += float(np.sum(problem.residual(fold.x, [e]) ** 2))
    return total


def test_the_validated_error_is_each_folds_own_minimum_wherever_in_the_valley_the_fit_ended():
    problem = _Curve(np.array([0.0, 0.6]), seed=7)
    best = least_squares(problem.residual, np.array([0.01, 0.5]), xtol=1e-15, ftol=1e-15, gtol=1e-15).x
    sse = float(np.sum(problem.residual(best) ** 2))
    # along the valley (u0 = c - CURVE u1^2) to where the sum of squares is 1e-7 higher
    along = lambda s: best + np.array([-CURVE * (2 * best[1] * s + s * s), s])  # noqa: E731
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if float(np.sum(problem.residual(along(mid)) ** 2)) - sse < 1e-7 else (lo, mid)
    other = along(lo)
    assert float(np.sum(problem.residual(other) ** 2)) - sse == pytest.approx(1e-7, rel=1e-3)
    reference = _reference(problem, best)
    assert _reference(problem, other) == pytest.approx(reference, rel=1e-4)  # the folds' own minima
    one, how = validate(problem, best, _fitted(problem, best))
    two, _ = validate(problem, other, _fitted(problem, other))
    assert how == "leave one experiment out"
    # one Gauss-Newton step per fold (halved until the rows left in fit no worse) read 56.598 and
    # 55.160 here: 2.5 % apart for 1e-7 of the sum of squares
    assert two == pytest.approx(one, rel=1e-4)
    # each fold stops within a noise energy of its minimum's cost (the fit's own stop); along the
    # folds' flat valleys the held-out error moves 1.1 % within that
    assert one == pytest.approx(reference, rel=0.02)


def test_a_fold_ends_on_its_updated_jacobian_and_validates_as_its_minimum():
    # a fold reads its point alone: where the secant through its steps says it is done, the
    # differenced Jacobian that would confirm it is not taken
    problem = _Curve(np.array([0.0, 0.6]), seed=3)
    best = least_squares(problem.residual, np.array([0.01, 0.5]), xtol=1e-15, ftol=1e-15, gtol=1e-15).x
    J = _fitted(problem, best).jac
    jacobians = {}
    for ends in (False, True):
        calls = []
        difference = problem.jacobian
        problem.jacobian = lambda *a, **k: (calls.append(1), difference(*a, **k))[1]  # noqa: B023
        held = reference = 0.0
        for i, e in enumerate(problem.exps):
            rest = [x for x in problem.exps if x is not e]
            fold = fit(problem, best, exps=rest, continuation=False, secant_ends=ends,
                       jac0=np.delete(J, np.s_[i * T.size:(i + 1) * T.size], axis=0))
            minimum = least_squares(lambda x: problem.residual(x, rest), best, xtol=1e-14, ftol=1e-14, gtol=1e-14)
            held += float(np.sum(problem.residual(fold.x, [e]) ** 2))
            reference += float(np.sum(problem.residual(minimum.x, [e]) ** 2))
        # validated as by scipy's fold minima, within the test above's tolerance
        assert held == pytest.approx(reference, rel=0.02)
        problem.jacobian = difference
        jacobians[ends] = len(calls)
    assert jacobians[True] < jacobians[False]
