"""clean/band.py: a row's spread, worked out only for the rows the band search asks, is the whole
picture's row spread bit for bit, whatever the picture's memory layout."""

import numpy as np
import pytest

from tamp_os.clean import band

pytestmark = pytest.mark.timeout(60)


@pytest.mark.parametrize("layout", ["rows", "columns", "every other column", "transposed"])
def test_a_rows_spread_is_the_pictures_row_spread_in_any_layout(layout):
    rng = np.random.default_rng(7)
    picture = {
        "rows": lambda: rng.random((120, 333)).astype(np.float32),
        "columns": lambda: np.asfortranarray(rng.random((120, 333)).astype(np.float32)),
        "every other column": lambda: rng.random((120, 666)).astype(np.float32)[:, ::2],
        "transposed": lambda: rng.random((333, 120)).astype(np.float32).T,
    }[layout]()
    expected = picture.std(axis=1) / 2.5
    spread = band._RowSpread(picture, 2.5)
    assert [spread[row] for row in range(picture.shape[0])] == expected.tolist()


def test_the_band_is_found_the_same_in_any_layout():
    # A picture with a bright data band holding dark text marks at the bottom: the same band
    # whether the picture is laid out by rows or by columns.
    rng = np.random.default_rng(8)
    picture = rng.normal(100, 20, (200, 300)).clip(0, 255).astype(np.float32)
    picture[170:] = 250.0
    picture[180:190, 20:120:6] = 5.0  # text-like marks in the band
    found = band.detect_info_band(picture)
    assert found == band.detect_info_band(np.asfortranarray(picture))
    assert found[1] >= 25  # the band's 30 rows found at the bottom (within its frame rows)
