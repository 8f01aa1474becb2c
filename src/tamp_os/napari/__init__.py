"""The napari front end (the `napari` extra): a dock widget that prints the layers on screen
through the same convert() as every front end, a reader for the microscope files napari does not
open itself, and writers that save layers as .stl or .3mf prints. napari finds it through the
`napari.manifest` entry point (napari.yaml beside this file)."""
