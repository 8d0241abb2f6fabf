"""The one-line texts add-effect and diagnose print about fitted values: a ratio's unit "1" is
not printed after its value (it read "scale_y = 0.2881 1 lies outside ..." as two numbers), and
one value the data do not determine is "1 value", not "1 values"."""

from __future__ import annotations

from types import SimpleNamespace

from odsuite.contracts.effects import Parameter
from odsuite.diagnosis import add_effect, checks, physical


def test_an_implausible_ratio_is_printed_without_a_unit(monkeypatch):
    monkeypatch.setattr(checks, "consistency", lambda *a, **k: SimpleNamespace(spread={}, consistent=True,
                                                                              amplitude_dependent=[]))
    monkeypatch.setattr(checks, "tolerated_misfit", lambda *a, **k: 0.0)
    params = [Parameter("spring_stiffness.scale_y", "1", 1.0, 0.25, 4.0, plausible=(0.5, 2.0)),
              Parameter("spring_stiffness.dz", "m", 0.0, -0.1, 0.1, plausible=(-0.02, 0.02))]
    joint = SimpleNamespace(params=params, full=None, weights=None,
                            values=lambda x: ({"spring_stiffness.scale_y": 0.2881, "spring_stiffness.dz": 0.05}, {}))
    after = SimpleNamespace(error=0.01, noise_floor_error=0.01, floor=None)
    lines = add_effect._warnings("spring_stiffness", None, joint, SimpleNamespace(x=None), None, [], after)
    assert lines == ["spring_stiffness: scale_y = 0.2881 lies outside its physical range [0.5, 2]: implausible",
                     "spring_stiffness: dz = 0.05 m lies outside its physical range [-0.02, 0.02]: implausible"]


def test_one_undetermined_value_is_singular():
    row = {"label": "stiffness of feet along y", "value": 1.2e5, "unit": "N/m", "nominal": 1.5e5,
           "determined": False}
    words = physical.text([row])
    assert "1 value not determined one by one (stiffness of feet along y" in words
    assert "2 values not determined" in physical.text([row, dict(row, label="stiffness of feet along x")])
