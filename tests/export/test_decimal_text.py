"""NumPy's decimal text (export/decimal_text.py) against Python's own '%.6f' and '%d'."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import examples
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from tamp_os.export import decimal_text

PARTS = [b"<a x=\"", b"\" y=\"", b"\"/>\n"]


def _numpy_lines(values: np.ndarray) -> bytes:
    fields = decimal_text.fixed_six(values.ravel())
    fields = fields.reshape(len(values), 2, fields.shape[1])
    return decimal_text.lines_text([fields[:, 0], fields[:, 1]], PARTS)


def _python_lines(values: np.ndarray) -> bytes:
    return "".join('<a x="%.6f" y="%.6f"/>\n' % tuple(row) for row in values.astype(np.float64).tolist()).encode()


# Values where '%.6f' is delicate: exact ties (k/128 is a float32 whose millionfold ends in .5),
# zeros of both signs, negatives that round to zero, values just beside whole numbers, wide ones.
TRICKY = np.array([0.0, -0.0, 1 / 128, -1 / 128, 3 / 128, 5e-7, -5e-7, -1e-9, 4.9999995e-7, 0.9999995, -0.9999995,
                   1.0000005, 99.99999, 12345.679, -65536.5, 2.0**-20, 8_000_000.0, -9_000_000_000.0], dtype=np.float32)


@pytest.mark.timeout(60)
def test_tricky_values_read_as_python_writes_them():
    values = np.stack([TRICKY, TRICKY[::-1]], axis=1)
    assert decimal_text.fixed_six_supported(values)
    assert _numpy_lines(values) == _python_lines(values)


@pytest.mark.timeout(120)
@settings(max_examples=examples(200))
@given(values=arrays(np.float32, st.tuples(st.integers(0, 40), st.just(2)),
                     elements=st.floats(-2.0**33, 2.0**33, width=32) | st.integers(-4000, 4000).map(lambda k: k / 128)))
def test_any_float32_reads_as_python_writes_it(values):
    assert decimal_text.fixed_six_supported(values)
    assert _numpy_lines(values) == _python_lines(values)


@pytest.mark.timeout(60)
@pytest.mark.parametrize("bad", [np.inf, -np.inf, np.nan, 3e10, -1e12])
def test_values_it_cannot_write_exactly_are_refused(bad):
    """inf and nan have no digits; beyond FIXED_SIX_MAX the millionfold may not be exact."""
    assert not decimal_text.fixed_six_supported(np.array([[1.0, bad]], dtype=np.float32))


@pytest.mark.timeout(120)
@settings(max_examples=examples(200))
@given(count=st.integers(1, 5000), picks=st.lists(st.integers(0, 4999), max_size=60), wide=st.lists(st.integers(0, 2**32 - 1), max_size=5))
def test_indices_read_as_python_writes_them_with_and_without_the_table(count, picks, wide):
    indices = np.array([p % count for p in picks], dtype=np.uint32)
    expected = "".join(f"<i {i}>\n" for i in indices.tolist()).encode()
    for table in (decimal_text.index_table(count), None):
        fields = decimal_text.index_fields(indices, table=table)
        assert decimal_text.lines_text([fields], [b"<i ", b">\n"]) == expected
    big = np.array(wide, dtype=np.uint32)  # any uint32, as an invalid mesh's indices may be
    fields = decimal_text.index_fields(big)
    assert decimal_text.lines_text([fields], [b"<i ", b">\n"]) == "".join(f"<i {i}>\n" for i in wide).encode()


@pytest.mark.timeout(60)
def test_no_rows_give_no_text():
    empty = np.zeros((0, 2), np.float32)
    assert _numpy_lines(empty) == b"" and decimal_text.fixed_six_supported(empty)
    assert decimal_text.lines_text([decimal_text.index_fields(np.zeros(0, np.uint32))], [b"<i ", b">\n"]) == b""
