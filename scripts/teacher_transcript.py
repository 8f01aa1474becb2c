"""The teacher's web-app flow by keyboard, as a transcript (docs/newcomer-transcripts.md): a real
server and headless Chromium; three files (one not an image), a caption per image, the Original
Prusa MK4, Update, Generate, the zip, then the same prints for the Bambu Lab A1. Each line says the
keys pressed, where focus landed (its label) and what the live regions and alerts said.

Run: PYTHONPATH=src:tests .venv/bin/python scripts/teacher_transcript.py
"""

from __future__ import annotations

import io
import sys
import tempfile
import zipfile
from pathlib import Path

FOCUSED = """() => {
  const el = document.activeElement;
  const label = (el.labels && el.labels[0]) ? el.labels[0].textContent : (el.getAttribute('aria-label') || el.textContent);
  return `${el.tagName.toLowerCase()}${el.id ? '#' + el.id : ''} "${label.trim().replace(/\\s+/g, ' ').slice(0, 90)}"`;
}"""
SAID = """() => [...document.querySelectorAll('[role=status], [role=alert]')].map(e => e.textContent.trim().replace(/\\s+/g, ' '))
  .filter(Boolean).map(t => t.slice(0, 160))"""


def main() -> int:
    from gui_support import CHROMIUM, LAUNCH_ARGS, png_bytes, start_server, stop_server
    from playwright.sync_api import sync_playwright

    work = Path(tempfile.mkdtemp(prefix="teacher-"))
    files = []
    for i, name in enumerate(("cells.png", "fibres.png")):
        (work / name).write_bytes(png_bytes((40, 50), 20 + i))
        files.append(str(work / name))
    (work / "notes.png").write_text("my notes, not an image")
    files.append(str(work / "notes.png"))
    proc, url = start_server(work / "jobs", slow_s=0.0, grace_s=30.0)
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=LAUNCH_ARGS)
            page = browser.new_context(accept_downloads=True).new_page()
            page.goto(url)
            first_round(page, files)
            second_round(page)
            browser.close()
    finally:
        stop_server(proc)
    return 0


class Said:
    """Prints one transcript line per step and counts the Tab presses."""

    def __init__(self):
        self.total = 0

    def __call__(self, page, keys: str, tabs: int = 0) -> None:
        self.total += tabs
        heard = "; ".join(page.evaluate(SAID)) or "-"
        print(f"- {keys}{f' ({tabs} Tab)' if tabs else ''} -> focus: {page.evaluate(FOCUSED)}; live/alert: {heard}")


def first_round(page, files: list[str]) -> None:
    """Upload, captions, the MK4, Update, Generate and the zip."""
    from gui_support import tabs_to  # Tab presses to a control, its focus checked visible

    say = Said()
    print(f"Page: {page.title()}")
    n = tabs_to(page, lambda i: i["id"] == "images")
    say(page, "Tab to the file field", n)
    page.set_input_files("#images", files)
    n = tabs_to(page, lambda i: i["text"] == "Add images")
    say(page, "choose cells.png, fibres.png, notes.png; Tab", n)
    page.keyboard.press("Enter")
    page.wait_for_selector("h1:has-text('Step 2 of 3')", timeout=60000)
    page.wait_for_timeout(300)
    print(f"Page: {page.title()}")
    say(page, "Enter")
    for i, caption in enumerate(("cells", "fibres")):
        n = tabs_to(page, lambda info, i=i: info["id"] == f"caption_{i}")
        page.keyboard.type(caption)
        say(page, f"Tab, type '{caption}'", n)
    n = tabs_to(page, lambda i: i["id"] == "printer")
    page.select_option("#printer", "Original Prusa MK4")
    say(page, "Tab, choose Original Prusa MK4 with the arrow keys", n)
    n = tabs_to(page, lambda i: i["id"] == "update")
    with page.expect_navigation():
        page.keyboard.press("Enter")
    say(page, "Tab, Enter on Update", n)
    print(f"  outputs ticked: {', '.join(page.eval_on_selector_all('input[name=formats]:checked', 'els => els.map(e => e.value)'))}; "
          f"beside the printer: {page.locator('#printer-outputs').inner_text()}")
    n = tabs_to(page, lambda i: i["text"] == "Generate")
    with page.expect_navigation():
        page.keyboard.press("Enter")
    say(page, "Tab to Generate, Enter", n)
    page.wait_for_selector("h1:has-text('Your lithographs')", timeout=180000)
    page.wait_for_function("document.activeElement.id === 'page-title'", timeout=10000)
    page.wait_for_timeout(400)
    print(f"Page: {page.title()}")
    say(page, "(waiting; the page updates itself)")
    n = tabs_to(page, lambda i: i["text"].startswith("Download everything"))
    with page.expect_download(timeout=60000) as download:
        page.keyboard.press("Enter")
    say(page, "Tab, Enter on Download everything (zip)", n)
    print(f"  zip: {', '.join(zipfile.ZipFile(download.value.path()).namelist())}")
    print(f"  Tab presses from the first page to the download: {say.total}")


def second_round(page) -> None:
    """The same prints for the Bambu Lab A1, from the results page."""
    from gui_support import tabs_to  # Tab presses to a control, its focus checked visible

    say = Said()
    n = tabs_to(page, lambda i: i["id"] == "again-printer")
    page.select_option("#again-printer", "Bambu Lab A1")
    say(page, "Tab, choose Bambu Lab A1", n)
    n = tabs_to(page, lambda i: i["id"] == "again")
    with page.expect_navigation():
        page.keyboard.press("Enter")
    say(page, "Tab, Enter on Make them for this printer", n)
    page.wait_for_selector("h1:has-text('Your lithographs for Bambu Lab A1')", timeout=180000)
    page.wait_for_function("document.activeElement.id === 'page-title'", timeout=10000)
    page.wait_for_timeout(400)
    say(page, "(waiting)")
    n = tabs_to(page, lambda i: i["text"].startswith("Download everything"))
    href = page.evaluate("document.activeElement.href")
    names = zipfile.ZipFile(io.BytesIO(page.request.get(href).body())).namelist()
    say(page, "Tab, Enter on Download everything (zip)", n)
    print(f"  zip: {', '.join(names)}")


if __name__ == "__main__":
    sys.exit(main())
