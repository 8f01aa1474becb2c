"""The web app words its own controls (issue 54.7), run as a user runs it (`tamp-os gui`, an
upload, Generate): its notes name its form's labels and leave out advice for settings it does not
have; the description it shows names no control at all."""

from __future__ import annotations

import html
import re

import httpx
import pytest

from czi_builder import four_channel_czi
from gui_support import generate_and_wait, new_job, start_server, stop_server


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    proc, url = start_server(tmp_path_factory.mktemp("gui-words"), slow_s=0.0)
    yield url
    stop_server(proc)


def page_text(page: str) -> str:
    return html.unescape(re.sub(r"<[^>]+>", " ", page))


@pytest.mark.timeout(300)
def test_a_channel_print_is_worded_with_the_forms_controls(server, tmp_path):
    czi = four_channel_czi(tmp_path / "four.czi").read_bytes()
    with httpx.Client(base_url=server, timeout=60, follow_redirects=False) as client:
        job = new_job(client, [("four.czi", czi)])
        generate_and_wait(client, job, timeout_s=240)
        said = " ".join(page_text(client.get(f"/jobs/{job}").text).split())
    assert "left out: Mono." in said, said
    assert "Choose others" not in said and "channels off" not in said and "`" not in said and "⟦" not in said
    assert "; “Channel” prints a single channel." in said  # the form's Channel field
