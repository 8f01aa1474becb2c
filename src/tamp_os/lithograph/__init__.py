"""The product: the pipeline that ties the stages together (read → clean → relief → mesh →
tactile), the report and its words, the files and recipe written, and the jobs built on them
(convert, batch, sweep, check, render, multi-panel figures)."""
