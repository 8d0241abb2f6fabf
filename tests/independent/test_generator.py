"""The independent generator checked against closed-form physics, scipy and odsuite's readers."""

from __future__ import annotations

import ast
import json
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from odsuite_plugins.importers.legacy import read_ctr, read_dat
from odsuite_plugins.importers.lvm import read_lvm
from odsuite_plugins.importers.uff import read_uff

from . import cases, writers
from .rigs import thesis_rig, two_body_rig
from .rigsim import Model, anti_aliasing, lti_response, simulate, structure_response
from .structure import Accelerometer, BaseMotion, Daq, GapContact, Hit, RigidBody, Setup, Spring, Structure

REPO = Path(__file__).resolve().parents[2]
THESIS_RIG_TOML = REPO / "plugins" / "models" / "rigs" / "thesis-dynamometer.toml"
IDEAL_DAQ = dict(adc_bits=None, aa_family=None, noise_rms_v=0.0)  # the DAQ out of the way


def one_mass(kz=4.0e6, cz=0.0, mass=2.0, **spring) -> Structure:
    """A z oscillator: one spring at the centre of mass acts along z; three springs acting only in
    x and y (at z = +-0.1 m and x = 0.1 m) hold the other five motions without touching z."""
    body = RigidBody("b", mass, np.zeros(3), np.diag([0.01, 0.01, 0.01]))
    lateral = [Spring(f"lateral{i}", "b", np.array(p), np.array([1e7, 1e7, 0.0]), np.zeros(3))
               for i, p in enumerate([(0, 0, 0.1), (0, 0, -0.1), (0.1, 0, 0)])]
    main = Spring("main", "b", np.zeros(3), np.array([0.0, 0.0, kz]), np.array([0.0, 0.0, cz]), **spring)
    return Structure([body], [main, *lateral])


def z_response(structure: Structure, peak=10.0, fs=20000.0, n=4000, oversample=8, duration=0.2e-3):
    model = Model(structure)
    h = 1 / (fs * oversample)
    t = np.arange(n * oversample) * h
    hit = Hit("b", np.zeros(3), np.array([0.0, 0.0, 1.0]), peak, duration)
    F = model.generalized_forces(Setup(structure, [], None, Daq(), [hit]), t, 1e-3)
    q, _, _ = structure_response(model, F, h)
    return t, q[:, 2]


def test_the_generator_imports_nothing_from_odsuite():
    """Independence: only this test file may use odsuite (its readers, to check the writers)."""
    for module in ("structure", "rigsim", "rigs", "writers", "cases"):
        tree = ast.parse((Path(__file__).parent / f"{module}.py").read_text())
        imported = [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
        imported += [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
        assert not [m for m in imported if m.split(".")[0] in ("odsuite", "odsuite_plugins")], module


# ---------------------------------------------------------------------------------------------
# eigenproblems against hand-derived cases


def test_one_dof_frequency_and_the_thesis_bounce_mode():
    # 4e6 N/m on 2 kg: f = sqrt(k/m)/(2 pi) = 225.08 Hz
    f = Model(one_mass()).natural_frequencies()
    assert np.min(np.abs(f - np.sqrt(4.0e6 / 2.0) / (2 * np.pi))) < 1e-9 * 225.1
    # thesis: four symmetric springs under G decouple the bounce mode, sqrt(4 kz / m)
    thesis = Model(thesis_rig().structure).natural_frequencies()
    bounce = np.sqrt(4 * 1.26e6 / 2.714) / (2 * np.pi)
    assert np.min(np.abs(thesis - bounce)) < 1e-9 * bounce
    # the digest: six rigid modes between about 97 and 228 Hz
    assert 96.5 < thesis[0] < 98.0 and 227.0 < thesis[-1] < 228.5


def test_two_dof_car_matches_the_hand_formula_and_thomson():
    # thesis §2.1 (Thomson): m = 100 slug, J = 1600 slug ft^2, k1 = 2400 lb/ft at 4.5 ft behind,
    # k2 = 2600 lb/ft at 5.5 ft ahead of G; bounce z and pitch about y
    m, J, k1, k2, l1, l2 = 100.0, 1600.0, 2400.0, 2600.0, 4.5, 5.5
    car = RigidBody("car", m, np.zeros(3), np.diag([1.0, J, 1.0]))
    springs = [Spring("rear", "car", np.array([-l1, 0, 0]), np.array([0, 0, k1]), np.zeros(3)),
               Spring("front", "car", np.array([l2, 0, 0]), np.array([0, 0, k2]), np.zeros(3))]
    w = 2 * np.pi * Model(Structure([car], springs)).natural_frequencies()
    w = np.sort(w[w > 1e-6])
    # det([[k1 + k2 - m w^2, k2 l2 - k1 l1], [k2 l2 - k1 l1, k1 l1^2 + k2 l2^2 - J w^2]]) = 0
    a, b, c = k1 + k2, k2 * l2 - k1 * l1, k1 * l1 ** 2 + k2 * l2 ** 2
    p, q = a / m + c / J, (a * c - b * b) / (m * J)
    hand = np.sqrt([(p - np.sqrt(p * p - 4 * q)) / 2, (p + np.sqrt(p * p - 4 * q)) / 2])
    np.testing.assert_allclose(w, hand, rtol=1e-10)
    # the published 6.90 and 9.05-9.06 rad/s
    assert abs(w[0] - 6.90) < 0.005 and 9.045 < w[1] < 9.065


# ---------------------------------------------------------------------------------------------
# integrators


def test_lti_response_matches_scipy_lsim():
    rng = np.random.default_rng(7)
    model = Model(thesis_rig().structure)
    A, B = model.state_space()
    h = 1 / 160000
    t = np.arange(3000) * h
    u = rng.standard_normal((t.size, 6)) * np.hanning(t.size)[:, None]
    ours = lti_response(A, B, None, None, u, h)
    _, _, theirs = signal.lsim((A, B, np.eye(12), np.zeros((12, 6))), u, t)
    assert np.max(np.abs(ours - theirs)) < 1e-9 * np.max(np.abs(theirs))
    # a single-input filter runs every column separately: the thesis's 1 kHz anti-aliasing filter
    aa = anti_aliasing(Daq(aa_family="ellip", aa_order=6, aa_cutoff_hz=1000.0))
    ours = lti_response(*aa, u[:, :3], h)
    for k in range(3):
        _, theirs, _ = signal.lsim(aa, u[:, k], t)
        assert np.max(np.abs(ours[:, k] - theirs)) < 1e-9 * np.max(np.abs(theirs))


@pytest.mark.parametrize("oversample, tolerance", [(8, 1e-7), (4, 1e-6)])
def test_rk4_path_matches_the_exact_linear_path(oversample, tolerance):
    # 225 Hz: RK4's global error ~ (w h)^4 = 6e-9 at 8x and 1e-7 at 4x the 20 kHz rate
    linear = one_mass(cz=120.0)
    zero_cubic = one_mass(cz=120.0, cubic=np.zeros(3))  # nonlinear path, no nonlinearity
    assert not zero_cubic.is_linear
    _, exact = z_response(linear, n=300, oversample=oversample)
    _, rk4 = z_response(zero_cubic, n=300, oversample=oversample)
    assert np.max(np.abs(rk4 - exact)) < tolerance * np.max(np.abs(exact))


def _free_vibration(t, z, after):
    """Upward zero crossings (interpolated) and the peaks between them, after time ``after``."""
    z, t = z[t > after], t[t > after]
    i = np.nonzero((z[:-1] < 0) & (z[1:] >= 0))[0]
    crossings = t[i] - z[i] * (t[i + 1] - t[i]) / (z[i + 1] - z[i])
    peaks = np.array([np.max(z[a:b]) for a, b in zip(i[:-1], i[1:])])
    return crossings, peaks


def test_cubic_hardening_follows_the_duffing_backbone():
    k, m = 4.0e6, 2.0
    _, z_lin = z_response(one_mass(kz=k, mass=m), n=400)
    amp = np.max(np.abs(z_lin))
    k3 = 0.3 * k / amp ** 2  # 3/4 k3 A^2 / k = 0.225: a 10.6 % frequency rise
    t, z = z_response(one_mass(kz=k, mass=m, cubic=np.array([0.0, 0.0, k3])), n=400)
    crossings, peaks = _free_vibration(t, z, 1.5e-3)
    f = 1 / np.mean(np.diff(crossings))
    A = np.mean(peaks)
    backbone = np.sqrt(k / m + 0.75 * k3 * A ** 2 / m) / (2 * np.pi)  # first harmonic balance
    assert abs(f / backbone - 1) < 0.005, (f, backbone)
    assert f > 1.08 * np.sqrt(k / m) / (2 * np.pi)


def test_coulomb_friction_decays_by_four_f_over_k_per_cycle():
    k, friction = 4.0e6, 10.0  # N
    t, z = z_response(one_mass(kz=k, friction=np.array([0.0, 0.0, friction]), friction_velocity=1e-5),
                      peak=1000.0, n=500)
    _, peaks = _free_vibration(t, z, 1.5e-3)
    drops = -np.diff(peaks)[:4]
    np.testing.assert_allclose(drops, 4 * friction / k, rtol=0.03)


def test_gap_contact_acts_only_beyond_its_clearance():
    t, free = z_response(one_mass(cz=60.0), n=300)
    amp = np.max(np.abs(free))
    loose = one_mass(cz=60.0)
    loose.contacts.append(GapContact("stop", "b", np.zeros(3), np.array([0, 0, 1.0]), 1.01 * amp, 1e6))
    np.testing.assert_allclose(z_response(loose, n=300)[1], free, atol=1e-7 * amp)
    tight = one_mass(cz=60.0)
    tight.contacts.append(GapContact("stop", "b", np.zeros(3), np.array([0, 0, 1.0]), 0.3 * amp, 1.2e7))
    z = z_response(tight, n=300)[1]
    # the stop adds stiffness: smaller excursions, a shorter period
    assert np.max(np.abs(z)) < 0.8 * amp
    c_free = _free_vibration(t, free, 1.5e-3)[0]
    c_tight = _free_vibration(t, z, 1.5e-3)[0]
    assert np.mean(np.diff(c_tight)) < 0.9 * np.mean(np.diff(c_free))


def test_base_motion_transmissibility():
    k, m, c = 4.0e5, 2.0, 180.0  # 71 Hz, 10 % damping
    w0 = np.sqrt(k / m)
    zeta = c / (2 * np.sqrt(k * m))
    f = 1.4 * w0 / (2 * np.pi)
    s = one_mass(kz=k, cz=c, mass=m)
    s.base_motion = BaseMotion(np.array([0, 0, 1e-5, 0, 0, 0]), f, ramp_s=0.01)
    up = np.array([0.0, 0.0, 1.0])
    accs = [Accelerometer("body", 1, "b", np.zeros(3), up, 0.01),
            Accelerometer("floor", 2, "ground", np.zeros(3), up, 0.01)]
    daq = Daq(sampling_rate=20000.0, n_samples=6000, pre_trigger=0, **IDEAL_DAQ)
    rec = simulate(Setup(s, accs, None, daq, []), np.random.default_rng(0))
    tail = rec.time > 0.2  # 0.2 s = 21 time constants 1/(zeta w0)
    ratio = np.ptp(rec.accelerations[tail, 0]) / np.ptp(rec.accelerations[tail, 1])
    r = 2 * np.pi * f / w0
    closed = np.sqrt((1 + (2 * zeta * r) ** 2) / ((1 - r * r) ** 2 + (2 * zeta * r) ** 2))
    assert abs(ratio / closed - 1) < 2e-3, (ratio, closed)


# ---------------------------------------------------------------------------------------------
# sensors and DAQ


def test_nine_sensors_see_a_rigid_body_padgaonkar():
    """a_P = a_G + alpha x r at every sensor: the digest's Eq. 4.13 recovers alpha from the nine
    signals, both redundant estimates agree, and corner C's acceleration is a_G + alpha x (C - G)."""
    rig = thesis_rig()
    rig.daq = replace(rig.daq, n_samples=1024, **IDEAL_DAQ)
    hit = Hit("platform", np.array([0.03, -0.05, -0.0114]), np.array([0.3, 0.2, 0.93]), 20.0)
    rec = simulate(Setup(rig.structure, rig.accelerometers, None, rig.daq, [hit]), np.random.default_rng(0))
    a = {s.name: rec.accelerations[:, j] for j, s in enumerate(rig.accelerometers)}
    rx, ry, rz = 0.09846, 0.16993, 0.02210
    alpha = rec.qdd[:, 3:6]
    scale = np.max(np.abs(alpha))
    pairs = [((a["z1"] - a["zC"]) / ry, -(a["y3"] - a["yC"]) / rz),
             ((a["x3"] - a["xC"]) / rz, -(a["z2"] - a["zC"]) / rx),
             ((a["y2"] - a["yC"]) / rx, -(a["x1"] - a["xC"]) / ry)]
    for k, (first, second) in enumerate(pairs):
        np.testing.assert_allclose(first, second, atol=1e-9 * scale)  # rigid: the pair agrees
        np.testing.assert_allclose((first + second) / 2, alpha[:, k], atol=1e-9 * scale)
    corner = np.array([-0.0500253, -0.08084058, -0.01139952])
    a_c = rec.qdd[:, :3] + np.cross(alpha, corner)
    np.testing.assert_allclose(np.column_stack([a["xC"], a["yC"], a["zC"]]), a_c,
                               atol=1e-9 * np.max(np.abs(a_c)))


def test_flexible_mode_breaks_the_rigid_redundancy_and_adds_its_frequency():
    case = cases.build_case("flexible-mode", seed=4, n_samples=1024)
    f_flex = case.truth["effect"]["frequency_hz"]
    freqs = Model(case.actual.structure).natural_frequencies()
    top = Model(case.nominal.structure).natural_frequencies().max()
    assert 1.1 * top <= f_flex <= 2000.0
    assert freqs.size == 7 and np.min(np.abs(freqs - f_flex)) < 0.05 * f_flex  # coupled through the springs
    shapes = case.truth["effect"]["shape_at_sensors_m_per_unit"]
    assert max(abs(shapes["xC"][0]), abs(shapes["yC"][1])) > 0.05  # in-plane motion at a sensor
    rig = case.actual
    rig.daq = replace(rig.daq, **IDEAL_DAQ)
    rec = simulate(Setup(rig.structure, rig.accelerometers, None, rig.daq, case.records[0]),
                   np.random.default_rng(0))
    a = {s.name: rec.accelerations[:, j] for j, s in enumerate(rig.accelerometers)}
    mismatch = (a["z1"] - a["zC"]) / 0.16993 + (a["y3"] - a["yC"]) / 0.0221
    assert np.max(np.abs(mismatch)) > 1e-3 * np.max(np.abs(rec.qdd[:, 3]))


def test_scan_skew_delays_each_channel_by_its_scan_slot():
    s = one_mass(cz=1000.0)  # 18 % damping: the record holds the whole response, no leakage
    up = np.array([0.0, 0.0, 1.0])
    accs = [Accelerometer("first", 1, "b", np.zeros(3), up, 0.01),
            Accelerometer("twin", 6, "b", np.zeros(3), up, 0.01)]  # same motion, 5 scan slots later
    skew = 12e-6
    # with the anti-aliasing filter the samples are those of a band-limited signal, so a delay is a
    # pure phase slope; without it aliased hammer content bends the phase by ~0.5 %
    daq = Daq(sampling_rate=20000.0, n_samples=2048, pre_trigger=64, scan_skew_s=skew, adc_bits=None,
              noise_rms_v=0.0, aa_family="butter", aa_order=4, aa_cutoff_hz=1000.0)
    rec = simulate(Setup(s, accs, None, daq, [Hit("b", np.zeros(3), up, 10.0)]), np.random.default_rng(0))
    X1, X6 = np.fft.rfft(rec.volts[:, 1]), np.fft.rfft(rec.volts[:, 6])
    f = np.fft.rfftfreq(2048, 1 / 20000.0)
    band = np.abs(X1) > 0.1 * np.abs(X1).max()
    # v6(t) = v1(t + 5 skew): phase advance 2 pi f 5 skew
    slope = np.polyfit(2 * np.pi * f[band], np.unwrap(np.angle(X6[band] / X1[band])), 1)[0]
    assert abs(slope / (5 * skew) - 1) < 1e-5


def test_sensor_resonance_iepe_and_gain_in_the_steady_state():
    """A sine base motion seen by a ground sensor with a 2 kHz resonance and a 20 Hz IEPE corner:
    volts / acceleration = sign sensitivity (1 + gain_error) |H_res H_iepe| at the drive frequency."""
    f = 900.0
    s = one_mass()
    s.base_motion = BaseMotion(np.array([0, 0, 1e-6, 0, 0, 0]), f, ramp_s=0.005)
    sensor = Accelerometer("floor", 1, "ground", np.array([0.1, 0, 0]), np.array([0, 0, 1.0]), 0.0102,
                           sign=-1.0, gain_error=0.1, resonance_hz=2000.0, resonance_damping=0.05,
                           iepe_corner_hz=20.0)
    daq = Daq(sampling_rate=20000.0, n_samples=5000, pre_trigger=0, **IDEAL_DAQ)
    rec = simulate(Setup(s, [sensor], None, daq, []), np.random.default_rng(0))
    tail = rec.time >= 0.15  # 19 IEPE time constants; the 0.1 s left hold 90 whole periods
    w, wr, wc = 2 * np.pi * f, 2 * np.pi * 2000.0, 2 * np.pi * 20.0
    H = wr ** 2 / (wr ** 2 - w ** 2 + 2j * 0.05 * wr * w) * (1j * w / (1j * w + wc))
    # the fine grid holds the input linear between its points (triangle kernel): the drive
    # frequency passes with sinc^2(f / f_fine), 1.0e-4 short at 900 Hz and 160 kHz
    expected = -0.0102 * 1.1 * H * np.sinc(f / (8 * 20000.0)) ** 2
    fit = np.linalg.lstsq(np.column_stack([np.cos(w * rec.time[tail]), np.sin(w * rec.time[tail])]),
                          np.column_stack([rec.volts[tail, 1], rec.accelerations[tail, 0]]), rcond=None)[0]
    measured = complex(fit[0, 0], -fit[1, 0]) / complex(fit[0, 1], -fit[1, 1])
    assert abs(measured / expected - 1) < 1e-5, (measured, expected)


def test_adc_levels_noise_and_load_cell():
    rig = thesis_rig()
    rig.daq = replace(rig.daq, n_samples=2048, adc_bits=12, noise_rms_v=0.0, adc_range=(-5.0, 5.0))
    setup = Setup(rig.structure, rig.accelerometers, rig.force_sensor, rig.daq, rig.hits[:1])
    rec = simulate(setup, np.random.default_rng(0))
    lsb = 10.0 / 4096
    codes = (rec.volts + 5.0) / lsb
    np.testing.assert_allclose(codes, np.round(codes), atol=1e-9)
    assert np.max(np.abs(rec.volts - rec.clean_volts)) <= lsb / 2 + 1e-12
    # the load cell: its integral over the pulse is the hammer impulse 2 F T / pi (the 1 kHz
    # low-pass keeps the area of a pulse)
    hit = rig.hits[0]
    impulse = np.sum(rec.clean_volts[:, 0]) / rig.daq.sampling_rate / 2.248e-3
    assert abs(impulse / (2 * hit.peak_n * hit.duration_s / np.pi) - 1) < 1e-3
    noisy = simulate(replace(setup, daq=replace(rig.daq, adc_bits=None, noise_rms_v=1e-3)),
                     np.random.default_rng(1))
    residual = noisy.volts - noisy.clean_volts
    assert abs(np.std(residual) / 1e-3 - 1) < 0.02  # 22528 samples: the std is known to ~0.5 %


def test_flicker_noise_rises_as_one_over_f_below_its_corner():
    """The 1/f disturbance's density is the white level's times corner / f: averaged over 16
    channels and Welch segments, each octave's density over the white noise's density follows
    1 + corner / f within 15 % (a real IEPE accelerometer's noise rises so below 100-300 Hz)."""
    from .rigsim import daq_disturbances

    fs, n, corner = 10240.0, 2**15, 100.0
    daq = Daq(sampling_rate=fs, n_samples=n, noise_rms_v=50e-6, flicker_v=50e-6, flicker_corner_hz=corner)
    x = daq_disturbances(daq, np.arange(n) / fs, 16, np.random.default_rng(4))
    f, psd = signal.welch(x, fs, nperseg=4096, axis=0)
    white = (50e-6) ** 2 / (fs / 2)
    for lo in (10.0, 20.0, 40.0, 80.0, 160.0, 320.0, 640.0, 1280.0):
        band = (f >= lo) & (f < 2 * lo)
        expected = np.mean(1 + corner / f[band])
        assert np.mean(psd[band]) / white == pytest.approx(expected, rel=0.15), lo


# ---------------------------------------------------------------------------------------------
# writers against odsuite's readers


@pytest.fixture(scope="module")
def thesis_record():
    rig = thesis_rig()
    rig.daq = replace(rig.daq, n_samples=1024, noise_rms_v=50e-6)
    rec = simulate(Setup(rig.structure, rig.accelerometers, rig.force_sensor, rig.daq, rig.hits[:1]),
                   np.random.default_rng(3))
    return rig, rec


@pytest.mark.parametrize("decimal", [".", ","])
@pytest.mark.parametrize("x_columns", ["One", "No", "Multi"])
@pytest.mark.parametrize("physical", [False, True])
def test_lvm_reads_back_with_odsuite(tmp_path, thesis_record, decimal, x_columns, physical):
    rig, rec = thesis_record
    path = writers.write_lvm(tmp_path / "r.lvm", rec, decimal=decimal, x_columns=x_columns, physical=physical)
    lvm = read_lvm(path)
    expected = rec.volts / rec.scale if physical else rec.volts
    assert lvm.sampling_rate == 20000.0
    assert lvm.channel_names == rec.names
    assert lvm.units == (rec.units if physical else ["V"] * 11)
    # 10 significant digits
    np.testing.assert_allclose(lvm.data, expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max())
    if x_columns != "No":
        np.testing.assert_allclose(lvm.time[:, 0], rec.time, atol=1e-12)
    if physical:  # xC reads negative along +x: the nominal scale carries the sign
        assert rec.scale[2] == pytest.approx(-0.020292)


def test_dat_and_ctr_read_back_with_odsuite(tmp_path, thesis_record):
    rig, rec = thesis_record
    dat = writers.write_dat(tmp_path / "r.DAT", rec)
    ctr = writers.write_ctr(tmp_path / "r.CTR", rec, rig, rig.daq)
    np.testing.assert_array_equal(read_dat(dat, n_channels=11).data, rec.volts)
    si = read_ctr(ctr)
    assert [c.location for c in si.channels][2:5] == ["xC", "yC", "zC"]
    assert si.channels[0].sensitivity == pytest.approx(2.248e-3, rel=1e-12)
    assert si.channels[0].sensor_type.value == 1 and si.channels[5].sensor_type.value == 4
    assert si.channels[5].sensitivity == pytest.approx(0.020088, rel=1e-12) and si.channels[5].invert
    assert si.channels[5].offset_length == rig.daq.pre_trigger
    assert si.rig.nine_channels == list(range(2, 11))
    assert (si.rig.rx, si.rig.ry, si.rig.rz) == pytest.approx((0.09846, 0.16993, 0.0221))


def test_uff58_reads_back_with_odsuite(tmp_path, thesis_record):
    rig, rec = thesis_record
    path = writers.write_uff58(tmp_path / "r.uff", rec, rig)
    functions = read_uff(path).functions
    assert [f.name for f in functions] == rec.names
    by_name = {f.name: f for f in functions}
    np.testing.assert_array_equal(by_name["z2"].data, rec.volts[:, 8] / rec.scale[8])
    assert by_name["z2"].rsp_dir == 3 and by_name["y2"].rsp_node == by_name["z2"].rsp_node
    assert by_name["x1"].rsp_node != by_name["xC"].rsp_node
    assert by_name["force"].unit == "N" and by_name["z2"].x[1] == pytest.approx(5e-5)


def test_rig_toml_is_well_formed_and_matches_the_shipped_thesis_rig(tmp_path):
    rig = thesis_rig()
    doc = tomllib.loads(writers.write_rig_toml(tmp_path / "thesis.toml", rig).read_text())
    assert [s["name"] for s in doc["springs"]] == ["spring1", "spring2", "spring3", "spring4"]
    assert doc["springs"][0]["stiffness"] == [262000.0, 262000.0, 1260000.0]
    assert doc["acquisition"]["anti_aliasing"] == {"family": "butterworth", "order": 4, "cutoff_hz": 1000.0}
    force = [s for s in doc["sensors"] if s["kind"] == "force"]
    assert force == [{"name": "force", "kind": "force", "channel": 0, "sensitivity": 2.248e-3, "sign": 1}]
    # the digest-built rig agrees with the rig file shipped with odsuite, sensor by sensor
    shipped = tomllib.loads(THESIS_RIG_TOML.read_text())
    ours = {s["name"]: s for s in doc["sensors"] if s["kind"] == "accelerometer"}
    assert set(ours) == {s["name"] for s in shipped["sensors"]}
    for s in shipped["sensors"]:
        o = ours[s["name"]]
        assert (o["channel"], o["sign"]) == (s["channel"], s["sign"])
        np.testing.assert_allclose(o["position"], s["position"], atol=1e-12)
        np.testing.assert_allclose(o["axis"], s["axis"])
        assert o["sensitivity"] == pytest.approx(s["sensitivity"], rel=1e-12)
    np.testing.assert_allclose(doc["bodies"][0]["inertia"], shipped["bodies"][0]["inertia"], rtol=1e-12)
    assert doc["bodies"][0]["mass"] == shipped["bodies"][0]["mass"]


def test_two_body_rig_toml_has_triaxial_sensors_and_body_body_springs(tmp_path):
    doc = tomllib.loads(writers.write_rig_toml(tmp_path / "two.toml", two_body_rig()).read_text())
    triax = [s for s in doc["sensors"] if s["kind"] == "triaxial_accelerometer"]
    assert len(triax) == 6 and all(len(s["channels"]) == 3 and len(s["axes"]) == 3 for s in triax)
    assert sorted(c for s in triax for c in s["channels"]) == list(range(1, 19))
    assert {(s["body"], s["other"]) for s in doc["springs"]} == {("base", "ground"), ("machine", "base")}
    assert doc["channel_count"] == 19


def test_two_body_modes_split_into_isolation_and_mount_bands():
    f = Model(two_body_rig().structure).natural_frequencies()
    assert f.size == 12 and 5 < f[0] and f[5] < 40 and 40 < f[6] and f[-1] < 200


# ---------------------------------------------------------------------------------------------
# the case catalogue


@pytest.mark.parametrize("rig", ["thesis", "two-body"])
def test_every_case_builds_reproducibly_within_its_ranges(rig):
    for name in cases.CASES:
        a = cases.build_case(name, seed=11, rig=rig, n_samples=512)
        b = cases.build_case(name, seed=11, rig=rig, n_samples=512)
        ja, jb = (json.dumps(writers.to_jsonable(c.truth_document()), sort_keys=True) for c in (a, b))
        assert ja == jb, name
        effect = a.truth["effect"]
        if effect["kind"] == "stiffness":
            assert 0.05 <= abs(effect["factor"] - 1) <= 0.40
        elif effect["kind"] == "added_mass":
            body = a.nominal.structure.body(effect["body"])
            assert 0.03 <= effect["mass_kg"] / body.mass <= 0.15
        elif effect["kind"] == "sensor_tilt":
            assert 5 <= effect["angle_deg"] <= 40
            assert np.degrees(np.arccos(np.dot(effect["nominal_axis"], effect["true_axis"]))) == \
                pytest.approx(effect["angle_deg"])
        elif effect["kind"] == "scan_skew":
            assert 2e-6 <= effect["skew_per_channel_s"] <= 20e-6
        elif effect["kind"] == "double_hit":
            assert 2e-3 <= effect["delay_s"] <= 10e-3 and all(len(hits) == 2 for hits in a.records)
        elif effect["kind"] == "cubic_hardening":
            levels = effect["force_levels_n"]
            assert 0.5 <= levels[0] and levels[-1] <= 50 and len(a.records) == 5
    draws = {cases.build_case("softer-axis", seed=s, rig=rig).truth["effect"]["factor"] for s in range(5)}
    assert len(draws) == 5  # a range, not one fixed shape


def test_added_mass_keeps_the_total_first_moment():
    case = cases.build_case("added-mass", seed=5, rig="two-body")
    e = case.truth["effect"]
    old = case.nominal.structure.body(e["body"])
    np.testing.assert_allclose(e["new_mass_kg"] * np.asarray(e["new_com_m"]),
                               old.mass * old.com + e["mass_kg"] * np.asarray(e["point_m"]), rtol=1e-12)
    assert Model(case.actual.structure).natural_frequencies()[0] < Model(case.nominal.structure).natural_frequencies()[0]


def test_hardening_series_stiffens_with_force_level():
    """The lowest level responds like the linear rig; the top level deflects less per newton."""
    case = cases.build_case("hardening-series", seed=2, n_samples=600)
    case.records = [case.records[0], case.records[-1]]
    case.actual.daq = replace(case.actual.daq, **IDEAL_DAQ)
    low, high = case.simulate()
    linear = replace(case, actual=case.nominal.copy())
    linear.actual.daq = case.actual.daq
    reference = linear.simulate()[0]
    levels = case.truth["effect"]["force_levels_n"]

    def compliance(rec, level):  # peak z motion of G per newton
        return np.max(np.abs(rec.q[:, 2])) / level

    assert compliance(low, levels[0]) == pytest.approx(compliance(reference, levels[0]), rel=0.01)
    assert compliance(high, levels[-1]) < 0.97 * compliance(low, levels[0])


def test_double_hit_load_cell_holds_both_impulses():
    case = cases.build_case("double-hit", seed=3, n_samples=1024)
    case.records = case.records[:1]
    # the 1 kHz anti-aliasing filter stays: the sum of samples is the area of a band-limited pulse
    case.actual.daq = replace(case.actual.daq, adc_bits=None, noise_rms_v=0.0)
    rec = case.simulate()[0]
    first, second = case.records[0]
    impulse = np.sum(rec.clean_volts[:, 0]) / case.actual.daq.sampling_rate / 2.248e-3
    expected = 2 * (first.peak_n + second.peak_n) * first.duration_s / np.pi  # half-sine areas
    assert impulse == pytest.approx(expected, rel=1e-3)
    assert second.peak_n / first.peak_n == pytest.approx(case.truth["effect"]["second_hit_fraction"])


def test_cli_writes_files_and_truth(tmp_path, capsys):
    assert cases.main([str(tmp_path), "--case", "sensor-gain", "--seed", "1", "--samples", "256",
                       "--decimal", ","]) == 0
    out = capsys.readouterr().out
    assert "Hz" in out and "sensor-gain" in out
    truth = json.loads(next(tmp_path.glob("*truth.json")).read_text())
    assert truth["effect"]["kind"] == "sensor_gain" and len(truth["records"]) == 3
    lvm = read_lvm(next(tmp_path.glob("*r00.lvm")))
    assert lvm.header["Decimal_Separator"] == "," and lvm.data.shape == (256, 11)
    assert cases.main(["--list"]) == 0 and "rattle" in capsys.readouterr().out
    assert cases.main([str(tmp_path), "--case", "nope"]) == 1
    assert "unknown case 'nope'" in capsys.readouterr().err
    assert cases.main([str(tmp_path), "--formats", "lvm,csv"]) == 1
    assert "unknown csv" in capsys.readouterr().err


def test_common_noise_is_the_same_volts_on_every_channel():
    """The ``common`` disturbance: a white noise every channel shares, as loud as each channel's own
    white noise, so two channels' noises correlate by one half."""
    from .rigsim import daq_disturbances

    fs, n = 5120.0, 2**15
    daq = Daq(sampling_rate=fs, n_samples=n, noise_rms_v=50e-6, common_v=50e-6)
    x = daq_disturbances(daq, np.arange(n) / fs, 6, np.random.default_rng(5))
    c = np.corrcoef(x.T)
    off = c[~np.eye(6, dtype=bool)]
    assert np.all(np.abs(off - 0.5) < 0.03), off
    assert np.std(x, axis=0) == pytest.approx(np.full(6, 50e-6 * np.sqrt(2)), rel=0.02)


def test_ambient_vibration_is_a_noise_band_at_its_frequency_on_the_channels_that_feel_it():
    """The ``ambient`` disturbance: on each channel that feels it, a noise band of the set rms
    whose Welch density peaks at ambient_hz (Q 3: half its power within f0 (1 +- 1/(2Q))), apart
    from channel to channel; a channel set to zero (the load cell) holds the white noise alone."""
    import scipy.signal

    from .rigsim import daq_disturbances

    fs, n, f0 = 2048.0, 2**16, 20.0
    level = np.array([0.0, 150e-6, 150e-6, 150e-6])
    daq = Daq(sampling_rate=fs, n_samples=n, noise_rms_v=1e-9, ambient_v=level, ambient_hz=f0, ambient_q=3.0)
    x = daq_disturbances(daq, np.arange(n) / fs, 4, np.random.default_rng(6))
    assert np.std(x[:, 0]) == pytest.approx(1e-9, rel=0.02)
    assert np.std(x[:, 1:], axis=0) == pytest.approx(level[1:], rel=1e-3)
    f, p = scipy.signal.welch(x[:, 1:], fs=fs, nperseg=4096, axis=0)
    assert np.all(np.abs(f[np.argmax(p, axis=0)] - f0) < 2.0), f[np.argmax(p, axis=0)]
    near = (f > f0 * (1 - 1 / 6)) & (f < f0 * (1 + 1 / 6))
    assert np.all(p[near].sum(axis=0) / p.sum(axis=0) > 0.4)
    assert abs(np.corrcoef(x[:, 1], x[:, 2])[0, 1]) < 0.05
