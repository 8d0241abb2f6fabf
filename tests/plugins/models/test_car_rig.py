"""The thesis's 2-DOF automobile (§2.1, Thomson) written as a rig file: the rigid-bodies model read
from it has the published natural frequencies and the same modes as the thesis's coded car model."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest
from odsuite_plugins.models.rigid_bodies import rigid_bodies as rigid_bodies_model
from odsuite_plugins.models.thesis import thesis_car_2dof

from odsuite.domain.rig import rig_from_dict

RIG_FILE = Path(__file__).resolve().parents[3] / "projects" / "rigs" / "thesis-car-2dof.toml"


@pytest.fixture
def undamped(registries):
    """The rig with its shock absorbers removed: the thesis's example has none."""
    data = tomllib.loads(RIG_FILE.read_text())
    for spring in data["springs"]:
        spring["damping"] = [0.0, 0.0, 0.0]
    return rig_from_dict(data, registries.sensor_types)


def test_published_natural_frequencies(undamped):
    omega = np.sort(2 * np.pi * np.array([m["frequency_hz"] for m in rigid_bodies_model(undamped).modes().as_list()]))
    # thesis §2.1 (Thomson): 6.90 and 9.05-9.06 rad/s
    assert omega[0] == pytest.approx(6.90, abs=0.005)
    assert omega[1] == pytest.approx(9.055, abs=0.01)


def test_same_modes_as_the_coded_car_model(undamped):
    from_rig = rigid_bodies_model(undamped).modes().as_list()
    coded = thesis_car_2dof().modes().as_list()
    for a, b in zip(from_rig, coded, strict=True):
        assert a["frequency_hz"] == pytest.approx(b["frequency_hz"], rel=1e-9)


def test_two_vertical_sensors_solve_bounce_and_pitch(registries):
    from odsuite.contracts.solvers import choose_solver

    rig = rig_from_dict(tomllib.loads(RIG_FILE.read_text()), registries.sensor_types)
    body = rig.body("car")
    chosen = choose_solver(rig, body, ["front_z", "rear_z"], registries.coordinate_solvers)
    assert chosen.name == "least-squares"
    # a bounce of 1 mm and a pitch of 2 mrad (nose down: phi > 0 lowers the front, x forward, z up)
    z, phi = 1e-3, 2e-3
    signals = {s.name: np.array([z + phi * -s.position[0]]) for s in rig.accelerometers}
    at_g = chosen.solver.solve(rig, body, signals).at_g[0]
    assert at_g[2] == pytest.approx(z) and at_g[4] == pytest.approx(phi)
    assert np.allclose(at_g[[0, 1, 3, 5]], 0.0)
