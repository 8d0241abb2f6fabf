"""Write the frozen project files of each format version (run once per version, then never again).

    .venv/bin/python tests/data/back_compat/make_files.py

The files are committed; tests/core/test_project_migrations.py reads them with the current code and
compares with ``expected()``, which regenerates the same values from fixed seeds.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

from odsuite.store.project import DerivedArray, Excitation, create_project
from odsuite.store.project_format import FORMAT_VERSION
from odsuite.contracts.plugins import registries
from odsuite.domain.rig import load_rig
from odsuite.domain.systeminfo import ChannelInfo, FilterFamily, RigInfo, SensorType, Systeminfo

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[2]
RIG_FILE = "plugins/models/rigs/thesis-dynamometer.toml"


def expected() -> dict:
    """The content of every frozen file, regenerated from fixed seeds."""
    rng = np.random.default_rng(1997)
    channels = [ChannelInfo(sensor_type=SensorType.LOADCELL, sensitivity=0.0022, cutoff_high=500.0, serial="F1")]
    channels += [ChannelInfo(sensor_type=SensorType.ACCELEROMETER, sensitivity=0.02 + 1e-4 * i, cutoff_high=None,
                             cutoff_low=2.0, invert=True, filter_family=FilterFamily.BUTTERWORTH,
                             location=f"corner {i}") for i in range(10)]
    rig = RigInfo(use_in_gcc=True, plate_sizes=[(0.09846, 0.16993, 0.0221)], plate_origins=[(0.0, 0.0, 0.0)],
                  coordinate_columns=[1], rx=0.09846, ry=0.16993, rz=None, nine_channels=list(range(2, 11)))
    return {
        "raw": rng.normal(scale=0.5, size=(2000, 11)),
        "systeminfo": Systeminfo(channels, rig),
        "excitation": Excitation(0, np.array([0.01, -0.02, -0.01105]), np.array([0.0, 0.0, 1.0])),
        "derived": rng.normal(size=(2000, 6)),
        "revision": ([{"effect": "stiffness", "scale": 1.1}], {"k": 2.0e6}, {"error": 0.25}),
    }


def make_frozen(path: Path) -> None:
    e = expected()
    os.chdir(REPO)  # a relative rig path: the file holds no path of the machine that made it
    with create_project(path, rig=load_rig(RIG_FILE, registries().sensor_types)) as p:
        p.add_experiment("hit-z", e["raw"], sampling_rate=5000.0, systeminfo=e["systeminfo"],
                         excitation=e["excitation"], pretrigger=200, source="make_files.py")
        p.write_derived("hit-z", "gencoords", {"q": DerivedArray(e["derived"], "m|rad", ("sample", "coordinate"))},
                        provenance={"plugin": "gencoord_padgaonkar", "version": "0.1.0",
                                    "parameters": {"at": "center"}})
        p.add_model_revision(*e["revision"], parent=0)


if __name__ == "__main__":
    target = HERE / f"project-{FORMAT_VERSION}.h5"
    if target.exists():
        sys.exit(f"{target} exists: frozen files are never rewritten")
    make_frozen(target)
    print(f"wrote {target}")
