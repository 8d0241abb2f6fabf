"""The diagnosis's ordering rules on candidates whose fits are given (odsuite.diagnosis.ranking)."""

from types import SimpleNamespace

import pytest

from odsuite.diagnosis import ranking


def _cand(effect, n, consistent, confounded):
    return SimpleNamespace(effect=effect, significant=True, fitted=True, n_parameters=n, consistent=consistent,
                           confounded_with=[confounded], _resolved=object())


@pytest.mark.parametrize("simpler_agrees, top_agrees, promoted", [
    (True, True, True),     # the same residual, fewer parameters: parsimony
    (False, True, False),   # a simpler proxy whose per-experiment values disagree stays second
    (False, False, True),   # neither agrees: parsimony again
    (None, True, True),     # consistency not tested (one experiment): parsimony
])
def test_a_simpler_candidate_goes_first_unless_it_disagrees_across_experiments_where_the_top_agrees(
        monkeypatch, simpler_agrees, top_agrees, promoted):
    # the two explain the same resolved residual: the top one gains nothing over the simpler
    monkeypatch.setattr(ranking.resolution, "gain", lambda a, b: 0.0)
    top = _cand("mass_properties", 30, top_agrees, "stiffness")
    simpler = _cand("stiffness", 15, simpler_agrees, "mass_properties")
    cands = [top, simpler]
    ranking.prefer_fewer_parameters(cands, SimpleNamespace(get=lambda name: SimpleNamespace(data_driven=False)))
    assert cands[0] is (simpler if promoted else top)
