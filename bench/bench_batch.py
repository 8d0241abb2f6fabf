"""Speed of ``odsuite batch``: 8 projects x ``diagnose`` (simulated rig, 2 experiments x 2048
samples each, a different hidden stiffness per project; four candidate effects, so that the five
passes below stay within minutes on a shared 2-core machine).

1. serial: the projects one after another in this process (diagnose with one thread), the
   baseline; with ``--threads`` also diagnose's own thread pool (workers=2), one after another;
2. ``batch --workers 2``: an embedded LocalCluster with two worker processes (its start included);
3. the same batch through a scheduler and two workers started as separate processes
   (``dask scheduler``, ``dask worker``) on 127.0.0.1: the results must be identical to 2.;
4. the same again with one of those workers killed (SIGKILL) mid-batch: the scheduler reruns its
   task on the other; results identical, every project verifies.

Prints each wall time and the ratio serial / batch (target >= 1.7x on a 2-core machine). Run with
`.venv/bin/python bench/bench_batch.py [N_PROJECTS] [--threads]`.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "core"))

from hidden_effects import make_project  # noqa: E402

from odsuite.ops.batch import run_batch  # noqa: E402
from odsuite.diagnosis.diagnose import diagnose  # noqa: E402
from odsuite.store.project import open_project  # noqa: E402

TARGET = 1.7
EFFECTS = ["stiffness", "damping", "mass_properties", "sensor_gain"]
DASK = str(Path(sys.executable).with_name("dask"))


def _results(batch) -> list[str]:
    """Each project's result as text: equal text, equal numbers to the last bit."""
    return [json.dumps(r["result"], sort_keys=True) for r in batch.projects]


def _start_external(tmp: Path) -> tuple[list[subprocess.Popen], str]:
    """A scheduler and two single-threaded workers without nannies (a killed one stays dead)."""
    sched_file = tmp / "scheduler.json"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    # both give up on their own if this script dies before stopping them
    procs = [subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", "--idle-timeout", "120",
                               "--dashboard-address", "127.0.0.1:0", "--scheduler-file", str(sched_file)], **quiet)]
    deadline = time.monotonic() + 60
    while not sched_file.exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    address = json.loads(sched_file.read_text())["address"]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    for _ in range(2):
        procs.append(subprocess.Popen([DASK, "worker", address, "--nthreads", "1", "--no-nanny", "--host",
                                       "127.0.0.1", "--no-dashboard", "--death-timeout", "30"], env=env, **quiet))
    from distributed import Client

    with Client(address, timeout="30s") as c:
        c.wait_for_workers(2, timeout=60)
    return procs, address


def _kill_worker_when_busy(procs: list[subprocess.Popen], killed: list[int]):
    def on_submitted(client, futures) -> None:
        pids = client.run(os.getpid)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            busy = [w for w, keys in client.processing().items() if keys]
            if busy:
                time.sleep(1.0)  # inside a diagnosis
                pid = pids[busy[0]]
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                return
            time.sleep(0.05)
    return on_submitted


def main(n_projects: int = 8, threads: bool = False) -> None:
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        paths = [make_project(tmp / f"rig{i}.h5", [("stiffness", {"scale_z": 1.2 + 0.1 * i})], seed=30 + i,
                              n_samples=2048, scenarios=("T1", "T5")) for i in range(n_projects)]
        t0 = time.perf_counter()
        serial = []
        for p in paths:
            with open_project(p) as project:
                serial.append(diagnose(project, effects=EFFECTS, workers=1).as_dict())
        t_serial = time.perf_counter() - t0
        t_threads = None
        if threads:
            t0 = time.perf_counter()
            for p in paths:
                with open_project(p) as project:
                    diagnose(project, effects=EFFECTS, workers=2)
            t_threads = time.perf_counter() - t0
        t0 = time.perf_counter()
        local = run_batch("diagnose", paths, workers=2, options={"effects": EFFECTS})
        t_local = time.perf_counter() - t0
        assert local.ok, local.projects
        procs, address = _start_external(tmp)
        try:
            t0 = time.perf_counter()
            external = run_batch("diagnose", paths, scheduler=address, options={"effects": EFFECTS})
            t_external = time.perf_counter() - t0
            killed: list[int] = []
            killed_run = run_batch("diagnose", paths, scheduler=address, options={"effects": EFFECTS},
                                   on_submitted=_kill_worker_when_busy(procs, killed))
        finally:
            for proc in procs:
                proc.terminate()
            for proc in procs:
                try:
                    proc.wait(timeout=30)
                except subprocess.TimeoutExpired:  # still inside a task: no graceful close
                    proc.kill()
                    proc.wait()
        intact = 0
        for p in paths:
            with open_project(p) as project:
                intact += sum(project.verify().values()) > 0
    same_external = _results(local) == _results(external)
    same_killed = _results(local) == _results(killed_run)
    worst = max(abs(a["candidates"][0]["error_after"] - b["result"]["candidates"][0]["error_after"])
                / a["candidates"][0]["error_after"] for a, b in zip(serial, local.projects))
    ratio = t_serial / t_local
    print(f"batch diagnose: {n_projects} projects x 2 experiments x 2048 samples, effects {', '.join(EFFECTS)}, "
          f"{os.cpu_count()} cores")
    print(f"serial (one after another, 1 thread each): {t_serial:.1f} s")
    if t_threads is not None:
        print(f"serial with diagnose's thread pool (workers=2): {t_threads:.1f} s = {t_serial / t_threads:.2f}x")
    print(f"batch --workers 2 (LocalCluster, start included): {t_local:.1f} s = {ratio:.2f}x "
          f"(target {TARGET}x: {'met' if ratio >= TARGET else 'missed'})")
    print(f"batch via dask scheduler + 2 dask workers on 127.0.0.1: {t_external:.1f} s = "
          f"{t_serial / t_external:.2f}x; results identical to the local cluster's: {same_external}")
    print(f"worker pid {killed[0] if killed else '-'} killed mid-batch: {killed_run.counts}; results identical: "
          f"{same_killed}; projects that verify: {intact}/{n_projects}")
    print(f"largest relative difference of the top candidate's error, serial vs batch: {worst:.1e}")
    if not (same_external and same_killed and killed and intact == n_projects):
        sys.exit(1)


if __name__ == "__main__":
    # a terminated bench still stops the processes it started (the finally blocks run)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    args = [a for a in sys.argv[1:] if a != "--threads"]
    main(*(int(a) for a in args[:1]), threads="--threads" in sys.argv)
