"""A rig written from docs/rig-format.md alone: three bodies in a chain (a slender frame on two
isolators, a pedestal on four mounts on it, a head on four mounts on the pedestal), sensors of
10, 50, 100 and 500 mV/g, one on a tilted axis mounted reversed. Taken through new, acquire,
process and compare; the measured FRFs are checked against the closed form of the vertical chain."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import scipy.linalg

from tests.cli.clirun import run

RIG = Path(__file__).resolve().parents[1] / "data" / "rigs" / "three-body-stand.toml"
# the rig file's numbers: masses (kg), vertical stiffness and damping of each link of the chain
# (2 isolators, 4 pedestal mounts, 4 head mounts), N/m and N s/m
MASS = np.array([60.0, 25.0, 15.0])
K_LINKS = np.array([2 * 1.2e6, 4 * 2e6, 4 * 1e6])
C_LINKS = np.array([2 * 900.0, 4 * 200.0, 4 * 120.0])


def chain(links: np.ndarray) -> np.ndarray:
    """The 3 x 3 matrix of springs (or dampers) ground - frame - pedestal - head."""
    a, b, c = links
    return np.array([[a + b, -b, 0.0], [-b, b + c, -c], [0.0, -c, c]])


def test_the_vertical_chain_is_three_of_the_models_modes(registries):
    from odsuite.domain.rig import load_rig

    rig = load_rig(RIG, registries.sensor_types)
    assert [b.name for b in rig.moving_bodies] == ["frame", "pedestal", "head"]
    assert len(rig.accelerometers) == 21 and rig.force_channel == 0
    model = registries.models.get(rig.default_model)(rig)
    # every body's centre of mass lies on the z axis and the springs sit symmetrically about it:
    # the vertical motions decouple into the chain's three modes, roots of det(K - w^2 M) = 0
    k1, k2, k3 = K_LINKS
    m1, m2, m3 = MASS
    frame, pedestal, head = (np.poly1d([-m, k]) for m, k in ((m1, k1 + k2), (m2, k2 + k3), (m3, k3)))
    determinant = frame * (pedestal * head - k3 ** 2) - k2 ** 2 * head  # polynomial in w^2
    expected = np.sort(np.sqrt(determinant.r.real)) / (2 * np.pi)
    np.testing.assert_allclose(expected, np.sqrt(scipy.linalg.eigvalsh(chain(K_LINKS), np.diag(MASS))) / (2 * np.pi),
                               rtol=1e-9)
    undamped = np.sqrt(scipy.linalg.eigh(model.K, model.M, eigvals_only=True)) / (2 * np.pi)
    assert len(undamped) == 18
    for fz in expected:  # 23.86, 75.72 and 130.39 Hz
        assert np.min(np.abs(undamped - fz)) < 1e-9 * fz


def test_a_blow_on_the_axis_gives_the_chains_accelerance(capsys, tmp_path):
    p = tmp_path / "stand.h5"
    code, out, err = run(capsys, "new", p, "--rig", RIG)
    assert code == 0 and err == "", err
    code, out, err = run(capsys, "acquire", p, "--daq", "sim", "--name", "centre", "--samples", "2048",
                         "--force-point=0,0,670", "--force-dir=-z", "--force-peak", "100")
    assert code == 0, err
    assert "on 'head'" in out
    code, out, err = run(capsys, "process", p)
    assert code == 0, err
    assert all(f"{b}: least-squares" in out for b in ("frame", "pedestal", "head"))
    code, out, err = run(capsys, "compare", p, "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert len(doc["channels"]) == 21
    assert doc["error"] <= 1.5 * doc["noise_floor_error"]  # the rig's own records: the model is perfect

    from odsuite.analysis.modal_project import experiment_frf

    frf, _ = experiment_frf(p, "centre")
    f, names = frf.frequency, frf.output_names
    band = (f > 12.0) & (f < 200.0)  # the chain's three modes, where the 100 N blow is well above the noise
    w = 2 * np.pi * f[band]
    K, C, M = chain(K_LINKS), chain(C_LINKS), np.diag(MASS)
    # a blow downwards: accelerance of each body per newton along -z, upwards positive
    accelerance = np.array([w_ ** 2 * np.linalg.solve(K - w_ ** 2 * M + 1j * w_ * C, [0.0, 0.0, 1.0]) for w_ in w])
    # each channel's FRF against its body's closed form, along its axis (H3: 0.8 of z, read with
    # its sign undone); F3 is the 10 mV/g sensor, ten times noisier in m/s^2
    for channel, body, along, limit in (("F1_z", 0, 1.0, 0.06), ("F2_z", 0, 1.0, 0.06), ("F3", 0, 1.0, 0.25),
                                        ("P1_z", 1, 1.0, 0.06), ("P2_z", 1, 1.0, 0.06), ("H1_z", 2, 1.0, 0.06),
                                        ("H2_z", 2, 1.0, 0.06), ("H3", 2, 0.8, 0.06)):
        h, ref = frf.H[names.index(channel), band], along * accelerance[:, body]
        assert np.linalg.norm(h - ref) / np.linalg.norm(ref) < limit, channel
    # an isolator 17 % softer would be far off: the check sees the rig's stiffness
    softer = np.array([w_ ** 2 * np.linalg.solve(chain(K_LINKS * [5 / 6, 1, 1]) - w_ ** 2 * M + 1j * w_ * C,
                                                 [0.0, 0.0, 1.0]) for w_ in w])
    h = frf.H[names.index("H1_z"), band]
    assert np.linalg.norm(h - softer[:, 2]) / np.linalg.norm(softer[:, 2]) > 0.1
    # the blow on the axis moves nothing sideways: the in-plane channels see < 3 % of the head's z
    for channel in ("H1_x", "H1_y", "P3", "F1_x"):
        assert np.linalg.norm(frf.H[names.index(channel), band]) < 0.03 * np.linalg.norm(accelerance[:, 2])

    # the default `modes` finds the chain's three modes (the 15 in-plane channels, noise at an axis
    # blow, hid them from every model order while each output weighed alike), at the closed form's
    # frequencies and damping ratios: the roots of det(K + s C + s^2 M) = 0
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    poles = np.linalg.eigvals(A)
    poles = poles[poles.imag > 0][np.argsort(np.abs(poles[poles.imag > 0]))]
    f_chain, zeta_chain = np.abs(poles) / (2 * np.pi), -poles.real / np.abs(poles)  # 23.86, 75.70, 130.38 Hz
    code, out, err = run(capsys, "modes", p, "--experiment", "centre", "--json")
    assert code == 0, err
    modes = json.loads(out)["modes"]
    f_id = np.array([m["frequency_hz"] for m in modes])
    zeta_id = np.array([m["damping_ratio"] for m in modes])
    assert len(modes) == 3, f_id
    # 2.5 Hz lines: the 5 %-damped first mode's half-power band spans two of them
    assert np.all(np.abs(f_id / f_chain - 1) < [0.01, 0.002, 0.002]), (f_id, f_chain)
    assert np.all(np.abs(zeta_id / zeta_chain - 1) < [0.15, 0.05, 0.05]), (zeta_id, zeta_chain)
    # so `compare` sets them against the model's modes (the report's section)
    code, out, err = run(capsys, "compare", p, "--json")
    pairs = json.loads(out)["modal"]
    assert [round(r["model_hz"], 2) for r in pairs] == [round(x, 2) for x in f_chain]
    assert all(r["mac"] > 0.99 for r in pairs), pairs

    # the ODS of a hammer record on its own lines (fs / n = 2.5 Hz; Welch segments gave 10 Hz and
    # answered --at 75 with 70 Hz), the pedestal against the head as the chain's accelerances at 75 Hz
    code, out, err = run(capsys, "ods", p, "centre", "--reference", "H1_z", "--at", "75", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert (doc["frequency_hz"], doc["resolution_hz"], doc["segments"]) == (75.0, 2.5, 1)
    assert "coherence is 1 by construction" in doc["notes"][0]
    w75 = 2 * np.pi * 75.0
    a75 = np.linalg.solve(K - w75 ** 2 * M + 1j * w75 * C, [0.0, 0.0, 1.0])
    ratio = complex(*doc["shape"]["P1_z"]) / complex(*doc["shape"]["H1_z"])
    assert abs(ratio - a75[1] / a75[2]) < 0.05 * abs(a75[1] / a75[2]), (ratio, a75[1] / a75[2])
