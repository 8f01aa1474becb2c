"""Prove that a change left behaviour alone: convert the demo pictures and every fixture with the
code in this tree and with the code at a git commit, and compare every output byte for byte.

    .venv/bin/python scripts/check_identical.py --ref 8c4743d

Both runs go through the command line (the most stable interface) on the same input paths, with
the default settings and with variants that exercise furniture, the grid mesher and STEP. Exit
status 0 when every file is identical, 1 otherwise (the differing files are listed).

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


def convert_all(src: Path, images: list[Path], out: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(src))
    for variant, options in VARIANTS.items():
        for image in images:
            # one call per image: a refused input must not stop the others
            # `tamp_os.cli.main` is the command line in every layout the package has had
            cmd = [sys.executable, "-c", "import sys; from tamp_os.cli import main; sys.exit(main(sys.argv[1:]))",
                   "convert", str(image), "-o", str(out / variant), *options]
            (out / variant).mkdir(parents=True, exist_ok=True)
            result = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
            (out / variant / f"{image.name}.log").write_text(result.stdout + result.stderr + f"exit {result.returncode}\n")


ADDED_RECIPE_KEYS = ("printer_profile",)
ADDED_INPUT_KEYS = ("path_from_recipe",)


def _recipe_text(path: Path) -> str:
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
    return json.dumps(recipe, indent=2, ensure_ascii=False) + "\n"


def _pdf_bytes(path: Path) -> bytes:
    """A PDF without its creation time (cairo writes the clock's time, so two runs always differ there)."""
    return re.sub(rb"/CreationDate \(D:[0-9Z+\-']*\)", b"", path.read_bytes())


def compare(a: Path, b: Path) -> list[str]:
    names_a = {p.relative_to(a) for p in a.rglob("*") if p.is_file()}
    names_b = {p.relative_to(b) for p in b.rglob("*") if p.is_file()}
    problems = [f"only in this tree: {n}" for n in sorted(names_a - names_b)]
    problems += [f"only at the reference: {n}" for n in sorted(names_b - names_a)]
    for name in sorted(names_a & names_b):
        if name.name.endswith(".tamp.json"):
            if _recipe_text(a / name) != _recipe_text(b / name):
                problems.append(f"differs: {name}")
        elif name.suffix == ".pdf":
            if _pdf_bytes(a / name) != _pdf_bytes(b / name):
                problems.append(f"differs: {name}")
        elif not filecmp.cmp(a / name, b / name, shallow=False):
            problems.append(f"differs: {name}")
    return problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ref", required=True, help="git commit whose code gives the expected outputs")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="tamp-identical-") as tmp:
        tmp = Path(tmp)
        images = inputs(tmp / "inputs")
        ref_tree = tmp / "ref"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(ref_tree), args.ref], check=True, capture_output=True)
        try:
            convert_all(ref_tree / "src", images, tmp / "expected")
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(ref_tree)], check=False)
        convert_all(ROOT / "src", images, tmp / "actual")
        n_files = sum(1 for p in (tmp / "expected").rglob("*") if p.is_file())
        problems = compare(tmp / "actual", tmp / "expected")
    for line in problems:
        print(line)
    print(f"{n_files} files compared with {args.ref}: " + ("all identical" if not problems else f"{len(problems)} differ"))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
