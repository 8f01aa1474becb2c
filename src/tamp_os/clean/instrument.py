"""What the microscope recorded about how the picture was made: magnification, accelerating
voltage and detector, from Zeiss, FEI/Thermo Fisher, TESCAN, Olympus SIS and DM metadata.

The detector matters to the relief: in secondary-electron (SE) images brightness shows edges and
slopes, in backscattered (BSE) images composition, in STEM images mass and thickness; never height.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from pathlib import Path

from ..facts import Facts
from .vendor import number, tescan_main

SIGNALS = {"SE": "secondary-electron", "BSE": "backscattered-electron", "STEM": "scanning transmission",
           "BF": "bright-field"}
# Which side is matter, by signal: SE, BSE and (HAADF) STEM show matter bright; a bright-field
# transmission image shows it dark (matter scatters the beam away from the detector).
BRIGHT_MATTER = ("SE", "BSE", "STEM")
DARK_MATTER = ("BF",)
# Detector names by signal, most specific first (BSE names often contain "SE" too).
_DETECTOR_WORDS = (
    ("BSE", ("BSE", "BSD", "CBS", "ESB", "ABS", "BACKSCATTER")),
    ("STEM", ("STEM", "HAADF", "ADF")),
    ("SE", ("SE", "INLENS", "IN-LENS", "ETD", "TLD", "EVERHART")),
)
# The same words as a data band prints them ("Det SE", "BSD Full", "Signal A = HE-SE2", "[ETD"),
# matched as whole words: in free text a substring finds SE in "SEM" or "BASE". Bright field
# first (a "STEM BF" band names the detector after the mode), and within a signal the detector's
# name before the mode's ("STEM HAADF": HAADF).
_BAND_WORDS = tuple((signal, tuple(re.compile(rf"(?<![A-Z0-9])({word})(?![A-Z0-9])") for word in words)) for signal, words in (
    ("BF", ("BF", "ABF", "BRIGHT[- ]?FIELD")),
    ("BSE", ("BSE", "BSED", "BSD", "CBS", "ESB", "VCD", "COMPO", "BACKSCATTER(?:ED)?")),
    ("STEM", ("HAADF", "ADF", "STEM")),
    ("SE", ("SE[12]?", "SEI", "ETD", "TLD", "INLENS", "IN-LENS", "LEI", "EVERHART")),
))
_KV = re.compile(r"(?<![0-9.,])([0-9]{1,3}(?:[.,][0-9]+)?) ?K[V¥](?![A-Z])")  # OCR reads V as ¥ in small band fonts
BAND_SOURCE = "the data band's text (OCR)"


@dataclass(frozen=True)
class Instrument(Facts):
    """Facts of the acquisition, each None when the file does not record it.

    magnification : as the microscope reported it (×).
    kv : accelerating voltage in kV.
    detector : the detector's name as the file gives it ("HE-SE2", "ETD").
    signal : "SE", "BSE", "STEM" or "BF" (bright field) when the detector's name or mode says so.
    source : the metadata the facts came from.
    """

    magnification: float | None = None
    kv: float | None = None
    detector: str | None = None
    signal: str | None = None
    source: str = ""

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def matter_is_bright(signal: str | None) -> bool | None:
    """True when the signal shows matter bright (SE, BSE, STEM), False when dark (bright field),
    None when the signal is unknown."""
    return True if signal in BRIGHT_MATTER else False if signal in DARK_MATTER else None


def instrument_from_text(text: str | None, source: str = BAND_SOURCE) -> Instrument | None:
    """The detector (and its signal) and the voltage a data band's text names, or None when it
    names neither. The detector is the first word found of the most specific signal (bright
    field, then BSE, STEM, SE)."""
    upper = " ".join(str(text or "").upper().split())
    detector = signal = None
    for name, patterns in _BAND_WORDS:
        found = next((m for m in (p.search(upper) for p in patterns) if m), None)
        if found:
            detector, signal = found.group(1), name
            break
    volts = _KV.search(upper)
    kv = float(volts.group(1).replace(",", ".")) if volts else None
    kv = kv if kv is not None and 0.05 <= kv <= 400 else None
    if detector is None and kv is None:
        return None
    return Instrument(None, kv, detector, signal, source)


def with_band_words(instrument: Instrument | None, band: Instrument | None) -> Instrument | None:
    """The file's facts, completed by what its data band says (`band`): the band's detector and
    signal when the file names no signal, its voltage when the file has none."""
    if band is None:
        return instrument
    if instrument is None:
        return band
    if instrument.signal is not None:
        return instrument
    return dataclasses.replace(instrument, detector=band.detector or instrument.detector, signal=band.signal,
                               kv=instrument.kv or band.kv, source=f"{instrument.source}; detector from {band.source}")


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
