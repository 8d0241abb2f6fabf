"""The processing-step contract: what a provider of ``odsuite_register_processing_steps`` gives.

A *step* turns one channel's samples into new samples. It has a streaming form (``init_state``,
``process(chunk, state) -> (out, state)``, ``finish(state) -> tail``) and a whole-record form
(``apply``). Outputs may lag their inputs (Eq. 4.5 needs one sample of look-ahead; an offset window
must be complete before anything can be emitted); ``finish`` emits what is still held, so that
the concatenated outputs always equal ``apply`` of the whole record.

A registered provider is called as ``provider(fs=..., **params)`` (``fs`` in Hz, the parameters
of the chain specification's entry, SI) and returns a :class:`Step` or a list of steps and
markers; wrong parameters raise ``TypeError`` or :class:`~odsuite.domain.errors.ConfigError`. Two
markers exist: :class:`Tap` (name an intermediate signal, e.g. "acceleration" after filter 1) and
:class:`Reverse` (time reversal: the record is finished, then run backwards; zero-phase filtering
is forward - reverse - forward - reverse).

A provider may also say what it does as a linear operator, ``provider.linear_form(fs=...,
**params)`` returning a tuple of :class:`Gain`, :class:`WindowMean` and :class:`Filter` (or None
when it is not one of these). The comparison then runs a model's prediction through the same
operators in one call over many channels instead of streaming each channel's chain.
:class:`StepProvider` bundles a factory with its linear form.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from odsuite.domain.errors import ConfigError


_EMPTY = np.empty(0)


class Step:
    """Base class of processing steps; subclasses implement ``process`` (and ``finish`` if they
    hold samples back).

    A step with ``batched = True`` runs along the last axis of its input, so it also processes
    several channels with the same settings at once (channels x samples), and its
    ``process_owned`` may overwrite its input (a buffer the caller gives away).
    """

    batched: bool = False

    def init_state(self) -> Any:
        """The state before the first sample."""
        return None

    def process(self, chunk: np.ndarray, state: Any) -> tuple[np.ndarray, Any]:
        """Process the next samples; return the outputs now available and the new state."""
        raise NotImplementedError

    def process_owned(self, chunk: np.ndarray, state: Any) -> tuple[np.ndarray, Any]:
        """``process`` of a chunk nobody else holds: the step may overwrite and return it."""
        return self.process(chunk, state)

    def finish(self, state: Any) -> np.ndarray:
        """The outputs still held back once the input has ended."""
        return _EMPTY

    def apply(self, x: np.ndarray) -> np.ndarray:
        """Whole-record form: the same result as streaming the record in one chunk."""
        out, state = self.process(np.asarray(x, dtype=float), self.init_state())
        tail = self.finish(state)
        return np.concatenate([out, tail], axis=-1) if tail.shape[-1] else out

    def fuse(self, following: Step) -> Step | None:
        """A single step equivalent to ``self`` then ``following``, or None (no fusion)."""
        return None


@dataclass(frozen=True)
class Tap:
    """Marks the signal at this point of a chain as an output named ``name``."""

    name: str


@dataclass(frozen=True)
class Reverse:
    """Time reversal: what follows runs over the record backwards (after the record has ended)."""


Item = Step | Tap | Reverse


@dataclass(frozen=True)
class Gain:
    """y = factor * x."""

    factor: float


@dataclass(frozen=True)
class WindowMean:
    """y = x - mean(x[start:start + length])."""

    start: int
    length: int


@dataclass(frozen=True, eq=False)
class Filter:
    """An IIR filter as second-order sections, causal from rest or zero-phase (sosfiltfilt)."""

    sos: np.ndarray
    zero_phase: bool = False


LinearOp = Gain | WindowMean | Filter


@dataclass(frozen=True)
class StepProvider:
    """A step factory and, optionally, its linear form (see the module docstring)."""

    make: Callable[..., Step | list]
    linear: Callable[..., tuple[LinearOp, ...] | None] | None = None
    description: str = ""

    def __call__(self, *, fs: float, **params: Any) -> Step | list:
        return self.make(fs=fs, **params)

    def linear_form(self, *, fs: float, **params: Any) -> tuple[LinearOp, ...] | None:
        if self.linear is None:
            return None
        try:
            return self.linear(fs=fs, **params)
        except TypeError as exc:
            raise ConfigError(f"processing step parameters {params}: {exc}") from None


class StepFactory(Protocol):
    """What every registered processing step is (checked when a plugin registers one): called with
    the sampling rate (Hz) and the chain entry's parameters, it returns a :class:`Step` or a list of
    steps and markers. :class:`StepProvider` implements it."""

    def __call__(self, *, fs: float, **params: Any) -> Step | list: ...


PROTOCOL = StepFactory
#: optional members that, where given, must be methods
OPTIONAL_METHODS = ("linear_form",)
