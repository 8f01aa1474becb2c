"""Issue 22 benchmark: how much of each channel's structure a finger finds raised, and the time it costs.

Per channel: the share of its structures (Otsu foreground of the channel on the print grid, found
independently of the encoder's own masks) raised at least 0.5 mm over the background. For the H&E
slides (he_heights): the median height of nuclei (haematoxylin above Otsu within the tissue), of
stroma (bottom 40 %) and of white space, and the share of nuclei ≥ 0.5 mm over the stroma. Speed: a three-channel Medium print against the same picture as one channel.

    PYTHONPATH=src python benchmarks/bench_channels.py
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np
from skimage import filters
from skimage.transform import resize

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "tests" / "relief"))
REAL = ROOT.parent / "shared" / "fixtures" / "real"

from tamp_os.lithograph.pipeline import make_lithograph
from tamp_os.relief import channel_stage
from tamp_os.relief.channels import stain_channels

RAISED_MM = 0.5


def _structures(values: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    v = resize(values.astype(np.float64), shape, anti_aliasing=True)
    return v > filters.threshold_otsu(v)


def channel_rows(name: str, source, **kw) -> list[tuple]:
    t = time.perf_counter()
    litho = make_lithograph(source, **kw)  # the channel path is the default for these
    dt = time.perf_counter() - t
    r = litho.report
    grown_rows = round((r.relief_mm[1] - (r.relief_mm[1] - _key_depth(litho))) / r.mm_per_px)
    h = litho.heightmap[: litho.heightmap.shape[0] - grown_rows] - litho.params.base_mm
    raw = {n: v for n, v, _, _ in channel_stage.raw_channels(source, litho.params)}
    background = np.median(h[h < RAISED_MM]) if (h < RAISED_MM).any() else 0.0
    rows = []
    for e in r.key:
        chan = e.label.rsplit("(", 1)[-1].rstrip(")")
        if chan not in raw:
            continue
        s = _structures(raw[chan], h.shape)
        rows.append((name, chan, e.encoding, e.label, f"{100 * float((h[s] - background >= RAISED_MM).mean()):.0f} %", f"{dt:.2f}"))
    return rows


def _key_depth(litho) -> float:
    for w in litho.report.warnings:
        if "grew by" in str(w):
            return float(str(w).split("grew by ")[1].split(" mm")[0])
    return 0.0


HE_FILES = ("aperio_cmu1_he_skin.svs", "histo_he_carcinoma_dense_nuclei.png", "histo_he_stroma_collagen_vessel.png",
            "aperio_tcga_cr7395_j2k_no_mpp.svs")


def he_heights(path, **kw) -> dict:
    """Median heights above the base (mm) of nuclei, stroma and white (lumens, glass) on the print,
    the masks found from the source independently of the relief: haematoxylin (rgb2hed) of the source
    on the print grid above Otsu within the tissue = nuclei; the tissue's haematoxylin bottom 40 % = stroma;
    brightness > 0.85 = white. Also the share of the nuclei raised ≥ 0.5 mm over the stroma's median."""
    from tamp_os.read.channels import read_channels

    litho = make_lithograph(path, width_mm=100, **kw)
    r = litho.report
    planes = read_channels(path)
    rgb = np.stack([c.values for c in planes[:3]], axis=-1) / 255.0
    rows_picture = round(100 * rgb.shape[0] / rgb.shape[1] / r.mm_per_px) + 1
    h = litho.heightmap[:rows_picture] - litho.params.base_mm
    small = resize(rgb, h.shape + (3,), anti_aliasing=True)
    white = small.mean(axis=2) > 0.85
    hem = stain_channels(small)[0].image
    tissue = ~white
    nuclei = tissue & (hem > filters.threshold_otsu(hem[tissue]))
    stroma = tissue & (hem <= np.percentile(hem[tissue], 40)) & ~nuclei
    over = float(np.median(h[nuclei]) - np.median(h[stroma]))
    felt = float((h[nuclei] - np.median(h[stroma]) >= RAISED_MM).mean())
    return {"style": r.relief_style, "key": "; ".join(f"{e.encoding}: {e.label}" for e in r.key) or "-",
            "nuclei": float(np.median(h[nuclei])), "stroma": float(np.median(h[stroma])),
            "white": float(np.median(h[white])) if white.any() else float("nan"), "white_share": float(white.mean()),
            "over": over, "felt": felt}


def he_rows(**kw) -> list[tuple]:
    rows = []
    for name in HE_FILES:
        m = he_heights(REAL / name, **kw)
        rows.append((name, m["style"], m["key"], f"{m['nuclei']:.2f}", f"{m['stroma']:.2f}", f"{m['white']:.2f}",
                     f"{100 * m['white_share']:.0f} %", f"{m['over']:+.2f}", f"{100 * m['felt']:.0f} %"))
    return rows


def speed(runs: int = 5) -> tuple[float, float]:
    """CPU seconds (time.process_time, best of `runs`) of the 600x600 composite as one channel and as three with its key."""
    from test_channels import _synthetic_channels

    n, f, s = _synthetic_channels(600, 600)
    rgb = (np.stack([f, s, n], axis=-1) * 230).astype(np.uint8)
    make_lithograph(rgb, preset="medium", width_mm=100)  # imports and caches, not timed
    best = {}
    for label, kw in (("one", {"channel": "blue"}), ("three", {})):
        times = []
        for _ in range(runs):
            t = time.process_time()
            make_lithograph(rgb, preset="medium", width_mm=100, **kw)
            times.append(time.process_time() - t)
        best[label] = min(times)
    return best["one"], best["three"]


def decision_rows() -> list[tuple]:
    """Every real fixture: does it take the channel path by default, and why (relief/channel_auto.py)."""
    from tamp_os.params import LithoParams
    from tamp_os.read.image import read_image
    from tamp_os.relief.channel_auto import colour_facts, colour_kind, route

    top = ROOT.parent / "shared" / "fixtures"
    rows = []
    for path in sorted(p for p in list(top.iterdir()) + list(REAL.iterdir()) if p.is_file() and p.suffix not in (".md", ".ser")):
        picture = read_image(path)
        got = route(path, picture, LithoParams())
        if got:
            rows.append((path.name, "channels", got.why))
        else:
            sample = picture.file.colour_sample
            why = colour_kind(colour_facts(sample))[1] if sample is not None else f"{picture.file.channel_count} channel"
            rows.append((path.name, "luminance", why))
    return rows


def main() -> None:
    print("| fixture | path by default | why |")
    print("|---|---|---|")
    for row in decision_rows():
        print("| " + " | ".join(row) + " |")
    print()
    from test_channels import _synthetic_channels

    n, f, s = _synthetic_channels()
    rows = channel_rows("synthetic RGB composite", (np.stack([f, s, n], axis=-1) * 230).astype(np.uint8), width_mm=90)
    rows += channel_rows("zeiss_dapi_gfp_2ch.czi", REAL / "zeiss_dapi_gfp_2ch.czi", width_mm=100)
    rows += channel_rows("nikon_pbmc_4ch.nd2", REAL / "nikon_pbmc_4ch.nd2", width_mm=80)
    rows += channel_rows("zeiss_airyscan_2ch_t3.czi", REAL / "zeiss_airyscan_2ch_t3.czi", width_mm=100)
    rows += channel_rows("leica_beads_xz_2ch.lif (XZ section)", REAL / "leica_beads_xz_2ch.lif", width_mm=100)
    rows += channel_rows("fluo_cell_dna_mt_actin_3ch.tif", REAL / "fluo_cell_dna_mt_actin_3ch.tif", width_mm=100)
    rows += channel_rows("fluo_widefield_dapi_tubulin_2ch.tif", REAL / "fluo_widefield_dapi_tubulin_2ch.tif", width_mm=100)
    print("| picture | channel | encoding | key | structures raised ≥0.5 mm | convert s |")
    print("|---|---|---|---|---|---|")
    for row in rows:
        print("| " + " | ".join(row) + " |")
    print()
    print("| H&E picture | path | key | nuclei mm | stroma mm | white mm | white share | nuclei over stroma mm | nuclei raised ≥0.5 mm over stroma |")
    print("|---|---|---|---|---|---|---|---|---|")
    for row in he_rows():
        print("| " + " | ".join(row) + " |")
    one, three = speed()
    print()
    print(f"Speed (600×600 RGB composite, Medium, 100 mm, CPU time, best of 5, load average {os.getloadavg()[0]:.1f}): "
          f"one channel {one:.2f} s, three channels with key {three:.2f} s, extra {three - one:+.2f} s")


if __name__ == "__main__":
    main()
