"""Exact-discretisation simulation against scipy.signal.lsim/dlsim and closed-form SDOF responses."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal
from odsuite_plugins.models.thesis import thesis_dynamometer

from odsuite.domain.errors import ConfigError, DimensionError
from odsuite.domain.model import Input, Model, Output, RigidBody, SpringDamper
from odsuite.domain.simulation import simulate

FS = 20_000.0


def hammer(n: int, fs: float = FS, start: int = 40, width_s: float = 4e-4, peak: float = 300.0) -> np.ndarray:
    """A half-sine hammer pulse with a little measurement noise before and after."""
    t = np.arange(n) / fs
    u = np.where((t >= start / fs) & (t < start / fs + width_s),
                 peak * np.sin(np.pi * (t - start / fs) / width_s), 0.0)
    return u + np.random.default_rng(0).normal(0, 0.2, n)


def _rel(y, ref):
    return np.max(np.abs(y - ref), axis=0) / np.max(np.abs(ref), axis=0)


@pytest.mark.parametrize("hold", ["zoh", "foh"])
def test_dynamometer_matches_lsim(thesis_rig, hold):
    model = thesis_dynamometer(thesis_rig)
    inputs = [Input.force((0.050025, -0.075761, -0.00632), (-1, 0, 0)),
              Input.force((0.0, 0.004122, -0.011399), (0, 0, 1))]
    outputs = [Output.sensor(s) for s in thesis_rig.sensors] + list(Output.coordinates("platform"))
    n = 2000
    u = np.column_stack([hammer(n), 0.5 * hammer(n, start=300)])
    y = simulate(model, inputs, u, FS, outputs, hold=hold)
    ss = model.state_space(inputs, outputs)
    t = np.arange(n) / FS
    _, ref, _ = scipy.signal.lsim((ss.A, ss.B, ss.C, ss.D), u, t, interp=(hold == "foh"))
    assert y.shape == (n, 15)
    assert np.all(_rel(y, ref) < 1e-9)
    if hold == "zoh":
        sysd = scipy.signal.cont2discrete((ss.A, ss.B, ss.C, ss.D), 1 / FS, method="zoh")
        _, refd, _ = scipy.signal.dlsim(sysd, u)
        assert np.all(_rel(y, refd) < 1e-9)


def sdof(m=2.0, c=30.0, k=8e5):
    body = RigidBody("m", m, np.eye(3), dofs=("z",))
    return Model.build([body], [SpringDamper("k", (0, 0, 0), "m", None, (0, 0, k), (0, 0, c))])


def test_sdof_step_response_closed_form():
    m, c, k = 2.0, 30.0, 8e5
    model = sdof(m, c, k)
    wn = np.sqrt(k / m)
    z = c / (2 * np.sqrt(k * m))
    wd = wn * np.sqrt(1 - z * z)
    n, F = 4000, 5.0
    t = np.arange(n) / FS
    outs = [Output.at_point((0, 0, 0), (0, 0, 1), q) for q in ("displacement", "velocity", "acceleration")]
    y = simulate(model, [Input.force((0, 0, 0), (0, 0, 1))], np.full(n, F), FS, outs, hold="zoh")
    e = np.exp(-z * wn * t)
    x = F / k * (1 - e * (np.cos(wd * t) + z / np.sqrt(1 - z * z) * np.sin(wd * t)))
    v = F / k * e * wn**2 / wd * np.sin(wd * t)
    assert np.max(np.abs(y[:, 0] - x)) < 1e-12 * F / k
    assert np.max(np.abs(y[:, 1] - v)) < 1e-11 * np.abs(v).max()
    # acceleration from the equation of motion (D term: the force acts at once)
    assert np.max(np.abs(y[:, 2] - (F - c * v - k * x) / m)) < 1e-10 * F / m


def test_sdof_ramp_response_closed_form_first_order_hold():
    m, c, k = 2.0, 30.0, 8e5
    model = sdof(m, c, k)
    wn = np.sqrt(k / m)
    z = c / (2 * np.sqrt(k * m))
    wd = wn * np.sqrt(1 - z * z)
    n, slope = 3000, 1e4  # N/s
    t = np.arange(n) / FS
    y = simulate(model, [Input.force((0, 0, 0), (0, 0, 1))], slope * t, FS,
                 [Output.at_point((0, 0, 0), (0, 0, 1), "displacement")], hold="foh")[:, 0]
    ref = slope / k * (t - 2 * z / wn + np.exp(-z * wn * t)
                       * (2 * z / wn * np.cos(wd * t) + (2 * z * z - 1) / wd * np.sin(wd * t)))
    assert np.max(np.abs(y - ref)) < 1e-12 * np.abs(ref).max()


def test_sdof_impulse_response_converges_to_closed_form():
    m, c, k = 2.0, 30.0, 8e5
    model = sdof(m, c, k)
    wn = np.sqrt(k / m)
    z = c / (2 * np.sqrt(k * m))
    wd = wn * np.sqrt(1 - z * z)
    impulse = 0.01  # N s
    errors = []
    for fs in (20e3, 80e3):
        n = int(0.05 * fs)
        u = np.zeros(n)
        u[0] = impulse * fs  # one-sample pulse of the impulse's area
        t = np.arange(n) / fs
        y = simulate(model, [Input.force((0, 0, 0), (0, 0, 1))], u, fs,
                     [Output.at_point((0, 0, 0), (0, 0, 1), "displacement")])[:, 0]
        h = impulse / (m * wd) * np.exp(-z * wn * t) * np.sin(wd * t)
        # a pulse of width T equals an impulse at T/2
        h_mid = impulse / (m * wd) * np.exp(-z * wn * (t - 0.5 / fs)) * np.sin(wd * (t - 0.5 / fs))
        errors.append(np.max(np.abs(y[1:] - h[1:])) / np.abs(h).max())
        assert np.max(np.abs(y[1:] - h_mid[1:])) / np.abs(h).max() < 1e-3
    assert errors[1] < errors[0] / 3  # first-order convergence to the ideal impulse


def test_band_limited_hold_matches_lsim_of_the_band_limited_pulse():
    # a 300 Hz oscillator hit by a 1.5 ms pulse sampled at 2048 samples/s: the record implies the
    # band-limited signal sum_k u[k] sinc(fs t - k), here evaluated on a 32x finer grid (from 0.2 s
    # before the record, where its tails start) and run through scipy's lsim
    fs, n, before, fine = 2048.0, 1024, 400, 32
    m, f0, zeta = 2.0, 300.0, 0.02
    k = m * (2 * np.pi * f0) ** 2
    model = sdof(m, 2 * zeta * np.sqrt(k * m), k)
    hit, out = Input.force((0, 0, 0), (0, 0, 1)), Output.at_point((0, 0, 0), (0, 0, 1), "acceleration")
    t = np.arange(n) / fs
    u = np.where((t > 0.05) & (t < 0.0515), 100.0 * np.sin(np.pi * (t - 0.05) / 1.5e-3), 0.0)
    on = np.flatnonzero(u)
    tf = np.arange(-before * fine, (n - 1) * fine + 1) / (fs * fine)
    uf = np.sinc(fs * tf[:, None] - on[None, :]) @ u[on]
    ss = model.state_space([hit], [out])
    _, yf, _ = scipy.signal.lsim((ss.A, ss.B, ss.C, ss.D), uf, tf - tf[0])
    ref = yf[before * fine::fine]
    band = simulate(model, [hit], u, fs, [out], hold="band")[:, 0]
    foh = simulate(model, [hit], u, fs, [out], hold="foh")[:, 0]
    scale = np.abs(ref).max()
    # measured 1.1e-4; the first-order hold of the samples loses sinc^2(f0/fs) = 7 % of the response
    assert np.abs(band - ref).max() < 3e-4 * scale
    assert np.abs(foh - ref).max() > 0.05 * scale


@pytest.mark.parametrize("hold", ["zoh", "foh"])
@pytest.mark.parametrize("path", ["modal", "matrix exponential"])
def test_sensor_dynamics_in_series_match_lsim(thesis_rig, monkeypatch, hold, path):
    """Nine identical sensor filters (Eq. 2.2: 0.5 Hz high-pass, 25 kHz resonance) in series with
    the structure: repeated, widely spread eigenvalues; both simulation paths still match lsim."""
    from odsuite.domain import simulation
    from odsuite.domain.model import SensorDynamics

    if path != "modal":
        monkeypatch.setattr(simulation, "MAX_MODAL_CONDITION", 0.0)
    model = thesis_dynamometer(thesis_rig)
    model = model.replace(chain=model.chain.with_items(
        "dynamics", {"*": SensorDynamics(highpass_hz=0.5, resonance_period_s=1 / 25e3)}))
    inputs = [Input.force((0.0, 0.004122, -0.011399), (0, 0, 1))]
    outputs = [Output.sensor(s) for s in thesis_rig.sensors]
    n = 1500
    u = hammer(n)
    y = simulate(model, inputs, u, FS, outputs, hold=hold)
    ss = model.state_space(inputs, outputs)
    _, ref, _ = scipy.signal.lsim((ss.A, ss.B, ss.C, ss.D), u, np.arange(n) / FS, interp=(hold == "foh"))
    assert np.max(np.abs(y - ref)) < 1e-9 * np.abs(ref).max()


def test_bad_input_records_are_refused(thesis_rig):
    model = thesis_dynamometer(thesis_rig)
    inp = [Input.force((0, 0, 0), (0, 0, 1))]
    out = [Output.sensor(thesis_rig.sensors[0])]
    with pytest.raises(DimensionError, match=r"\(10, 2\)"):
        simulate(model, inp, np.zeros((10, 2)), FS, out)
    with pytest.raises(DimensionError, match="NaN"):
        simulate(model, inp, np.full(10, np.nan), FS, out)
    with pytest.raises(ConfigError, match="hold"):
        simulate(model, inp, np.zeros(10), FS, out, hold="cubic")
