"""The package as users install it (issue 50): a wheel built with `python -m build`, installed with pip
into a clean venv from its honest lower bounds (not from the lock), converts a PNG; each extra installs
on top of it with `pip install "WHEEL[NAME]"` and its feature works. And the lock agrees with
pyproject.toml. Slow: pip downloads every package (with no cache under CI)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import pytest

from conftest import FIXTURES, ROOT, need

pytestmark = pytest.mark.slow

# What each extra brings, checked by using it: a script run by the venv's Python in a folder that holds
# ramp.png and ramp.stl (the core's conversion), which exits non-zero when the feature does not work.
FEATURES = {
    "gui": """
        import socket, subprocess, time, urllib.request
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0)); port = s.getsockname()[1]
        server = subprocess.Popen(["tamp-os", "gui", "--no-browser", "--port", str(port)])
        try:
            for _ in range(600):
                try:
                    page = urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=1).read().decode()
                    break
                except OSError:
                    time.sleep(0.1)
            assert "<form" in page, page[:200]
        finally:
            server.terminate(); server.wait(10)
    """,
    "render": """
        import os, pathlib, subprocess
        os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"
        subprocess.run(["tamp-os", "render", "out/ramp.stl", "-o", "renders"], check=True)
        assert len(list(pathlib.Path("renders").rglob("ramp.png"))) == 2, list(pathlib.Path("renders").rglob("*"))
    """,
    "dask": """
        import pathlib, shutil, subprocess
        from distributed import LocalCluster
        pathlib.Path("batch_in").mkdir(); shutil.copy("ramp.png", "batch_in/ramp.png")
        with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", dashboard_address="127.0.0.1:0") as cluster:
            subprocess.run(["tamp-os", "batch", "batch_in", "-o", "batch_out", "--formats", "stl",
                            "--dask-scheduler", cluster.scheduler_address], check=True)
        assert pathlib.Path("batch_out/ramp.stl").stat().st_size > 0
    """,
    "vendor": """
        import pathlib, subprocess, numpy as np, mrcfile
        with mrcfile.new("map.mrc") as mrc:
            mrc.set_data(np.add.outer(np.arange(40), np.arange(48)).astype(np.float32)[None])
            mrc.voxel_size = 2.5
        said = subprocess.run(["tamp-os", "info", "map.mrc"], check=True, capture_output=True, text=True).stdout
        assert "pixel size: 250 pm" in said, said  # 2.5 Å
        subprocess.run(["tamp-os", "convert", "map.mrc", "-o", "mrc_out", "--formats", "stl"], check=True)
        assert pathlib.Path("mrc_out/map.stl").stat().st_size > 0
    """,
    "ocr": """
        from PIL import Image, ImageDraw, ImageFont
        from tamp_os.clean import ocr
        assert ocr.backend() == "tesserocr", ocr.backend()
        picture = Image.new("L", (160, 120), 255)
        ImageDraw.Draw(picture).text((50, 10), "B", fill=0,
                                      font=ImageFont.truetype("/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf", 90))
        read = ocr.read_line(picture)
        assert read is not None and read[0].strip() == "B", read
    """,
    "dm": """
        import pathlib, subprocess, sys
        subprocess.run(["tamp-os", "convert", sys.argv[1], "-o", "dm_out", "--formats", "stl"], check=True)
        assert pathlib.Path("dm_out", pathlib.Path(sys.argv[1]).stem + ".stl").stat().st_size > 0
    """,
    "napari": """
        import numpy as np, mrcfile, npe2
        manifest = npe2.PluginManager.instance()
        manifest.discover()
        assert manifest.get_manifest("tamp-os").display_name, "no napari manifest"
        from tamp_os.napari.reader import napari_get_reader
        with mrcfile.new("map2.mrc") as mrc:
            mrc.set_data(np.add.outer(np.arange(40), np.arange(48)).astype(np.float32)[None])
            mrc.voxel_size = 2.5
        layers = napari_get_reader("map2.mrc")("map2.mrc")
        assert layers and layers[0][0].shape[-2:] == (40, 48), layers
    """,
}


def _pip(venv: Path, *args: str, timeout_s: float) -> None:
    done = subprocess.run([str(venv / "bin" / "python"), "-m", "pip", "install", "-q", "--disable-pip-version-check", *args],
                          capture_output=True, text=True, timeout=timeout_s)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """A wheel built by `python -m build` from a copy of the tracked files (the checkout stays clean)."""
    source = tmp_path_factory.mktemp("source")
    tracked = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    for name in filter(None, tracked.split("\0")):
        (source / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, source / name)
    out = tmp_path_factory.mktemp("dist")
    subprocess.run([sys.executable, "-m", "build", "--wheel", "--outdir", str(out), str(source)],
                   capture_output=True, check=True, timeout=600)
    return next(out.glob("tamp_os-*.whl"))


@pytest.fixture(scope="module")
def core(wheel, tmp_path_factory) -> tuple[Path, Path]:
    """A clean venv with the core installed from the wheel by pip, and a folder with its first conversion."""
    venv = tmp_path_factory.mktemp("venv")
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=120)
    _pip(venv, str(wheel), timeout_s=600)
    work = tmp_path_factory.mktemp("work")
    from PIL import Image
    import numpy as np

    Image.fromarray(np.add.outer(np.arange(60), np.arange(80)).astype(np.uint8) * 2).save(work / "ramp.png")
    subprocess.run([str(venv / "bin" / "tamp-os"), "convert", "ramp.png", "-o", "out", "--formats", "stl"],
                   cwd=work, check=True, capture_output=True, timeout=300, env=_env(venv))
    return venv, work


def _env(venv: Path) -> dict[str, str]:
    return dict(os.environ, PATH=f"{venv / 'bin'}:{os.environ['PATH']}", PYTHONPATH="", VIRTUAL_ENV=str(venv))


def test_the_wheel_carries_the_napari_manifest_templates_and_static_files(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    for wanted in ("tamp_os/napari/napari.yaml", "tamp_os/gui/templates/index.html", "tamp_os/gui/static/app.js",
                   "tamp_os/gui/static/style.css", "tamp_os/gui/static/vendor/model-viewer.min.js"):
        assert wanted in names
    entry_points = zipfile.ZipFile(wheel).read(next(n for n in names if n.endswith("entry_points.txt"))).decode()
    assert "[napari.manifest]" in entry_points and "tamp_os.napari:napari.yaml" in entry_points


@pytest.mark.timeout(1200)
def test_the_core_installs_from_its_lower_bounds_and_converts_a_png(core):
    venv, work = core
    version = subprocess.run([str(venv / "bin" / "tamp-os"), "--version"], capture_output=True, text=True, check=True)
    assert version.stdout.startswith("tamp-os ")
    import trimesh

    plate = trimesh.load(work / "out" / "ramp.stl")
    assert plate.is_watertight and plate.volume > 0
    # The core brings none of the extras.
    missing = subprocess.run([str(venv / "bin" / "python"), "-c", "import fastapi"], capture_output=True)
    assert missing.returncode != 0


@pytest.mark.timeout(1200)
@pytest.mark.parametrize("extra", list(FEATURES))
def test_each_extra_installs_on_the_core_and_its_feature_works(core, wheel, extra, request):
    venv, work = core
    argv = []
    if extra == "dm":
        dm3 = FIXTURES / "test_STEM_image.dm3"
        need(dm3.is_file(), f"fixture {dm3.name}")
        argv = [str(dm3)]
    _pip(venv, f"{wheel}[{extra}]", timeout_s=1100)
    done = subprocess.run([str(venv / "bin" / "python"), "-c", textwrap.dedent(FEATURES[extra]), *argv],
                          cwd=work, capture_output=True, text=True, timeout=300, env=_env(venv))
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]


@pytest.mark.timeout(300)
def test_the_lock_agrees_with_pyproject():
    uv = ROOT / ".tools" / "uv" / "bin" / "uv"
    need(uv.is_file(), "uv in .tools/uv (make setup installs it)")
    done = subprocess.run([str(uv), "-q", "lock", "--check"], cwd=ROOT, capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stderr


@pytest.mark.timeout(300)
def test_the_set_up_refuses_a_lock_that_pyproject_has_moved_past_and_names_make_lock(tmp_path):
    """A dependency added to pyproject.toml without `make lock`: the set-up stops in one line naming
    the command, and writes no stamp, so no later run trusts the .venv it began."""
    uv = ROOT / ".tools" / "uv" / "bin" / "uv"
    need(uv.is_file(), "uv in .tools/uv (make setup installs it)")
    (tmp_path / "scripts").mkdir()
    shutil.copy(ROOT / "scripts" / "setup.sh", tmp_path / "scripts" / "setup.sh")
    shutil.copy(ROOT / "uv.lock", tmp_path / "uv.lock")
    shutil.copytree(ROOT / ".tools" / "uv", tmp_path / ".tools" / "uv", symlinks=True)
    pyproject = (ROOT / "pyproject.toml").read_text()
    (tmp_path / "pyproject.toml").write_text(pyproject.replace('    "tqdm>=4.60",', '    "tqdm>=4.60",\n    "six>=1.16",', 1))
    done = subprocess.run(["bash", "scripts/setup.sh"], cwd=tmp_path, capture_output=True, text=True, timeout=280,
                          env=dict(os.environ, PATH="/usr/bin:/bin"))
    assert done.returncode == 1, done.stdout + done.stderr
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("setup: uv.lock does not agree with pyproject.toml") and "make lock" in last
    assert not (tmp_path / ".venv" / ".tamp-installed").exists()
