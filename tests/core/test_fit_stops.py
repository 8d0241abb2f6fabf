"""Where a diagnosis fit stops early (odsuite.diagnosis.fitting): the fall of the objective its
linearisation promises, against the linear least-squares optimum numpy computes, and the rules
that end a search on it (no more than a noise energy left; a pair that cannot come near the
simpler single it must beat)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from odsuite.diagnosis.fitting import STALL_GAIN, TARGET_FACTOR, _promise, _Stops


def test_the_promise_is_the_fall_to_the_linear_least_squares_optimum():
    rng = np.random.default_rng(3)
    J, f = rng.normal(size=(200, 5)), rng.normal(size=200)
    best = np.linalg.lstsq(J, f, rcond=None)[0]
    optimum = 0.5 * float(np.sum((f - J @ best) ** 2))
    assert _promise(J.T @ J, J.T @ f, np.ones(5, bool)) == pytest.approx(0.5 * float(f @ f) - optimum, rel=1e-10)
    # a parameter held at its bound: the optimum over the others
    keep = np.array([True, False, True, True, True])
    best = np.linalg.lstsq(J[:, keep], f, rcond=None)[0]
    optimum = 0.5 * float(np.sum((f - J[:, keep] @ best) ** 2))
    assert _promise(J.T @ J, J.T @ f, keep) == pytest.approx(0.5 * float(f @ f) - optimum, rel=1e-10)
    assert _promise(J.T @ J, J.T @ f, np.zeros(5, bool)) == 0.0


def _step(stops: _Stops, x: np.ndarray, J: np.ndarray, f: np.ndarray) -> None:
    stops.jacobian(x, J.T @ J, J.T @ f)
    stops(SimpleNamespace(x=x, cost=0.5 * float(f @ f)))


def test_a_search_stops_where_less_than_a_noise_energy_is_left():
    rng = np.random.default_rng(4)
    J = rng.normal(size=(100, 2))
    lo, hi = np.full(2, -10.0), np.full(2, 10.0)
    least = 0.5 * STALL_GAIN * 1e-3
    x = np.zeros(2)
    far = rng.normal(size=100) + J @ np.array([1.0, -1.0])  # a step away holds far more than least
    _step(_Stops(least, None, lo, hi), x, J, far)  # goes on
    f = rng.normal(size=100)
    f -= J @ np.linalg.lstsq(J, f, rcond=None)[0]  # at the optimum: nothing left to promise
    with pytest.raises(StopIteration):
        _step(_Stops(least, None, lo, hi), x, J, f + 1e-6 * J[:, 0])


def test_a_pair_stops_where_it_cannot_come_near_its_target():
    rng = np.random.default_rng(5)
    J = rng.normal(size=(100, 2))
    lo, hi = np.full(2, -10.0), np.full(2, 10.0)
    noise = rng.normal(size=100)
    noise -= J @ np.linalg.lstsq(J, noise, rcond=None)[0]  # what no step of these parameters removes
    floor = 0.5 * float(noise @ noise)
    x = np.zeros(2)
    # the linearisation reaches the floor: within TARGET_FACTOR of a target at the floor, it goes on
    stops = _Stops(0.0, floor, lo, hi)
    _step(stops, x, J, noise + J @ np.array([3.0, 1.0]))
    _step(stops, x, J, noise + J @ np.array([1.0, 0.5]))
    # a target far below what it can reach: the first iteration only notes its reach, the second
    # (its reach fell by less than half) stops it, and says why
    stops = _Stops(0.0, floor / (2 * TARGET_FACTOR), lo, hi)
    _step(stops, x, J, 1.2 * noise + J @ np.array([3.0, 1.0]))
    assert not stops.target_stop
    with pytest.raises(StopIteration):
        _step(stops, x, J, 1.1 * noise + J @ np.array([1.0, 0.5]))
    assert stops.target_stop
