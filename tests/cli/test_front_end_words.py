"""Each front end words its own controls (issue 54.7). The library names parameters (`channels`);
the command line says its options (--channels), the web app its form labels and napari its
widget's; advice naming a control a front end lacks is left out there, and the print's files
(the description, inside the 3MF and PDF too) name no control at all: whoever reads them has
none, and they are the same whichever front end made them."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from cli_support import run_tamp
from czi_builder import four_channel_czi

# Words of advice that name the channel controls, as the library's notes said them in every front end
CHANNEL_ADVICE = ("Choose others with", "prints a single channel", "channels off", "channels`", "⟦", "`")


def noise_png(path):
    Image.fromarray((np.random.default_rng(0).random((120, 160)) * 255).astype(np.uint8)).save(path)
    return path


@pytest.mark.timeout(300)
def test_the_command_line_says_its_options_and_the_description_names_none(tmp_path):
    four_channel_czi(tmp_path / "four.czi")
    done = run_tamp("convert", "four.czi", "-o", "out", "--verbose", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    notes = [line for line in done.stdout.splitlines() if line.startswith("  note: ")]
    assert any(n.endswith("left out: Mono. Choose others with --channels.") for n in notes), notes
    assert any("; --channel prints a single channel, and --channels off prints the brightness as before." in n for n in notes), notes
    described = (tmp_path / "out" / "four.description.txt").read_text(encoding="utf-8")
    assert "left out: Mono." in described and "because the file has 4 channels." in described  # what was done is said
    assert not [w for w in CHANNEL_ADVICE if w in described], described  # how to change it is the front end's to say


@pytest.mark.timeout(300)
def test_a_verdicts_advice_is_in_option_words_and_left_out_of_the_description(tmp_path):
    noise_png(tmp_path / "noise.png")
    done = run_tamp("convert", "noise.png", "--relief-style", "reference", "-o", "out", "--verbose", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    advice = [line for line in done.stdout.splitlines() if line.startswith("  advice: ")]
    assert any(line.endswith("not as shape; try --relief-style structure, or a larger --detail-mm.") for line in advice), done.stdout
    described = (tmp_path / "out" / "noise.description.txt").read_text(encoding="utf-8")
    assert "felt as roughness, not as shape." in described and "relief_style" not in described and "try " not in described
    checked = run_tamp("check", "noise.png", "--relief-style", "reference", cwd=tmp_path)
    assert "try --relief-style structure, or a larger --detail-mm." in checked.stdout, checked.stdout  # was relief_style


@pytest.mark.timeout(300)
def test_the_web_app_and_napari_word_the_same_notes_with_their_own_controls(tmp_path):
    from tamp_os import LithoParams
    from tamp_os.gui.forms import label_of, offers, web_words
    from tamp_os.lithograph.convert import convert
    from tamp_os.lithograph.report import web_summary_lines
    from tamp_os.napari.controls import advice_words, widget_words

    made = convert(four_channel_czi(tmp_path / "four.czi"), LithoParams(), tmp_path / "out")
    web = " ".join(web_summary_lines(made.report, label_of, offers))
    assert "left out: Mono." in web and "Choose others" not in web  # the web app has no channels field
    assert "; “Channel” prints a single channel." in web and "channels off" not in web  # it has a Channel field
    assert advice_words(made.report) == []  # the widget has neither control: nothing to add to the description
    decided = [widget_words(w) for w in made.report.warnings if "channel by channel" in str(w)]
    assert decided and decided[0].endswith("because the file has 4 channels.") and "channel`" not in decided[0]

    rough = convert(noise_png(tmp_path / "noise.png"), LithoParams(relief_style="reference"), tmp_path / "out2")
    web_touch = [web_words(v) for v in rough.touch()]
    assert any(v.endswith("try “Relief style” structure, or a larger “Finest shape (mm)”.") for v in web_touch), web_touch
    said = advice_words(rough.report)
    assert any(v.endswith("not as shape; try “Relief style” structure.") for v in said), said  # no detail control there
