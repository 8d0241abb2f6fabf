"""Running chains of processing steps over records, chunk by chunk, on one or more threads.

Long records run chunk by chunk with states carried across chunks; between reversals the
intermediate record goes to a temporary file, so peak memory does not grow with record length.

Speed: channels whose chains are identical run together as one channels x samples block per
``sosfilt`` call, in blocks that stay in the L2 cache; built-in steps are ``batched`` and filter
the runner's own buffers in place; filters and integrators with no tap between them are one
cascade; threads share the channels (``workers``).
"""

from __future__ import annotations

import json
import os
import tempfile
import threading
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np

from odsuite.domain.errors import ConfigError, DimensionError
from odsuite.contracts.steps import _EMPTY, Item, Reverse, Step, Tap

DEFAULT_CHUNK = 1 << 16



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

    def through(self, tap: str) -> Chain:
        """The chain up to ``tap``: the same samples there, and nothing computed after it."""
        at = [k for k, i in enumerate(self.items) if isinstance(i, Tap) and i.name == tap]
        if not at:
            return self
        end = next((k + 1 for k, s in enumerate(self.spec) if s.get("tap") == tap), len(self.spec))
        return Chain(self.items[:at[0] + 1], self.spec[:end], self.fs)

    def run(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """Process a whole record in memory (one chunk); returns every tap (same length as ``x``)."""
        x = np.asarray(x, dtype=float)
        if x.ndim != 1:
            raise DimensionError(f"chain input: expected one channel (1-D samples), got shape {x.shape}")
        return run_array([self], x[:, None], chunk=max(x.size, 1))[0]


class _SegmentRunner:
    """Streams blocks (channels x samples, time on the last axis) through one segment (no
    reversal inside) of the identical chains of a group.

    The runner owns the blocks it is given and lets steps overwrite them, so every tap's samples
    go to ``emit(tap, block)`` the moment they pass: ``emit`` copies what it keeps.
    """

    def __init__(self, items: Sequence[Step | Tap], emit: Callable[[str, np.ndarray], None]) -> None:
        self.items = list(items)
        self.emit = emit
        self.states = [i.init_state() if isinstance(i, Step) else None for i in self.items]

    def push(self, x: np.ndarray) -> np.ndarray:
        """Run a block the caller gives away; returns the segment's output now available."""
        return self._run(x, final=False)

    def finish(self, channels: int) -> np.ndarray:
        """Flush every step once the input has ended."""
        return self._run(np.empty((channels, 0)), final=True)

    def _run(self, x: np.ndarray, final: bool) -> np.ndarray:
        owned = True
        for k, item in enumerate(self.items):
            if isinstance(item, Tap):
                if x.shape[-1]:
                    self.emit(item.name, x)
                continue
            state = self.states[k]
            if item.batched:
                x, state = (item.process_owned if owned else item.process)(x, state)
                tail = item.finish(state) if final else _EMPTY
            else:  # a step written for one channel (1-D samples); its output may alias anything
                x, state = item.process(x[0], state)
                x = np.asarray(x, dtype=float).reshape(1, -1)
                tail = np.asarray(item.finish(state), dtype=float).reshape(1, -1) if final else _EMPTY
                owned = False
            self.states[k] = state
            if tail.shape[-1]:
                x = np.concatenate([x, tail], axis=-1)
        return x



#: Bytes of one block of a group (channels x samples) pushed through its steps at a time: the
#: block and its copies stay in the L2 cache while the filters run over it (512 KiB measured
#: best of 128 KiB..2 MiB in bench/bench_processing.py on a 2 MiB-L2 core).
BLOCK_BYTES = 1 << 19


def _groups(chains: Sequence[Chain], parts: int = 1) -> list[list[int]]:
    """Indices of chains that run together as one block: the same specification, sampling rate
    and step types, all steps batched (other chains run alone); each group cut into up to
    ``parts`` consecutive pieces, so that threads can share it."""
    groups: dict[Any, list[int]] = {}
    for c, chain in enumerate(chains):
        batched = all(i.batched for i in chain.items if isinstance(i, Step))
        key = ((json.dumps(chain.spec, sort_keys=True, default=repr), chain.fs,
                tuple(type(i) for i in chain.items)) if batched else ("alone", c))
        groups.setdefault(key, []).append(c)
    out = []
    for members in groups.values():
        cuts = np.linspace(0, len(members), min(parts, len(members)) + 1).round().astype(int)
        out += [members[a:b] for a, b in zip(cuts[:-1], cuts[1:])]
    return out


class _Scratch:
    """An append-only temporary file of float64 samples per channel, read back from its end."""

    def __init__(self, channels: int, directory: str | None) -> None:
        self.files = [tempfile.TemporaryFile(dir=directory) for _ in range(channels)]
        self.n = 0

    def append(self, x: np.ndarray) -> None:
        if x.shape[-1]:
            for f, row in zip(self.files, x):
                f.seek(self.n * 8)
                f.write(np.ascontiguousarray(row, dtype=np.float64).tobytes())
            self.n += x.shape[-1]

    def pop_back(self, k: int) -> np.ndarray:
        """The last ``k`` remaining samples, reversed (the record read backwards), channels x k."""
        k = min(k, self.n)
        self.n -= k
        buf = np.empty((len(self.files), k))
        for f, row in zip(self.files, buf):
            f.seek(self.n * 8)
            f.readinto(memoryview(row).cast("B"))
        return buf[:, ::-1].copy()

    def close(self) -> None:
        for f in self.files:
            f.close()


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
        block = np.empty((self.ncols, stop - start))
        for c in range(self.ncols):
            os.preadv(self.file.fileno(), [memoryview(block[c]).cast("B")], (c * self.n + start) * 8)
        return block.T


class _Sink:
    """Collects (chain, tap) outputs into target datasets and writes them in whole rows.

    ``targets`` maps a target name to its list of (chain index, tap name) columns; ``write(name,
    start, block)`` stores rows ``start:start+len(block)`` and must copy them (the block is reused).
    In single-pass runs rows are written as soon as every column has them (a group's block that
    fills a whole target goes straight through); otherwise outputs go to a temporary column store
    first.

    ``concurrent``: groups push from several threads at once, each into its own columns, without a
    lock; a pushing thread that finds the writer free writes the rows complete so far. The caller
    ``reserve``s room before each input chunk and ``flush``es the rest after it, while no thread
    pushes.
    """

    def __init__(self, n: int, targets: Mapping[str, Sequence[tuple[int, str]]],
                 write: Callable[[str, int, np.ndarray], None], *, direct: bool,
                 chunk: int, scratch_dir: str | None, concurrent: bool = False) -> None:
        self.n, self.write, self.direct, self.chunk = n, write, direct, chunk
        self.concurrent = concurrent
        self._write_lock = threading.Lock()
        self.where: dict[tuple[int, str], tuple[str, int]] = {}
        for name, cols in targets.items():
            for j, key in enumerate(cols):
                self.where[key] = (name, j)
        self.ncols = {name: len(cols) for name, cols in targets.items()}
        self.pos = dict.fromkeys(self.where, 0)
        self.routes: dict[tuple[tuple[int, ...], str], tuple[list, list]] = {}
        if direct:  # rows waiting for other columns: buf[col, head:fill[col]] per target
            self.buf = {name: np.empty((k, 0)) for name, k in self.ncols.items()}
            self.fill = {name: np.zeros(k, dtype=np.int64) for name, k in self.ncols.items()}
            self.head = dict.fromkeys(self.ncols, 0)
            self.written = dict.fromkeys(self.ncols, 0)
        else:
            self.stores = {name: _ColumnStore(n, k, scratch_dir) for name, k in self.ncols.items()}

    def _route(self, members: tuple[int, ...], tap: str) -> tuple[list, list]:
        """Where the rows of ``members``' tap go: [(row, (chain, tap), target, column)], and the
        same as runs of rows that go to consecutive columns of one target:
        [(row0, row1, target, col0, col1)]."""
        key = (members, tap)
        if key not in self.routes:
            route = [(r, (c, tap), *self.where[(c, tap)]) for r, c in enumerate(members)
                     if (c, tap) in self.where]
            runs: list[list] = []
            for r, _, name, col in route:
                if runs and runs[-1][1] == r and runs[-1][2] == name and runs[-1][4] == col:
                    runs[-1][1], runs[-1][4] = r + 1, col + 1
                else:
                    runs.append([r, r + 1, name, col, col + 1])
            self.routes[key] = (route, [tuple(run) for run in runs])
        return self.routes[key]

    def push(self, members: tuple[int, ...], tap: str, x: np.ndarray, backwards: bool) -> None:
        """Samples ``x`` (len(members) x k) of ``tap`` of the chains ``members``."""
        route, runs = self._route(members, tap)
        k = x.shape[-1]
        if not route or not k:
            return
        pos = self.pos
        for _, key, _, _ in route:
            if pos[key] + k > self.n:
                raise DimensionError(f"tap {tap!r} of chain {key[0]} produced more than {self.n} samples")
            pos[key] += k
        if not self.direct:
            for r, key, name, col in route:
                end = pos[key]
                if backwards:
                    self.stores[name].put(col, self.n - end, x[r, ::-1])
                else:
                    self.stores[name].put(col, end - k, x[r])
            return
        for r0, r1, name, c0, c1 in runs:
            fill, head = self.fill[name], self.head[name]
            if c1 - c0 == len(fill) and fill[0] == head:  # whole rows, nothing waiting: straight on
                self.write(name, self.written[name], x[r0:r1].T)  # no other group writes this target
                self.written[name] += k
                continue
            f = int(fill[c0])  # the rows of a run always arrive together
            if f + k > self.buf[name].shape[1]:
                if self.concurrent:  # reserve() made room for every sample fed so far
                    raise DimensionError(f"tap {tap!r} of chain {members[r0]} produced more samples than "
                                         "its input so far")
                f -= self._room(name, f + k)
            self.buf[name][c0:c1, f:f + k] = x[r0:r1]
            fill[c0:c1] = f + k
            # as soon as whole rows are there, while they are in the cache; with threads, whoever
            # finds the writer free writes them (the others go on filtering)
            if not self.concurrent:
                self._flush(name)
            elif self._write_lock.acquire(blocking=False):
                try:
                    self._flush(name)
                finally:
                    self._write_lock.release()

    def reserve(self, fed: int) -> None:
        """Room in the buffers for every column to reach input sample ``fed`` (a single-pass chain
        never emits ahead of its input), so that concurrent pushes never move a buffer."""
        if self.direct:
            for name in self.fill:
                need = fed - self.written[name] + self.head[name]
                if need > self.buf[name].shape[1]:
                    self._room(name, need)

    def _room(self, name: str, need: int) -> int:
        """Move waiting rows to the buffer's start and grow it to hold ``need`` - (the shift)
        samples per column; returns the shift."""
        buf, fill, head = self.buf[name], self.fill[name], self.head[name]
        top = int(fill.max())
        if head:
            buf[:, :top - head] = buf[:, head:top].copy()
            fill -= head
            self.head[name] = 0
        if need - head > buf.shape[1]:
            # an odd row length: rows a power of two apart would share cache sets
            grown = np.empty((buf.shape[0], max(2 * buf.shape[1], need - head, self.chunk) | 1))
            grown[:, :top - head] = buf[:, :top - head]
            self.buf[name] = grown
        return head

    def flush(self) -> None:
        """Write the rows every column of a target has."""
        if self.direct:
            for name in self.fill:
                self._flush(name)

    def _flush(self, name: str) -> None:
        fill, head = self.fill[name], self.head[name]
        have = int(fill.min()) - head
        if have <= 0:
            return
        self.write(name, self.written[name], self.buf[name][:, head:head + have].T)
        self.written[name] += have
        # all written: start again at 0 (with threads, reserve() moves the rows between chunks)
        if not self.concurrent and fill[0] == head + have and (fill == fill[0]).all():
            fill[:] = 0
            self.head[name] = 0
        else:
            self.head[name] = head + have

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


def _columns(members: Sequence[int]) -> slice | list[int]:
    """A slice for consecutive column indices (a view, no gather), else the list."""
    lo = members[0]
    return slice(lo, lo + len(members)) if list(members) == list(range(lo, lo + len(members))) else list(members)


def run_chains(chains: Sequence[Chain], n: int, read: Callable[[int, int], np.ndarray],
               targets: Mapping[str, Sequence[tuple[int, str]]],
               write: Callable[[str, int, np.ndarray], None], *, chunk: int = DEFAULT_CHUNK,
               progress: Callable[[int, int], None] | None = None,
               scratch_dir: str | None = None, workers: int = 1) -> None:
    """Run one chain per input column over a record of ``n`` rows, chunk by chunk.

    ``read(start, stop)`` returns rows of the input (rows x len(chains)); outputs named in
    ``targets`` are handed to ``write`` in whole rows (``write`` copies them: the block is
    reused; with ``workers`` > 1 it is called from worker threads, at the same time for different
    targets, one call at a time for one target).
    ``progress(done, total)`` is called after each chunk (total counts every pass). Chains with
    the same settings run together, channels x samples, in cache-sized blocks; ``workers``
    threads share the channels (the filter kernel and numpy's copies release the GIL). Results
    do not depend on ``chunk`` or ``workers``. Peak memory is a few chunks, whatever ``n``.
    """
    if chunk < 1:
        raise ConfigError(f"chunk size must be >= 1 sample, got {chunk}")
    if workers < 1:
        raise ConfigError(f"workers must be >= 1 thread, got {workers}")
    groups = [tuple(g) for g in _groups(chains, workers)]
    cols = [_columns(g) for g in groups]
    segs = [chains[g[0]].segments() for g in groups]
    passes = max(len(s) for s in segs) if segs else 0
    pool = ThreadPoolExecutor(min(workers, len(groups))) if workers > 1 and len(groups) > 1 else None
    sink = _Sink(n, targets, write, direct=passes <= 1, chunk=chunk, scratch_dir=scratch_dir,
                 concurrent=pool is not None)

    def each(fn: Callable[[int], int], gs: Sequence[int]) -> int:
        """``fn`` of every group (in the pool when there is one); the largest result."""
        return max(pool.map(fn, gs) if pool else map(fn, gs), default=0)

    scratch: dict[int, _Scratch] = {}
    total, done = n * passes, 0
    try:
        for p in range(passes):
            backwards = p % 2 == 1
            active = [g for g in range(len(groups)) if len(segs[g]) > p]

            runners = {g: _SegmentRunner(segs[g][p], lambda tap, x, m=groups[g], b=backwards: sink.push(m, tap, x, b))
                       for g in active}
            new_scratch = {g: _Scratch(len(groups[g]), scratch_dir) for g in active if len(segs[g]) > p + 1}

            def run(g: int, x: np.ndarray) -> int:
                y = runners[g].push(x)
                if g in new_scratch:
                    new_scratch[g].append(y)
                return x.shape[-1]

            if p == 0:
                for a in range(0, n, chunk):
                    block = np.asarray(read(a, min(a + chunk, n)), dtype=float)
                    if block.ndim != 2 or block.shape[1] != len(chains):
                        raise DimensionError(f"input rows {a}..: expected {len(chains)} channels, "
                                             f"got shape {block.shape}")
                    sink.reserve(a + block.shape[0])

                    def feed(g: int, block: np.ndarray = block) -> int:
                        step = max(1024, BLOCK_BYTES // (8 * len(groups[g])))
                        for s in range(0, block.shape[0], step):
                            run(g, np.array(block[s:s + step, cols[g]].T, order="C"))
                        return block.shape[0]

                    each(feed, active)
                    sink.flush()
                    done += block.shape[0]
                    if progress:
                        progress(done, total)
            else:
                while any(scratch[g].n for g in active):
                    step = each(lambda g: run(g, scratch[g].pop_back(chunk)), active)
                    sink.flush()
                    done = min(done + step, total)
                    if progress:
                        progress(done, total)
            for g in active:
                y = runners[g].finish(len(groups[g]))
                if g in new_scratch:
                    new_scratch[g].append(y)
            sink.flush()
            for s in scratch.values():
                s.close()
            scratch = new_scratch
        sink.close()
    finally:
        if pool:
            pool.shutdown()
        for s in scratch.values():
            s.close()


def run_array(chains: Sequence[Chain], raw: np.ndarray, *, chunk: int = DEFAULT_CHUNK,
              scratch_dir: str | None = None, workers: int = 1) -> list[dict[str, np.ndarray]]:
    """Run one chain per column of ``raw`` (samples x channels) chunk by chunk, on ``workers``
    threads; every tap of every chain is returned (list of {tap: samples})."""
    raw = np.asarray(raw, dtype=float)
    if raw.ndim != 2 or raw.shape[1] != len(chains):
        raise DimensionError(f"raw: expected samples x {len(chains)} channels, got shape {raw.shape}")
    n = raw.shape[0]
    groups = _groups(chains, workers)
    targets = {f"{g}:{t}": [(c, t) for c in members]
               for g, members in enumerate(groups) for t in chains[members[0]].taps}
    # one array per channel and tap: each result is contiguous and lives on its own
    out = {name: [np.empty(n) for _ in cols] for name, cols in targets.items()}

    def write(name: str, start: int, block: np.ndarray) -> None:
        stop = start + block.shape[0]
        for j, arr in enumerate(out[name]):
            arr[start:stop] = block[:, j]

    run_chains(chains, n, lambda a, b: raw[a:b], targets, write, chunk=chunk, scratch_dir=scratch_dir,
               workers=workers)
    result: list[dict[str, np.ndarray]] = [{} for _ in chains]
    for g, members in enumerate(groups):
        for j, c in enumerate(members):
            result[c] = {t: out[f"{g}:{t}"][j] for t in chains[c].taps}
    return result
