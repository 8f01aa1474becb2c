"""Panel detection speed on 4000 × 3000 figures (issue 23: at most 0.3 s, letters included): the
geometry alone (gutters, cut, classification, regular grid, edges at full resolution), the
letters alone (corner search and OCR, on the boxes found), and the whole detection, wall and CPU time, best of 5 (the machine is 2 cores shared with other work: the best
run is the one least disturbed, and the CPU time is what the detection itself costs). Letters are
read in process by tesserocr; the last column is the whole detection with the `tesseract` command
instead (the fallback). Also: the model's load (once per process) and the first figure of a
process, the time on single micrographs, which are never split, and the time to say what every
panel of a 4000 × 3000 figure shows (the overview's words).

    PYTHONPATH=src .venv/bin/python benchmarks/bench_panels.py          (all)
    PYTHONPATH=src .venv/bin/python benchmarks/bench_panels.py words    (the overview's words only)
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from figures import FIXTURES, dark_fluorescence, grid_white_boxes, row_on_black, synthetic_texture, with_title  # noqa: E402

from tamp_os.clean import ocr  # noqa: E402
from tamp_os.clean.panels import _labels, detect_panels  # noqa: E402


def best_of(fn, runs: int = 5) -> tuple[float, float, object]:
    """Best wall time and best CPU time (this process, all its threads) of `runs`."""
    walls, cpus, result = [], [], None
    for _ in range(runs):
        wall, cpu = time.perf_counter(), time.process_time()
        result = fn()
        cpus.append(time.process_time() - cpu)
        walls.append(time.perf_counter() - wall)
    return min(walls), min(cpus), result


def figures():
    yield "2×2 white, letters in boxes", grid_white_boxes([synthetic_texture(1460, 1960, s) for s in range(4)], cols=2, gutter=26, size=120)
    yield "1×3 black, dark panel", row_on_black([synthetic_texture(2800, 1300, 5), dark_fluorescence(2800, 1300, 6),
                                                 synthetic_texture(2800, 1300, 7)], gutter=40, top=160, size=120)
    yield "1×3 white, title strip", with_title([synthetic_texture(2800, 1300, s) for s in range(3)], gutter=40)


def with_command(fn):
    """fn() with the letters read by the tesseract command (the in-process API set aside)."""
    saved = dict(ocr._state)
    ocr._state.clear()
    ocr._state["failed"] = "benchmark: the command line"
    try:
        return fn()
    finally:
        ocr._state.clear()
        ocr._state.update(saved)


def main() -> None:
    made = list(figures())
    first = made[0][1].image.astype(np.float32)
    wall, cpu = time.perf_counter(), time.process_time()
    cold = detect_panels(first)  # the model loads when the first letters are read
    cold_wall, cold_cpu = time.perf_counter() - wall, time.process_time() - cpu
    load = ocr._state.get("seconds")
    print(f"OCR backend: {ocr.backend()}; first figure of the process (model load included): {cold_wall:.3f} s wall, "
          f"{cold_cpu:.3f} s CPU, letters {','.join(cold.labels())}" + (f"; the load alone {load:.3f} s" if load else ""))
    print()
    print("| figure | size px | panels | geometry ms wall / CPU | letters ms wall / CPU | total ms wall / CPU | letters | total with the tesseract command ms |")
    print("|---|---|---|---|---|---|---|---|")
    for name, fig in made:
        values = fig.image.astype(np.float32)
        g_wall, g_cpu, layout = best_of(lambda: detect_panels(values, read_letters=False))
        l_wall, l_cpu, _ = best_of(lambda: _labels(values, None, layout.boxes(), True))
        t_wall, t_cpu, lettered = best_of(lambda: detect_panels(values))
        c_wall, _, by_command = with_command(lambda: best_of(lambda: detect_panels(values), runs=3))
        assert by_command.labels() == lettered.labels(), (by_command.labels(), lettered.labels())
        h, w = values.shape
        print(f"| {name} | {w}×{h} | {len(layout.panels)} | {1e3 * g_wall:.0f} / {1e3 * g_cpu:.0f} | "
              f"{1e3 * l_wall:.0f} / {1e3 * l_cpu:.0f} | {1e3 * t_wall:.0f} / {1e3 * t_cpu:.0f} | "
              f"{','.join(lettered.labels())} | {1e3 * c_wall:.0f} |")
    from tamp_os.read.image import read_image

    print("\n| single micrograph | size px | split | s |")
    print("|---|---|---|---|")
    for name in ("fept_spheres_sem.png", "test_tiff_Zeiss_SEM_1k.tif", "real/aperio_cmu1_he_skin.svs", "real/sem_fei_sio2_particles_35kx.tif"):
        if (FIXTURES / name).is_file():
            values = read_image(FIXTURES / name).values
            seconds, _, layout = best_of(lambda: detect_panels(values))
            print(f"| {name} | {values.shape[1]}×{values.shape[0]} | {layout.split} | {seconds:.3f} |")
    words()


def words() -> None:
    """What each panel shows (relief/content_word.py), for the overview: every panel of a 4000 ×
    3000 figure, best of 5, wall / CPU ms, with the words found."""
    from PIL import Image

    from figures import fluorescence_composite, grid_colour
    from synthetic_content import dark_line_network, dim_and_bright_beads, dot_lattice, faint_grains

    from tamp_os.lithograph.figure import figure_colour, panel_contents
    from tamp_os.params import LithoParams
    from tamp_os.read.image import read_array

    def big(image):
        image = image if image.dtype == np.uint8 else (np.clip(image, 0, 1) * 255).astype(np.uint8)
        return np.asarray(Image.fromarray(image).resize((1960, 1460), Image.Resampling.BILINEAR))

    beads, lines, grains, lattice = (m(300, 400).image for m in (dim_and_bright_beads, dark_line_network, faint_grains, dot_lattice))
    sets = {"grey: beads, grain boundaries, faint grains, lattice": [beads, lines, grains, lattice],
            "colour: beads, grain boundaries, faint grains, fluorescence": [beads, lines, grains, fluorescence_composite(300, 400)],
            "grey: four textures": [synthetic_texture(1460, 1960, s) for s in range(4)]}
    print("\n| figure (4 panels) | size px | words | words ms wall / CPU |")
    print("|---|---|---|---|")
    for name, panels in sets.items():
        fig = grid_colour([big(p) for p in panels], cols=2, gutter=26, size=120)
        picture = read_array(fig.image)
        layout = detect_panels(picture.values, read_letters=False)
        colour = figure_colour(fig.image, picture, LithoParams())
        wall, cpu, found = best_of(lambda: panel_contents(picture.values, layout, colour))
        said = "; ".join(f"{k}: {w.words}" for k, w in found.items())
        print(f"| {name} | {fig.image.shape[1]}×{fig.image.shape[0]} | {said} | {1e3 * wall:.0f} / {1e3 * cpu:.0f} |")
    import os

    print(f"\nload average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    if sys.argv[1:] == ["words"]:
        words()
    else:
        main()
