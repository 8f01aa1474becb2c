"""Key labels short enough for a braille key line (issue 22): the dye kept, acquisition words dropped."""

import pytest

from tamp_os.relief.key_labels import label_forms, short_channel_name


@pytest.mark.parametrize("name, short", [
    ("FITC BP", "FITC"), ("TRITC BP", "TRITC"), ("HyD 1 Leica/FITC", "FITC"), ("HyD 3 Leica/TRITC", "TRITC"),
    ("EGFP 525/50 nm", "EGFP"), ("Cy5 BP 660/50", "Cy5"), ("GFP 488nm", "GFP"), ("mCherry 610 nm", "mCherry"),
    # nothing to drop, or nothing would be left: the name as it is
    ("DAPI", "DAPI"), ("ChA-T1", "ChA-T1"), ("Mono", "Mono"), ("channel 0", "channel 0"), ("BP 525/50", "BP 525/50"),
    ("Alexa 488", "Alexa 488"),  # a lone number without a filter band names the dye
])
def test_short_channel_name_keeps_the_dye(name, short):
    assert short_channel_name(name) == short


def test_label_forms_fullest_first_dye_last_no_acquisition_words():
    forms = label_forms("spots", "FITC BP")
    assert forms == ("spots (FITC)", "spots FITC", "FITC")
    assert all("BP" not in f for f in forms)
    assert [len(f) for f in forms] == sorted((len(f) for f in forms), reverse=True)
    assert label_forms("nuclei", "DAPI")[-1] == "DAPI" and len(set(label_forms("nuclei", "DAPI"))) == 3
    # a role the dye or the file name says is worth more than a channel's code name: it comes before it
    assert label_forms("microtubules", "ChA-T1", role_known=True)[-2:] == ("microtubules", "ChA-T1")


@pytest.mark.parametrize("short, compact", [("Alexa Fluor 647", "AF647"), ("Alexa 488", "AF488"), ("alexa-594", "AF594"),
                                            ("FITC", "FITC"), ("Alexa Fluor", "Alexa Fluor")])
def test_compact_dye_is_the_usual_abbreviation_and_last_among_the_forms(short, compact):
    from tamp_os.relief.key_labels import compact_dye

    assert compact_dye(short) == compact
    assert label_forms("lines", short)[-1] == compact
