"""Issue 33.3: every message names the controls of the front end that shows it. A clause of advice
between ⟦ and ⟧ names controls; a front end without one of them leaves that clause out, the others
say it in their own words, and the library's text (reports, recipes) keeps it whole."""

from __future__ import annotations

import pytest
from hypothesis import given, settings, strategies as st

from conftest import examples
from tamp_os.errors import Text, render


NOTE = Text("Printed channel by channel, because the file has 2 channels⟦; `channel` prints a single channel⟧"
            "⟦, and `channels` off prints the brightness as before⟧.")


@pytest.mark.timeout(30)
def test_the_library_and_the_command_line_keep_every_clause():
    from tamp_os.cli.commands import cli_words

    assert str(NOTE) == ("Printed channel by channel, because the file has 2 channels; channel prints a single channel, "
                         "and channels off prints the brightness as before.")
    assert cli_words(NOTE).endswith("; --channel prints a single channel, and --channels off prints the brightness as before.")


@pytest.mark.timeout(30)
def test_the_web_app_leaves_out_advice_naming_a_control_it_does_not_have():
    from tamp_os.gui.forms import offers, web_words

    assert offers("channel") and not offers("channels")
    said = web_words(NOTE)
    assert said == "Printed channel by channel, because the file has 2 channels; “Channel” prints a single channel."
    assert "channels" not in said.lower().replace("2 channels", "")


@pytest.mark.timeout(60)
def test_real_channel_notes_in_the_web_app_name_only_its_own_controls(fixture):
    from tamp_os.gui.forms import web_words
    from tamp_os.lithograph.pipeline import make_lithograph

    report = make_lithograph(fixture("real/nikon_pbmc_4ch.nd2")).report
    said = [web_words(w) for w in report.warnings]
    assert any("left out: Mono" in s for s in said), said
    assert not any("“channels”" in s or "channels off" in s for s in said), said


@pytest.mark.timeout(60)
@settings(max_examples=examples(100), deadline=None)
@given(text=st.text(alphabet=st.characters(blacklist_characters="⟦⟧`"), max_size=40))
def test_a_clause_with_no_control_in_it_is_kept_by_every_front_end(text):
    template = f"before ⟦{text}⟧ after"
    assert render(template, None, offers=lambda name: False) == f"before {text} after"
    assert render(template) == f"before {text} after"
