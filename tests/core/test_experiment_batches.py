"""A Jacobian's columns of per-experiment parameters (impact_location: a hit's point) moved
together, one parameter of each experiment per evaluation, each column taken from its own
experiment's rows: the numbers of one evaluation per column, in a third of the evaluations."""

from __future__ import annotations

import numpy as np

from hidden_effects import CASES, make_project


def test_per_experiment_columns_batched_equal_one_at_a_time(tmp_path):
    import odsuite.diagnosis.fitting as fitting

    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import prepare
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project

    path = make_project(tmp_path / "s.odsp", [("impact_location", CASES["impact_location"])], n_samples=2048)
    with open_project(path) as p:
        exps, base = prepare(p), revision_model(p)
        problem = fitting.Problem(base, registries().effects.get("impact_location"), fitting.fit_windows(exps),
                                  stride=2)
        names = [e.name for e in problem.exps]
        assert len(names) >= 3 and all(f.experiment in names for f in problem.free)
        per = len(problem.free) // len(names)
        lo, hi = problem.lower_upper()
        u = np.clip(np.random.default_rng(3).normal(0.0, 0.5, len(problem.free)), lo, hi)
        for exps_ in (fitting.heads(problem.exps)[0], problem.exps):
            r0 = problem.residual(u, exps_)
            before = problem.evaluations
            J = problem.jacobian(u, r0, exps_)
            assert problem.evaluations - before == per  # one evaluation per parameter of an experiment
            # each column by an evaluation of its own, every record predicted
            at, rows = 0, {}
            for e in exps_:
                n = len(range(0, e.n_samples, problem.stride)) * len(e.sensors)
                rows[e.name] = slice(at, at + n)
                at += n
            for i, f in enumerate(problem.free):
                du = np.zeros_like(u)
                du[i] = 1.0 if u[i] + 1.0 <= hi[i] else -1.0
                col = -(problem.residual(u + du, exps_, keep=False) - r0) / du[i]
                own = rows[f.experiment]
                assert np.array_equal(J[own, i], col[own])  # the same numbers, to the bit
                others = np.ones(len(col), bool)
                others[own] = False
                assert not J[others, i].any()
                # elsewhere the column's own evaluation changed nothing but the last digits
                assert np.abs(col[others]).max(initial=0.0) <= 1e-9 * np.abs(J).max()


def test_screening_jacobian_declines_the_linearisations_after_one_step(tmp_path):
    """Screening's Jacobian (``tangent``) of a hit's point: the linearisation in the poles and the
    cubic tangent both decline a step that leaves the structure linear and unchanged, known from
    the first step's models; the other steps' models are not built (the thesis bench: 15 models of
    5 experiments each, twice per Jacobian). The columns are those of the differences."""
    import odsuite.diagnosis.fitting as fitting

    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import prepare
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project

    path = make_project(tmp_path / "s.odsp", [("impact_location", CASES["impact_location"])], n_samples=2048)
    with open_project(path) as p:
        exps, base = prepare(p), revision_model(p)
        problem = fitting.Problem(base, registries().effects.get("impact_location"), fitting.fit_windows(exps),
                                  stride=2)
        assert len(problem.free) >= 6
        built = []
        models = problem.models

        def counted(u, exps_=None):
            built.append(u.copy())
            return models(u, exps_)

        problem.models = counted
        for exps_ in (fitting.heads(problem.exps)[0], problem.exps):
            u = problem.zero()
            r0 = problem.residual(u, exps_)
            built.clear()
            J = problem.jacobian(u, r0, exps_, tangent=True)
            # the models of one parameter's step (the differences move one parameter per experiment)
            stepped = [b for b in built if np.count_nonzero(b) == 1]
            assert len(stepped) <= 2  # one step's models for each linearisation that declines
            assert np.array_equal(J, problem.jacobian(u, r0, exps_))
