"""A spring's 3x3 stiffness or damping matrix must be positive semi-definite; an eigenvalue that is
zero but for round-off (an inclined mount's matrix with one rig axis scaled to 0, as the damping
effect's lower bound does) is zero, a truly negative one is refused."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from odsuite.domain.errors import ConfigError
from odsuite.domain.model import SpringDamper


def _inclined(damping) -> SpringDamper:
    return SpringDamper("mount", np.zeros(3), "body", None, stiffness=np.full(3, 1e5), damping=damping)


def test_a_matrix_scaled_to_zero_along_an_axis_is_accepted():
    # an inclined mount of the cabinet rig with its damping's y scaled to 0 (a diagnosis's trial point)
    scaled = np.array([[1794.8175064895415, -0.0, -751.3168725175035], [-0.0, 0.0, 0.0],
                       [-751.3168725175035, 0.0, 1685.4610240162804]])
    assert np.linalg.eigvalsh(scaled).min() < 0  # round-off: the matrix as numpy sees it
    spring = _inclined(scaled)
    np.testing.assert_array_equal(spring.damping, scaled)
    # and as the damping effect makes it from the unscaled matrix
    c, s = np.cos(0.4), np.sin(0.4)
    rot = np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])
    spring = _inclined(rot @ np.diag([900.0, 1200.0, 2500.0]) @ rot.T)
    np.testing.assert_array_equal(replace(spring, damping=spring.scaled("damping", [1.0, 0.0, 1.0])).damping[1], 0.0)


def test_a_negative_eigenvalue_is_refused():
    with pytest.raises(ConfigError, match="must be >= 0"):
        _inclined(np.diag([900.0, -1e-6, 2500.0]) + 1e-9 * np.ones((3, 3)))
