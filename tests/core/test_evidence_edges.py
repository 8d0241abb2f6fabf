"""A fitted value held at an end of its search range is printed as such, without the spread the
linearisation there gives (the LADISK beam's sensor tilts sat at -1.05 rad and read "± 0.0108 rad")."""

from __future__ import annotations

from types import SimpleNamespace

from odsuite.contracts.effects import Parameter
from odsuite.diagnosis.diagnose import _describe_values


def _problem(*params: Parameter):
    free = [SimpleNamespace(label=p.name, param=p, scale=1.0) for p in params]
    return SimpleNamespace(free=free, fixed={})


def test_a_value_at_its_range_end_reads_so_without_a_spread():
    tilt = Parameter("acc_tilt_a", "rad", 0.0, -1.05, 1.05)
    gain = Parameter("acc_gain", "1", 1.0, 0.5, 2.0)
    text = _describe_values(_problem(tilt, gain), {"acc_tilt_a": -1.05, "acc_gain": 1.2},
                            {"acc_tilt_a": 0.0108, "acc_gain": 0.01})
    assert "acc_tilt_a = -1.05 rad (nominal 0, at the lower end of its range)" in text, text
    assert "± 0.0108" not in text
    assert "acc_gain = 1.2 ± 0.01 (nominal 1)" in text, text  # inside its range: as before
    upper = _describe_values(_problem(tilt), {"acc_tilt_a": 1.05}, {"acc_tilt_a": 0.02})
    assert upper == "acc_tilt_a = 1.05 rad (nominal 0, at the upper end of its range)", upper
