"""The compiled time loop of the nonlinear simulation (cubic springs): its records advance
together, each with the arithmetic of the integrator written out step by step in numpy (equal to
rounding: numpy's products sum in another order) and of its own simulation alone (to the bit)."""

from __future__ import annotations

import numpy as np
import pytest

from odsuite.domain.model import Input
from odsuite.domain.simulation import _nonlinear_setup, check_input_record, simulate_nonlinear, simulate_nonlinear_many

FS = 20_000.0


def half_sine(n: int, peak: float, start_s: float, width_s: float = 4e-4) -> np.ndarray:
    t = np.arange(n) / FS
    return np.where((t > start_s) & (t < start_s + width_s), peak * np.sin(np.pi * (t - start_s) / width_s), 0.0)


@pytest.fixture
def hardening(registries, thesis_rig):
    model = registries.models.get("thesis-dynamometer")(thesis_rig)
    hard = registries.effects.get("nonlinear_stiffness").apply(
        model, {"hardening_spring1": 30.0, "hardening_spring2": 3.0, "hardening_spring4": 100.0})
    points = [Input.force((0.025, -0.040, -0.0114), (0, 0, 1)), Input.force((0.0, 0.010, -0.0114), (0.6, 0, 0.8))]
    drives = [(hard.input_matrices([points[0]])[0], half_sine(700, 60.0, 1e-3)),
              (hard.input_matrices([points[1]])[0], half_sine(500, 90.0, 2e-3)),
              (hard.input_matrices([points[0]])[0], half_sine(600, 30.0, 5e-4))]
    return hard.structure, drives


def stepped_in_numpy(structure, drives, hold: str) -> list[np.ndarray]:
    """The integrator's steps one record at a time, in numpy: the state and the cubic force at a
    step's start to the state and deflections at its end, a predictor and a corrector of the
    force there."""
    E, c = structure.cubic_rows()
    n, sub = structure.n_dof, 2 if hold == "band" else 1
    records = [check_input_record(u, bf.shape[1]) for bf, u in drives]
    pull, drive, inputs, step_t, end_pull_t, end_deflection_t = _nonlinear_setup(
        structure, E, [bf for bf, _ in drives], records, FS, hold, sub)
    out = []
    for r, u in enumerate(records):
        x, g = np.zeros(2 * n), np.zeros(len(c))
        states = [x]
        for k in range(inputs.shape[1]):
            xd = inputs[r, k] + np.concatenate([x, g]) @ step_t
            x, d_base = xd[:2 * n], xd[2 * n:]
            g = c * (d_base - g @ end_deflection_t) ** 3  # predictor
            g = c * (d_base - g @ end_deflection_t) ** 3  # corrector
            x = x - g @ end_pull_t
            g = c * (d_base - g @ end_deflection_t) ** 3
            states.append(x)
        q = np.array(states)[:(len(u) - 1) * sub + 1:sub]
        d = q[:, :n] @ E.T
        out.append(q @ structure.A[n:].T + drive[r, :len(u)] - (c * d ** 3) @ pull.T)
    return out


@pytest.mark.parametrize("hold", ["foh", "band"])
def test_the_compiled_loop_is_the_integrator_stepped_in_numpy(hardening, hold):
    structure, drives = hardening
    fast = simulate_nonlinear_many(structure, drives, FS, hold)
    ref = stepped_in_numpy(structure, drives, hold)
    for f, r in zip(fast, ref):
        assert f.shape == r.shape
        assert np.abs(f - r).max() < 1e-13 * np.abs(r).max()  # measured 7e-15
    # the case hardens: the cubic force changes the response far beyond that
    soft = simulate_nonlinear_many(structure, [(0.01 * bf, u) for bf, u in drives], FS, hold)
    assert max(np.abs(100 * s - f).max() / np.abs(f).max() for s, f in zip(soft, fast)) > 0.05


def test_records_together_are_each_record_alone_to_the_bit(hardening):
    # the first-order hold (the band-limited input of a shorter record depends on the padding)
    structure, drives = hardening
    together = simulate_nonlinear_many(structure, drives, FS, "foh")
    for (bf, u), y in zip(drives, together):
        assert np.array_equal(simulate_nonlinear(structure, bf, u, FS, "foh"), y)


@pytest.mark.parametrize("hold", ["foh", "band"])
def test_a_record_of_one_sample_is_its_input_alone(hardening, hold):
    # a diagnosis's shortest window of a record held one sample, and the set-up's reshape of no
    # steps raised (diagnose stopped with a ValueError on a slab rig's noisy null)
    structure, drives = hardening
    bf, u = drives[0]
    one = u[:1] + 5.0
    y = simulate_nonlinear_many(structure, [(bf, one)], FS, hold)[0]
    # at rest, no cubic force: the acceleration is the force's own, M^-1 B f
    n = structure.n_dof
    expected = (np.zeros((1, 2 * n)) @ structure.A[n:].T + one @ (structure.Minv @ bf).T)
    assert y.shape == expected.shape and np.allclose(y, expected, rtol=1e-12, atol=0)
