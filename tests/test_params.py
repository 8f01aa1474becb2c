"""The parameters object: what a wrong value is told."""

import pytest

from tamp_os.errors import ParameterError
from tamp_os.params import LithoParams


def test_an_unreadable_scale_bar_names_auto_and_off_beside_a_length():
    # --scale-bar takes auto, off or a length; the message named only "a number and a unit"
    with pytest.raises(ParameterError) as info:
        LithoParams(scale_bar="5furlongs")
    text = str(info.value)
    assert "scale_bar" in text and "'5furlongs'" in text
    assert "auto" in text and "off" in text, text
    assert "auto" in info.value.allowed and "off" in info.value.allowed


def test_pixel_size_names_no_words_it_does_not_take():
    with pytest.raises(ParameterError) as info:
        LithoParams(pixel_size="5furlongs")
    assert "auto" not in str(info.value) and "off" not in str(info.value)
