"""The thesis's tests 1-8 as simulator scenarios (Tables 5.1 and 5.3), points in the rig frame.

Rig frame of the thesis rig: origin at the platform's centre of mass G, platform axes, z pointing
down into the platform, so the top face is z = -11.40 mm and a hammer blow on it acts along +z.
The platform spans x -50.03 .. +48.43 mm, y -80.84 .. +89.09 mm, z -11.40 .. +10.70 mm; its top
face's centre is (-0.80, 4.12, -11.40) mm.

Tests 1-4 are described only in words (Table 5.1); the points chosen for them:

- T1 "positive Z at a centre of the platform": the top face's centre, +z.
- T2 "mid-width near the edge; rotation about X and translation Z": on the top face, midway along
  x, 10 mm inside the +y edge, +z.
- T3 "mid-length near the edge coinciding with the Y axis; rotation about Y and translation Z": on
  the top face, midway along y, 10 mm inside the x = -50.03 mm edge (the edge through corner C,
  which carries the reference axes), +z.
- T4 "mid-height of the side near the edge; rotation about Z and translation X": on the -x side
  face at mid-height, 10 mm inside the -y edge, +x.

Tests 5-8 use Table 5.3's points (mm from G). Table 5.3 repeats test 6's numbers for test 7
(erratum 7) although test 7 hit "the farthest corner from the origin"; T7 here mirrors T6's point
to the opposite corner of the top face: (35.73, 76.39, -11.40) mm. T5's published x = 50.025 mm lies
1.6 mm outside the +x face (48.43 mm; Table 5.3 assumes G at mid-length) and is kept as published.
Tests 7 and 8 had several hits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from odsuite.api import ConfigError
from odsuite_plugins.daq_sim.hammer import Hit

MM = 1e-3
_X = np.array([1.0, 0.0, 0.0])
_Z = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class Scenario:
    """One hammer test: point (m, rig frame), unit direction, hits and what the thesis expected."""

    name: str
    description: str
    point: np.ndarray
    direction: np.ndarray
    hits: tuple[Hit, ...]


SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario("T1", "Table 5.1 test 1: +z at the centre of the top face; z translation dominates",
                 np.array([-0.795, 4.124, -11.400]) * MM, _Z, (Hit(0.0, 20.0, 0.5e-3),)),
        Scenario("T2", "Table 5.1 test 2: +z at mid-length near the +y edge; roll and z dominate",
                 np.array([-0.795, 79.089, -11.400]) * MM, _Z, (Hit(0.0, 20.0, 0.5e-3),)),
        Scenario("T3", "Table 5.1 test 3: +z at mid-width near the edge along Y; pitch and z dominate",
                 np.array([-40.025, 4.124, -11.400]) * MM, _Z, (Hit(0.0, 20.0, 0.5e-3),)),
        Scenario("T4", "Table 5.1 test 4: +x on the -x side at mid-height near the -y edge; yaw and x dominate",
                 np.array([-50.025, -70.841, -0.350]) * MM, _X, (Hit(0.0, 2.5, 0.5e-3),)),
        Scenario("T5", "Table 5.3 test 5: -x on the side near corner 2",
                 np.array([50.025, -75.761, -6.320]) * MM, -_X, (Hit(0.0, 2.5, 0.5e-3),)),
        Scenario("T6", "Table 5.3 test 6: +z on the top near the origin of the reference axes",
                 np.array([-37.325, -68.141, -11.400]) * MM, _Z, (Hit(0.0, 15.0, 0.5e-3),)),
        Scenario("T7", "Table 5.3 test 7: several +z hits on the top near the farthest corner",
                 np.array([35.735, 76.389, -11.400]) * MM, _Z,
                 (Hit(0.0, 15.0, 0.5e-3), Hit(0.061, 10.0, 0.6e-3), Hit(0.137, 12.0, 0.4e-3))),
        Scenario("T8", "Table 5.3 test 8: several +z hits at the centre of the top",
                 np.array([0.0, 4.122, -11.399]) * MM, _Z,
                 (Hit(0.0, 15.0, 0.5e-3), Hit(0.048, 12.0, 0.5e-3), Hit(0.115, 9.0, 0.7e-3))),
    )
}


def scenario(name: str) -> Scenario:
    try:
        return SCENARIOS[name.upper()]
    except KeyError:
        raise ConfigError(f"unknown scenario {name!r} (known: {', '.join(SCENARIOS)})") from None
