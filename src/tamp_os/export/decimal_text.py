"""Numbers written as decimal text by NumPy, a whole block of rows per array operation: the same
characters Python's '%.6f' and '%d' write, two to three times as fast, and with the GIL released for most
of the work (so zlib, or another writer, runs on the other core meanwhile; see threemf.py).

Each number is laid out in a fixed-width field of ASCII digits whose unused places hold a zero
byte; the lines are assembled as one uint8 array from a template and the zero bytes dropped at
the end. '%.6f' of a float32 x: x * 10**6 is exact in float64 (x's 24-bit significand times
10**6's 20 bits needs at most 44 of float64's 53), so rounding it to an integer with ties to even
gives the same six decimals as Python's correctly rounded formatting (round half to even as well).
"""

from __future__ import annotations

import functools

import numpy as np

PAD = 0  # the byte that fills unused places; never a character of the text
# Beyond this magnitude x * 10**6 may not be an exact integer in float64: such values (and inf,
# nan) are left to Python's formatting by the caller (fixed_six_supported).
FIXED_SIX_MAX = 2.0**53 / 1e6


def digit_columns(values: np.ndarray, width: int, *, pad_leading: bool) -> np.ndarray:
    """(len(values), width) uint8: each non-negative integer's ASCII digits, right-aligned; its
    leading zeros are PAD when `pad_leading` (the first digit from the right always stays)."""
    out = np.empty((len(values), width), np.uint8)
    rest = np.asarray(values, dtype=np.int64)
    for j in range(width - 1, -1, -1):
        zero = rest == 0 if pad_leading and j < width - 1 else None
        rest, digit = np.divmod(rest, 10)
        digit = digit.astype(np.uint8)
        digit += ord("0")
        if zero is not None:
            digit[zero] = PAD
        out[:, j] = digit
    return out


def width_of(largest: int) -> int:
    """How many digits the non-negative integer `largest` has."""
    return len(str(max(int(largest), 0)))


def lines_text(fields: list[np.ndarray], parts: list[bytes]) -> bytes:
    """Rows of parts[0] fields[0] parts[1] fields[1] ... parts[-1], each field an (n, w) uint8
    array of characters and PAD; the rows' text one after the other without the PAD bytes."""
    n = len(fields[0]) if fields else 0
    width = sum(map(len, parts)) + sum(f.shape[1] for f in fields)
    out = np.empty((n, width), np.uint8)
    at = 0
    for k, part in enumerate(parts):
        out[:, at : at + len(part)] = np.frombuffer(part, np.uint8)
        at += len(part)
        if k < len(fields):
            out[:, at : at + fields[k].shape[1]] = fields[k]
            at += fields[k].shape[1]
    flat = out.ravel()
    return flat[flat != PAD].tobytes()


def fixed_six_supported(values: np.ndarray) -> bool:
    """Whether fixed_six writes these float32 values (all finite and below FIXED_SIX_MAX)."""
    return len(values) == 0 or bool(np.abs(values.astype(np.float64)).max() < FIXED_SIX_MAX)


def fixed_six(values: np.ndarray) -> np.ndarray:
    """(len(values), w) uint8 fields: what '%.6f' writes of each float32 value (as float64),
    sign, integer digits, point and six decimals, with PAD in the unused places. The values
    must pass fixed_six_supported."""
    x = np.asarray(values, dtype=np.float32).astype(np.float64)
    whole, fraction = np.divmod(np.rint(np.abs(x) * 1e6).astype(np.int64), 1_000_000)
    digits = width_of(whole.max()) if len(x) else 1
    out = np.empty((len(x), digits + 8), np.uint8)
    # The sign from the value, not the rounded integer: '-0.000000' for -0.0 and tiny negatives, as Python (PAD is 0).
    out[:, 0] = np.signbit(x).view(np.uint8) * np.uint8(ord("-"))
    if digits <= 3:  # a print's millimetres: one gather from the table of 0 .. 999
        out[:, 1 : digits + 1] = np.take(_triples(True)[:, 3 - digits :], whole, axis=0)
    else:
        out[:, 1 : digits + 1] = digit_columns(whole, digits, pad_leading=True)
    out[:, digits + 1] = ord(".")
    high, low = np.divmod(fraction, 1000)  # the decimals three at a time, gathered from a table
    out[:, digits + 2 : digits + 5] = np.take(_triples(False), high, axis=0)
    out[:, digits + 5 :] = np.take(_triples(False), low, axis=0)
    return out


@functools.lru_cache(maxsize=2)
def _triples(pad_leading: bool) -> np.ndarray:
    """digit_columns of 0 .. 999, three places each (read-only: shared)."""
    table = digit_columns(np.arange(1000), 3, pad_leading=pad_leading)
    table.flags.writeable = False
    return table


def index_fields(indices: np.ndarray, *, table: np.ndarray | None = None) -> np.ndarray:
    """(len(indices), w) uint8 fields: what '%d' writes of each non-negative integer index, taken
    from `table` (index_table of more than the largest index) when given, else computed."""
    if table is not None:
        return np.take(table, indices, axis=0)
    return digit_columns(indices, width_of(indices.max()) if len(indices) else 1, pad_leading=True)


def index_table(count: int) -> np.ndarray:
    """The fields of the indices 0 .. count - 1 (index_fields' table): gathered rows instead of
    divisions per corner."""
    return digit_columns(np.arange(count, dtype=np.int64), width_of(count - 1), pad_leading=True)
