"""measured-modal-damping: each model mode damped as its measured partner, on a simulated hit of a
beam with known damping and on the real LADISK record (published damping ratios)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from odsuite_plugins.beam.fe import BeamSpec, BeamStructure, Support

from odsuite_plugins.importers.lvm import read_lvm
from odsuite.domain.model import Input, Model, Output, Sensor

L, MU, EI = 0.5, 2.0, 100.0  # m, kg/m, N m^2: bending modes near 101, 277, 544, 900 Hz
TRUE_ZETA = (0.004, 0.003, 0.002, 0.0015)


def hit(structure: BeamSpec, fs: float = 8192.0, n: int = 32768) -> SimpleNamespace:
    """A record of a 0.5 ms half-sine blow at 0.1 m seen at 0.45 m (exact: H(f) F(f), 4 s, decayed)."""
    model = Model(BeamStructure(structure))
    sensor = Sensor("acc", 0, "beam", np.array([0.45, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]))
    f = np.fft.rfftfreq(n, 1 / fs)
    inputs, outputs = [Input.force([0.1, 0, 0], [0, 0, 1], body="beam")], [Output.sensor(sensor)]
    # in blocks: one dense solve per line, kept to a few MB at a time
    H = np.concatenate([model.transfer(inputs, outputs, block)[:, 0, 0] for block in np.array_split(f, 64)])
    t = np.arange(n) / fs
    pulse = np.where(t < 5e-4, 100.0 * np.sin(np.pi * t / 5e-4), 0.0)  # N
    response = np.fft.irfft(H * np.fft.rfft(pulse), n)
    return SimpleNamespace(name="sim", fs=fs, n_samples=n, force=pulse, measured=response[:, None])


def test_each_mode_takes_its_measured_partners_damping(registries):
    effect = registries.effects.get("measured-modal-damping")
    truth = BeamSpec("beam", np.zeros(3), L, MU, EI, elements=12, damping_ratio=TRUE_ZETA,
                     supports=(Support("a", 0.05, 1e3), Support("b", 0.45, 1e3)))
    f, z = effect.measured_modes(hit(truth))
    model = Model(BeamStructure(BeamSpec("beam", np.zeros(3), L, MU, EI, elements=12, damping_ratio=(0.03,),
                                         supports=truth.supports)))
    bending = model.structure.damped_modes_hz()
    # the record also shows the beam bouncing and rocking on its soft supports below the bending
    # modes; each bending mode is the identified one nearest it
    nearest = [int(np.argmin(np.abs(f - b))) for b in bending[:4]]
    assert np.allclose(f[nearest], bending[:4], rtol=2e-3)
    np.testing.assert_allclose(z[nearest], TRUE_ZETA, rtol=0.05)
    np.testing.assert_allclose(f[:2], model.modes().frequency_hz[:2], rtol=2e-3)  # the supports' 7.1, 9.9 Hz
    params = effect.parameters(model)
    assert [p.nominal for p in params[:3]] == pytest.approx([0.03] * 3, rel=1e-6)
    # the ratios the projection finds, applied: the model's bending modes decay as the record's
    shared = {}
    for k, fk in enumerate(bending[:len(params)]):
        near = np.argmin(np.abs(f - fk))
        shared[f"zeta_{k + 1}"] = z[near] if abs(f[near] / fk - 1) < 0.1 else params[k].nominal
    damped = effect.apply(model, shared).modes()
    got = [damped.damping_ratio[np.argmin(np.abs(damped.frequency_hz - fk))] for fk in bending[:4]]
    np.testing.assert_allclose(got, TRUE_ZETA, rtol=0.05)
    # a mode the record does not resolve keeps the model's own ratio
    assert effect.parameters(effect.apply(model, shared))[-1].nominal == pytest.approx(0.03, rel=1e-6)


def test_a_record_too_short_to_resolve_a_peak_gives_no_damping(registries):
    effect = registries.effects.get("measured-modal-damping")
    short = hit(BeamSpec("beam", np.zeros(3), L, MU, EI, elements=12, damping_ratio=TRUE_ZETA), n=256)  # 4 Hz lines
    f, z = effect.measured_modes(short)
    assert np.all(2 * z * f >= 2 * short.fs / short.n_samples)


def test_the_real_beam_records_give_the_published_damping(registries, real_data):
    """LADISK beam (README: 0.0047, 0.0031, 0.0020 at 695.0, 1897.6, 3671.2 Hz, LSCF by pyEMA)."""
    effect = registries.effects.get("measured-modal-damping")
    lvm = read_lvm(real_data / "ladisk_beam_impact" / "acceleration.lvm")
    data = lvm.data  # columns: acceleration (g), force (N)
    rec = SimpleNamespace(name="acceleration", fs=lvm.sampling_rate, n_samples=data.shape[0], force=data[:, 1],
                          measured=data[:, :1] * 9.80665)
    f, z = effect.measured_modes(rec)
    for f_pub, z_pub in ((695.0, 0.0047), (1897.6, 0.0031), (3671.2, 0.0020)):
        k = np.argmin(np.abs(f - f_pub))
        assert f[k] == pytest.approx(f_pub, rel=2e-3)
        assert z[k] == pytest.approx(z_pub, rel=0.10)
