"""Rendered previews of meshes: an isometric full view and a close-up, with alt text.

PyVista (VTK) renders offscreen with no display through EGL; the window class is chosen by
VTK_DEFAULT_OPENGL_WINDOW, which must name an installed backend (an empty or wrong value crashes
the process), so we set it only when it is unset. Orthographic projection, a key light and a
fill light, matte shading (no specular highlights), light or dark theme.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import MissingDependencyError, ParameterError, require_extra
from ..export.files import write_png, write_text
from ..formats import READABLE_MESH_SUFFIXES as MESH_SUFFIXES
THEMES = {"light": ("white", "#b9b4ab"), "dark": ("#1e1e1e", "#c8c2b8")}


@dataclass(frozen=True)
class View:
    width_px: int = 1200
    height_px: int = 900
    azimuth_deg: float = -30.0
    elevation_deg: float = 35.0
    zoom: float = 1.0
    closeup_zoom: float = 3.0
    theme: str = "light"

    def __post_init__(self):
        if not (64 <= self.width_px <= 8192 and 64 <= self.height_px <= 8192):
            raise ParameterError(f"render size: each side must be 64–8192 px; got {self.width_px}×{self.height_px}.")
        if not 0 <= self.elevation_deg <= 90:
            raise ParameterError(f"elevation: must be 0–90 degrees; got {self.elevation_deg}.")
        if not (0.1 <= self.zoom <= 20 and 1 <= self.closeup_zoom <= 50):
            raise ParameterError(f"zoom: must be 0.1–20 (close-up 1–50); got {self.zoom} and {self.closeup_zoom}.")
        if self.theme not in THEMES:
            raise ParameterError(f"theme: must be light or dark; got {self.theme!r}.")


OFFSCREEN_ENV = {"VTK_DEFAULT_OPENGL_WINDOW": "vtkEGLRenderWindow"}  # EGL + Mesa: no X server needed


def _pyvista():
    # The entry points (cli.main, gui.serve) set OFFSCREEN_ENV; a library must not change the
    # process environment behind its caller's back, so here we only say what is missing.
    if not os.environ.get("VTK_DEFAULT_OPENGL_WINDOW") and not os.environ.get("DISPLAY"):
        raise MissingDependencyError(
            "rendering without a display needs the environment variable VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow "
            "set before PyVista is imported (the tamp-os command and the web app set it; in a notebook run "
            "os.environ.update(tamp_os.lithograph.render.OFFSCREEN_ENV) first)."
        )
    require_extra("render", "rendering", "pyvista")
    import pyvista

    pyvista.OFF_SCREEN = True
    return pyvista


def _load(path: Path):
    import trimesh

    mesh = trimesh.load(path, force="mesh", process=False)
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)


def render_views(vertices: np.ndarray, faces: np.ndarray, view: View) -> tuple[np.ndarray, np.ndarray]:
    """(full view, close-up) as RGB uint8 arrays."""
    pv = _pyvista()
    cells = np.hstack([np.full((len(faces), 1), 3), faces]).ravel()
    surface = pv.PolyData(vertices, cells)
    background, colour = THEMES[view.theme]
    plotter = pv.Plotter(off_screen=True, window_size=(view.width_px, view.height_px), lighting="none")
    plotter.set_background(background)
    plotter.add_mesh(surface, color=colour, smooth_shading=False, specular=0.0, diffuse=0.85, ambient=0.15)
    # Key light from the upper left of the viewer, fill light from the right, both following the camera.
    plotter.add_light(pv.Light(position=(-1.0, 1.0, 1.0), focal_point=(0, 0, 0), intensity=1.0, light_type="camera light"))
    plotter.add_light(pv.Light(position=(1.0, -0.3, 0.6), focal_point=(0, 0, 0), intensity=0.45, light_type="camera light"))
    plotter.enable_parallel_projection()
    # Look from in front of the print (from -y, where the reader sits), turned by the azimuth
    # and raised by the elevation, with +z up: the far edge (top of the image) appears at the top.
    centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
    az, el = np.radians(view.azimuth_deg), np.radians(view.elevation_deg)
    direction = np.array([np.sin(az) * np.cos(el), -np.cos(az) * np.cos(el), np.sin(el)])
    distance = 3 * float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))
    plotter.camera_position = [tuple(centre + distance * direction), tuple(centre), (0, 0, 1)]
    plotter.reset_camera()
    plotter.camera.zoom(view.zoom)
    plotter.render()
    full = plotter.screenshot(return_img=True)
    plotter.camera.zoom(view.closeup_zoom)
    plotter.render()
    close = plotter.screenshot(return_img=True)
    plotter.close()
    return full, close


def alt_text(name: str, vertices: np.ndarray, view: View, *, closeup: bool) -> str:
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    size = hi - lo
    what = f"Close-up, {view.closeup_zoom:g} times nearer, of the centre of" if closeup else "Rendered view of"
    return (
        f"{what} the 3D-printable tactile relief {name}: a plate {size[0]:.0f} by {size[1]:.0f} mm and up to "
        f"{size[2]:.1f} mm high, seen from {view.elevation_deg:g} degrees above the horizon, turned "
        f"{view.azimuth_deg:g} degrees; raised parts of the relief are lit from the upper left."
    )


def render_file(path: Path, out_dir: Path, view: View) -> list[Path]:
    """Write renders/full/NAME.png and renders/closeup/NAME.png, each with NAME.alt.txt beside it."""

    vertices, faces = _load(path)
    full, close = render_views(vertices, faces, view)
    written = []
    for kind, image in (("full", full), ("closeup", close)):
        folder = out_dir / "renders" / kind
        folder.mkdir(parents=True, exist_ok=True)
        written.append(write_png(folder / f"{path.stem}.png", image))
        written.append(write_text(folder / f"{path.stem}.alt.txt", alt_text(path.stem, vertices, view, closeup=kind == "closeup") + "\n"))
    return written


def find_meshes(items) -> list[Path]:
    """Meshes named, and in folders one file per name (the same print in several formats is
    rendered once, from the first of MESH_SUFFIXES present)."""
    found = []
    for item in map(Path, items):
        if item.is_dir():
            by_stem: dict[str, Path] = {}
            for path in sorted(item.iterdir(), key=lambda p: (p.stem, MESH_SUFFIXES.index(p.suffix.lower()) if p.suffix.lower() in MESH_SUFFIXES else 99)):
                if path.suffix.lower() in MESH_SUFFIXES:
                    by_stem.setdefault(path.stem, path)
            found += list(by_stem.values())
        else:
            found.append(item)
    return found
