"""Stage 1, reading: any image file to an array and typed metadata. `image` dispatches by content
(TIFF and its pages and stacks, DigitalMicrograph, anything Pillow reads); `vendor/` holds the
microscope formats; `cost` prices a read before any pixel is decoded; `model` holds the types the
readers share; `channels` gives every channel of one plane."""
