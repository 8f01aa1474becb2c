"""relief/legibility.py: figures of synthetic reliefs with known answers, and every verdict at its threshold."""

import math
import numpy as np
import pytest
from conftest import need


def _figures(**changes) -> dict:
    """Figures of a relief that reads well (no advice), changed where a test says."""
    base = dict(fine_share=0.1, levels_used=3, smallest_step_mm=1.0, narrow_area_mm2=0.0, narrow_share=0.0,
                steepest_slope_deg=44.6, object_count=0, object_lift_mm=None, lowest_lift_mm=None, relief_span_mm=2.0,
                period_mm=None)
    return {**base, **changes}


def _verdicts(style=None, nozzle_mm=0.4, **changes) -> list[str]:
    from tamp_os.relief.legibility import verdicts

    return [str(v) for v in verdicts(_figures(**changes), nozzle_mm, style)]


def test_verdicts_of_a_relief_that_reads_well():
    assert _verdicts() == [
        "Most of the relief is shape a fingertip can follow: only 10% of its variation is finer than about 1 mm.",
        "3 distinct height levels, at least 1 mm apart: easy to tell apart by touch.",
        "The steepest slope is 45 degrees.",
    ]


@pytest.mark.parametrize("span, levels, flat", [(0.049, 1, True), (0.049, 0, True), (0.05, 1, False), (0.01, 2, False)])
def test_a_flat_plate_is_only_said_when_nothing_is_raised(span, levels, flat):
    said = _verdicts(relief_span_mm=span, levels_used=levels, smallest_step_mm=None)
    assert (said == ["This print is a flat plate: there is nothing raised to feel."]) == flat


def test_fine_share_verdicts_at_and_above_the_warning():
    assert _verdicts(fine_share=0.2)[0].startswith("Most of the relief is shape")  # 0.2 is not above the warning
    rough = "21% of this relief's height variation is finer than a fingertip resolves (about 1 mm), so it is felt as roughness, not as shape; "
    assert _verdicts(fine_share=0.21)[0] == rough + "try relief_style structure, or a larger detail_mm."
    assert _verdicts(fine_share=0.21, style="structure")[0] == rough + "try a larger detail_mm or a lower texture_mm."
    assert _verdicts(fine_share=0.5, style="content")[0] == (
        "50% of this relief's height variation is finer than a fingertip resolves (about 1 mm): it is the edges of the "
        "drawn content (raised lines, members' outlines), kept on purpose; a wider print spreads it out.")
    assert _verdicts(fine_share=0.5, period_mm=3.04, style="content")[0] == (
        "50% of this relief's height variation is finer than a 1 mm low-pass keeps, but it is a lattice of 3.0 mm pitch, "
        "which fingers feel as a pattern (braille dots are 2.5 mm apart), not as roughness.")
    assert _verdicts(fine_share=0.1, period_mm=3.0)[0].startswith("Most of the relief")  # a period only matters when rough


def test_a_channel_print_is_not_advised_options_that_do_not_reach_its_textures():
    """The channels' ridges and dots are drawn at a set spacing; the relief style and detail_mm
    would not change them (and the style would drop the key): the verdict says what they are."""
    rough, narrow = _verdicts(fine_share=0.3, narrow_share=0.1, narrow_area_mm2=1694, style="channels")[0:3:2]
    assert rough == ("30% of this relief's height variation is finer than a fingertip resolves (about 1 mm): it is the "
                     "edges of the channels' textures, drawn so on purpose and named in the key.")
    assert "detail_mm" not in narrow and "channels' textures" in narrow, narrow


def test_the_advice_names_parameters_in_each_front_ends_words():
    from tamp_os.relief.legibility import verdicts

    said = verdicts(_figures(fine_share=0.3), 0.4)[0]
    assert "`relief_style` structure" in said.template and "`detail_mm`" in said.template


def test_level_verdicts_at_their_thresholds():
    assert _verdicts(levels_used=9)[1] == (
        "The heights vary continuously (9 layer levels in use): read it as a landscape, not as distinct levels.")
    assert _verdicts(levels_used=8)[1] == "8 distinct height levels, at least 1 mm apart: easy to tell apart by touch."
    assert _verdicts(levels_used=2, smallest_step_mm=0.3)[1] == (
        "2 height levels; the smallest step between neighbouring regions is 0.3 mm, under the 0.5 mm fingers tell "
        "apart reliably; try fewer levels or a taller relief.")
    assert _verdicts(smallest_step_mm=0.5)[1] == "3 distinct height levels, at least 0.5 mm apart: easy to tell apart by touch."
    assert _verdicts(smallest_step_mm=0.4999999)[1].startswith("3 height levels; the smallest step")
    assert len(_verdicts(levels_used=1, smallest_step_mm=None)) == 2  # no level sentence


def test_narrow_feature_verdict_above_five_percent():
    assert not any("narrower" in v for v in _verdicts(narrow_share=0.05, narrow_area_mm2=50))
    assert _verdicts(narrow_share=0.051, narrow_area_mm2=51.2, nozzle_mm=0.6)[2] == (
        "51 mm² (5% of the picture) is ridges or grooves narrower than two nozzle widths (1.2 mm): they may not print "
        "and read as noise; a larger detail_mm removes them.")


def test_object_verdicts_singular_plural_low_and_high():
    one_low = _verdicts(object_count=1, object_lift_mm=0.4, lowest_lift_mm=0.4)
    assert one_low[2] == ("The 1 object stands only 0.4 mm (median) above the ground around it; a finger may not find it; "
                          "try relief_style objects.")
    two_low = _verdicts(object_count=2, object_lift_mm=0.99, lowest_lift_mm=0.5, style="objects")
    assert two_low[2] == ("The 2 objects stand only 0.99 mm (median) above the ground around them; a finger may not find "
                          "them; try a taller relief_mm.")
    # The content style's own check measures its members against the picture (issue 32: a dense
    # lattice's "stand only 0 mm (median)" beside "392 members, all raised at least 2.0 mm").
    assert not any("stand only" in v for v in _verdicts(object_count=2, object_lift_mm=0.0, lowest_lift_mm=0.0, style="content"))
    assert _verdicts(object_count=2, object_lift_mm=0.5, lowest_lift_mm=0.5, style="objects")[2].endswith("try a taller relief_mm.")
    assert _verdicts(object_count=1, object_lift_mm=1.0, lowest_lift_mm=1.0)[2] == (
        "1 object stands 1 mm (median; lowest 1 mm) above the ground around it.")
    assert _verdicts(object_count=3, object_lift_mm=2.0, lowest_lift_mm=1.5)[2] == (
        "3 objects stand 2 mm (median; lowest 1.5 mm) above the ground around them.")
    # The content style says its members' height once, in its own check ("Found 3 members, all raised ...").
    assert not any("objects stand" in v for v in _verdicts(object_count=3, object_lift_mm=2.0, lowest_lift_mm=1.5, style="content"))


MM = 0.4


def _two_levels(low=1.0, high=3.0, shape=(60, 80)):
    h = np.full(shape, low)
    h[:, shape[1] // 2:] = high
    return h


def test_span_levels_and_shares_of_a_two_level_plate():
    from tamp_os.relief.legibility import assess

    report = assess(_two_levels(), MM)
    assert report.relief_span_mm == pytest.approx(2.0)
    assert report.levels_used == 2 and report.smallest_step_mm == pytest.approx(2.0)
    assert report.object_count == 0 and report.object_lift_mm is None and report.lowest_lift_mm is None
    assert report.narrow_area_mm2 == 0.0 and report.narrow_share == 0.0
    assert report.period_mm is None and report.levels_mm is None
    assert report.verdicts[1] == "2 distinct height levels, at least 2 mm apart: easy to tell apart by touch."
    # The step is 0.4 mm wide at 0.4 mm a pixel (one pixel): arctan(2 / 0.8) on the central difference.
    assert report.steepest_slope_deg == pytest.approx(np.degrees(np.arctan(2.0 / (2 * MM))), abs=0.5)


def test_a_level_must_cover_a_fingertips_area():
    from tamp_os.relief.legibility import assess

    h = np.full((50, 50), 1.0)  # 20 × 20 mm at 0.4 mm a pixel
    h[10:14, 10:14] = 2.0  # 16 px = 2.56 mm²: under the 6 mm² default
    assert assess(h, MM).levels_used == 1 and assess(h, MM).smallest_step_mm is None
    assert assess(h, MM, min_area_mm2=2.5).levels_used == 2
    h[10:17, 10:17] = 2.0  # 49 px = 7.84 mm²
    assert assess(h, MM).levels_used == 2 and assess(h, MM).smallest_step_mm == pytest.approx(1.0)


def test_heights_are_compared_to_the_layer_height():
    from tamp_os.relief.legibility import assess

    h = _two_levels(1.0, 1.06)
    assert assess(h, MM).levels_used == 2  # 0.06 mm rounds to one 0.1 mm layer
    assert assess(h, MM).smallest_step_mm == pytest.approx(0.1)
    assert assess(h, MM, layer_mm=0.2).levels_used == 1  # 0.06 mm rounds to no 0.2 mm layer
    assert assess(h, MM, layer_mm=0.03).smallest_step_mm == pytest.approx(0.06)
    fine = assess(_two_levels(1.0, 1.0005), MM, layer_mm=1e-6)  # the quantum is at least 1 µm
    assert fine.levels_used == 1


def test_levels_that_never_touch_have_no_step():
    from tamp_os.relief.legibility import _levels_and_step

    q = np.zeros((40, 40))
    q[:, 20:] = 1.0
    assert _levels_and_step(q, 0.1, 10) == (2, pytest.approx(1.0))
    assert _levels_and_step(q, 0.1, 801) == (0, None)
    # Two big regions separated by a thin strip that is too small to count: no step between big neighbours.
    q = np.zeros((40, 41))
    q[:, 20] = 0.5
    q[:, 21:] = 1.0
    levels, step = _levels_and_step(q, 0.1, 100)
    assert levels == 2 and step is None


def test_fine_share_of_a_flat_a_smooth_and_a_rough_relief():
    from tamp_os.relief.legibility import _fine_share

    assert _fine_share(np.full((30, 30), 2.0), MM) == 0.0
    assert _fine_share(np.full((30, 30), 2.0) + 1e-7 * (np.arange(30) % 2), MM) == 0.0  # variance under 1e-12
    checker = 1.0 + (np.indices((60, 60)).sum(0) % 2)  # a pixel checkerboard: almost all fine
    assert _fine_share(checker, MM) > 0.95
    wide = np.tile(np.sin(np.arange(200) * 2 * np.pi * MM / 40.0), (20, 1))  # 40 mm waves: a fingertip follows them
    assert _fine_share(wide, MM) < 0.01
    # The low-pass is sigma = 1 mm on the print: at a finer pitch the same waves are the same share.
    fine_pitch = np.tile(np.sin(np.arange(800) * 2 * np.pi * 0.1 / 4.0), (20, 1))
    coarse_pitch = np.tile(np.sin(np.arange(200) * 2 * np.pi * MM / 4.0), (20, 1))
    assert _fine_share(fine_pitch, 0.1) == pytest.approx(_fine_share(coarse_pitch, MM), abs=0.05)


def test_a_grating_a_finger_can_feel_has_its_period():
    from tamp_os.relief.legibility import assess

    x = np.arange(250) * MM
    grating = np.tile(1.0 + (np.sin(2 * np.pi * x / 4.0) > 0), (120, 1))  # 4 mm bars: rough by share, felt as a pattern
    report = assess(grating, MM)
    assert report.fine_share > 0.2
    assert report.period_mm == pytest.approx(4.0, rel=0.05)
    assert "lattice of 4.0 mm pitch" in report.verdicts[0]
    fine = np.tile(1.0 + (np.sin(2 * np.pi * x / 1.6) > 0), (120, 1))  # 1.6 mm bars: finer than 2.5 mm, roughness
    assert assess(fine, MM).period_mm is None


def test_feelable_period_of_a_flat_work_grid_is_none():
    from tamp_os.relief.legibility import _feelable_period

    assert _feelable_period(np.full((40, 40), 3.0), MM) is None


def test_narrow_area_counts_ridges_and_grooves_but_not_low_ones():
    from tamp_os.relief.legibility import _narrow_area

    pitch = 0.1
    h = np.ones((100, 100))
    h[:, 20:23] += 1.0  # a ridge 0.3 mm wide
    h[:, 60:63] -= 1.0  # a groove 0.3 mm wide
    area = _narrow_area(h, pitch, 0.4)
    assert area == pytest.approx(2 * 0.3 * 100 * pitch, rel=0.01)
    low = np.ones((100, 100))
    low[:, 20:23] += 0.25  # not higher than 0.25 mm: texture
    assert _narrow_area(low, pitch, 0.4) == 0.0
    low[:, 20:23] += 0.01
    assert _narrow_area(low, pitch, 0.4) == pytest.approx(0.3 * 100 * pitch, rel=0.01)


def test_narrow_share_is_of_the_whole_relief():
    from tamp_os.relief.legibility import assess

    pitch = 0.1
    h = np.ones((200, 200))
    h[:, 50:53] += 1.0
    report = assess(h, pitch, nozzle_mm=0.4)
    assert report.narrow_share == pytest.approx(report.narrow_area_mm2 / (200 * 200 * pitch**2))


def test_lift_of_labelled_objects_against_the_ground_they_own():
    from tamp_os.relief.legibility import _lifts

    yy, xx = np.mgrid[0:100, 0:200]
    a = (yy - 50) ** 2 + (xx - 50) ** 2 < 10**2
    b = (yy - 50) ** 2 + (xx - 150) ** 2 < 10**2
    h = np.where(xx < 100, 1.0, 2.0)  # each object's own ground: 1 mm on the left, 2 mm on the right
    h = h + 3.0 * a + 0.5 * b
    labels = a * 1 + b * 2
    n, median_lift, lowest = _lifts(h, labels, MM)
    assert n == 2 and lowest == pytest.approx(0.5) and median_lift == pytest.approx((3.0 + 0.5) / 2)
    assert _lifts(h, a | b, MM)[1:] == pytest.approx((1.75, 0.5))  # a mask is labelled first
    assert _lifts(h, np.zeros_like(labels), MM) == (0, None, None)
    assert _lifts(h, None, MM) == (0, None, None)


def test_lift_without_a_ring_of_ground_uses_all_the_ground():
    from tamp_os.relief.legibility import _lifts

    h = np.full((40, 40), 1.0)
    mask = np.zeros((40, 40), bool)
    mask[:, :39] = True  # the object leaves one column of ground, 0.4 mm away: no ring 1-3 mm out
    h[mask] = 2.5
    h[:, 39] = 1.5
    n, lift, lowest = _lifts(h, mask, MM)
    assert n == 1 and lift == pytest.approx(1.0) and lowest == pytest.approx(1.0)


def test_lift_ring_is_one_to_three_mm_around_the_object():
    from tamp_os.relief.legibility import _lifts

    pitch = 0.25
    yy, xx = np.mgrid[0:120, 0:120]
    r = np.hypot(yy - 60, xx - 60)
    mask = r < 12
    h = np.full((120, 120), 5.0)  # far ground: 5 mm, never in the ring
    h[r < 12 + 3 / pitch] = 1.0  # the ring 1-3 mm out (and the first mm) at 1 mm
    h[(r >= 12) & (r < 12 + 0.9 / pitch)] = 9.0  # the first millimetre next to the object is left out
    h[mask] = 2.0
    assert _lifts(h, mask, pitch)[1] == pytest.approx(1.0)


def test_the_report_as_a_dictionary():
    from tamp_os.relief.legibility import assess

    report = assess(_two_levels(), MM)
    d = report.as_dict()
    assert "levels_mm" not in d and isinstance(d["verdicts"], list) and d["verdicts"] == list(report.verdicts)
    assert d["levels_used"] == 2 and d["relief_span_mm"] == pytest.approx(2.0)
    import dataclasses

    with_levels = dataclasses.replace(report, levels_mm=(1.0, 3.0)).as_dict()
    assert with_levels["levels_mm"] == [1.0, 3.0]


def test_a_fine_grid_is_measured_on_a_working_grid_of_a_quarter_nozzle():
    from tamp_os.relief.legibility import assess

    pitch = 0.025  # 4 times finer than nozzle / 4
    h = np.ones((400, 400))
    h[:, 100:112] += 1.0  # a ridge 0.3 mm wide
    report = assess(h, pitch, nozzle_mm=0.4)
    assert report.narrow_area_mm2 == pytest.approx(0.3 * 400 * pitch, rel=0.35)
    assert report.levels_used == 1  # the ridge covers 3 mm², under a fingertip's 6 mm²
