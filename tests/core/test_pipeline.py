"""Chains built from Table E.2, chunked execution, and process_experiment on a project."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.integrate
import scipy.signal

from odsuite.processing.chain_spec import build_chain, chain_for_channel, channel_chain_spec
from odsuite.domain.errors import ConfigError
from odsuite.processing.executor import run_array
from odsuite.processing.pipeline import process_experiment
from odsuite.contracts.steps import Tap
from odsuite.domain.systeminfo import (
    ChannelInfo,
    FilterType,
    Integration,
    SensorType,
    Systeminfo,
)

def _installed_steps():
    """The installed plugins' processing steps (chains name them)."""
    from odsuite.contracts.plugins import registries

    return registries().processing_steps


FS = 20_000.0
DT = 1 / FS
TABLE_E3 = ChannelInfo(sensor_type=SensorType.ACCELEROMETER, sensitivity=0.020292, integration=Integration.DOUBLE,
                       filter_type=FilterType.HIGHPASS, filter_order=8, sampling_rate=FS, cutoff_high=10_000.0,
                       cutoff_low=20.0, ripple_db=0.1, attenuation_db=60.0, filters_on=3, invert=True,
                       offset_start=0, offset_length=400, daq_gain=10.0)


def _eq45(x):
    xp = np.concatenate([[0.0], x, [0.0]])
    return np.cumsum(xp[:-2] + 4 * xp[1:-1] + xp[2:]) * DT / 6


def _close(a, b, rel=1e-12):
    np.testing.assert_allclose(a, b, rtol=0, atol=rel * np.abs(b).max())


def test_table_e3_chain_equals_the_thesis_procedure():
    # Eq. 4.3, invert, offset, filter 1 (Eq. 4.4), Eq. 4.5, filter 2 (Eq. 4.6), Eq. 4.7
    v = np.random.default_rng(5).standard_normal(8000) * 0.05 + 0.01
    out = chain_for_channel(TABLE_E3, registry=_installed_steps()).run(v)
    sos = scipy.signal.ellip(8, 0.1, 60.0, 20.0, "highpass", fs=FS, output="sos")
    x1 = -v / (0.020292 * 10.0)
    x1 = x1 - x1[:400].mean()
    x2 = scipy.signal.sosfilt(sos, x1)
    x3 = _eq45(x2)
    x5 = _eq45(scipy.signal.sosfilt(sos, x3))
    _close(out["acceleration"], x2)
    # the 20 Hz high-pass poles sit within 2e-3 of z = 1: rounding in another order grows ~1e4 times
    _close(out["velocity"], scipy.signal.sosfilt(sos, x3), rel=1e-9)
    _close(out["displacement"], x5, rel=1e-9)


@pytest.mark.parametrize("integration,bits,expected", [
    (Integration.DOUBLE, 3, ["f", "acceleration", "int", "f", "velocity", "int", "displacement"]),
    (Integration.DOUBLE, 5, ["f", "acceleration", "int", "velocity", "int", "f", "displacement"]),
    (Integration.DOUBLE, 16, ["f", "acceleration", "int", "f", "velocity", "int", "f", "displacement"]),
    (Integration.SINGLE, 7, ["f", "acceleration", "int", "f", "f", "velocity"]),
    (Integration.SINGLE, 2, ["acceleration", "int", "f", "velocity"]),
    (Integration.NONE, 6, ["f", "f", "acceleration"]),
])
def test_chain_order_and_bitmask(integration, bits, expected):
    spec = channel_chain_spec(replace(TABLE_E3, integration=integration, filters_on=bits))
    assert [s["step"] for s in spec[:3]] == ["convert", "invert", "offset"]
    short = [{"iir": "f", "integrate": "int"}.get(s.get("step"), s.get("tap")) for s in spec[3:]]
    assert short == expected


def test_micro_units_and_unknown_step(registries):
    ch = replace(TABLE_E3, micro_units=True, filters_on=0, offset_length=0, integration=Integration.NONE)
    out = chain_for_channel(ch, registry=registries.processing_steps).run(np.array([0.2, -0.1]))
    np.testing.assert_allclose(out["acceleration"], -np.array([0.2, -0.1]) / 0.20292 * 1e6)
    with pytest.raises(ConfigError, match=r"chain\[1\]: unknown processing step 'smooth' \(known: .*integrate"):
        build_chain([{"step": "invert"}, {"step": "smooth"}], fs=FS, registry=registries.processing_steps)
    with pytest.raises(ConfigError, match="'iir'.*unexpected keyword argument 'cutof'"):
        build_chain([{"step": "iir", "cutof": 3}], fs=FS, registry=registries.processing_steps)


def test_a_labs_own_step_by_name(registries):
    from odsuite.contracts.steps import Step

    class Clip(Step):
        def __init__(self, limit):
            self.limit = limit

        def process(self, chunk, state):
            return np.clip(chunk, -self.limit, self.limit), state

    registries.processing_steps.add("clip", lambda fs, limit: Clip(limit))
    chain = build_chain([{"step": "clip", "limit": 1.0}, {"step": "integrate", "rule": "trapezoid"}],
                        fs=FS, registry=registries.processing_steps)
    x = np.linspace(-3, 3, 101)
    _close(chain.run(x)["output"], scipy.integrate.cumulative_trapezoid(np.clip(x, -1, 1), dx=DT, initial=0))


@pytest.mark.parametrize("chunk", [1, 7, 997, 4096, 100_000])
def test_chunked_equals_in_memory(chunk):
    rng = np.random.default_rng(6)
    n = 3000 if chunk == 1 else 30_000
    raw = rng.standard_normal((n, 3)) * 0.05
    chains = [chain_for_channel(TABLE_E3, registry=_installed_steps()),
              chain_for_channel(replace(TABLE_E3, zero_phase=True, offset_start=250, offset_length=1200), registry=_installed_steps()),
              build_chain([{"step": "moving-average", "length": 50}, {"step": "integrate", "rule": "trapezoid"},
                           {"tap": "velocity"}], fs=FS, registry=_installed_steps())]
    got = run_array(chains, raw, chunk=chunk)
    for c, chain in enumerate(chains):
        ref = chain.run(raw[:, c])
        assert set(got[c]) == set(ref)
        for tap in ref:
            _close(got[c][tap], ref[tap])


def _clip_chain(registries):
    from odsuite.contracts.steps import Step

    class Clip(Step):  # a lab's step written for one channel
        def process(self, chunk, state):
            return np.clip(chunk, -1.0, 1.0), state

    registries.processing_steps.add("clip", lambda fs: Clip())
    return build_chain([{"step": "clip"}, {"step": "integrate"}], fs=FS, registry=registries.processing_steps)


@pytest.mark.parametrize("chunk", [613, 100_000])
def test_channels_with_the_same_chain_run_as_one_block(registries, chunk):
    # identical chains run together (channels x samples); each column still equals its own chain
    # run alone, in any order and mixed with chains that run alone (another gain, a lab's 1-D step)
    from odsuite.processing.executor import _groups

    zp = replace(TABLE_E3, zero_phase=True, offset_start=250, offset_length=1200)
    chains = [chain_for_channel(TABLE_E3, registry=_installed_steps()), chain_for_channel(zp, registry=_installed_steps()), chain_for_channel(TABLE_E3, registry=_installed_steps()),
              _clip_chain(registries), chain_for_channel(replace(TABLE_E3, daq_gain=5.0), registry=_installed_steps()),
              chain_for_channel(zp, registry=_installed_steps()), chain_for_channel(TABLE_E3, registry=_installed_steps())]
    assert _groups(chains) == [[0, 2, 6], [1, 5], [3], [4]]
    raw = np.random.default_rng(9).standard_normal((20_000, len(chains))) * 0.05 + 0.01
    got = run_array(chains, raw, chunk=chunk)
    for c, chain in enumerate(chains):
        ref = chain.run(raw[:, c])
        assert set(got[c]) == set(ref)
        for tap in ref:
            np.testing.assert_array_equal(got[c][tap], ref[tap])
    # the same numbers from the steps applied one after the other with scipy (as in the first test)
    sos = scipy.signal.ellip(8, 0.1, 60.0, 20.0, "highpass", fs=FS, output="sos")
    for c, gain in ((6, 10.0), (4, 5.0)):
        x1 = -raw[:, c] / (0.020292 * gain)
        acc = scipy.signal.sosfilt(sos, x1 - x1[:400].mean())
        _close(got[c]["acceleration"], acc)
        _close(got[c]["displacement"], _eq45(scipy.signal.sosfilt(sos, _eq45(acc))), rel=1e-9)


def test_threads_equal_one_thread(registries):
    zp = replace(TABLE_E3, zero_phase=True, offset_start=250, offset_length=1200)
    chains = ([chain_for_channel(TABLE_E3, registry=_installed_steps()) for _ in range(5)] + [chain_for_channel(replace(TABLE_E3, invert=False), registry=_installed_steps())]
              + [chain_for_channel(zp, registry=_installed_steps()), _clip_chain(registries), chain_for_channel(zp, registry=_installed_steps())])
    raw = np.random.default_rng(10).standard_normal((9000, len(chains))) * 0.05
    raw[:, 5] = raw[:, 0]
    one = run_array(chains, raw, chunk=2048)
    for workers in (2, 3):
        many = run_array(chains, raw, workers=workers, chunk=2048)
        for a, b in zip(one, many):
            assert set(a) == set(b)
            for tap in a:
                np.testing.assert_array_equal(a[tap], b[tap])
    # IEEE arithmetic is symmetric in sign: the uninverted channel is exactly the negative
    np.testing.assert_array_equal(one[5]["velocity"], -one[0]["velocity"])


@pytest.mark.parametrize("workers", [1, 2])
def test_targets_mixing_groups_get_whole_rows(workers):
    # one dataset whose columns come from different groups in scrambled order, and taps that lag
    # their inputs (Eq. 4.5) or hold them back over several chunks (an offset window late in the
    # record): written in whole rows, in order, equal to each chain alone
    from odsuite.processing.executor import run_chains

    chains = [chain_for_channel(TABLE_E3, registry=_installed_steps()) for _ in range(4)] + [chain_for_channel(replace(TABLE_E3, daq_gain=2.0), registry=_installed_steps()),
                                                                chain_for_channel(replace(TABLE_E3, offset_start=5000), registry=_installed_steps())]
    raw = np.random.default_rng(11).standard_normal((7000, len(chains))) * 0.05
    order = [3, 5, 4, 0, 2, 1]
    targets = {"d": [(c, "displacement") for c in order], "a": [(4, "acceleration"), (1, "velocity")]}
    out = {name: np.full((7000, len(cols)), np.nan) for name, cols in targets.items()}
    starts = {name: [] for name in targets}

    def write(name, start, block):
        starts[name].append((start, block.shape[0]))
        out[name][start:start + block.shape[0]] = block

    run_chains(chains, 7000, lambda a, b: raw[a:b], targets, write, chunk=1500, workers=workers)
    for name, got in starts.items():  # consecutive rows, each once
        assert [a for a, _ in got] == list(np.cumsum([0] + [k for _, k in got[:-1]]))
        assert sum(k for _, k in got) == 7000
    ref = run_array(chains, raw)
    for j, c in enumerate(order):
        np.testing.assert_array_equal(out["d"][:, j], ref[c]["displacement"])
    np.testing.assert_array_equal(out["a"][:, 0], ref[4]["acceleration"])
    np.testing.assert_array_equal(out["a"][:, 1], ref[1]["velocity"])


def test_zero_phase_chain_is_sosfiltfilt_between_integrations():
    ch = replace(TABLE_E3, zero_phase=True, integration_rule="trapezoid")
    v = np.random.default_rng(7).standard_normal(6000) * 0.05
    out = run_array([chain_for_channel(ch, registry=_installed_steps())], v[:, None], chunk=613)[0]
    sos = scipy.signal.ellip(8, 0.1, 60.0, 20.0, "highpass", fs=FS, output="sos")
    x1 = -v / 0.20292
    x1 -= x1[:400].mean()
    acc = scipy.signal.sosfiltfilt(sos, x1)
    vel = scipy.signal.sosfiltfilt(sos, scipy.integrate.cumulative_trapezoid(acc, dx=DT, initial=0))
    _close(out["acceleration"], acc, rel=1e-10)  # sosfiltfilt's ill-conditioned 20 Hz poles, see above
    _close(out["velocity"], vel, rel=1e-10)
    _close(out["displacement"], scipy.integrate.cumulative_trapezoid(vel, dx=DT, initial=0), rel=1e-9)


def test_chain_ends_in_a_tap():
    chain = build_chain([{"step": "micro"}], fs=FS, registry=_installed_steps())
    assert isinstance(chain.items[-1], Tap) and chain.taps == ["output"]


def test_a_chain_through_a_tap_gives_the_same_samples_there():
    # compare's measured side needs the acceleration stage only: the chain cut after its tap
    v = np.random.default_rng(8).standard_normal(6000) * 0.05
    sos = scipy.signal.ellip(8, 0.1, 60.0, 20.0, "highpass", fs=FS, output="sos")
    for ch in (TABLE_E3, replace(TABLE_E3, zero_phase=True)):
        chain = chain_for_channel(ch, registry=_installed_steps())
        cut = chain.through("acceleration")
        assert cut.taps == ["acceleration"] and len(cut.items) < len(chain.items)
        np.testing.assert_array_equal(cut.run(v)["acceleration"], chain.run(v)["acceleration"])
        if not ch.zero_phase:
            x1 = -v / 0.20292
            _close(cut.run(v)["acceleration"], scipy.signal.sosfilt(sos, x1 - x1[:400].mean()))
        assert chain.through("no such tap") is chain


def _pulse_project(tmp_path, thesis_rig, n=4000, **channel_changes):
    """A project whose accelerometers read an exact rigid-body pulse of the platform (sensor
    signals from odsuite.domain.rigidbody, through each channel's sign, sensitivity and gain)."""
    from odsuite.contracts.daq import rig_systeminfo
    from odsuite.store.project import Excitation, create_project
    from odsuite.domain.rigidbody import sensor_signals

    si = rig_systeminfo(thesis_rig, FS)
    si = Systeminfo([replace(c, **channel_changes) for c in si.channels], si.rig)
    body = next(b for b in thesis_rig.bodies if b.nine_sensor_set is not None)
    t = np.arange(n) * DT
    T0, T1 = 0.02, 0.12
    u = np.clip((t - T0) / (T1 - T0), 0, 1)
    k = np.pi / (T1 - T0)
    sn, cs = np.sin(np.pi * u), np.cos(np.pi * u)
    amp = np.array([1e-5, -2e-5, 3e-5, 1e-4, -2e-4, 1.5e-4])
    d = (sn**4)[:, None] * amp
    acc = sensor_signals(thesis_rig, body, d, "acceleration", d_g_dot=(4 * sn**3 * cs * k)[:, None] * amp,
                         d_g_ddot=((12 * sn**2 * cs**2 - 4 * sn**4) * k**2)[:, None] * amp)
    raw = np.zeros((n, thesis_rig.channel_count))
    for s in thesis_rig.sensors:
        if s.name in acc:
            c = si.channels[s.channel]
            raw[:, s.channel] = s.sign * acc[s.name] * c.sensitivity * c.daq_gain
    force = np.exp(-(((t - 0.01) / 0.001) ** 2)) * 100.0
    fc = si.channels[thesis_rig.force_channel]
    raw[:, thesis_rig.force_channel] = force * fc.sensitivity * fc.daq_gain
    project = create_project(tmp_path / "p.odsp", thesis_rig)
    project.add_experiment("pulse", raw, sampling_rate=FS, systeminfo=si,
                           excitation=Excitation(thesis_rig.force_channel, np.zeros(3), np.array([0, 0, 1.0])))
    return project, body, d, force, raw, si


def test_process_experiment_recovers_rigid_motion(tmp_path, thesis_rig):
    # filters off and the centred rule: the chain is conversion + double trapezoid integration,
    # whose error on this smooth pulse is O(dt^2)
    project, body, d, force, raw, si = _pulse_project(
        tmp_path, thesis_rig, filters_on=0, offset_length=0, integration_rule="trapezoid")
    calls = []
    summary = process_experiment(project, "pulse", chunk=777, progress=lambda a, b: calls.append((a, b)))
    assert calls[-1] == (4000, 4000)
    proc = project.read_derived("pulse", "processed")
    info = project.derived_info("pulse", "processed")
    assert info["units"] == {"acceleration": "m/s^2", "velocity": "m/s", "displacement": "m", "force": "N"}
    np.testing.assert_allclose(proc["force"], force, rtol=1e-12, atol=1e-12)
    gc = project.read_derived("pulse", "gencoords")
    err = np.abs(gc[f"{body.name}_at_g"] - d).max(axis=0) / np.abs(d).max(axis=0)
    assert np.all(err < 2e-3), err
    # the rigid body passes the Eq. 4.12 check
    assert summary["bodies"][body.name]["flagged"] == []
    assert np.all(gc[f"{body.name}_rigidity"] < 1e-3)
    # the stored displacements are the chain's own output, column by column
    chans = info["provenance"]["parameters"]["channels"]
    for j, k in enumerate(chans):
        ref = chain_for_channel(si.channels[k], registry=_installed_steps()).run(raw[:, k])
        _close(proc["displacement"][:, j], ref["displacement"])
    project.close()


def test_process_experiment_table_e3_chunked_equals_in_memory(tmp_path, thesis_rig):
    project, body, d, force, raw, si = _pulse_project(tmp_path, thesis_rig, n=3001)
    process_experiment(project, "pulse", chunk=101)
    proc = project.read_derived("pulse", "processed")
    for j, k in enumerate(project.derived_info("pulse", "processed")["provenance"]["parameters"]["channels"]):
        ref = chain_for_channel(si.channels[k], registry=_installed_steps()).run(raw[:, k])
        for tap in ("acceleration", "velocity", "displacement"):
            _close(proc[tap][:, j], ref[tap])
    project.close()


def test_object_ids_are_those_the_full_readers_give(tmp_path, thesis_rig):
    """``object_ids`` (what the stored errors' stamp hashes) reads the same ids as ``experiment`` and
    ``derived_info``, which read every attribute; re-processing gives new derived ids."""
    project, *_ = _pulse_project(tmp_path, thesis_rig, n=1001)
    assert project.object_ids("pulse") == (project.experiment("pulse").object_id, {})
    process_experiment(project, "pulse")
    record, derived = project.object_ids("pulse")
    assert sorted(derived) == sorted(project.derived_kinds("pulse")) and len(derived) == 2
    assert (record, derived) == (project.experiment("pulse").object_id,
                                 {k: project.derived_info("pulse", k)["object_id"] for k in derived})
    process_experiment(project, "pulse")
    assert project.object_ids("pulse")[0] == record
    assert all(project.object_ids("pulse")[1][k] != derived[k] for k in derived)
    project.close()


def test_cli_process(tmp_path, thesis_rig, capsys):
    from odsuite.cli import main

    project, *_ = _pulse_project(tmp_path, thesis_rig, n=2000)
    project.close()
    assert main(["process", str(tmp_path / "p.odsp"), "--experiment", "pulse"]) == 0
    out = capsys.readouterr().out
    assert "pulse: acceleration, displacement, force, velocity for channels 2, 3, 4" in out
    assert main(["process", str(tmp_path / "p.odsp"), "--experiment", "nope"]) == 1
    assert "no experiment" in capsys.readouterr().err.lower()


@pytest.mark.parametrize(("specs", "expected"), [
    (5, "build_chain: 'specs' must be a list of steps (tables with a 'step' or 'tap' entry), got 5"),
    (None, "build_chain: 'specs' must be a list of steps (tables with a 'step' or 'tap' entry), got None"),
    ("iir", "build_chain: 'specs' must be a list of steps (tables with a 'step' or 'tap' entry), got 'iir'"),
    ({"step": "iir"}, "build_chain: 'specs' must be a list of steps (tables with a 'step' or 'tap' entry), got {'step': 'iir'}"),
    ([{"step": "invert"}, 5], "chain[1]: expected a table {'step': NAME, ...}, got 5"),
    (np.zeros((2, 40)), "chain[0]: expected a table {'step': NAME, ...}, got array(["
                        + "0., " * 17 + "0...."),
])
def test_build_chain_refuses_what_is_no_list_of_tables(registries, specs, expected):
    with pytest.raises(ConfigError) as info:
        build_chain(specs, fs=FS, registry=registries.processing_steps)
    assert str(info.value) == expected
