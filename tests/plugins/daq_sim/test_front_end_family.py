"""The simulated rig records through the anti-aliasing filter of the family its rig file declares
(elliptic, Chebyshev, Bessel), as the model predicts through it. It drew every family as a
Butterworth of the same order and cut-off with a warning: an elliptic 8th-order filter at 10 kHz
and its Butterworth differ in phase by 0.7 degree at 300 Hz and 14 degrees at 3 kHz."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.signal

from odsuite.contracts.plugins import registries
from odsuite.domain.rig import AntiAliasing, load_rig
from odsuite_plugins.daq_sim.chain import ChannelChain
from odsuite_plugins.daq_sim.simulator import default_chains, rig_systeminfo

RIGS = Path(__file__).resolve().parents[2] / "data" / "rigs"


@pytest.mark.parametrize("family,order", [("elliptic", 8), ("elliptic", 7), ("chebyshev1", 6), ("bessel", 5)])
def test_the_chain_of_a_declared_family_responds_as_that_filter(family, order):
    aa = AntiAliasing(family, order, 10000.0, 0.1, 80.0)
    z, p, k = aa.zpk()
    chain = ChannelChain(sensitivity=0.01, sensor_tc=None, coupler_tc=None, resonance_hz=None, gain=1.0,
                         aaf_order=order, aaf_cutoff_hz=10000.0,
                         aaf_zpk=(tuple(complex(q) for q in z), tuple(complex(q) for q in p), float(k)))
    f = np.array([50.0, 300.0, 3000.0, 9000.0, 15000.0])
    expected = 0.01 * scipy.signal.freqs_zpk(z, p, k, worN=2 * np.pi * f)[1]
    assert chain.frequency_response(f) == pytest.approx(expected, rel=1e-12)
    # the simulator's discrete sections (first-order hold at 8 x 25.6 kHz) follow it in the band
    _, discrete = scipy.signal.sosfreqz(chain.discrete_sos(204800.0), worN=f[:3], fs=204800.0)
    assert np.abs(discrete / expected[:3]) == pytest.approx(1.0, abs=3e-3)
    assert np.degrees(np.angle(discrete / expected[:3])) == pytest.approx(0.0, abs=0.05)


def test_a_rig_declaring_an_elliptic_filter_is_simulated_through_it():
    rig = load_rig(RIGS / "stiff-bracket.toml", registries().sensor_types)
    chains = default_chains(rig, rig_systeminfo(rig, 25600.0))
    z, p, k = rig.acquisition.anti_aliasing.zpk()
    f = np.array([300.0, 3000.0])
    for chain in chains.values():
        assert chain.aaf_zpk is not None
        h = chain.frequency_response(f) / (chain.sign * chain.sensitivity * chain.gain)
        elliptic = scipy.signal.freqs_zpk(z, p, k, worN=2 * np.pi * f)[1]
        assert np.angle(h / elliptic, deg=True) == pytest.approx([0.0, 0.0], abs=0.5)


def test_a_force_channel_bypassing_the_filter_passes_no_low_pass():
    # force_channel = false kept the thesis's 8th-order 1 kHz low-pass on the force channel, while
    # the model (driven by the measured force, the filter on the accelerometers alone) takes the
    # force as unfiltered: the bracket's model read 50 times its noise floor off its own record
    rig = load_rig(RIGS / "stiff-bracket.toml", registries().sensor_types)
    aa = rig.acquisition.anti_aliasing
    rig = replace(rig, acquisition=replace(rig.acquisition, anti_aliasing=replace(aa, force_channel=False)))
    chains = default_chains(rig, rig_systeminfo(rig, 25600.0))
    assert chains[rig.force_channel].aaf_cutoff_hz is None
    assert all(c.aaf_cutoff_hz == aa.cutoff_hz for ch, c in chains.items() if ch != rig.force_channel
               and rig.sensor_on_channel(ch) is not None)
