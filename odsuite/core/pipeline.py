"""The signal processing function (thesis Ch. 4.3, Eq. 4.2-4.8, Table E.2) as a chain of steps.

A *step* turns one channel's samples into new samples. It has a streaming form (``init_state``,
``process(chunk, state) -> (out, state)``, ``finish(state) -> tail``) and a whole-record form
(``apply``). Outputs may lag their inputs (Eq. 4.5 needs one sample of look-ahead; an offset window
must be complete before anything can be emitted); ``finish`` emits what is still held, so that
the concatenated outputs always equal ``apply`` of the whole record.

Steps are registered providers in the ``processing_steps`` registry: ``provider(fs=..., **params)``
returns a step or a list of steps and markers. A chain also holds two markers: :class:`Tap` (name an
intermediate signal, e.g. "acceleration" after filter 1) and :class:`Reverse` (time reversal: the
record is finished, then run backwards; zero-phase filtering is forward - reverse - forward -
reverse). Long records run chunk by chunk with states carried across chunks; between reversals the
intermediate record goes to a temporary file, so peak memory does not grow with record length.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Any

import numpy as np

from odsuite.core.errors import ConfigError, DimensionError
from odsuite.core.systeminfo import ChannelInfo, FilterFamily, FilterType, Integration

#: Rows per chunk when a record is read from a project.
DEFAULT_CHUNK = 1 << 16

_EMPTY = np.empty(0)


class Step:
    """Base class of processing steps; subclasses implement ``process`` (and ``finish`` if they
    hold samples back)."""

    def init_state(self) -> Any:
        """The state before the first sample."""
        return None

    def process(self, chunk: np.ndarray, state: Any) -> tuple[np.ndarray, Any]:
        """Process the next samples; return the outputs now available and the new state."""
        raise NotImplementedError

    def finish(self, state: Any) -> np.ndarray:
        """The outputs still held back once the input has ended."""
        return _EMPTY

    def apply(self, x: np.ndarray) -> np.ndarray:
        """Whole-record form: the same result as streaming the record in one chunk."""
        out, state = self.process(np.asarray(x, dtype=float), self.init_state())
        tail = self.finish(state)
        return np.concatenate([out, tail]) if tail.size else out

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
class Chain:
    """One channel's processing: steps and markers, and the specification it was built from."""

    items: tuple[Item, ...]
    spec: tuple[dict, ...]
    fs: float

    @property
    def taps(self) -> list[str]:
        return [i.name for i in self.items if isinstance(i, Tap)]

    def segments(self) -> list[list[Step | Tap]]:
        """The items between reversals; segment k runs backwards in time when k is odd."""
        segs: list[list[Step | Tap]] = [[]]
        for item in self.items:
            if isinstance(item, Reverse):
                segs.append([])
            else:
                segs[-1].append(item)
        return segs

    def run(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """Process a whole record in memory; returns every tap (same length as ``x``)."""
        x = np.asarray(x, dtype=float)
        if x.ndim != 1:
            raise DimensionError(f"chain input: expected one channel (1-D samples), got shape {x.shape}")
        out: dict[str, np.ndarray] = {}
        backwards = False
        for seg in self.segments():
            runner = _SegmentRunner(seg)
            taps, y = runner.push(x)
            taps2, y2 = runner.finish()
            for name, arr in taps.items():
                full = np.concatenate([arr, taps2[name]])
                out[name] = full[::-1].copy() if backwards else full
            x = np.concatenate([y, y2])[::-1].copy()
            backwards = not backwards
        return out


class _SegmentRunner:
    """Streams chunks through one segment (no reversal inside), collecting its taps."""

    def __init__(self, items: Sequence[Step | Tap]) -> None:
        self.items = list(items)
        self.states = [i.init_state() if isinstance(i, Step) else None for i in self.items]

    def push(self, x: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
        taps = {}
        for k, item in enumerate(self.items):
            if isinstance(item, Tap):
                taps[item.name] = x
            else:
                x, self.states[k] = item.process(x, self.states[k])
        return taps, x

    def finish(self) -> tuple[dict[str, np.ndarray], np.ndarray]:
        taps = {}
        x = _EMPTY
        for k, item in enumerate(self.items):
            if isinstance(item, Tap):
                taps[item.name] = x
            else:
                out, self.states[k] = item.process(x, self.states[k])
                tail = item.finish(self.states[k])
                x = np.concatenate([out, tail]) if tail.size else out
        return taps, x


# --------------------------------------------------------------------------------------------
# building chains


def _fuse(items: list[Item]) -> list[Item]:
    """Merge neighbouring steps that can run as one (e.g. a scale folded into the next filter,
    filters and integrators cascaded in one ``sosfilt`` call); never across taps or reversals."""
    out: list[Item] = []
    for item in items:
        if out and isinstance(item, Step) and isinstance(out[-1], Step):
            fused = out[-1].fuse(item)
            if fused is not None:
                out[-1] = fused
                continue
        out.append(item)
    return out


def _make(registry, spec: Mapping[str, Any], fs: float, where: str) -> list[Item]:
    if "tap" in spec:
        if set(spec) != {"tap"} or not isinstance(spec["tap"], str) or not spec["tap"]:
            raise ConfigError(f"{where}: a tap is {{'tap': NAME}} alone, got {dict(spec)!r}")
        return [Tap(spec["tap"])]
    if "step" not in spec:
        raise ConfigError(f"{where}: expected {{'step': NAME, ...parameters}}, got {dict(spec)!r}")
    name = spec["step"]
    if name not in registry:
        known = ", ".join(registry.names())
        raise ConfigError(f"{where}: unknown processing step {name!r} (known: {known})")
    params = {k: v for k, v in spec.items() if k != "step"}
    try:
        made = registry.get(name)(fs=fs, **params)
    except TypeError as exc:  # wrong or missing parameter names
        raise ConfigError(f"{where}: step {name!r}: {exc}") from None
    made = made if isinstance(made, list) else [made]
    for m in made:
        if not isinstance(m, (Step, Tap, Reverse)):
            raise ConfigError(f"{where}: step {name!r} made {type(m).__name__}, not a processing step")
    return made


def build_chain(specs: Sequence[Mapping[str, Any]], *, fs: float, registry=None,
                where: str = "chain") -> Chain:
    """A chain from a list of ``{"step": name, ...params}`` (and ``{"tap": name}``) entries.

    Steps are looked up in ``registry`` (default: the installed plugins' processing steps), so a
    lab's own registered step is used by name. A final tap "output" is added when the chain does not
    end in a tap.
    """
    if registry is None:
        from odsuite.core.plugins import registries

        registry = registries().processing_steps
    if not (isinstance(fs, (int, float)) and fs > 0):
        raise ConfigError(f"{where}: sampling rate must be > 0 Hz, got {fs!r}")
    items: list[Item] = []
    specs = [dict(s) for s in specs]
    for k, spec in enumerate(specs):
        if not isinstance(spec, Mapping):
            raise ConfigError(f"{where}[{k}]: expected a table {{'step': NAME, ...}}, got {spec!r}")
        items += _make(registry, spec, float(fs), f"{where}[{k}]")
    if not items or not isinstance(items[-1], Tap):
        items.append(Tap("output"))
        specs.append({"tap": "output"})
    return Chain(tuple(_fuse(items)), tuple(specs), float(fs))


#: Names of a quantity after 0, 1, 2 integrations.
_INTEGRALS = {"acceleration": ("acceleration", "velocity", "displacement")}


def stage_names(quantity: str) -> tuple[str, str, str]:
    """Tap names of a channel's signal, its integral and double integral."""
    return _INTEGRALS.get(quantity, (quantity, f"{quantity}_integral", f"{quantity}_integral2"))


def _filter_spec(ch: ChannelInfo) -> dict:
    return {"step": "iir", "family": FilterFamily(ch.filter_family).name.lower(),
            "type": FilterType(ch.filter_type).name.lower(), "order": int(ch.filter_order),
            "cutoff_low": ch.cutoff_low, "cutoff_high": ch.cutoff_high,
            "ripple_db": ch.ripple_db, "attenuation_db": ch.attenuation_db,
            "zero_phase": bool(ch.zero_phase)}


def channel_chain_spec(ch: ChannelInfo) -> list[dict]:
    """The step list of a channel, in the order of Table E.2 and the Signal Processor VI.

    convert -> (invert) -> (micro) -> offset -> filter 1 -> [tap] -> integrate -> filter 2 ->
    [tap] -> integrate -> filter 3 -> [tap]. Filters run when their bit of ``filters_on`` is set.
    The VI's front panel (App. F, "Signal Processing (Filters & Integration) ii") pairs an integral
    switch with filter 1 and with filter 2, then has filter 3: single integration is filter 1,
    integrate, filter 2, filter 3 (the tap after filter 3 is the velocity); no integration runs
    the three filters in a row on the measured quantity.
    """
    integration = Integration(ch.integration)
    on = 7 if ch.filters_on == 16 else int(ch.filters_on)  # legacy 16 = all on (erratum 8)
    names = stage_names(ch.quantity)
    spec: list[dict] = [{"step": "convert", "sensitivity": ch.sensitivity, "daq_gain": ch.daq_gain}]
    if ch.invert:
        spec.append({"step": "invert"})
    if ch.micro_units:
        spec.append({"step": "micro"})
    if ch.offset_length > 0:
        spec.append({"step": "offset", "start": int(ch.offset_start), "length": int(ch.offset_length)})
    integrate = {"step": "integrate", "rule": ch.integration_rule}
    filters = [_filter_spec(ch) if on & (1 << k) else None for k in range(3)]
    if integration is Integration.NONE:
        spec += [f for f in filters if f] + [{"tap": names[0]}]
    elif integration is Integration.SINGLE:
        spec += [f for f in filters[:1] if f] + [{"tap": names[0]}, integrate]
        spec += [f for f in filters[1:] if f] + [{"tap": names[1]}]
    else:
        spec += [f for f in filters[:1] if f] + [{"tap": names[0]}, integrate]
        spec += [f for f in filters[1:2] if f] + [{"tap": names[1]}, integrate]
        spec += [f for f in filters[2:] if f] + [{"tap": names[2]}]
    return spec


def channel_unit(ch: ChannelInfo, stage: int) -> str:
    """SI unit of a channel's signal after ``stage`` integrations (micro-units get a "u" prefix)."""
    unit = ch.unit
    if stage:
        base = {"m/s^2": ("m/s", "m"), "m/s": ("m", "m s")}.get(unit)
        unit = base[stage - 1] if base else f"{unit} s" if stage == 1 else f"{unit} s^2"
    return f"u{unit}" if ch.micro_units else unit


def chain_for_channel(ch: ChannelInfo, *, registry=None, where: str = "channel") -> Chain:
    """The Table E.2 chain of one channel (see :func:`channel_chain_spec`)."""
    return build_chain(channel_chain_spec(ch), fs=ch.sampling_rate, registry=registry, where=where)


# --------------------------------------------------------------------------------------------
# chunked execution over many channels


class _ScratchColumn:
    """An append-only temporary file of float64 samples, read back from its end."""

    def __init__(self, directory: str | None) -> None:
        self.file = tempfile.TemporaryFile(dir=directory)
        self.n = 0

    def append(self, x: np.ndarray) -> None:
        if x.size:
            self.file.seek(self.n * 8)
            self.file.write(np.ascontiguousarray(x, dtype=np.float64).tobytes())
            self.n += x.size

    def pop_back(self, k: int) -> np.ndarray:
        """The last ``k`` remaining samples, reversed (the record read backwards)."""
        k = min(k, self.n)
        self.n -= k
        buf = np.empty(k)
        self.file.seek(self.n * 8)
        self.file.readinto(memoryview(buf).cast("B"))
        return buf[::-1]

    def close(self) -> None:
        self.file.close()


class _ColumnStore:
    """Tap outputs of one target dataset kept in a temporary file (column-major) when they arrive
    out of order (reversed passes); copied to the target in row blocks at the end."""

    def __init__(self, n: int, ncols: int, directory: str | None) -> None:
        self.n, self.ncols = n, ncols
        self.file = tempfile.TemporaryFile(dir=directory)
        self.file.truncate(n * ncols * 8)

    def put(self, col: int, start: int, x: np.ndarray) -> None:
        os.pwrite(self.file.fileno(), np.ascontiguousarray(x).tobytes(), (col * self.n + start) * 8)

    def rows(self, start: int, stop: int) -> np.ndarray:
        block = np.empty((stop - start, self.ncols))
        col = np.empty(stop - start)
        for c in range(self.ncols):
            os.preadv(self.file.fileno(), [memoryview(col).cast("B")], (c * self.n + start) * 8)
            block[:, c] = col
        return block


class _Sink:
    """Collects (chain, tap) outputs into target datasets and writes them in whole rows.

    ``targets`` maps a target name to its list of (chain index, tap name) columns; ``write(name,
    start, block)`` stores rows ``start:start+len(block)``. In single-pass runs rows are written
    as soon as every column has them; otherwise outputs go to a temporary column store first.
    """

    def __init__(self, n: int, targets: Mapping[str, Sequence[tuple[int, str]]],
                 write: Callable[[str, int, np.ndarray], None], *, direct: bool,
                 chunk: int, scratch_dir: str | None) -> None:
        self.n, self.write, self.direct, self.chunk = n, write, direct, chunk
        self.where: dict[tuple[int, str], tuple[str, int]] = {}
        for name, cols in targets.items():
            for j, key in enumerate(cols):
                self.where[key] = (name, j)
        self.ncols = {name: len(cols) for name, cols in targets.items()}
        self.pos: dict[tuple[int, str], int] = {key: 0 for key in self.where}
        if direct:
            self.pending = {name: [[] for _ in range(k)] for name, k in self.ncols.items()}
            self.written = dict.fromkeys(self.ncols, 0)
        else:
            self.stores = {name: _ColumnStore(n, k, scratch_dir) for name, k in self.ncols.items()}

    def push(self, chain: int, tap: str, x: np.ndarray, backwards: bool) -> None:
        key = (chain, tap)
        if key not in self.where or not x.size:
            return
        name, col = self.where[key]
        pos = self.pos[key]
        if pos + x.size > self.n:
            raise DimensionError(f"tap {tap!r} of chain {chain} produced more than {self.n} samples")
        self.pos[key] = pos + x.size
        if self.direct:
            self.pending[name][col].append(x.copy())
        elif backwards:
            self.stores[name].put(col, self.n - pos - x.size, x[::-1])
        else:
            self.stores[name].put(col, pos, x)

    def flush(self) -> None:
        if not self.direct:
            return
        for name, cols in self.pending.items():
            have = min(sum(a.size for a in c) for c in cols)
            if have == 0:
                continue
            block = np.empty((have, len(cols)))
            for j, c in enumerate(cols):
                joined = np.concatenate(c) if len(c) > 1 else c[0]
                block[:, j] = joined[:have]
                cols[j] = [joined[have:]] if joined.size > have else []
            self.write(name, self.written[name], block)
            self.written[name] += have

    def close(self) -> None:
        for key, pos in self.pos.items():
            if pos != self.n:
                raise DimensionError(f"tap {key[1]!r} of chain {key[0]} produced {pos} samples, "
                                     f"expected {self.n}")
        if not self.direct:
            for name, store in self.stores.items():
                for a in range(0, self.n, self.chunk):
                    b = min(a + self.chunk, self.n)
                    self.write(name, a, store.rows(a, b))
                store.file.close()


def run_chains(chains: Sequence[Chain], n: int, read: Callable[[int, int], np.ndarray],
               targets: Mapping[str, Sequence[tuple[int, str]]],
               write: Callable[[str, int, np.ndarray], None], *, chunk: int = DEFAULT_CHUNK,
               progress: Callable[[int, int], None] | None = None,
               scratch_dir: str | None = None) -> None:
    """Run one chain per input column over a record of ``n`` rows, chunk by chunk.

    ``read(start, stop)`` returns rows of the input (rows x len(chains)); outputs named in
    ``targets`` are handed to ``write`` in whole rows. ``progress(done, total)`` is called after
    each chunk (total counts every pass). Peak memory is a few chunks, whatever ``n``.
    """
    if chunk < 1:
        raise ConfigError(f"chunk size must be >= 1 sample, got {chunk}")
    segs = [c.segments() for c in chains]
    passes = max(len(s) for s in segs) if segs else 0
    sink = _Sink(n, targets, write, direct=passes <= 1, chunk=chunk, scratch_dir=scratch_dir)
    scratch: dict[int, _ScratchColumn] = {}
    total, done = n * passes, 0
    try:
        for p in range(passes):
            backwards = p % 2 == 1
            active = [c for c in range(len(chains)) if len(segs[c]) > p]
            runners = {c: _SegmentRunner(segs[c][p]) for c in active}
            more = {c for c in active if len(segs[c]) > p + 1}
            new_scratch = {c: _ScratchColumn(scratch_dir) for c in more}

            def emit(c: int, taps: dict, y: np.ndarray) -> None:
                for name, arr in taps.items():
                    sink.push(c, name, arr, backwards)
                if c in new_scratch:
                    new_scratch[c].append(y)

            if p == 0:
                for a in range(0, n, chunk):
                    block = np.asarray(read(a, min(a + chunk, n)), dtype=float)
                    if block.ndim != 2 or block.shape[1] != len(chains):
                        raise DimensionError(f"input rows {a}..: expected {len(chains)} channels, "
                                             f"got shape {block.shape}")
                    for c in active:
                        emit(c, *runners[c].push(np.ascontiguousarray(block[:, c])))
                    sink.flush()
                    done += block.shape[0]
                    if progress:
                        progress(done, total)
            else:
                while any(scratch[c].n for c in active):
                    step = 0
                    for c in active:
                        x = scratch[c].pop_back(chunk)
                        step = max(step, x.size)
                        emit(c, *runners[c].push(x))
                    sink.flush()
                    done = min(done + step, total)
                    if progress:
                        progress(done, total)
            for c in active:
                emit(c, *runners[c].finish())
            sink.flush()
            for s in scratch.values():
                s.close()
            scratch = new_scratch
        sink.close()
    finally:
        for s in scratch.values():
            s.close()


def run_array(chains: Sequence[Chain], raw: np.ndarray, *, chunk: int = DEFAULT_CHUNK,
              scratch_dir: str | None = None) -> list[dict[str, np.ndarray]]:
    """Run one chain per column of ``raw`` (samples x channels) chunk by chunk; every tap of every
    chain is returned (list of {tap: samples})."""
    raw = np.asarray(raw, dtype=float)
    if raw.ndim != 2 or raw.shape[1] != len(chains):
        raise DimensionError(f"raw: expected samples x {len(chains)} channels, got shape {raw.shape}")
    n = raw.shape[0]
    targets = {f"{c}:{t}": [(c, t)] for c, ch in enumerate(chains) for t in ch.taps}
    out = {name: np.empty((n, 1)) for name in targets}

    def write(name: str, start: int, block: np.ndarray) -> None:
        out[name][start:start + block.shape[0]] = block

    run_chains(chains, n, lambda a, b: raw[a:b], targets, write, chunk=chunk, scratch_dir=scratch_dir)
    return [{t: out[f"{c}:{t}"][:, 0] for t in ch.taps} for c, ch in enumerate(chains)]
