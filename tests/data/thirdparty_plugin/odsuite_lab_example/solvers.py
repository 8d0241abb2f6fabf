"""Weighted least squares: generalized coordinates of a body from its single-axis sensors, each
sensor weighted by the inverse variance of its noise in physical units.

The rigid-body relation of sensor i (position p_i, unit axis a_i, centre of mass G) is
``s_i = [a_i, (p_i - G) x a_i] . d_G`` (small angles). The channels share one ADC, so their noise
is equal in volts and sensor i's noise in physical units is proportional to 1 / sensitivity_i:
weighting by sensitivity_i^2 gives the minimum-variance unbiased estimate (Gauss-Markov), where
odsuite's built-in least squares weights every sensor alike.
"""

import numpy as np

from odsuite.api import ConfigError
from odsuite.api import SolverResult, body_sensors, com_to_corner, stack_signals

#: below the built-ins (least-squares 1, padgaonkar-nine 2): chosen only where a rig file names it
SUITABILITY = 0.5


class WeightedLeastSquares:
    name = "lab_wls"
    description = "weighted least squares over six or more single-axis sensors, weights = sensitivity^2"

    def _system(self, rig, body, names):
        """The weighted (m, 6) matrix and the square roots of the weights; refuses fewer than six
        independent directions."""
        sensors = [rig.sensor(n) for n in names]
        r = np.array([s.position for s in sensors]).reshape(-1, 3) - body.com
        a = np.array([s.axis for s in sensors]).reshape(-1, 3)
        sens = [s.sensitivity for s in sensors]
        # without every sensitivity the noise levels are unknown: every sensor weighs alike
        root_w = np.array(sens, float) if None not in sens else np.ones(len(sensors))
        A = np.hstack([a, np.cross(r, a)])
        if len(names) < 6 or np.linalg.matrix_rank(A) < 6:
            raise ConfigError(f"rig {rig.name!r}: body {body.name!r}: sensors {', '.join(names) or 'none'} "
                              f"do not determine the six generalized coordinates ({self.name})")
        return A * root_w[:, None], root_w

    def suitability(self, rig, body, sensors):
        names = tuple(s.name for s in body_sensors(rig, body) if s.name in set(sensors))
        try:
            self._system(rig, body, names)
        except ConfigError:
            return None
        return SUITABILITY

    def solve(self, rig, body, signals):
        names = tuple(s.name for s in body_sensors(rig, body) if s.name in signals)
        Aw, root_w = self._system(rig, body, names)
        S = stack_signals(signals, names, f"rig {rig.name!r} body {body.name!r}")
        at_g = np.linalg.lstsq(Aw, (S * root_w).T, rcond=None)[0].T
        corner = body.plate.corner if body.plate is not None else None
        at_c = None if corner is None else com_to_corner(at_g, body.com - corner)
        return SolverResult(at_c=at_c, at_g=at_g, condition_number=float(np.linalg.cond(Aw)), sensors=names)
