"""Operating deflection shapes from measured FRFs, as rigid-body motion, against the model's own
coordinate FRF (Eq. 3.18) at the same frequency, and animated by the renderers."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import odsuite
from odsuite.analysis.modal_project import ods_coordinates, ods_motion

sys.path.insert(0, str(Path(__file__).parent))
from hidden_effects import make_project  # noqa: E402

#: rotations weighed as the displacement they give 5 cm from the centre of mass
WEIGHT = np.array([1.0, 1.0, 1.0, 0.05, 0.05, 0.05])


@pytest.fixture(scope="module")
def project(tmp_path_factory):
    return make_project(tmp_path_factory.mktemp("ods") / "p.h5", scenarios=("T3",), n_samples=4096)


@pytest.mark.parametrize("frequency_hz", [103.5, 150.0, 216.9])
def test_ods_equals_the_models_coordinate_frf(project, frequency_hz):
    from odsuite.domain.model import Input, Output
    from odsuite.analysis.modelrev import base_model

    with odsuite.open_project(project) as p:
        measured = ods_coordinates(p, "T3", frequency_hz)["platform"]
        exc = p.experiment("T3").excitation
        model = base_model(p.rig, registries=p.registries)
        body = p.rig.body("platform")
    exact = model.transfer([Input.force(exc.point, exc.direction)], [Output.coordinates(body)], frequency_hz)[0, :, 0]
    a, b = measured * WEIGHT, exact * WEIGHT
    # the truth is the nominal model: only the 20 Hz high-pass, noise and the force window differ
    assert np.linalg.norm(a - b) / np.linalg.norm(b) < 0.05


def test_ods_motion_is_the_shape_turning(project):
    with odsuite.open_project(project) as p:
        shapes = ods_coordinates(p, "T3", 216.9)
    motion, fs = ods_motion(shapes, 216.9, cycles=2, frames_per_cycle=40)
    d = motion["platform"]
    assert d.shape == (80, 6) and fs == pytest.approx(40 * 216.9)
    assert np.allclose(d[0], shapes["platform"].real) and np.allclose(d[10], -shapes["platform"].imag)
    assert np.allclose(d[:40], d[40:])


@pytest.mark.render
def test_render_ods_movie(project, tmp_path):
    from odsuite.cli import main

    out = tmp_path / "ods.gif"
    assert main(["render", str(project), "T3", "-o", str(out), "--ods", "216.9"]) == 0
    from PIL import Image

    with Image.open(out) as gif:
        assert gif.n_frames == 120  # three cycles of 40 frames
