"""`make demo` (not part of the installed package): convert built-in example images (shipped inside
scikit-image) and, when present, the real microscope files in ../shared/fixtures (or $TAMP_FIXTURES),
to STL, 3MF, GLB and the PDF/SVG tactile graphics, plus one two-colour print and one tiled print
(of the FePt spheres, or of scikit-image's coins when the fixtures are not here), printing one
plain line per file and saying what it left out."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from tamp_os.lithograph.products import convert as convert_product
from tamp_os.errors import TampError
from tamp_os.params import LithoParams
from tamp_os.read.image import read_array

BUILTIN = ("cell", "immunohistochemistry", "moon")
# the project's sibling folder, or another (TAMP_FIXTURES, as the tests read it)
FIXTURES = Path(os.environ.get("TAMP_FIXTURES") or Path(__file__).resolve().parents[2] / "shared" / "fixtures")


def examples():
    """(name, source) pairs: bundled scikit-image pictures (no download), then fixture files."""
    import skimage.data

    for name in BUILTIN:
        yield name, read_array(getattr(skimage.data, name)(), name=name)
    if FIXTURES.is_dir():
        for path in sorted(FIXTURES.iterdir()):
            if path.is_file() and path.suffix.lower() != ".md":
                yield path.name, path


def main(argv=None) -> int:
    import logging

    logging.basicConfig(level=logging.ERROR)  # warnings are printed as notes below each line
    out = Path((argv or sys.argv[1:] or ["demo-output"])[0])
    out.mkdir(parents=True, exist_ok=True)
    failed = 0
    if not FIXTURES.is_dir():
        print(f"demo: the real microscope files ({FIXTURES}) are not here: only the built-in pictures are converted")
    for name, source in examples():
        failed += not convert(name, source, out, formats=("stl", "3mf", "glb", "pdf", "svg"))
    # The other outputs, once each: a two-colour print and a plate tiled for a small bed.
    fept = FIXTURES / "fept_spheres_sem.png"
    if fept.is_file():
        source, caption = fept, "FePt"
    else:
        import skimage.data

        source, caption = read_array(skimage.data.coins(), name="coins"), "coins"
    failed += not convert("two colours", source, out / "two-colours", formats=("3mf", "stl"), multicolour=True, caption=caption)
    failed += not convert("tiles", source, out / "tiles", formats=("stl",), bed_mm="80")
    print(f"demo: outputs in {out}/")
    return 1 if failed else 0


def convert(name: str, source, out: Path, **params) -> bool:
    """Convert one example and print the same line as `tamp-os convert`; False if it failed."""
    try:
        conversion = convert_product(source, LithoParams(**params), out).conversions[0]
    except TampError as exc:
        print(f"{name}: not converted: {exc}")
        return False
    print(conversion.summary())
    for warning in conversion.report.warnings:
        print(f"  note: {warning}")
    return True


if __name__ == "__main__":
    sys.exit(main())
