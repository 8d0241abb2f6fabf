"""The fits' residual whitened channel by channel (odsuite.diagnosis.fitting.channel_weights): a
quiet, precise channel among loud ones keeps its weight, so a right cause fitted to all of them
leaves that channel at its own noise; the contract's error stays the unweighted sum of squares."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from hidden_effects import make_project  # noqa: E402

from odsuite.analysis.modelrev import current_revision, revision_model  # noqa: E402
from odsuite.analysis.noise_floor import active_var  # noqa: E402
from odsuite.analysis.prediction import prepare  # noqa: E402
from odsuite.diagnosis.fitting import Problem, channel_weights, fit, fit_windows, weight_notes  # noqa: E402
from odsuite.store.project import open_project  # noqa: E402

#: the other channels' noise, in standard deviations of their own: a 100 mV/g sensor beside a
#: 10 V/g one reads in physical units about this much louder
LOUD = 300.0


@pytest.fixture(scope="module")
def stiffer(tmp_path_factory):
    """One thesis hit (T1, 2048 samples at 20 kHz) of a rig whose springs are 30 % stiffer
    vertically; every channel but xC with white noise of LOUD times its own added (seeded), and its
    noise variance as the record's noise estimate would give it."""
    path = make_project(tmp_path_factory.mktemp("weights") / "stiffer.h5", [("stiffness", {"scale_z": 1.3})],
                        n_samples=2048, scenarios=("T1",))
    with open_project(path) as project:
        base = revision_model(project, current_revision(project))
        (e,) = prepare(project, None)
        effect = project.registries.effects.get("stiffness")
    quiet = [s.name for s in e.sensors].index("xC")
    loud = LOUD * np.sqrt(e.noise_var)
    loud[quiet] = 0.0
    noisy = np.random.default_rng(1).standard_normal(e.measured.shape) * loud
    e = replace(e, measured=e.measured + noisy, noise_var=e.noise_var + loud**2)
    return base, effect, e, quiet


def test_weights_are_each_channels_inverse_noise_keeping_the_pooled_noise_energy(stiffer):
    _, _, e, quiet = stiffer
    w = channel_weights([e])[e.name]
    var = active_var(np.asarray(e.noise_var), np.asarray(e.lsb))
    # noise whitened: every channel's per-sample variance the same, their sum as before
    np.testing.assert_allclose(w**2 * var, np.full(len(var), var.mean()), rtol=1e-12)
    assert float(np.sum(w**2 * var)) == pytest.approx(float(np.sum(var)), rel=1e-12)
    assert w[quiet] > 0.9 * LOUD * np.max(np.delete(w, quiet))


def test_a_right_fit_leaves_the_quiet_channel_at_its_noise(stiffer):
    base, effect, e, quiet = stiffer
    windows = fit_windows([e])
    problem = Problem(base, effect, windows, full=[e])
    res = fit(problem, problem.zero())
    (predicted,) = problem.predictions(res.x, [e])
    r = e.measured - predicted
    n = windows[0].n_samples
    # where the response is (the fit window), the quiet channel's residual energy against its
    # noise energy there: near 1 for the maximum-likelihood fit (measured 1.05); fitted unweighted,
    # the loud channels' noise moved the springs and left xC at 6.3x
    assert float(np.sum(r[:n, quiet] ** 2)) / (n * float(e.noise_var[quiet])) < 1.3
    # the loud channels are at their own noise too
    others = np.delete(np.arange(r.shape[1]), quiet)
    ratio = np.sum(r[:n, others] ** 2, axis=0) / (n * np.asarray(e.noise_var)[others])
    assert np.all(np.abs(ratio - 1.0) < 0.15), ratio
    # the contract's error is the unweighted sum of squares
    assert problem.sse(res.x, [e]) == pytest.approx(float(np.sum(r**2)), rel=1e-12)


def test_a_channel_without_a_noise_estimate_weighs_one_and_is_named(stiffer):
    # its noise and its converter step unknown (zero): the others keep their whitening (they all
    # fell back to ones, silently), it weighs as if its noise were theirs on average
    _, _, e, quiet = stiffer
    blind = (quiet + 1) % len(e.sensors)
    noise, lsb = np.array(e.noise_var, float), np.array(e.lsb, float)
    noise[blind], lsb[blind] = 0.0, 0.0
    e = replace(e, noise_var=noise, lsb=lsb)
    w = channel_weights([e])[e.name]
    var = active_var(noise, lsb)
    known = np.delete(np.arange(len(var)), blind)
    np.testing.assert_allclose(w[known], np.sqrt(var[known].mean() / var[known]), rtol=1e-12)
    assert w[blind] == 1.0
    (note,) = weight_notes([e])
    assert e.sensors[blind].name in note and e.name in note
    assert weight_notes([replace(e, noise_var=np.array(e.noise_var) + 1.0)]) == []


def test_a_near_noiseless_channel_weighs_no_more_than_its_converter_step_allows(stiffer):
    # a channel's noise cannot be below its rounding's step^2/12: a noise estimate of ~0 with a
    # known step is weighed at the step's rounding, not at 1e15 times the others
    _, _, e, quiet = stiffer
    noise = np.array(e.noise_var, float)
    noise[quiet] = 1e-30
    e = replace(e, noise_var=noise)
    w = channel_weights([e])[e.name]
    step = float(np.asarray(e.lsb)[quiet])
    var = np.maximum(noise, np.asarray(e.lsb, float) ** 2 / 12.0)
    assert w[quiet] == pytest.approx(np.sqrt(var.mean() / (step**2 / 12.0)), rel=1e-12)
    assert np.isfinite(w).all() and w[quiet] < 1e6 * np.median(w)


def test_residual_written_in_place_is_the_concatenated_one(tmp_path):
    """Problem._residual_of writes each experiment's residual into the whole: the same numbers to the
    bit as the concatenation of each part (the expression it replaced, written out here), strided
    or not, weighted or not, of some columns, and capped where a prediction blows up (inf, nan)."""
    import odsuite.diagnosis.fitting as fitting
    from hidden_effects import make_project

    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import prepare
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import open_project

    def concatenated(problem, preds, exps, columns, k, strided, weighted):
        parts = []
        for e, p in zip(exps, preds):
            r = e.measured[::k] - (p if strided else p[::k])
            cap = fitting.UNSTABLE_RESIDUAL * (np.abs(e.measured).max() + 1e-300)
            if not np.abs(r).max(initial=0.0) <= cap:
                r = np.clip(np.nan_to_num(r, nan=cap, posinf=cap, neginf=-cap), -cap, cap)
            if weighted:
                r = r * problem.weights[e.name]
            parts.append((r if columns is None else r[:, columns]).ravel())
        return np.concatenate(parts)

    path = make_project(tmp_path / "p.odsp", [], n_samples=2048, scenarios=("T1", "T3"))
    with open_project(path) as p:
        exps, base = prepare(p), revision_model(p)
        problem = fitting.Problem(base, registries().effects.get("stiffness"), fitting.fit_windows(exps), stride=3)
        preds = [problem.base_prediction(e) for e in problem.exps]
        blown = [preds[0], preds[1].copy()]
        blown[1][5, 2], blown[1][9, 0], blown[1][11, 1] = np.inf, np.nan, -1e30
        for ps in (preds, blown):
            for columns in (None, [0, 2]):
                for k in (1, 3):
                    for weighted in (True, False):
                        got = problem._residual_of(ps, problem.exps, columns, k, weighted=weighted)
                        want = concatenated(problem, ps, problem.exps, columns, k, False, weighted)
                        assert np.isfinite(got).all()
                        np.testing.assert_array_equal(got, want)
            strided = [q[::3] for q in ps]
            np.testing.assert_array_equal(problem._residual_of(strided, problem.exps, None, 3, strided=True),
                                          concatenated(problem, strided, problem.exps, None, 3, True, True))
