"""The pair rule of the diagnosis (odsuite.diagnosis.joint): a pair is accepted only when each member
adds, over the other alone, more whitened excess than chi-square at 0.001 with the other's
parameters (scipy's quantile), the pair beats each member by validated error and BIC, and no
simpler single comes within the test. Resolved residuals built by hand: one experiment, two bands,
one channel, every cell with 20 degrees of freedom and a limit of 3."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import scipy.stats

from odsuite.analysis.resolved import Resolved
from odsuite.diagnosis.joint import accepted, overlap

DOF = 20.0
LIMIT = 3.0


def _res(ratios) -> Resolved:
    q = np.array(ratios, float).reshape(2, 1)
    n = np.full_like(q, DOF)
    return Resolved(["r0"], [["x1"]], [[(10.0, 20.0), (20.0, 40.0)]], [q], [np.ones_like(q)], [n], [n],
                    [np.full_like(q, LIMIT)])


def _cand(name, ratios, k, validated, bic, significant=True):
    return SimpleNamespace(effect=name, _resolved=_res(ratios), n_parameters=k, validated_error=validated,
                           bic=bic, significant=significant)


def test_each_member_must_add_beyond_the_chi_square_quantile_of_its_parameters():
    a = _cand("a", [LIMIT + 5.0, LIMIT], 3, 0.02, 100.0)
    b = _cand("b", [LIMIT, LIMIT + 5.0], 2, 0.02, 100.0)
    # over a alone, b's part removes DOF * 5 = 100 of whitened excess; over b, a's part the same
    pair = _cand("a+b", [LIMIT, LIMIT], 5, 0.01, 90.0)
    assert 100.0 > scipy.stats.chi2.isf(1e-3, 3) and 100.0 > scipy.stats.chi2.isf(1e-3, 2)
    ok, why = accepted(pair, (a, b), [a, b])
    assert ok, why
    # b's part only 0.5 above the limit: 10 of excess, below chi2.isf(0.001, 2) = 13.8
    a_small = _cand("a", [LIMIT + 5.0, LIMIT + 0.5], 3, 0.02, 100.0)
    b_big = _cand("b", [LIMIT, LIMIT + 0.5], 2, 0.02, 100.0)
    assert DOF * 0.5 < scipy.stats.chi2.isf(1e-3, 2)
    ok, why = accepted(pair, (a_small, b_big), [a_small, b_big])
    assert not ok and "adds no significant gain" in why


def test_a_pair_that_does_not_validate_better_than_a_member_is_refused():
    a = _cand("a", [LIMIT + 5.0, LIMIT], 3, 0.02, 100.0)
    b = _cand("b", [LIMIT, LIMIT + 5.0], 2, 0.02, 100.0)
    worse = _cand("a+b", [LIMIT, LIMIT], 5, 0.0201, 90.0)  # held out, worse than a alone
    assert not accepted(worse, (a, b), [a, b])[0]
    penalised = _cand("a+b", [LIMIT, LIMIT], 5, 0.01, 100.5)  # a lower error, but not by the BIC
    assert not accepted(penalised, (a, b), [a, b])[0]


def test_a_simpler_single_that_explains_as_much_wins():
    a = _cand("a", [LIMIT + 5.0, LIMIT], 3, 0.02, 100.0)
    b = _cand("b", [LIMIT, LIMIT + 5.0], 2, 0.02, 100.0)
    pair = _cand("a+b", [LIMIT, LIMIT], 5, 0.01, 90.0)
    simple = _cand("c", [LIMIT + 0.1, LIMIT], 1, 0.011, 91.0)  # 2 left: below chi2.isf(0.001, 4)
    ok, why = accepted(pair, (a, b), [a, b, simple])
    assert not ok and "c alone" in why


def test_overlap_needs_a_common_cell_above_the_floor_that_both_lower():
    before = _res([LIMIT + 5.0, LIMIT + 5.0])
    a = _cand("a", [LIMIT + 1.0, LIMIT + 5.0], 1, 0.0, 0.0)
    b = _cand("b", [LIMIT + 5.0, LIMIT + 1.0], 1, 0.0, 0.0)
    c = _cand("c", [LIMIT + 2.0, LIMIT + 2.0], 1, 0.0, 0.0)
    assert not overlap(a, b, before)  # each lowers only its own band
    assert overlap(a, c, before) and overlap(b, c, before)


def test_a_mode_paired_with_a_gain_solves_its_participations_through_the_gain(tmp_path, registries):
    """ProjectingJoint: records made by the model with one sensor's gain 0.8 and a 731 Hz mode of
    known participations (noise-free, odsuite's own prediction): at the true gain and frequency the
    joint projection recovers every product phi_sensor x phi_force and the records exactly, where
    the mode alone (the gain left at 1) cannot."""
    import sys
    from dataclasses import replace
    from pathlib import Path

    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import predict, prepare
    from odsuite.diagnosis.fitting import Problem
    from odsuite.diagnosis.joint import ProjectingJoint, joined, without
    from odsuite.store.project import open_project

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from hidden_effects import make_project

    path = make_project(tmp_path / "p.odsp", n_samples=2048, scenarios=("T1", "T6"))
    gain, mode = registries.effects.get("sensor_gain"), registries.effects.get("missing_mode")
    with open_project(path) as p:
        exps = prepare(p)
        model = revision_model(p).shared
        sensors = [s.name for s in p.rig.sensors if s.quantity == "acceleration"]
        phi = {f"phi_{s}": 0.5 + 0.1 * k * (-1) ** k for k, s in enumerate(sensors)}
        force = {e.name: 0.6 - 0.3 * i for i, e in enumerate(exps)}
        truth = gain.apply(model, {f"{sensors[2]}_gain": 0.8})
        shape = {"frequency_hz": 731.0, "damping_ratio": 0.03, **phi}
        exps = [replace(e, measured=predict(mode.apply(truth, {**shape, "phi_force": force[e.name]}), e)) for e in exps]
        pair = joined(gain, mode, model)
        assert isinstance(pair, ProjectingJoint) and pair.name == "sensor_gain+missing_mode"
        models = {e.name: model for e in exps}
        base = [predict(model, e) for e in exps]
        values = {f"sensor_gain.{s}_gain": 0.8 if s == sensors[2] else 1.0 for s in sensors}
        values |= {"missing_mode.frequency_hz": 731.0, "missing_mode.damping_ratio": 0.03}
        shared, per, deltas = pair.project(models, values, exps, base, None)
        for e in exps:
            c = per[e.name]["missing_mode.phi_force"]
            for s in sensors:
                assert shared[f"missing_mode.phi_{s}"] * c == pytest.approx(phi[f"phi_{s}"] * force[e.name], rel=1e-6)
        for e, b, d in zip(exps, base, deltas):
            np.testing.assert_allclose(b + d, e.measured, rtol=0, atol=1e-7 * np.abs(e.measured).max())
        # the mode alone, through the gain as the rig file gives it, leaves the gain's part
        _, _, alone = mode.project(models, {"frequency_hz": 731.0, "damping_ratio": 0.03}, exps, base, None)
        worst = max(np.abs(b + d - e.measured).max() / np.abs(e.measured).max() for e, b, d in zip(exps, base, alone))
        assert worst > 1e-3
        # the pair without the mode is the gain alone: no mode projected at its nominal frequency
        problem = Problem(revision_model(p), pair, exps)
        u = problem.zero()
        for i, f in enumerate(problem.free):
            if f.param.name == f"sensor_gain.{sensors[2]}_gain":
                u[i] = (0.8 - f.param.nominal) / f.scale
        for e, got in zip(exps, without(problem, u, "missing_mode")):
            np.testing.assert_array_equal(got, predict(truth, e))
        # and without the gain, the mode alone at the pair's frequency, its participations projected
        mode_alone = Problem(revision_model(p), mode, exps)
        v = mode_alone.zero()
        for j, g in enumerate(mode_alone.free):
            i = next(i for i, f in enumerate(problem.free) if f.param.name == f"missing_mode.{g.param.name}")
            v[j] = u[i]
        for got, want in zip(without(problem, u, "sensor_gain"), mode_alone.predictions(v)):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())


def test_a_member_is_tested_against_the_pair_without_it_where_that_beats_the_others_single_fit():
    # b's single fit stopped short (nothing removed); the pair with a at its nominal values (b alone
    # at the pair's values) leaves what the pair leaves: a adds nothing, whatever b's single says
    a = _cand("a", [LIMIT + 5.0, LIMIT + 0.2], 10, 0.02, 100.0)
    b = _cand("b", [LIMIT + 5.0, LIMIT + 5.0], 4, 0.03, 110.0)
    pair = _cand("a+b", [LIMIT, LIMIT], 14, 0.01, 90.0)
    assert accepted(pair, (a, b), [a, b])[0]  # against b's single fit a seems to add 100
    pair._without = {"a": _res([LIMIT + 0.1, LIMIT]), "b": _res([LIMIT + 5.0, LIMIT + 0.2])}
    # a's gain over the pair without it: DOF x 0.1, below chi2.isf(0.001, 10)
    ok, why = accepted(pair, (a, b), [a, b])
    assert not ok and "a adds no significant gain over b alone" in why
    # where the pair without a member leaves more than the other's single fit, the single decides
    pair._without = {"a": _res([LIMIT + 9.0, LIMIT + 9.0]), "b": _res([LIMIT + 9.0, LIMIT + 9.0])}
    assert accepted(pair, (a, b), [a, b])[0]


def test_a_pair_with_an_effect_that_adds_a_body_applies_it_last(tmp_path, registries):
    """base_motion makes the rig's base a moving body; mass_properties names its parameters per
    body only where there are several. Paired, base_motion is applied last, so mass_properties'
    values as its single fit names them hold (applied first, the pair stopped diagnose with 'unknown
    parameter(s) mass_scale ...'), and the pair is mass_properties' model with base_motion on top."""
    import sys
    from pathlib import Path

    from odsuite.analysis.modelrev import revision_model
    from odsuite.diagnosis.joint import joined
    from odsuite.store.project import open_project

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from hidden_effects import make_project

    path = make_project(tmp_path / "p.odsp", n_samples=1024, scenarios=("T1",))
    base, mass = registries.effects.get("base_motion"), registries.effects.get("mass_properties")
    with open_project(path) as p:
        model = revision_model(p).shared
    compliant = {"base_motion.compliance": 1e-6}
    assert len(base.apply(model, {"compliance": 1e-6}).bodies) == len(model.bodies) + 1
    pair = joined(base, mass, model)
    assert pair.name == "mass_properties+base_motion"
    got = pair.apply(model, {"mass_properties.mass_scale": 1.3, **compliant})
    want = base.apply(mass.apply(model, {"mass_scale": 1.3}), {"compliance": 1e-6})
    assert len(got.bodies) == 2
    assert [b.mass for b in got.bodies] == pytest.approx([b.mass for b in want.bodies])
    assert got.bodies[0].mass == pytest.approx(1.3 * model.bodies[0].mass)
