"""A minimal Leica LIF (version 2) written from arrays, for tests that need a series the real
fixture does not hold: a λ (emission) or Λ (excitation) wavelength sweep.

Layout: a header block (0x70, size, 0x2A, the XML's length in UTF-16 characters, the XML), then one
memory block per image (0x70, 0, 0x2A, its size as uint64, 0x2A, its id's length, the id in UTF-16,
the pixels). Each image is an Element under the root's Children, with its dimensions and channels
in Data/Image/ImageDescription and its memory block named in Memory/@MemoryBlockID.
"""

from __future__ import annotations

import struct

import numpy as np

DIM_ID = {"X": 1, "Y": 2, "Z": 3, "T": 4, "λ": 5, "Λ": 9}


def _image_xml(name: str, index: int, axes: str, data: np.ndarray, coords: dict) -> str:
    """Dimensions are listed innermost first, each with its byte increment (C is a channel list)."""
    itemsize = data.dtype.itemsize
    inc, dims, channels = itemsize, [], []
    for axis, n in reversed(list(zip(axes, data.shape))):
        if axis == "C":
            channels = [(c * inc) for c in range(n)]
        else:
            origin, step = coords.get(axis, (0.0, 1e-7))
            dims.append(f'<DimensionDescription DimID="{DIM_ID[axis]}" NumberOfElements="{n}" Origin="{origin:e}" '
                        f'Length="{step * (n - 1):e}" Unit="{"s" if axis == "T" else "m"}" BitInc="0" BytesInc="{inc}"/>')
        inc *= n
    channels = channels or [0]
    chans = "".join(f'<ChannelDescription DataType="0" ChannelTag="0" Resolution="{itemsize * 8}" NameOfMeasuredQuantity="" '
                    f'Min="0" Max="{2 ** (itemsize * 8) - 1}" Unit="" LUTName="Gray" IsLUTInverted="0" BytesInc="{b}" BitInc="0"/>'
                    for b in channels)
    return (f'<Element Name="{name}" Visibility="1" CopyOption="1" UniqueID="00000000-0000-0000-0000-{index:012d}"><Data><Image>'
            f'<ImageDescription><Channels>{chans}</Channels><Dimensions>{"".join(dims)}</Dimensions></ImageDescription>'
            f'</Image></Data><Memory Size="{data.nbytes}" MemoryBlockID="MemBlock_{index}"/><Children/></Element>')


def _memory_block(index: int, payload: bytes) -> bytes:
    ident = f"MemBlock_{index}".encode("utf-16-le")
    return struct.pack("<IIBQBI", 0x70, 0, 0x2A, len(payload), 0x2A, len(ident) // 2) + ident + payload


def write_lif(path, images: list[tuple[str, str, np.ndarray, dict]]):
    """images: (name, axes outermost first such as 'λYX' or 'CλYX', data in that order, coords) where
    coords maps an axis to (origin, step) in metres (seconds for T); default 0 and 0.1 µm."""
    children = "".join(_image_xml(name, i + 1, axes, np.asarray(data), coords) for i, (name, axes, data, coords) in enumerate(images))
    xml = (f'<LMSDataContainerHeader Version="2"><Element Name="{path.stem}" Visibility="1" CopyOption="1" '
           f'UniqueID="00000000-0000-0000-0000-000000000000"><Data><Experiment/></Data>'
           f'<Memory Size="0" MemoryBlockID="MemBlock_0"/><Children>{children}</Children></Element></LMSDataContainerHeader>')
    text = xml.encode("utf-16-le")
    out = struct.pack("<IIBI", 0x70, len(text) + 5, 0x2A, len(text) // 2) + text + _memory_block(0, b"")
    for i, (_, _, data, _) in enumerate(images):
        out += _memory_block(i + 1, np.ascontiguousarray(data).tobytes())
    path.write_bytes(out)
    return path
