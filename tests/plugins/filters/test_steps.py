"""The Signal Processor steps against scipy and closed forms (thesis Eq. 4.3-4.7)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate
import scipy.signal

from odsuite.domain.errors import ConfigError
from odsuite_plugins.filters import steps

def _installed_steps():
    """The installed plugins' processing steps (chains name them)."""
    from odsuite.contracts.plugins import registries

    return registries().processing_steps


FS = 20_000.0
DT = 1 / FS


@pytest.mark.parametrize("family,ftype,cut", [
    ("elliptic", "highpass", {"cutoff_low": 20.0}),
    ("elliptic", "lowpass", {"cutoff_high": 1000.0}),
    ("elliptic", "bandpass", {"cutoff_low": 50.0, "cutoff_high": 500.0}),
    ("butterworth", "bandstop", {"cutoff_low": 50.0, "cutoff_high": 500.0}),
    ("butterworth", "highpass", {"cutoff_low": 20.0, "cutoff_high": 10_000.0}),  # row 8 unused
])
def test_designs_equal_scipy(family, ftype, cut):
    sos = steps.design_sos(fs=FS, family=family, type=ftype, order=6, ripple_db=0.1,
                           attenuation_db=60.0, **cut)
    wn = [cut["cutoff_low"], cut["cutoff_high"]] if ftype.startswith("band") else (
        cut["cutoff_low"] if ftype == "highpass" else cut["cutoff_high"])
    if family == "elliptic":
        ref = scipy.signal.ellip(6, 0.1, 60.0, wn, btype=ftype, fs=FS, output="sos")
    else:
        ref = scipy.signal.butter(6, wn, btype=ftype, fs=FS, output="sos")
    np.testing.assert_array_equal(sos, ref)


def test_table_e3_filter_response():
    # 8th-order elliptic high-pass, 20 Hz, 0.1 dB ripple, 60 dB stop band (thesis §5.2)
    sos = steps.design_sos(fs=FS, order=8, cutoff_low=20.0)
    f, h = scipy.signal.sosfreqz(sos, worN=[5.0, 20.0, 100.0, 1000.0], fs=FS)
    db = 20 * np.log10(np.abs(h))
    assert db[0] < -59.9  # stop band
    assert -0.1 - 1e-6 <= db[1] <= 0 and db[2] >= -0.1 - 1e-6 and db[3] >= -0.1 - 1e-6


def test_causal_filter_equals_sosfilt():
    x = np.random.default_rng(1).standard_normal(5000)
    step = steps.iir(FS, family="butterworth", type="lowpass", order=4, cutoff_high=800.0)
    ref = scipy.signal.sosfilt(scipy.signal.butter(4, 800.0, fs=FS, output="sos"), x)
    np.testing.assert_array_equal(step.apply(x), ref)


def test_zero_phase_equals_sosfiltfilt():
    x = np.random.default_rng(2).standard_normal(6000) + np.linspace(0, 3, 6000)
    from odsuite.processing.chain_spec import build_chain

    chain = build_chain([{"step": "iir", "order": 8, "cutoff_low": 20.0, "zero_phase": True}], fs=FS, registry=_installed_steps())
    ref = scipy.signal.sosfiltfilt(steps.design_sos(fs=FS, order=8, cutoff_low=20.0), x)
    np.testing.assert_allclose(chain.run(x)["output"], ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def _eq45(x, dt):
    """Eq. 4.5 written as its sum: y[i] = sum_{j<=i} (x[j-1] + 4x[j] + x[j+1]) dt/6, x[-1]=x[m]=0."""
    xp = np.concatenate([[0.0], x, [0.0]])
    return np.cumsum(xp[:-2] + 4 * xp[1:-1] + xp[2:]) * dt / 6


def test_thesis_integration_is_eq_4_5():
    x = np.random.default_rng(3).standard_normal(10_000)
    y = steps.integrate(FS).apply(x)
    ref = _eq45(x, DT)
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_thesis_integration_of_constant_leads():
    # constant c from t_0 (x[-1] = x[m] = 0): y[i] = c dt (i + 5/6), last sample c dt (m - 1/3);
    # the true integral from t_0 is c dt i: the sums run past t_i
    m, c = 50, 2.5
    y = steps.integrate(FS).apply(np.full(m, c))
    i = np.arange(m)
    np.testing.assert_allclose(y[:-1], c * DT * (i[:-1] + 5 / 6), rtol=1e-13)
    assert y[-1] == pytest.approx(c * DT * (m - 1 / 3), rel=1e-13)


def test_thesis_integration_of_ramp():
    # x[j] = j: sum_{j<=i} (6j) dt/6 + boundary terms = dt (i(i+1)/2 + (x[i+1] - x[i] - x[0])/6)
    m = 40
    x = np.arange(m, dtype=float)
    y = steps.integrate(FS).apply(x)
    i = np.arange(m)
    nxt = np.append(x[1:], 0.0)
    np.testing.assert_allclose(y, DT * (i * (i + 1) / 2 + (nxt - x) / 6), rtol=1e-13)


def test_thesis_integration_of_sinusoid_leads_half_sample():
    # Eq. 4.5 sums to y[i] = dt (S_i + (x[i+1] - x[i] - x[0]) / 6) with S_i = sum_{j<=i} x[j];
    # for x = cos(j wdt), S_i = sin((i + 1/2) wdt) / (2 sin(wdt/2)) + 1/2 in closed form
    f, m = 500.0, 4000
    th = 2 * np.pi * f * DT
    i = np.arange(m)
    x = np.cos(th * i)
    y = steps.integrate(FS).apply(x)
    s = np.sin((i + 0.5) * th) / (2 * np.sin(th / 2)) + 0.5  # sum_{j<=i} cos(j th)
    nxt = np.append(x[1:], 0.0)
    exact = DT * (s + (nxt - x - x[0]) / 6)
    np.testing.assert_allclose(y, exact, rtol=0, atol=1e-12)
    # the oscillating part is sin(w (t_i + dt/2)) / w: a lead of half a sample (phase w dt / 2)
    core = DT * s - DT / 2
    np.testing.assert_allclose(core, np.sin(th * (i + 0.5)) / (2 * np.pi * f) * (th / 2) / np.sin(th / 2),
                               atol=1e-15)


def test_trapezoid_equals_cumulative_trapezoid():
    x = np.random.default_rng(4).standard_normal(3000)
    y = steps.integrate(FS, rule="trapezoid").apply(x)
    ref = scipy.integrate.cumulative_trapezoid(x, dx=DT, initial=0)
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_double_thesis_integration_advances_one_sample():
    # a 300 Hz tone: thesis double integral equals the trapezoid one shifted by one sample
    f, m = 300.0, 20_000
    t = np.arange(m) * DT
    x = np.sin(2 * np.pi * f * t)
    th2 = steps.integrate(FS).apply(steps.integrate(FS).apply(x))
    tr2 = steps.integrate(FS, "trapezoid").apply(steps.integrate(FS, "trapezoid").apply(x))
    # remove the linear drift both rules carry from the start, compare the oscillation's phase
    def phase(y):
        yy = y - np.polyval(np.polyfit(t, y, 1), t)
        return np.angle(np.sum(yy * np.exp(-2j * np.pi * f * t)))
    lead = (phase(th2) - phase(tr2) + np.pi) % (2 * np.pi) - np.pi
    assert lead == pytest.approx(2 * np.pi * f * DT, rel=0.02)


def test_convert_invert_micro():
    v = np.array([0.1, -0.2, 0.05])
    # Eq. 4.3 in SI: 20.292 mV/(m/s^2) is 0.020292 V/(m/s^2), gain 10
    np.testing.assert_allclose(steps.convert(FS, 0.020292, 10.0).apply(v), v / (0.020292 * 10))
    np.testing.assert_array_equal(steps.invert(FS).apply(v), -v)
    np.testing.assert_array_equal(steps.micro(FS).apply(v), v * 1e6)


def test_offset_window_and_moving_average():
    x = np.arange(20, dtype=float) ** 2
    y = steps.offset(FS, start=3, length=4).apply(x)
    np.testing.assert_allclose(y, x - np.mean([9, 16, 25, 36]))
    ma = steps.moving_average(FS, 5).apply(x)
    ref = np.array([x[i] - x[max(0, i - 4):i + 1].mean() for i in range(20)])
    np.testing.assert_allclose(ma, ref, rtol=1e-13, atol=1e-12)
    with pytest.raises(ConfigError, match="outside the record of 20 samples"):
        steps.offset(FS, start=18, length=4).apply(x)


@pytest.mark.parametrize("kwargs,match", [
    ({"type": "highpass", "cutoff_low": 12_000.0}, "cutoff_low"),
    ({"type": "lowpass", "cutoff_low": 20.0}, "cutoff_high"),
    ({"family": "chebyshev", "cutoff_low": 20.0}, "family"),
    ({"type": "bandpass", "cutoff_low": 500.0, "cutoff_high": 50.0}, "below"),
    ({"order": 0, "cutoff_low": 20.0}, "order"),
])
def test_bad_filter_settings(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        steps.iir(FS, **kwargs)


def test_registered(registries):
    for name in ("convert", "invert", "micro", "offset", "moving-average", "iir", "integrate"):
        assert name in registries.processing_steps


def _stream(step, x, sizes):
    """``step`` streamed over ``x`` in chunks of the given sizes (last axis), plus its tail."""
    state, outs, a = step.init_state(), [], 0
    for k in sizes:
        y, state = step.process(x[..., a:a + k], state)
        outs.append(np.array(y))
        a += k
    outs.append(np.asarray(step.finish(state)).reshape(x.shape[:-1] + (-1,)))
    return np.concatenate(outs, axis=-1)


@pytest.mark.parametrize("make", [
    lambda: steps.convert(FS, 0.02, 10.0),
    lambda: steps.offset(FS, start=30, length=200).scaled(-3.0),
    lambda: steps.moving_average(FS, 37),
    lambda: steps.iir(FS, order=8, cutoff_low=20.0),
    lambda: steps.integrate(FS),
    lambda: steps.integrate(FS).fuse(steps.iir(FS, order=8, cutoff_low=20.0)),  # Eq. 4.5 + filter 2
    lambda: steps.zero_phase_steps(steps.design_sos(fs=FS, order=4, cutoff_low=50.0))[0],  # odd pad
    lambda: steps.zero_phase_steps(steps.design_sos(fs=FS, order=4, cutoff_low=50.0))[1],  # steady start
])
def test_channels_at_once_equal_one_by_one(make):
    # a block of channels (channels x samples) gives, row by row, exactly the 1-D results
    x = np.random.default_rng(8).standard_normal((3, 1500)) + np.array([[0.0], [2.0], [-5.0]])
    sizes = [250, 1, 700, 549]
    block = _stream(make(), x, sizes)
    assert block.shape[0] == 3 and block.shape[1] >= 1500 - 1
    for r in range(3):
        np.testing.assert_array_equal(block[r], _stream(make(), x[r], sizes))
    # owned buffers may be overwritten in place: same numbers
    step, state, outs = make(), None, []
    state = step.init_state()
    for a, k in zip(np.cumsum([0] + sizes[:-1]), sizes):
        y, state = step.process_owned(x[:, a:a + k].copy(), state)
        outs.append(np.array(y))
    outs.append(np.asarray(step.finish(state)).reshape(3, -1))
    np.testing.assert_array_equal(np.concatenate(outs, axis=-1), block)
