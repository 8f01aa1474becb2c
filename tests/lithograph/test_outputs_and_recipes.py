"""Outputs never overwrite each other, recipes are read defensively and rebuild from anywhere,
batches share folders safely, and the library speaks in parameter names."""

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from conftest import ROOT, run_cli as run
from tamp_os import make_lithograph
from tamp_os.cli.commands import cli_words, main
from tamp_os.errors import ParameterError, Text
from tamp_os.params import LithoParams

pytestmark = pytest.mark.timeout(240)


def picture(path: Path, seed: int = 0) -> Path:
    Image.fromarray((np.random.default_rng(seed).random((30, 40)) * 255).astype(np.uint8)).save(path)
    return path


def test_two_inputs_with_one_name_get_distinct_outputs(tmp_path, capsys):
    (tmp_path / "b").mkdir()
    a = picture(tmp_path / "sample.png", 1)
    b = picture(tmp_path / "b" / "sample.png", 2)
    c = tmp_path / "sample.tif"
    Image.open(a).save(c)
    code, out, _ = run(capsys, "convert", a, b, c, "-o", tmp_path / "out")
    assert code == 0
    stls = sorted(p.name for p in (tmp_path / "out").glob("*.stl"))
    assert len(stls) == 3 and len(set(stls)) == 3
    assert out.count("another input of this run has the same name") == 3
    recipes = [json.loads(p.read_text(encoding="utf-8")) for p in (tmp_path / "out").glob("*.tamp.json")]
    assert sorted(r["input"]["path"] for r in recipes) == sorted(map(str, (a, b, c)))  # each output names its own input


def test_saving_without_gcode_never_slices(tmp_path):
    litho = make_lithograph(np.eye(12), scale_bar="off")
    written = litho.save(tmp_path)
    assert not list(tmp_path.glob("*.gcode")) and litho.report.print is None
    assert [p.suffix for p in written][-1] == ".json"


def test_the_pipeline_never_imports_the_slicer():
    code = "import sys, tamp_os.lithograph.pipeline, tamp_os.lithograph.outputs; print('tamp_os.printing.slicer' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_a_recipe_rebuilds_from_another_folder(tmp_path, capsys):
    work = tmp_path / "work"
    work.mkdir()
    picture(work / "p.png")
    old = os.getcwd()
    try:
        os.chdir(work)  # the input is given as a relative path, as users type it
        assert main(["convert", "p.png", "-o", "out"]) == 0
    finally:
        os.chdir(old)
    moved = tmp_path / "moved"
    (work).rename(moved)
    code, _, err = run(capsys, "convert", "--recipe", moved / "out" / "p.tamp.json", "-o", tmp_path / "again")
    assert code == 0, err
    assert (tmp_path / "again" / "p.stl").read_bytes() == (moved / "out" / "p.stl").read_bytes()


@pytest.mark.parametrize(
    "recipe, needle",
    [
        ({"input": {"name": "p.png"}, "params": {}}, "sha256"),
        ({"input": "p.png", "params": {}}, "'input' record"),
        ({"input": {"name": None, "sha256": "0" * 64}, "params": {}}, "plain file name"),
        ({"input": {"name": "../../etc/passwd", "sha256": "0" * 64}, "params": {}}, "plain file name"),
        ({"input": {"name": "p.png", "sha256": "0" * 64, "path": 5}, "params": {}}, "must be text"),
        ({"input": {"name": "p.png", "sha256": "0" * 64}, "params": []}, "'params'"),
        ({"input": {"name": "p.png", "sha256": "0" * 64}, "params": {"no_such": 1}}, "unknown parameter"),
    ],
)
def test_bad_recipes_are_one_clear_error(tmp_path, capsys, recipe, needle):
    path = tmp_path / "r.tamp.json"
    path.write_text(json.dumps(recipe), encoding="utf-8")
    code, _, err = run(capsys, "convert", "--recipe", path, "-o", tmp_path / "o")
    assert code == 1 and err.count("error:") == 1 and needle in err, err
    assert "Traceback" not in err


def test_deeply_nested_or_binary_recipes_are_refused_without_echoing_them(tmp_path, capsys):
    deep = tmp_path / "deep.tamp.json"
    deep.write_text("[" * 100000 + "]" * 100000)
    code, _, err = run(capsys, "convert", "--recipe", deep, "-o", tmp_path / "o")
    assert code == 1 and "not the JSON a recipe holds" in err
    secret = tmp_path / "secret.tamp.json"
    secret.write_bytes(b"\xff\xfeSECRET-TOKEN-123\x00")
    code, _, err = run(capsys, "convert", "--recipe", secret, "-o", tmp_path / "o")
    assert code == 1 and "SECRET" not in err and "\\xff" not in err


def test_a_recipe_opens_only_its_input_with_the_matching_hash(tmp_path, capsys):
    picture(tmp_path / "p.png")
    assert main(["convert", str(tmp_path / "p.png"), "-o", str(tmp_path / "out")]) == 0
    recipe_path = tmp_path / "out" / "p.tamp.json"
    recipe = json.loads(recipe_path.read_text(encoding="utf-8"))
    other = tmp_path / "other.png"
    picture(other, 9)
    recipe["input"].update(path=str(other), path_from_recipe=None)
    (tmp_path / "p.png").unlink()
    recipe_path.write_text(json.dumps(recipe), encoding="utf-8")
    code, _, err = run(capsys, "convert", "--recipe", recipe_path, "-o", tmp_path / "o2")
    assert code == 1 and "has changed" in err and not (tmp_path / "o2").exists()


def test_batch_refuses_a_negative_worker_count(tmp_path, capsys):
    picture(tmp_path / "p.png")
    code, _, err = run(capsys, "batch", tmp_path / "p.png", "-o", tmp_path / "out", "--workers", "-1")
    assert code == 2 and "--workers" in err and "Traceback" not in err


def test_odd_folder_entries_never_stop_a_batch(tmp_path, capsys):
    src = tmp_path / "in"
    src.mkdir()
    picture(src / "good.png")
    os.symlink(src / "loop.png", src / "loop.png")  # a link to itself
    os.symlink(src / "missing.png", src / "broken.png")
    os.mkfifo(src / "pipe.png")
    code, out, _ = run(capsys, "batch", src, "-o", tmp_path / "out", "--workers", "1")
    assert "1 converted" in out and "3 failed" in out and code == 1
    report = json.loads((tmp_path / "out" / "batch-report.json").read_text(encoding="utf-8"))
    assert {Path(r["input"]).name for r in report if r["status"] == "failed"} == {"loop.png", "broken.png", "pipe.png"}


def test_a_second_batch_into_the_same_folder_is_refused_while_the_first_runs(tmp_path):
    src = tmp_path / "in"
    src.mkdir()
    for i in range(6):
        picture(src / f"p{i}.png", i)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "tamp_os.cli.commands", "batch", str(src), "-o", str(out), "--workers", "1", "--resolution-px", "300"]
    first = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline and not (out / ".tamp-batch.lock").exists():
        time.sleep(0.05)
    time.sleep(0.5)
    second = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    first_out, first_err = first.communicate(timeout=300)
    assert first.returncode == 0, first_err
    assert "6 converted" in first_out
    if "is writing into this folder now" not in second.stderr:  # the first finished before the second started
        assert second.returncode == 0
    else:
        assert second.returncode == 1


def test_workers_end_when_the_batch_is_killed(tmp_path):
    src = tmp_path / "in"
    src.mkdir()
    for i in range(8):
        picture(src / f"p{i}.png", i)
    cmd = [sys.executable, "-m", "tamp_os.cli.commands", "batch", str(src), "-o", str(tmp_path / "out"), "--workers", "2",
           "--resolution-px", "600", "--mesher", "grid"]
    parent = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    children: list[int] = []
    deadline = time.time() + 60
    while time.time() < deadline and len(children) < 2:
        children = [int(p) for p in subprocess.run(["pgrep", "-P", str(parent.pid)], capture_output=True, text=True).stdout.split()]
        time.sleep(0.1)
    assert children, "the batch started no workers"
    os.kill(parent.pid, signal.SIGKILL)
    parent.wait(timeout=10)
    deadline = time.time() + 20
    while time.time() < deadline and any(Path(f"/proc/{c}").exists() and "Z" not in Path(f"/proc/{c}/stat").read_text().split()[2] for c in children):
        time.sleep(0.2)
    alive = [c for c in children if Path(f"/proc/{c}").exists() and Path(f"/proc/{c}/stat").read_text().split()[2] != "Z"]
    assert not alive, f"workers {alive} outlived their batch"


def test_messages_speak_parameters_in_the_library_and_flags_in_the_cli():
    with pytest.raises(ParameterError) as caught:
        LithoParams(pixel_size="5 parsecs")
    assert str(caught.value).startswith("pixel_size: cannot read '5 parsecs'")
    assert cli_words(caught.value).startswith("--pixel-size: cannot read '5 parsecs'")
    assert caught.value.parameter == "pixel_size" and caught.value.value == "5 parsecs"
    assert cli_words(Text("x.tif: `page` must be 0–3; got 5.")) == "x.tif: --page must be 0–3; got 5."
    assert cli_words(Text("`z_slice` must be 0–4")) == "--slice must be 0–4"
    # Only a parameter's name between backticks is a name: prose, quotes and a file's own keys are kept.
    assert cli_words("set depth_mm to 60.0") == "set depth_mm to 60.0"
    assert cli_words(Text("the `caption` says `hello`")) == "the --caption says `hello`"
    in_file = ParameterError("printers.toml: [a] needs `nozzle_mm`", in_file=True)
    assert cli_words(in_file) == "printers.toml: [a] needs nozzle_mm"


# Flags of programs we run (PrusaSlicer, lou_translate, tesseract) are not ours.
EXTERNAL_TOOL_FLAGS = {"--forward", "--psm", "--oem", "--info", "--export-gcode", "--load", "--output", "--save"}


def test_no_command_line_flag_outside_the_cli_and_the_web_app():
    found = []
    for path in (ROOT / "src" / "tamp_os").rglob("*.py"):
        rel = path.relative_to(ROOT / "src" / "tamp_os").as_posix()
        if rel in ("printing/slicer.py", "printing/prusa_presets.py") or rel.startswith(("cli/", "gui/")):
            continue
        for flag in re.findall(r"(?<![\w-])--[a-z][a-z-]+", path.read_text(encoding="utf-8")):
            if flag not in EXTERNAL_TOOL_FLAGS:
                found.append(f"{rel}: {flag}")
    assert not found, found
