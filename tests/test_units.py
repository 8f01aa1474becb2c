"""Lengths typed by a user: how they are read and how a mistake is said."""

import pytest

from tamp_os.errors import ParameterError
from tamp_os.units import parse_length_m


def test_unreadable_length_says_the_examples_once_and_ends_with_a_sentence():
    # the message ended "...(units: ...). for example 4.2nm": the hint repeated the first example
    # after the full list, in lower case, as a fragment
    with pytest.raises(ParameterError) as info:
        parse_length_m("4.2parsecs")
    text = str(info.value)
    assert text.count("4.2nm") == 1, text
    assert "'4.2parsecs'" in text and "pixel_size" in text
    assert text.rstrip().endswith(")."), text
    # the hint (what to do) stays apart from the problem, for a front end to lay out itself
    assert "4.2nm" in info.value.hint and "4.2nm" not in info.value.problem


def test_a_readable_length_is_in_metres():
    assert parse_length_m("4.2nm") == pytest.approx(4.2e-9)
    assert parse_length_m("3 micron") == pytest.approx(3e-6)
