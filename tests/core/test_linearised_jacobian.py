"""The diagnosis's linearised Jacobian (odsuite.domain.simulation.linearised_band,
odsuite.analysis.prediction.linearised_changes, fitting.Problem._linearised): a change of the
structure's response to first order in its poles and residues, against central differences of
the exact simulation and against the finite-difference Jacobian it replaces."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from odsuite.domain.model import StateSpace
from odsuite.domain.simulation import linearised_band, simulate_state_space

sys.path.insert(0, str(Path(__file__).parent))


def _two_masses(k2: float, m1: float = 1.0) -> StateSpace:
    """Two masses on springs (ground - k1 - m1 - k2 - m2), force on m2, both accelerations out."""
    k1, m2, c = 4.0e4, 0.5, 3.0
    M = np.diag([m1, m2])
    K = np.array([[k1 + k2, -k2], [-k2, k2]])
    C = c / k1 * K
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Minv @ K, -Minv @ C]])
    B = np.vstack([np.zeros((2, 1)), Minv @ [[0.0], [1.0]]])
    return StateSpace(A, B, A[2:], Minv @ [[0.0], [1.0]])


def _hit(fs: float, n: int) -> np.ndarray:
    t = np.arange(n) / fs
    return np.where(t < 2e-3, np.sin(np.pi * t / 2e-3) ** 2, 0.0)[:, None] * 50.0


@pytest.mark.parametrize("which", ["stiffness", "mass"])
def test_linearised_change_is_the_central_difference_of_exact_simulations(which):
    fs, n = 2048.0, 4096
    u = _hit(fs, n)
    make = (lambda d: _two_masses(2.0e4 * (1 + d))) if which == "stiffness" else (lambda d: _two_masses(2.0e4, 1 + d))
    d = 1e-4
    basis, (matrix,) = linearised_band(make(0.0), [make(d)], u, fs)
    # the reference: the exact simulation's derivative (central differences; they agree to 3e-6
    # for steps of 1e-4 to 1e-6): the change is d times it, but for d's own second-order share
    # (7e-5 here: the poles and residues are not linear in the stiffness)
    h = 1e-5
    deriv = (simulate_state_space(make(h), u, fs, "band") - simulate_state_space(make(-h), u, fs, "band")) / (2 * h)
    change = basis @ matrix
    assert np.linalg.norm(change - d * deriv) <= 2e-4 * np.linalg.norm(d * deriv)
    # the exact difference of the two simulations, which the forward difference takes (it holds
    # the response's second-order share over 2 s: 2e-3)
    exact = simulate_state_space(make(d), u, fs, "band") - simulate_state_space(make(0.0), u, fs, "band")
    assert np.linalg.norm(change - exact) <= 5e-3 * np.linalg.norm(exact)


def test_nearly_repeated_poles_that_move_are_simulated_instead():
    # two equal, uncoupled oscillators: one pole pair twice; a change that splits them exchanges
    # their shapes, which no first-order change of each mode alone describes
    def pair(k: float) -> StateSpace:
        A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.diag([1e4, k]), -np.diag([2.0, 2.0])]])
        return StateSpace(A, np.array([[0.0], [0.0], [1.0], [1.0]]), A[2:], np.array([[1.0], [1.0]]))

    u = _hit(2048.0, 1024)
    assert linearised_band(pair(1e4 * (1 + 1e-9)), [pair(1e4 * (1 + 1e-4))], u, 2048.0) is None
    assert linearised_band(pair(2e4), [pair(2e4 * (1 + 1e-6))], u, 2048.0) is not None


def test_problem_jacobian_linearised_agrees_with_finite_differences(tmp_path):
    import odsuite.diagnosis.fitting as fitting
    from hidden_effects import CASES, make_project

    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import prepare
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project

    path = make_project(tmp_path / "s.odsp", [("stiffness", CASES["stiffness"])], n_samples=2048)
    with open_project(path) as p:
        exps, base = prepare(p), revision_model(p)
        for name in ("stiffness", "mass_properties"):
            problem = fitting.Problem(base, registries().effects.get(name), fitting.fit_windows(exps), stride=2)
            lo, hi = problem.lower_upper()
            u = np.clip(np.random.default_rng(5).normal(0.0, 0.5, len(problem.free)), lo, hi)
            r0 = problem.residual(u)
            steps = np.full(len(u), fitting.DIFF_STEP)
            assert problem._linearised(u, steps, r0, problem.exps) is not None  # the path under test is taken
            before = problem.evaluations
            J = problem.jacobian(u, r0, step=fitting.DIFF_STEP)
            assert problem.evaluations - before == len(u)  # each column counts as an evaluation
            # the finite differences of exact simulations it replaces
            fd = np.column_stack([-(problem.residual(u + np.eye(len(u))[i] * fitting.DIFF_STEP, keep=False) - r0)
                                  / fitting.DIFF_STEP for i in range(len(u))])
            err = np.linalg.norm(J - fd, axis=0) / np.linalg.norm(fd, axis=0)
            assert err.max() < 1e-3, (name, err)


@pytest.fixture
def sensor_case(tmp_path):
    """A thesis record (its coordinates not yet simulated), its rig's model and sensor names."""
    from hidden_effects import make_project

    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import prepare
    from odsuite.store.project import open_project

    with open_project(make_project(tmp_path / "s.odsp", n_samples=2048)) as p:
        e = prepare(p)[0]
        yield e, revision_model(p).shared, [s.name for s in e.sensors]


def _applied(model, name: str, **changed):
    """``model`` with effect ``name`` at its nominal values but ``changed``."""
    from odsuite.contracts.plugins import registries

    eff = registries().effects.get(name)
    return eff.apply(model, {**{q.name: q.nominal for q in eff.parameters(model)}, **changed})


def test_predict_sharing_equals_predict_for_sensor_effects(sensor_case):
    """A candidate that changes the sensors alone (gain, tilt, position, cables) is predicted from
    the chain's filtering of the kept coordinates, combined by its sensor rows: the same numbers
    as each sensor's own chain (predict) but for rounding; a delay on every channel (every
    channel's chain new) takes predict's path."""
    from dataclasses import replace

    from odsuite.analysis.prediction import predict, predict_sharing

    e, base, names = sensor_case
    models = [_applied(base, "sensor_gain", **{f"{names[1]}_gain": 1.3}),
              _applied(base, "channel_swap", pair=2.0, ratio=1.1),
              _applied(base, "sensor_orientation", **{f"{names[0]}_tilt_a": 0.07}),
              _applied(base, "sensor_position", **{f"{names[2]}_dx": 0.012})]
    predict(base, e)  # the base structure's coordinates kept on the record
    for m in models:
        assert m.structure is base.structure
        ref = predict(m, replace(e, _cache=None, _filtered=None))
        got = predict_sharing(m, e)
        assert e._filtered is not None and e._filtered[0] is e._cache  # the shared path is taken
        assert np.abs(got - ref).max() <= 1e-10 * np.abs(ref).max()
        assert np.abs(got - predict(base, e)).max() > 1e-3 * np.abs(ref).max()  # the effect shows
    skew = _applied(base, "scan_skew", skew_s=2e-5)
    kept = dict(e._filtered[1])
    got = predict_sharing(skew, e)
    assert set(e._filtered[1]) == set(kept)  # nothing filtered for a chain per channel
    ref = predict(skew, replace(e, _cache=None, _filtered=None))
    assert np.array_equal(got, ref)


@pytest.mark.parametrize("samples", [None, 1922])
def test_predict_sharing_takes_kept_spectra_and_columns_with_predicts_numbers(sensor_case, samples):
    """A search over channel delays (every channel's chain new at each point) shifts the undelayed
    signals' kept spectra: predict's numbers to the bit, at point after point, and again after the
    rows change (a gain with the delays). Exchanged cables, pair after pair, take the columns the
    last prediction had for their rows: each prediction the one computed afresh (a column product
    gives a column the same sum beside any others; checked to rounding, 1e-13) and predict's to
    1e-10; so is one sensor's gain, whose single new column is computed beside a kept one. On a
    head of 1922 samples too, whose delays transform at 3888 samples, not twice them (3844 = 2^2
    31^2: simulation.delay_length)."""
    from dataclasses import replace

    from odsuite.analysis.prediction import predict, predict_sharing
    from odsuite.contracts.plugins import registries
    from odsuite.domain.simulation import delay_length

    e, base, names = sensor_case
    if samples is not None:
        e = e.head(samples)
        assert delay_length(e.n_samples) == 3888
    predict(base, e)
    rng = np.random.default_rng(3)
    delayed = [_applied(base, "channel_delay", **{f"{n}_delay": float(d) for n, d in
                                                  zip(names, rng.uniform(-60e-6, 60e-6, len(names)))})
               for _ in range(3)]
    delayed.append(_applied(delayed[0], "sensor_gain", **{f"{names[1]}_gain": 1.2}))
    delayed.append(_applied(base, "scan_skew", skew_s=7e-6))
    for m in delayed:
        got = predict_sharing(m, e)
        assert "delayed" in e._filtered[3]  # the kept spectra's path
        assert np.array_equal(got, predict(m, replace(e, _cache=None, _filtered=None)))
    assert not np.array_equal(predict_sharing(delayed[0], e), predict_sharing(delayed[3], e))

    pairs = registries().effects.get("channel_swap").parameters(base)[0].choices[1:]
    one_gain = _applied(base, "sensor_gain", **{f"{names[2]}_gain": 0.9})
    # the record's chains (two groups of channels), and one chain for every channel
    one_chain = replace(e, operators=[replace(e.operators[0], columns=tuple(range(len(names))))],
                        _filtered=None)
    assert len(e.operators) > 1
    for e in (e, one_chain):
        for m in [_applied(base, "channel_swap", pair=k) for k in pairs] + [one_gain, base]:
            got = predict_sharing(m, e)
            assert any(isinstance(k, tuple) for k in e._filtered[3])  # a kept prediction's columns
            again = predict_sharing(m, replace(e, _filtered=None))  # the coordinates kept, no prediction
            assert np.abs(got - again).max() <= 1e-13 * np.abs(again).max()
            ref = predict(m, replace(e, _cache=None, _filtered=None))
            assert np.abs(got - ref).max() <= 1e-10 * np.abs(ref).max()


def test_jacobian_columns_from_the_changes_equal_the_differenced_linearised_residuals(tmp_path):
    """The linearised Jacobian is written from each model's change of prediction times the
    channel's weight over the step (prediction.linearised_changes), not by differencing the
    residuals of the linearised predictions (the model's own plus those changes), which it equals
    but for rounding (the difference cancels all but the change's digits); into the rows of a
    C-ordered Jacobian, on a rig whose channels have two chains (two operator groups) and at a
    stride."""
    import odsuite.diagnosis.fitting as fitting
    from hidden_effects import CASES, make_project

    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import linearised_changes, predict, prepare
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project

    path = make_project(tmp_path / "s.odsp", [("stiffness", CASES["stiffness"])], n_samples=2048)
    with open_project(path) as p:
        exps, base = prepare(p), revision_model(p)
        assert len(exps[0].operators) > 1  # more than one chain: the changes are written group by group
        for name in ("stiffness", "mass_properties"):
            problem = fitting.Problem(base, registries().effects.get(name), fitting.fit_windows(exps), stride=3)
            lo, hi = problem.lower_upper()
            u = np.clip(np.random.default_rng(7).normal(0.0, 0.5, len(problem.free)), lo, hi)
            r0 = problem.residual(u)
            steps = np.where(np.arange(len(u)) % 2 == 0, 1.0, -1.0) * fitting.DIFF_STEP
            J = problem._linearised(u, steps, r0, problem.exps)
            assert J is not None and J.flags.c_contiguous and J.shape == (r0.size, len(u))
            # the columns as they were taken: residuals of the linearised predictions, differenced
            models0 = problem.models(u)
            points = problem._stepped_models(u, steps, range(len(u)))
            preds = []
            for e in problem.exps:
                own_e = predict(models0[e.name], e)[::problem.stride]
                ch = linearised_changes(models0[e.name], [q[e.name] for q in points], e, problem.stride)
                preds.append([own_e + ch[:, :, i] for i in range(len(u))])
            ref = np.column_stack([
                -(problem._residual_of([pe[i] for pe in preds], problem.exps, None, problem.stride, strided=True)
                  - r0) / steps[i] for i in range(len(u))])
            err = np.linalg.norm(J - ref, axis=0) / np.linalg.norm(ref, axis=0)
            assert err.max() < 1e-8, (name, err)
            # unscaled, the changes are the linearised predictions less the model's own at u
            e = problem.exps[0]
            change = linearised_changes(models0[e.name], [q[e.name] for q in points], e, problem.stride)
            assert change.shape == (preds[0][0].shape[0], len(e.sensors), len(u))
            own = predict(models0[e.name], e)[::problem.stride]
            # against the exact simulation of the stepped models: first order in the step
            for i in (0, len(u) - 1):
                exact = predict(points[i][e.name], e)[::problem.stride] - own
                # (measured 0.7-2.7e-5: second order in a step of fitting.DIFF_STEP natural steps)
                assert np.abs(change[:, :, i] - exact).max() <= 1e-3 * np.abs(exact).max()


def test_mode_signals_are_each_modes_lfilter_to_the_bit():
    """The modes' signals in one compiled call equal scipy's lfilter run per mode and input, as
    they were: every number of a linearised Jacobian is unchanged. Also where the coefficients
    are those kept from another record's call (every experiment of a Jacobian runs the same poles)."""
    import scipy.signal

    from odsuite.domain import simulation
    from odsuite.domain.simulation import _mode_signals, _phi

    rng = np.random.default_rng(7)
    lam = np.array([-3.0 + 2 * np.pi * 150j, -0.5 + 2 * np.pi * 40j, -80.0, -20.0 + 2 * np.pi * 900j])
    T = 1.0 / 4096.0
    x = lam * T
    p, g0, g1 = np.exp(x), T * _phi(x, 1), T * _phi(x, 2)
    simulation._MODE_COEFFICIENTS.clear()
    for ut, every in [(rng.standard_normal((2, 1501)), 1), (rng.standard_normal((2, 1501)), 2),
                      (rng.standard_normal((2, 977)), 1)]:
        got = _mode_signals(lam, T, ut, every)
        for i in range(len(lam)):
            b0, b1 = g1[i], g0[i] - g1[i]
            for j in range(len(ut)):
                ref, _ = scipy.signal.lfilter([b0, b1], [1.0, -p[i]], ut[j], zi=[-b0 * ut[j, 0]])
                assert np.array_equal(got[i, j], ref[::every])


@pytest.mark.parametrize("which", ["stiffness", "mass"])
def test_eigen_changes_are_the_first_order_of_the_decompositions(which):
    """The poles' and residues' changes from one decomposition (first-order eigenvalue and
    eigenvector derivatives, simulation._eigen_changes) against the differences of the stepped
    systems' own decompositions (each paired to its nearest pole): they agree to second order in
    the step, so their gap relative to the change falls tenfold with the step (measured 0.24 times
    the step); a missing or wrong term of the derivatives leaves a relative gap that does not."""
    from odsuite.domain.simulation import _eigen_changes, _modal, _residues

    T = 1.0 / 4096.0
    make = (lambda d: _two_masses(2.0e4 * (1 + d))) if which == "stiffness" else (lambda d: _two_masses(2.0e4, 1 + d))
    m0 = _modal(make(0.0).A, T)
    R0 = _residues(make(0.0), m0)
    gaps = []
    for d in (1e-3, 1e-4):
        ss = make(d)
        m = _modal(ss.A, T)
        order = np.argmin(np.abs(m[4][None, :] - m0[4][:, None]), axis=1)
        dlam_ref, dR_ref = m[4][order] - m0[4], _residues(ss, m)[:, order] - R0
        (dlam,), (dR,) = _eigen_changes(make(0.0), m0, [ss])
        assert np.abs(dlam_ref).min() > 1e-6 * np.abs(m0[4]).min()  # the step moves every pole
        assert np.abs(dR_ref).max() > 1e-6 * np.abs(R0).max()  # and the residues
        gaps.append((np.abs(dlam - dlam_ref).max() / np.abs(dlam_ref).max(),
                     np.abs(dR - dR_ref).max() / np.abs(dR_ref).max()))
    (lam_big, res_big), (lam_small, res_small) = gaps
    assert lam_big < 1e-3 and res_big < 1e-3, gaps  # within the step of 1e-3
    assert lam_small < 0.15 * lam_big and res_small < 0.15 * res_big, gaps
