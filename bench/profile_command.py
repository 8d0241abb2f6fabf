"""Where one ``odsuite`` command spends its time: the command run in this process under cProfile,
timed in CPU seconds of this process (``time.process_time``), which hold on a machine shared with
other work where wall-clock profiles do not (time in worker processes is not in it). Prints the top
entries by cumulative time and optionally writes the profile for snakeviz or pstats.

Run with `.venv/bin/python bench/profile_command.py [--top 25] [--out FILE.prof] -- compare P.h5`.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import time
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--top", type=int, default=25, help="entries to print (default 25)")
    ap.add_argument("--sort", default="cumulative", help="pstats sort key (default cumulative)")
    ap.add_argument("--out", type=Path, help="also write the profile here")
    ap.add_argument("argv", nargs=argparse.REMAINDER, help="the odsuite command and its arguments, after --")
    args = ap.parse_args()
    argv = args.argv[1:] if args.argv[:1] == ["--"] else args.argv
    sys.argv = [str(Path(sys.executable).with_name("odsuite")), *argv]  # as the odsuite program
    profiler = cProfile.Profile(time.process_time)
    t0, c0 = time.perf_counter(), time.process_time()
    profiler.enable()
    try:
        from odsuite.cli import main as odsuite_main

        code = odsuite_main(argv)
    finally:
        profiler.disable()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(f"\nodsuite {' '.join(argv)}: exit {code}, {wall:.1f} s wall, {cpu:.1f} s CPU in this process",
          file=sys.stderr)
    if args.out:
        profiler.dump_stats(args.out)
    pstats.Stats(profiler, stream=sys.stderr).sort_stats(args.sort).print_stats(args.top)


if __name__ == "__main__":
    main()
