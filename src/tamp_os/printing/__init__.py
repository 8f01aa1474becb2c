"""Printing: printer profiles and their tables, presets by nozzle, the print settings a slicer
reads, and slicing with PrusaSlicer. Data and rules only: it imports no stage."""
