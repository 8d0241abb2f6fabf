"""NI-DAQmx acquisition through the ``nidaqmx`` package (thesis §5.1, App. D.1).

One task holds every channel of the rig: IEPE accelerometers and the IEPE load cell powered by the
card (``iepe=True``), or plain voltage channels behind external conditioning like the thesis's
couplers and filters. Finite records use a reference trigger with pre-trigger samples (analog edge
on the force channel, or a digital edge on a PFI line); the continuous mode streams until a capture
is requested and keeps the ``pretrigger`` samples before it (the DAC program's 'capture' button).
Chunks go to the project as they are read. Stored values are volts at the card's input: IEPE
readings in physical units are multiplied back by their sensitivity.
"""

from __future__ import annotations

import warnings
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from odsuite_plugins.daq_ni.options import OPTIONS
from odsuite.contracts.daq import (
    READING,
    WAITING,
    AcquisitionSettings,
    Progress,
    Recording,
    channel_name,
    rig_systeminfo,
)
from odsuite.api import ConfigError, HardwareError
from odsuite.api import Excitation
from odsuite.api import Rig
from odsuite.api import SensorType, Systeminfo

G = 9.80665  # m/s^2 per g: NI's accelerometer sensitivities are per g
INSTALL_HINT = ("install the NI-DAQmx driver (Linux: `python -m nidaqmx installdriver`, Windows: "
                "ni.com/downloads) and check the device in NI MAX, or use `--daq sim`")
# NI-DAQmx status codes (nidaqmx.error_codes.DAQmxErrors / DAQmxWarnings)
NOT_FOUND = {-200220: "invalid device", -201003: "device cannot be accessed", -200170: "no such physical channel"}
TIMEOUTS = {-200474, -200284}
OVERLOADS = {-200362, 200005, 200004}


def import_nidaqmx():
    """The ``nidaqmx`` module, or a HardwareError saying what is missing and how to get it."""
    try:
        import nidaqmx
        import nidaqmx.constants  # noqa: F401
        import nidaqmx.stream_readers  # noqa: F401
    except ImportError:
        raise HardwareError(
            "NI-DAQmx acquisition needs the Python package 'nidaqmx' (`pip install nidaqmx`) and the "
            f"NI-DAQmx driver: {INSTALL_HINT}"
        ) from None
    return nidaqmx


def hardware_error(exc: Exception, what: str) -> HardwareError:
    """One clear line for an NI-DAQmx exception raised while ``what``."""
    if type(exc).__name__ == "DaqNotFoundError":
        return HardwareError(f"NI-DAQmx driver not found while {what}: {INSTALL_HINT}")
    code = getattr(exc, "error_code", None)
    first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    if code in NOT_FOUND:
        return HardwareError(f"{NOT_FOUND[code]} while {what} (NI-DAQmx {code}): {first}; "
                             "check the device name in NI MAX (`--device`)")
    if code in OVERLOADS:
        return HardwareError(f"input over-range while {what} (NI-DAQmx {code}): {first}; widen the channel's limits")
    return HardwareError(f"NI-DAQmx error {code} while {what}: {first}")


def _is_error(exc: Exception) -> bool:
    return type(exc).__module__.startswith("nidaqmx")


class NiDaq:
    """The ``ni`` acquisition backend."""

    name = "ni"
    description = "National Instruments cards through NI-DAQmx (IEPE accelerometers, load cell)"
    options = OPTIONS

    def record(
        self,
        rig: Rig | None,
        settings: AcquisitionSettings,
        *,
        progress: Progress | None = None,
        device: str = "Dev1",
        physical_channels: Sequence[str] | None = None,
        systeminfo: Systeminfo | None = None,
        iepe: bool = True,
        excitation_current: float = 0.004,
        trigger_source: str | None = None,
        point: Sequence[float] | None = None,
        direction: Sequence[float] | None = None,
        capture: Callable[[], bool] | None = None,
        force_body: str | None = None,
    ) -> Recording:
        """Configure a task for every channel of ``rig`` and return the record, read lazily.

        ``physical_channels`` default to ``{device}/ai0 .. ai{n-1}``. ``trigger_source`` None arms
        an analog edge on the force channel at ``settings.trigger_level`` N; a terminal such as
        "/Dev1/PFI0" arms a digital edge. ``point`` (m, rig frame) and ``direction`` describe
        where the hammer hits (``force_body``: the body, when the point lies on two). ``capture`` is polled in continuous mode.
        """
        if rig is None:
            raise ConfigError("NI acquisition needs a project with a rig: its channels define the task")
        if settings.mode == "continuous" and capture is None:
            raise ConfigError("continuous acquisition needs a capture request (the CLI waits for Enter)")
        n_ch = rig.channel_count
        phys = list(physical_channels) if physical_channels is not None else [f"{device}/ai{k}" for k in range(n_ch)]
        if len(phys) != n_ch:
            raise ConfigError(f"option 'physical_channels': {len(phys)} given, rig {rig.name!r} has {n_ch} channels")
        si = systeminfo or rig_systeminfo(rig, settings.sampling_rate)
        if len(si.channels) != n_ch:
            raise ConfigError(f"Systeminfo has {len(si.channels)} channels, rig {rig.name!r} has {n_ch}")
        if (point is None) != (direction is None):
            raise ConfigError("give both a force point and a force direction, or neither")
        excitation = None
        if point is not None:
            d = np.asarray(direction, dtype=float)
            excitation = Excitation(rig.force_channel, np.asarray(point, dtype=float), d / np.linalg.norm(d),
                                    force_body)
        kinds = [_channel_kind(rig, si, k, iepe) for k in range(n_ch)]
        if iepe:  # no external amplifier between an IEPE sensor and the card
            si = Systeminfo(channels=[replace(c, daq_gain=1.0) if kinds[k] != "voltage" else c
                                      for k, c in enumerate(si.channels)], rig=si.rig)
        nidaqmx = import_nidaqmx()
        try:
            task = nidaqmx.Task()
        except Exception as exc:
            if _is_error(exc):
                raise hardware_error(exc, "creating the task") from None
            raise
        try:
            scale = self._configure(nidaqmx, task, rig, si, phys, kinds, settings, excitation_current, trigger_source)
        except Exception as exc:
            task.close()
            if _is_error(exc):
                raise hardware_error(exc, f"configuring {device}") from None
            raise
        rec = Recording(
            chunks=iter(()), n_samples=settings.n_samples, sampling_rate=settings.sampling_rate,
            pretrigger=settings.pretrigger, systeminfo=si, excitation=excitation,
            channel_names=[channel_name(rig, k) for k in range(n_ch)],
            source=f"daq_ni device={device} mode={settings.mode} iepe={iepe} trigger={trigger_source or 'analog force'}",
        )
        rec.chunks = self._read(nidaqmx, task, settings, scale, progress, capture, rec)
        return rec

    def _configure(self, nidaqmx, task, rig, si, phys, kinds, settings, current, trigger_source) -> np.ndarray:
        c = nidaqmx.constants
        scale = np.ones(len(phys))  # physical reading x scale = volts at the card
        for k, (name, kind, info) in enumerate(zip(phys, kinds, si.channels, strict=True)):
            label = channel_name(rig, k)
            if kind == "accel":
                task.ai_channels.add_ai_accel_chan(
                    name, name_to_assign_to_channel=label,
                    min_val=info.limit_low / info.sensitivity, max_val=info.limit_high / info.sensitivity,
                    units=c.AccelUnits.METERS_PER_SECOND_SQUARED, sensitivity=info.sensitivity * 1000 * G,
                    sensitivity_units=c.AccelSensitivityUnits.MILLIVOLTS_PER_G,
                    current_excit_source=c.ExcitationSource.INTERNAL, current_excit_val=current)
                scale[k] = info.sensitivity
            elif kind == "force":
                task.ai_channels.add_ai_force_iepe_chan(
                    name, name_to_assign_to_channel=label,
                    min_val=info.limit_low / info.sensitivity, max_val=info.limit_high / info.sensitivity,
                    units=c.ForceUnits.NEWTONS, sensitivity=info.sensitivity * 1000,
                    sensitivity_units=c.ForceIEPESensorSensitivityUnits.MILLIVOLTS_PER_NEWTON,
                    current_excit_source=c.ExcitationSource.INTERNAL, current_excit_val=current)
                scale[k] = info.sensitivity
            else:
                task.ai_channels.add_ai_voltage_chan(
                    name, name_to_assign_to_channel=label, min_val=info.limit_low,
                    max_val=info.limit_high, units=c.VoltageUnits.VOLTS)
        finite = settings.mode == "finite"
        task.timing.cfg_samp_clk_timing(
            settings.sampling_rate,
            sample_mode=c.AcquisitionType.FINITE if finite else c.AcquisitionType.CONTINUOUS,
            samps_per_chan=settings.n_samples if finite else max(settings.n_samples, 10 * settings.chunk_size))
        if finite:
            ref = task.triggers.reference_trigger
            if trigger_source is None:
                f = rig.force_channel
                # the level in the force channel's units: N for IEPE, volts otherwise
                level = settings.trigger_level * (1.0 if kinds[f] == "force" else si.channels[f].sensitivity * si.channels[f].daq_gain)
                slope = c.Slope.RISING if settings.trigger_slope == "rising" else c.Slope.FALLING
                ref.cfg_anlg_edge_ref_trig(phys[f], pretrigger_samples=settings.pretrigger,
                                           trigger_slope=slope, trigger_level=level)
            else:
                edge = c.Edge.RISING if settings.trigger_slope == "rising" else c.Edge.FALLING
                ref.cfg_dig_edge_ref_trig(trigger_source, pretrigger_samples=settings.pretrigger, trigger_edge=edge)
        return scale

    def _read(self, nidaqmx, task, settings, scale, progress, capture, rec) -> Iterator[np.ndarray]:
        from nidaqmx.stream_readers import AnalogMultiChannelReader

        n, m, fs = settings.n_samples, settings.chunk_size, settings.sampling_rate
        what = "starting the task"
        try:
            reader = AnalogMultiChannelReader(task.in_stream)
            task.start()
            if progress:
                progress(WAITING, 0, n)

            def read(count: int, timeout: float) -> np.ndarray:
                buf = np.empty((len(scale), count))
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    reader.read_many_sample(buf, number_of_samples_per_channel=count, timeout=timeout)
                for w in caught:
                    if getattr(w.message, "error_code", None) in OVERLOADS:
                        raise hardware_error(w.message, what)
                return buf.T * scale

            done = 0
            if settings.mode == "continuous":
                what = "waiting for a capture"
                ring: deque[np.ndarray] = deque()
                held = 0
                while not capture():
                    block = read(m, m / fs + 5.0)
                    ring.append(block)
                    held += block.shape[0]
                    while ring and held - ring[0].shape[0] >= settings.pretrigger:
                        held -= ring.popleft().shape[0]
                    if progress:
                        progress(WAITING, 0, n)
                if ring and settings.pretrigger:
                    before = np.concatenate(list(ring))[-settings.pretrigger:]
                    done = before.shape[0]
                    yield before
            else:
                what = "waiting for the trigger"
            first_timeout = settings.trigger_timeout + n / fs
            while done < n:
                count = min(m, n - done)
                try:
                    block = read(count, first_timeout if done == 0 else count / fs + 5.0)
                except Exception as exc:
                    if getattr(exc, "error_code", None) in TIMEOUTS and done == 0 and settings.mode == "finite":
                        raise HardwareError(
                            f"trigger timeout: no {settings.trigger_slope} edge through {settings.trigger_level:g} N "
                            f"on the force channel within {settings.trigger_timeout:g} s"
                        ) from None
                    raise
                what = "reading"
                done += block.shape[0]
                if task.in_stream.overloaded_chans_exist:
                    rec.notes.append(f"over-range on {task.in_stream.overloaded_chans} by sample {done}")
                yield block
                if progress:
                    progress(READING, done, n)
        except Exception as exc:
            if _is_error(exc):
                raise hardware_error(exc, what) from None
            raise
        finally:
            task.close()


def _channel_kind(rig: Rig, si: Systeminfo, k: int, iepe: bool) -> str:
    if not iepe:
        return "voltage"
    t = si.channels[k].sensor_type
    if k == rig.force_channel and t == SensorType.LOADCELL:
        return "force"
    return "accel" if t == SensorType.ACCELEROMETER else "voltage"


def available(*_: Any) -> bool:
    """True when the nidaqmx package and the NI-DAQmx driver are both present."""
    try:
        import_nidaqmx()
        import nidaqmx.system

        nidaqmx.system.System.local().driver_version  # noqa: B018 - raises without the driver
    except Exception:
        return False
    return True
