"""The second simulator: small-motion rigid bodies on springs (plus flexible modes and nonlinear
elements), sensor dynamics and a DAQ (anti-aliasing filter, multiplexed sampling, hum, drift,
noise, ADC), written from first principles so that its numbers do not share odsuite's code.

Coordinates: 6 per body [x y z rx ry rz] at its centre of mass (rig axes), then one modal
coordinate per flexible mode. A point p of body b moves by d + theta x (p - G) + sum phi_m(p) eta_m.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import linalg, signal
from scipy.interpolate import CubicSpline, PPoly

from .structure import GROUND, Accelerometer, Setup, Structure, mat3, vec3


def skew(r: np.ndarray) -> np.ndarray:
    """[r]x, so that skew(r) @ v == cross(r, v)."""
    x, y, z = r
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rigid_point_matrix(r: np.ndarray) -> np.ndarray:
    """3x6 map from [d, theta] to the displacement of a point at offset r: d + theta x r."""
    return np.hstack([np.eye(3), -skew(np.asarray(r, float))])


class Model:
    """Mass, stiffness and damping matrices of a Structure and the point maps that build them."""

    def __init__(self, structure: Structure):
        self.structure = structure
        self.body_index = {b.name: i for i, b in enumerate(structure.bodies)}
        self.n_rigid = 6 * len(structure.bodies)
        self.n = self.n_rigid + len(structure.modes)
        self.M = np.zeros((self.n, self.n))
        for i, b in enumerate(structure.bodies):
            self.M[6 * i:6 * i + 3, 6 * i:6 * i + 3] = b.mass * np.eye(3)
            self.M[6 * i + 3:6 * i + 6, 6 * i + 3:6 * i + 6] = np.asarray(b.inertia, float)
        self.K = np.zeros((self.n, self.n))
        self.C = np.zeros((self.n, self.n))
        for j, mode in enumerate(structure.modes):
            k = self.n_rigid + j
            w = 2 * np.pi * mode.frequency_hz
            self.M[k, k] = 1.0  # mass-normalised shape
            self.K[k, k] = w * w
            self.C[k, k] = 2 * mode.damping_ratio * w
        for s in structure.springs:
            L = self.relative_matrix(s.body, s.other, s.position)
            self.K += L.T @ mat3(s.stiffness) @ L
            self.C += L.T @ mat3(s.damping) @ L

    def point_matrix(self, body: str, point, sensor: str | None = None) -> np.ndarray:
        """3 x n map from the coordinates to the displacement of ``point`` on ``body`` (zero for
        ground: base motion enters separately)."""
        P = np.zeros((3, self.n))
        if body == GROUND:
            return P
        i = self.body_index[body]
        point = vec3(point)
        P[:, 6 * i:6 * i + 6] = rigid_point_matrix(point - vec3(self.structure.bodies[i].com))
        for j, mode in enumerate(self.structure.modes):
            if mode.body == body:
                P[:, self.n_rigid + j] = mode.at(point, sensor)
        return P

    def relative_matrix(self, body: str, other: str, point) -> np.ndarray:
        return self.point_matrix(body, point) - self.point_matrix(other, point)

    def mode_shapes(self) -> tuple[np.ndarray, np.ndarray]:
        """Undamped natural frequencies (Hz, ascending) and mass-normalised shapes (columns) from
        K v = w^2 M v."""
        w2, V = linalg.eigh(self.K, self.M)
        return np.sqrt(np.clip(w2, 0.0, None)) / (2 * np.pi), V

    def natural_frequencies(self) -> np.ndarray:
        return self.mode_shapes()[0]

    def state_space(self) -> tuple[np.ndarray, np.ndarray]:
        """A, B of x = [q, qdot] driven by generalised forces."""
        Minv = np.linalg.inv(self.M)
        A = np.block([[np.zeros((self.n, self.n)), np.eye(self.n)], [-Minv @ self.K, -Minv @ self.C]])
        B = np.vstack([np.zeros((self.n, self.n)), Minv])
        return A, B

    def generalized_forces(self, setup: Setup, t: np.ndarray, trigger_s: float) -> np.ndarray:
        """Hammer hits and base motion (through the ground springs) as (len(t), n) forces."""
        F = np.zeros((t.size, self.n))
        for hit in setup.hits:
            f = hit.force(t, trigger_s)
            P = self.point_matrix(hit.body, hit.point)
            F += np.outer(f, P.T @ vec3(hit.direction))
        base = self.structure.base_motion
        if base is not None:
            disp, vel, _ = base.motion(t)
            for s in self.structure.springs:
                if (s.body == GROUND) == (s.other == GROUND):
                    continue
                # the ground end moves with the base and pulls the moving end through K and C
                moving = s.other if s.body == GROUND else s.body
                G = rigid_point_matrix(vec3(s.position))
                P = self.point_matrix(moving, s.position)
                F += (disp @ G.T @ mat3(s.stiffness).T + vel @ G.T @ mat3(s.damping).T) @ P
        return F


def _foh_matrices(A: np.ndarray, B: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact discretisation for inputs linear between samples (first-order hold): from
    expm([[A, B, 0], [0, 0, I], [0, 0, 0]] h) = [[Phi, G1, G2], ...],
    x[k+1] = Phi x[k] + (G1 - G2/h) u[k] + (G2/h) u[k+1]."""
    n, m = B.shape
    big = np.zeros((n + 2 * m, n + 2 * m))
    big[:n, :n] = A
    big[:n, n:n + m] = B
    big[n:n + m, n + m:] = np.eye(m)
    E = linalg.expm(big * h)
    Phi, G1, G2 = E[:n, :n], E[:n, n:n + m], E[:n, n + m:]
    return Phi, G1 - G2 / h, G2 / h


def lti_response(A, B, C, D, u: np.ndarray, h: float) -> np.ndarray:
    """Output of x' = A x + B u, y = C x + D u from rest (C None: the states x), u (N, m) sampled
    every h and linear in between; a single-input system needs C and D. Written here (not scipy.signal.lsim) so the generator owns its
    integrator; the modal form runs one first-order recursion per eigenvalue (scipy.signal.lfilter)
    instead of a Python loop over samples. A single-input system (m = 1) filters every column of u
    independently, so many channels share one call."""
    A, B = np.atleast_2d(np.asarray(A, float)), np.asarray(B, float).reshape(len(A), -1)
    u = np.asarray(u, float).reshape(len(u), -1)
    siso = B.shape[1] == 1
    # a diagonal similarity (A = T Ab T^-1) keeps the eigenvectors well conditioned: a filter's
    # companion form scaled by w^order otherwise has cond(V) ~ 1e12
    A, T = linalg.matrix_balance(A, permute=False)
    B = np.linalg.solve(T, B)
    Phi, P0, P1 = _foh_matrices(A, B, h)
    lam, V = np.linalg.eig(Phi)
    if np.linalg.cond(V) >= 1e8:
        raise ValueError("repeated eigenvalues (a body free along some axis?): give every body springs")
    # x[k+1] = Phi x[k] + P0 u[k] + P1 u[k+1]; in modal coordinates z = V^-1 x, one pole each
    W = np.linalg.inv(V)
    if siso:  # y = Re(sum_k c_k z_k) + D u, one mode at a time
        w0, w1 = W @ P0[:, 0], W @ P1[:, 0]
        c = (np.atleast_2d(np.asarray(C, float))[0] * np.diag(T)) @ V
        y = float(np.atleast_2d(D)[0, 0]) * u
        for k, p in enumerate(lam):
            drive = w0[k] * u
            drive[:-1] += w1[k] * u[1:]
            y += (c[k] * signal.lfilter([0.0, 1.0], [1.0, -p], drive, axis=0)).real
        return y
    drive = u @ (W @ P0).T
    drive[:-1] += u[1:] @ (W @ P1).T
    z = np.empty(drive.shape, dtype=complex)
    for k, p in enumerate(lam):
        z[:, k] = signal.lfilter([0.0, 1.0], [1.0, -p], drive[:, k])
    x = (z @ (V.T * np.diag(T))).real
    if C is None:
        return x
    return x @ np.atleast_2d(C).T + u @ np.atleast_2d(D).T


class NonlinearForces:
    """Cubic, Coulomb and contact forces. Every element acts along one row of ``E`` (3 rows per
    nonlinear spring, 1 per contact), so one matrix product gives all element deflections; RK4
    evaluates this four times per fine step, and per-element Python loops would dominate."""

    def __init__(self, model: Model):
        s = model.structure
        springs = [sp for sp in s.springs if sp.cubic is not None or sp.friction is not None]
        rows = [model.relative_matrix(sp.body, sp.other, sp.position) for sp in springs]
        rows += [(model.relative_matrix(c.body, c.other, c.position).T @ vec3(c.axis))[None, :] for c in s.contacts]
        self.E = np.vstack(rows) if rows else np.zeros((0, model.n))
        pad = np.zeros(len(s.contacts))

        def per_row(values):
            return np.concatenate([np.zeros(3) if v is None else vec3(v) for v in values] + [pad])

        self.cubic = per_row([sp.cubic for sp in springs])
        self.friction = per_row([sp.friction for sp in springs])
        self.slip_velocity = np.concatenate([np.repeat([sp.friction_velocity for sp in springs], 3), pad + 1.0])
        none = np.zeros(3 * len(springs))
        # spring rows never touch a stop: an infinite clearance
        self.clearance = np.concatenate([none + np.inf, [c.clearance for c in s.contacts]])
        self.contact_k = np.concatenate([none, [c.stiffness for c in s.contacts]])
        self.contact_c = np.concatenate([none, [c.damping for c in s.contacts]])
        self.any_cubic, self.any_friction = bool(self.cubic.any()), bool(self.friction.any())
        self.any_contact = bool(s.contacts)

    def element_forces(self, d: np.ndarray, dv: np.ndarray) -> np.ndarray:
        """Force of each element row (tension positive) from its deflection and rate."""
        out = self.cubic * d ** 3 if self.any_cubic else np.zeros_like(d)
        if self.any_friction:
            out += self.friction * np.tanh(dv / self.slip_velocity)
        if self.any_contact:
            over = np.abs(d) - self.clearance
            out += np.where(over > 0, np.sign(d) * self.contact_k * over + self.contact_c * dv, 0.0)
        return out

    def __call__(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Generalised forces for one state (n,) or whole histories (N, n)."""
        return -(self.element_forces(q @ self.E.T, v @ self.E.T) @ self.E)


def rk4_response(model: Model, forces: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """q, qdot (N, n) of the nonlinear structure by classical fixed-step RK4 on the fine grid; the
    forces are linear between grid points (the same hold as lti_response)."""
    n = model.n
    Minv = np.linalg.inv(model.M)
    A, _ = model.state_space()
    nl = NonlinearForces(model)
    m = nl.E.shape[0]
    to_elements = linalg.block_diag(nl.E, nl.E)  # x -> [deflections, rates]
    from_elements = np.vstack([np.zeros((n, m)), -Minv @ nl.E.T])
    accel = forces @ Minv.T
    half = 0.5 * (accel[1:] + accel[:-1])

    def rate(x, a):
        y = to_elements @ x
        dx = A @ x + from_elements @ nl.element_forces(y[:m], y[m:])
        dx[n:] += a
        return dx

    N = forces.shape[0]
    X = np.zeros((N, 2 * n))
    x = np.zeros(2 * n)
    for i in range(N - 1):
        k1 = rate(x, accel[i])
        k2 = rate(x + 0.5 * h * k1, half[i])
        k3 = rate(x + 0.5 * h * k2, half[i])
        k4 = rate(x + h * k3, accel[i + 1])
        x = x + (h / 6) * (k1 + 2 * (k2 + k3) + k4)
        X[i + 1] = x
    if not np.all(np.isfinite(X)):
        raise ValueError(f"RK4 diverged at the step {h:.3g} s: raise the oversampling (stiff contact or friction)")
    return X[:, :n], X[:, n:]


def structure_response(model: Model, forces: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qdot, qddot (N, n): exact for a linear structure, RK4 otherwise."""
    A, B = model.state_space()
    total = forces
    if model.structure.is_linear:
        X = lti_response(A, B, None, None, forces, h)
        q, v = X[:, :model.n], X[:, model.n:]
    else:
        q, v = rk4_response(model, forces, h)
        total = forces + NonlinearForces(model)(q, v)
    acc = (total - q @ model.K.T - v @ model.C.T) @ np.linalg.inv(model.M).T
    return q, v, acc


def axis_accelerations(model: Model, sensors: list[Accelerometer], acc: np.ndarray,
                       base_acc: np.ndarray | None) -> np.ndarray:
    """Acceleration along each sensor's axis at its position (small motion), (N, len(sensors))."""
    on_body = np.zeros((model.n, len(sensors)))
    on_ground = np.zeros((6, len(sensors)))
    for j, s in enumerate(sensors):
        if s.body == GROUND:
            on_ground[:, j] = rigid_point_matrix(vec3(s.position)).T @ vec3(s.axis)
        else:
            on_body[:, j] = model.point_matrix(s.body, s.position, s.name).T @ vec3(s.axis)
    out = acc @ on_body
    if base_acc is not None:
        out += base_acc @ on_ground
    return out


def sensor_dynamics(sensor: Accelerometer) -> list[tuple]:
    """The sensor's own transfer functions as state-space blocks, in signal order."""
    blocks = []
    if sensor.resonance_hz is not None:
        w = 2 * np.pi * sensor.resonance_hz
        blocks.append(signal.tf2ss([w * w], [1.0, 2 * sensor.resonance_damping * w, w * w]))
    if sensor.iepe_corner_hz is not None:
        wc = 2 * np.pi * sensor.iepe_corner_hz
        blocks.append(signal.tf2ss([1.0, 0.0], [1.0, wc]))
    return blocks


def anti_aliasing(daq) -> tuple | None:
    """The analog anti-aliasing filter as a state-space block (None: no filter)."""
    if daq.aa_family is None:
        return None
    wc = 2 * np.pi * daq.aa_cutoff_hz
    if daq.aa_family == "butter":
        z, p, k = signal.butter(daq.aa_order, wc, analog=True, output="zpk")
    elif daq.aa_family == "ellip":
        z, p, k = signal.ellip(daq.aa_order, daq.aa_ripple_db, daq.aa_attenuation_db, wc, analog=True, output="zpk")
    else:
        raise ValueError(f"anti-aliasing family {daq.aa_family!r}: expected 'butter' or 'ellip'")
    return signal.zpk2ss(z, p, k)


@dataclass
class Record:
    """One simulated record: what the ADC delivered and the noise-free truth behind it."""

    time: np.ndarray  # s, the nominal sample instants (channel 0), trigger at pre_trigger
    volts: np.ndarray  # (n_samples, n_channels), after the ADC
    clean_volts: np.ndarray  # the same before hum, drift, noise and ADC
    names: list[str]
    units: list[str]  # physical unit per channel
    scale: np.ndarray  # nominal volts per physical unit (sign included), as a lab would set it
    force_n: np.ndarray  # true hammer force at the nominal sample instants
    accelerations: np.ndarray  # true acceleration along each accelerometer axis at its own instant
    q: np.ndarray  # coordinates at the nominal sample instants (n_samples, n)
    qdd: np.ndarray  # their second derivatives
    trigger_s: float
    noise_rms_v: np.ndarray | None = None  # the white noise added per channel (V rms)


def simulate(setup: Setup, rng: np.random.Generator, nominal_scale: dict[str, float] | None = None) -> Record:
    """Simulate one record. ``nominal_scale`` maps a channel name to the volts-per-unit a lab
    believes (the rig file's sign * sensitivity); default: the sensor's own without its errors."""
    daq = setup.daq
    fs = daq.sampling_rate
    fine = fs * daq.oversample
    h = 1.0 / fine
    trigger = daq.pre_trigger / fs
    n_ch = max([a.channel for a in setup.accelerometers] + ([setup.force_sensor.channel] if setup.force_sensor else [])) + 1
    # one spare nominal sample at the end covers the last channel's scan delay
    late = [k * daq.scan_skew_s + daq.channel_delay_s.get(k, 0.0) for k in range(n_ch)]  # s, per channel
    t_end = (daq.n_samples + 1) / fs + max(late + [0.0])
    t_fine = np.arange(int(np.ceil(t_end * fine)) + 2) * h
    model = Model(setup.structure)
    forces = model.generalized_forces(setup, t_fine, trigger)
    q, _, acc = structure_response(model, forces, h)
    base_acc = setup.structure.base_motion.motion(t_fine)[2] if setup.structure.base_motion else None
    hammer = sum((hit.force(t_fine, trigger) for hit in setup.hits), np.zeros_like(t_fine))
    n_acc = len(setup.accelerometers)
    analog = np.zeros((t_fine.size, n_ch))
    names = [f"aux{k}" for k in range(n_ch)]
    units = ["V"] * n_ch
    scale = np.ones(n_ch)
    nominal_scale = nominal_scale or {}
    truth = axis_accelerations(model, setup.accelerometers, acc, base_acc)
    measured = truth.copy()
    alike: dict[tuple, list[int]] = {}  # sensors of equal dynamics are filtered in one call
    for j, s in enumerate(setup.accelerometers):
        alike.setdefault((s.resonance_hz, s.resonance_damping, s.iepe_corner_hz), []).append(j)
    for columns in alike.values():
        for A, B, C, D in sensor_dynamics(setup.accelerometers[columns[0]]):
            measured[:, columns] = lti_response(A, B, C, D, measured[:, columns], h)
    for j, s in enumerate(setup.accelerometers):
        analog[:, s.channel] = s.sign * s.sensitivity * (1 + s.gain_error) * daq.amplifier_gain * measured[:, j]
        names[s.channel], units[s.channel] = s.name, "m/s^2"
        scale[s.channel] = nominal_scale.get(s.name, s.sign * s.sensitivity) * daq.amplifier_gain
    load_cell = setup.force_sensor
    if load_cell is not None:
        analog[:, load_cell.channel] = (load_cell.sign * load_cell.sensitivity * (1 + load_cell.gain_error)
                                        * daq.amplifier_gain * hammer)
        names[load_cell.channel], units[load_cell.channel] = load_cell.name, "N"
        scale[load_cell.channel] = (nominal_scale.get(load_cell.name, load_cell.sign * load_cell.sensitivity)
                                    * daq.amplifier_gain)
    aa = anti_aliasing(daq)
    if aa is not None:
        analog = lti_response(*aa, analog, h)
    t = np.arange(daq.n_samples) / fs
    # multiplexed scan: channel k is sampled k * skew after channel 0 (a spline between fine points)
    analog_spline = CubicSpline(t_fine, analog)
    volts_clean = np.column_stack([PPoly(analog_spline.c[..., k], t_fine)(t + late[k])
                                   for k in range(n_ch)])
    truth_spline = CubicSpline(t_fine, truth)
    truth_acc = np.column_stack([PPoly(truth_spline.c[..., j], t_fine)(t + late[s.channel])
                                 for j, s in enumerate(setup.accelerometers)]).reshape(t.size, n_acc)
    noise = np.broadcast_to(np.asarray(daq.noise_rms_v, float), (n_ch,)).copy()
    if daq.noise_fraction:
        signal_rms = np.sqrt(np.mean(volts_clean[daq.pre_trigger:] ** 2, axis=0))
        noise = np.sqrt(noise ** 2 + (daq.noise_fraction * signal_rms) ** 2)
        daq = replace(daq, noise_rms_v=noise)
    volts = volts_clean + daq_disturbances(daq, t, n_ch, rng)
    volts = adc(volts, daq)
    q_nominal, qdd_nominal = CubicSpline(t_fine, q)(t), CubicSpline(t_fine, acc)(t)
    force_nominal = CubicSpline(t_fine, hammer)(t)
    return Record(time=t, volts=volts, clean_volts=volts_clean, names=names,
                  units=units, scale=scale, force_n=force_nominal, accelerations=truth_acc, q=q_nominal, qdd=qdd_nominal,
                  trigger_s=trigger, noise_rms_v=noise)


def daq_disturbances(daq, t: np.ndarray, n_ch: int, rng: np.random.Generator) -> np.ndarray:
    """Mains hum (random phase per channel), linear drift, white noise, 1/f noise, a white noise
    shared by every channel and a band of ambient vibration, (len(t), n_ch) volts."""
    hum = np.broadcast_to(np.asarray(daq.hum_v, float), (n_ch,))
    drift = np.broadcast_to(np.asarray(daq.drift_v_per_s, float), (n_ch,))
    noise = np.broadcast_to(np.asarray(daq.noise_rms_v, float), (n_ch,))
    phase = rng.uniform(0, 2 * np.pi, n_ch)
    out = hum[None, :] * np.sin(2 * np.pi * daq.hum_hz * t[:, None] + phase[None, :])
    out += drift[None, :] * t[:, None]
    out += noise[None, :] * rng.standard_normal((t.size, n_ch))
    corner = np.broadcast_to(np.asarray(daq.flicker_corner_hz, float), (n_ch,))
    if corner.any():  # drawn last: records without it keep their draws
        f = np.fft.rfftfreq(t.size, t[1] - t[0])
        shape = np.zeros_like(f)
        shape[1:] = 1.0 / np.sqrt(f[1:])  # density times corner / f, from the white level's
        spectrum = np.fft.rfft(rng.standard_normal((t.size, n_ch)), axis=0) * shape[:, None]
        level = np.broadcast_to(np.asarray(daq.flicker_v, float), (n_ch,)) * np.sqrt(corner)
        out += level[None, :] * np.fft.irfft(spectrum, t.size, axis=0)
    if daq.common_v:  # drawn after the rest: records without it keep their draws
        out += daq.common_v * rng.standard_normal(t.size)[:, None]
    ambient = np.broadcast_to(np.asarray(daq.ambient_v, float), (n_ch,))
    if ambient.any():  # drawn after the rest: records without it keep their draws
        f = np.fft.rfftfreq(t.size, t[1] - t[0])
        x = f / daq.ambient_hz
        gain = 1.0 / np.sqrt((1.0 - x ** 2) ** 2 + (x / daq.ambient_q) ** 2)  # a resonance's magnitude
        band = np.fft.irfft(np.fft.rfft(rng.standard_normal((t.size, n_ch)), axis=0) * gain[:, None], t.size, axis=0)
        band /= np.sqrt(np.mean(band ** 2, axis=0))
        out += ambient[None, :] * band
    return out


def adc(volts: np.ndarray, daq) -> np.ndarray:
    """Clip to the ADC range and round to its 2**bits levels (mid-tread, LSB = range / 2**bits)."""
    lo, hi = daq.adc_range
    if daq.adc_bits is None:
        return np.clip(volts, lo, hi)
    lsb = (hi - lo) / 2 ** daq.adc_bits
    code = np.clip(np.round((volts - lo) / lsb), 0, 2 ** daq.adc_bits - 1)
    return lo + code * lsb
