"""What a 3-D model (`make_volume`) will cost, priced before the work: memory and time.

The cost of a model follows two numbers known before the voxel steps start: the working grid's
voxels (read, cropped to the content, interpolated and padded) and the most triangles marching
cubes can make of its surface (`mesh.volume.surface_triangles`, each cell priced by its case).
The phases run one after another, so the peak is the program's own memory and the largest phase:

- the voxel steps (level, specks, voids, walls: masks, labels and distance maps on the grid);
- the surface: the field kept, marching cubes, the mesh in manifold3d, and, when the surface has
  more than `max_triangles`, the simplifications and deviations that bring it to the budget, with
  the full surface kept as their reference;
- the walls, the stand and the files, on at most `max_triangles`.

The constants were measured on this machine kind (VmHWM of a child process, CPU seconds) over
balls, tori, noise and the development stacks, and rounded up: the price is meant to be at or above
the true peak (benchmarks/bench_volume.py prints both).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import InputError

PROGRAM_BYTES = 300e6  # the interpreter with NumPy, SciPy, scikit-image, manifold3d, trimesh and Embree loaded, and the stand's furniture
BYTES_PER_WORKING_VOXEL = 56  # float32 values, masks, two float64 distance maps, labels, the smoothed field (measured: ~50)
BYTES_PER_FIELD_VOXEL = 14  # during the surface: the field kept, its padded copy, the nudge mask, marching cubes' own
BYTES_PER_TRIANGLE = 1000  # marching cubes' arrays, the mesh in float64, in manifold3d, simplified copies, the deviation's trees
# (a 64³ noise stack: 2.4 GB at 2.8 million triangles at most, ~770 a triangle; smooth surfaces far less)
SECONDS_START = 2.0  # imports, the first slice, the stand's furniture and the files of a small model
SECONDS_PER_VOXEL = 1.2e-6  # the voxel steps and marching cubes
SECONDS_PER_TRIANGLE = 6e-6  # the surface into manifold3d, its walls, the stand's union, the checks and the files
SECONDS_PER_SIMPLIFIED_TRIANGLE = 150e-6  # the tolerance's search (several simplifications), the deviations measured and,
# when 0.1 mm cannot hold, the coarser grids tried (a noisy surface: minutes)
SAY_AFTER_S = 10.0  # a model priced at more than this says its expected time before it starts


@dataclass
class VolumePrice:
    """The price of a model: its memory by phase (bytes) and its expected time (CPU seconds)."""

    voxels: int
    triangles: int  # the most triangles marching cubes can make of the surface
    max_triangles: int
    phases: dict[str, float] = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def bytes(self) -> float:
        """The expected peak: the program and its largest phase."""
        return PROGRAM_BYTES + max(self.phases.values(), default=0.0)

    def words(self) -> str:
        """'about 12 s and 0.61 GB (a grid of 1.2 million voxels, a surface of up to 240,000 triangles)'."""
        return (f"about {self.seconds:.0f} s and {self.bytes / 1e9:.2f} GB (a working grid of {_count(self.voxels)} voxels, "
                f"a surface of up to {_count(self.triangles)} triangles)")

    def check(self, path, *, max_memory_gb: float, hint: str = "") -> None:
        """Refuse (InputError, one line) a model whose price is over `max_memory_gb`."""
        if self.bytes <= max_memory_gb * 1e9:
            return
        largest = max(self.phases, key=self.phases.get)
        raise InputError(
            f"{path}: this 3-D model would need about {self.bytes / 1e9:.1f} GB of memory ({largest} "
            f"{self.phases[largest] / 1e9:.1f} GB: a working grid of {_count(self.voxels)} voxels, a surface of up to "
            f"{_count(self.triangles)} triangles) and about {self.seconds:.0f} s, above the limit of {max_memory_gb:g} GB "
            f"that guards this computer; nothing was written.{(' ' + hint) if hint else ''}",
            hint=f"If the computer has the memory, raise the limit, for example `max_memory_gb` {int(self.bytes / 1e9) + 1}.")


def price_model(voxels: int, triangles: int, max_triangles: int) -> VolumePrice:
    """The price of a model on a working grid of `voxels` whose surface has at most `triangles`."""
    simplified = triangles if triangles > max_triangles else 0
    kept = min(triangles, max_triangles)
    phases = {
        "the voxel steps": float(voxels) * BYTES_PER_WORKING_VOXEL,
        "the surface": float(voxels) * BYTES_PER_FIELD_VOXEL + float(triangles) * BYTES_PER_TRIANGLE,
    }
    seconds = (SECONDS_START + voxels * SECONDS_PER_VOXEL + (triangles + kept) * SECONDS_PER_TRIANGLE
               + simplified * SECONDS_PER_SIMPLIFIED_TRIANGLE)
    return VolumePrice(int(voxels), int(triangles), int(max_triangles), phases, float(seconds))


def _count(n: int) -> str:
    """12,345 or 3.4 million."""
    return f"{n / 1e6:.1f} million" if n >= 1e6 else f"{n:,}"
