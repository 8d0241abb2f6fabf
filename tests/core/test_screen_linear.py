"""Screening's cheap judgements: cubic springs' Jacobian columns to first order from a linear
structure (prediction.cubic_change_predictions, simulation.simulate_many_inputs), against scipy's
simulation and the nonlinear integrator's differences; a resonance grid ranked by projection
(fitting._resonance_gains), against a mode simulated by scipy; a structure change's screening
columns as derivatives, against simulated differences' zero-step limit, and a hardened point's;
a failed damped step's point kept."""

from __future__ import annotations

import sys
from contextlib import contextmanager
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import scipy.signal

from odsuite.domain.model import StateSpace
from odsuite.domain.simulation import simulate_many_inputs

sys.path.insert(0, str(Path(__file__).parent))


@contextmanager
def stiffened_problem(tmp_path, effect: str):
    """The fit problem of ``effect`` (fit windows, every second sample) on a thesis project of
    2048 samples per record with a hidden stiffness change, its project open."""
    import odsuite.diagnosis.fitting as fitting
    from hidden_effects import CASES, make_project

    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import prepare
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project

    path = make_project(tmp_path / "s.odsp", [("stiffness", CASES["stiffness"])], n_samples=2048)
    with open_project(path) as p:
        exps, base = prepare(p), revision_model(p)
        yield fitting.Problem(base, registries().effects.get(effect), fitting.fit_windows(exps), stride=2)


def test_many_inputs_is_scipys_first_order_hold_simulation():
    A = np.array([[0, 0, 1, 0], [0, 0, 0, 1], [-4e5, 1e5, -20, 5], [1e5, -2e5, 5, -10]], float)
    ss = StateSpace(A, np.vstack([np.zeros((2, 2)), np.eye(2)]), A[2:], np.eye(2))
    fs, n = 5000.0, 800
    u = np.random.default_rng(3).normal(size=(n, 2))
    _, ref, _ = scipy.signal.lsim((ss.A, ss.B, ss.C, ss.D), u, np.arange(n) / fs, interp=True)
    got = simulate_many_inputs(ss, u, fs)
    assert np.abs(got - ref).max() <= 1e-8 * np.abs(ref).max()


def test_cubic_tangent_is_the_limit_of_nonlinear_simulations(tmp_path):
    import odsuite.diagnosis.fitting as fitting

    with stiffened_problem(tmp_path, "nonlinear_stiffness") as problem:
        head = fitting.heads(problem.exps)[1]
        u0 = problem.zero()
        r0 = problem.residual(u0, head)
        h = 1e-3  # natural steps: a hardening of 5e-3 at a micrometre
        before = problem.evaluations
        J = problem.jacobian(u0, r0, head, step=h, tangent=True)
        assert problem.evaluations - before == len(u0)  # each column counts as an evaluation
        # forward differences of the nonlinear integrator, at half and at the whole step: their
        # extrapolation to zero step is the derivative the tangent claims
        fd = [problem.jacobian(u0, r0, head, step=s) for s in (h / 2, h)]
        limit = 2 * fd[0] - fd[1]
        err = np.linalg.norm(J - limit, axis=0) / np.linalg.norm(limit, axis=0)
        assert err.max() < 2e-3, err
        assert np.linalg.norm(J, axis=0).min() > 0


def test_screening_jacobian_at_a_hardened_point_is_the_derivative(tmp_path):
    """Where the effect's own cubic springs are in the structure (a hardening screened from a
    sweep's rung), screening's Jacobian is the nonlinear simulations' derivative (differenced over
    DIFF_STEP), not the difference over a natural step (a hardening grown five-fold and more):
    against the zero-step limit of the simulations' differences."""
    import odsuite.diagnosis.fitting as fitting

    with stiffened_problem(tmp_path, "nonlinear_stiffness") as problem:
        head = fitting.heads(problem.exps)[1]
        u = np.array([0.02, 0.02, 0.02, 0.2])  # hardenings 0.1, 0.1, 0.1 and 1 at a micrometre
        r = problem.residual(u, head)
        before = problem.evaluations
        J = problem.jacobian(u, r, head, tangent=True)
        assert problem.evaluations - before == len(u)  # a nonlinear simulation per column
        h = 2e-4  # natural steps
        fd = [problem.jacobian(u, r, head, step=s) for s in (h / 2, h)]
        limit = 2 * fd[0] - fd[1]
        secant = problem.jacobian(u, r, head)  # a natural step
        norm = np.linalg.norm(limit, axis=0)
        err = np.linalg.norm(J - limit, axis=0) / norm
        assert err.max() < 5e-3, err  # the forward difference's own error: 2.5e-4 to 1.9e-3 here
        off = np.linalg.norm(secant - limit, axis=0) / norm
        assert off.min() > 0.5, off  # 0.93-1.01 here


def test_failed_damped_steps_keep_the_point_they_stay_at(tmp_path):
    """A damped step whose every trial raises the error returns its point, whose predictions
    (pushed out of the kept ones by the trials) are still kept: asked again, no evaluation."""
    import odsuite.diagnosis.fitting as fitting

    with stiffened_problem(tmp_path, "stiffness") as problem:
        head = fitting.heads(problem.exps)[0]
        u0 = problem.zero()
        r0 = problem.residual(u0, head)
        kept = problem.predictions(u0, head)
        uphill = -problem.jacobian(u0, r0, head, tangent=True)  # every step it gives raises the error
        before = problem.evaluations
        u = fitting._lm_step(problem, uphill, r0, u0, head)
        assert u is u0
        assert problem.evaluations - before == len(fitting.LM_DAMPING) > fitting.PREDICTIONS_KEPT
        again = problem.predictions(u0, head)
        assert problem.evaluations - before == len(fitting.LM_DAMPING)
        assert all(a is b for a, b in zip(again, kept))


def test_resonance_gain_ranks_the_mode_that_is_there():
    import odsuite.diagnosis.fitting as fitting

    fs, n, f0, zeta = 5120.0, 2048, 180.0, 0.01
    t = np.arange(n) / fs
    force = np.where(t < 1e-3, np.sin(np.pi * t / 1e-3) ** 2, 0.0) * 100.0
    w = 2 * np.pi * f0
    # the reference: a mode's acceleration (a''' + 2 zeta w a' + w^2 a = F), simulated by scipy,
    # seen at three sensors with their own participation
    mode = scipy.signal.lti([1.0, 0.0, 0.0], [1.0, 2 * zeta * w, w * w])
    _, acc, _ = scipy.signal.lsim(mode, force, t)
    measured = acc[:, None] * np.array([1.0, -0.4, 2.5])[None, :]
    exp = SimpleNamespace(n_samples=n, fs=fs, force=force, measured=measured)
    r = measured.ravel()
    grid = (40.0, 90.0, f0, 400.0, 900.0)
    gains = fitting._resonance_gains(grid, r, [exp], 1)
    assert int(np.argmax(gains)) == grid.index(f0)
    # most of it, though its damping is half GRID_DAMPING and a hit's acceleration starts with the
    # force itself (0.84 here)
    assert gains[grid.index(f0)] > 0.8 * float(r @ r)
    assert max(g for f, g in zip(grid, gains) if f != f0) < 0.2 * float(r @ r)


def test_screening_jacobian_is_the_derivative_of_simulations(tmp_path, monkeypatch):
    """Screening's structure-changing columns on a head are the derivative (linearised over
    DIFF_STEP), not the difference over a natural step (whose poles move as far as their gaps):
    against the zero-step limit of simulated differences."""
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
            head = fitting.heads(problem.exps)[0]
            u0 = problem.zero()
            r0 = problem.residual(u0, head)
            before = problem.evaluations
            J = problem.jacobian(u0, r0, head, tangent=True)
            assert problem.evaluations - before == len(u0)  # each column counts as an evaluation
            # the reference: simulated forward differences at two small steps, extrapolated to zero
            monkeypatch.setattr(fitting, "LINEARISED_FROM", 10**9)
            h = 0.02
            fd = [problem.jacobian(u0, r0, head, step=s) for s in (h / 2, h)]
            limit = 2 * fd[0] - fd[1]
            secant = problem.jacobian(u0, r0, head)  # a natural step, simulated
            monkeypatch.undo()
            norm = np.linalg.norm(limit, axis=0)
            err = np.linalg.norm(J - limit, axis=0) / norm
            assert err.max() < 1e-4, (name, err)  # 4e-6 and 6e-6 here
            # the natural step's difference is 9 % off it
            assert np.linalg.norm(secant - limit, axis=0).max() / norm.max() > 0.03


def test_resonance_sweep_ranks_its_grid_and_finds_the_whole_grids_best(tmp_path):
    """missing_mode's frequency sweep on a head: the start the effect's own error (the same
    projected fit) finds when every one of its 73 starts is evaluated, found from a few of them
    (_climb_grid): the hidden plate mode at 610 Hz, and on a stiffness change what stands in best."""
    import odsuite.diagnosis.fitting as fitting
    from hidden_effects import CASES, make_project

    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import prepare
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project

    for name in ("plate_flexibility_free", "stiffness"):
        path = make_project(tmp_path / f"{name}.odsp", [(name, CASES[name])], n_samples=2048)
        with open_project(path) as p:
            exps, base = prepare(p), revision_model(p)
            problem = fitting.Problem(base, registries().effects.get("missing_mode"), fitting.fit_windows(exps),
                                      stride=2)
            head = fitting.heads(problem.exps)[0]
            i = next(k for k, f in enumerate(problem.free) if f.param.name == "frequency_hz")
            f = problem.free[i]
            grid = [c for c in f.param.starts if f.param.lower <= c <= f.param.upper]
            u0 = problem.zero()

            def error(c):
                u = u0.copy()
                u[i] = (c - f.param.nominal) / f.scale
                return float(np.sum(problem.residual(u, head) ** 2))

            every = [error(c) for c in grid]  # the reference: the whole grid evaluated
            before = problem.evaluations
            u, sse = fitting._climb_grid(problem, i, u0, error(f.param.nominal), grid, head)
            assert problem.evaluations - before <= 10  # of 73 starts
            assert f.to_value(u[i]) == grid[int(np.argmin(every))]
            assert sse == min(every)
            if name == "plate_flexibility_free":
                assert abs(f.to_value(u[i]) / CASES[name]["frequency_hz"] - 1) < 0.05


def test_sensor_tangent_normal_equations_are_the_jacobians(tmp_path):
    """Screening's normal equations of a candidate whose every column is one sensor's parameter
    (sensor_position: three coordinates per sensor, differenced with the other sensors') are taken
    without the Jacobian: J^T J and J^T r equal those of the formed Jacobian (its zeros off each
    sensor's rows included) to rounding, for the same evaluations, and so does the damped step."""
    import odsuite.diagnosis.fitting as fitting

    with stiffened_problem(tmp_path, "sensor_position") as problem:
        head = fitting.heads(problem.exps)[-1]
        u0 = problem.zero()
        r0 = problem.residual(u0, head)
        before = problem.evaluations
        normal = problem.tangent(u0, r0, head)
        spent = problem.evaluations - before
        assert normal.J is None  # not formed
        J = problem.jacobian(u0, r0, head, tangent=True)
        assert problem.evaluations - before == 2 * spent < len(u0)  # batched: fewer than a column each
        G, g = J.T @ J, J.T @ r0
        assert np.abs(normal.G - G).max() <= 1e-12 * np.abs(G).max()
        assert np.abs(normal.g - g).max() <= 1e-12 * np.abs(g).max()
        assert np.array_equal(normal.G == 0, G == 0)  # zero between sensors, as the whole columns' products
        assert np.array_equal(normal.tiny(r0), fitting._tiny(J, r0))
        step = fitting._lm_step(problem, normal, r0, u0, head)
        formed = fitting._lm_step(problem, J, r0, u0, head)
        assert np.abs(step).max() > 0
        assert np.abs(step - formed).max() <= 1e-9 * np.abs(formed).max()
