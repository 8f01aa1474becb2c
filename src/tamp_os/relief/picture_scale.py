"""Deciding what is an object in the picture's own terms, whatever the print's width.

The object finders (edges, local contrast) carry lengths in mm: rim gaps bridged, necks split,
the local ground's width, the smallest object kept. Read on the print, they change meaning with
the print's width: the FePt spheres were 4 objects at 100 mm wide, 2 at 80 and 3 at 150. What is
an object is a fact of the picture, not of the print; only what a finger needs (a feelable
size, a groove) is a fact of the print.

So the edge finder (and the dense-field test, dense.py) run on a *picture grid*: the working
grid resampled as if the print were REFERENCE_WIDTH_MM wide (the width their constants were set
and measured at), where one "reference mm" is a fixed share of the picture's width. Their labels
come back to the working grid, and the styles then shape them in true mm. At REFERENCE_WIDTH_MM
the picture grid is the working grid itself (nothing is resampled, the objects are exactly those
found before). The members found by local contrast (population.py) stay on the working grid: on
the picture grid of a narrow print, a blurred plateau wider than their local ground left arcs
of its rim that passed as members.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .scales import resize_to

REFERENCE_WIDTH_MM = 100.0  # the finders' mm constants were set on prints this wide


@dataclass(frozen=True)
class PictureScale:
    """The working grid (shape, pitch in mm on the print) and its picture grid.

    picture_shape : (rows, cols) of the picture grid.
    picture_pitch_mm : its pitch in reference mm (REFERENCE_WIDTH_MM across the picture).
    """

    work_shape: tuple[int, int]
    pitch_mm: float
    picture_shape: tuple[int, int]
    picture_pitch_mm: float

    @classmethod
    def plan(cls, work_shape: tuple[int, int], pitch_mm: float) -> "PictureScale":
        """The picture grid keeps the working grid's pitch, in reference mm: at the reference
        width the two are the same grid."""
        rows, cols = work_shape
        width_mm = (cols - 1) * pitch_mm
        if cols < 2 or abs(width_mm - REFERENCE_WIDTH_MM) <= 0.5 * pitch_mm:
            return cls(work_shape, pitch_mm, work_shape, pitch_mm)
        cols_p = max(2, int(round(REFERENCE_WIDTH_MM / pitch_mm)) + 1)
        rows_p = max(2, int(round((rows - 1) * (cols_p - 1) / (cols - 1))) + 1)
        return cls(work_shape, pitch_mm, (rows_p, cols_p), REFERENCE_WIDTH_MM / (cols_p - 1))

    @property
    def identity(self) -> bool:
        return self.picture_shape == self.work_shape

    @property
    def blur_ratio(self) -> float:
        """How much blurrier the picture grid is than a picture prepared at the reference width
        (>= 1). The pipeline blurs in output pixels (a preset's 1.2 px), so a narrower print
        carries a picture blurred over a larger share of its width: by the ratio of the grids."""
        return max(1.0, (self.picture_shape[1] - 1) / max(self.work_shape[1] - 1, 1))

    @property
    def mm_per_reference_mm(self) -> float:
        """True mm on the print per reference mm (the print's width over REFERENCE_WIDTH_MM)."""
        return (self.work_shape[1] - 1) * self.pitch_mm / REFERENCE_WIDTH_MM

    def to_picture(self, work: np.ndarray) -> np.ndarray:
        """Working grid -> picture grid (bilinear)."""
        if self.identity:
            return work
        return resize_to(work, self.picture_shape, nearest=False)

    def labels_to_work(self, labels: np.ndarray) -> np.ndarray:
        """Labels on the picture grid -> the working grid (nearest), numbered 1..n again
        (a member smaller than a working pixel may vanish on a coarser grid)."""
        if self.identity:
            return labels
        from .objects import sequential_labels

        back = resize_to(labels.astype(np.float32), self.work_shape, nearest=True).astype(np.int32)
        return sequential_labels(back).astype(np.int32)


def find_objects_in_picture(work: np.ndarray, *, pitch_mm: float, min_area_mm2: float, nozzle_mm: float = 0.4):
    """objects.find_objects on the picture grid (its lengths in reference mm), labels on the
    working grid: the same objects at any print width."""
    from .objects import ObjectMap, find_objects

    scale = PictureScale.plan(work.shape, pitch_mm)
    found = find_objects(scale.to_picture(work), pitch_mm=scale.picture_pitch_mm, min_area_mm2=min_area_mm2, nozzle_mm=nozzle_mm,
                         blur_ratio=scale.blur_ratio)
    if scale.identity or found.count == 0:
        return found if scale.identity else ObjectMap(np.zeros(work.shape, np.int32), 0, found.method)
    labels = scale.labels_to_work(found.labels)
    return ObjectMap(labels, int(labels.max()), found.method)
