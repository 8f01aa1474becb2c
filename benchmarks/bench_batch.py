"""Batch benchmark (issue 37.3): a folder of real micrographs to STL + 3MF at Medium, on 1 and 2
worker processes of this machine (and with `--dask`, on Dask's local cluster of as many workers).

    .venv/bin/python benchmarks/bench_batch.py [COUNT] [--dask] [--rounds N] [--set fept-zeiss]

The development set: the real 2-D micrographs of the fixtures that convert by the usual relief
(SEM, TEM, STEM; the FePt JPEG, the Zeiss and FEI TIFFs, TVIPS, the SiO2 particles at two
magnifications, the moth head, the Velox and HyperSpy files), each copied under its own name
and repeated until there are COUNT (default 200). `--set fept-zeiss` is the earlier set: copies
of the FePt and Zeiss pictures only. Workers are started once and stay warm (a process pool keeps
them); each imports on its first picture. For each run: wall time, pictures per second, the
speed-up over 1 worker, the CPU time per picture (every worker's, with its imports and its
children: a `tesseract` command), the cores the workers kept busy (CPU / wall), the speed-up the
CPU times give (workers × CPU at 1 worker / CPU here: what the wall speed-up is when no one else
uses the cores), the largest peak resident memory of a worker, and the load average when it ended
(the machine is shared: a parallel speed-up is only as good as the cores left free, which a pure
CPU loop on 1 and 2 processes measures before and after the runs).
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from tamp_os import LithoParams
from tamp_os.lithograph.batch import Job, collect_inputs, run_batch, warm_worker

FIXTURES = Path(__file__).resolve().parents[1] / ".." / "shared" / "fixtures"
REAL = FIXTURES / "real"
DEVELOPMENT_SET = [FIXTURES / "fept_spheres_sem.png", FIXTURES / "test_tiff_Zeiss_SEM_1k.tif",
                   FIXTURES / "FEI-Helios-Ebeam-8bits.tif", REAL / "tvips_bin4.tif", REAL / "sem_fei_sio2_particles_35kx.tif",
                   REAL / "sem_fei_sio2_particles_10kx.tif", REAL / "sem_moth_head_scales_proboscis.tif",
                   REAL / "velox_talos_haadf_particles.emd", REAL / "stem_haadf_sio2_spheres.hspy"]
EARLIER_SET = [FIXTURES / "fept_spheres_sem.png", FIXTURES / "test_tiff_Zeiss_SEM_1k.tif"]


def peak_mb(pid: int) -> float:
    """A live process's peak resident memory (VmHWM) in MB, 0 when it cannot be read."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return 0.0


def quiet_worker() -> None:
    """The batch's own initializer (one core, imports done), and the pictures' warnings kept out of the table."""
    import logging

    warm_worker()
    logging.disable(logging.WARNING)


def cpu_s(pid: int) -> float:
    """CPU seconds of a live process and its finished children (a tesseract command), from /proc."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return sum(int(v) for v in fields[11:15]) / os.sysconf("SC_CLK_TCK")  # utime stime cutime cstime


def local_run(jobs, out: Path, workers: int) -> tuple[float, float, float]:
    """(wall s, largest worker peak MB, CPU s of all workers) on a local process pool of `workers` warm workers."""
    pool = ProcessPoolExecutor(max_workers=workers, initializer=quiet_worker)
    try:
        start = time.perf_counter()
        outcomes = run_batch(jobs, out, executor=pool)
        wall = time.perf_counter() - start
        peak = max(peak_mb(pid) for pid in pool._processes)  # the benchmark looks inside; the library does not
        cpu = sum(cpu_s(pid) for pid in pool._processes)
    finally:
        pool.shutdown()
    failed = [o["error"] for o in outcomes if o["status"] != "converted"]
    assert not failed, failed
    return wall, peak, cpu


def dask_run(jobs, out: Path, workers: int) -> tuple[float, float, float]:
    """(wall s, largest worker peak MB, CPU s of all workers) on a Dask LocalCluster of `workers` single-threaded processes."""
    from distributed import Client, LocalCluster

    # ":0": the scheduler's web server (started even without a dashboard) on a free port, not 8787,
    # which another cluster or a test may hold
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address="127.0.0.1:0") as cluster, \
            Client(cluster) as client:
        client.run(quiet_worker)  # one core and the imports, before the clock
        start = time.perf_counter()
        outcomes = run_batch(jobs, out, executor=client)
        wall = time.perf_counter() - start
        peaks = client.run(lambda: peak_mb(os.getpid()))
        cpus = client.run(lambda: cpu_s(os.getpid()))  # including the worker's start and imports
    failed = [o["error"] for o in outcomes if o["status"] != "converted"]
    assert not failed, failed
    return wall, max(peaks.values()), sum(cpus.values())


def spin(n: int) -> float:
    """A pure-Python loop: no memory traffic, no imports, no files (CPU seconds it took)."""
    start, x = time.process_time(), 0
    for i in range(n):
        x += i * i
    return time.process_time() - start


def cores_free(workers: int = 2, n: int = 6_000_000) -> float:
    """What the machine gives right now: the wall speed-up of `workers` processes over 1 on the
    same pure CPU work (4 equal pieces). Below `workers`, other users hold the cores, and no batch
    can do better than this."""
    walls = []
    for count in (1, workers):
        with ProcessPoolExecutor(max_workers=count) as pool:
            list(pool.map(spin, [1000] * count))  # started before the clock
            start = time.perf_counter()
            list(pool.map(spin, [n] * 4))
            walls.append(time.perf_counter() - start)
    return walls[0] / walls[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("count", nargs="?", type=int, default=200)
    parser.add_argument("--dask", action="store_true", help="also run on Dask's local cluster")
    parser.add_argument("--rounds", type=int, default=1, help="1 worker then 2, this many times (the load moves between runs)")
    parser.add_argument("--set", choices=("development", "fept-zeiss"), default="development")
    args = parser.parse_args()
    sources = DEVELOPMENT_SET if args.set == "development" else EARLIER_SET
    params = LithoParams(preset="medium", formats=("stl", "3mf"))
    print(f"{args.count} pictures ({len(sources)} distinct: {', '.join(s.name for s in sources)}), STL + 3MF, Medium, "
          f"{os.cpu_count()} cores\n")
    print(f"Before the runs, a pure CPU loop on 2 processes ran {cores_free():.2f}× as fast as on 1 (the cores this machine left free)\n",
          flush=True)
    print("| executor | workers | wall s | pictures/s | speed-up | CPU s per picture | cores used | speed-up by CPU | peak MB per worker | load average after |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    with tempfile.TemporaryDirectory() as tmp:
        inputs = Path(tmp) / "in"
        inputs.mkdir()
        for i in range(args.count):
            src = sources[i % len(sources)]
            shutil.copy(src, inputs / f"img{i:03d}_{src.name}")
        runs = [("process pool", local_run, 1), ("process pool", local_run, 2)]
        runs += [("Dask LocalCluster", dask_run, 1), ("Dask LocalCluster", dask_run, 2)] if args.dask else []
        runs *= args.rounds
        first, first_cpu = {}, {}
        for name, run, workers in runs:
            out = Path(tmp) / f"out-{name.split()[0]}-{workers}"
            jobs = [Job(p, out, params) for p, _ in collect_inputs([inputs])]
            wall, peak, cpu = run(jobs, out, workers)
            if workers == 1:  # each 2-worker run is compared with the 1-worker run just before it
                first[name], first_cpu[name] = wall, cpu
            load = os.getloadavg()
            # On a shared machine the wall time follows the other users' load; what the workers would do
            # alone is their CPU time spread over `workers` cores (each worker keeps to one core).
            by_cpu = workers * first_cpu[name] / cpu
            print(f"| {name} | {workers} | {wall:.1f} | {args.count / wall:.2f} | {first[name] / wall:.2f}× | {cpu / args.count:.2f} | "
                  f"{cpu / wall:.2f} | {by_cpu:.2f}× | {peak:.0f} | "
                  f"{load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} |", flush=True)
            shutil.rmtree(out)
        print(f"(after the runs, the pure CPU loop: {cores_free():.2f}×)")


if __name__ == "__main__":
    sys.exit(main())
