#!/usr/bin/env bash
# Set up everything TAMP-OS needs on a Debian machine; safe to run again (does only what is missing).
# System packages (braille, slicer, browser) come from apt-get when we are root or have sudo;
# otherwise the missing ones are named. Python packages go into .venv.
set -euo pipefail
cd "$(dirname "$0")/.."

# python3-venv for .venv; tesseract-ocr-eng holds the model that both the tesseract command and tesserocr (the ocr extra) read; libcairo2-dev + pkg-config to build pycairo; poppler-utils (pdfinfo, pdftoppm) to check PDFs; Mesa EGL/GL for PyVista offscreen; GLU and X client libraries that the gmsh wheel links; for the napari plugin's tests, Xvfb (napari draws with OpenGL: Qt's offscreen platform gets it from an X display) and the libraries the PyQt5 wheel's Qt links (D-Bus, fontconfig, GLib, X11).
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

PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv"
  "$PY" -m venv .venv
fi
stamp=.venv/.tamp-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ] || [ scripts/setup.sh -nt "$stamp" ]; then
  echo "setup: installing the tamp-os package and its Python dependencies into .venv"
  .venv/bin/python -m pip install -q --upgrade pip 2>&1 | grep -v "^WARNING: Location" || true
  .venv/bin/python -m pip install -q -e ".[test,all,napari]" 2>&1 | grep -v "^WARNING: Location" || true
  .venv/bin/python -c "import tamp_os, lib3mf, trimesh, tifffile, czifile, liffile, nd2, mrcfile, zarr, h5py, tesserocr, fastapi, uvicorn, pyvista, distributed, napari, magicgui, npe2, pytestqt"
  touch "$stamp"
fi

if command -v npm >/dev/null 2>&1 && [ ! -d .tools/node_modules/gltf-validator ]; then
  echo "setup: installing the Khronos glTF validator (npm) into .tools"
  mkdir -p .tools
  npm install --silent --prefix .tools gltf-validator@2.0.0-dev.3.10 >/dev/null
fi
echo "setup: done"
