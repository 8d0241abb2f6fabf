"""The diagnosis's own trust-region least squares (odsuite.diagnosis.fitting._trf) against scipy's
least_squares(method="trf") on a bounded nonlinear problem (a decaying sine, its frequency and
phase far from linear): without Broyden updates and steps taken further the same iterates,
evaluations and minimum; with them the same minimum in fewer Jacobians, and (with a loose ftol) no
earlier stop than scipy's on an updated Jacobian's promise. A step taken further (fitting._further)
against the closed-form minimum of a quadratic cost, and on a fit whose residual stays large
(Gauss-Newton steps fall short along their line) against scipy's minimum."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize

from odsuite.contracts.effects import Parameter
from odsuite.diagnosis.fitting import FURTHER_MAX, STALL_GAIN, _Free, _further, _Stops, _trf, search

T = np.linspace(0.0, 1.0, 4000)
LO, HI = np.array([0.0, 0.0, 5.0, -3.0, -1.0]), np.array([2.0, 10.0, 9.0, 3.0, 0.45])


@pytest.mark.parametrize("x0", [[0.5, 1.0, 6.5, 0.0, 0.0], [1.5, 5.0, 7.4, 1.0, 0.2]])
def test_trf_is_scipys_trf_without_updates_and_reaches_its_minimum_with_them(x0):
    fun, jac = _noisy(1, 0.01)  # its offset's slope beyond its bound: the fit ends on it
    x0 = np.array(x0)
    ref = scipy.optimize.least_squares(fun, x0, jac=jac, bounds=(LO, HI), method="trf", x_scale=1.0,
                                       max_nfev=60, xtol=1e-6, ftol=1e-8)
    same = _trf(fun, jac, x0, LO, HI, max_nfev=60, xtol=1e-6, ftol=1e-8, stops=_Stops(0.0, None, LO, HI),
                broyden=False, further=False)
    assert (same.nfev, same.njev, same.status) == (ref.nfev, ref.njev, ref.status)
    np.testing.assert_allclose(same.x, ref.x, rtol=0, atol=1e-8)
    assert same.cost == pytest.approx(ref.cost, rel=1e-12)
    updated = _trf(fun, jac, x0, LO, HI, max_nfev=60, xtol=1e-6, ftol=1e-8, stops=_Stops(0.0, None, LO, HI))
    assert updated.njev < ref.njev
    assert updated.cost == pytest.approx(ref.cost, rel=1e-9)
    # within a hundredth of the fit's standard deviations (from scipy's Jacobian at its minimum)
    sd = np.sqrt(np.diag(np.linalg.inv(ref.jac.T @ ref.jac)) * 2 * ref.cost / (T.size - 5))
    free = ref.active_mask == 0
    assert np.all(np.abs(updated.x - ref.x)[free] < 0.01 * sd[free])
    assert updated.x[4] == pytest.approx(HI[4], abs=1e-8)  # on the bound, as scipy's
    np.testing.assert_allclose(updated.jac, jac(updated.x), rtol=0, atol=1e-12)  # a differenced Jacobian


def _noisy(seed: int, noise: float):
    """A decaying sine on a sloping offset (the slope 0.5, beyond its bound 0.45), measured with ``noise``."""
    truth = np.array([1.0, 3.0, 7.0, 0.3, 0.5])

    def model(x):
        return x[0] * np.exp(-x[1] * T) * np.sin(2 * np.pi * x[2] * T + x[3]) + x[4] * T

    y = model(truth) + noise * np.random.default_rng(seed).standard_normal(T.size)

    def fun(x):
        return model(x) - y

    def jac(x, f=None):
        f0 = fun(x)
        return np.column_stack([(fun(x + 1e-7 * e) - f0) / 1e-7 for e in np.eye(5)])

    return fun, jac


@pytest.mark.parametrize("seed, x0", [(6, [0.77, 4.0, 6.8, -0.41, 0.8]), (11, [0.7, 3.82, 6.71, -0.79, 0.1]),
                                      (29, [1.47, 5.11, 6.55, -0.54, 0.37])])
def test_an_updated_jacobian_does_not_end_the_search(seed, x0):
    # scipy's ftol test ends a search on a step that gains little for what its Jacobian promised:
    # from a Broyden update that promise is the update's, which misses what the differenced
    # Jacobian sees. With a loose ftol the search must still end where scipy's (every Jacobian
    # differenced) ends, within a hundredth of one noise energy (sum of squares, sigma^2)
    noise, lo, hi = 0.3, np.array([0.0, 0.0, 5.0, -3.0, -1.0]), np.array([2.0, 10.0, 9.0, 3.0, 2.0])
    fun, jac = _noisy(seed, noise)
    x0 = np.array(x0)
    ref = scipy.optimize.least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf", x_scale=1.0,
                                       max_nfev=80, xtol=1e-8, ftol=1e-3)
    updated = _trf(fun, jac, x0, lo, hi, max_nfev=80, xtol=1e-8, ftol=1e-3, stops=_Stops(0.0, None, lo, hi))
    assert ref.status == updated.status == 2  # both ended by the ftol test
    assert 2 * (updated.cost - ref.cost) < 0.01 * noise**2
    assert updated.njev <= ref.njev


def _scaled_sine(seed: int, pull: float):
    """A decaying sine whose frequency goes as the square root of two factors' product (a
    stiffness's scale along an axis times a spring's) and whose amplitude is a third factor,
    measured with NOISE_SCALED, and the weak prior that alone decides how the product splits; in
    natural steps of 0.05 from 1 (u), with forward differences."""
    truth = (1.25, 1.28, 1.3)

    def model(v):
        a, b, c = v
        return c * np.exp(-4 * T_SCALED) * np.sin(2 * np.pi * 8 * np.sqrt(a * b) * T_SCALED)

    y = model(truth) + NOISE_SCALED * np.random.default_rng(seed).standard_normal(T_SCALED.size)
    root = np.full(3, np.sqrt(pull))

    def fun(u):
        return np.concatenate([model(1 + 0.05 * u) - y, root * u])

    def jac(u, f=None):
        f0 = fun(u)
        return np.column_stack([(fun(u + 1e-4 * e) - f0) / 1e-4 for e in np.eye(3)])

    return fun, jac


T_SCALED = np.linspace(0.0, 0.5, 2000)
NOISE_SCALED = 0.01


@pytest.mark.parametrize("seed, u0", [(1, [12.0, 0.0, 0.0]), (2, [0.0, 10.0, 4.0]), (3, [-5.0, 20.0, 2.0])])
def test_factors_searched_in_logarithms_reach_scipys_minimum_in_fewer_evaluations(seed, u0):
    # the product of two factors is what the data see: its valley of equal error is a hyperbola
    # in natural steps, along which the prior moves the search in short steps; in the factors'
    # logarithms (fitting.search) it is a straight line
    fun, jac = _scaled_sine(seed, 1e-3)
    free = [_Free(Parameter(name, "1", 1.0, 0.25, 4.0), None, 0.05) for name in "abc"]
    lo, hi, u0 = np.full(3, -15.0), np.full(3, 60.0), np.array(u0)
    ref = scipy.optimize.least_squares(fun, u0, jac=jac, bounds=(lo, hi), method="trf", x_scale=1.0, xtol=1e-12,
                                       ftol=1e-12, gtol=1e-12, max_nfev=500)
    least = 0.5 * STALL_GAIN * NOISE_SCALED**2  # one noise energy, in cost
    before = _trf(fun, jac, u0, lo, hi, max_nfev=32, xtol=1e-6, ftol=1e-8, stops=_Stops(least, None, lo, hi))
    logs = search(fun, jac, u0, lo, hi, free, least=least, target=None, max_nfev=32)
    # within half a noise energy of scipy's minimum (sum of squares, sigma^2)
    assert 2 * (logs.cost - ref.cost) < 0.5 * NOISE_SCALED**2
    # what the data see, the product and the amplitude, within a hundredth of their standard deviations
    v, v_ref = 1 + 0.05 * logs.x, 1 + 0.05 * ref.x
    J = jac(ref.x)[:T_SCALED.size] / 0.05  # per unit of the factors
    cov = np.linalg.pinv(J.T @ J) * 2 * ref.cost / (T_SCALED.size - 3)
    grad_product = np.array([v_ref[1], v_ref[0], 0.0])
    sd_product = float(np.sqrt(grad_product @ cov @ grad_product))
    assert abs(v[0] * v[1] - v_ref[0] * v_ref[1]) < 0.01 * sd_product
    assert abs(v[2] - v_ref[2]) < 0.01 * np.sqrt(cov[2, 2])
    # in fewer evaluations of the residual (a Jacobian is three) than the search in natural steps
    assert logs.nfev + 3 * logs.njev < before.nfev + 3 * before.njev
    np.testing.assert_allclose(logs.jac, jac(logs.x), rtol=0, atol=1e-9)  # d f / d u, at the point returned


def test_a_step_taken_further_lands_on_a_quadratic_costs_minimum_along_its_line():
    # a linear residual: the cost along any line is a parabola, whose minimum lstsq gives in closed form
    rng = np.random.default_rng(4)
    A, b = rng.standard_normal((50, 3)), rng.standard_normal(50)

    def fun(x):
        return A @ x - b

    x = np.zeros(3)
    best = np.linalg.lstsq(A, b, rcond=None)[0]
    lo, hi = np.full(3, -10.0), np.full(3, 10.0)
    cost = 0.5 * float(b @ b)
    slope = float((A.T @ fun(x)) @ (0.4 * best))
    out = _further(fun, x, cost, slope, 0.4 * best, 0.5 * float(fun(0.4 * best) @ fun(0.4 * best)), lo, hi, 0.0)
    assert out is not None
    x_t, f_t, cost_t, t = out
    assert t == pytest.approx(2.5, rel=1e-9)
    np.testing.assert_allclose(x_t, best, rtol=1e-9, atol=1e-12)
    assert cost_t == pytest.approx(0.5 * float(fun(best) @ fun(best)), rel=1e-12)
    np.testing.assert_allclose(f_t, fun(best), rtol=0, atol=1e-12)
    # the full step reaches the minimum already: nothing evaluated
    full = 0.5 * float(fun(best) @ fun(best))
    assert _further(fun, x, cost, float((A.T @ fun(x)) @ best), best, full, lo, hi, 0.0) is None
    # a short step whose parabola promises less than ``least`` more: nothing evaluated
    gain = 0.5 * float(fun(0.4 * best) @ fun(0.4 * best)) - full
    assert _further(fun, x, cost, slope, 0.4 * best, full + gain, lo, hi, 2 * gain) is None
    # a cost falling faster than linear along the line: at most FURTHER_MAX steps, within the bounds
    out = _further(fun, x, cost, slope, 0.1 * best, cost + 2 * slope, lo, hi, 0.0)
    assert out[3] == FURTHER_MAX
    np.testing.assert_allclose(out[0], np.clip(FURTHER_MAX * 0.1 * best, lo, hi))


def _large_residual(seed: int):
    """One decay and a sine fitted to two decays and a sine of another frequency, measured with
    NOISE_LARGE: the residual stays large where it fits, so Gauss-Newton's curvature (J^T J alone)
    is not the cost's and its steps fall short along their line."""
    y = (np.exp(-3 * T) + 0.6 * np.exp(-20 * T) + 0.3 * np.sin(9 * T)
         + NOISE_LARGE * np.random.default_rng(seed).standard_normal(T.size))

    def fun(x):
        return x[0] * np.exp(-x[1] * T) + x[2] * np.sin(x[3] * T) - y

    def jac(x, f=None):
        f0 = fun(x)
        return np.column_stack([(fun(x + 1e-7 * e) - f0) / 1e-7 for e in np.eye(4)])

    return fun, jac


NOISE_LARGE = 0.01


def test_steps_taken_further_reach_scipys_minimum_where_the_residual_stays_large():
    lo, hi = np.array([0.0, 0.0, -2.0, 1.0]), np.array([3.0, 30.0, 2.0, 20.0])
    least = 0.5 * STALL_GAIN * NOISE_LARGE**2  # one noise energy, in cost
    jacobians = {True: 0, False: 0}
    for seed, x0 in [(0, [0.5, 1.0, 0.1, 5.0]), (1, [0.5, 1.0, 0.1, 5.0]), (2, [0.5, 1.0, 0.1, 5.0]),
                     (1, [2.0, 10.0, 0.5, 12.0])]:
        fun, jac = _large_residual(seed)
        x0 = np.array(x0)
        ref = scipy.optimize.least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf", x_scale=1.0,
                                           xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=500)
        for further in (True, False):
            res = _trf(fun, jac, x0, lo, hi, max_nfev=60, xtol=1e-6, ftol=1e-8, stops=_Stops(least, None, lo, hi),
                       further=further)
            # within the search's own tolerance of scipy's minimum: one noise energy (sum of squares)
            assert 2 * (res.cost - ref.cost) < STALL_GAIN * NOISE_LARGE**2
            np.testing.assert_allclose(res.jac, jac(res.x), rtol=0, atol=1e-12)  # a differenced Jacobian
            jacobians[further] += res.njev
    # each step falls short along its line: taken further, the search needs fewer Jacobians
    assert jacobians[True] < jacobians[False]


def test_steps_are_not_taken_further_after_the_first_declined(monkeypatch):
    """Once the parabola puts a step's line minimum within reach (_further declines), the search
    stops asking: asked after every accepted step, these fits took 101 evaluations and 43
    Jacobians against 87 and 40."""
    from odsuite.diagnosis import fitting

    lo, hi = np.array([0.0, 0.0, -2.0, 1.0]), np.array([3.0, 30.0, 2.0, 20.0])
    least = 0.5 * STALL_GAIN * NOISE_LARGE**2
    answers: list[bool] = []

    def asked(*args):
        out = _further(*args)
        answers.append(out is not None)
        return out

    monkeypatch.setattr(fitting, "_further", asked)
    for seed in (0, 1, 2):
        answers.clear()
        fun, jac = _large_residual(seed)
        _trf(fun, jac, np.array([0.5, 1.0, 0.1, 5.0]), lo, hi, max_nfev=60, xtol=1e-6, ftol=1e-8,
             stops=_Stops(least, None, lo, hi))
        assert answers and answers[0]  # taken further at first
        assert False not in answers[:-1]  # nothing asked after a decline
