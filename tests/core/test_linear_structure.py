"""The structure contract: a model family that is not rigid bodies drives the core Model."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from odsuite.domain.errors import ConfigError
from odsuite.domain.model import Input, LinearStructure, Model, Output
from odsuite.domain.simulation import simulate

M1, M2, K1, K2, C1, C2 = 2.0, 1.0, 4.0e4, 1.0e4, 8.0, 2.0  # kg, N/m, N s/m


class TwoMasses(LinearStructure):
    """Two masses moving along z: m1 on k1 to the ground at x = 0, m2 on k2 to m1 at x = 1 m."""

    dof_names = ("m1.z", "m2.z")

    def __init__(self) -> None:
        self.M = np.diag([M1, M2])
        self.K = np.array([[K1 + K2, -K2], [-K2, K2]])
        self.C = np.array([[C1 + C2, -C2], [-C2, C2]])

    def point_rows(self, body, point):
        rows = np.zeros((3, 2))
        rows[2, int(round(point[0]))] = 1.0
        return rows


def test_a_plugin_structure_gives_modes_transfer_and_simulation():
    model = Model(TwoMasses(), name="two-masses")
    # modes: the generalized eigenproblem's roots
    lam = np.linalg.eigvals(np.block([[np.zeros((2, 2)), np.eye(2)],
                                      [-np.linalg.solve(model.M, model.K), -np.linalg.solve(model.M, model.C)]]))
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))]
    assert np.allclose(model.modes().frequency_hz, np.abs(lam) / (2 * np.pi), rtol=1e-10)
    # transfer: (K - w^2 M + j w C)^-1, accelerance of m2 to a force on m1
    f = np.array([5.0, 20.0, 40.0])
    w = 2 * np.pi * f
    force, accel = Input.force([0, 0, 0], [0, 0, 1]), Output.at_point([1, 0, 0], [0, 0, 1])
    ref = np.array([-(wk**2) * np.linalg.inv(model.K - wk**2 * model.M + 1j * wk * model.C)[1, 0] for wk in w])
    assert np.allclose(model.transfer([force], [accel], f)[:, 0, 0], ref, rtol=1e-10)
    # simulation: scipy's lsim of the same equations (displacement of m2, first-order hold)
    fs, u = 2000.0, np.zeros(400)
    u[5:12] = 50 * np.sin(np.pi * np.arange(7) / 7)
    sys = scipy.signal.StateSpace(np.block([[np.zeros((2, 2)), np.eye(2)],
                                            [-np.linalg.solve(model.M, model.K), -np.linalg.solve(model.M, model.C)]]),
                                  np.r_[0, 0, 1 / M1, 0][:, None], np.array([[0, 1, 0, 0]]), [[0]])
    _, ref_y, _ = scipy.signal.lsim(sys, u, np.arange(400) / fs)
    y = simulate(model, [force], u, fs, [Output.at_point([1, 0, 0], [0, 0, 1], "displacement")], hold="foh")
    assert np.allclose(y[:, 0], ref_y, atol=1e-9 * np.abs(ref_y).max())


def test_inputs_a_structure_cannot_take_are_refused_in_one_line():
    model = Model(TwoMasses())
    with pytest.raises(ConfigError, match="no rigid-body rotation"):
        model.input_matrices([Input.moment([0, 1, 0])])
    with pytest.raises(ConfigError, match="no springs to the ground"):
        model.input_matrices([Input.base_translation([0, 0, 1])])
