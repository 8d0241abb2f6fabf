"""The acquisition-backend contract: what a provider of ``odsuite_register_daq_backends`` gives.

Every backend (the simulated rig ``sim``, NI-DAQmx ``ni``, a lab's own) returns a
:class:`Recording`: raw volts delivered as row chunks plus the Systeminfo, excitation and trigger
facts that describe them (:func:`odsuite.processing.acquisition.acquire` streams them into a project).
"""

from __future__ import annotations

import inspect
import math
import numbers
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Protocol

from odsuite.contracts.backend_options import BackendOption  # a lab imports it from here too
from odsuite.domain.arguments import shown
from odsuite.domain.errors import ConfigError
from odsuite.domain.memory import check_record_fits  # noqa: F401  (a backend refuses a record with it)

if TYPE_CHECKING:  # annotations only: `odsuite plugins` reads backend options without numpy
    import numpy as np

    from odsuite.domain.excitation import Excitation
    from odsuite.domain.rig import Rig
    from odsuite.domain.systeminfo import Systeminfo

#: ``progress(stage, done, total)``: stage is "waiting for trigger" or "reading"; counts in samples.
Progress = Callable[[str, int, int], None]

WAITING = "waiting for trigger"
READING = "reading"


#: Sampling rates a vibration record can have: below 0.1 Hz a 2-sample record already lasts 20 s
#: per sample; above 100 MHz no accelerometer or hammer chain has bandwidth left to sample.
MIN_RATE_HZ = 0.1
MAX_RATE_HZ = 1e8
#: Samples per channel: 2**34 float64 samples are 128 GiB per channel, beyond any machine's memory;
#: the memory actually free is checked when the record is set up (``check_record_fits``).
MAX_SAMPLES = 2**34


@dataclass(frozen=True)
class AcquisitionSettings:
    """What the experimenter sets before a record (thesis §5.1, App. D.1).

    ``trigger_level`` is in newtons on the force channel (converted to volts with the force
    channel's sensitivity and gain); ``pretrigger`` samples precede the trigger sample.
    ``mode`` "finite" arms a reference trigger; "continuous" streams until a capture is requested.
    """

    sampling_rate: float = 20_000.0
    n_samples: int = 4096
    pretrigger: int = 512
    trigger_level: float = 1.0
    trigger_slope: str = "rising"
    trigger_timeout: float = 10.0
    mode: str = "finite"
    chunk_size: int = 1024

    def __post_init__(self) -> None:
        # from Python a text or a flag would reach the arithmetic below as a raw TypeError
        for name in ("sampling_rate", "n_samples", "pretrigger", "trigger_level", "trigger_timeout", "chunk_size"):
            if not _is_real(getattr(self, name)):
                raise ConfigError(f"acquisition setting {name!r}: must be a number, got {getattr(self, name)!r}")
        for name in ("trigger_slope", "mode"):
            if not isinstance(getattr(self, name), str):
                raise ConfigError(f"acquisition setting {name!r}: must be text, got {getattr(self, name)!r}")
        if not (math.isfinite(self.sampling_rate) and MIN_RATE_HZ <= self.sampling_rate <= MAX_RATE_HZ):
            raise ConfigError(f"acquisition setting 'sampling_rate': must be between {MIN_RATE_HZ:g} Hz and "
                              f"{MAX_RATE_HZ:g} Hz, got {self.sampling_rate!r} Hz")
        if int(self.n_samples) != self.n_samples or not 2 <= self.n_samples <= MAX_SAMPLES:
            raise ConfigError(f"acquisition setting 'n_samples': must be an integer from 2 to {MAX_SAMPLES}, "
                              f"got {self.n_samples!r}")
        for name in ("trigger_level", "trigger_timeout"):
            if not math.isfinite(getattr(self, name)):
                raise ConfigError(f"acquisition setting {name!r}: must be a finite number, got {getattr(self, name)!r}")
        if int(self.pretrigger) != self.pretrigger or not 0 <= self.pretrigger < self.n_samples:
            raise ConfigError(
                f"acquisition setting 'pretrigger': must be an integer in [0, n_samples={self.n_samples}), "
                f"got {self.pretrigger!r}"
            )
        if self.trigger_slope not in ("rising", "falling"):
            raise ConfigError(f"acquisition setting 'trigger_slope': 'rising' or 'falling', got {self.trigger_slope!r}")
        if not self.trigger_timeout > 0:
            raise ConfigError(f"acquisition setting 'trigger_timeout': must be > 0 s, got {self.trigger_timeout!r}")
        if self.mode not in ("finite", "continuous"):
            raise ConfigError(f"acquisition setting 'mode': 'finite' or 'continuous', got {self.mode!r}")
        if int(self.chunk_size) != self.chunk_size or self.chunk_size < 1:
            raise ConfigError(f"acquisition setting 'chunk_size': must be an integer >= 1, got {self.chunk_size!r}")


@dataclass
class Recording:
    """A record being delivered by a backend: ``chunks`` yields float64 volts, rows x channels."""

    chunks: Iterator[np.ndarray]
    n_samples: int
    sampling_rate: float
    pretrigger: int
    systeminfo: Systeminfo
    excitation: Excitation | None
    channel_names: list[str]
    source: str
    #: filled while the chunks are consumed: per channel index, samples at the ADC's limits
    clipped: dict[int, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


class DaqBackend(Protocol):
    """What a registered acquisition backend provides: ``description`` (str), ``options`` (a
    tuple of :class:`BackendOption`, the keywords of ``record`` a user may set) and ``record``.
    Hardware errors are :class:`~odsuite.domain.errors.HardwareError` naming device and channel."""

    description: str
    options: tuple[BackendOption, ...]

    def record(
        self, rig: Rig | None, settings: AcquisitionSettings, *, progress: Progress | None = None,
        **options: Any,
    ) -> Recording:
        """Arm the acquisition and return the record (its chunks are read lazily). Besides its own
        options it receives the common ones the user gave: ``point`` (m, rig frame) and
        ``direction`` of the hammer, ``force_body`` when the point lies on two bodies, and
        ``capture`` (polled in continuous mode) where the command line has a capture button."""
        ...


PROTOCOL = DaqBackend


def parse_backend_options(name: str, backend: DaqBackend, args: list[str]) -> dict[str, Any]:
    """The backend's own options from command-line words (``--seed 3``, ``--seed=3``, ``--flag``)."""
    by_flag = {o.cli_flag: o for o in backend.options}
    out: dict[str, Any] = {}
    words = list(args)
    while words:
        word = words.pop(0)
        flag, eq, value = word.partition("=")
        opt = by_flag.get(flag)
        if opt is None:
            known = ", ".join(sorted(by_flag)) or "none"
            raise ConfigError(f"acquisition backend {name!r} does not take {flag!r} (its options: {known})")
        if opt.type is bool:
            if eq:
                raise ConfigError(f"{flag} is a flag and takes no value, got {word!r}")
            out[opt.name] = opt.when_given
            continue
        if not eq:
            if not words:
                raise ConfigError(f"{flag} needs a value ({opt.help})")
            value = words.pop(0)
        try:
            out[opt.name] = opt.type(value)
        except ValueError:
            raise ConfigError(f"{flag}: expected {opt.type.__name__}, got {value!r}") from None
    return out


def _is_real(value: Any) -> bool:
    """A real number (numpy's too), not a flag."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


#: what each option type accepts from Python (a flag only a flag; an int no float; a float any real number)
_TYPE_WORDS = {int: "an integer", float: "a number", str: "text", bool: "True or False"}


def check_backend_options(backend: Any, options: dict[str, Any], where: str = "acquire") -> None:
    """A backend and the options a Python caller gives it (``acquire``'s keywords): the backend
    provides ``record`` and ``options``; every option is one of its own or a common one
    (COMMON_OPTIONS), of its declared type or None (its default). The command line
    parses them (parse_backend_options); from Python a wrong one reached the backend as a raw error."""
    if not callable(getattr(backend, "record", None)) or not isinstance(getattr(backend, "options", None), tuple):
        raise ConfigError(f"{where}: backend must be a registered acquisition backend "
                          f"(registries().daq_backends.get(NAME)), got {type(backend).__name__} {shown(backend)}")
    declared = {o.name: o for o in backend.options}
    # a backend's record may take keywords beyond the options a user sets (a test's hidden effects)
    takes = {k: v for k, v in inspect.signature(backend.record).parameters.items()
             if k not in ("rig", "settings", "progress")}  # acquire gives these itself
    anything = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in takes.values())
    for key, value in options.items():
        opt = declared.get(key)
        if opt is None:
            if key in COMMON_OPTIONS or key in takes or anything:
                continue
            known = ", ".join(sorted([*declared, *COMMON_OPTIONS]))
            raise ConfigError(f"{where}: the backend takes no option {key!r} (its options: {known})")
        if value is None:
            continue
        # a number as Python reads one (True is 1: `noise=False` is no noise)
        number = isinstance(value, numbers.Real) and math.isfinite(value)
        ok = (isinstance(value, bool) if opt.type is bool else
              isinstance(value, str) if opt.type is str else
              number and (opt.type is not int or float(value) == int(value)) if opt.type in (int, float) else
              isinstance(value, opt.type))
        if not ok:
            raise ConfigError(f"{where}: backend option {key!r}: expected {_TYPE_WORDS.get(opt.type, opt.type.__name__)}, "
                              f"got {shown(value)}")
        if opt.type is int:
            options[key] = int(value)


#: the options every backend receives besides its own (DaqBackend.record)
COMMON_OPTIONS = ("point", "direction", "force_body", "capture")


def rig_systeminfo(rig: Rig, sampling_rate: float) -> Systeminfo:
    """The Systeminfo an experimenter writes for a record on ``rig`` at ``sampling_rate``: the
    rig's own (``Systeminfo.for_rig``: the thesis rig's Table E.3), with low-pass cut-offs that the
    rate cannot hold brought down to Nyquist."""
    from odsuite.domain.systeminfo import Systeminfo

    si = Systeminfo.for_rig(rig, sampling_rate)
    nyquist = sampling_rate / 2
    channels = [replace(c, cutoff_high=None if c.cutoff_high is None else min(c.cutoff_high, nyquist))
                for c in si.channels]
    return Systeminfo(channels=channels, rig=si.rig)


def channel_name(rig: Rig, channel: int) -> str:
    """"force" for the force channel, the sensor's name, or "ai<k>" for an unused input."""
    if channel == rig.force_channel:
        return "force"
    sensor = rig.sensor_on_channel(channel)
    return sensor.name if sensor is not None else f"ai{channel}"
