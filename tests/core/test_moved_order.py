"""The order `add-effect` and `diagnose` print fitted values in (physical.moved): the furthest from
its nominal in its own uncertainties first; values that score alike but for rounding keep the
order the effect gives them. The beam's radius of gyration and the section height it means (h =
r sqrt 12, one parameter) printed in either order from run to run."""

from __future__ import annotations

import math

from odsuite.diagnosis import physical


def row(label: str, value: float, sd: float) -> dict:
    return {"label": label, "value": value, "nominal": 0.0, "uncertainty": sd, "unit": "1"}


def test_one_parameter_shown_two_ways_keeps_the_effects_order():
    r = 0.01067
    radius = row("radius of gyration / length", r, r / 237.1)
    # the same relative uncertainty through a product with sqrt(12), which rounds either way
    height = row("height of a rectangular section", r * math.sqrt(12) * 0.28, r * math.sqrt(12) * 0.28 / 237.1)
    for nudge in (1 + 1e-15, 1 - 1e-15, 1.0):
        shown = physical.moved([radius, {**height, "value": height["value"] * nudge}])
        assert [x["label"] for x in shown] == [radius["label"], height["label"]]
    # a real difference still decides
    shown = physical.moved([radius, {**height, "value": height["value"] * 1.001}])
    assert shown[0]["label"] == height["label"]
