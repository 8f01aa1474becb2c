"""`make demo` (not part of the installed package): convert built-in example images (shipped inside
scikit-image) and, when present, the real microscope files in ../shared/fixtures, to STL, 3MF, GLB
and the PDF/SVG tactile graphics, plus one two-colour print and one tiled print, printing one
plain line per file."""

from __future__ import annotations

import sys
from pathlib import Path

from tamp_os.lithograph.convert import convert as convert_image
from tamp_os.errors import TampError
from tamp_os.params import LithoParams
from tamp_os.read.image import read_array

BUILTIN = ("cell", "immunohistochemistry", "moon")
FIXTURES = Path(__file__).resolve().parents[2] / "shared" / "fixtures"  # the project's sibling folder


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
    for name, source in examples():
        failed += not convert(name, source, out, formats=("stl", "3mf", "glb", "pdf", "svg"))
    # The other outputs, once each: a two-colour print and a plate tiled for a small bed.
    if FIXTURES.is_dir():
        fept = FIXTURES / "fept_spheres_sem.png"
        failed += not convert("two colours", fept, out / "two-colours", formats=("3mf", "stl"), multicolour=True, caption="FePt")
        failed += not convert("tiles", fept, out / "tiles", formats=("stl",), bed_mm="80")
    print(f"demo: outputs in {out}/")
    return 1 if failed else 0


def convert(name: str, source, out: Path, **params) -> bool:
    """Convert one example and print the same line as `tamp-os convert`; False if it failed."""
    try:
        conversion = convert_image(source, LithoParams(**params), out)
    except TampError as exc:
        print(f"{name}: not converted: {exc}")
        return False
    print(conversion.summary())
    for warning in conversion.report.warnings:
        print(f"  note: {warning}")
    return True


if __name__ == "__main__":
    sys.exit(main())
