"""An eBraille 1.0 conformance checker for the tests, written from the rules the DAISY checker
(daisy/ebraille-checker: its EBR-* messages and feature files) and the eBraille 1.0 specification
list, not from our writer. `check(files, name)` returns [(rule, message)] for a package given as
{path in the zip: bytes} (in zip order) and its file name; [] means it conforms.

Rules (the DAISY checker's ids; OCF-* for the container rules EPUB's own checks cover):
- EBR-001 the packaged file's extension is .ebrl
- OCF-MIMETYPE `mimetype` is the first entry, stored (not compressed), and says application/epub+zip
- OCF-CONTAINER META-INF/container.xml names a rootfile that is in the zip
- EBR-003 / EBR-004 the package document is at the publication root / is named package.opf
- EBR-005 / EBR-006 the navigation document is at the root / is named index.html
- EBR-007 / EBR-008 required metadata elements present / dc:format not repeated
  (dc:creator, dc:date, dc:format, dc:identifier, dc:language, dc:title)
- EBR-009 / EBR-010 required metadata properties present / the single-valued ones not repeated
  (dcterms:modified, dcterms:dateCopyrighted, a11y:brailleCellType, a11y:brailleSystem,
  a11y:completeTranscription, a11y:producer, a11y:tactileGraphics)
- EBR-012 dc:format is "eBraille 1.0"; EBR-014 dc:language has the script subtag Brai;
  EBR-015 dcterms:dateCopyrighted is YYYY, YYYY-MM or YYYY-MM-DD; EBR-016 brailleCellType is 6, 8,
  "6, 8" or "8, 6"; EBR-017 completeTranscription is true or false; EBR-018 tactileGraphics is
  "none" or a comma list of PNG, SVG, PDF, JPG
- EBR-020 no legacy features (NCX, guide, OPF 2 meta name/content); EBR-021 no collections;
  EBR-022 no manifest fallbacks; EBR-070 / EBR-072 no fixed layout (pre-paginated, orientation, spread)
- RSC-006 no remote resources (http:, https: or // in src, href, data, xlink:href, CSS url())
- MANIFEST every file in the zip (but mimetype and META-INF) is in the manifest and every item is in the zip
- EBR-030 the text of content documents (and the nav document), and their user-facing attributes
  (title, alt, aria-label, aria-description, aria-roledescription, aria-placeholder), are braille
  (U+2800-U+28FF) and white space only
- EBR-040 no scripting (script elements, on* event attributes); EBR-041 no forms (form, formaction)
- EBR-050 no -epub- prefixed CSS properties; EBR-051 no properties that set the text's font;
  EBR-052 lengths in font-relative units only (em, rem, ex, ch, cap, ic, lh, rlh; 0 needs none),
  in style sheets and style attributes alike
"""

from __future__ import annotations

import io
import re
import xml.etree.ElementTree as ET
import zipfile
from posixpath import basename, dirname, join, normpath

OPF = "{http://www.idpf.org/2007/opf}"
DC = "{http://purl.org/dc/elements/1.1/}"
XHTML = "{http://www.w3.org/1999/xhtml}"
CONTAINER_NS = "{urn:oasis:names:tc:opendocument:xmlns:container}"

REQUIRED_ELEMENTS = {"creator": True, "date": True, "format": False, "identifier": True, "language": True, "title": True}  # name: may repeat
REQUIRED_PROPERTIES = {"dcterms:modified": False, "dcterms:dateCopyrighted": True, "a11y:brailleCellType": False,
                       "a11y:brailleSystem": True, "a11y:completeTranscription": False, "a11y:producer": True,
                       "a11y:tactileGraphics": False}
ALLOWED_CHARS = set(chr(c) for c in range(0x2800, 0x2900)) | {"\t", "\n", "\r", " ", "\u00a0", "\u00ad"}
USER_ATTRIBUTES = ("title", "alt", "aria-label", "aria-description", "aria-roledescription", "aria-placeholder")
FONT_PROPERTIES = ("font", "font-family", "font-size", "font-style", "font-weight", "font-variant", "font-stretch",
                   "font-feature-settings", "font-kerning", "font-size-adjust", "font-synthesis", "line-height",
                   "letter-spacing", "word-spacing", "text-transform")
FONT_RELATIVE = ("em", "rem", "ex", "rex", "ch", "rch", "cap", "rcap", "ic", "ric", "lh", "rlh")
LENGTH = re.compile(r"(?<![\w#.-])(-?\d*\.?\d+)([a-zA-Z]+)\b")
REMOTE = re.compile(r"^\s*(https?:|//)", re.I)


def read_zip(data: bytes) -> tuple[dict[str, bytes], list[zipfile.ZipInfo]]:
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        infos = archive.infolist()
        return {i.filename: archive.read(i) for i in infos}, infos


def check_bytes(data: bytes, name: str) -> list[tuple[str, str]]:
    files, infos = read_zip(data)
    problems = []
    first = infos[0] if infos else None
    if first is None or first.filename != "mimetype" or first.compress_type != zipfile.ZIP_STORED or first.extra:
        problems.append(("OCF-MIMETYPE", "mimetype must be the first entry, stored, with no extra field"))
    return problems + check(files, name)


def _css_problems(css: str, where: str) -> list[tuple[str, str]]:
    out = []
    css = re.sub(r"/\*.*?\*/", "", css, flags=re.S)
    for prop, value in re.findall(r"([-\w]+)\s*:\s*([^;{}]+)", css):
        prop = prop.strip().lower()
        if prop.startswith("-epub-"):
            out.append(("EBR-050", f"{where}: {prop}"))
        if prop in FONT_PROPERTIES:
            out.append(("EBR-051", f"{where}: {prop}"))
        for number, unit in LENGTH.findall(value):
            if unit.lower() not in FONT_RELATIVE and unit.lower() not in ("s", "ms", "deg", "turn", "rad", "dpi", "x"):
                out.append(("EBR-052", f"{where}: {prop}: {number}{unit}"))
        if re.search(r"url\(\s*['\"]?\s*(https?:|//)", value, re.I):
            out.append(("RSC-006", f"{where}: remote url() in {prop}"))
    return out


def _text_problems(root: ET.Element, where: str) -> list[tuple[str, str]]:
    out = []
    head = root.find(f"{XHTML}head")
    skip = {id(e) for e in (head.iter() if head is not None else ()) if e.tag in (f"{XHTML}style", f"{XHTML}meta", f"{XHTML}link")}
    for element in root.iter():
        texts = []
        if id(element) not in skip and not element.tag.endswith(("}style", "}script")):  # code, not text
            texts += [element.text or ""]
        texts += [element.tail or ""]
        texts += [element.attrib.get(a, "") for a in USER_ATTRIBUTES]
        for text in texts:
            bad = sorted({ch for ch in text if ch not in ALLOWED_CHARS})
            if bad:
                out.append(("EBR-030", f"{where}: {''.join(bad)[:15]!r} in <{element.tag.split('}')[-1]}>"))
    return out


def _content_problems(root: ET.Element, where: str) -> list[tuple[str, str]]:
    out = _text_problems(root, where)
    for element in root.iter():
        tag = element.tag.split("}")[-1]
        if tag == "script":
            out.append(("EBR-040", f"{where}: <script>"))
        if any(a.lower().startswith("on") for a in element.attrib):
            out.append(("EBR-040", f"{where}: event attribute on <{tag}>"))
        if tag == "form" or "formaction" in element.attrib:
            out.append(("EBR-041", f"{where}: a form"))
        if tag == "style":
            out += _css_problems(element.text or "", f"{where} <style>")
        if "style" in element.attrib:
            out += _css_problems(element.attrib["style"], f"{where} style attribute")
        for attr in ("src", "href", "data", "{http://www.w3.org/1999/xlink}href", "poster"):
            if REMOTE.match(element.attrib.get(attr, "")):
                out.append(("RSC-006", f"{where}: remote {attr} on <{tag}>"))
    return out


def check(files: dict[str, bytes], name: str) -> list[tuple[str, str]]:
    problems = []
    if not name.endswith(".ebrl"):
        problems.append(("EBR-001", f"{name}: the extension must be .ebrl"))
    if files.get("mimetype", b"").strip() != b"application/epub+zip":
        problems.append(("OCF-MIMETYPE", "mimetype must say application/epub+zip"))
    try:
        container = ET.fromstring(files["META-INF/container.xml"])
        rootfile = container.find(f"{CONTAINER_NS}rootfiles/{CONTAINER_NS}rootfile").attrib["full-path"]
    except (KeyError, AttributeError, ET.ParseError):
        return problems + [("OCF-CONTAINER", "META-INF/container.xml is missing or names no rootfile")]
    if rootfile not in files:
        return problems + [("OCF-CONTAINER", f"the rootfile {rootfile} is not in the zip")]
    if dirname(rootfile):
        problems.append(("EBR-003", f"{rootfile}: the package document must be at the publication root"))
    if basename(rootfile) != "package.opf":
        problems.append(("EBR-004", f"{rootfile}: the package document must be named package.opf"))
    opf = ET.fromstring(files[rootfile])
    base = dirname(rootfile)
    metadata = opf.find(f"{OPF}metadata")
    manifest = opf.find(f"{OPF}manifest")
    spine = opf.find(f"{OPF}spine")
    metas = metadata.findall(f"{OPF}meta") if metadata is not None else []
    for element, may_repeat in REQUIRED_ELEMENTS.items():
        found = metadata.findall(f"{DC}{element}") if metadata is not None else []
        if not found:
            problems.append(("EBR-007", f"dc:{element} is missing"))
        elif not may_repeat and len(found) > 1:
            problems.append(("EBR-008", f"dc:{element} is declared {len(found)} times"))
    values: dict[str, list[str]] = {}
    for meta in metas:
        if "property" in meta.attrib and "refines" not in meta.attrib:
            values.setdefault(meta.attrib["property"], []).append((meta.text or "").strip())
        if "name" in meta.attrib and "content" in meta.attrib:
            problems.append(("EBR-020", "OPF 2 meta (name/content) is a legacy feature"))
        if meta.attrib.get("property") == "rendition:layout" and (meta.text or "").strip() == "pre-paginated":
            problems.append(("EBR-070", "fixed layout (pre-paginated) is not allowed"))
        if meta.attrib.get("property") in ("rendition:orientation", "rendition:spread"):
            problems.append(("EBR-072", f"{meta.attrib['property']} is not allowed"))
    for prop, may_repeat in REQUIRED_PROPERTIES.items():
        found = values.get(prop, [])
        if not found:
            problems.append(("EBR-009", f"{prop} is missing"))
        elif not may_repeat and len(found) > 1:
            problems.append(("EBR-010", f"{prop} is declared {len(found)} times"))
    fmt = [(e.text or "").strip() for e in metadata.findall(f"{DC}format")] if metadata is not None else []
    if fmt and fmt[0] != "eBraille 1.0":
        problems.append(("EBR-012", f"dc:format is {fmt[0]!r}"))
    for language in (metadata.findall(f"{DC}language") if metadata is not None else []):
        subtags = (language.text or "").strip().split("-")
        if not any(s.lower() == "brai" and i > 0 and len(s) == 4 for i, s in enumerate(subtags)):
            problems.append(("EBR-014", f"dc:language {language.text!r} has no Brai script subtag"))
    checks = {
        "dcterms:dateCopyrighted": ("EBR-015", lambda v: re.fullmatch(r"\d{4}(-(0[1-9]|1[0-2])(-(0[1-9]|[12]\d|3[01]))?)?", v)),
        "a11y:brailleCellType": ("EBR-016", lambda v: re.fullmatch(r"6|8|6\s*,\s*8|8\s*,\s*6", v)),
        "a11y:completeTranscription": ("EBR-017", lambda v: v in ("true", "false")),
        "a11y:tactileGraphics": ("EBR-018", lambda v: v == "none" or all(s.strip() in ("PNG", "SVG", "PDF", "JPG") for s in v.split(","))),
    }
    for prop, (rule, ok) in checks.items():
        for value in values.get(prop, [])[:1]:
            if not ok(value):
                problems.append((rule, f"{prop} is {value!r}"))
    if spine is not None and "toc" in spine.attrib or opf.find(f"{OPF}guide") is not None:
        problems.append(("EBR-020", "NCX or guide is a legacy feature"))
    if opf.find(f"{OPF}collection") is not None:
        problems.append(("EBR-021", "collections are not supported"))
    items = manifest.findall(f"{OPF}item") if manifest is not None else []
    if any("fallback" in item.attrib for item in items):
        problems.append(("EBR-022", "manifest fallbacks are not supported"))
    if any(item.attrib.get("media-type") == "application/x-dtbncx+xml" for item in items):
        problems.append(("EBR-020", "an NCX is a legacy feature"))
    paths = {}
    for item in items:
        href = item.attrib.get("href", "")
        if REMOTE.match(href):
            problems.append(("RSC-006", f"remote manifest item {href}"))
            continue
        paths[normpath(join(base, href))] = item
    nav = [p for p, item in paths.items() if "nav" in item.attrib.get("properties", "").split()]
    if not nav:
        problems.append(("EBR-006", "no navigation document"))
    for path in nav:
        if dirname(path):
            problems.append(("EBR-005", f"{path}: the navigation document must be at the publication root"))
        if basename(path) != "index.html":
            problems.append(("EBR-006", f"{path}: the navigation document must be named index.html"))
    listed = {p for p in files if p != "mimetype" and not p.startswith("META-INF/")} - {rootfile}
    for path in sorted(listed - set(paths)):
        problems.append(("MANIFEST", f"{path} is in the zip but not in the manifest"))
    for path in sorted(set(paths) - set(files)):
        problems.append(("MANIFEST", f"{path} is in the manifest but not in the zip"))
    for path, item in paths.items():
        if path not in files:
            continue
        kind = item.attrib.get("media-type", "")
        if kind == "application/xhtml+xml":
            try:
                root = ET.fromstring(files[path])
            except ET.ParseError as exc:
                problems.append(("XML", f"{path}: {exc}"))
                continue
            problems += _content_problems(root, path)
        elif kind == "text/css":
            problems += _css_problems(files[path].decode("utf-8", "replace"), path)
    return problems


def rules(problems) -> set[str]:
    return {rule for rule, _ in problems}
