"""Which fitted parameters a finished fit is restarted from (fitting.held_implausibly): those held at
a bound of the search that lies outside their plausible range, shared ones only. A bound inside
the plausible range (a gain fitted to its end of 0.5-2 where 0.5-2 is plausible) is an answer, not
a valley's wall."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from odsuite.contracts.effects import Parameter
from odsuite.diagnosis import fitting


def problem(*free) -> SimpleNamespace:
    lo = np.array([(f.param.lower - f.param.nominal) / f.scale for f in free])
    hi = np.array([(f.param.upper - f.param.nominal) / f.scale for f in free])
    return SimpleNamespace(free=list(free), lower_upper=lambda: (lo, hi))


def free(param: Parameter, experiment: str | None = None) -> SimpleNamespace:
    return SimpleNamespace(param=param, experiment=experiment, scale=0.1)


def test_a_moment_at_its_lower_bound_below_the_plausible_range_is_held():
    izz = Parameter("Izz_scale", "1", 1.0, 0.5, 2.0, plausible=(0.8, 2.0))
    mass = Parameter("mass_scale", "1", 1.0, 0.5, 2.0, plausible=(0.8, 2.0))
    gain = Parameter("gain", "1", 1.0, 0.5, 2.0)  # every value plausible
    p = problem(free(mass), free(izz), free(gain), free(izz, "T1"))
    # mass 1.75, Izz at 0.5, the gain at its bound 2, the per-experiment Izz at 0.5
    u = np.array([7.5, -5.0, 10.0, -5.0])
    assert fitting.held_implausibly(p, u).tolist() == [False, True, False, False]
    # at its upper bound 2 a moment is plausible: not held
    assert not fitting.held_implausibly(p, np.array([7.5, 10.0, 0.0, 0.0])).any()
    # a hair inside the bound, as scipy's search leaves it, is at the bound
    assert fitting.held_implausibly(p, np.array([0.0, -5.0 + 1e-9, 0.0, 0.0])).tolist() == [False, True, False, False]
