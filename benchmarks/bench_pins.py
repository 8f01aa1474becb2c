"""Pin displays (issue 34) on the real development set: what each page of each display keeps.

    PYTHONPATH=src python benchmarks/bench_pins.py [OUT_FOLDER] [FILES...]

For each file, a table per display and page: raised pins, regions kept of those found in the
page's window, lines kept connected (source line pieces longer than a pin that land on a single
pin line, over those pieces), members kept separate (kept members whose pins are one piece with a
one-pin gap to every other region), and the scale ("1 pin = X"). Writes each display's files and
simulator PNG, and the plate's heights as a grey PNG beside them, into OUT_FOLDER (default
/tmp/tamp-os-pins) to look at.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
from scipy import ndimage

from tamp_os.errors import ExportError
from tamp_os.export.pin_files import pin_sets, save_pins
from tamp_os.export.pins import length_words, skeleton_of
from tamp_os.export.files import to_uint8, write_png
from tamp_os import make_lithograph

FIXTURES = Path(__file__).resolve().parents[2] / "shared" / "fixtures"
if not FIXTURES.is_dir():
    FIXTURES = Path("/work/shared/fixtures")
DEVELOPMENT_SET = ["fept_spheres_sem.png", "real/sem_fei_sio2_particles_35kx.tif", "real/zeiss_sem_al2o3_grains.czi",
                   "real/zeiss_dapi_gfp_2ch.czi", "real/stem_haadf_pto_sro_superlattice.hspy"]
EIGHT = np.ones((3, 3), bool)


def lines_connected(layer_data: np.ndarray, page) -> tuple[int, int, float]:
    """(pieces kept on one pin line, pieces) for the source line pieces longer than a pin, and the
    share of the source lines' length that lies within a pin of a pin line."""
    r0, r1, c0, c1 = page.window
    oy, ox, s = page.placement
    skeleton = skeleton_of(layer_data.astype(bool))[r0:r1, c0:c1]
    pieces, n = ndimage.label(skeleton, EIGHT)
    line_id = np.zeros(page.pins.shape, int)
    for k, region in enumerate((r for r in page.regions if r.layer == "lines"), start=1):
        line_id[region.mask] = k
    near = ndimage.grey_dilation(line_id, footprint=EIGHT)  # thinning may move a line by a pin
    ys, xs = np.nonzero(skeleton)
    all_py = np.clip((ys * s).astype(int) + oy, 0, page.pins.shape[0] - 1)
    all_px = np.clip((xs * s).astype(int) + ox, 0, page.pins.shape[1] - 1)
    length_share = float((near[all_py, all_px] > 0).mean()) if ys.size else 1.0
    kept = total = 0
    for k in range(1, n + 1):
        ys, xs = np.nonzero(pieces == k)
        if ys.size < 2 / s:
            continue
        total += 1
        py = np.clip((ys * s).astype(int) + oy, 0, page.pins.shape[0] - 1)
        px = np.clip((xs * s).astype(int) + ox, 0, page.pins.shape[1] - 1)
        ids = near[py, px]
        if (ids > 0).mean() >= 0.9 and len(set(ids[ids > 0])) == 1:
            kept += 1
    return kept, total, length_share


def members_separate(page) -> int:
    """Kept members that are one piece and keep a one-pin gap from every other region."""
    others = [r for r in page.regions if r.layer != "braille"]
    good = 0
    for r in others:
        if r.layer not in ("members", "dots"):
            continue
        grown = ndimage.binary_dilation(r.mask, EIGHT)
        alone = not any((grown & o.mask).any() for o in others if o is not r)
        if alone and ndimage.label(r.mask, EIGHT)[1] == 1:
            good += 1
    return good


def bench(path: Path, out: Path) -> None:
    start = time.perf_counter()
    litho = make_lithograph(path)
    made = time.perf_counter() - start
    stem = path.stem
    relief = (litho.heightmap - litho.params.base_mm) / litho.params.relief_mm
    write_png(out / f"{stem}.plate-heights.png", 255 - to_uint8(relief, 0.0, 1.0))
    print(f"\n## {path.name}  (relief {litho.report.relief_style} {litho.report.content_kind}, lithograph {made:.1f} s)")
    try:
        start = time.perf_counter()
        sets = pin_sets(litho, ["dotpad", "graphiti", "monarch"])
        paged = time.perf_counter() - start
    except ExportError as exc:
        print(f"refused: {exc}")
        return
    print(f"pages for three displays in {paged:.2f} s; layers: "
          + ", ".join(f"{layer.label} ({layer.kind})" for layer in sets["dotpad"].source.layers))
    print("| display | page | raised pins | regions kept / found | lines kept connected | members kept separate | 1 pin = |")
    print("|---|---|---|---|---|---|---|")
    for fmt, pin_set in sets.items():
        save_pins(pin_set, fmt, out, stem=stem, title=f"Tactile lithograph of {path.name}")
        line_layers = [layer for layer in pin_set.source.layers if layer.kind == "lines"]
        for page in pin_set.pages[:-1]:
            kept = sum(c.get("kept", 0) for c in page.counts.values())
            found = sum(c["found"] for c in page.counts.values())
            connected = "–"
            if line_layers:
                pairs = [lines_connected(layer.data, page) for layer in line_layers]
                k, t = sum(p[0] for p in pairs), sum(p[1] for p in pairs)
                connected = f"{k} / {t} ({min(p[2] for p in pairs):.0%} of the length)"
            members = sum(c.get("kept", 0) for lbl, c in page.counts.items()
                          if any(layer.label == lbl and layer.kind in ("members", "dots") for layer in pin_set.source.layers))
            separate = f"{members_separate(page)} / {members}" if members else "–"
            scale = length_words(page.um_per_pin) if page.um_per_pin else "unknown"
            name = page.name.split(",")[0]
            print(f"| {fmt} | {name} | {int((page.pins > 0).sum())} | {kept} / {found} | {connected} | {separate} | {scale} |")


def main(argv: list[str]) -> None:
    out = Path(argv[0]) if argv else Path("/tmp/tamp-os-pins")
    out.mkdir(parents=True, exist_ok=True)
    files = [Path(a) for a in argv[1:]] or [FIXTURES / f for f in DEVELOPMENT_SET]
    for path in files:
        if path.exists():
            bench(path, out)
        else:
            print(f"\n## {path.name}: not found, skipped")
    print(f"\nFiles and simulator PNGs in {out}")


if __name__ == "__main__":
    main(sys.argv[1:])
