"""The simulated rig on a moving ground (``--operating base-random``): the truth's time-domain
response to the ground's six accelerations against the model's frequency response through the
ground springs' and dampers' forces (absolute coordinates, an independent path), the record
through the command line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.signal
from odsuite_plugins.daq_sim.operating import ground_accelerations, rotation_length
from odsuite_plugins.daq_sim.truth import model_truth

from odsuite.cli import main
from odsuite.domain.model import Input, Output
from odsuite.contracts.plugins import registries
from odsuite.store.project import open_project
from odsuite.domain.rig import load_rig

RIGS = Path(__file__).resolve().parents[3] / "projects" / "rigs"
#: the thesis rig and its Systeminfo ship once, with the models plugin that registers them
PLUGIN_RIGS = Path(__file__).resolve().parents[3] / "plugins" / "models" / "rigs"


@pytest.mark.parametrize("rig_file, band", [("thesis-dynamometer.toml", (30.0, 350.0)),
                                            ("two-body-machine.toml", (8.0, 150.0))])
def test_ground_motion_transmissibility_from_the_simulated_record(rig_file, band):
    """Six independent white ground accelerations through the truth (relative coordinates,
    -M T a_g, first-order hold): the six-input H1 = G_yu G_uu^-1 from Welch cross-spectra of the
    simulated responses equals the model's absolute velocity per ground displacement / (i w),
    from the ground forces Kg u + Cg u' (absolute coordinates)."""
    rig = load_rig(next(d / rig_file for d in (RIGS, PLUGIN_RIGS) if (d / rig_file).is_file()),
                   registries().sensor_types)
    truth = model_truth(rig)
    fs = 4096.0  # well above both rigs' modes (to 228 Hz and 104 Hz): the hold's error is small
    length = rotation_length(np.array([s.position for s in rig.accelerometers]))
    u = ground_accelerations(int(120 * fs), 1.0, length, np.random.default_rng(1))
    y = truth.ground(u, fs)
    nper = 4 * 4096  # 0.25 Hz lines: four per half-power band of the lightest-damped mode (3.4 % at 16 Hz)
    # csd(x, y) = E[conj(X) Y]: G_uy[f, b, i] = sum_a G_uu[f, b, a] H[f, i, a], so H = (G_uu^-1 G_uy)^T
    f, Guu = scipy.signal.csd(u[:, :, None], u[:, None, :], fs, nperseg=nper, axis=0)
    _, Guy = scipy.signal.csd(u[:, :, None], y[:, None, :], fs, nperseg=nper, axis=0)
    keep = (f >= band[0]) & (f <= band[1])
    H1 = np.linalg.solve(Guu[keep], Guy[keep]).transpose(0, 2, 1)
    model = truth.model
    axes = np.eye(3)
    vel = model.transfer([Input.base_translation(a) for a in axes] + [Input.base_rotation(a) for a in axes],
                         [Output.sensor(s, "velocity") for s in rig.accelerometers], f[keep])
    # acceleration per ground acceleration (i w v) / (-w^2 u) = (v / u) / (i w), rotations alike
    ref = vel / (2j * np.pi * f[keep])[:, None, None]
    scale = np.abs(ref).max(axis=(0, 2), keepdims=True)  # per sensor: errors against its largest term
    err = np.abs(H1 - ref) / scale
    assert np.percentile(err, 95) < 0.03, np.percentile(err, 95)
    assert err.max() < 0.08, err.max()


def test_base_random_through_the_command_line(tmp_path, capsys):
    """A minute of base motion on the thesis rig at the default rms: no force channel, no
    excitation, no clipped sample, the source says what moved."""
    p = tmp_path / "b.h5"
    assert main(["new", str(p), "--rig", "thesis-dynamometer"]) == 0
    capsys.readouterr()
    assert main(["acquire", str(p), "--daq", "sim", "--name", "b", "--rate", "1000", "--samples", "60000",
                 "--operating", "base-random", "--seed", "5"]) == 0
    assert "clipped" not in capsys.readouterr().err
    with open_project(p) as proj:
        exp = proj.experiment("b")
        assert exp.excitation is None and "ai0" in exp.channel_names
        source = proj.info()["experiments"]["b"]["source"]
    assert "operating=base-random base_rms=0.3m/s^2" in source and "length_m=0.1028" in source


def test_base_random_on_another_rig(tmp_path):
    """The two-body machine (its own rate, 5120 Hz): the ground moves both bodies."""
    p = tmp_path / "m.h5"
    assert main(["new", str(p), "--rig", str(RIGS / "two-body-machine.toml")]) == 0
    assert main(["acquire", str(p), "--daq", "sim", "--name", "b", "--samples", "10240",
                 "--operating", "base-random", "--base-rms", "0.5", "--seed", "2"]) == 0
    with open_project(p) as proj:
        exp = proj.experiment("b")
        assert exp.excitation is None and exp.sampling_rate == 5120.0
        assert "base_rms=0.5m/s^2" in proj.info()["experiments"]["b"]["source"]
