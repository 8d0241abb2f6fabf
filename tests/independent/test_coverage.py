"""The coverage harness reads each stored physical row's truth from the simulated rig by its label."""

from __future__ import annotations

import pytest

from . import coverage
from .rigs import RIGS


def test_truth_of_reads_springs_bodies_and_centres_of_mass_by_label():
    rig = RIGS["two-body"]()
    assert coverage.truth_of("stiffness of isolator2 along z", rig) == 200000.0
    assert coverage.truth_of("stiffness of isolators (each, e.g. isolator1) along x", rig) == 80000.0
    assert coverage.truth_of("mass of machine", rig) == 20.0
    assert coverage.truth_of("centre of mass of machine, z", rig) == pytest.approx(225.0)  # mm
    assert coverage.truth_of("Ixx of machine", rig) is None  # not compared


def test_specs_cycle_force_and_noise_over_seeds():
    specs = coverage.specs(6, ["thesis"])
    softer = [s for s in specs if s["case"] == "softer-mount"]
    assert [s["force_n"] for s in softer] == [5.0, 30.0, 200.0] * 2
    assert len({(s["force_n"], s.get("noise_fraction")) for s in softer}) == 6
