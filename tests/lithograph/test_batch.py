"""Batch conversion: failures isolated, reports complete, resumable after a kill, Dask = local."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image

from conftest import need_module, run_cli as run


def make_inputs(folder, good=25, hostile=5, size=(48, 64)):
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    for i in range(good):
        Image.fromarray((rng.random(size) * 255).astype(np.uint8)).save(folder / f"img{i:02d}.png")
    bad = [b"", b"not an image at all", b"\x89PNG\r\n\x1a\n" + b"\x00" * 20, b"II*\x00" + b"\xff" * 10, b"GIF89a"]
    for i in range(hostile):
        (folder / f"bad{i}.png").write_bytes(bad[i % len(bad)])
    return folder


@pytest.mark.slow
def test_hostile_inputs_never_stop_the_batch(tmp_path, capsys):
    src = make_inputs(tmp_path / "in")
    code, out, _ = run(capsys, "batch", src, "-o", tmp_path / "out", "--preset", "low", "--workers", "2", "--formats", "stl,3mf")
    assert code == 1
    assert "25 converted, 0 already up to date, 5 failed" in out
    report = json.loads((tmp_path / "out" / "batch-report.json").read_text(encoding="utf-8"))
    assert len(report) == 30
    failed = [r for r in report if r["status"] == "failed"]
    assert sorted(os.path.basename(r["input"]) for r in failed) == [f"bad{i}.png" for i in range(5)]
    assert all(r["error"] and r["input"].split("/")[-1] in r["error"] for r in failed)
    csv_rows = (tmp_path / "out" / "batch-report.csv").read_text(encoding="utf-8").splitlines()
    assert len(csv_rows) == 31 and csv_rows[0] == "input,status,outputs,seconds,error,warnings,touch"
    assert len(list((tmp_path / "out").glob("*.3mf"))) == 25
    # A rerun redoes nothing that is already right.
    code, out, _ = run(capsys, "batch", src, "-o", tmp_path / "out", "--preset", "low", "--workers", "2", "--formats", "stl,3mf")
    assert "0 converted, 25 already up to date, 5 failed" in out
    # Changing a parameter makes every good input out of date.
    code, out, _ = run(capsys, "batch", src, "-o", tmp_path / "out", "--preset", "low", "--relief-mm", "2", "--formats", "stl,3mf")
    assert "25 converted" in out


@pytest.mark.slow
def test_killed_batch_resumes_without_rewriting_finished_work(tmp_path):
    src = make_inputs(tmp_path / "in", good=12, hostile=0, size=(300, 400))
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "tamp_os.cli.commands", "batch", str(src), "-o", str(out), "--workers", "1",
           "--mesher", "grid", "--resolution-px", "250", "--formats", "stl,3mf,glb"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 120
    while time.time() < deadline and len(list(out.glob("*.tamp.json"))) < 4:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGTERM)
    proc.wait(timeout=30)
    finished = sorted(out.glob("*.tamp.json"))
    assert 4 <= len(finished) < 12, "the batch should have been stopped part-way"
    before = {p.name: (p.stat().st_ino, p.stat().st_mtime_ns) for stem in finished for p in out.glob(stem.name.replace(".tamp.json", ".*"))}
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert len(list(out.glob("*.tamp.json"))) == 12
    assert not list(out.glob(".*.part"))
    after = {name: (out / name).stat() for name in before}
    assert {n: (s.st_ino, s.st_mtime_ns) for n, s in after.items()} == before
    report = json.loads((out / "batch-report.json").read_text(encoding="utf-8"))
    skipped = sum(r["status"].startswith("skipped") for r in report)
    assert skipped >= len(finished) and all(r["status"] != "failed" for r in report)


@pytest.mark.slow
def test_dask_cluster_gives_the_same_outputs_as_the_local_pool(tmp_path, capsys):
    distributed = need_module("distributed")
    src = make_inputs(tmp_path / "in", good=6, hostile=1)
    # The scheduler starts its web server even without a dashboard, at 8787 unless told: a free port,
    # or a busy 8787 (another cluster) is a warning, and warnings fail tests here.
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address="127.0.0.1:0", host="127.0.0.1") as cluster:
        code, out, _ = run(capsys, "batch", src, "-o", tmp_path / "dask", "--dask-scheduler", cluster.scheduler_address, "--formats", "stl,3mf")
    assert code == 1 and "6 converted" in out and "1 failed" in out
    run(capsys, "batch", src, "-o", tmp_path / "local", "--workers", "2", "--formats", "stl,3mf")
    names = sorted(p.name for p in (tmp_path / "local").glob("*.stl")) + sorted(p.name for p in (tmp_path / "local").glob("*.3mf"))
    assert len(names) == 12
    for name in names:
        assert (tmp_path / "dask" / name).read_bytes() == (tmp_path / "local" / name).read_bytes(), name


def test_overrides_recursive_include_and_name_collisions(tmp_path, capsys):
    src = make_inputs(tmp_path / "in", good=2, hostile=0)
    (src / "sub").mkdir()
    Image.open(src / "img00.png").save(src / "sub" / "deep.tif")
    Image.open(src / "img01.png").save(src / "img01.bmp")  # same stem as img01.png
    (src / "notes.txt").write_text("sidecar, not an image")
    overrides = tmp_path / "over.csv"
    overrides.write_text("file,preset,relief_mm,invert\nimg00.png,high,2.5,true\nsub/deep.tif,low,,\n")
    code, out, err = run(capsys, "batch", src, "-o", tmp_path / "out", "--recursive", "--overrides", overrides)
    assert code == 0, err
    recipe = json.loads((tmp_path / "out" / "img00.tamp.json").read_text(encoding="utf-8"))
    assert recipe["params"]["preset"] == "high" and recipe["params"]["relief_mm"] == 2.5 and recipe["params"]["invert"] is True
    deep = json.loads((tmp_path / "out" / "sub" / "deep.tamp.json").read_text(encoding="utf-8"))
    assert deep["params"]["preset"] == "low"
    assert (tmp_path / "out" / "img01_png.stl").is_file() and (tmp_path / "out" / "img01_bmp.stl").is_file()
    code, out, _ = run(capsys, "batch", src, "-o", tmp_path / "only", "--include", "*.bmp")
    assert "1 converted" in out
    bad = tmp_path / "bad.csv"
    bad.write_text("file,relief_mm\nimg00.png,lots\n")
    code, _, err = run(capsys, "batch", src, "-o", tmp_path / "x", "--overrides", bad)
    assert code == 1 and "line 2" in err and "relief_mm" in err


@pytest.mark.timeout(60)
def test_unreachable_dask_scheduler_is_a_clear_usage_error(tmp_path, capsys, monkeypatch):
    from tamp_os.cli import commands
    from tamp_os.gui import free_port

    monkeypatch.setattr(commands, "DASK_CONNECT_S", 1.0)  # nothing listens there: no need to wait 10 s

    src = make_inputs(tmp_path / "in", good=1, hostile=0)
    code, _, err = run(capsys, "batch", src, "-o", tmp_path / "out", "--dask-scheduler", f"tcp://127.0.0.1:{free_port()}")
    assert code == 1 and "cannot reach a Dask scheduler" in err and "Traceback" not in err


@pytest.mark.timeout(300)
def test_volume_batch_makes_each_stack_a_model_and_one_bad_file_stops_nothing(tmp_path, capsys):
    """`batch --volume`: each z-stack becomes a closed 3-D model; a single plane and a broken file fail
    with their own message; a rerun finds the models up to date."""
    import tifffile
    import trimesh

    src = tmp_path / "in"
    src.mkdir()
    z, y, x = np.mgrid[:24, :24, :24]
    for i, radius in enumerate((6, 8)):
        ball = np.where(np.sqrt((x - 12) ** 2 + (y - 12) ** 2 + (z - 12) ** 2) < radius, 1000, 100).astype(np.uint16)
        tifffile.imwrite(src / f"ball{i}.tif", ball, imagej=True, resolution=(2.0, 2.0), metadata={"spacing": 0.5, "unit": "um", "axes": "ZYX"})
    tifffile.imwrite(src / "flat.tif", np.full((32, 32), 7, np.uint16))
    (src / "broken.tif").write_bytes(b"II*\x00" + b"\xff" * 10)
    args = ("batch", src, "-o", tmp_path / "out", "--volume", "--size-mm", "30", "--workers", "1")
    code, out, _ = run(capsys, *args)
    assert code == 1 and "2 converted, 0 already up to date, 2 failed" in out
    report = {os.path.basename(r["input"]): r for r in json.loads((tmp_path / "out" / "batch-report.json").read_text(encoding="utf-8"))}
    assert "single plane" in report["flat.tif"]["error"] and "broken.tif" in report["broken.tif"]["error"]
    for name in ("ball0", "ball1"):
        assert report[f"{name}.tif"]["outputs"] == [f"{name}.stl", f"{name}.description.txt", f"{name}.tamp.json"]
        mesh = trimesh.load(tmp_path / "out" / f"{name}.stl", force="mesh", process=True)
        assert mesh.is_watertight and mesh.volume > 0 and max(mesh.extents) >= 30  # the model on its base plate
    code, out, _ = run(capsys, *args)
    assert "0 converted, 2 already up to date, 2 failed" in out


def openblas_threads() -> dict[str, int]:
    """{library file: its thread count} for each OpenBLAS loaded in this process (NumPy's, SciPy's)."""
    import ctypes

    with open("/proc/self/maps") as maps:
        loaded = {line.split()[-1] for line in maps if "openblas" in line.rsplit("/", 1)[-1].lower()}
    counts = {}
    for path in loaded:
        library = ctypes.CDLL(path)
        for name in ("scipy_openblas_get_num_threads64_", "scipy_openblas_get_num_threads", "openblas_get_num_threads"):
            if hasattr(library, name):
                counts[os.path.basename(path)] = getattr(library, name)()
                break
    return counts


def threads_in_worker():
    from tamp_os.clean.stage import clean_picture  # noqa: F401  (the scale-bar reader's module)

    return os.environ.get("TAMP_THREADS"), os.environ.get("OMP_THREAD_LIMIT"), openblas_threads(), "tamp_os.lithograph.convert" in sys.modules


@pytest.mark.timeout(120)
@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc/self/maps")
def test_batch_workers_keep_to_one_core_and_start_warm():
    """A worker of the local pool has one core to itself: BLAS told one thread (also the copy
    inherited from a parent that had loaded NumPy), OpenMP limited, no helper threads; and the
    conversion is imported before its first picture."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from tamp_os.lithograph.batch import warm_worker

    # The worker is forked from a fork server that loaded SciPy's OpenBLAS first (a parent with BLAS
    # threads), not from this test process: forking pytest's worker, whose own threads may hold a
    # lock at that moment, now and then left the child deadlocked and the run hanging.
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(["scipy.linalg"])
    with ProcessPoolExecutor(max_workers=1, mp_context=context, initializer=warm_worker) as pool:
        tamp_threads, omp_limit, blas, warm = pool.submit(threads_in_worker).result(timeout=90)
    assert (tamp_threads, omp_limit, warm) == ("1", "1", True)
    assert blas and set(blas.values()) == {1}, blas


def test_largest_inputs_are_started_first(tmp_path):
    from tamp_os import LithoParams
    from tamp_os.lithograph.batch import Job, largest_first

    sizes = [10, 3000, 0, 200]
    for i, size in enumerate(sizes):
        (tmp_path / f"{i}.png").write_bytes(b"x" * size)
    jobs = [Job(tmp_path / f"{i}.png", tmp_path, LithoParams()) for i in range(len(sizes))] + [Job(tmp_path / "gone.png", tmp_path, LithoParams())]
    order = largest_first(jobs)
    assert order[:4] == [1, 3, 0, 2] and sorted(order) == list(range(5))


MAPPED_BLOCKS = """
import ctypes, sys
import numpy as np
class Info(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in "arena ordblks smblks hblks hblkhd usmblks fsmblks uordblks fordblks keepcost".split()]
libc = ctypes.CDLL(None)
libc.mallinfo2.restype = Info
if sys.argv[1] == "tuned":
    from tamp_os.lithograph.batch import reuse_freed_arrays
    reuse_freed_arrays()
before = libc.mallinfo2().hblks
array = np.ones(4 << 20, np.uint8)
print(libc.mallinfo2().hblks - before)
"""


@pytest.mark.timeout(60)
@pytest.mark.skipif(sys.platform != "linux", reason="glibc's allocator")
def test_worker_reuses_freed_arrays_even_where_dask_fixes_the_malloc_thresholds():
    """Under Dask's MALLOC_TRIM_THRESHOLD_ every array over 128 KB is a new mapping (its pages zeroed
    again: 40 % more CPU per conversion); a batch worker puts the 32 MB threshold back."""
    import platform

    if platform.libc_ver()[0] != "glibc":
        pytest.skip("not glibc")
    env = dict(os.environ, MALLOC_TRIM_THRESHOLD_="65536", PYTHONPATH=os.pathsep.join(sys.path))
    mapped = {mode: int(subprocess.run([sys.executable, "-c", MAPPED_BLOCKS, mode], env=env, capture_output=True, text=True,
                                       check=True, timeout=50).stdout) for mode in ("plain", "tuned")}
    assert mapped == {"plain": 1, "tuned": 0}
