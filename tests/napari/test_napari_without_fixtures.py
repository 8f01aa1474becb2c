"""A clone without ../shared: the napari tests that need a real file skip cleanly (issue 54.1), as
docs/testing.md promises; napari's viewer fixture once failed at teardown after such a skip."""

from __future__ import annotations

import os
import subprocess
import sys
from xml.etree import ElementTree

import pytest

from conftest import ROOT, need_module


@pytest.mark.napari
@pytest.mark.timeout(300)
def test_the_napari_tests_of_real_files_skip_cleanly_without_the_fixtures_folder(tmp_path):
    need_module("napari.viewer")
    env = {**os.environ, "TAMP_FIXTURES": str(tmp_path / "no-fixtures")}
    env.pop("TAMP_STRICT", None)  # strict runs fail on a missing file by design; this is the clone's run
    done = subprocess.run([sys.executable, "-m", "pytest", "tests/napari", "-q", "-p", "no:cacheprovider", "-k", "(czi or fept) and not without_fixtures",
                           f"--junitxml={tmp_path / 'run.xml'}"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=280)
    said = done.stdout + done.stderr
    assert done.returncode == 0, said
    assert "rep_call" not in said
    suite = ElementTree.parse(tmp_path / "run.xml").getroot().find("testsuite")
    counts = {key: int(suite.get(key)) for key in ("tests", "skipped", "failures", "errors")}
    assert counts["tests"] >= 3 and counts["skipped"] == counts["tests"], counts  # each test of a real file skipped
    assert counts["failures"] == counts["errors"] == 0, said
    assert "the fixtures folder" in done.stdout and "is missing" in done.stdout
