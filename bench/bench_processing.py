"""Throughput and memory of the processing chain (Table E.3 settings) against a bare baseline.

Baseline, on the same arrays in the same run: scipy.signal.sosfilt + np.cumsum, i.e. filter,
integrate, filter, integrate per channel, results dropped. odsuite runs the whole Table E.2 chain
(conversion, inversion, offset window, filter 1, Eq. 4.5, filter 2, Eq. 4.5) and delivers all
three stages of every channel:

- "streamed": ``run_chains`` handing every stage to a sink that copies it into one reused buffer,
  as ``process_experiment`` hands rows to the project's datasets. Like the baseline, it allocates
  no memory per sample: this is the chain's own throughput, the figure the targets apply to
  (>= 1.0x on one core, >= 1.5x with two threads);
- "kept": ``run_array`` returning every stage of every channel in new arrays. It also pays for
  writing 3 x 8 bytes of fresh memory per channel and sample, which the baseline never does; on a
  virtual machine that hands out zeroed pages this costs as much as a third of the filtering;
- "per channel": ``Chain.run`` channel after channel (no blocks of identical chains), results kept.

With two threads each takes half of the channels; rows that both halves feed are written by
whichever thread finds the writer free. Each figure is the best of interleaved repeats (wall
clock); the load average is printed because other work on the machine lowers every figure.

    .venv/bin/python bench/bench_processing.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np
import scipy.signal

def _installed_steps():
    """The installed plugins' processing steps (chains name them)."""
    from odsuite.contracts.plugins import registries

    return registries().processing_steps


FS = 20_000.0


def _channel():
    from odsuite.domain.systeminfo import ChannelInfo, FilterType, Integration, SensorType

    return ChannelInfo(sensor_type=SensorType.ACCELEROMETER, sensitivity=0.020292, integration=Integration.DOUBLE,
                       filter_type=FilterType.HIGHPASS, filter_order=8, sampling_rate=FS, cutoff_low=20.0,
                       ripple_db=0.1, attenuation_db=60.0, filters_on=3, invert=True, offset_length=400,
                       daq_gain=10.0)


def baseline(raw: np.ndarray) -> None:
    sos = scipy.signal.ellip(8, 0.1, 60.0, 20.0, "highpass", fs=FS, output="sos")
    dt = 1 / FS
    for x in raw.T:
        v = np.cumsum(scipy.signal.sosfilt(sos, x)) * dt
        np.cumsum(scipy.signal.sosfilt(sos, v)) * dt


def best(fs: list, repeat: int) -> list[float]:
    """Best time of each function, run in turn (interleaved, so load from elsewhere hits all)."""
    times = [[] for _ in fs]
    for _ in range(repeat):
        for f, t in zip(fs, times):
            t0 = time.perf_counter()
            f()
            t.append(time.perf_counter() - t0)
    return [min(t) for t in times]


def throughput(channels: int, samples: int, repeat: int, judge: bool = True) -> None:
    from odsuite.processing.executor import DEFAULT_CHUNK, run_array, run_chains
    from odsuite.processing.chain_spec import chain_for_channel

    raw = np.random.default_rng(0).standard_normal((samples, channels)) * 0.05
    chains = [chain_for_channel(_channel(), registry=_installed_steps()) for _ in range(channels)]
    targets = {t: [(c, t) for c in range(channels)] for t in chains[0].taps}
    sink = np.empty((DEFAULT_CHUNK, channels))

    def write(name: str, start: int, block: np.ndarray) -> None:
        sink[:block.shape[0]] = block

    def streamed(workers: int) -> None:
        run_chains(chains, samples, lambda a, b: raw[a:b], targets, write, workers=workers)

    load = os.getloadavg()[0]
    t_base, t_one, t_kept, t_stream, t_kept2, t_stream2 = best([
        lambda: baseline(raw),
        lambda: [c.run(raw[:, k]) for k, c in enumerate(chains)],
        lambda: run_array(chains, raw),
        lambda: streamed(1),
        lambda: run_array(chains, raw, workers=2),
        lambda: streamed(2),
    ], repeat)
    ms = samples * channels / 1e6
    met = ("met" if t_base / t_stream >= 1.0 and t_base / t_stream2 >= 1.5 else "MISSED") if judge else "apply to 1e6"
    print(f"{channels} ch x {samples:.0e} samples: baseline {ms / t_base:5.1f} MS/s | streamed: 1 core "
          f"{t_base / t_stream:4.2f}x, 2 threads {t_base / t_stream2:4.2f}x (targets 1.0x/1.5x {met}) | kept: "
          f"1 core {t_base / t_kept:4.2f}x, 2 threads {t_base / t_kept2:4.2f}x | per channel {t_base / t_one:4.2f}x "
          f"(load average {load:.2f} -> {os.getloadavg()[0]:.2f})")


CHILD = """
import resource, sys
from odsuite.store.project import open_project
from odsuite.processing.pipeline import process_experiment
with open_project(sys.argv[1], "a") as p:
    process_experiment(p, "long", workers=2)
# VmHWM is this process's own peak; ru_maxrss can carry the parent's peak across exec
hwm = next(int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmHWM"))
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, hwm)
"""


def peak_memory(samples: int) -> None:
    """Peak RSS of processing a ``samples``-long channel stored in a project (fresh process)."""
    from odsuite.store.project import create_project
    from odsuite.domain.systeminfo import Systeminfo

    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "long.odsp")
        p = create_project(path, None)
        rows = 1 << 20

        def chunks():
            rng = np.random.default_rng(1)
            for a in range(0, samples, rows):
                yield rng.standard_normal((min(rows, samples - a), 1)) * 0.05

        p.add_experiment("long", chunks(), sampling_rate=FS, systeminfo=Systeminfo([_channel()]),
                         excitation=None, n_samples=samples)
        p.close()
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-c", CHILD, path], capture_output=True, text=True, check=True)
        dt = time.perf_counter() - t0
        maxrss, hwm = (int(v) / 1024 for v in out.stdout.split()[-2:])
        print(f"peak memory processing one channel of {samples:.0e} samples from a project: {hwm:.0f} MB "
              f"VmHWM, {maxrss:.0f} MB ru_maxrss "
              f"(limit 500 MB; record {samples * 8 / 1e6:.0f} MB raw; {dt:.1f} s)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (seconds, not minutes)")
    args = ap.parse_args()
    sizes = [(10, 100_000), (64, 100_000)] if args.quick else [(10, 1_000_000), (64, 1_000_000)]
    peak_memory(10_000_000 if args.quick else 100_000_000)  # first, while this process is small
    for (channels, samples), repeat in zip(sizes, (5, 3)):
        throughput(channels, samples, repeat=repeat, judge=not args.quick)
    print(f"(this process: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB peak)")


if __name__ == "__main__":
    main()
