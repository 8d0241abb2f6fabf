"""Multi-setup output-only analysis (roving sensors merged through reference channels, PoSER):
against a shear frame's exact modes, and on the Palisaden building's record split into setups
against pyOMA2's single-record shapes and the published frequencies."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.linalg
import scipy.signal

from conftest import REAL_DATA
from odsuite.analysis.modal import mac
from odsuite.analysis.multisetup import check_references, merge_setups
from odsuite.analysis.oma import identify_output_only
from odsuite.cli import main
from odsuite.domain.errors import ConfigError

PALISADEN_SSI = np.array([1.88205042, 2.4211625, 2.68851009])  # pyOMA2's documentation (README)
#: the building's split: references ch2 (y at point 1) and ch3 (x at point 2) see all three modes;
#: each setup another 30 min of the record at another level (x1, x3.7, x0.5) and roving channels
PALISADEN_SETUPS = {"a": ([1, 2, 0], 1.0), "b": ([1, 2, 3], 3.7), "c": ([1, 2, 4, 5], 0.5)}


def _chain(n: int = 6):
    """A fixed-free shear chain of n floors (10 t, 20 MN/m storeys): natural frequencies (Hz) and
    shapes (scipy.linalg.eigh), and its continuous state space with a force on every floor and
    accelerations out (2 % modal damping)."""
    K = 2.0e7 * (2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))
    K[-1, -1] = 2.0e7
    M = 1.0e4 * np.eye(n)
    w2, V = scipy.linalg.eigh(K, M)
    wn = np.sqrt(w2)
    C = M @ V @ np.diag(2 * 0.02 * wn) @ V.T @ M
    Mi = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Mi @ K, -Mi @ C]])
    B = np.vstack([np.zeros((n, n)), Mi])
    return wn / (2 * np.pi), V, (A, B, np.hstack([-Mi @ K, -Mi @ C]), Mi)


def _ambient(system, fs: float, seconds: float, level: float, seed: int) -> np.ndarray:
    """Floor accelerations under independent white forces of rms ``level`` N (exact zero-order
    hold at twice the rate, decimated)."""
    dt = 1 / (2 * fs)
    Ad, Bd, Cd, Dd, _ = scipy.signal.cont2discrete(system, dt, "zoh")
    rng = np.random.default_rng(seed)
    u = level * rng.standard_normal((int(2 * fs * seconds), system[1].shape[1]))
    _, y, _ = scipy.signal.dlsim((Ad, Bd, Cd, Dd, dt), u)
    return scipy.signal.decimate(y, 2, ftype="fir", axis=0)


def test_roving_chain_merged_against_exact_modes():
    """Three setups of a 6-floor chain, each a different record and force level, with floors 4 and 6
    as references and two roving floors each (floors 1-2, 3, 5), sensor noise 3, 8 and 15 % of
    each channel's rms: the merged frequencies within 1 % of eigh's, shapes MAC >= 0.98 against
    the exact ones over all six floors; a merge without the rescaling (each setup's shape as
    identified) is what the test would catch (MAC well below)."""
    fs = 100.0
    f_true, V, system = _chain()
    floors = {"s1": [3, 5, 0, 1], "s2": [3, 5, 2], "s3": [3, 5, 4]}
    results = []
    rng = np.random.default_rng(1)
    for k, ((name, cols), level, noise) in enumerate(zip(floors.items(), (1e3, 4e3, 2e2), (0.03, 0.08, 0.15))):
        y = _ambient(system, fs, 300.0, level, seed=10 + k)[:, cols]
        y = y + noise * y.std(axis=0) * rng.standard_normal(y.shape)
        results.append(identify_output_only(y, fs, f_band=(0.5, 20.0), output_names=[f"floor{c + 1}" for c in cols]))
    merged = merge_setups(results, list(floors), ["floor4", "floor6"])
    assert merged.channels == ["floor4", "floor6", "floor1", "floor2", "floor3", "floor5"]
    rows = [int(c[5:]) - 1 for c in merged.channels]
    pick = [int(np.argmin(np.abs(merged.frequency_hz - f))) for f in f_true[:3]]
    np.testing.assert_allclose(merged.frequency_hz[pick], f_true[:3], rtol=0.01)
    assert np.diag(mac(merged.shapes[:, pick], V[rows, :3])).min() >= 0.98
    np.testing.assert_allclose(merged.damping_ratio[pick], 0.02, rtol=0.3)
    assert np.all(merged.frequency_spread_hz[pick] < 0.01 * f_true[:3])
    # unscaled: each setup's roving part as identified (largest entry 1 per setup) -> wrong shapes
    raw = merged.shapes.copy()
    row = 2
    for s, r in zip(floors, results):
        rov = [c for c in range(len(r.output_names)) if r.output_names[c] not in ("floor4", "floor6")]
        for k in pick:
            raw[row:row + len(rov), k] = r.shapes[rov, [next(j for j, f in enumerate(r.frequency_hz)
                                                             if abs(f / merged.per_setup[k][s][0] - 1) < 1e-12)]]
        row += len(rov)
    assert np.diag(mac(raw[:, pick], V[rows, :3])).min() < 0.98


def test_reference_channels_checked_in_one_line():
    setups = [("a", ["ch1", "ch2", "ch3"]), ("b", ["CH1", "ch2", "ch4"])]
    assert check_references(setups, None, "P.h5") == ["ch2"]
    with pytest.raises(ConfigError, match=r"setup 'b' has no reference channel 'ch1' \(it has 'CH1'"):
        check_references(setups, ["ch1", "ch2"], "P.h5")
    with pytest.raises(ConfigError, match=r"setup 'a' has no reference channel 'ch9' \(its channels: ch1, ch2, ch3\)"):
        check_references(setups, ["ch2", "ch9"], "P.h5")
    with pytest.raises(ConfigError, match="share no channel name"):
        check_references([("a", ["x"]), ("b", ["y"])], None, "P.h5")
    with pytest.raises(ConfigError, match="adds no roving channel"):
        check_references([("a", ["x", "y"]), ("b", ["x"])], None, "P.h5")


@pytest.fixture(scope="module")
def palisaden_setups(tmp_path_factory):
    """The Palisaden record as a roving survey: three 30-min setups (experiments a, b, c) of
    PALISADEN_SETUPS's channels and levels."""
    from odsuite.domain.systeminfo import ChannelInfo, SensorType, Systeminfo
    from odsuite.store.project import open_project

    y = np.load(REAL_DATA / "palisaden_building" / "Palisaden_dataset.npy")
    p = tmp_path_factory.mktemp("palisaden_setups") / "P.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    n = y.shape[0] // 3
    with open_project(p, "a") as proj:
        for k, (name, (cols, level)) in enumerate(PALISADEN_SETUPS.items()):
            chans = [ChannelInfo(sensor_type=SensorType.ACCELEROMETER, location=f"ch{c + 1}", sampling_rate=100.0,
                                 limit_high=100.0, limit_low=-100.0) for c in cols]
            proj.add_experiment(name, level * y[k * n:(k + 1) * n, cols], sampling_rate=100.0,
                                systeminfo=Systeminfo(chans), excitation=None,
                                channel_names=[f"ch{c + 1}" for c in cols])
    return p


def test_palisaden_split_into_setups(palisaden_setups, capsys):
    """`modes --output-only` over three setups, references taken as the channels all setups share
    (ch2, ch3): the three modes within 0.5 % of pyOMA2's published SSI-cov frequencies, merged
    shapes over all six channels MAC >= 0.95 against pyOMA2's shapes of the whole record, in one
    piece (MPC >= 0.99), and the per-setup frequencies reported with their spread."""
    from odsuite.analysis.modal import mac

    ref = json.loads((REAL_DATA / "palisaden_building" / "pyoma2_reference.json").read_text())
    capsys.readouterr()
    assert main(["modes", str(palisaden_setups), "--experiment", "a", "--experiment", "b", "--experiment", "c",
                 "--output-only", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["references"] == ["ch2", "ch3"] and sorted(doc["channels"]) == [f"ch{k}" for k in range(1, 7)]
    f = np.array([m["frequency_hz"] for m in doc["modes"]])
    pick = [int(np.argmin(np.abs(f - f0))) for f0 in PALISADEN_SSI]
    np.testing.assert_allclose(f[pick], PALISADEN_SSI, rtol=0.005)
    theirs = ref["modes"]["SSIcov"]
    phi = (np.array(theirs["shape"]["re"]) + 1j * np.array(theirs["shape"]["im"])).T
    ours = np.array([[complex(*doc["modes"][k]["shape"][f"ch{c + 1}"]) for c in range(6)] for k in pick]).T
    assert np.diag(mac(ours, phi)).min() >= 0.95
    for k in pick:
        m = doc["modes"][k]
        assert m["mpc"] >= 0.99 and set(m["setups"]) == {"a", "b", "c"}
        per = [s["frequency_hz"] for s in m["setups"].values()]
        assert m["frequency_spread_hz"] == pytest.approx(np.std(per, ddof=1), rel=1e-9)
        assert min(s["reference_mac"] for s in m["setups"].values()) >= 0.9
    # pyOMA2's MultiSetup_PoSER on the same split (make_pyoma2_multisetup_reference.py): the same
    # channels in the same order, frequencies within 0.1 %, shapes MAC >= 0.99
    peer = json.loads((REAL_DATA / "palisaden_building" / "pyoma2_multisetup_reference.json").read_text())
    assert peer["channels"] == doc["channels"]
    np.testing.assert_allclose(f[pick], peer["frequency_hz"], rtol=0.001)
    phi = (np.array(peer["shape"]["re"]) + 1j * np.array(peer["shape"]["im"])).T
    ours = np.array([[complex(*doc["modes"][k]["shape"][c]) for c in doc["channels"]] for k in pick]).T
    assert np.diag(mac(ours, phi)).min() >= 0.99


def test_inconsistent_reference_is_one_line(palisaden_setups, capsys):
    capsys.readouterr()
    assert main(["modes", str(palisaden_setups), "--experiment", "a", "--experiment", "c", "--output-only",
                 "--reference", "ch2,ch1"]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "setup 'c' has no reference channel 'ch1'" in err


def test_modes_and_render_merge_the_same_modes(palisaden_setups, capsys):
    """`modes --output-only` and the mode-shape renderer (``project_setups_modes`` with its defaults,
    as `render` and `report` call it) identify with one default model order: with 50 in `modes` and
    40 in `render` the setups' bands differed (up to 19.6-25.8 Hz against 14.6-20.5 Hz) and `modes`
    merged two more modes (13.29 and 19.54 Hz, MPC 0.74 and 0.42)."""
    from odsuite.analysis.multisetup import project_setups_modes

    capsys.readouterr()
    assert main(["modes", str(palisaden_setups), "--experiment", "a", "--experiment", "b", "--experiment", "c",
                 "--output-only", "--json"]) == 0
    modes = [m["frequency_hz"] for m in json.loads(capsys.readouterr().out)["modes"]]
    rendered = project_setups_modes(palisaden_setups, ["a", "b", "c"]).frequency_hz
    np.testing.assert_allclose(modes, rendered, rtol=1e-9)


def test_api_output_only_modes_take_the_projects_path(palisaden_setups):
    """Through odsuite.api (which checks a project argument) the two functions that open the project
    in their own worker processes take its path, str or Path: a rig-less project's report lists
    these modes."""
    from odsuite import api
    from odsuite.analysis.multisetup import project_setups_modes

    merged = api.project_setups_modes(str(palisaden_setups), ["a", "b", "c"])
    np.testing.assert_array_equal(merged.frequency_hz,
                                  project_setups_modes(palisaden_setups, ["a", "b", "c"]).frequency_hz)
    res, freq, spectrum, unit = api.experiment_output_only_modes(palisaden_setups, "a")
    assert len(res.frequency_hz) >= 1 and freq.shape[0] == spectrum.shape[-1]
