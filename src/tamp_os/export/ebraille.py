"""A lithograph as an eBraille 1.0 publication (`NAME.ebrl`, issue 35): an EPUB 3 container whose
text is Unicode braille only, with the tactile graphic inline as SVG.

The zip holds (in this order; `mimetype` first and stored, as OCF requires):

- `mimetype`: `application/epub+zip`;
- `META-INF/container.xml`: points to `package.opf` at the publication root;
- `package.opf`: the package document, with every metadata field eBraille requires (dc:title,
  dc:identifier as a urn:uuid made from the input's SHA-256, dc:language with the `Brai` script
  subtag of the braille table's language, dc:creator, dc:date, dc:format `eBraille 1.0`,
  dcterms:modified, dcterms:dateCopyrighted, a11y:brailleSystem, a11y:brailleCellType,
  a11y:completeTranscription, a11y:producer, a11y:tactileGraphics `SVG, PDF`) and the manifest and
  spine;
- `index.html`: the navigation document (table of contents and page list), in braille;
- `content.html`: title, caption, the tactile graphic (inline SVG: each region a path with
  role="graphics-object", an id and a braille aria-label; the swell-paper PDF beside it through
  `<object>`, with braille text as its fallback), the key, the description and the touch tour
  (an ordered list whose items link to the regions' ids), and the original micrograph;
- `style.css`: a few rules in font-relative units, nothing that sets a font;
- `graphic.pdf`: the same graphic as the PDF for swell paper (export/tactile2d.py);
- `micrograph.png`: the original picture, contrast-stretched to 8 bits.

Every braille string is made by liblouis from its print source (tactile/braille.py); the file is
written through files.write_atomic.
"""

from __future__ import annotations

import datetime as _dt
import io
import uuid
import zipfile
from dataclasses import dataclass
from pathlib import Path
import numpy as np

from .files import write_atomic
from .graphic2d import Graphic2D
from .markup import escape, quoteattr
from .regions import Tour, labelled_svg, plain_svg

MIMETYPE = "application/epub+zip"
FIXED_ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # the same input gives the same bytes
FILES = ("mimetype", "META-INF/container.xml", "package.opf", "index.html", "content.html", "style.css", "graphic.pdf", "micrograph.png")
STYLE = """body { margin: 1em; }
section { margin-bottom: 2em; }
figure { margin: 1em 0; }
ol, ul { padding-left: 2em; }
li { margin-bottom: 0.5em; }
"""


@dataclass(frozen=True)
class Book:
    """What the publication says, in print; every text is put into braille when it is written."""

    title: str
    caption: str | None
    description: str
    key: tuple[tuple[str, str], ...]  # (name, what it is) per key entry, in reading order
    tour: Tour
    braille_table: str
    identifier_seed: str  # the input's SHA-256 (and the output's name): the same input, the same identifier
    producer: str
    source_name: str


def language_tag(table: str) -> str:
    """The braille table's language with the Brai script subtag: en-ueb-g2.ctb -> 'en-Brai'; 'en-US' -> 'en-Brai-US'."""
    from ..tactile.braille_tables import installed_tables

    first = table.split(",")[0].strip()
    found = next((t for t in installed_tables() if t.name == Path(first).name), None)
    language = (found.language if found else "") or first.split("-")[0].split(".")[0] or "und"
    parts = language.replace("_", "-").split("-")
    if not parts[0].isalpha() or not 2 <= len(parts[0]) <= 3:
        parts = ["und"]
    rest = [p for p in parts[1:] if p.lower() != "brai" and len(p) != 4]  # a script subtag already there gives way
    return "-".join([parts[0].lower(), "Brai", *rest])


def braille_system(table: str) -> str:
    """The braille code by name: 'UEB grade2' for en-ueb-g2.ctb, else the table's display name."""
    from ..tactile.braille_tables import installed_tables

    first = Path(table.split(",")[0].strip()).name
    found = next((t for t in installed_tables() if t.name == first), None)
    grade = (found.grade if found else "") or ("1" if "-g1" in first else "2" if "-g2" in first else "")
    if "ueb" in first.lower():
        return f"UEB grade{grade}" if grade else "UEB"
    if found and found.display_name:
        return found.display_name
    return first


class Brailler:
    """Print -> Unicode braille by liblouis, each string once; remembers every pair (for the check
    that back-translation gives the print again)."""

    def __init__(self, table: str):
        self.table = table
        self.pairs: dict[str, str] = {}

    def __call__(self, text: str) -> str:
        from ..tactile.braille import to_braille, unwritable_characters

        # The texts are the tool's own sentences around a file's name, which may hold control and
        # format characters (an escape sequence, a right-to-left override): never meant to be read,
        # so left out rather than refused (the plate refuses them in a caption or a key label).
        unwritable = set(unwritable_characters(text))
        writable = "".join(ch for ch in text if ch not in unwritable) if unwritable else text
        if writable not in self.pairs:
            self.pairs[writable] = to_braille(writable, self.table, what=f"the eBraille text {writable!r}")
        return self.pairs[writable]


def _pagebreak(number: int, br: Brailler) -> str:
    return f'<span epub:type="pagebreak" role="doc-pagebreak" id="page-{number}" aria-label={quoteattr(br(str(number)))}></span>'


def _xhtml(title: str, lang: str, body: str, head_extra: str = "") -> str:
    return ("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!DOCTYPE html>\n"
            f'<html xmlns="http://www.w3.org/1999/xhtml" xmlns:epub="http://www.idpf.org/2007/ops" xml:lang="{lang}" lang="{lang}">\n'
            f'<head>\n<meta charset="utf-8"/>\n<title>{escape(title)}</title>\n{head_extra}</head>\n<body>\n{body}\n</body>\n</html>\n')


SECTIONS = (("s-title", "title"), ("s-graphic", "tactile graphic"), ("s-key", "key"), ("s-description", "description"),
            ("s-tour", "touch tour"), ("s-micrograph", "original micrograph"))


def content_document(book: Book, graphic: Graphic2D, br: Brailler, *, lang: str) -> str:
    tour = book.tour
    svg = labelled_svg(plain_svg(graphic, book.title), tour, label_of=lambda r: br(r.label), title=br(book.title), touch_attrs=False,
                       document_role=False)
    svg = svg[svg.index("<svg"):]
    heading = dict(SECTIONS)
    parts = [f'<section id="s-title" aria-labelledby="h-title">{_pagebreak(1, br)}\n<h1 id="h-title">{escape(br(book.title))}</h1>']
    if book.caption:
        parts.append(f"<p>{escape(br(book.caption))}</p>")
    parts.append("</section>")
    parts.append(f'<section id="s-graphic" aria-labelledby="h-graphic">{_pagebreak(2, br)}\n<h2 id="h-graphic">{escape(br(heading["s-graphic"]))}</h2>')
    parts.append(f"<figure>\n{svg}\n<figcaption>{escape(br(book.caption or book.title))}</figcaption>\n</figure>")
    parts.append(f'<p><object data="graphic.pdf" type="application/pdf">{escape(br("The same tactile graphic for swell paper, as PDF."))}</object></p>')
    parts.append("</section>")
    parts.append(f'<section id="s-key" aria-labelledby="h-key">{_pagebreak(3, br)}\n<h2 id="h-key">{escape(br(heading["s-key"]))}</h2>\n<ul>')
    parts += [f"<li>{escape(br(f'{name}: {what}'))}</li>" for name, what in book.key]
    parts.append("</ul>\n</section>")
    parts.append(f'<section id="s-description" aria-labelledby="h-description">\n<h2 id="h-description">{escape(br(heading["s-description"]))}</h2>')
    parts.append(f"<p>{escape(br(book.description))}</p>\n</section>")
    parts.append(f'<section id="s-tour" aria-labelledby="h-tour">{_pagebreak(4, br)}\n<h2 id="h-tour">{escape(br(heading["s-tour"]))}</h2>')
    parts.append(f"<p>{escape(br(tour.intro))}</p>\n<ol>")
    for region in tour.regions:
        parts.append(f'<li><a href="#{region.id}">{escape(br(region.label))}</a>\u2800{escape(br(region.description))}</li>')
    parts.append("</ol>\n</section>")
    parts.append(f'<section id="s-micrograph" aria-labelledby="h-micrograph">\n<h2 id="h-micrograph">{escape(br(heading["s-micrograph"]))}</h2>')
    alt = br(f"The original micrograph, {book.source_name}, as a picture.")
    parts.append(f"<p><img src=\"micrograph.png\" alt={quoteattr(alt)}/></p>\n</section>")
    head = '<link rel="stylesheet" type="text/css" href="style.css"/>\n'
    return _xhtml(br(book.title), lang, "\n".join(parts), head)


def navigation_document(book: Book, br: Brailler, lang: str) -> str:
    toc = "\n".join(f'<li><a href="content.html#{sid}">{escape(br(name))}</a></li>' for sid, name in SECTIONS)
    pages = "\n".join(f'<li><a href="content.html#page-{n}">{escape(br(str(n)))}</a></li>' for n in range(1, 5))
    body = (f'<nav epub:type="toc" role="doc-toc" id="toc">\n<h1>{escape(br("contents"))}</h1>\n<ol>\n{toc}\n</ol>\n</nav>\n'
            f'<nav epub:type="page-list" role="doc-pagelist" id="page-list">\n<h2>{escape(br("pages"))}</h2>\n<ol>\n{pages}\n</ol>\n</nav>')
    return _xhtml(br(book.title), lang, body, '<link rel="publication" href="package.opf" type="application/oebps-package+xml"/>\n')


def cell_type(texts) -> str:
    """'8' when any cell raises dot 7 or 8, else '6'."""
    return "8" if any(ord(ch) >= 0x2840 for text in texts for ch in text if "\u2800" <= ch <= "\u28ff") else "6"


def package_document(book: Book, lang: str, today: _dt.date, *, cells: str) -> str:
    identifier = f"urn:uuid:{uuid.uuid5(uuid.NAMESPACE_URL, 'tamp-os:' + book.identifier_seed)}"
    day = today.isoformat()
    source = f"urn:tamp-os:{book.identifier_seed}"
    meta = [
        f"<dc:identifier id=\"uid\">{identifier}</dc:identifier>",
        f"<dc:title>{escape(book.title)}</dc:title>",
        f"<dc:language>{lang}</dc:language>",
        "<dc:creator>TAMP-OS</dc:creator>",
        f"<dc:date>{day}</dc:date>",
        "<dc:format>eBraille 1.0</dc:format>",
        f"<dc:description>{escape(book.description)}</dc:description>",
        f"<dc:source id=\"src\">{escape(source)}</dc:source>",
        f"<meta property=\"dcterms:modified\">{day}T00:00:00Z</meta>",
        f"<meta property=\"dcterms:dateCopyrighted\">{today.year}</meta>",
        f"<meta property=\"a11y:brailleSystem\">{escape(braille_system(book.braille_table))}</meta>",
        f"<meta property=\"a11y:brailleCellType\">{cells}</meta>",
        "<meta property=\"a11y:completeTranscription\">true</meta>",
        f"<meta property=\"a11y:producer\">{escape(book.producer)}</meta>",
        "<meta property=\"a11y:tactileGraphics\">SVG, PDF</meta>",
        "<meta property=\"schema:accessMode\">tactile</meta>",
        "<meta property=\"schema:accessModeSufficient\">tactile</meta>",
        "<meta property=\"schema:accessibilityFeature\">braille</meta>",
        "<meta property=\"schema:accessibilityFeature\">tactileGraphic</meta>",
        "<meta property=\"schema:accessibilityFeature\">tableOfContents</meta>",
        "<meta property=\"schema:accessibilityHazard\">none</meta>",
        f"<meta property=\"schema:accessibilitySummary\">{escape('Braille text and a tactile graphic with a touch tour of its regions.')}</meta>",
    ]
    manifest = [
        '<item id="nav" href="index.html" media-type="application/xhtml+xml" properties="nav"/>',
        '<item id="content" href="content.html" media-type="application/xhtml+xml" properties="svg"/>',
        '<item id="style" href="style.css" media-type="text/css"/>',
        '<item id="graphic-pdf" href="graphic.pdf" media-type="application/pdf"/>',
        '<item id="micrograph" href="micrograph.png" media-type="image/png"/>',
    ]
    return ("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
            '<package xmlns="http://www.idpf.org/2007/opf" version="3.0" xml:lang="en" unique-identifier="uid">\n'
            '<metadata xmlns:dc="http://purl.org/dc/elements/1.1/">\n' + "\n".join(meta) + "\n</metadata>\n"
            "<manifest>\n" + "\n".join(manifest) + "\n</manifest>\n"
            '<spine>\n<itemref idref="nav"/>\n<itemref idref="content"/>\n</spine>\n</package>\n')


CONTAINER = ("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
             '<container version="1.0" xmlns="urn:oasis:names:tc:opendocument:xmlns:container">\n'
             '<rootfiles>\n<rootfile full-path="package.opf" media-type="application/oebps-package+xml"/>\n</rootfiles>\n</container>\n')


def micrograph_png(values: np.ndarray) -> bytes:
    """The picture as an 8-bit grey PNG, stretched from its 1st to 99th percentile."""
    from PIL import Image

    values = np.asarray(values, np.float64)
    finite = values[np.isfinite(values)]
    lo, hi = (np.percentile(finite, [1, 99]) if finite.size else (0.0, 1.0))
    grey = np.clip((np.nan_to_num(values, nan=lo) - lo) / ((hi - lo) or 1.0), 0, 1)
    buffer = io.BytesIO()
    Image.fromarray((grey * 255).round().astype(np.uint8)).save(buffer, format="PNG")
    return buffer.getvalue()


def package_files(book: Book, graphic: Graphic2D, picture: np.ndarray, *, today: _dt.date | None = None,
                  page_size: str | None = None) -> tuple[dict[str, bytes], dict[str, str]]:
    """Every file of the publication by its path, in zip order, and the braille made for it ({print: braille})."""
    from .tactile2d import write_pdf

    today = today or _dt.date.today()
    br = Brailler(book.braille_table)
    lang = language_tag(book.braille_table)
    content = content_document(book, graphic, br, lang=lang)
    nav = navigation_document(book, br, lang)
    pdf = io.BytesIO()
    write_pdf(graphic, pdf, page_size, metadata={"title": book.title, "description": book.description})
    files = {
        "mimetype": MIMETYPE.encode("ascii"),
        "META-INF/container.xml": CONTAINER.encode("utf-8"),
        "package.opf": package_document(book, lang, today, cells=cell_type(br.pairs.values())).encode("utf-8"),
        "index.html": nav.encode("utf-8"),
        "content.html": content.encode("utf-8"),
        "style.css": STYLE.encode("utf-8"),
        "graphic.pdf": pdf.getvalue(),
        "micrograph.png": micrograph_png(picture),
    }
    return files, dict(br.pairs)


def zip_bytes(files: dict[str, bytes]) -> bytes:
    """The OCF zip: `mimetype` first, stored and without extra fields; the rest deflated; fixed times."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name, data in files.items():
            info = zipfile.ZipInfo(name, date_time=FIXED_ZIP_TIME)
            info.compress_type = zipfile.ZIP_STORED if name == "mimetype" else zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            archive.writestr(info, data)
    return buffer.getvalue()


def write_ebraille(path, book: Book, graphic: Graphic2D, *, picture: np.ndarray, today: _dt.date | None = None) -> Path:
    """Write the publication to `path` (NAME.ebrl) atomically."""
    files, _ = package_files(book, graphic, picture, today=today)
    data = zip_bytes(files)
    return write_atomic(Path(path), lambda fh: fh.write(data))


KEY_WORDS = {"members": ("domes", "the members of the population, each raised as a dome"),
             "dots": ("dots", "small raised dots"),
             "lines": ("raised lines", "the picture's lines, raised"),
             "areas": ("raised areas", "areas raised as flat plateaus")}
ENCODING_WORDS = {"domes": "raised as domes", "dots": "raised as dots", "ridges": "raised as ridges", "plateau": "raised as a plateau"}


def key_entries(litho, tour: Tour) -> tuple[tuple[str, str], ...]:
    """The key in reading order: a channel print's own entries, else what kinds of region the picture has; then the furniture."""
    out = []
    if getattr(litho.report, "key", None):
        out += [(entry.label, ENCODING_WORDS.get(entry.encoding, entry.encoding)) for entry in litho.report.key]
    else:
        kinds = []
        for region in tour.regions:
            if region.kind in KEY_WORDS and region.kind not in kinds:
                kinds.append(region.kind)
        out += [KEY_WORDS[k] for k in kinds]
    ids = {r.id for r in tour.regions}
    if "scale-bar" in ids:
        bar = next(r for r in tour.regions if r.id == "scale-bar")
        out.append(("scale bar", bar.description))
    if "corner" in ids:
        out.append(("cut corner", "at the top right of the plate; hold the plate with it there"))
    return tuple(out)


def book_from_lithograph(litho, tour: Tour, description: str) -> Book:
    from ..version import __version__

    return Book(tour.title, litho.params.caption, description, key_entries(litho, tour), tour, litho.params.braille_table,
                f"{litho.picture.file.sha256}:{litho.name}", f"TAMP-OS {__version__}", litho.picture.file.name)
