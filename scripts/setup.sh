#!/usr/bin/env bash
# Set up everything TAMP-OS needs on a Debian machine; safe to run again (does only what is missing).
# System packages (braille, slicer, browser) come from apt-get when we are root or have sudo;
# otherwise the missing ones are named. Python packages go into .venv.
set -euo pipefail
cd "$(dirname "$0")/.."

# python3-venv for .venv; tesseract-ocr-eng holds the model that both the tesseract command and tesserocr (the ocr extra) read; libcairo2-dev + pkg-config to build pycairo; poppler-utils (pdfinfo, pdftoppm) to check PDFs; Mesa EGL/GL for PyVista offscreen; GLU and X client libraries that the gmsh wheel links; for the napari plugin's tests, Xvfb (napari draws with OpenGL: Qt's offscreen platform gets it from an X display) and the libraries the PyQt5 wheel's Qt links (D-Bus, fontconfig, GLib, X11).
if [ "${1:-}" != --lock ]; then
APT_PACKAGES="python3-venv liblouis-bin liblouis-data python3-louis prusa-slicer chromium tesseract-ocr tesseract-ocr-eng fonts-dejavu-core libegl1 libgl1 libglu1-mesa libxcursor1 libxft2 libxinerama1 libcairo2-dev pkg-config poppler-utils nodejs npm epubcheck xvfb libdbus-1-3 libfontconfig1 libglib2.0-0 libx11-6 libxext6"
missing=""
for pkg in $APT_PACKAGES; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing="$missing $pkg"
done
# nodejs/npm may come from elsewhere (nvm, a tarball): only ask apt for them when the commands are absent.
command -v node >/dev/null 2>&1 && missing="${missing/ nodejs/}"
command -v npm >/dev/null 2>&1 && missing="${missing/ npm/}"
if [ -n "${missing// /}" ]; then
  if [ "$(id -u)" = 0 ]; then SUDO=""; elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then SUDO="sudo"; else SUDO="none"; fi
  if [ "$SUDO" = none ]; then
    echo "setup: missing system packages:$missing"
    echo "setup: install them with: sudo apt-get install$missing (tests that need them will skip or, with TAMP_STRICT=1, fail)"
  else
    echo "setup: installing system packages:$missing"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
  fi
fi
fi

PY=${PYTHON:-python3}
# The Python packages come from the committed lock (uv.lock, refreshed by `make lock`), installed by
# a pinned uv that the standard library's venv and its own pip fetch: the same versions on every
# machine, whatever PyPI published since, and no resolver run at set-up time.
UV_VERSION=0.13.9
UV=.tools/uv/bin/uv
export UV_PYTHON_DOWNLOADS=never UV_PROJECT_ENVIRONMENT=.venv
# No package cache when pip is told to keep none; uv's progress bars only on a terminal.
if [ -n "${PIP_NO_CACHE_DIR:-}" ]; then export UV_NO_CACHE=1; fi
UV_QUIET=-q
if [ -t 1 ]; then UV_QUIET=""; fi
if [ ! -x "$UV" ] || [ "$("$UV" --version 2>/dev/null)" != "uv $UV_VERSION" ]; then
  echo "setup: installing the package installer uv $UV_VERSION into .tools/uv"
  rm -rf .tools/uv
  "$PY" -m venv .tools/uv
  if ! pip_said=$(.tools/uv/bin/python -m pip install -q --disable-pip-version-check "uv==$UV_VERSION" 2>&1); then
    # (without pip's notes about configured package folders that a machine lacks)
    echo "$pip_said" | grep -v "^WARNING: Location" >&2
    rm -rf .tools/uv
    echo "setup: could not install uv $UV_VERSION from PyPI (pip's message above says why); check the connection to PyPI and run make setup again" >&2
    exit 1
  fi
fi
if [ "${1:-}" = --lock ]; then
  shift
  "$UV" lock "$@"
  echo "setup: uv.lock agrees with pyproject.toml; commit them together"
  exit 0
fi
# The stamp holds the lock's hash and is written last: a .venv whose install stopped half-way has no
# matching stamp, so the next run installs again (uv sync repairs what is there).
stamp=.venv/.tamp-installed
want="$(cat pyproject.toml uv.lock scripts/setup.sh | sha256sum | cut -d' ' -f1)"
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  rm -f "$stamp"
  if ! "$UV" -q lock --check; then
    echo "setup: uv.lock does not agree with pyproject.toml: run make lock, then commit uv.lock with pyproject.toml" >&2
    exit 1
  fi
  echo "setup: installing tamp-os and the locked Python packages into .venv (uv sync, about a minute)"
  if ! "$UV" $UV_QUIET sync --locked --python "$PY" --extra test --extra all --extra napari; then
    echo "setup: installing the Python packages failed: uv's message above names the package; fix what it says (a system library missing for a package built from source: see the list above), then run make setup again" >&2
    exit 1
  fi
  .venv/bin/python -c "import tamp_os, lib3mf, trimesh, tifffile, czifile, liffile, nd2, mrcfile, zarr, h5py, tesserocr, fastapi, uvicorn, pyvista, distributed, napari, magicgui, npe2, pytestqt"
  echo "$want" > "$stamp"
fi

if command -v npm >/dev/null 2>&1 && [ ! -d .tools/node_modules/gltf-validator ]; then
  echo "setup: installing the Khronos glTF validator (npm) into .tools"
  mkdir -p .tools
  npm install --silent --prefix .tools gltf-validator@2.0.0-dev.3.10 >/dev/null
fi
echo "setup: done"
