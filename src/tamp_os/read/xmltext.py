"""XML from image files (OME-XML), parsed with care: by a parser, in time linear in its length.

A regular expression over XML (`<Channel[^>]*\\sName="…"`) backtracks quadratically on a long
comment or attribute list: a 450 KB OME-TIFF took a minute. The standard library's expat parser
is linear; it is handed only documents without a DTD (OME-XML never has one), so no entity can
expand (the "billion laughs" family) and nothing external is fetched. defusedxml would do the
same; the check below is all of it that this use needs, without a new dependency.
"""

from __future__ import annotations

import functools
import logging
import xml.etree.ElementTree as ET

log = logging.getLogger(__name__)

MAX_XML_CHARS = 64_000_000  # OME-XML of a large plate is a few MB; beyond this it is not metadata


@functools.lru_cache(maxsize=4)
def parse_xml(text: str) -> ET.Element | None:
    """The root element of `text`, or None when it is not XML we accept (DTD, entities, malformed, huge)."""
    if not isinstance(text, str) or len(text) > MAX_XML_CHARS:
        return None
    if "<!DOCTYPE" in text or "<!ENTITY" in text:
        log.warning("XML metadata with a DTD or entities was ignored (OME-XML has none)")
        return None
    try:
        return ET.fromstring(text)
    except (ET.ParseError, ValueError):
        return None


def local_name(tag: str) -> str:
    """'{http://www.openmicroscopy.org/Schemas/OME/2016-06}Channel' -> 'Channel'."""
    return tag.rpartition("}")[2]


def ome_channel_names(text: str) -> list[str]:
    """The Name attribute of every Channel element, in document order ('' when a channel has none)."""
    root = parse_xml(text)
    if root is None:
        return []
    return [el.attrib.get("Name", "") for el in root.iter() if local_name(el.tag) == "Channel" and "Name" in el.attrib]
