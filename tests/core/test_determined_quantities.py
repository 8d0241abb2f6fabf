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
