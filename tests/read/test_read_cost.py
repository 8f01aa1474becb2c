"""The memory guard's message (read_cost.check_memory)."""

import pytest

from tamp_os.errors import InputError
from tamp_os.read.cost import Cost, check_memory


def test_the_memory_limit_hint_says_the_option_as_it_is_typed():
    from tamp_os.cli.commands import cli_words

    cost = Cost()
    cost.add("decoded pixels", 2.5e9)
    with pytest.raises(InputError) as info:
        check_memory("x.tif", "1000×1000 image", cost, max_memory_gb=1.0)
    words = cli_words(info.value)
    assert "--max-memory-gb 3." in words and "= 3" not in words, words  # it said "--max-memory-gb = 3"
    assert "2.5 GB" in words and "1 GB" in words
