"""The virtual rig: a truth model struck by a hammer, seen through the measurement chain and the DAQ.

The DAQ runs continuously; the trigger fires on the first force sample that crosses the level with
the set slope once ``pretrigger`` samples are in the buffer, and the record holds ``pretrigger``
samples before that sample and the rest after it, as an NI reference trigger does. Everything random
(when the first hit arrives, noise, offsets, drift, hum phase) comes from one numpy Generator seeded
by ``seed``: one seed, one record.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from odsuite_plugins.daq_sim.chain import (
    MAX_AAF_ORDER,
    ChannelChain,
    adc_input_disturbances,
    run_analog,
)
from odsuite_plugins.daq_sim.hammer import Hit, half_sine_force
from odsuite_plugins.daq_sim.operating import (
    DEFAULT_BASE_RMS,
    DEFAULT_FORCE_RMS,
    GROUND_KINDS,
    ground_accelerations,
    operating_forces,
    parse_operating,
    rotation_length,
)
from odsuite_plugins.daq_sim.options import (MAX_ADC_BITS, MAX_NOISE_SCALE, MAX_PEAK_N, MIN_ADC_BITS, MIN_PEAK_N,
                                             OPTIONS)
from odsuite_plugins.daq_sim.scenarios import SCENARIOS
from odsuite_plugins.daq_sim.scenarios import scenario as get_scenario

from odsuite.contracts.daq import (
    READING,
    WAITING,
    AcquisitionSettings,
    Progress,
    Recording,
    channel_name,
    check_record_fits,
    rig_systeminfo,
)
from odsuite.api import ConfigError, HardwareError
from odsuite.api import Excitation
from odsuite.api import Rig
from odsuite.api import SensorType, Systeminfo

#: ``truth(force, fs, point, direction[, body=NAME]) -> accelerations``: force (N) sampled at fs;
#: returns (samples x sensors) m/s^2 along each rig accelerometer's axis at its position, in
#: ``rig.accelerometers`` order; ``body`` is passed only when the experimenter names the body hit.
#: A truth that also has ``ground(accelerations, fs)`` (samples x 6, the ground's rigid acceleration:
#: m/s^2 along x, y, z, rad/s^2 about them through the rig origin) can record base motion.
Truth = Callable[[np.ndarray, float, np.ndarray, np.ndarray], np.ndarray]

#: without a declared anti-aliasing filter the thesis's 1 kHz one is drawn, but never above this
#: fraction of the record's rate: every card filters below its Nyquist frequency, and a 1 kHz
#: filter at 1024 samples/s let a hammer blow alias into the record (a perfect model of a rig
#: written from docs/rig-format.md then read 21x its floor)
ANTI_ALIAS_RATE_FRACTION = 0.4
#: bipolar input ranges (V) of an NI E-series card (AT-MIO-16E-2): the card uses the smallest one
#: that holds the limits the experimenter sets, e.g. -2..3 V is read on +-5 V
E_SERIES_RANGES = (0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0)


#: a hammer record's internal rate (Hz) at least: the blow's half-sine and the structure's response
#: are held linear between its samples (first-order hold), which at 8 x 5120 Hz read 0.6 % high at
#: 1 kHz and 2 % at 1.8 kHz against the band-limited records the model sees; a perfect model of a
#: 5120 Hz rig then failed its nulls at 0.1x the thesis's noise (800-2560 Hz cells 3x their floor).
#: An operating record's smooth load keeps the least
FINE_RATE_HZ = 160e3
#: ... with at least this and at most that many internal steps per sample
OVERSAMPLE_RANGE = (8, 64)
#: ... and at most this many internal steps in all (memory: every channel at the internal rate)
FINE_STEPS_MAX = 1 << 23


def default_oversample(settings) -> int:
    """A hammer record's internal steps per sample: the thesis's 20 kHz rate 8 times, slower rates
    more (FINE_RATE_HZ), a long record fewer (FINE_STEPS_MAX), never fewer than 8."""
    need = int(np.ceil(FINE_RATE_HZ / max(float(settings.sampling_rate), 1.0)))
    room = FINE_STEPS_MAX // max(int(settings.n_samples), 1)
    return int(max(min(need, OVERSAMPLE_RANGE[1], room), OVERSAMPLE_RANGE[0]))


def adc_range(low: float, high: float) -> float:
    """Half-width of the smallest E-series range holding [low, high] (the largest if none does)."""
    need = max(abs(low), abs(high))
    return next((r for r in E_SERIES_RANGES if r >= need), E_SERIES_RANGES[-1])


def default_chains(rig: Rig, systeminfo: Systeminfo, *, noise: float = 1.0,
                   adc_bits: int | None = None) -> dict[int, ChannelChain]:
    """The thesis's chain for every channel: ICP sensors (sensitivities: the rig's sensors, the
    Systeminfo's load cell), 1 kHz 8th-order anti-aliasing (at most ANTI_ALIAS_RATE_FRACTION of the rate) with the Systeminfo's gain (§5.1), a
    12-bit ADC (or ``adc_bits``) on the E-series range that holds the Systeminfo's limits.

    Noise levels are typical of the thesis's Fig. A.1 floor (a few LSB), scaled by ``noise`` (True
    is 1, False 0); offsets and drift set the scale of their random per-record values (drawn from
    the seed). What the rig's ``[acquisition]`` table declares replaces the thesis's front end: the
    IEPE corner, the sensors' resonance (none where a rig with the table declares none, and the
    load cell flat, as the model takes them), the anti-aliasing filter's order and cut-off (drawn
    as a Butterworth), the ADC's bits and range.
    """
    acq = rig.acquisition
    sensor_front: dict = {}
    everywhere: dict = {}
    aa = acq.anti_aliasing if acq is not None else None
    if acq is not None:
        if acq.iepe_corner_hz:
            sensor_front.update(sensor_tc=1.0 / (2 * np.pi * acq.iepe_corner_hz), coupler_tc=None)
        # the sensors' resonance the rig declares, or none: a rig that describes its front end is
        # simulated as described (undeclared, the thesis's 54 kHz accelerometer and 36 kHz load-cell
        # resonances lagged the accelerations 0.1 us behind the force: at 200 N a null's 800-1600 Hz
        # cell read 2.5x its floor and a scan skew of 7 ns was "significant")
        sensor_front.update(resonance_hz=acq.sensor_resonance_hz or None,
                            resonance_damping=acq.sensor_resonance_damping)
        if acq.adc_bits:
            everywhere["adc_bits"] = acq.adc_bits
        if acq.adc_range is not None:
            everywhere.update(limit_low=acq.adc_range[0], limit_high=acq.adc_range[1])
    if aa is not None and aa.order > MAX_AAF_ORDER:
        raise ConfigError(f"{rig.source or 'rig ' + repr(rig.name)} [acquisition] field 'anti_aliasing.order': the "
                          f"simulated DAQ models orders 1 to {MAX_AAF_ORDER}, got {aa.order}")
    filtered = {"aaf_order": aa.order, "aaf_cutoff_hz": aa.cutoff_hz} if aa is not None else {}
    if aa is not None and aa.family != "butterworth":  # the declared family, as the model predicts through it
        zf, pf, kf = aa.zpk()
        filtered["aaf_zpk"] = (tuple(complex(q) for q in zf), tuple(complex(q) for q in pf), float(kf))
    chains: dict[int, ChannelChain] = {}
    for ch in range(rig.channel_count):
        info = systeminfo.channels[ch]
        r = adc_range(info.limit_low, info.limit_high)
        sensor = rig.sensor_on_channel(ch)
        if ch == rig.force_channel:  # a load cell the model takes as flat, where the rig declares its front end
            chain = ChannelChain(sensitivity=info.sensitivity, sensor_tc=50.0, coupler_tc=None,
                                 resonance_hz=36_000.0 if acq is None else None, noise_rms=1.0e-3, offset=3e-3)
        elif sensor is not None:
            if sensor.sensitivity is None:
                raise ConfigError(f"rig {rig.name!r}: sensor {sensor.name!r} (channel {ch}) has no sensitivity")
            chain = ChannelChain(sensitivity=sensor.sensitivity, sign=sensor.sign,
                                 noise_rms=0.3e-3, offset=5e-3, drift=1e-3)
        else:  # an unused input (Table E.3 channel 1): noise only
            chain = ChannelChain(sensitivity=1.0, sensor_tc=None, coupler_tc=None, resonance_hz=None,
                                 noise_rms=1.0e-3)
        chain = replace(chain, **{"gain": info.daq_gain, "limit_low": -r, "limit_high": r, **everywhere})
        if sensor is not None and ch != rig.force_channel and sensor.quantity == "acceleration":
            chain = replace(chain, **sensor_front)
        if filtered and (ch != rig.force_channel or aa.force_channel):
            chain = replace(chain, **filtered)
        elif filtered:  # a force channel that bypasses the declared filter passes none: not the thesis's 1 kHz
            chain = replace(chain, aaf_cutoff_hz=None)
        elif chain.aaf_cutoff_hz is not None:
            chain = replace(chain, aaf_cutoff_hz=min(chain.aaf_cutoff_hz, ANTI_ALIAS_RATE_FRACTION * info.sampling_rate))
        if adc_bits is not None:
            chain = replace(chain, adc_bits=adc_bits)
        chain = replace(chain, noise_rms=chain.noise_rms * noise, offset=chain.offset * noise,
                        drift=chain.drift * noise, hum_amplitude=chain.hum_amplitude * noise)
        chain.validate(f"rig {rig.name!r} channel {ch}")
        chains[ch] = chain
    return chains


def find_trigger(force_volts: np.ndarray, level: float, slope: str, start: int) -> int | None:
    """Index of the first sample ``i >= max(start, 1)`` where the force crosses ``level``:
    rising ``x[i-1] < level <= x[i]``, falling ``x[i-1] > level >= x[i]``; None if it never does."""
    start = max(start, 1)
    prev, cur = force_volts[start - 1:-1], force_volts[start:]
    hit = (prev < level) & (cur >= level) if slope == "rising" else (prev > level) & (cur <= level)
    idx = np.flatnonzero(hit)
    return int(idx[0]) + start if idx.size else None


class SimulatedRig:
    """The ``sim`` acquisition backend."""

    name = "sim"
    description = "the simulated rig: the rig's model struck by a virtual hammer, through ADC chains"
    #: the thesis tests ``scenario`` names: name -> Scenario (description, point, direction, hits)
    scenarios = SCENARIOS
    options = OPTIONS

    def __init__(self, truth_factory: Callable[..., Truth] | None = None) -> None:
        self._truth_factory = truth_factory

    def record(
        self,
        rig: Rig | None,
        settings: AcquisitionSettings,
        *,
        progress: Progress | None = None,
        scenario: str | None = None,
        seed: int | None = 0,
        point: Sequence[float] | None = None,
        direction: Sequence[float] | None = None,
        hits: Sequence[Hit] | None = None,
        truth: Truth | None = None,
        effects: Sequence[tuple[str, Mapping[str, Any]]] = (),
        chains: Mapping[int, ChannelChain] | None = None,
        oversample: int | None = None,
        noise: float = 1.0,
        force_peak: float | None = None,
        truth_rig: str | None = None,
        adc_bits: int | None = None,
        force_body: str | None = None,
        contact_ms: float | None = None,
        operating: str | None = None,
        force_rms: float | None = None,
        base_rms: float | None = None,
    ) -> Recording:
        """Strike the virtual rig and return the triggered record.

        ``scenario`` ("T1".."T8", default T1 when no point is given) gives point, direction and
        hits (without one: a 20 N, 0.5 ms hit); ``point`` (m, rig frame),
        ``direction`` and ``hits`` override it. ``truth`` replaces the rig's default model (with
        ``effects`` applied: hidden from the Systeminfo). ``chains`` replaces channels' chains
        (e.g. a sensor whose true sensitivity differs from its nominal one). ``truth_rig``: a rig
        file whose model, sensor axes, positions and sensitivities make the record instead.
        ``operating`` (random, sweep, unbalance:HZ) records a running machine instead
        (``force_rms``), base-random the ground moving under it (``base_rms``): see
        :meth:`_operating_record`.
        """
        if oversample is None:
            oversample = OVERSAMPLE_RANGE[0] if operating is not None else default_oversample(settings)
        _check_options(rig, settings, oversample, seed, noise, adc_bits, operating, force_rms, hits, force_peak,
                       contact_ms)
        ground = operating is not None and parse_operating(operating, settings.sampling_rate).kind in GROUND_KINDS
        if base_rms is not None and not ground:
            raise ConfigError("--base-rms sets the ground's motion: give --operating base-random too")
        if ground:
            if force_rms is not None or point is not None or direction is not None or scenario is not None:
                raise ConfigError(f"--operating {operating}: the ground moves, no force acts; drop --force-rms, "
                                  "--force-point, --force-dir and --scenario")
            return self._operating_record(rig, settings, operating, None, None, truth, effects, chains,
                                          int(oversample), noise, seed, progress,
                                          DEFAULT_BASE_RMS if base_rms is None else base_rms, truth_rig, adc_bits)
        sc, point, direction = _force_line(scenario, point, direction)
        if operating is not None:
            return self._operating_record(rig, settings, operating, point, direction, truth, effects, chains,
                                          int(oversample), noise, seed, progress,
                                          DEFAULT_FORCE_RMS if force_rms is None else force_rms, truth_rig,
                                          adc_bits)
        hits = _scaled_hits(hits, sc, force_peak, contact_ms)
        systeminfo = rig_systeminfo(rig, settings.sampling_rate)
        truth, true_sensitivity = self._truth(rig, truth, effects, truth_rig)
        all_chains = _record_chains(rig, systeminfo, chains, noise, adc_bits, true_sensitivity)
        volts, force = _struck_stream(rig, settings, hits, truth, all_chains, point, direction, force_body,
                                      int(oversample), np.random.default_rng(seed))
        raw, clipped = _triggered(rig, settings, all_chains, volts)
        names = [channel_name(rig, ch) for ch in range(rig.channel_count)]
        # a scenario's hits scaled by --force-peak are still that scenario (the source says the peak)
        label = (sc.name if sc is not None and (hits == list(sc.hits) or force_peak is not None or contact_ms is not None)
                 else "custom")
        n = settings.n_samples
        rec = Recording(
            chunks=_chunks(raw, settings.chunk_size, progress),
            n_samples=n, sampling_rate=settings.sampling_rate, pretrigger=settings.pretrigger,
            systeminfo=systeminfo,
            excitation=Excitation(force_channel=rig.force_channel, point=point, direction=direction, body=force_body),
            channel_names=names,
            source=f"daq_sim scenario={label} seed={seed} hits={len(hits)} oversample={oversample}"
                   + (f" force_peak={force_peak:g}N" if force_peak is not None else "")
                   + (f" contact={contact_ms:g}ms" if contact_ms is not None else ""),
            clipped={ch: c for ch, c in clipped.items() if c},
        )
        if progress:
            progress(WAITING, 0, n)
        return rec

    def _operating_record(self, rig, settings, operating, point, direction, truth, effects, chains, oversample,
                          noise, seed, progress, rms, truth_rig=None, adc_bits=None) -> Recording:
        """A running machine: the operating load at ``point`` (its line, or the rotor's axis, along
        ``direction``; ``rms`` its force, N), or the ground's random motion (``rms`` its
        acceleration, m/s^2), for the whole record, no trigger. The force channel's input is left
        open (no load cell: the ADC's noise only) and named as an unused input; no excitation is stored."""
        fs, n = settings.sampling_rate, settings.n_samples
        load = parse_operating(operating, fs)
        truth, true_sensitivity = self._truth(rig, truth, effects, truth_rig)
        rng = np.random.default_rng(seed)
        fine = fs * oversample
        # a settling lead: the record starts once the machine runs steadily (five time constants of
        # the slowest rig mode are far below a second; the sensors' own high-passes settle with it)
        lead = int(round(1.0 * fs))
        n_fine = (lead + n) * oversample
        sensors = rig.accelerometers
        if load.kind in GROUND_KINDS:
            if not hasattr(truth, "ground"):
                raise ConfigError(f"--operating {load}: this truth has no ground-motion input")
            length = rotation_length(np.array([s.position for s in sensors]))
            acc = np.asarray(truth.ground(ground_accelerations(n_fine, rms, length, rng), fine), dtype=float)
            what = f"base_rms={rms:g}m/s^2 rotation_rms={rms / length:.4g}rad/s^2 length_m={length:.4g}"
        else:
            loads = operating_forces(load, n_fine, fine, fs, direction, rms, rng)
            acc = sum(np.asarray(truth(f, fine, point, d), dtype=float) for f, d in loads)
            where = ",".join(f"{1e3 * v:g}" for v in point)
            axis = ",".join(f"{v:g}" for v in direction)
            what = f"force_rms={rms:g}N point_mm={where} direction={axis}"
        if acc.shape != (n_fine, len(sensors)):
            raise HardwareError(f"simulator: the truth model returned shape {acc.shape}, expected {(n_fine, len(sensors))}")
        systeminfo = rig_systeminfo(rig, fs)
        fch = rig.force_channel
        open_input = replace(systeminfo.channels[fch], sensor_type=SensorType.NONE, location="", serial="")
        systeminfo = Systeminfo([open_input if k == fch else c for k, c in enumerate(systeminfo.channels)],
                                rig=systeminfo.rig)
        all_chains = _record_chains(rig, systeminfo, chains, noise, adc_bits, true_sensitivity)
        raw = np.empty((n, rig.channel_count))
        clipped: dict[int, int] = {}
        column = _sensor_columns(sensors)
        for ch in range(rig.channel_count):
            chain = all_chains[ch]
            idx = column.get(ch)
            quantity = acc[:, idx] if idx is not None else np.zeros(n_fine)
            volts = run_analog(chain, quantity, fine)[::oversample][lead:]
            volts = volts + adc_input_disturbances(chain, n, fs, rng)
            if count := chain.clipped(volts):
                clipped[ch] = count
            raw[:, ch] = chain.quantise(volts)
        names = [f"ai{ch}" if ch == fch else channel_name(rig, ch) for ch in range(rig.channel_count)]
        return Recording(
            chunks=_chunks(raw, settings.chunk_size, progress), n_samples=n, sampling_rate=fs, pretrigger=0,
            systeminfo=systeminfo, excitation=None, channel_names=names,
            source=f"daq_sim operating={load} {what} seed={seed} oversample={oversample}",
            clipped=clipped,
        )

    def _truth(self, rig: Rig, truth: Truth | None, effects: Sequence[tuple[str, Mapping[str, Any]]],
               truth_rig: str | None = None) -> tuple[Truth, dict[int, tuple[float, float]]]:
        """The truth and {channel: (sensitivity, sign)} of sensors whose truth differs from the rig."""
        if truth_rig is not None:
            if truth is not None or effects:
                raise ConfigError("simulator: give a truth rig, a truth or effects, not two of them")
            from odsuite_plugins.daq_sim.truth import rig_file_truth

            return rig_file_truth(rig, truth_rig)
        if truth is None:
            return self._default_truth(rig, effects), {}
        if effects:
            raise ConfigError("simulator: give either a truth or effects on the rig's default model, not both")
        return truth, {}

    def _default_truth(self, rig: Rig, effects: Sequence[tuple[str, Mapping[str, Any]]]) -> Truth:
        if self._truth_factory is None:
            from odsuite_plugins.daq_sim.truth import model_truth

            return model_truth(rig, effects)
        return self._truth_factory(rig, effects)


def _record_chains(rig: Rig, systeminfo: Systeminfo, chains: Mapping[int, ChannelChain] | None,
                   noise: float, adc_bits: int | None = None,
                   true_sensitivity: Mapping[int, tuple[float, float]] | None = None) -> dict[int, ChannelChain]:
    """The default chains of the record's channels, with a truth rig's sensitivities and the
    caller's replacements."""
    out = default_chains(rig, systeminfo, noise=noise, adc_bits=adc_bits)
    for ch, (sensitivity, sign) in (true_sensitivity or {}).items():
        out[ch] = replace(out[ch], sensitivity=sensitivity, sign=sign)
    for ch, chain in (chains or {}).items():
        if ch not in out:
            raise ConfigError(f"simulator option 'chains': rig {rig.name!r} has no channel {ch}")
        chain.validate(f"simulator chain of channel {ch}")
        out[ch] = chain
    return out


def _chunks(raw: np.ndarray, size: int, progress: Progress | None) -> Iterator[np.ndarray]:
    for start in range(0, raw.shape[0], size):
        chunk = raw[start:start + size]
        yield chunk
        if progress:
            progress(READING, start + chunk.shape[0], raw.shape[0])


def _check_options(rig, settings, oversample, seed, noise, adc_bits, operating, force_rms, hits, force_peak,
                   contact_ms) -> None:
    """The record's options, each refused in one line before anything is simulated."""
    if rig is None:
        raise ConfigError("the simulated rig needs a project with a rig (created without --rig none)")
    if settings.mode != "finite":
        raise ConfigError("acquisition setting 'mode': the simulated rig records finite triggered records only")
    if int(oversample) != oversample or oversample < 1:
        raise ConfigError(f"simulator option 'oversample': an integer >= 1, got {oversample!r}")
    if seed is not None and (int(seed) != seed or not 0 <= seed < 2**63):
        raise ConfigError(f"simulator option 'seed': an integer from 0 to 2**63-1, got {seed!r}")
    # the simulation runs at oversample times the rate, all channels at once
    check_record_fits(settings.n_samples * int(oversample), len(rig.sensors),
                      f"simulator: --samples {settings.n_samples} (oversampled {oversample}x)")
    if not (np.isfinite(noise) and 0 <= noise <= MAX_NOISE_SCALE):
        raise ConfigError(f"--noise: a scale from 0 to {MAX_NOISE_SCALE:g}, got {noise!r}")
    if adc_bits is not None and not MIN_ADC_BITS <= adc_bits <= MAX_ADC_BITS:
        raise ConfigError(f"--adc-bits: an integer from {MIN_ADC_BITS} to {MAX_ADC_BITS}, got {adc_bits!r}")
    if operating is None and force_rms is not None:
        raise ConfigError("--force-rms sets an operating load: give --operating too")
    if operating is not None and (hits is not None or force_peak is not None or contact_ms is not None):
        raise ConfigError("--operating records a running machine: drop the hammer's hits, --force-peak and "
                          "--contact-ms")


def _force_line(scenario, point, direction):
    """The scenario (T1 when nothing is given) and the force's point (m) and unit direction."""
    if scenario is None and point is None and direction is None:
        scenario = "T1"
    sc = get_scenario(scenario) if scenario else None
    if sc is None and (point is None or direction is None):
        raise ConfigError("simulator: give a scenario or both a force point and a direction")
    point = np.asarray(point if point is not None else sc.point, dtype=float)
    direction = np.asarray(direction if direction is not None else sc.direction, dtype=float)
    if point.shape != (3,) or direction.shape != (3,) or not np.linalg.norm(direction) > 0:
        raise ConfigError(f"simulator: force point {point.tolist()} / direction {direction.tolist()} must be 3-vectors, direction non-zero")
    return sc, point, direction / np.linalg.norm(direction)


def _scaled_hits(hits, sc, force_peak, contact_ms) -> list[Hit]:
    """The hammer's hits: given, the scenario's or one default hit, scaled to ``force_peak`` (N)
    and ``contact_ms`` (ms)."""
    hits = list(hits if hits is not None else sc.hits if sc is not None else (Hit(),))
    if not hits:
        raise ConfigError("simulator: at least one hit is needed")
    if force_peak is not None:
        if not MIN_PEAK_N <= force_peak <= MAX_PEAK_N:  # NaN fails too
            raise ConfigError(f"--force-peak: a hammer's peak force, {MIN_PEAK_N:g} to {MAX_PEAK_N:g} N, "
                              f"got {force_peak!r}")
        top = max(h.peak for h in hits)
        hits = [replace(h, peak=h.peak * force_peak / top) for h in hits]
    if contact_ms is not None:
        hits = [replace(h, width=1e-3 * contact_ms) for h in hits]
    for i, h in enumerate(hits):
        h.validate(f"simulator hit {i}")
    return hits


def _sensor_columns(sensors) -> dict[int, int]:
    """Each channel's (first) sensor's column of the truth's output, found once (a search per
    channel was quadratic: 4,000 sensors)."""
    column: dict[int, int] = {}
    for i, s in enumerate(sensors):
        column.setdefault(s.channel, i)
    return column


def _struck_stream(rig, settings, hits, truth, all_chains, point, direction, force_body, oversample, rng):
    """Every channel's voltage over a stream long enough for the pre-trigger buffer, the hits and a
    late trigger (V, samples x channels), and the force at the fine rate (N)."""
    fs, n, pre = settings.sampling_rate, settings.n_samples, settings.pretrigger
    fine = fs * oversample
    # the hammer arrives a random while after the buffer holds the pre-trigger samples
    lead = pre + int(rng.integers(20, 400)) + rng.uniform(0.0, 1.0)
    span = max(h.time + h.width for h in hits)
    # room after the last hit for the analog filters' delay before a late trigger
    n_stream = int(np.ceil(lead + (span + 0.05) * fs)) + n
    t_fine = np.arange(n_stream * oversample) / fine
    force = half_sine_force(t_fine, hits, t0=lead / fs)
    # a truth is told the body hit only when the experimenter says (a point on two bodies)
    acc = np.asarray(truth(force, fine, point, direction, **({"body": force_body} if force_body else {})),
                     dtype=float)
    sensors = rig.accelerometers
    if acc.shape != (force.size, len(sensors)):
        raise HardwareError(f"simulator: the truth model returned shape {acc.shape}, expected {(force.size, len(sensors))}")
    volts = np.empty((n_stream, rig.channel_count))
    column = _sensor_columns(sensors)
    for ch in range(rig.channel_count):
        chain = all_chains[ch]
        if ch == rig.force_channel:
            quantity = force
        else:
            idx = column.get(ch)
            quantity = acc[:, idx] if idx is not None else np.zeros_like(force)
        analog = run_analog(chain, quantity, fine)[::oversample]
        volts[:, ch] = analog + adc_input_disturbances(chain, n_stream, fs, rng)
    return volts, force


def _triggered(rig, settings, all_chains, volts):
    """The record the force channel's trigger cuts from the stream: ADC codes (samples x channels)
    and the clipped samples per channel."""
    n, pre = settings.n_samples, settings.pretrigger
    fch = rig.force_channel
    level_v = settings.trigger_level * all_chains[fch].sensitivity * all_chains[fch].gain
    codes = all_chains[fch].quantise(volts[:, fch])
    trig = find_trigger(codes, level_v, settings.trigger_slope, pre)
    if trig is None or trig - pre + n > volts.shape[0]:
        peak = (codes.max() - all_chains[fch].offset) / (all_chains[fch].sensitivity * all_chains[fch].gain)
        raise HardwareError(
            f"trigger timeout: force channel {fch} never crossed {settings.trigger_level:g} N "
            f"({settings.trigger_slope}); the hammer peaked near {peak:.3g} N"
        )
    record = volts[trig - pre: trig - pre + n]
    clipped = {ch: all_chains[ch].clipped(record[:, ch]) for ch in range(rig.channel_count)}
    raw = np.column_stack([all_chains[ch].quantise(record[:, ch]) for ch in range(rig.channel_count)])
    return raw, clipped
