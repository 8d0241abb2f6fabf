"""The measurement chain of one channel, from the physical quantity to the ADC code (thesis §2.3, §5.1).

sensor (sensitivity, resonance and amplifier time constant, Eq. 2.2) -> ICP coupler high-pass
(time constant TC1) -> anti-aliasing Butterworth low-pass with gain -> ADC input: offset, drift,
white noise, mains hum -> ADC (bits, input limits, clipping).

The analog part is one linear system per channel, discretised with a first-order hold at the
simulator's internal (oversampled) rate: exact for a piecewise-linear input.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import numpy as np
import scipy  # scipy.signal and scipy.linalg load on first use: fast `odsuite plugins`

from odsuite.api import ConfigError

#: the highest anti-aliasing order the simulated analog front end models (a rig file may state 16)
MAX_AAF_ORDER = 12


@dataclass(frozen=True)
class ChannelChain:
    """Analog chain and ADC of one channel. Volts at the ADC = sign * sensitivity * gain * quantity
    in the pass band. ``None`` time constants or resonance switch that element off."""

    sensitivity: float  # V per SI unit (true value; the Systeminfo holds the nominal one)
    sign: float = 1.0
    gain: float = 10.0  # anti-aliasing filter gain (Table A.1 G_f)
    sensor_tc: float | None = 0.5  # s, sensor's built-in amplifier (TC in Eq. 2.2)
    coupler_tc: float | None = 10.0  # s, ICP coupler / power supply (TC1 in Eq. 2.2)
    resonance_hz: float | None = 54_000.0  # sensor's mounted resonance (omega_n / 2 pi)
    resonance_damping: float = 0.03
    aaf_order: int = 8
    aaf_cutoff_hz: float | None = 1000.0
    # the low-pass's analog zeros, poles (rad/s) and gain where the rig declares another family than
    # Butterworth (elliptic, Chebyshev, Bessel); None: a Butterworth of aaf_order at aaf_cutoff_hz
    aaf_zpk: tuple[tuple[complex, ...], tuple[complex, ...], float] | None = None
    adc_bits: int = 12
    limit_low: float = -5.0  # V
    limit_high: float = 5.0  # V
    noise_rms: float = 0.0  # V at the ADC input
    offset: float = 0.0  # V
    drift: float = 0.0  # V/s, while the drift is linear (drift_profile)
    hum_amplitude: float = 0.0  # V
    hum_hz: float = 60.0

    def validate(self, where: str) -> None:
        """Raise ConfigError naming ``where`` (e.g. "channel 4") and the field at fault."""
        def bad(field: str, why: str) -> ConfigError:
            return ConfigError(f"{where}: chain field {field!r} {why}, got {getattr(self, field)!r}")

        for f in ("sensitivity", "gain"):
            if not (np.isfinite(getattr(self, f)) and getattr(self, f) > 0):
                raise bad(f, "must be > 0")
        for f in ("sensor_tc", "coupler_tc", "resonance_hz", "aaf_cutoff_hz"):
            v = getattr(self, f)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise bad(f, "must be > 0 or None")
        if not 0 < self.resonance_damping < 1:
            raise bad("resonance_damping", "must be in (0, 1)")
        if not 1 <= self.aaf_order <= MAX_AAF_ORDER:
            raise bad("aaf_order", f"must be 1..{MAX_AAF_ORDER}")
        if not 2 <= self.adc_bits <= 32:
            raise bad("adc_bits", "must be 2..32")
        if not self.limit_high > self.limit_low:
            raise bad("limit_high", f"must exceed limit_low={self.limit_low}")
        for f in ("noise_rms", "hum_amplitude"):
            if getattr(self, f) < 0:
                raise bad(f, "must be >= 0")

    def with_(self, **changes) -> ChannelChain:
        return replace(self, **changes)

    # -- analog part -------------------------------------------------------------------------
    def analog_zpk(self) -> tuple[np.ndarray, np.ndarray, float]:
        """Continuous-time zeros, poles (rad/s) and gain of the whole analog chain."""
        zeros: list[complex] = []
        poles: list[complex] = []
        k = self.sign * self.sensitivity * self.gain
        for tc in (self.sensor_tc, self.coupler_tc):  # j w TC / (1 + j w TC) = s / (s + 1/TC)
            if tc is not None:
                zeros.append(0.0)
                poles.append(-1.0 / tc)
        if self.resonance_hz is not None:  # 1 / (1 - (w/wn)^2 + 2 j zeta w/wn)
            wn, z = 2 * np.pi * self.resonance_hz, self.resonance_damping
            poles += [wn * (-z + 1j * np.sqrt(1 - z * z)), wn * (-z - 1j * np.sqrt(1 - z * z))]
            k *= wn * wn
        if self.aaf_cutoff_hz is not None and self.aaf_zpk is not None:
            zeros += list(self.aaf_zpk[0])
            poles += list(self.aaf_zpk[1])
            k *= self.aaf_zpk[2]
        elif self.aaf_cutoff_hz is not None:
            _, p, kb = scipy.signal.buttap(self.aaf_order)
            wc = 2 * np.pi * self.aaf_cutoff_hz
            poles += list(p * wc)
            k *= kb * wc**self.aaf_order
        return np.asarray(zeros, dtype=complex), np.asarray(poles, dtype=complex), float(k)

    def frequency_response(self, f_hz: np.ndarray) -> np.ndarray:
        """Analog response (V per SI unit) at ``f_hz``: Eq. 2.2 times the filter, gain and sign."""
        z, p, k = self.analog_zpk()
        _, h = scipy.signal.freqs_zpk(z, p, k, worN=2 * np.pi * np.asarray(f_hz, dtype=float))
        return h

    def discrete_sos(self, fs: float) -> np.ndarray:
        """Second-order sections of the analog chain, each section discretised with a first-order
        hold at ``fs`` (one high-order system would be ill-conditioned: poles span 0.1 Hz-54 kHz)."""
        z, p, k = self.analog_zpk()
        # the high-passes' zeros at 0, each with its pole (appended first); an elliptic low-pass's
        # zeros on the imaginary axis, a conjugate pair with each of its pole pairs, highest first
        at_zero = sum(1 for q in z if q == 0)
        sections: list[tuple[list, list]] = [([0.0], [pz]) for pz in p[:at_zero]]
        rest = p[at_zero:]
        upper = [q for q in rest if q.imag > 1e-9 * abs(q)]
        real = [q.real for q in rest if abs(q.imag) <= 1e-9 * abs(q)]
        zero_pairs = sorted((q for q in z if q != 0 and q.imag > 0), key=lambda q: -q.imag)
        upper = sorted(upper, key=lambda q: -q.imag) if zero_pairs else upper
        sections += [([zq, np.conj(zq)] if (zq := zero_pairs[i] if i < len(zero_pairs) else None) is not None
                      else [], [q, np.conj(q)]) for i, q in enumerate(upper)]
        sections += [([], real[i:i + 2]) for i in range(0, len(real), 2)]
        rows = [_foh_section(tuple(complex(q) for q in zs), tuple(complex(q) for q in ps), float(fs))
                for zs, ps in sections]
        sos = np.array(rows) if rows else np.array([[1.0, 0.0, 0.0, 1.0, 0.0, 0.0]])
        # overall gain: each section's own (_foh_section: unit DC gain where it has no zeros, else 1)
        # divided out of k, which holds them all
        if zero_pairs:
            own = [np.real(np.prod([-q for q in ps])) for zs, ps in sections if not zs]
            scale = k / np.prod(own) if own else k
        else:
            scale = k / np.real(np.prod([(-q) for q in rest])) if len(rest) else k
        sos[0, :3] *= scale
        return sos

    # -- ADC ----------------------------------------------------------------------------------
    @property
    def lsb(self) -> float:
        """Volts per ADC code: the input range spread over 2**bits codes."""
        return (self.limit_high - self.limit_low) / 2**self.adc_bits

    def quantise(self, volts: np.ndarray) -> np.ndarray:
        """Round to the nearest code of ``limit_low + k * lsb``, k = 0 .. 2**bits - 1 (clipping at
        both ends, as a bipolar NI range: -L .. L - lsb)."""
        codes = np.clip(np.round((volts - self.limit_low) / self.lsb), 0, 2**self.adc_bits - 1)
        return self.limit_low + codes * self.lsb

    def clipped(self, volts: np.ndarray) -> int:
        """Samples the ADC cannot represent (beyond half a code outside the range)."""
        half = 0.5 * self.lsb
        return int(np.count_nonzero((volts < self.limit_low - half) | (volts >= self.limit_high - half)))


@functools.lru_cache(maxsize=1024)
def _foh_section(zs: tuple[complex, ...], ps: tuple[complex, ...], fs: float) -> np.ndarray:
    """One unit-DC-gain second-order section discretised with a first-order hold at ``fs``: the
    same for every channel of one sensor kind, so computed once (4,000 channels took 5 minutes)."""
    ks = float(np.real(np.prod([-q for q in ps]))) if not zs else 1.0  # unit DC gain
    num, den = scipy.signal.zpk2tf(np.asarray(zs), np.asarray(ps), ks)
    bd, ad, _ = scipy.signal.cont2discrete((np.real(num), np.real(den)), 1.0 / fs, method="foh")
    bd = np.ravel(bd)
    row = np.concatenate([np.pad(bd, (0, 3 - len(bd))), np.pad(ad, (0, 3 - len(ad)))])
    row.flags.writeable = False  # shared by every caller
    return row


def run_analog(chain: ChannelChain, quantity: np.ndarray, fs: float) -> np.ndarray:
    """Analog output volts (before offset, noise and ADC) for ``quantity`` sampled at ``fs``."""
    return scipy.signal.sosfilt(chain.discrete_sos(fs), quantity)


#: the front end's drift is linear for this long (s), then settles exponentially over as long again:
#: warm-up drift is bounded, and a linear one at 1 mV/s had run a 10-minute operating record into
#: the ADC's limits after 7 minutes; records shorter than this are unchanged
DRIFT_LINEAR_S = 30.0


def drift_profile(t: np.ndarray) -> np.ndarray:
    """Seconds of drift at times ``t`` (s): t up to DRIFT_LINEAR_S, then settling (value and slope
    continuous) towards 2 DRIFT_LINEAR_S."""
    late = np.maximum(t - DRIFT_LINEAR_S, 0.0)
    return np.minimum(t, DRIFT_LINEAR_S) + DRIFT_LINEAR_S * -np.expm1(-late / DRIFT_LINEAR_S)


def adc_input_disturbances(chain: ChannelChain, n: int, fs: float, rng: np.random.Generator) -> np.ndarray:
    """Offset + drift (``drift_profile``) + white noise + mains hum, in volts, for ``n`` samples at ``fs``."""
    t = np.arange(n) / fs
    out = chain.offset + chain.drift * drift_profile(t)
    if chain.noise_rms:
        out = out + rng.normal(0.0, chain.noise_rms, n)
    if chain.hum_amplitude:
        out = out + chain.hum_amplitude * np.sin(2 * np.pi * chain.hum_hz * t + rng.uniform(0, 2 * np.pi))
    return out

