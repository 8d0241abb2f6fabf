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


def _one_channel_case():
    """One experiment, one channel: a 50 Hz tone the model lacks above white noise of variance
    sigma2 (the floor: its expected energy and 2 degrees of freedom per line in every band)."""
    from odsuite.analysis.noise_floor import NoiseFloor, band_edges, in_band

    fs, n, sigma2 = 1000.0, 4096, 1e-4
    rng = np.random.default_rng(6)
    t = np.arange(n) / fs
    tone = 0.05 * np.sin(2 * np.pi * 50.0 * t)[:, None]
    e = SimpleNamespace(name="r0", measured=tone + rng.normal(scale=np.sqrt(sigma2), size=(n, 1)), fs=fs,
                        n_samples=n, sensors=[SimpleNamespace(name="z1")])
    edges = band_edges(fs, n)
    lines = [int(m.sum()) for m in in_band(fs, n, edges)]
    # white noise's energy per band: sigma2 per real sample, n / 2 lines sharing n sigma2
    energy = np.array([[2.0 * sigma2 * k] for k in lines])
    dof = np.array([[2.0 * k] for k in lines])
    floor = NoiseFloor(energy={}, measured={}, bands={"r0": (edges, energy, dof)})
    return e, tone, floor, sigma2


def test_a_pair_stops_where_its_likelihood_ratio_and_promise_cannot_pass_the_test():
    """diagnose._cannot_pass: the pair's likelihood ratio over a simpler single at the point
    reached, plus JOINT_REACH times the promise in noise energies (cost x 2 stride / noise
    energy), against scipy's chi-square quantile of the extra parameters."""
    import scipy.stats

    from odsuite.analysis import resolved as resolution
    from odsuite.diagnosis.diagnose import JOINT_REACH, _cannot_pass

    e, tone, floor, sigma2 = _one_channel_case()
    single = resolution.resolve([e], [np.zeros_like(tone)], floor)  # leaves the tone
    assert single.detected()
    amplitude = {"x": 0.0}
    problem = SimpleNamespace(full=[e], stride=2, noise_scale=sigma2, evaluations=0)

    def predictions(x, exps):
        problem.evaluations += 1
        return [amplitude["x"] * tone]

    problem.predictions = predictions
    limit = scipy.stats.chi2.isf(1e-3, 4)  # a pair of 7 parameters against a single of 3
    unit = 2.0 * problem.stride / sigma2
    # at the single's point (it adds nothing: likelihood ratio 0) with a promise that cannot make
    # up the limit: stop, and say why
    why: list[str] = []
    edge = limit / (JOINT_REACH * unit)
    assert _cannot_pass(problem, [(3, "a", single)], floor, 7, why)(np.zeros(1), 0.99 * edge)
    assert "could not pass the test against a" in why[-1] and f"{limit:.3g}" in why[-1]
    # a promise that could: it goes on
    assert not _cannot_pass(problem, [(3, "a", single)], floor, 7, [])(np.zeros(1), 1.01 * edge)
    # a pair that removes the tone passes with room: it goes on and the single is not tested again
    amplitude["x"] = 1.0
    check = _cannot_pass(problem, [(3, "a", single)], floor, 7, [])
    before = problem.evaluations
    assert not check(np.zeros(1), 0.0) and problem.evaluations == before + 1
    assert not check(np.ones(1), 0.0) and problem.evaluations == before + 1
    # a single with as many parameters is not the test's
    assert not _cannot_pass(problem, [], floor, 7, [])(np.zeros(1), 0.0)


def test_a_search_stops_where_cannot_pass_says_so():
    rng = np.random.default_rng(7)
    J = rng.normal(size=(100, 2))
    lo, hi = np.full(2, -10.0), np.full(2, 10.0)
    f = rng.normal(size=100) + J @ np.array([1.0, -1.0])
    asked = []

    def cannot_pass(x, promised):
        asked.append(promised)
        return len(asked) > 1

    stops = _Stops(0.0, None, lo, hi, cannot_pass)
    _step(stops, np.zeros(2), J, f)  # asked with the linearisation's promise: goes on
    assert asked == [pytest.approx(_promise(J.T @ J, J.T @ f, np.ones(2, bool)))] and not stops.target_stop
    with pytest.raises(StopIteration):
        _step(stops, np.zeros(2), J, f)
    assert stops.target_stop
