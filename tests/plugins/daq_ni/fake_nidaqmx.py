"""A fake of the parts of ``nidaqmx`` that the NI backend uses, injected through ``sys.modules``.

It behaves like a card: ``signal`` (volts at the inputs, samples x channels) streams from the
moment the task starts; a reference trigger delivers ``pretrigger`` samples before the first
crossing (only once the buffer holds them) and the rest after it; IEPE channels are returned in
physical units (volts / sensitivity), as the driver scales them. Every configuration call is logged.
"""

from __future__ import annotations

import sys
import types
import warnings
from enum import Enum

import numpy as np

G = 9.80665


class AccelUnits(Enum):
    G = 10186
    METERS_PER_SECOND_SQUARED = 12470


class AccelSensitivityUnits(Enum):
    MILLIVOLTS_PER_G = 12509
    VOLTS_PER_G = 12510


class ForceUnits(Enum):
    NEWTONS = 15875


class ForceIEPESensorSensitivityUnits(Enum):
    MILLIVOLTS_PER_NEWTON = 15891


class ExcitationSource(Enum):
    INTERNAL = 10200


class VoltageUnits(Enum):
    VOLTS = 10348


class AcquisitionType(Enum):
    FINITE = 10178
    CONTINUOUS = 10123


class Slope(Enum):
    RISING = 10280
    FALLING = 10171


Edge = Slope


class DaqError(Exception):
    def __init__(self, message, error_code):
        super().__init__(message)
        self.error_code = error_code


class DaqWarning(Warning):
    def __init__(self, message, error_code):
        super().__init__(message)
        self.error_code = error_code


class DaqNotFoundError(Exception):
    pass


DaqError.__module__ = DaqWarning.__module__ = DaqNotFoundError.__module__ = "nidaqmx.errors"


class Card:
    """The simulated hardware behind the fake: what the inputs carry and which devices exist."""

    def __init__(self, signal: np.ndarray, devices=("Dev1",), driver=True, digital_trigger_at=None):
        self.signal = np.asarray(signal, dtype=float)
        self.devices = set(devices)
        self.driver = driver
        self.digital_trigger_at = digital_trigger_at
        self.calls: list[tuple] = []
        self.tasks: list[Task] = []
        self.overloaded: str = ""
        self.warning: int | None = None  # a DAQmx warning code every read raises (e.g. 200005)


CARD: Card | None = None


class _Channels:
    def __init__(self, task):
        self.task = task

    def _add(self, kind, physical_channel, **kw):
        dev, _, ai = physical_channel.partition("/")
        if dev not in CARD.devices:
            raise DaqError(f"Device identifier is invalid.\nDevice Specified: {dev}", -200220)
        self.task.channels.append((kind, int(ai[2:]), kw))
        CARD.calls.append((kind, physical_channel, kw))

    def add_ai_accel_chan(self, physical_channel, **kw):
        self._add("add_ai_accel_chan", physical_channel, **kw)

    def add_ai_force_iepe_chan(self, physical_channel, **kw):
        self._add("add_ai_force_iepe_chan", physical_channel, **kw)

    def add_ai_voltage_chan(self, physical_channel, **kw):
        self._add("add_ai_voltage_chan", physical_channel, **kw)


class _Timing:
    def __init__(self, task):
        self.task = task

    def cfg_samp_clk_timing(self, rate, source="", active_edge=None, sample_mode=AcquisitionType.FINITE,
                            samps_per_chan=1000):
        self.task.timing_cfg = dict(rate=rate, sample_mode=sample_mode, samps_per_chan=samps_per_chan)
        CARD.calls.append(("cfg_samp_clk_timing", rate, dict(sample_mode=sample_mode, samps_per_chan=samps_per_chan)))


class _RefTrigger:
    def __init__(self, task):
        self.task = task

    def cfg_anlg_edge_ref_trig(self, trigger_source, pretrigger_samples, trigger_slope=Slope.RISING,
                               trigger_level=0.0):
        self.task.trigger = ("analog", trigger_source, pretrigger_samples, trigger_slope, trigger_level)
        CARD.calls.append(("cfg_anlg_edge_ref_trig", trigger_source,
                           dict(pretrigger_samples=pretrigger_samples, trigger_slope=trigger_slope,
                                trigger_level=trigger_level)))

    def cfg_dig_edge_ref_trig(self, trigger_source, pretrigger_samples, trigger_edge=Edge.RISING):
        self.task.trigger = ("digital", trigger_source, pretrigger_samples, trigger_edge, None)
        CARD.calls.append(("cfg_dig_edge_ref_trig", trigger_source,
                           dict(pretrigger_samples=pretrigger_samples, trigger_edge=trigger_edge)))


class _InStream:
    def __init__(self, task):
        self.task = task

    @property
    def overloaded_chans_exist(self):
        return bool(CARD.overloaded)

    @property
    def overloaded_chans(self):
        return [CARD.overloaded]


class Task:
    def __init__(self, new_task_name=""):
        if not CARD.driver:
            raise DaqNotFoundError("Could not find an installation of NI-DAQmx.")
        self.channels, self.trigger, self.timing_cfg = [], None, None
        self.ai_channels = _Channels(self)
        self.timing = _Timing(self)
        self.triggers = types.SimpleNamespace(reference_trigger=_RefTrigger(self))
        self.in_stream = _InStream(self)
        self.started = self.closed = False
        self.position = None
        CARD.tasks.append(self)

    def start(self):
        self.started = True
        CARD.calls.append(("start",))
        self.position = self._first_sample()

    def _first_sample(self) -> int | None:
        if self.trigger is None:
            return 0
        kind, source, pre, slope, level = self.trigger
        if kind == "digital":
            at = CARD.digital_trigger_at
            return None if at is None else at - pre
        ch = next(i for i, (_, ai, _) in enumerate(self.channels) if source.endswith(f"ai{ai}"))
        x = self._scaled()[:, ch]
        prev, cur = x[pre - 1 if pre else 0:-1], x[max(pre, 1):]
        hit = (prev < level) & (cur >= level) if slope == Slope.RISING else (prev > level) & (cur <= level)
        idx = np.flatnonzero(hit)
        return None if idx.size == 0 else int(idx[0]) + max(pre, 1) - pre

    def _scaled(self) -> np.ndarray:
        """What the driver returns: volts, or physical units for IEPE channels."""
        cols = []
        for kind, ai, kw in self.channels:
            v = CARD.signal[:, ai]
            if kind == "add_ai_accel_chan":
                v = v / (kw["sensitivity"] / 1000 / G)
            elif kind == "add_ai_force_iepe_chan":
                v = v / (kw["sensitivity"] / 1000)
            cols.append(v)
        return np.column_stack(cols)

    def read_block(self, data: np.ndarray, n: int, timeout: float) -> int:
        if self.position is None:
            raise DaqError("Some or all of the samples requested have not yet been acquired.", -200284)
        x = self._scaled()
        if self.position + n > x.shape[0]:
            raise DaqError("Some or all of the samples requested have not yet been acquired.", -200284)
        if CARD.warning is not None:
            warnings.warn(DaqWarning(f"DAQmx warning {CARD.warning}", CARD.warning), stacklevel=2)
        data[:, :n] = x[self.position:self.position + n].T
        self.position += n
        CARD.calls.append(("read", n))
        return n

    def close(self):
        self.closed = True

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class AnalogMultiChannelReader:
    def __init__(self, in_stream):
        self.task = in_stream.task

    def read_many_sample(self, data, number_of_samples_per_channel=-1, timeout=10.0):
        return self.task.read_block(data, number_of_samples_per_channel, timeout)


def install(monkeypatch, card: Card) -> types.ModuleType:
    """Put the fake ``nidaqmx`` (and its submodules) into ``sys.modules`` for one test."""
    global CARD
    CARD = card
    root = types.ModuleType("nidaqmx")
    constants = types.ModuleType("nidaqmx.constants")
    for cls in (AccelUnits, AccelSensitivityUnits, ForceUnits, ForceIEPESensorSensitivityUnits,
                ExcitationSource, VoltageUnits, AcquisitionType, Slope):
        setattr(constants, cls.__name__, cls)
    constants.Edge = Edge
    errors = types.ModuleType("nidaqmx.errors")
    errors.DaqError, errors.DaqWarning, errors.DaqNotFoundError = DaqError, DaqWarning, DaqNotFoundError
    readers = types.ModuleType("nidaqmx.stream_readers")
    readers.AnalogMultiChannelReader = AnalogMultiChannelReader
    root.Task, root.constants, root.errors, root.stream_readers = Task, constants, errors, readers
    for name, mod in (("nidaqmx", root), ("nidaqmx.constants", constants), ("nidaqmx.errors", errors),
                      ("nidaqmx.stream_readers", readers)):
        monkeypatch.setitem(sys.modules, name, mod)
    return root
