"""Effects without a presupposed shape (missing_mode, channel_delay, scan_skew), the cubic
hardening effect and the simulations they need, against closed forms and scipy."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate

from odsuite.domain.model import Input, Model, Output
from odsuite.analysis.modelrev import RevisionModel
from odsuite.domain.simulation import sampled_later, simulate, simulate_nonlinear

FS = 20_000.0
TOP = Input.force((0.025, -0.040, -0.0114), (0, 0, 1))  # down on the top face


@pytest.fixture
def model(registries, thesis_rig) -> Model:
    return registries.models.get("thesis-dynamometer")(thesis_rig)


def half_sine(n: int, peak: float, start_s: float = 1e-3, width_s: float = 4e-4) -> np.ndarray:
    t = np.arange(n) / FS
    return np.where((t > start_s) & (t < start_s + width_s), peak * np.sin(np.pi * (t - start_s) / width_s), 0.0)


def test_nonlinear_simulation_matches_scipy_dop853(registries, model, monkeypatch):
    hard = registries.effects.get("nonlinear_stiffness").apply(
        model, {"hardening_spring1": 3.0, "hardening_spring3": 1.0})
    st = hard.structure
    assert not st.is_linear and model.structure.is_linear
    n_samples, force = 1500, half_sine(1500, 50.0)
    bf, _ = hard.input_matrices([TOP])
    qdd = simulate_nonlinear(st, bf, force, FS)
    # the same equations by an adaptive 8th-order Runge-Kutta, the force linear between samples
    n = st.n_dof
    E, c = st.cubic_rows()
    t = np.arange(n_samples) / FS

    def accel(tt, x):
        d = E @ x[:n]
        return st.A[n:] @ x + st.Minv @ (bf[:, 0] * np.interp(tt, t, force) - E.T @ (c * d**3))

    sol = scipy.integrate.solve_ivp(lambda tt, x: np.concatenate([x[n:], accel(tt, x)]), (0.0, t[-1]),
                                    np.zeros(2 * n), t_eval=t, method="DOP853", rtol=1e-10, atol=1e-16,
                                    max_step=1 / FS)
    ref = np.array([accel(tt, x) for tt, x in zip(t, sol.y.T)])
    # measured 6.4e-4 of the response where the hardening changes it by 25 %
    assert np.abs(qdd - ref).max() < 1e-3 * np.abs(ref).max()
    # second order: half the step, a quarter of the error
    monkeypatch.setattr("odsuite.domain.simulation.NONLINEAR_STEPS_PER_SAMPLE", 2)
    finer = simulate_nonlinear(st, bf, force, FS)
    assert np.abs(finer - ref).max() < 0.3 * np.abs(qdd - ref).max()
    # the hardening is in the response: the linear model differs by far more than that
    lin = simulate_nonlinear(model.structure, bf, force, FS)
    assert np.abs(lin - ref).max() > 0.05 * np.abs(ref).max()


def test_nonlinear_simulation_without_cubic_terms_is_the_linear_one(model, thesis_rig):
    force = half_sine(2000, 20.0)
    bf, _ = model.input_matrices([TOP])
    qdd = simulate_nonlinear(model.structure, bf, force, FS)
    outputs = [Output.sensor(s) for s in thesis_rig.sensors]
    _, rows = model.output_rows(outputs)
    ref = simulate(model, [TOP], force, FS, outputs, hold="foh")
    assert np.abs(qdd @ rows.T - ref).max() < 1e-9 * np.abs(ref).max()


def test_nonlinear_simulation_of_the_band_limited_force_without_cubic_terms_is_the_linear_one(model, thesis_rig):
    force = half_sine(2000, 20.0)
    bf, _ = model.input_matrices([TOP])
    qdd = simulate_nonlinear(model.structure, bf, force, FS, hold="band")
    outputs = [Output.sensor(s) for s in thesis_rig.sensors]
    _, rows = model.output_rows(outputs)
    ref = simulate(model, [TOP], force, FS, outputs, hold="band")
    assert np.abs(qdd @ rows.T - ref).max() < 1e-9 * np.abs(ref).max()
    # and differs from the first-order hold's (the hammer pulse has content near the band's top)
    foh = simulate(model, [TOP], force, FS, outputs, hold="foh")
    assert np.abs(foh - ref).max() > 1e-4 * np.abs(ref).max()


def test_hardening_raises_the_response_frequency_with_the_force_level(registries, model):
    # a Duffing oscillator's backbone: the bounce frequency rises with amplitude
    hard = registries.effects.get("nonlinear_stiffness").apply(
        model, {f"hardening_spring{i}": 200.0 for i in range(1, 5)})
    bf, _ = hard.input_matrices([TOP])
    peaks = []
    for level in (1.0, 100.0):
        qdd = simulate_nonlinear(hard.structure, bf, half_sine(8192, level), FS)
        spec = np.abs(np.fft.rfft(qdd[:, 2] * np.hanning(8192)))
        peaks.append(np.fft.rfftfreq(8192, 1 / FS)[np.argmax(spec)])
    linear = model.modes().frequency_hz
    assert peaks[0] == pytest.approx(linear[np.argmin(np.abs(linear - peaks[0]))], abs=3.0)
    assert peaks[1] > peaks[0] + 5.0


@pytest.mark.parametrize("n", [4096, 2141])
def test_sampled_later_shifts_a_band_limited_signal(n):
    # 2141 samples: twice them have a large prime factor, so the transform pads further (to 4320)
    from odsuite.domain.simulation import delay_length

    assert delay_length(n) >= 2 * n
    assert delay_length(2141) == 4320 and delay_length(4096) == 8192
    t = np.arange(n) / FS

    def pulse(tt):  # a Gaussian-windowed 800 Hz burst: band-limited far below Nyquist
        return np.exp(-(((tt - 0.05) / 0.005) ** 2)) * np.sin(2 * np.pi * 800 * tt)

    delays = [0.0, 7e-6, 63e-6, -20e-6]
    y = sampled_later(np.column_stack([pulse(t)] * 4), FS, delays)
    for k, tau in enumerate(delays):
        assert np.abs(y[:, k] - pulse(t + tau)).max() < 1e-9


def test_sampled_later_repeated_and_unordered_delays_shift_each_column_by_its_own():
    """A channel's phase shift is computed once per distinct delay (a search sets every channel to
    the same start): each column equal to the bit to that column shifted alone, whatever the
    delays' order or repeats, and to the burst shifted by its own delay."""
    from odsuite.domain import simulation

    n = 4096
    t = np.arange(n) / FS
    rng = np.random.default_rng(3)
    y = np.column_stack([np.exp(-(((t - 0.05) / 0.005) ** 2)) * np.sin(2 * np.pi * f * t) for f in (800, 650, 900,
                                                                                                      700, 820)])
    y += 1e-3 * rng.standard_normal(y.shape) * np.exp(-(((t - 0.05) / 0.01) ** 2))[:, None]
    for delays in ([20e-6] * 5, [63e-6, 7e-6, 63e-6, -20e-6, 7e-6], [5e-6, 0.0, -5e-6, 0.0, 5e-6]):
        simulation._PHASES.clear()
        got = sampled_later(y, FS, delays)
        spectrum = np.fft.rfft(y, n=simulation.delay_length(n), axis=0)
        for k, tau in enumerate(delays):
            simulation._PHASES.clear()
            alone = sampled_later(y[:, [k]], FS, [tau])
            np.testing.assert_array_equal(got[:, k], alone[:, 0])
            np.testing.assert_array_equal(sampled_later(y, FS, delays, spectrum=spectrum)[:, k], alone[:, 0])
        # against each column's own phase shift computed here (the transforms of several columns
        # at once round otherwise: 2e-16 of a peak near 1)
        w = 2 * np.pi * np.fft.rfftfreq(simulation.delay_length(n), 1.0 / FS)
        for k, tau in enumerate(delays):
            m = simulation.delay_length(n)
            want = np.fft.irfft(spectrum[:, k] * np.exp(1j * w * tau), n=m)[:n] if tau else y[:, k]
            np.testing.assert_allclose(got[:, k], want, rtol=0, atol=1e-14)


def test_scan_skew_delays_channel_k_by_k_steps_after_the_force(registries, model, thesis_rig):
    skewed = registries.effects.get("scan_skew").apply(model, {"skew_s": 5e-6})
    force = thesis_rig.force_channel
    for s in thesis_rig.sensors:
        if s.quantity == "acceleration":
            assert skewed.chain.delay[s.name] == pytest.approx((s.channel - force) * 5e-6, rel=1e-12)
    one = registries.effects.get("channel_delay").apply(model, {"zC_delay": 40e-6})
    assert one.chain.delay["zC"] == 40e-6 and one.chain.delay["xC"] == 0.0


def test_missing_mode_adds_one_resonance_with_its_participations(registries, model, thesis_rig):
    eff = registries.effects.get("missing_mode")
    values = {"frequency_hz": 640.0, "damping_ratio": 0.02, "phi_zC": 0.7, "phi_x1": -0.3, "phi_force": 0.5}
    moved = eff.apply(model, values)
    assert len(moved.modes()) == len(model.modes()) + 1
    # the added receptance at a sensor: phi_j phi_F (-w^2) / (wn^2 - w^2 + 2 j zeta wn w), closed form
    freqs = np.array([200.0, 600.0, 640.0, 900.0])
    outputs = [Output.sensor(thesis_rig.sensor(n)) for n in ("zC", "x1", "y2")]
    added = moved.transfer([TOP], outputs, freqs) - model.transfer([TOP], outputs, freqs)
    w, wn = 2 * np.pi * freqs, 2 * np.pi * 640.0
    mode = -w**2 / (wn**2 - w**2 + 2j * 0.02 * wn * w)
    assert np.allclose(added[:, 0, 0], 0.7 * 0.5 * mode, rtol=1e-9)
    assert np.allclose(added[:, 1, 0], -0.3 * 0.5 * mode, rtol=1e-9)
    assert np.abs(added[:, 2, 0]).max() < 1e-12 * np.abs(added[:, 0, 0]).max()


def test_coupled_mode_is_joined_to_the_rigid_motion_by_the_springs_it_moves(registries, model):
    """A mode moving spring1's end by phi along z: the spring couples it to the rigid coordinates
    by k_z phi (the rigid motion of the spring's point along z) in stiffness and c_z phi in damping
    (a spring's energy, written out by hand); the mode's own terms are its frequency and damping
    with the rigid coordinates held, the spring ends included."""
    eff = registries.effects.get("coupled_mode")
    phi, f, zeta = 0.4, 700.0, 0.02
    moved = eff.apply(model, {"frequency_hz": f, "damping_ratio": zeta, "phi_zC": 0.7, "phi_force": 0.5,
                              "phi_spring1_z": phi})
    spring = next(s for s in model.springs if s.name == "spring1")
    body = model.bodies[0]
    rx, ry, _ = np.asarray(spring.point, float) - body.com
    # z displacement of the spring's point per rigid coordinate (x, y, z, rx, ry, rz)
    row = np.array([0.0, 0.0, 1.0, ry, -rx, 0.0])
    kz, cz = np.diag(spring.matrix("stiffness"))[2], np.diag(spring.matrix("damping"))[2]
    K, C = moved.K, moved.C
    wn = 2 * np.pi * f
    assert K[-1, -1] == pytest.approx(wn**2, rel=1e-12)
    assert np.allclose(K[:6, -1], kz * phi * row, rtol=1e-12, atol=1e-9 * kz)
    assert C[-1, -1] == pytest.approx(2 * zeta * wn, rel=1e-12)
    assert np.allclose(C[:6, -1], cz * phi * row, rtol=1e-12, atol=1e-9 * cz)
    assert np.allclose(K[:6, :6], model.K) and np.allclose(moved.M[:6, -1], 0.0)
    # with the spring ends at rest it is missing_mode's uncoupled mode
    still = eff.apply(model, {"frequency_hz": f, "damping_ratio": zeta, "phi_zC": 0.7, "phi_force": 0.5})
    plain = registries.effects.get("missing_mode").apply(
        model, {"frequency_hz": f, "damping_ratio": zeta, "phi_zC": 0.7, "phi_force": 0.5})
    assert np.array_equal(still.K, plain.K) and np.array_equal(still.C, plain.C)


def test_missing_mode_stored_as_a_revision_predicts_like_the_fit(registries, model):
    """A revision applies the shared values, then each experiment's force participation: the same
    single mode as applying everything at once."""
    eff = registries.effects.get("missing_mode")
    shared = {"frequency_hz": 640.0, "damping_ratio": 0.02, "phi_zC": 0.7, "phi_z2": -0.4}
    revision = RevisionModel(eff.apply(model, shared), [(eff, {"r0": {"phi_force": 0.5}})])
    stored = revision.for_experiment("r0")
    direct = eff.apply(eff.apply(model, shared), {**shared, "phi_force": 0.5})
    assert len(stored.structure.flexible_modes) == len(direct.structure.flexible_modes) == 1
    outputs = [Output.sensor(s) for s in model.sensors if s.quantity == "acceleration"]
    h1 = stored.transfer([TOP], outputs, [640.0])
    h2 = direct.transfer([TOP], outputs, [640.0])
    assert np.allclose(h1, h2, rtol=1e-12)


def test_rank_one_participations_recovered_exactly():
    from odsuite_plugins.models.data_effects import _rank_one

    rng = np.random.default_rng(3)
    phi, c = rng.normal(size=9), np.array([0.8, -0.3, 1.2])
    N = rng.uniform(1.0, 5.0, (3, 9))
    N[1, 4:] = 0.0  # sensors an experiment's mode response never reaches
    R = N * np.outer(c, phi)  # <r, G> of noise-free data
    phi_fit, c_fit = _rank_one(R, N)
    assert np.allclose(np.outer(c_fit, phi_fit), np.outer(c, phi), rtol=1e-9, atol=1e-12)


def _rank_one_every_sweep(R, N, sweeps):
    """_rank_one as first written, every sweep run (the reference for its early stop): its start
    (no sweep), then ``sweeps`` sweeps. The tables here have no entry it masks out."""
    import odsuite_plugins.models.data_effects as de

    saved, de.RANK_ONE_SWEEPS = de.RANK_ONE_SWEEPS, 0
    try:
        phi, c = de._rank_one(R, N)
    finally:
        de.RANK_ONE_SWEEPS = saved
    for _ in range(sweeps):
        phi, c = de._rank_one_sweep(R, N, c)
    return phi, c


def test_rank_one_stops_where_a_sweep_repeats_with_every_sweeps_numbers(monkeypatch):
    """The alternating sweeps stop once one leaves c as it was (each is a function of c alone):
    the numbers of every sweep run, to the bit, on tables that reach that point early and on noisy
    ones that may not; and a table that reaches it is not swept on (a million sweeps allowed)."""
    import time

    import odsuite_plugins.models.data_effects as de

    rng = np.random.default_rng(5)
    tables = []
    for k in range(40):
        phi, c = rng.normal(size=18), rng.normal(size=3)
        N = rng.uniform(1.0, 5.0, (3, 18))
        noise = (0.0, 1e-3, 0.3)[k % 3]
        tables.append((N * np.outer(c, phi) + noise * rng.normal(size=N.shape), N))
    for R, N in tables:
        got = de._rank_one(R, N)
        want = _rank_one_every_sweep(R, N, de.RANK_ONE_SWEEPS)
        assert all(g.tobytes() == w.tobytes() for g, w in zip(got, want))
    # a table whose sweeps repeat within RANK_ONE_SWEEPS (noisy tables among them)
    R, N = next((R, N) for R, N in tables if _rank_one_every_sweep(R, N, de.RANK_ONE_SWEEPS - 1)[1].tobytes()
                == _rank_one_every_sweep(R, N, de.RANK_ONE_SWEEPS)[1].tobytes())
    monkeypatch.setattr(de, "RANK_ONE_SWEEPS", 10**6)
    c0 = time.process_time()
    got = de._rank_one(R, N)
    assert time.process_time() - c0 < 2.0  # every sweep: about 30 s
    assert all(g.tobytes() == w.tobytes() for g, w in zip(got, _rank_one_every_sweep(R, N, 200)))


def test_a_missing_modes_response_alone_is_the_whole_structures_change(tmp_path, registries):
    """missing_mode's search predicts only the added mode (its coordinate is uncoupled): equal to
    the whole structure simulated with and without it, through every part of the chain that a
    sensor's row or signal passes (tilt, gain, position, delay, sensor dynamics, the front end,
    the force's gain and point), on the thesis rig's one body."""
    import sys
    from pathlib import Path

    from dataclasses import replace

    from odsuite.domain.model import AnalogFilter, FlexibleMode
    from odsuite.analysis.modelrev import revision_model
    from odsuite.analysis.prediction import flexible_mode_change, predict, prepare
    from odsuite.store.project import open_project

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "core"))
    from hidden_effects import make_project

    path = make_project(tmp_path / "p.odsp", n_samples=2048, scenarios=("T1", "T6"))
    eff = registries.effects
    with open_project(path) as p:
        exps = prepare(p)
        model = revision_model(p).shared
        sensors = [s.name for s in p.rig.sensors if s.quantity == "acceleration"]
        a, b = sensors[0], sensors[3]
        model = eff.get("sensor_orientation").apply(model, {f"{a}_tilt_a": 0.3, f"{b}_tilt_b": -0.2})
        model = eff.get("sensor_gain").apply(model, {f"{a}_gain": 1.2})
        model = eff.get("sensor_position").apply(model, {f"{b}_dx": 0.01})
        model = eff.get("channel_delay").apply(model, {f"{b}_delay": 40e-6})
        model = eff.get("force_gain").apply(model, {"gain": 0.9})
        model = eff.get("impact_location").apply(model, {"dx": 0.005, "dy": -0.004, "dz": 0.0})
        model = eff.get("sensor_dynamics").apply(model, {"highpass_hz": 2.0, "resonance_period_s": 1 / 3000.0})
        # a front end as a rig's [acquisition] declares one: a 4-pole anti-aliasing filter at 5 kHz
        aa = AnalogFilter((), tuple(2 * np.pi * 5000.0 * np.exp(1j * np.pi * (0.5 + (2 * k + 1) / 8)) for k in range(4)),
                          (2 * np.pi * 5000.0) ** 4)
        model = model.replace(chain=replace(model.chain, front_end=aa))
        table = {s: 0.5 + 0.1 * k * (-1) ** k for k, s in enumerate(sensors)} | {"force": -0.7}
        mode = FlexibleMode("extra", model.bodies[0].name, 731.0, 0.03, lambda point, direction, tag: table.get(tag, 0.0))
        with_mode = model.replace(structure=type(model.structure)(
            model.structure.bodies, model.structure.springs, model.structure.flexible_modes + (mode,)))
        for e in exps:
            whole = predict(with_mode, e) - predict(model, e)
            alone = flexible_mode_change(model, e, mode)
            assert np.abs(whole).max() > 1e-3 * np.abs(e.measured).max()  # the mode is seen
            np.testing.assert_allclose(alone, whole, rtol=0, atol=1e-9 * np.abs(whole).max())


def test_mounted_mode_carries_its_parts_mass_with_the_body(registries, model):
    """A 50 g part on a mount soft along d, carrying the triaxial sensors at C: in the relative
    coordinate r (the part's motion along d beyond the body's at C), its kinetic energy
    1/2 m |B x' + d r'|^2 gives M = [[M_body + m B'B, m B'd], [m d'B, m]] (B: the rigid displacement
    of C, written out by hand). mounted_mode with share 1 and the sensors' participations d.a/sqrt(m)
    is that system with q = sqrt(m) r."""
    eff = registries.effects.get("mounted_mode")
    sensors = [s for s in model.sensors if s.name in ("xC", "yC", "zC")]
    tag = "_".join(s.name for s in sensors)
    m, f = 0.05, 900.0
    d = np.array([0.6, 0.0, 0.8])
    phi = {f"phi_{s.name}": float(d @ (s.axis / np.linalg.norm(s.axis))) / np.sqrt(m) for s in sensors}
    moved = eff.apply(model, {"frequency_hz": f, "damping_ratio": 0.02, **phi, f"part_{tag}": 1.0})
    rx, ry, rz = np.asarray(sensors[0].position, float) - model.bodies[0].com
    B = np.array([[1.0, 0, 0, 0, rz, -ry], [0, 1.0, 0, -rz, 0, rx], [0, 0, 1.0, ry, -rx, 0]])
    M = moved.M
    assert np.allclose(M[:6, :6], model.M + m * B.T @ B, rtol=1e-12, atol=1e-12)
    assert np.allclose(M[:6, -1], np.sqrt(m) * B.T @ d, rtol=1e-12, atol=1e-12)
    assert np.allclose(M[-1, :6], M[:6, -1]) and M[-1, -1] == 1.0
    assert moved.K[-1, -1] == pytest.approx((2 * np.pi * f) ** 2, rel=1e-12)
    assert np.allclose(moved.K[:6, -1], 0.0)
    # the part is not where no share is given: missing_mode's uncoupled mode
    plain = registries.effects.get("missing_mode").apply(model, {"frequency_hz": f, "damping_ratio": 0.02, **phi})
    assert np.array_equal(eff.apply(model, {"frequency_hz": f, "damping_ratio": 0.02, **phi}).M, plain.M)


def test_two_missing_modes_stored_in_a_revision_keep_their_own_force_participations(registries, model):
    """A structure may lack two modes: missing_mode added twice. The revision applies each entry's
    hit participation with that entry's shared values, so each lands on its own mode (by the
    entry's frequency), as applying both modes with their participations at once."""
    from odsuite.analysis.modelrev import apply_effects, instance_names

    eff = registries.effects.get("missing_mode")
    first = {"frequency_hz": 640.0, "damping_ratio": 0.02, "phi_zC": 0.7, "phi_z2": -0.4}
    second = {"frequency_hz": 910.0, "damping_ratio": 0.03, "phi_zC": -0.2, "phi_x1": 0.6}
    entries = [{"effect": "missing_mode", "values": first, "per_experiment": {"r0": {"phi_force": 0.5}}},
               {"effect": "missing_mode", "values": second, "per_experiment": {"r0": {"phi_force": -0.8}}}]
    stored = apply_effects(model, entries, registries=registries).for_experiment("r0")
    direct = eff.apply(eff.apply(model, {**first, "phi_force": 0.5}), {**second, "phi_force": -0.8})
    assert len(stored.structure.flexible_modes) == 2
    forces = sorted(f.shape.table["force"] for f in stored.structure.flexible_modes)
    assert forces == [-0.8, 0.5]
    outputs = [Output.sensor(s) for s in model.sensors if s.quantity == "acceleration"]
    freqs = [300.0, 640.0, 910.0]
    assert np.allclose(stored.transfer([TOP], outputs, freqs), direct.transfer([TOP], outputs, freqs), rtol=1e-12)
    assert instance_names(entries) == ["missing_mode", "missing_mode#2"]
