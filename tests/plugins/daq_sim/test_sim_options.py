"""The simulated rig's options for a user's own exercises: a truth from another rig file, the ADC's
resolution and the noise level."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from odsuite_plugins.daq_sim.simulator import SimulatedRig

from odsuite.contracts.daq import AcquisitionSettings
from odsuite.domain.errors import ConfigError
from odsuite.domain.rig import load_rig

RIG_FILE = Path(__file__).resolve().parents[3] / "projects" / "rigs" / "two-body-machine.toml"
SETTINGS = AcquisitionSettings(sampling_rate=10240.0, n_samples=2048, pretrigger=256)
POINT, DIRECTION = [0.05, 0.02, 0.25], [0.0, 0.0, -1.0]


def record(rig, **kw) -> np.ndarray:
    rec = SimulatedRig().record(rig, SETTINGS, point=POINT, direction=DIRECTION, seed=7, **kw)
    return np.concatenate(list(rec.chunks))


def hidden_change(tmp_path: Path) -> Path:
    """The two-body rig with isolator1 twice as stiff and the first machine accelerometer reading 25 %
    high: written as a user would, by editing a copy of the file."""
    text = RIG_FILE.read_text()
    text = text.replace("stiffness = [200000.0, 200000.0, 400000.0]  # N/m",
                        "stiffness = [400000.0, 400000.0, 800000.0]  # N/m", 1)
    text = text.replace("channels = [1, 2, 3]\nsensitivity = 0.0102", "channels = [1, 2, 3]\nsensitivity = 0.01275", 1)
    path = tmp_path / "stiffer.toml"
    path.write_text(text)
    return path


@pytest.fixture
def rig(registries):
    return load_rig(RIG_FILE, registries.sensor_types)


def test_the_rigs_own_file_as_truth_changes_nothing(rig):
    assert np.array_equal(record(rig, truth_rig=str(RIG_FILE)), record(rig))


def test_a_truth_file_records_its_own_structure_and_sensitivities(rig, registries, tmp_path):
    path = hidden_change(tmp_path)
    true_rig = load_rig(path, registries.sensor_types)
    hidden = record(rig, truth_rig=str(path))
    # the same record as a project whose rig is the changed one: same model, same chains
    assert np.array_equal(hidden, record(true_rig))
    nominal = record(rig)
    assert not np.allclose(hidden, nominal)
    # the force is the project rig's hammer: the same blow
    assert np.array_equal(hidden[:, 0], nominal[:, 0])


def test_adc_bits_set_the_code_step(rig):
    raw = record(rig, adc_bits=16)
    codes = np.unique(raw[:, 4])
    steps = np.diff(codes)
    # +-5 V range (the rig's +-5 V limits): one code is 10 V / 2**16
    assert steps.min() == pytest.approx(10.0 / 2**16, rel=1e-6)
    assert np.allclose(steps / steps.min(), np.round(steps / steps.min()), atol=1e-6)


def test_noise_zero_leaves_only_quantisation_before_the_hit(rig):
    quiet = record(rig, noise=0.0, adc_bits=24)
    # before the blow no structure moves: every channel sits at one code (no noise, offset or drift)
    pre = quiet[:200]
    assert np.all(np.ptp(pre, axis=0) == 0)
    loud = record(rig, noise=10.0)
    normal = record(rig)
    assert np.std(loud[:200, 4]) > 5 * np.std(normal[:200, 4])


@pytest.mark.parametrize("kw, words", [
    ({"adc_bits": 4}, ["--adc-bits", "4"]),
    ({"noise": -1.0}, ["--noise", "-1.0"]),
    ({"noise": float("nan")}, ["--noise", "nan"]),
    ({"truth_rig": "no-such-rig.toml"}, ["no-such-rig.toml"]),
])
def test_bad_options_are_one_line(rig, kw, words):
    with pytest.raises(ConfigError) as err:
        record(rig, **kw)
    assert "\n" not in str(err.value) and all(w in str(err.value) for w in words), str(err.value)


def test_a_truth_file_without_the_rigs_channels_is_refused(rig, tmp_path):
    path = tmp_path / "fewer.toml"
    path.write_text(RIG_FILE.read_text().replace("channels = [1, 2, 3]", "channels = [1, 2, 20]", 1)
                    .replace("channel_count = 19", "channel_count = 21", 1))
    with pytest.raises(ConfigError) as err:
        record(rig, truth_rig=str(path))
    assert "channel 3" in str(err.value) and "fewer.toml" in str(err.value), str(err.value)


def test_the_rigs_acquisition_table_sets_the_adc(rig):
    # the two-body rig declares a 24-bit converter on +-5 V: steps of 10 V / 2**24 (a finer grid
    # than any noise-free difference could fake: at least a thousand distinct codes)
    assert rig.acquisition.adc_bits == 24
    codes = np.unique(record(rig)[:, 4])
    assert codes.size > 1000
    steps = np.diff(codes) / (10.0 / 2**24)
    assert np.allclose(steps, np.round(steps), atol=1e-3) and steps.min() == pytest.approx(1.0, abs=1e-3)
