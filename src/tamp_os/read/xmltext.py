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
# Metadata XML nests at most this deep: the fixtures' CZI, LIF and OME-XML nest 9-13 deep. Deeper
# nesting is no microscope's metadata, and a reader that walks it recursively (liffile walks
# nested LIF elements so) fails on it half way with a RecursionError (issue 40.4).
MAX_XML_DEPTH = 200


def xml_depth_over(text: str | bytes, limit: int = MAX_XML_DEPTH) -> bool:
    """Whether `text` nests elements deeper than `limit`: one pass of the expat parser, which stops
    at the first element too deep. Malformed XML is not too deep (its reader says what is wrong)."""
    import xml.parsers.expat

    class TooDeep(Exception):
        pass

    depth = 0

    def start(name, attrs):
        nonlocal depth
        depth += 1
        if depth > limit:
            raise TooDeep

    def end(name):
        nonlocal depth
        depth -= 1

    parser = xml.parsers.expat.ParserCreate()
    parser.StartElementHandler, parser.EndElementHandler = start, end
    try:
        parser.Parse(text, True)
    except TooDeep:
        return True
    except (xml.parsers.expat.ExpatError, ValueError):
        return False
    return False


@functools.lru_cache(maxsize=4)
def parse_xml(text: str) -> ET.Element | None:
    """The root element of `text`, or None when it is not XML we accept (DTD, entities, malformed, huge)."""
    if not isinstance(text, str) or len(text) > MAX_XML_CHARS:
        return None
    if "<!DOCTYPE" in text or "<!ENTITY" in text:
        log.warning("XML metadata with a DTD or entities was ignored (OME-XML has none)")
        return None
    if xml_depth_over(text):
        log.warning("XML metadata nested over %d elements deep was ignored (OME-XML nests about a dozen)", MAX_XML_DEPTH)
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
