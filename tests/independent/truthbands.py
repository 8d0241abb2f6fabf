"""How far a hidden change shows above the noise, computed from the truth alone: the records of the
actual rig (as simulated, before noise) against the records the nominal rig would give under the
same blows, channel by channel and frequency band by band, against the white noise and ADC
quantisation the simulator added in that band. A band-residual-to-noise ratio of 5 says that the
model error in that band has 5x the rms of the noise there."""

from __future__ import annotations

import numpy as np

from .rigsim import Record, simulate
from .structure import Setup


def octave_bands(fs: float, lowest_hz: float = 12.5) -> list[tuple[float, float]]:
    """[0, lowest), then octaves up to the Nyquist frequency (Hz)."""
    edges = [0.0]
    f = lowest_hz
    while f < fs / 2:
        edges.append(f)
        f *= 2
    edges.append(fs / 2)
    return list(zip(edges[:-1], edges[1:]))


def band_energy(x: np.ndarray, fs: float, bands) -> np.ndarray:
    """Energy sum(x^2) of each column of x (N, channels) that lies in each band (bands, channels),
    by Parseval on the real FFT: the bands' energies add up to sum(x^2)."""
    n = x.shape[0]
    spec = np.abs(np.fft.rfft(x, axis=0)) ** 2 / n
    weight = np.full(spec.shape[0], 2.0)
    weight[0] = 1.0
    if n % 2 == 0:
        weight[-1] = 1.0
    spec *= weight[:, None]
    f = np.fft.rfftfreq(n, 1.0 / fs)
    out = []
    for lo, hi in bands:
        inside = (f >= lo) & ((f < hi) if hi < fs / 2 else (f <= hi))
        out.append(spec[inside].sum(axis=0))
    return np.array(out)


def noise_energy(record: Record, daq, bands) -> np.ndarray:
    """The expected energy of the white noise and the quantisation in each band (bands, channels):
    N sigma^2 times the band's share of 0..fs/2."""
    n, n_ch = record.volts.shape
    sigma2 = np.broadcast_to(np.asarray(record.noise_rms_v if record.noise_rms_v is not None else daq.noise_rms_v,
                                        float), (n_ch,)) ** 2
    if daq.adc_bits:
        lsb = (daq.adc_range[1] - daq.adc_range[0]) / 2 ** daq.adc_bits
        sigma2 = sigma2 + lsb ** 2 / 12
    share = np.array([(hi - lo) / (daq.sampling_rate / 2) for lo, hi in bands])
    return n * share[:, None] * sigma2[None, :]


def nominal_records(case, rng_seed: int = 0) -> list[Record]:
    """The records the nominal rig gives under the case's blows (its clean_volts are noise-free)."""
    nominal = case.nominal
    daq = case.actual.daq  # the same record length and sampling
    out = []
    for hits in case.records:
        setup = Setup(nominal.structure, nominal.accelerometers, nominal.force_sensor,
                      type(daq)(sampling_rate=daq.sampling_rate, n_samples=daq.n_samples, pre_trigger=daq.pre_trigger,
                                adc_bits=None, adc_range=daq.adc_range, amplifier_gain=daq.amplifier_gain,
                                aa_family=nominal.daq.aa_family, aa_order=nominal.daq.aa_order,
                                aa_cutoff_hz=nominal.daq.aa_cutoff_hz, oversample=daq.oversample),
                      hits)
        out.append(simulate(setup, np.random.default_rng(rng_seed), case.nominal_scale()))
    return out


def band_residual_to_noise(case, actual: list[Record], nominal: list[Record] | None = None) -> dict:
    """The largest sqrt(residual energy / noise energy) over records, channels and octave bands,
    where it is, and the whole table (records x bands x channels)."""
    nominal = nominal if nominal is not None else nominal_records(case)
    daq = case.actual.daq
    bands = octave_bands(daq.sampling_rate)
    table = []
    for a, b in zip(actual, nominal):
        res = band_energy(a.clean_volts - b.clean_volts, daq.sampling_rate, bands)
        table.append(np.sqrt(res / noise_energy(a, daq, bands)))
    table = np.array(table)
    r, k, c = np.unravel_index(int(np.argmax(table)), table.shape)
    return {"max_ratio": float(table[r, k, c]), "record": int(r), "band_hz": list(bands[k]),
            "channel": actual[r].names[c], "bands_hz": [list(b) for b in bands],
            "channels": list(actual[0].names), "ratios": table}
