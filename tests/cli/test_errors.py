"""errors.py: messages name parameters as data and templates, so each front end says them in its
own words without rewriting sentences; parameters take SI numbers as well as text."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from tamp_os import make_lithograph
from tamp_os.errors import InputError, ParameterError, Text, render
from tamp_os.params import LithoParams
from conftest import examples

pytestmark = pytest.mark.timeout(120)


def test_a_parameter_error_carries_its_parts_as_data():
    with pytest.raises(ParameterError) as caught:
        LithoParams(relief_mm=70)
    e = caught.value
    assert e.parameter == "relief_mm" and e.value == 70 and "50" in e.allowed
    assert str(e) == "relief_mm: must be > 0.0 and ≤ 50.0 mm; got 70 mm."
    assert e.words(lambda name: "Relief height") == "Relief height: must be > 0.0 and ≤ 50.0 mm; got 70 mm."


def test_errors_and_texts_survive_pickling_with_their_template():
    """Batch workers send errors and warnings back pickled; the CLI still names its options."""
    e = pickle.loads(pickle.dumps(InputError("x.tif: too large.", hint="raise `max_megapixels` to 5.")))
    assert str(e) == "x.tif: too large. raise max_megapixels to 5."
    assert e.words(lambda n: "--max-megapixels") == "x.tif: too large. raise --max-megapixels to 5."
    assert e.hint_names() == {"max_megapixels"} and e.words(hint=False) == "x.tif: too large."
    t = pickle.loads(pickle.dumps(Text("choose one slice with `z_slice`")))
    assert t == "choose one slice with z_slice" and t.words(lambda n: "--slice") == "choose one slice with --slice"
    p = pickle.loads(pickle.dumps(ParameterError("`bed_mm`: no", parameter="bed_mm", value="x", allowed="a size")))
    assert (p.parameter, p.value, p.allowed) == ("bed_mm", "x", "a size")


PLAIN = st.text(alphabet=st.characters(blacklist_characters="`", blacklist_categories=("Cs",)), max_size=12)
PIECE = st.one_of(  # (template, said by a front end, said by the library)
    PLAIN.map(lambda t: (t, t, t)),
    st.sampled_from(["z_slice", "pixel_size", "relief_mm"]).map(lambda n: (f"`{n}`", f"<{n}>", n)),  # parameters
    st.sampled_from(["hello", "nozzle", "x_y", ""]).map(lambda w: (f"`{w}`",) * 3),  # not parameters: kept as they are
)


@settings(max_examples=examples(300), deadline=None)
@given(st.lists(PIECE, max_size=8))
def test_render_replaces_only_backticked_parameter_names(pieces):
    template = "".join(t for t, _, _ in pieces)
    assert render(template, lambda name: f"<{name}>") == "".join(w for _, w, _ in pieces)
    assert Text(template) == "".join(lib for _, _, lib in pieces)


def test_pixel_size_scale_bar_and_bed_take_si_numbers():
    """Bug: make_lithograph(img, pixel_size=4.2e-9) was refused ('must be text')."""
    image = np.tile(np.linspace(0, 1, 64), (48, 1))
    litho = make_lithograph(image, pixel_size=4.2e-9, preset="low")
    assert litho.report.pixel_size_m == pytest.approx(4.2e-9)
    assert litho.report.pixel_size_m == make_lithograph(image, pixel_size="4.2nm", preset="low").report.pixel_size_m
    assert LithoParams(scale_bar=5e-6).scale_bar_m == pytest.approx(5e-6)
    assert LithoParams(bed_mm=150).bed_size_mm == (150.0, 150.0)
    for bad in (-1.0, 0.0, 5.0, float("nan"), True):
        with pytest.raises(ParameterError, match="pixel_size"):
            LithoParams(pixel_size=bad)


def test_reprs_are_one_short_line():
    litho = make_lithograph(np.eye(40), preset="low")
    for text in (repr(litho), repr(litho.mesh)):
        assert "\n" not in text and len(text) < 200 and "array(" not in text
    assert "triangles" in repr(litho.mesh) and "mm" in repr(litho)


def test_help_shows_each_fields_unit_range_and_meaning():
    import pydoc

    from tamp_os.lithograph.pipeline import make_lithograph as make

    text = pydoc.render_doc(LithoParams, renderer=pydoc.plaintext)
    for needle in ("relief_mm", "height of the relief above the base", "mm", "> 0.0 and ≤ 50.0", "pixel_size"):
        assert needle in text, needle
    assert "relief_mm" in make.__doc__ and "> 0.0 and ≤ 50.0" in make.__doc__


def test_the_report_is_typed_frozen_and_keeps_its_json_keys():
    import dataclasses
    import json

    from tamp_os.lithograph.report import Plate

    litho = make_lithograph(np.pad(np.ones((30, 40)), 8), preset="low", pixel_size="1um", caption="A")
    r = litho.report
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.triangles = 0
    assert isinstance(r.tactile, Plate) and r.tactile.scale_bar_m > 0 and r.tactile.scale_bar_mm >= 8
    assert r.tactile.scale_bar_label and r["tactile"]["scale_bar_label"] == r.tactile.scale_bar_label
    d = r.as_dict()
    json.dumps(d)  # plain JSON all the way down
    for key in ("input", "print_mm", "tactile", "crop", "annotations", "warnings", "legibility", "instrument", "relief_style"):
        assert key in d, key
    assert d["legibility"]["verdicts"] == list(r.legibility.verdicts) and "levels_mm" in d["legibility"]
    assert d["crop"] == {"top_rows": 0, "bottom_rows": 0, "left_columns": 0, "right_columns": 0, "source": None}
    assert "print" not in d and r.get("print") is None
