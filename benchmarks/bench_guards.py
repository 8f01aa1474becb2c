"""Bounded work on hostile input, timed: each parser on 1 MB of adversarial text, a 1,000,000
character caption, a 450 KB OME comment, and a single picture offered to the web app's panel
chooser. The tests (tests/test_reliability.py, test_gui_panels.py) check what each returns and
catch a hang with their timeout; the times, and the bound each should stay under on a quiet
2-core machine, are here: the first call's CPU time in this process.

    PYTHONPATH=src .venv/bin/python benchmarks/bench_guards.py
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from cli_support import ADVERSARIAL_XML, MB, SIDECAR_CASES  # noqa: E402


def first_cpu_s(fn) -> float:
    """The first call's CPU time: the parsers cache by text, so a repeat would time the cache."""
    start = time.process_time()
    fn()
    return time.process_time() - start


def cases(tmp: Path):
    from tamp_os.clean.scale import read_pixel_size
    from tamp_os.clean.vendor import ini_sections
    from tamp_os.errors import ParameterError
    from tamp_os.read.model import file_channel_names
    from tamp_os.units import parse_length_m

    for name, text in sorted(ADVERSARIAL_XML.items()):
        yield f"OME-XML {name}: channel names", 1.0, lambda text=text: file_channel_names({"ome_metadata": text})
        yield f"OME-XML {name}: pixel size", 1.0, lambda text=text: read_pixel_size({"ome_metadata": text}, {}, None, width_px=100)
    image = tmp / "sem.tif"
    image.write_bytes(b"")
    for name, text in sorted(SIDECAR_CASES.items()):
        def sidecar(text=text):
            (tmp / "sem.txt").write_text(text[:MB])
            (tmp / "sem.hdr").write_text("[MAIN]\n" + text[:MB - 7])
            read_pixel_size({}, {}, str(image), width_px=100)
        yield f"sidecar {name}", 1.0, sidecar

    def lengths():
        for text in ("1" * MB, "1." + "1" * MB, " " * MB + "nm"):
            try:
                parse_length_m(text)
            except ParameterError:
                pass
    yield "length text of 1 MB (3 cases)", 1.0, lengths

    def ini():
        for text in ("[MAIN]\n" + "a=b\n" * (MB // 4), "[" * MB, "[MAIN]\n" + "=" * MB, "[MAIN]\nPixelSizeX=" + "1" * MB):
            ini_sections(text)
    yield "INI sidecar of 1 MB (4 cases)", 1.0, ini

    from figures import synthetic_texture
    from tamp_os.gui.panel_choice import find_panels

    single = synthetic_texture(300, 400, 7).astype(np.float32) / 255
    yield "web app: a single 400x300 picture offered for panels", 0.5, lambda: find_panels(single, tmp / "none", 4)


def main() -> None:
    print("| case | CPU s | bound s |")
    print("|---|---:|---:|")
    with tempfile.TemporaryDirectory() as folder:
        for name, bound, fn in cases(Path(folder)):
            print(f"| {name} | {first_cpu_s(fn):.3f} | {bound:g} |")


if __name__ == "__main__":
    main()
