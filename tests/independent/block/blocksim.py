"""A simulator of the block on four mounts, written apart from odsuite and from rigsim.

Rigid block with six coordinates at its centre of mass (small rotations about x, y, z), springs as
3-axis stiffness and damping at points, the hammer as a half-sine force at a point. Linear cases
are solved exactly per sample of a fine grid (matrix exponential, force held linear between fine
samples); a Coulomb friction at one mount is integrated with RK4 on the same grid. The DAQ: an
analog anti-aliasing Butterworth (bilinear at the fine rate), the IEPE AC coupling on the
accelerometers, decimation to the record rate, ADC-input noise (white plus 1/f-like), mains hum at
50 Hz and 150 Hz, an offset and a slow drift, then 16-bit rounding over +-5 V. Records are CSV
files of volts with a time column, columns named like the rig's sensors.
"""

from __future__ import annotations

import argparse
import copy
import json
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import linalg, signal

HERE = Path(__file__).resolve().parent
RIG_FILE = HERE / "block-on-four-mounts.toml"
OVERSAMPLE = 8


def skew(r):
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def point_map(r):
    """Displacement of a point at r (from the centre of mass) for coordinates [u, theta]."""
    return np.hstack([np.eye(3), -skew(r)])


def as_matrix(v):
    v = np.asarray(v, float)
    return np.diag(v) if v.ndim == 1 else v


@dataclass
class Truth:
    """What the simulated block really is: the rig file plus hidden changes."""

    rig: dict
    spring_scale: dict = field(default_factory=dict)  # spring name -> stiffness factor
    added_mass: tuple | None = None  # (kg, [x, y, z] m)
    true_sensitivity_factor: dict = field(default_factory=dict)  # sensor channel name -> factor
    friction: tuple | None = None  # (spring name, friction force N, smoothing velocity m/s)


def load_rig():
    return tomllib.loads(RIG_FILE.read_text())


def body_properties(truth: Truth):
    body = next(b for b in truth.rig["bodies"] if b["name"] == "block")
    m = float(body["mass"])
    com = np.asarray(body["com"], float)
    J = np.asarray(body["inertia"], float)
    if truth.added_mass is not None:
        dm, p = truth.added_mass
        p = np.asarray(p, float)
        new_com = (m * com + dm * p) / (m + dm)
        # parallel axis: both parts' inertia about the new centre
        def shift(mass, d):
            return mass * (d @ d * np.eye(3) - np.outer(d, d))
        J = J + shift(m, com - new_com) + shift(dm, p - new_com)
        m, com = m + dm, new_com
    return m, com, J


def system_matrices(truth: Truth):
    m, com, J = body_properties(truth)
    M = linalg.block_diag(m * np.eye(3), J)
    K = np.zeros((6, 6))
    C = np.zeros((6, 6))
    for s in truth.rig["springs"]:
        T = point_map(np.asarray(s["position"], float) - com)
        k = as_matrix(s["stiffness"]) * truth.spring_scale.get(s["name"], 1.0)
        c = as_matrix(s.get("damping", [0, 0, 0]))
        K += T.T @ k @ T
        C += T.T @ c @ T
    return M, K, C, com


def sensor_channels(rig):
    """(column name, channel, position, axis, sign, sensitivity) per accelerometer channel."""
    out = []
    for s in rig["sensors"]:
        kind = s.get("kind", "accelerometer")
        if kind == "accelerometer":
            out.append((s["name"], s["channel"], s["position"], s["axis"], s.get("sign", 1),
                        s["sensitivity"]))
        elif kind == "triaxial_accelerometer":
            sens = s["sensitivity"]
            sens = sens if isinstance(sens, list) else [sens] * 3
            axes = s.get("axes", np.eye(3).tolist())
            names = s.get("names", [f"{s['name']}_{a}" for a in "xyz"])
            for i in range(3):
                out.append((names[i], s["channels"][i], s["position"], axes[i], 1, sens[i]))
    return out


def modes_hz(truth: Truth):
    M, K, C, _ = system_matrices(truth)
    w2 = linalg.eigh(K, M, eigvals_only=True)
    return np.sqrt(np.abs(w2)) / 2 / np.pi


def hammer_force(t, hits):
    """Half-sine pulses: hits = [(time s, peak N, contact s)]."""
    f = np.zeros_like(t)
    for t0, peak, tc in hits:
        inside = (t >= t0) & (t <= t0 + tc)
        f[inside] += peak * np.sin(np.pi * (t[inside] - t0) / tc)
    return f


def respond_linear(M, K, C, Bq, force, dt):
    """Accelerations q'' on the fine grid, exact for a force linear between samples."""
    n = M.shape[0]
    Minv = linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    B = np.concatenate([np.zeros(n), Minv @ Bq])[:, None]
    # first-order hold: scipy shifts the state by the input's term and gives it back in Cd, Dd
    Ad, Bd, Cd, Dd, _ = signal.cont2discrete((A, B, np.eye(2 * n), np.zeros((2 * n, 1))), dt,
                                             method="foh")
    sysd = signal.dlti(Ad, Bd, Cd, Dd, dt=dt)
    _, x, _ = signal.dlsim(sysd, force)
    q, v = x[:, :n], x[:, n:]
    acc = (force[:, None] * (Minv @ Bq)[None, :]) - (q @ (Minv @ K).T) - (v @ (Minv @ C).T)
    return acc


def respond_friction(M, K, C, Bq, force, dt, T_fric, mu_n, v0):
    """RK4 with a smoothed Coulomb friction in x and y at one mount (force mu_n, velocity v0)."""
    n = M.shape[0]
    Minv = linalg.inv(M)
    P = T_fric[:2]  # x and y of the mount point

    def deriv(q, v, f):
        vp = P @ v
        fr = -mu_n * np.tanh(vp / v0)
        a = Minv @ (Bq * f - K @ q - C @ v + P.T @ fr)
        return v, a

    q = np.zeros(n)
    v = np.zeros(n)
    acc = np.zeros((len(force), n))
    for k in range(len(force)):
        f0 = force[k]
        f1 = force[k + 1] if k + 1 < len(force) else f0
        fm = 0.5 * (f0 + f1)
        k1q, k1v = deriv(q, v, f0)
        acc[k] = k1v
        k2q, k2v = deriv(q + 0.5 * dt * k1q, v + 0.5 * dt * k1v, fm)
        k3q, k3v = deriv(q + 0.5 * dt * k2q, v + 0.5 * dt * k2v, fm)
        k4q, k4v = deriv(q + dt * k3q, v + dt * k3v, f1)
        q = q + dt / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
        v = v + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    return acc


def record(truth: Truth, point, direction, hits, rng, samples=4096, noise="lab"):
    """Volts per column: dict name -> array, and the rate. noise "lab": white, 1/f-like, hum at 50
    and 150 Hz, offset and drift; "white": white noise and the 50 Hz hum only."""
    rig = truth.rig
    acq = rig["acquisition"]
    fs = float(acq["sampling_rate"])
    fine = fs * OVERSAMPLE
    dt = 1.0 / fine
    n_fine = samples * OVERSAMPLE
    t = np.arange(n_fine) * dt
    force = hammer_force(t, hits)
    M, K, C, com = system_matrices(truth)
    Tp = point_map(np.asarray(point, float) - com)
    Bq = Tp.T @ np.asarray(direction, float)
    if truth.friction is None:
        acc = respond_linear(M, K, C, Bq, force, dt)
    else:
        name, mu_n, v0 = truth.friction
        s = next(s for s in rig["springs"] if s["name"] == name)
        acc = respond_friction(M, K, C, Bq, force, dt,
                               point_map(np.asarray(s["position"], float) - com), mu_n, v0)

    aa = acq["anti_aliasing"]
    wn = 2 * np.pi * aa["cutoff_hz"]
    b, a = signal.butter(aa["order"], wn, analog=True)
    sos_aa = signal.zpk2sos(*signal.bilinear_zpk(*signal.tf2zpk(b, a), fine))
    wc = 2 * np.pi * acq["iepe_corner_hz"]
    sos_iepe = signal.zpk2sos(*signal.bilinear_zpk([0.0], [-wc], 1.0, fine))

    lsb = (acq["adc_range"][1] - acq["adc_range"][0]) / 2 ** acq["adc_bits"]
    tr = np.arange(samples) / fs

    def daq(volts_fine, accelerometer):
        x = signal.sosfilt(sos_aa, volts_fine)
        if accelerometer:
            x = signal.sosfilt(sos_iepe, x)
        x = x[::OVERSAMPLE]
        white = rng.normal(0, 25e-6, samples)
        pink = signal.lfilter([1.0], [1.0, -0.995], rng.normal(0, 4e-6, samples))
        hum = (rng.uniform(50e-6, 250e-6) * np.sin(2 * np.pi * 50.0 * tr + rng.uniform(0, 6.3))
               + rng.uniform(10e-6, 60e-6) * np.sin(2 * np.pi * 150.0 * tr + rng.uniform(0, 6.3)))
        drift = rng.uniform(-3e-3, 3e-3) + rng.uniform(-2e-3, 2e-3) * np.sin(
            2 * np.pi * tr / 7.0 + rng.uniform(0, 6.3))
        if noise == "white":
            pink = drift = 0.0
            hum = rng.uniform(50e-6, 250e-6) * np.sin(2 * np.pi * 50.0 * tr + rng.uniform(0, 6.3))
        v = x + white + pink + hum + drift
        v = np.clip(np.round(v / lsb) * lsb, acq["adc_range"][0], acq["adc_range"][1] - lsb)
        return v

    fsens = next(s for s in rig["sensors"] if s.get("kind") == "force")
    cols = {"time": tr, fsens["name"]: daq(force * fsens["sensitivity"], False)}
    for name, ch, pos, axis, sign, sens in sensor_channels(rig):
        ax = np.asarray(axis, float)
        ap = acc @ (ax @ point_map(np.asarray(pos, float) - com))
        true_sens = sens * truth.true_sensitivity_factor.get(name, 1.0)
        cols[name] = daq(sign * true_sens * ap, True)
    return cols, fs


def write_csv(path, cols):
    names = list(cols)
    header = ",".join(["time [s]"] + [f"{n} [V]" for n in names[1:]])
    data = np.column_stack([cols[n] for n in names])
    # the time column rounded as a lab's program writes it (steps 0.000244140 and 0.000244141 s)
    np.savetxt(path, data, delimiter=",", header=header, comments="",
               fmt=["%.9f"] + ["%.9g"] * (len(names) - 1))


# The four blows of every case: point (m), direction, name; the last one double-hit
BLOWS = [
    ("E1", [0.15, 0.10, 0.2], "-z", [0, 0, -1]),
    ("E2", [0.6, 0.30, 0.12], "-x", [-1, 0, 0]),
    ("E3", [0.40, 0.0, 0.15], "+y", [0, 1, 0]),
    ("E4", [0.50, 0.30, 0.2], "-z", [0, 0, -1]),
]


def make_truth(case: str) -> Truth:
    rig = load_rig()
    if case == "null":
        return Truth(rig)
    if case == "soft":
        return Truth(rig, spring_scale={"soft2": 0.6})
    if case == "mass":
        return Truth(rig, added_mass=(12.0, [0.45, 0.3, 0.2]))
    if case == "gain":
        return Truth(rig, true_sensitivity_factor={"a2_y": 1.2})
    if case == "soft+gain":
        return Truth(rig, spring_scale={"soft2": 0.6}, true_sensitivity_factor={"a3_z": 0.8})
    if case == "friction":
        return Truth(rig, friction=("pad", 40.0, 1e-4))
    raise ValueError(case)


def write_case(out: Path, case: str, seed: int, peak: float | None, noise: str = "lab",
               samples: int = 4096):
    """The case's four CSV records and a manifest of the blows (name, file, point, direction)."""
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    truth = make_truth(case)
    fs = float(truth.rig["acquisition"]["sampling_rate"])
    t_hit0 = (truth.rig["acquisition"]["pre_trigger"] + 4) / fs
    manifest = []
    for name, point, dname, d in BLOWS:
        level = peak if peak is not None else float(np.exp(rng.uniform(np.log(5), np.log(200))))
        tc = rng.uniform(0.6e-3, 1.5e-3)
        t0 = t_hit0 + rng.uniform(0, 2) / fs
        hits = [(t0, level, tc)]
        if name == "E4":
            hits.append((t0 + 0.011, 0.35 * level, tc))
        cols, _ = record(truth, point, d, hits, rng, samples=samples, noise=noise)
        path = out / f"{name}.csv"
        write_csv(path, cols)
        manifest.append({"name": name, "file": str(path),
                         "point": ",".join(f"{1000 * c:g}mm" for c in point),
                         "dir": dname, "peak_n": level})
    (out / "manifest.json").write_text(json.dumps(
        {"case": case, "seed": seed, "modes_hz": modes_hz(truth).tolist(), "blows": manifest},
        indent=1))
    return manifest


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("case")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--peak", type=float, default=None)
    ap.add_argument("--noise", choices=["lab", "white"], default="lab")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    m = write_case(Path(a.out), a.case, a.seed, a.peak, a.noise)
    print(json.dumps(m))


if __name__ == "__main__":
    main()
