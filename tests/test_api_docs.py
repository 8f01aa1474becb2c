"""The public API's docstrings: numpydoc sections, and their examples run (doctest)."""

from __future__ import annotations

import doctest

import pytest

from tamp_os import LithoParams
from tamp_os.lithograph.convert import convert
from tamp_os.lithograph.pipeline import make_lithograph
from tamp_os.lithograph.report import Report
from tamp_os.read.image import read_image

PUBLIC = [make_lithograph, convert, read_image, LithoParams, Report]


@pytest.mark.timeout(300)
@pytest.mark.parametrize("obj", PUBLIC, ids=lambda o: o.__name__)
def test_examples_run(obj):
    finder = doctest.DocTestFinder(recurse=False)
    tests = finder.find(obj, obj.__name__, globs={obj.__name__: obj})
    assert tests and tests[0].examples, f"{obj.__name__} has no example"
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for test in tests:
        runner.run(test)
    assert runner.failures == 0, f"{runner.failures} example(s) of {obj.__name__} failed (run with -s to see them)"


@pytest.mark.parametrize("obj", PUBLIC, ids=lambda o: o.__name__)
def test_numpydoc_sections(obj):
    doc = obj.__doc__ or ""
    assert "Examples\n    --------" in doc
    if callable(obj) and not isinstance(obj, type):
        assert "Parameters\n    ----------" in doc and "Returns\n    -------" in doc
