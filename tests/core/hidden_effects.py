"""Projects on the simulated thesis rig with hidden effects in the truth, for the diagnosis tests.

Five experiments like the thesis's T1, T2, T3, T5, T6 with 8192 samples each, 16-bit ADC chains
and the simulator's default noise, offsets and drift. The effects change the simulator's truth only
(the project's model revision 0 is the plain rigid model).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

SCENARIOS = ("T1", "T2", "T3", "T5", "T6")
N_SAMPLES = 8192

#: hidden effects at clearly detectable sizes (name -> parameters of the truth)
CASES: dict[str, dict[str, float]] = {
    "stiffness": {"scale_z": 1.6},
    "damping": {"scale_x": 4.0, "scale_y": 4.0, "scale_z": 4.0},
    "mass_properties": {"mass_scale": 1.3, "com_dz": 0.008},
    "plate_flexibility": {"frequency_hz": 520.0, "damping_ratio": 0.02, "twist": 0.8},
    "plate_flexibility_free": {"frequency_hz": 610.0, "damping_ratio": 0.03, "phi_zC": 0.6, "phi_z1": -0.5,
                               "phi_z2": 0.4, "phi_force": 0.5},
    "sensor_gain": {"zC_gain": 1.25},
    "sensor_polarity": {"x1_polarity": -1.0},
    "sensor_orientation": {"yC_tilt_a": 0.2, "yC_tilt_b": 0.2, "x1_tilt_a": 0.2, "x1_tilt_b": 0.2},
    "sensor_position": {"z1_dx": 0.015},
    "sensor_dynamics": {"highpass_hz": 20.0},
    "impact_location": {"dx": 0.02, "dy": -0.015},
    "force_gain": {"gain": 1.2},
    "base_motion": {"compliance": 2e-7},
}


def make_project(path: Path, effects: Sequence[tuple[str, Mapping[str, Any]]] = (), *, seed: int = 10,
                 n_samples: int = N_SAMPLES, scenarios: Sequence[str] = SCENARIOS) -> Path:
    """Create ``path`` with one simulated experiment per scenario, the truth altered by ``effects``."""
    from odsuite_plugins.daq_sim.simulator import default_chains

    from odsuite.processing.acquisition import acquire
    from odsuite.contracts.daq import AcquisitionSettings, rig_systeminfo
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import create_project

    p = create_project(path)
    try:
        chains = {k: replace(c, adc_bits=16) for k, c in default_chains(p.rig, rig_systeminfo(p.rig, 20000.0)).items()}
        for i, sc in enumerate(scenarios):
            acquire(p, registries().daq_backends.get("sim"), sc, AcquisitionSettings(n_samples=n_samples), scenario=sc, seed=seed + i,
                    effects=[(n, dict(v)) for n, v in effects], chains=chains)
    finally:
        p.close()
    return path
