"""A rigid motion with a closed form, written as a legacy test, imported and processed with
zero-phase filters, comes back as generalized coordinates at G (thesis Ch. 4.3-4.7)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import odsuite
from odsuite_plugins.importers.importing import import_legacy
from odsuite_plugins.importers.legacy import write_ctr, write_dat
from odsuite.processing.pipeline import process_experiment
from odsuite.store.project import create_project
from odsuite.domain.rigidbody import harmonic_motion, sensor_signals
from odsuite.domain.systeminfo import Systeminfo

FS = 20000.0
N = 32768
#: sinusoids between 50 and 500 Hz in every coordinate, amplitudes of a hammer test's motion
FREQS = np.array([[53.0, 137.0, 311.0, 487.0],
                  [61.0, 149.0, 293.0, 461.0],
                  [71.0, 173.0, 257.0, 433.0],
                  [83.0, 191.0, 239.0, 409.0],
                  [97.0, 211.0, 227.0, 397.0],
                  [101.0, 223.0, 331.0, 499.0]])
AMPS = np.vstack([np.full((3, 4), 1e-6), np.full((3, 4), 1e-5)])


def _record(rig, flip: str | None = None):
    """Raw volts of the nine accelerometers (and a silent force channel) for the closed-form
    motion, as the thesis rig records them: sign -1, Table E.3 sensitivities and DAQ gains."""
    si = Systeminfo.for_rig(rig, FS)
    # zero-phase 4th-order Butterworth high-passes at 20 Hz and the centred integration rule: no
    # phase error and a flat pass band (the thesis's elliptic design has 0.1 dB ripple, which
    # forward-backward filtering doubles: ~2 % per filter); the third filter (on displacement)
    # removes the offset that integrating the velocity leaves
    si = replace(si, channels=[replace(ch, zero_phase=True, integration_rule="trapezoid", filter_family=1,
                                       filter_order=4, filters_on=7 if ch.filters_on else 0, offset_length=0)
                               for ch in si.channels])
    t = np.arange(N) / FS
    # starts at zero displacement: the double integral of acceleration cannot know d(0)
    d, d_dot, d_ddot = harmonic_motion(t, AMPS, FREQS, phase=0.0)
    body = rig.body("platform")
    acc = sensor_signals(rig, body, d, "acceleration", d_g_dot=d_dot, d_g_ddot=d_ddot)
    raw = np.zeros((N, rig.channel_count))
    for s in rig.sensors:
        ch = si.channels[s.channel]
        sign = -s.sign if s.name == flip else s.sign
        raw[:, s.channel] = sign * acc[s.name] * ch.sensitivity * ch.daq_gain
    return raw, si, d


@pytest.mark.parametrize("flip", [None, "z1"])
def test_closed_form_motion_through_legacy_import(tmp_path, thesis_rig, flip):
    raw, si, truth = _record(thesis_rig, flip)
    dat, ctr = tmp_path / "T.DAT", tmp_path / "T.CTR"
    write_dat(dat, raw)
    write_ctr(si, ctr)
    path = tmp_path / "p.h5"
    create_project(path).close()
    import_legacy(path, dat, ctr, "synthetic", "0,0,0", "+z")
    with odsuite.open_project(path, "a") as p:
        summary = process_experiment(p, "synthetic")
        at_g = p.read_derived("synthetic", "gencoords")["platform_at_g"]
    rigidity = summary["bodies"]["platform"]
    if flip is None:
        # the middle half: near the ends the 20 Hz filters' transients outlast sosfiltfilt's padding
        core = slice(N // 4, -N // 4)
        err = np.sqrt(np.mean((at_g[core] - truth[core]) ** 2, axis=0) / np.mean(truth[core] ** 2, axis=0))
        assert np.all(err < 0.01), err
        assert max(rigidity["rigidity"].values()) < 0.01
        assert not rigidity["flagged"]
    else:
        # z1 enters the x angular acceleration pair (Eq. 4.12a vs 4.12d)
        assert "x" in rigidity["flagged"]
