"""Default magnification and the Characteristic Forced Response instant against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from odsuite.domain.errors import ConfigError
from odsuite_plugins.renderers.motion import (characteristic_instant, contact_index,
                                              default_magnification)


def test_magnification_from_a_pure_translation(thesis_rig):
    d = np.zeros((50, 6))
    d[:, 2] = 3e-6 * np.sin(np.linspace(0, 3, 50))
    ht, hr = default_magnification(thesis_rig, {"platform": d})
    # every corner moves by |z|; the platform's largest side is its width 169.93 mm
    assert ht == hr == pytest.approx(0.15 * 0.16993 / np.abs(d[:, 2]).max())


def test_magnification_from_a_pure_yaw(thesis_rig):
    d = np.zeros((2, 6))
    d[1, 5] = 2e-5
    ht, _ = default_magnification(thesis_rig, {"platform": d})
    plate = thesis_rig.body("platform").plate
    # yaw about G: the farthest corner in the x-y plane sweeps radius * angle
    xs = plate.corner[0] + np.array([0, plate.size[0]])
    ys = plate.corner[1] + np.array([0, plate.size[1]])
    radius = max(np.hypot(x, y) for x in xs for y in ys)
    assert ht == pytest.approx(0.15 * 0.16993 / (radius * 2e-5))


def test_cfr_is_the_first_peak_after_contact(thesis_rig):
    fs, n0 = 20000.0, 400
    t = np.arange(4000) / fs
    wn, zeta = 2 * np.pi * 180.0, 0.03
    wd = wn * np.sqrt(1 - zeta**2)
    tau = np.clip(t - n0 / fs, 0, None)
    z = 1e-6 * np.exp(-zeta * wn * tau) * np.sin(wd * tau)  # impulse response from sample n0
    d = np.zeros((t.size, 6))
    d[:, 2] = z
    force = np.zeros(t.size)
    force[n0:n0 + 8] = np.hanning(8) * 50
    contact = contact_index(force)
    assert contact == n0 + 1  # the Hann window's first sample is zero
    peak = characteristic_instant(thesis_rig, {"platform": d}, contact=contact)
    t_peak = np.arctan(wd / (zeta * wn)) / wd  # first maximum of the impulse response
    assert peak == pytest.approx(n0 + t_peak * fs, abs=1)


def test_no_motion_no_cfr(thesis_rig):
    with pytest.raises(ConfigError, match="do not move"):
        characteristic_instant(thesis_rig, {"platform": np.zeros((10, 6))})
    assert default_magnification(thesis_rig, {"platform": np.zeros((10, 6))}) == (1.0, 1.0)
