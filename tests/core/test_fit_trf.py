"""The diagnosis's own trust-region least squares (odsuite.diagnosis.fitting._trf) against scipy's
least_squares(method="trf") on a bounded nonlinear problem (a decaying sine, its frequency and
phase far from linear): without Broyden updates the same iterates, evaluations and minimum; with
them the same minimum in fewer Jacobians, and (with a loose ftol) no earlier stop than scipy's on an
updated Jacobian's promise."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize

from odsuite.diagnosis.fitting import _Stops, _trf

T = np.linspace(0.0, 1.0, 4000)
LO, HI = np.array([0.0, 0.0, 5.0, -3.0, -1.0]), np.array([2.0, 10.0, 9.0, 3.0, 0.45])


@pytest.mark.parametrize("x0", [[0.5, 1.0, 6.5, 0.0, 0.0], [1.5, 5.0, 7.4, 1.0, 0.2]])
def test_trf_is_scipys_trf_without_updates_and_reaches_its_minimum_with_them(x0):
    fun, jac = _noisy(1, 0.01)  # its offset's slope beyond its bound: the fit ends on it
    x0 = np.array(x0)
    ref = scipy.optimize.least_squares(fun, x0, jac=jac, bounds=(LO, HI), method="trf", x_scale=1.0,
                                       max_nfev=60, xtol=1e-6, ftol=1e-8)
    same = _trf(fun, jac, x0, LO, HI, max_nfev=60, xtol=1e-6, ftol=1e-8, stops=_Stops(0.0, None, LO, HI),
                broyden=False)
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
