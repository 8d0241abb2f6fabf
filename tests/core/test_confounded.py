"""Which candidates the diagnosis names as confounded (odsuite.diagnosis.ranking.mark_confounded):
alike changes of the predictions, and neither explains significantly more than the other by the
likelihood-ratio test on the resolved residual (chi-square at 0.001 with the better one's
parameters, scipy's quantile). Resolved residuals built by hand: one experiment, two bands, one
channel, every cell with 20 degrees of freedom and a limit of 3."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import scipy.stats

from odsuite.diagnosis.ranking import mark_confounded

from tests.core.test_joint_pairs import DOF, LIMIT, _res


def _cand(name, change, ratios, k, data_driven=False):
    """A fitted candidate whose model changes the (one experiment's) prediction by ``change``."""
    change = np.asarray(change, float)[:, None]
    problem = SimpleNamespace(linear=False, free=[0], exps=[None], zero=lambda: np.zeros(1),
                              predictions=lambda u: [change * u[0]], effect=SimpleNamespace(data_driven=data_driven))
    return SimpleNamespace(effect=name, _problem=problem, _u=np.ones(1), error_after=0.1, screened_error=0.2,
                           n_parameters=k, confounded_with=[], _resolved=_res(ratios))


def test_alike_changes_of_which_one_explains_far_more_are_not_confounded():
    t = np.linspace(0, 1, 200)
    shape = np.sin(40 * t)
    # cosine 0.995: the same shape, a little more of it in the second candidate
    foot = _cand("spring_stiffness", shape * 1.1 + 0.01 * np.cos(7 * t), [LIMIT, LIMIT], 6)
    mass = _cand("mass_properties", shape, [LIMIT + 5.0, LIMIT + 5.0], 10)
    va, vb = foot._problem.predictions(foot._u)[0].ravel(), mass._problem.predictions(mass._u)[0].ravel()
    assert abs(va @ vb) / (np.linalg.norm(va) * np.linalg.norm(vb)) > 0.99
    # the foot leaves 2 x DOF x 5 = 200 less whitened excess: beyond chi2.isf(0.001, 6) = 22.5
    mark_confounded([foot, mass], None, 1.0)
    assert foot.confounded_with == [] and mass.confounded_with == []


def test_alike_changes_that_explain_as_much_are_confounded():
    t = np.linspace(0, 1, 200)
    shape = np.sin(40 * t)
    a = _cand("stiffness", shape * 1.1 + 0.01 * np.cos(7 * t), [LIMIT + 0.5, LIMIT], 4)
    b = _cand("spring_stiffness", shape, [LIMIT + 0.9, LIMIT], 6)
    # 20 x 0.4 = 8 between them: below chi2.isf(0.001, k) for either's parameters
    assert DOF * 0.4 < scipy.stats.chi2.isf(1e-3, 4)
    mark_confounded([a, b], None, 1.0)
    assert a.confounded_with == ["spring_stiffness"] and b.confounded_with == ["stiffness"]


def test_a_data_driven_stand_in_that_explains_more_stays_confounded_with_the_named_mechanism():
    # a mode of any shape (20 parameters) explains more of the plate's bending residual than the
    # named plate mode (5): its freedom, not a different cause; they still name each other
    t = np.linspace(0, 1, 200)
    shape = np.sin(40 * t)
    plate = _cand("plate_flexibility", shape, [LIMIT + 5.0, LIMIT + 5.0], 5)
    mode = _cand("mounted_mode", shape * 1.1 + 0.01 * np.cos(7 * t), [LIMIT, LIMIT], 20, data_driven=True)
    mark_confounded([plate, mode], None, 1.0)
    assert plate.confounded_with == ["mounted_mode"] and mode.confounded_with == ["plate_flexibility"]
    # a named mechanism that explains as much more is told apart
    named = _cand("spring_stiffness", shape * 1.1 + 0.01 * np.cos(7 * t), [LIMIT, LIMIT], 20)
    mark_confounded([_cand("plate_flexibility", shape, [LIMIT + 5.0, LIMIT + 5.0], 5), named], None, 1.0)
    assert named.confounded_with == []
