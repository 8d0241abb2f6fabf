"""A fifth rig, written from docs/rig-format.md alone, with its own simulator (block/blocksim.py,
which shares no code with rigsim or odsuite): a 60 kg block on three soft mounts and one stiff
pad, three triaxial accelerometers of three sensitivities and one single-axis sensor mounted
upside down, a 16-bit DAQ. Records go in as a user's CSV files of volts through `odsuite import`.

What issue 30 promises of the verdict, judged on it: records of the rig file itself leave nothing
to explain; a softer mount struck at 100 N is named as a stiffness."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import linalg

from .block import blocksim

SAMPLES = 2048  # 0.5 s at 4096 Hz: the slowest mode (22 Hz, 5 % damping) has died away by then


def _odsuite(capsys, *args) -> str:
    from odsuite.cli import main

    capsys.readouterr()
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    assert code == 0, out.err[-600:]
    return out.out


def _project(tmp_path, capsys, case, seed, peak, noise):
    """A project on the rig file with the case's four records imported and processed."""
    blows = blocksim.write_case(tmp_path / "rec", case, seed, peak, noise, samples=SAMPLES)
    project = tmp_path / "p.h5"
    _odsuite(capsys, "new", project, "--rig", blocksim.RIG_FILE)
    for b in blows:
        _odsuite(capsys, "import", project, b["file"], "--name", b["name"],
                 f"--force-point={b['point']}", f"--force-dir={b['dir']}")
    _odsuite(capsys, "process", project)
    return project


def _diagnose(capsys, project, *effects) -> dict:
    args = ["diagnose", project, "--json", "--workers", "1"]
    for e in effects:
        args += ["--effect", e]
    return json.loads(_odsuite(capsys, *args))


def test_simulator_modes_are_odsuite_models_modes(tmp_path, capsys):
    """The simulator's M, K, C (assembled here from the rig file by point maps) and odsuite's
    model of the same file: the same six damped modes, frequency and damping ratio."""
    M, K, C, _ = blocksim.system_matrices(blocksim.make_truth("null"))
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-linalg.solve(M, K), -linalg.solve(M, C)]])
    poles = linalg.eigvals(A)
    poles = poles[poles.imag > 0]
    poles = poles[np.argsort(np.abs(poles))]
    project = tmp_path / "p.h5"
    _odsuite(capsys, "new", project, "--rig", blocksim.RIG_FILE)
    modes = json.loads(_odsuite(capsys, "model", project, "--json"))["modes"]
    np.testing.assert_allclose([m["frequency_hz"] for m in modes], np.abs(poles) / (2 * np.pi),
                               rtol=1e-6)
    np.testing.assert_allclose([m["damping_ratio"] for m in modes], -poles.real / np.abs(poles),
                               rtol=1e-6)


def test_records_of_the_rig_itself_leave_nothing_to_explain_white_noise(tmp_path, capsys):
    """A null (the truth is the rig file exactly) under white ADC noise and a 50 Hz hum, blows of
    5-200 N, one a double hit: nothing to explain."""
    project = _project(tmp_path, capsys, "null", 1, None, "white")
    d = _diagnose(capsys, project, "stiffness")
    assert d["verdict"] == "nothing to explain", d["signature"]["cells"]


def test_records_of_the_rig_itself_leave_nothing_to_explain_lab_noise(tmp_path, capsys):
    """The same null under a lab's noise: white plus 1/f-like noise, hum at 50 and 150 Hz, an
    offset and a slow drift, 16-bit rounding."""
    project = _project(tmp_path, capsys, "null", 1, None, "lab")
    d = _diagnose(capsys, project, "stiffness")
    assert d["verdict"] == "nothing to explain", d["signature"]["cells"]


def test_a_softer_mount_struck_at_100_newton_is_named_a_stiffness(tmp_path, capsys):
    """Mount soft2 at 0.6 of its stiffness, every blow 100 N: the best significant candidate is a
    stiffness, and its fitted stiffness of soft2 along each axis is 0.6 of the rig file's (5 %),
    the other mounts' their own (10 %)."""
    project = _project(tmp_path, capsys, "soft", 101, 100.0, "lab")
    d = _diagnose(capsys, project, "stiffness", "spring_stiffness")
    significant = [c for c in d["candidates"] if c["significant"]]
    assert significant and significant[0]["effect"] == "spring_stiffness", d["candidates"][:2]
    fitted = {p["label"]: p["value"] / p["nominal"] for p in significant[0]["physical"]
              if p["label"].startswith("stiffness of ")}
    assert len(fitted) == 12
    for label, ratio in fitted.items():
        expected = 0.6 if "soft2" in label else 1.0
        assert ratio == pytest.approx(expected, rel=0.05 if expected < 1 else 0.1), label


def _exact_accelerance(truth, blow, freq):
    """Accelerance (outputs x lines, (m/s^2)/N) of the rig's accelerometer axes to a blow, from the
    simulator's M, K, C, and each mode's own term (outputs x lines x modes) with its poles: the
    state-space eigenvectors, independent of odsuite."""
    M, K, C, com = blocksim.system_matrices(truth)
    _, point, _, direction = next(b for b in blocksim.BLOWS if b[0] == blow)
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-linalg.solve(M, K), -linalg.solve(M, C)]])
    B = np.concatenate([np.zeros(n), linalg.solve(M, blocksim.point_map(np.asarray(point) - com).T
                                                  @ np.asarray(direction, float))])
    S = np.array([np.asarray(ax, float) @ blocksim.point_map(np.asarray(pos, float) - com)
                  for _, _, pos, ax, _, _ in blocksim.sensor_channels(truth.rig)])
    lam, V = linalg.eig(A)
    left = linalg.solve(V, B)  # modal participation of the force
    s = 2j * np.pi * np.asarray(freq)[None, :, None]
    terms = (S @ V[:n])[:, None, :] * left[None, None, :] * s**2 / (s - lam[None, None, :])
    up = np.flatnonzero(lam.imag > 0)
    up = up[np.argsort(np.abs(lam[up]))]
    partner = [int(np.argmin(np.abs(lam - lam[r].conj()))) for r in up]
    own = terms[..., up] + terms[..., partner]
    return terms.sum(axis=2), own, lam[up]


def _well_excited(H, own, lam, freq):
    """Which modes a blow excites well, judged on the exact FRFs by the rules ``check_poles``
    holds a pole to: its own term at least half of |H| at its frequency, and |H| there at least
    its level 3 half-power bandwidths to either side (a peak of its own), in some output."""
    out = []
    for r, p in enumerate(lam):
        f0, half = abs(p) / (2 * np.pi), 3 * 2 * (-p.real / (2 * np.pi))
        i = int(np.argmin(np.abs(freq - f0)))
        dominance = np.max(np.abs(own[:, i, r]) / np.abs(H[:, i]))
        level = np.array([[np.interp(f0 + d, freq, np.abs(h)) for d in (-half, 0.0, half)] for h in H])
        out.append(dominance >= 0.5 and np.max(level[:, 1] / level[:, [0, 2]].max(axis=1)) >= 1)
    return np.array(out)


def _assert_found(poles, frequency_hz, damping_ratio, blow):
    """Each true pole has an identified mode within 1 % in frequency and 20 % in damping ratio."""
    for p in poles:
        f, z = abs(p) / (2 * np.pi), -p.real / abs(p)
        k = int(np.argmin(np.abs(frequency_hz - f)))
        assert frequency_hz[k] == pytest.approx(f, rel=0.01), (blow, f, frequency_hz)
        assert damping_ratio[k] == pytest.approx(z, rel=0.2), (blow, f, z, damping_ratio)


@pytest.mark.parametrize("blow", ["E1", "E2", "E3"])
def test_modes_are_found_on_the_exact_frfs_of_a_short_record(blow):
    """The fit itself on this rig: the exact FRFs (no noise) of each blow on the lines of a
    2048-sample record at 4096 Hz (2 Hz apart), up to the usable band of a 1 ms half-sine blow
    (1.02 / T, docs/modal.md). Every mode the blow excites well (``_well_excited``) is found,
    frequency within 1 % (the stability criterion's tolerance between orders) and damping ratio
    within 20 % (a wide cluster's damping may spread by 20 % over the orders,
    CLUSTER_DAMPING_SPREAD, and the median is reported)."""
    from odsuite.analysis.modal import identify_modes

    freq = np.fft.rfftfreq(2048, 1 / 4096.0)
    H, own, lam = _exact_accelerance(blocksim.make_truth("null"), blow, freq[1:])
    excited = _well_excited(H, own, lam, freq[1:])
    assert excited.sum() >= 4, excited
    res = identify_modes(freq, np.hstack([np.zeros((H.shape[0], 1)), H]), f_band=(None, 1.02 / 1e-3))
    _assert_found(lam[excited], res.frequency_hz, res.damping_ratio, blow)


@pytest.mark.xfail(strict=True, reason=(
    "no blow's modes are reported ('no stable poles'): at 100 N most channels respond 14-46 ADC "
    "codes against 0.5-1 code of noise, the 50 Hz hum (1.6 codes) makes the 50 Hz line of a single "
    "hit's H1 up to 14 x the structure's, and 1/f noise and drift 3-12 x below 20 Hz; the fit now "
    "finds poles within 1.5 % of the 22-44 Hz modes (seed 1), and the synthesis check refuses them "
    "all: misfit 39-109 % near them against its 30 %, which noise of 2-30 % of |H| there alone "
    "nearly uses up"))
def test_modes_of_records_struck_at_100_newton(tmp_path, capsys):
    """The null case, every blow 100 N, through `odsuite modes`: each blow's well-excited modes
    (on its exact FRFs, ``_well_excited``) within 1 % in frequency and 20 % in damping ratio of the
    simulator's poles, as on the exact FRFs."""
    project = _project(tmp_path, capsys, "null", 1, 100.0, "lab")
    truth = blocksim.make_truth("null")
    freq = np.fft.rfftfreq(2048, 1 / 4096.0)[1:]
    for blow in ("E1", "E2", "E3"):
        H, own, lam = _exact_accelerance(truth, blow, freq)
        modes = json.loads(_odsuite(capsys, "modes", project, "--experiment", blow, "--json"))["modes"]
        _assert_found(lam[_well_excited(H, own, lam, freq)], np.array([m["frequency_hz"] for m in modes]),
                      np.array([m["damping_ratio"] for m in modes]), blow)


@pytest.mark.parametrize("blow", ["E1", "E2", "E3"])
def test_modes_survive_noise_of_three_per_mille_of_the_peak(blow):
    """The exact FRFs on the lines of the records `odsuite modes` fits (1806 samples: 2.27 Hz),
    with complex white noise of 0.3 % of each output's peak per line (far below the records'
    own: 2-30 % of |H| near the modes at 100 N): every well-excited mode found as on the exact
    FRFs (1 % in frequency, 20 % in damping ratio)."""
    from odsuite.analysis.modal import identify_modes

    freq = np.fft.rfftfreq(1806, 1 / 4096.0)
    H, own, lam = _exact_accelerance(blocksim.make_truth("null"), blow, freq[1:])
    excited = _well_excited(H, own, lam, freq[1:])
    rng = np.random.default_rng(0)
    noise = (rng.normal(size=H.shape) + 1j * rng.normal(size=H.shape)) / np.sqrt(2)
    H = H + 0.003 * np.abs(H).max(axis=1, keepdims=True) * noise
    res = identify_modes(freq, np.hstack([np.zeros((H.shape[0], 1)), H]), f_band=(None, 1.02 / 1e-3))
    _assert_found(lam[excited], res.frequency_hz, res.damping_ratio, blow)


def test_a_fitted_number_has_one_uncertainty_in_diagnose_add_effect_and_model(tmp_path, capsys):
    """The softer mount's stiffnesses as diagnose prints them, add-effect stores them and model
    reads them back: the same values with the same uncertainties (diagnose printed the fit's own,
    2.8 kN/m along y, while the revision stored the spread between the four records, 5.1)."""
    project = _project(tmp_path, capsys, "soft", 101, 100.0, "lab")
    d = _diagnose(capsys, project, "spring_stiffness")
    fitted = next(c for c in d["candidates"] if c["effect"] == "spring_stiffness")
    added = json.loads(_odsuite(capsys, "add-effect", project, "spring_stiffness", "--json"))
    stored = json.loads(_odsuite(capsys, "model", project, "--json"))["physical"]["spring_stiffness"]
    entry = next(e for e in added["effects"] if e["effect"] == "spring_stiffness")
    assert [r["label"] for r in fitted["physical"]] == [r["label"] for r in entry["physical"]] \
        == [r["label"] for r in stored]
    for shown, kept, read in zip(fitted["physical"], entry["physical"], stored):
        assert kept == read
        assert shown["value"] == pytest.approx(kept["value"], rel=1e-3), shown["label"]
        assert shown["uncertainty"] == pytest.approx(kept["uncertainty"], rel=0.02), shown["label"]
    along_y = next(r for r in stored if r["label"] == "stiffness of soft2 along y")
    assert along_y["value"] == pytest.approx(180e3, abs=2 * along_y["uncertainty"])
    for name, sd in fitted["uncertainties"].items():
        assert sd == pytest.approx(entry["uncertainties"][name], rel=0.02), name


@pytest.mark.slow
def test_every_line_fits_80_columns_on_the_block_rig(tmp_path, capsys, monkeypatch):
    """At 80 columns (a terminal that wide, or piped) compare's notes, diagnose's table of every
    effect (pairs among them) and its list of effects that do not apply, add-effect and model fit
    the width; they ran 94-220 characters, and a pair's name broke inside a word."""
    from odsuite import cli

    monkeypatch.setattr(cli.console, "width", 80)
    project = _project(tmp_path, capsys, "soft", 101, 100.0, "lab")
    out = {args[0]: _odsuite(capsys, *args) for args in (
        ["compare", project], ["diagnose", project, "--workers", "1"],
        ["add-effect", project, "spring_stiffness"], ["model", project], ["info", project])}
    # the softer mount alone explains these records, so no pair is fitted here; a pair's name at 80
    # columns is tested on its own (tests/cli/test_no_traps.py)
    assert "not applicable to this model" in out["diagnose"] and "spring_stiffness" in out["diagnose"]
    too_long = [(command, line) for command, text in out.items() for line in text.splitlines() if len(line) > 80]
    assert not too_long, too_long
