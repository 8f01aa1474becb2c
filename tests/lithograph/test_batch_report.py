"""The batch report is rewritten after each input, and stale parts go."""

import json
import os
import subprocess
import sys
import numpy as np
import pytest
from PIL import Image
from conftest import FIXTURES, ROOT, run_cli as run
from tamp_os import make_lithograph
from tamp_os.errors import ParameterError
from tamp_os.relief.heightmap import heights_mm
from tamp_os.relief.preprocess import prepare, resample, stretch


pytestmark = pytest.mark.timeout(240)


def test_the_batch_report_is_rewritten_after_each_input_and_stale_parts_go(tmp_path, capsys):
    from tamp_os.lithograph.batch import Job, run_batch
    from tamp_os.params import LithoParams

    src = tmp_path / "in"
    src.mkdir()
    for i in range(3):
        Image.fromarray((np.random.default_rng(i).random((30, 40)) * 255).astype(np.uint8)).save(src / f"p{i}.png")
    out = tmp_path / "out"
    out.mkdir()
    stale = out / ".p0.stl.abc.part"
    stale.write_bytes(b"half a file")
    seen = []

    def watch(outcome, count, total):
        rows = json.loads((out / "batch-report.json").read_text(encoding="utf-8"))
        seen.append(len(rows))

    jobs = [Job(src / f"p{i}.png", out, LithoParams(preset="low")) for i in range(3)]
    run_batch(jobs, out, workers=1, on_done=watch)
    assert seen == [1, 2, 3]  # the report on disk grew with every finished input
    assert not stale.exists()
