"""A candidate that adds one uncoupled flexible mode (plate_flexibility, plate_flexibility_free):
its predictions as the base's plus the mode's response alone (fitting.Problem._with_added_mode,
the response to unit participations kept per frequency and damping), against the whole structure
simulated with the mode; its screening columns differenced on that response, against the zero-step
limit of the whole structure's simulated differences."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))


def _point(problem, values):
    u = problem.zero()
    for i, f in enumerate(problem.free):
        if f.param.name in values:
            u[i] = (values[f.param.name] - f.param.nominal) / f.scale
    return u


def test_added_mode_predictions_are_the_whole_structures(tmp_path):
    import odsuite.diagnosis.fitting as fitting
    from hidden_effects import CASES, make_project

    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import predict, prepare
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project

    path = make_project(tmp_path / "p.odsp", [("plate_flexibility", CASES["plate_flexibility"])], n_samples=2048)
    with open_project(path) as p:
        exps, base = prepare(p), revision_model(p)
        points = {"plate_flexibility": [{"frequency_hz": 520.0, "damping_ratio": 0.02, "twist": 0.8},
                                        # the same frequency and damping: the kept unit response
                                        {"frequency_hz": 520.0, "damping_ratio": 0.02, "twist": -0.3, "bend_x": 0.5,
                                         "bend_y": 0.2},
                                        {"frequency_hz": 1310.0, "damping_ratio": 0.05, "bend_y": 1.1}],
                  "plate_flexibility_free": [{"frequency_hz": 610.0, "damping_ratio": 0.03, "phi_zC": 0.6,
                                              "phi_z1": -0.5, "phi_force": 0.5},
                                             {"frequency_hz": 610.0, "damping_ratio": 0.03, "phi_x1": 0.2,
                                              "phi_force": -0.9},
                                             {"frequency_hz": 610.0, "damping_ratio": 0.08, "phi_zC": 0.6,
                                              "phi_force": 0.5}]}
        for name, values in points.items():
            problem = fitting.Problem(base, registries().effects.get(name), fitting.fit_windows(exps))
            for v in values:
                u = _point(problem, v)
                assert problem._with_added_mode(u, problem.exps) is not None  # the shortcut is taken
                got = problem.predictions(u)
                wholes = [predict(problem.models(u)[e.name], e) for e in problem.exps]
                seen = max(float(np.abs(w - problem.base_prediction(e)).max()) for e, w in zip(problem.exps, wholes))
                assert seen > 1e-3 * max(float(np.abs(e.measured).max()) for e in problem.exps)  # the mode is seen
                for g, whole in zip(got, wholes):
                    np.testing.assert_allclose(g, whole, rtol=0, atol=1e-9 * seen)
            # every amplitude zero: the base's predictions
            got = problem.predictions(_point(problem, {"frequency_hz": 700.0}))
            for e, g in zip(problem.exps, got):
                np.testing.assert_array_equal(g, problem.base_prediction(e))


def test_added_mode_screening_columns_are_the_derivative(tmp_path, monkeypatch):
    """plate_flexibility's screening Jacobian at a point with the mode (every column simulated on
    the mode's response alone, over DIFF_STEP) against the zero-step limit of the whole structure's
    simulated forward differences."""
    import odsuite.diagnosis.fitting as fitting
    from hidden_effects import CASES, make_project

    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import prepare
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project

    path = make_project(tmp_path / "p.odsp", [("plate_flexibility", CASES["plate_flexibility"])], n_samples=2048)
    with open_project(path) as p:
        exps, base = prepare(p), revision_model(p)
        problem = fitting.Problem(base, registries().effects.get("plate_flexibility"), fitting.fit_windows(exps),
                                  stride=2)
        head = fitting.heads(problem.exps)[1]
        u = _point(problem, {"frequency_hz": 540.0, "damping_ratio": 0.025, "twist": 0.6, "bend_x": 0.2})
        r0 = problem.residual(u, head)
        before = problem.evaluations
        J = problem.jacobian(u, r0, head, tangent=True)
        assert problem.evaluations - before == len(u)  # each column counts as an evaluation
        # the reference: the whole structure simulated, differenced at two small steps, extrapolated
        monkeypatch.setattr(fitting, "LINEARISED_FROM", 10**9)
        monkeypatch.setattr(fitting.Problem, "_added_mode", lambda self, u, exps: None)
        whole = fitting.Problem(base, problem.effect, problem.exps, stride=2)
        r_whole = whole.residual(u, head)
        np.testing.assert_allclose(r0, r_whole, rtol=0, atol=1e-9 * np.abs(r_whole).max())
        h = 0.002
        fd = [whole.jacobian(u, r_whole, head, step=s) for s in (h / 2, h)]
        limit = 2 * fd[0] - fd[1]
        monkeypatch.undo()
        norm = np.linalg.norm(limit, axis=0)
        assert norm.min() > 0
        err = np.linalg.norm(J - limit, axis=0) / norm
        assert err.max() < 1e-3, err


def _two_body(path):
    """Two hits on the two-body machine (two bodies: missing_mode has a choice of body), a mode
    hidden on its top."""
    from odsuite.contracts.daq import AcquisitionSettings
    from odsuite.contracts.plugins import registries
    from odsuite.processing.acquisition import acquire
    from odsuite.store.project import create_project

    rig = Path(__file__).resolve().parents[2] / "projects" / "rigs" / "two-body-machine.toml"
    p = create_project(path, rig=str(rig))
    try:
        for i, (point, direction) in enumerate((((0.1, 0.05, 0.25), (0, 0, -1)), ((0.15, -0.05, 0.2), (-1, 0, 0)))):
            acquire(p, registries().daq_backends.get("sim"), f"hit{i + 1}",
                    AcquisitionSettings(sampling_rate=10240.0, n_samples=2048, pretrigger=256),
                    point=point, direction=direction, seed=30 + i, effects=[("stiffness", {"scale_z": 0.8})])
    finally:
        p.close()
    return path


def test_missing_mode_projection_reuses_unit_responses_across_bodies(tmp_path, monkeypatch):
    """missing_mode's projection on the problems of each body choice (derived from one problem)
    takes the unit responses the family keeps (Problem.unit_response): the same numbers to the bit
    as the effect's own projection, which simulates each again, and one simulation per
    experiment, frequency and damping for all bodies; _climb_grid's ranking of a frequency grid
    (kept per family) the same as computed on each choice's problem."""
    import odsuite.diagnosis.fitting as fitting
    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import prepare
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project

    made: list[tuple] = []
    unit = fitting.flexible_mode_unit

    def counted(model, e, f, zeta):
        made.append((e.name, e.n_samples, f, zeta))
        return unit(model, e, f, zeta)

    monkeypatch.setattr(fitting, "flexible_mode_unit", counted)
    effect = registries().effects.get("missing_mode")
    with open_project(_two_body(tmp_path / "p.odsp")) as p:
        exps, base = prepare(p), revision_model(p)
        root = fitting.Problem(base, effect, fitting.fit_windows(exps))
        bodies = next(d for d in root.discrete if d.name == "body").choices
        assert len(bodies) == 2
        head = fitting.heads(root.exps)[0]
        points = ({"frequency_hz": 180.0, "damping_ratio": 0.02}, {"frequency_hz": 415.0, "damping_ratio": 0.05})
        for body in bodies:
            problem = root.derived({"body": body})
            for v in points:
                u = _point(problem, v)
                for exps_ in (problem.exps, head):
                    shared, per, deltas = problem.project(u, exps_)
                    models = {e.name: base.for_experiment(e.name) for e in exps_}
                    want = effect.project(models, {**problem.fixed, **v}, exps_,
                                          [problem.base_prediction(e) for e in exps_], None)
                    assert (shared, per) == (want[0], want[1])
                    for d, w in zip(deltas, want[2]):
                        np.testing.assert_array_equal(d, w)
        # through the problems: each response simulated once for both bodies (the effect's own
        # projection above simulates them again, uncounted: prediction's own reference)
        assert len(made) == len(set(made)) == len(points) * 2 * len(exps)
        for body in bodies:
            problem = root.derived({"body": body})
            grid = sorted(c for c in problem.free[0].param.starts if problem.free[0].param.lower <= c)
            fitting._climb_grid(problem, 0, problem.zero(), np.inf, grid, head)
            without = problem._residual_of([problem.base_prediction(e) for e in head], head, None, problem.stride)
            kept = problem._gains[(tuple(grid), tuple(e.span for e in head))]
            np.testing.assert_array_equal(kept, fitting._resonance_gains(grid, without, head, problem.stride))

