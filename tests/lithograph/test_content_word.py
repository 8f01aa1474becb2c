"""What a panel shows in a word (relief/content_word.py): each kind of picture named, the count
of a population near the truth, a panel letter's label box not counted, the same words on every
run, and cheap enough for the overview of a 4000 × 3000 figure."""

from __future__ import annotations

import time

import numpy as np
import pytest
import skimage.data
from PIL import Image, ImageDraw

from conftest import FIXTURES, need
from figures import FONT, fluorescence_composite, grid_colour
from synthetic import tem_texture
from synthetic_content import dark_line_network, dim_and_bright_beads, dot_lattice, faint_grains, line_diagram

from tamp_os.lithograph.content_word import content_word, without_corner_labels
from content_support import agrees


def _u8(image: np.ndarray) -> np.ndarray:
    return (np.clip(image, 0, 1) * 255).astype(np.uint8)


def _word(image: np.ndarray):
    if image.ndim == 3:
        return content_word(image.astype(np.float32).mean(axis=2), image)
    return content_word(image)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("maker, kind", [(dim_and_bright_beads, "members"), (dark_line_network, "lines"), (dot_lattice, "lattice"),
                                         (faint_grains, "grains"), (line_diagram, "line art")])
@pytest.mark.parametrize("size", [(192, 256), (300, 400), (900, 1200)])
def test_each_kind_of_grey_picture_is_named(maker, kind, size):
    truth = maker(*size)
    word = _word(_u8(truth.image))
    assert word.kind == kind, (truth.name, size, word)
    if kind == "members":
        assert abs(word.count - int(truth.members.max())) <= 2 and word.words == f"particles (about {word.count})"


@pytest.mark.timeout(120)
def test_colour_pictures_named_by_the_channel_paths_decision():
    composite = fluorescence_composite(300, 400)
    word = _word(composite)
    assert (word.kind, word.count, word.words) == ("fluorescence", 3, "fluorescence, 3 colours")
    two = composite.copy()
    two[..., 1] = np.random.default_rng(1).normal(4, 2, two.shape[:2]).clip(0, 255)  # green left as noise
    assert _word(two).words == "fluorescence, 2 colours"
    assert _word(skimage.data.immunohistochemistry()).words == "stained tissue"
    # colour that carries no meaning is named by its brightness, as the print is made
    grey = np.repeat(_u8(dim_and_bright_beads(300, 400).image)[..., None], 3, axis=2)
    assert _word(grey).kind == "members"
    assert _word(skimage.data.astronaut()).kind not in ("fluorescence", "stain")


@pytest.mark.timeout(60)
def test_plain_and_flat_pictures():
    assert content_word(np.full((200, 300), 7.0)).words == "a flat picture"
    assert content_word(np.full((200, 300), np.nan)).words == "a flat picture"
    assert content_word(_u8(tem_texture(300, 400).image)).words == "picture"  # noise over smooth grains: nothing to name


@pytest.mark.timeout(120)
def test_a_letter_box_in_a_corner_is_not_counted():
    """A white label box with its letter at the top left of a bead field would be one more
    particle; the picture's own ground touching the corner is left alone (it reaches out of the
    corner); a black box is cleared as a white one is. (A letter without a box, on the picture's
    own ground, is not told from the picture: the prints clean it, the word may count it.)"""
    beads = _u8(dim_and_bright_beads(300, 400).image)
    plain = _word(beads)
    assert plain.kind == "members"
    canvas = Image.fromarray(beads)
    draw = ImageDraw.Draw(canvas)
    from PIL import ImageFont

    draw.rectangle([0, 0, 45, 54], fill=255)
    draw.text((9, 4), "a", fill=0, font=ImageFont.truetype(FONT, 36))
    boxed = _word(np.asarray(canvas))
    assert boxed.count == plain.count, (boxed, plain)
    work = np.random.default_rng(0).uniform(0.2, 0.8, (96, 128)).astype(np.float32)
    work[:, :40] = 1.0  # a bright ground along the whole left side: the picture's, not a label
    assert np.array_equal(without_corner_labels(work), work)
    work[:10, 60:70] = 0.0
    boxed = work.copy()
    boxed[:12, -14:] = 0.0  # a black box in the top right corner
    cleared = without_corner_labels(boxed)
    assert np.all(cleared[:12, -14:] == np.float32(np.median(boxed))) and np.array_equal(cleared[:, :-14], boxed[:, :-14])


@pytest.mark.timeout(120)
def test_same_words_on_every_run_and_for_any_copy():
    pictures = [_u8(t.image) for t in (dim_and_bright_beads(300, 400), dark_line_network(300, 400))] + [fluorescence_composite(300, 400)]
    first = [_word(p) for p in pictures]
    assert [_word(p.copy()) for p in pictures] == first
    assert [_word(np.ascontiguousarray(p[::1])) for p in pictures] == first


@pytest.mark.timeout(300)
def test_words_for_a_four_panel_4000_by_3000_figure():
    """The overview words for all four panels of a 4000 × 3000 figure (one of them colour), each
    grey panel decided on its print's own grid; their CPU time (at most 0.5 s) is measured in
    benchmarks/bench_panels.py."""
    from tamp_os.clean.panels import detect_panels
    from tamp_os.lithograph.figure import figure_colour, panel_contents
    from tamp_os.params import LithoParams
    from tamp_os.read.image import read_array

    rows, cols = 1460, 1960

    def big(image):
        return np.asarray(Image.fromarray(image).resize((cols, rows), Image.Resampling.BILINEAR))

    panels = [big(_u8(t.image)) for t in (dim_and_bright_beads(300, 400), dark_line_network(300, 400), faint_grains(300, 400))]
    figure = grid_colour(panels + [big(fluorescence_composite(300, 400))], cols=2, gutter=26, size=120)
    assert figure.image.shape[:2] == (2998, 3998)
    picture = read_array(figure.image)
    layout = detect_panels(picture.values, read_letters=False)
    colour = figure_colour(figure.image, picture, LithoParams())
    words = panel_contents(picture.values, layout, colour)  # its CPU time: benchmarks/bench_panels.py (words)
    assert [w.kind for w in words.values()] == ["members", "lines", "grains", "fluorescence"]


AGREE = ["fept_spheres_sem.png", "test_tiff_Zeiss_SEM_1k.tif", "FEI-Helios-Ebeam-8bits.tif", "real/sem_fei_sio2_particles_35kx.tif",
         "real/sem_fei_sio2_particles_10kx.tif", "real/zeiss_sem_al2o3_grains.czi", "real/confocal_membranes_cells3d.tif",
         "real/velox_talos_haadf_particles.emd", "real/tvips_bin4.tif", "real/tia_talos_tem_search.emi", "real/jeol_dummy_bf.img"]


@pytest.mark.timeout(300)
@pytest.mark.parametrize("name", AGREE)
@pytest.mark.parametrize("width_mm", [100, 60])
def test_the_word_agrees_with_the_print_of_the_same_pixels(name, width_mm):
    """A panel's word and its own print decide on the same grid: the word of a fixture's pixels
    (as a panel carries them: no file metadata) names what the print of those pixels raised, at the
    width it is printed (once, on a 128-point grid of its own, FePt's 4 spheres read as a network
    of lines and the Al2O3 grain boundaries and SiO2 particles as 'picture')."""
    from tamp_os.params import LithoParams
    from tamp_os.lithograph.pipeline import make_lithograph
    from tamp_os.read.image import read_image

    need((FIXTURES / name).is_file(), f"fixture {name}")
    values = read_image(FIXTURES / name).values
    params = LithoParams(width_mm=width_mm)
    word = content_word(values, params=params)
    report = make_lithograph(values, params).report
    assert agrees(word, report), (name, word, report.relief_style, report.content_kind, report.legibility)
