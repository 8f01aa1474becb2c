"""Prove that a change left behaviour alone: convert the demo pictures and every fixture with the
code in this tree and with the code at a git commit, and compare every output byte for byte.

    .venv/bin/python scripts/check_identical.py --ref 8c4743d

Both runs go through the command line (the most stable interface) on the same input paths, with
the default settings and with variants that exercise furniture, the grid mesher and STEP. Exit
status 0 when every file is identical, 1 otherwise (the differing files are listed).

With `--real NAME ...` the named files of fixtures/real (the ones whose scale or labels are read
by OCR: sem_fei_sio2_particles_35kx.tif, ..._10kx.tif, sem_moth_head_scales_proboscis.tif,
tvips_bin4.tif) are converted too, in the default and furniture variants. With `--3mf-as-read`,
3MF files are compared the way their readers see them instead of byte for byte (issue 37: the
writer changed): the same triangles, metadata, attachments and base materials, and vertices
within 1e-6 mm and two float32 steps; the recipes' checksums of 3MF files are then left out.

Two deliberate additions are allowed: recipes written by newer code carry `printer_profile` (the
whole printer profile, so a recipe rebuilds the same on any machine) and the input's
`path_from_recipe` (so a moved folder still rebuilds). Recipes are compared as bytes after removing
exactly those keys and re-serialising the rest the way the recipe writer does.
"""

from __future__ import annotations

import argparse
import filecmp
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT.parent / "shared" / "fixtures"
PICTURES = ("cell", "immunohistochemistry", "moon", "coins")
VARIANTS = {
    "default": ["--formats", "stl,3mf,glb"],
    "furniture": ["--formats", "stl,3mf", "--caption", "Test 5 um", "--frame-mm", "2", "--pixel-size", "0.5um"],
    "grid": ["--formats", "stl,glb", "--mesher", "grid", "--preset", "low", "--invert"],
    "step": ["--formats", "step", "--preset", "low", "--width-mm", "60"],
    "graphic": ["--formats", "pdf,svg,stl", "--preset", "low", "--page-size", "a4"],
}


REAL_VARIANTS = ("default", "furniture")


def inputs(folder: Path) -> list[Path]:
    """The scikit-image demo pictures written as PNG files, then every fixture."""
    import numpy as np
    import skimage.data
    from PIL import Image

    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in PICTURES:
        path = folder / f"{name}.png"
        if not path.exists():
            Image.fromarray(np.asarray(getattr(skimage.data, name)())).save(path)
        paths.append(path)
    paths += sorted(p for p in FIXTURES.iterdir() if p.is_file() and p.suffix.lower() != ".md")
    return paths


def convert_all(src: Path, images: list[Path], out: Path, real: list[Path]) -> None:
    env = dict(os.environ, PYTHONPATH=str(src))
    for variant, options in VARIANTS.items():
        for image in images + (real if variant in REAL_VARIANTS else []):
            # one call per image: a refused input must not stop the others
            # `tamp_os.cli.main` is the command line in every layout the package has had
            cmd = [
                sys.executable,
                "-c",
                "import sys; from tamp_os.cli import main; sys.exit(main(sys.argv[1:]))",
                "convert",
                str(image),
                "-o",
                str(out / variant),
                *options,
            ]
            (out / variant).mkdir(parents=True, exist_ok=True)
            result = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
            (out / variant / f"{image.name}.log").write_text(result.stdout + result.stderr + f"exit {result.returncode}\n")


ADDED_RECIPE_KEYS = ("printer_profile",)
ADDED_INPUT_KEYS = ("path_from_recipe",)


def _recipe_text(path: Path, threemf_as_read: bool = False) -> str:
    recipe = json.loads(path.read_text(encoding="utf-8"))
    for key in ADDED_RECIPE_KEYS:
        recipe.pop(key, None)
    for key in ADDED_INPUT_KEYS:
        recipe["input"].pop(key, None)
    # A PDF's checksum changes with cairo's CreationDate on every run (even between two runs of one
    # commit); the PDF itself is compared without its date (see compare), so its checksum is left out.
    hashes = recipe.get("output_sha256") or {}
    for name in [n for n in hashes if n.lower().endswith(".pdf")]:
        hashes[name] = "(pdf: compared without its creation date)"
    for name in [n for n in hashes if threemf_as_read and n.lower().endswith(".3mf")]:
        hashes[name] = "(3mf: compared as read)"
    return json.dumps(recipe, indent=2, ensure_ascii=False) + "\n"


def _pdf_bytes(path: Path) -> bytes:
    """A PDF without its creation time (cairo writes the clock's time, so two runs always differ there)."""
    return re.sub(rb"/CreationDate \(D:[0-9Z+\-']*\)", b"", path.read_bytes())


def _3mf_as_read(path: Path) -> tuple:
    """(vertices, everything else) of a 3MF package as a reader sees it: the model's elements and
    attributes (vertex coordinates as numbers), and every other part but the relationships."""
    import zipfile
    from xml.etree import ElementTree as ET

    import numpy as np

    with zipfile.ZipFile(path) as archive:
        parts = {n: archive.read(n) for n in archive.namelist() if not n.endswith((".rels", "[Content_Types].xml"))}
    model = ET.fromstring(parts.pop("3D/3dmodel.model"))
    vertices = np.array([[float(v.get(k)) for k in "xyz"] for v in model.iter() if v.tag.endswith("}vertex")], dtype=np.float32)
    rest = [(e.tag, sorted(e.attrib.items()), (e.text or "").strip()) for e in model.iter() if not e.tag.endswith("}vertex")]
    # lib3mf leaves out pid/p1 that equal the object's default, as the new writer does; namespaces
    # other than core and production are declared by lib3mf and never used
    return vertices, rest, parts


def _same_3mf(a: Path, b: Path) -> bool:
    import numpy as np

    va, ra, pa = _3mf_as_read(a)
    vb, rb, pb = _3mf_as_read(b)
    return va.shape == vb.shape and np.allclose(va, vb, rtol=2.4e-7, atol=1e-6) and ra == rb and pa == pb


def compare(a: Path, b: Path, threemf_as_read: bool = False) -> list[str]:
    names_a = {p.relative_to(a) for p in a.rglob("*") if p.is_file()}
    names_b = {p.relative_to(b) for p in b.rglob("*") if p.is_file()}
    problems = [f"only in this tree: {n}" for n in sorted(names_a - names_b)]
    problems += [f"only at the reference: {n}" for n in sorted(names_b - names_a)]
    for name in sorted(names_a & names_b):
        if name.name.endswith(".tamp.json"):
            if _recipe_text(a / name, threemf_as_read) != _recipe_text(b / name, threemf_as_read):
                problems.append(f"differs: {name}")
        elif name.suffix == ".pdf":
            if _pdf_bytes(a / name) != _pdf_bytes(b / name):
                problems.append(f"differs: {name}")
        elif threemf_as_read and name.suffix == ".3mf":
            if not _same_3mf(a / name, b / name):
                problems.append(f"differs as read: {name}")
        elif not filecmp.cmp(a / name, b / name, shallow=False):
            problems.append(f"differs: {name}")
    return problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ref", required=True, help="git commit whose code gives the expected outputs")
    parser.add_argument("--real", nargs="*", default=[], metavar="NAME", help="files of fixtures/real to convert too (default and furniture variants)")
    parser.add_argument("--3mf-as-read", dest="threemf_as_read", action="store_true", help="compare 3MF files as their readers see them, not byte for byte")
    parser.add_argument("--keep", type=Path, help="copy both runs' outputs into this folder (to study the differences)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="tamp-identical-") as tmp:
        tmp = Path(tmp)
        images = inputs(tmp / "inputs")
        real = [FIXTURES / "real" / name for name in args.real]
        ref_tree = tmp / "ref"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(ref_tree), args.ref], check=True, capture_output=True)
        try:
            convert_all(ref_tree / "src", images, tmp / "expected", real)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(ref_tree)], check=False)
        convert_all(ROOT / "src", images, tmp / "actual", real)
        n_files = sum(1 for p in (tmp / "expected").rglob("*") if p.is_file())
        problems = compare(tmp / "actual", tmp / "expected", args.threemf_as_read)
        if args.keep:
            import shutil

            for run in ("actual", "expected"):
                shutil.copytree(tmp / run, args.keep / run, dirs_exist_ok=True)
    for line in problems:
        print(line)
    print(f"{n_files} files compared with {args.ref}: " + ("all identical" if not problems else f"{len(problems)} differ"))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
