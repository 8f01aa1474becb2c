"""What the microscope recorded about how the picture was made: magnification, accelerating
voltage and detector, from Zeiss, FEI/Thermo Fisher, TESCAN, Olympus SIS and DM metadata.

The detector matters to the relief: in secondary-electron (SE) images brightness shows edges and
slopes, in backscattered (BSE) images composition, in STEM images mass and thickness; never height.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from ..facts import Facts
from .vendor import number, tescan_main

SIGNALS = {"SE": "secondary-electron", "BSE": "backscattered-electron", "STEM": "scanning transmission"}
# Detector names by signal, most specific first (BSE names often contain "SE" too).
_DETECTOR_WORDS = (
    ("BSE", ("BSE", "BSD", "CBS", "ESB", "ABS", "BACKSCATTER")),
    ("STEM", ("STEM", "HAADF", "ADF")),
    ("SE", ("SE", "INLENS", "IN-LENS", "ETD", "TLD", "EVERHART")),
)


@dataclass(frozen=True)
class Instrument(Facts):
    """Facts of the acquisition, each None when the file does not record it.

    magnification : as the microscope reported it (×).
    kv : accelerating voltage in kV.
    detector : the detector's name as the file gives it ("HE-SE2", "ETD").
    signal : "SE", "BSE" or "STEM" when the detector's name or mode says so.
    source : the metadata the facts came from.
    """

    magnification: float | None = None
    kv: float | None = None
    detector: str | None = None
    signal: str | None = None
    source: str = ""

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def signal_of(*names: str | None) -> str | None:
    """'SE', 'BSE' or 'STEM' from detector names or modes ('HE-SE2' -> 'SE'), else None."""
    for name in names:
        text = str(name or "").upper()
        for signal, words in _DETECTOR_WORDS:
            if text and any(w in text for w in words):
                return signal
    return None


def _entry(sem: dict, key: str, index: int):
    try:
        return sem[key][index]
    except (KeyError, IndexError, TypeError):
        return None


def _zeiss(metadata: dict) -> Instrument | None:
    sem = metadata.get("sem_metadata")
    if not sem:
        return None
    kv = number(_entry(sem, "ap_actualkv", 1))  # ('EHT', 25.0, 'kV')
    unit = str(_entry(sem, "ap_actualkv", 2) or "kV")
    kv = kv / 1000 if kv is not None and unit.lower() == "v" else kv
    detector = _entry(sem, "dp_detector_type", 1) or _entry(sem, "dp_detector_channel", 1)
    magnification = number(_entry(sem, "ap_mag", 1))
    if magnification is not None and "K" in str(_entry(sem, "ap_mag", 2) or "").upper():
        magnification *= 1000  # ('Mag', 1.0, 'K X')
    return Instrument(magnification, kv, detector, signal_of(detector), "Zeiss SmartSEM")


def _fei(metadata: dict) -> Instrument | None:
    fei = metadata.get("fei_metadata")
    if not fei:
        return None
    volts = number((fei.get("Beam") or {}).get("HV")) or number((fei.get("EBeam") or {}).get("HV"))
    detectors = fei.get("Detectors") or {}
    field = number((fei.get("Scan") or {}).get("HorFieldsize")) or number((fei.get("EBeam") or {}).get("HorFieldsize"))
    canvas = number((fei.get("Image") or {}).get("MagCanvasRealWidth"))
    # FEI's databar magnification: the reference display width over the horizontal field width.
    magnification = canvas / field if canvas and field else None
    name = detectors.get("Name")
    return Instrument(magnification, volts / 1000 if volts else None, name, signal_of(detectors.get("Mode"), name),
                      "FEI/Thermo Fisher metadata")


def _tescan(metadata: dict, tiff_tags: dict, path: Path | None) -> Instrument | None:
    found = tescan_main(tiff_tags, path)
    if found is None:
        return None
    main, where = found
    volts = number(main.get("HV"))
    detector = main.get("Detector")
    return Instrument(number(main.get("Magnification")), volts / 1000 if volts else None, detector, signal_of(detector), where)


def _sis(metadata: dict) -> Instrument | None:
    sis = metadata.get("sis_metadata")
    if not sis or number(sis.get("magnification")) is None:
        return None
    return Instrument(magnification=number(sis.get("magnification")), source="Olympus SIS")


def _dm(metadata: dict) -> Instrument | None:
    tem = ((metadata.get("dm_metadata") or {}).get("Acquisition_instrument") or {}).get("TEM") or {}
    if not tem:
        return None
    detector = (tem.get("Detector") or {}) if isinstance(tem.get("Detector"), dict) else {}
    name = next(iter(detector), None)
    mode = tem.get("acquisition_mode")
    return Instrument(number(tem.get("magnification")), number(tem.get("beam_energy")), name, signal_of(mode, name),
                      "DigitalMicrograph")


def read_instrument(metadata: dict, tiff_tags: dict, path: str | None) -> Instrument | None:
    """The acquisition facts the file records, or None when it records none.

    Parameters
    ----------
    metadata, tiff_tags : ImageFile.metadata and ImageFile.tiff_tags of the input.
    path : the input file, for a TESCAN `.hdr` sidecar beside it; None for arrays.
    """
    where = Path(path) if path else None
    for found in (_zeiss(metadata), _fei(metadata), _tescan(metadata, tiff_tags, where), _sis(metadata), _dm(metadata)):
        if found is not None and (found.magnification or found.kv or found.detector):
            return found
    return None
