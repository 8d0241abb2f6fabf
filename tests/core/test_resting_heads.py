"""A screening's short heads without the samples before the force acts (PreparedExperiment.resting_head):
the model is at rest there, so the predictions of the samples kept are the whole head's to a few
1e-5 of their peak (linear and cubic springs alike; the noise is a percent), the rows cut are the
measured noise alone, and a screening on them (cut at a multiple of the residual's stride, so it
keeps the head's own samples) reaches the same errors to 1e-4 and the same fits. Where a chain's offset window spans the cut the head
stays whole. The fit windows leave those samples out too (fitting.fit_windows), and a diagnosis
on them reads what it read on windows that kept them."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hidden_effects import make_project
from odsuite.analysis.modelrev import revision_model
from odsuite.analysis.prediction import REST_MARGIN_S, prepare, predict
from odsuite.store.project import open_project


@pytest.fixture(scope="module")
def softer(tmp_path_factory):
    """Two thesis hits (4096 samples, 512 before the trigger) of a rig whose springs are softer vertically."""
    path = make_project(tmp_path_factory.mktemp("rest") / "softer.h5", [("stiffness", {"scale_z": 0.8})],
                        n_samples=4096, scenarios=("T1", "T4"))
    with open_project(path) as p:
        yield p, prepare(p)


def _models(project):
    base = revision_model(project).shared
    effects = project.registries.effects
    return {"linear": effects.get("stiffness").apply(base, {"scale_z": 0.9}),
            "cubic": effects.get("nonlinear_stiffness").apply(base, {f"hardening_{g}": 5.0 for g in
                                                                     effects.get("nonlinear_stiffness")._groups(base)})}


@pytest.mark.parametrize("kind", ["linear", "cubic"])
@pytest.mark.parametrize("after_s", [0.01, 0.04])
def test_a_resting_head_predicts_the_heads_samples(softer, kind, after_s):
    project, exps = softer
    model = _models(project)[kind]
    for e in exps:
        n = e.trigger + int(round(after_s * e.fs))
        head, resting = e.head(n), e.resting_head(n)
        acting = int(np.flatnonzero(e.force)[0])
        assert resting.first == acting - int(round(REST_MARGIN_S * e.fs)) > 0
        assert resting.n_samples == head.n_samples - resting.first and resting.trigger == e.trigger - resting.first
        assert np.array_equal(resting.measured, head.measured[resting.first:])
        assert resting.span != head.span  # never the same key for kept predictions
        whole = predict(model, replace(head, _cache=None, _filtered=None))
        cut = predict(model, resting)
        peak = np.max(np.abs(whole))
        # the samples cut: the model at rest (the band-limited force rings into them, no more)
        assert np.max(np.abs(whole[:resting.first])) < 1e-5 * peak
        assert np.max(np.abs(cut - whole[resting.first:])) < 3e-5 * peak


def test_the_cut_keeps_a_strided_residuals_samples(softer):
    # a residual of every third sample of the cut head holds the whole head's every third sample
    _, exps = softer
    e = exps[0]
    n = e.trigger + int(round(0.01 * e.fs))
    resting = e.resting_head(n, 3)
    assert resting.first % 3 == 0 and resting.first > e.resting_head(n).first - 3
    assert np.array_equal(resting.measured[::3], e.head(n).measured[resting.first::3])


def test_a_chains_offset_over_the_cut_keeps_the_head_whole(softer):
    # the thesis chain's offsets (the means of samples 0-400 and 0-100) lie where the model is at
    # rest (the force acts from 490): the prediction's are nil, and the head is cut. One over the
    # force's start keeps it whole; one after the cut moves with it
    _, exps = softer
    e = exps[0]
    n = e.trigger + int(round(0.01 * e.fs))
    assert [op.offset for op in e.operators] == [(0, 400), (0, 100)]
    resting = e.resting_head(n)
    first, acting = resting.first, int(np.flatnonzero(e.force)[0])
    assert first > 0 and all(op.offset is None for op in resting.operators)
    spanning = replace(e, operators=[replace(op, offset=(first - 10, acting - first + 20)) for op in e.operators])
    assert spanning.resting_head(n).first == 0 and spanning.resting_head(n).n_samples == n
    after = replace(e, operators=[replace(op, offset=(first + 10, 100)) for op in e.operators])
    assert [op.offset for op in after.resting_head(n).operators] == [(10, 100)] * len(e.operators)


def test_the_early_and_late_parts_are_cut_in_the_records_samples(softer):
    # checks.linearity splits each fit window where the fit's information reaches half, and the
    # verdict's held-out test cuts the whole records there: a window that starts after the samples
    # at rest (a resting head) puts the cut that much later in its record (read in the window's own
    # samples, the late part took in half the early part's response: a rattle then read "explained")
    from odsuite.analysis.modelrev import revision_model
    from odsuite.contracts.plugins import registries
    from odsuite.diagnosis import checks, fitting

    project, exps = softer
    base = revision_model(project)
    effect = registries().effects.get("stiffness")
    rest = fitting.fit_windows(exps, 2)
    whole = [e.head(w.first + w.n_samples) for e, w in zip(exps, rest)]
    assert all(w.first > 0 and w.first % 2 == 0 for w in rest)
    cuts = {}
    for kind, windows in (("rest", rest), ("whole", whole)):
        problem = fitting.Problem(base, effect, windows, full=exps, stride=2)
        res = fitting.fit(problem, problem.zero())
        cuts[kind] = checks.linearity(problem, res).cuts
    for e in exps:
        assert e.trigger < cuts["rest"][e.name] < e.trigger + int(round(0.1 * e.fs))
        assert abs(cuts["rest"][e.name] - cuts["whole"][e.name]) <= 4, cuts


def test_screening_on_resting_heads_reaches_the_same_errors(softer, monkeypatch):
    from odsuite.diagnosis import fitting
    from odsuite.diagnosis.diagnose import diagnose

    project, exps = softer
    effects = ["stiffness", "mass_properties", "nonlinear_stiffness", "sensor_gain", "channel_delay"]
    rest = diagnose(project, effects=effects, prepared=[replace(e, _cache=None) for e in exps], workers=1)

    def whole_heads(exps, stride=1, slowest_hz=None, lowest_hz=None):
        return ([[e.head(e.trigger + int(round(t * e.fs))) for e in exps]
                 for t in fitting.head_times(exps, slowest_hz, lowest_hz)] + [list(exps)])

    monkeypatch.setattr(fitting, "heads", whole_heads)
    whole = diagnose(project, effects=effects, prepared=[replace(e, _cache=None) for e in exps], workers=1)
    assert [c.effect for c in rest.candidates] == [c.effect for c in whole.candidates]
    assert rest.verdict == whole.verdict and rest.candidates[0].effect == "stiffness"
    for a, b in zip(rest.candidates, whole.candidates):
        assert a.screened_error == pytest.approx(b.screened_error, rel=1e-4)
        assert a.fitted == b.fitted and a.significant == b.significant
    assert rest.candidates[0].error_after == pytest.approx(whole.candidates[0].error_after, rel=1e-6)


def test_a_diagnosis_on_windows_without_their_samples_at_rest_reads_as_on_whole_windows(softer, monkeypatch):
    # the rows at rest are the measured noise at every parameter value: the fits reach the same
    # values, and the checks, which count those rows in their variances (Problem.at_rest), the
    # same uncertainties and tests (the predictions differ by the front end's in-band response
    # over another length: a few 1e-5)
    from odsuite.diagnosis import diagnose as diagnosing
    from odsuite.diagnosis import fitting

    project, exps = softer
    effects = ["stiffness", "mass_properties", "sensor_gain", "channel_delay"]
    assert all(w.first > 0 and w.first % 2 == 0 for w in fitting.fit_windows(exps, 2))
    cut = diagnosing.diagnose(project, effects=effects, prepared=[replace(e, _cache=None) for e in exps], workers=1)

    def whole_windows(exps, stride=1):
        return [e.head(w.first + w.n_samples) for e, w in zip(exps, fitting.fit_windows(exps, stride))]

    monkeypatch.setattr(diagnosing, "fit_windows", whole_windows)
    whole = diagnosing.diagnose(project, effects=effects, prepared=[replace(e, _cache=None) for e in exps], workers=1)
    assert cut.verdict == whole.verdict and [c.effect for c in cut.candidates] == [c.effect for c in whole.candidates]
    for a, b in zip(cut.candidates, whole.candidates):
        assert (a.fitted, a.significant, a.consistent, a.early_late_agree) == (b.fitted, b.significant, b.consistent,
                                                                                b.early_late_agree)
        assert a.error_after == pytest.approx(b.error_after, rel=1e-4)
        for k, v in b.uncertainties.items():
            if v is not None:
                assert a.uncertainties[k] == pytest.approx(v, rel=1e-3), k
        for name, values in b.per_experiment_fits.items():  # SI: a centre of mass 1e-6 m apart at most
            assert a.per_experiment_fits[name] == pytest.approx(values, rel=1e-3, abs=1e-6), name
        early_a, early_b = getattr(a, "_early_late", None), getattr(b, "_early_late", None)
        assert (early_a is None) == (early_b is None)
        if early_b is not None and early_b.cov is not None:
            assert np.allclose(early_a.cov, early_b.cov, rtol=1e-3, atol=1e-3 * np.abs(early_b.cov).max())


@pytest.mark.parametrize("stride", [2, 3])
def test_the_rows_at_rest_and_the_cut_windows_rows_are_the_whole_windows_residual(softer, stride):
    # Problem.at_rest: the rows a window cut, strided and weighted as the fit's residual, put back
    # in front of the cut window's rows give the residual of the window that kept them (to the
    # front end's in-band response over another length)
    from odsuite.analysis.modelrev import revision_model
    from odsuite.contracts.plugins import registries
    from odsuite.diagnosis import fitting

    project, exps = softer
    base = revision_model(project)
    effect = registries().effects.get("stiffness")
    cut = fitting.fit_windows(exps, stride)
    whole = [e.head(w.first + w.n_samples) for e, w in zip(exps, cut)]
    assert all(w.first > 0 and w.first % stride == 0 for w in cut)
    a = fitting.Problem(base, effect, cut, full=exps, stride=stride)
    b = fitting.Problem(base, effect, whole, full=exps, stride=stride, weights=a.weights)
    assert np.ptp(np.concatenate(list(a.weights.values()))) > 0.01  # the channels weigh differently
    ra, rb = a.residual(a.zero()), b.residual(b.zero())
    start_a = start_b = 0
    for w, e in zip(cut, whole):
        c = w.measured.shape[1]
        na, nb = len(range(0, w.n_samples, stride)) * c, len(range(0, e.n_samples, stride)) * c
        rest = a.at_rest(w)
        assert rest.shape == (len(range(0, w.first, stride)), c)
        joined = np.concatenate([rest.ravel(), ra[start_a:start_a + na]])
        assert joined.shape == (nb,)
        assert np.allclose(joined, rb[start_b:start_b + nb], rtol=0, atol=1e-4 * np.abs(rb).max())
        # the rows at rest alone, against their own level (the noise: a weight's percent shows)
        assert np.allclose(rest.ravel(), rb[start_b:start_b + rest.size], rtol=0, atol=2e-3 * np.abs(rest).max())
        start_a, start_b = start_a + na, start_b + nb
    assert a.rest_cost() == pytest.approx(0.5 * sum(float(np.sum(a.at_rest(w) ** 2)) for w in cut))
    with pytest.raises(ValueError, match="stride"):
        fitting.Problem(base, effect, fitting.fit_windows(exps, 1), full=exps, stride=4).at_rest(
            next(w for w in fitting.fit_windows(exps, 1) if w.first % 4))
