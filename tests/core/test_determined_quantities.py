"""What diagnose prints of a fit is what the data determine: an effect's physical quantities (a
spring's stiffness in N/m along each axis, the product of a factor per axis and one per spring),
never the split into factors, which only the prior decides; a pair reports its members'
quantities; the report's table shows the same."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest


@pytest.fixture
def model(registries, thesis_rig):
    return registries.models.get("thesis-dynamometer")(thesis_rig)


def test_a_pair_reports_its_members_quantities(registries, model):
    from odsuite.diagnosis import physical
    from odsuite.diagnosis.joint import Joint

    stiffness, gain = registries.effects.get("stiffness"), registries.effects.get("force_gain")
    pair = Joint([stiffness, gain])
    first = model.springs[0].name
    values = {"stiffness.scale_z": 1.3, f"stiffness.scale_{first}": 1.5, "force_gain.gain": 1.1}
    own = {"scale_z": 1.3, f"scale_{first}": 1.5}
    rows = physical.quantities(pair, model, values)
    alone = physical.quantities(stiffness, model, own)
    assert rows[:-1] == alone
    assert rows[-1]["label"] == "force_gain gain" and rows[-1]["value"] == pytest.approx(1.1)
    k = np.diag(model.springs[0].matrix("stiffness"))[2]
    z = next(r for r in rows if r["label"].startswith(f"stiffness of {first}") and r["label"].endswith("along z"))
    assert z["value"] == pytest.approx(1.3 * 1.5 * k, rel=1e-12) and z["unit"] == "N/m"


def _candidate(**kw):
    base = dict(effect="stiffness", parameters={"scale_x": 0.973, "scale_foot1": 1.028}, uncertainties={},
                validated_error=0.02, validation="leave one experiment out", unidentifiable=[],
                confounded_parameters=[["scale_x", "scale_y", "scale_z", "scale_foot1", "scale_unit_mount2"]],
                physical=[{"label": "stiffness of unit_mount2 along z", "value": 1.9666e7, "unit": "N/m",
                           "uncertainty": 450.0, "nominal": 2.5713e7}])
    return SimpleNamespace(**{**base, **kw})


def test_the_evidence_names_no_factor_the_data_cannot_separate():
    from odsuite.diagnosis.diagnose import _evidence

    words = _evidence(None, _candidate(), 0.797, 0.0207, [], None, None, None)
    assert "stiffness of unit_mount2 along z = 19.67 ± 0.00045 MN/m (model: 25.71)" in words
    assert "scale_" not in words


def test_the_reports_table_shows_the_quantities_not_the_factors():
    from odsuite_plugins.renderers.report import _candidates_section

    c = {"effect": "stiffness", "significant": True, "error_after": 0.0206, "validated_error": 0.0206,
         "parameters": {"scale_x": 0.973, "scale_unit_mount2": 0.786}, "units": {"scale_x": "1"},
         "evidence": "", "physical": _candidate().physical}
    html = _candidates_section({"baseline_error": 0.797, "noise_floor_error": 0.0207, "revision": 0,
                                "candidates": [c]}, 0, [])
    assert "stiffness of unit_mount2 along z" in html and "MN/m" in html
    assert "scale_" not in html


class _Isolators:
    """Six isolators in two rows of three under a rigid frame, each one's vertical stiffness its own
    parameter (N/m): the stand-in of a per-spring effect for physical.mark_undetermined."""

    names = [f"iso{i}" for i in range(1, 7)]

    @classmethod
    def values(cls, model, v):
        return {**{n: 400e3 for n in cls.names}, **v}  # nominal 400 kN/m each

    @classmethod
    def physical(cls, model, v):
        return [(f"stiffness of {n} along z", v[n], "N/m") for n in cls.names]


def test_six_isolators_print_what_the_data_determine_not_each_value():
    """The pattern +1 -2 +1 / -1 +2 -1 moves nothing a sensor sees: each isolator's stiffness is
    one of many values that fit alike, their sum is determined, and so is the difference of two
    that the pattern moves alike (the row's end isolators). Each combination's uncertainty is the
    parameters' covariance carried to it, w^T C w."""
    from odsuite.diagnosis import physical

    names = _Isolators.names
    truth = np.array([400e3, 400e3, 240e3, 400e3, 400e3, 400e3])  # iso3 40 % softer
    pattern = np.array([1.0, -2.0, 1.0, -1.0, 2.0, -1.0])
    pattern /= np.linalg.norm(pattern)
    step = 30e3  # N/m per natural step along the pattern
    fitted = truth + 0.7 * step * pattern  # the prior's point of the valley, not the truth
    # a covariance that leaves the pattern out (the pseudo-inverse's), 1 kN/m along the rest
    seen = np.eye(6) - np.outer(pattern, pattern)
    rng = np.random.default_rng(3)
    A = seen @ (np.diag(rng.uniform(0.5, 2.0, 6)) * 1e3) @ seen
    C = A @ A.T
    sds = np.sqrt(np.diag(C))
    corr = C / np.outer(sds, sds)
    values = dict(zip(names, fitted))
    propagation: dict = {}
    rows = physical.quantities(_Isolators, None, values, names, sds, corr, propagation=propagation)

    def values_at(x):
        return {n: fitted[i] + x[i] for i, n in enumerate(names)}

    physical.mark_undetermined(rows, _Isolators, None, values_at, np.zeros(6), pattern[:, None] * step,
                               propagation)
    assert [r.get("determined", True) for r in rows[:6]] == [False] * 6
    combos = {r["label"]: r for r in rows[6:]}
    assert set(combos) == {"stiffness of iso1 + iso2 + iso3 + iso4 + iso5 + iso6 along z",
                           "stiffness of iso1 - iso3 along z", "stiffness of iso4 - iso6 along z"}
    total = combos["stiffness of iso1 + iso2 + iso3 + iso4 + iso5 + iso6 along z"]
    assert total["value"] == pytest.approx(truth.sum(), rel=1e-12) and total["nominal"] == pytest.approx(2.4e6)
    ends = combos["stiffness of iso1 - iso3 along z"]
    assert ends["value"] == pytest.approx(160e3, rel=1e-9) and ends["nominal"] == 0.0
    for combo, w in ((total, np.ones(6)), (ends, np.array([1.0, 0, -1.0, 0, 0, 0]))):
        assert combo["uncertainty"] == pytest.approx(np.sqrt(w @ C @ w), rel=1e-3)
        assert combo["combination"] == {f"stiffness of {names[i]} along z": c for i, c in enumerate(w) if c}
    # printed: the combinations, and one phrase for the values the data do not determine alone
    words = physical.text(physical.moved(rows))
    assert "stiffness of iso1 - iso3 along z = 160 ±" in words
    assert "6 values not determined one by one" in words
    assert "stiffness of iso3 along z =" not in words


def test_a_combination_the_pattern_moves_is_not_printed():
    # two isolators whose pattern coefficients differ (iso2 -2, iso5 +2) give no determined
    # difference; a group whose members all move one way gives no determined sum
    from odsuite.diagnosis.physical import determined_combinations

    rows = [{"label": f"stiffness of iso{i} along z", "value": 4e5, "unit": "N/m", "uncertainty": None,
             "nominal": 4e5, "determined": False} for i in (2, 5)]
    assert determined_combinations(rows, np.array([[-2.0e3, 2.0e3]])) == [
        {"label": "stiffness of iso2 + iso5 along z", "value": 8e5, "unit": "N/m", "uncertainty": None,
         "nominal": 8e5, "combination": {"stiffness of iso2 along z": 1.0, "stiffness of iso5 along z": 1.0}}]
    assert determined_combinations(rows, np.array([[1.0e3, 1.0e3]])) == [
        {"label": "stiffness of iso2 - iso5 along z", "value": 0.0, "unit": "N/m", "uncertainty": None,
         "nominal": 0.0, "combination": {"stiffness of iso2 along z": 1.0, "stiffness of iso5 along z": -1.0}}]
