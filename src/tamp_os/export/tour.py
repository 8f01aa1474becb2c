"""The touch tour (`NAME.tour.html`, issue 35): one self-contained page that shows the tactile
graphic at the plate's true size and says what each region is when it is touched.

- No network: the SVG, the style and the script are all inside the page, so it works from a file.
- The SVG is the 2-D graphic (export/tactile2d.py) with its regions (export/regions.py) on top,
  each a path with role="graphics-object", an id and its print label; the plate is drawn in CSS
  millimetres at its own size, so at zoom 1 the page lies under or beside the printed plate.
- Touching or clicking a region focuses it and announces its label and description in an
  aria-live region, and speaks them with the Web Speech API where the browser has it.
- Keyboard: the regions are one tab stop (a roving tabindex); the arrow keys step through them in
  the tour's reading order (the cut corner first), Home and End go to the first and last, Enter or
  Space says the details; the tour is also an ordered list of buttons below the graphic.

Written through files.write_atomic.
"""

from __future__ import annotations

from pathlib import Path

from .files import write_atomic
from .graphic2d import Graphic2D
from .markup import escape, quoteattr, script_json
from .regions import Tour, labelled_svg, plain_svg

STYLE = """
:root { color-scheme: light; }
body { font-family: system-ui, sans-serif; margin: 0; padding: 1rem; color: #111; background: #fff; line-height: 1.4; }
h1 { font-size: 1.4rem; margin: 0 0 0.5rem; }
#plate { display: inline-block; border: 1px solid #555; background: #fff; }
#plate svg { display: block; }
#plate svg:focus-within { outline: none; }
#regions path { cursor: pointer; }
#regions path:focus { outline: none; stroke: #0050d0; stroke-width: 0.8; stroke-opacity: 1; fill: #0050d0; fill-opacity: 0.18; }
#announce { min-height: 3em; font-size: 1.15rem; padding: 0.5rem; border: 2px solid #0050d0; margin: 0.75rem 0; max-width: 60rem; }
#tour-list button { font: inherit; text-align: left; background: #f2f2f2; color: #111; border: 1px solid #555; padding: 0.25rem 0.5rem; margin: 0.1rem 0; cursor: pointer; }
#tour-list button:focus { outline: 3px solid #0050d0; }
.hint { max-width: 60rem; }
"""

SCRIPT = """
(function () {
  var order = JSON.parse(document.getElementById('tour-data').textContent);
  var live = document.getElementById('announce');
  var index = 0;
  function byId(id) { return document.getElementById(id); }
  function say(text) {
    live.textContent = text;
    if ('speechSynthesis' in window && window.SpeechSynthesisUtterance) {
      try { window.speechSynthesis.cancel(); window.speechSynthesis.speak(new SpeechSynthesisUtterance(text)); } catch (e) {}
    }
  }
  function region(i) { return byId(order[i].id); }
  function move(i, details) {
    if (i < 0 || i >= order.length) { return; }
    region(index).setAttribute('tabindex', '-1');
    index = i;
    var el = region(index);
    el.setAttribute('tabindex', '0');
    el.focus();
    say(details ? order[index].label + '. ' + order[index].description : order[index].label);
  }
  order.forEach(function (item, i) {
    var el = byId(item.id);
    el.setAttribute('tabindex', i === 0 ? '0' : '-1');
    el.addEventListener('click', function () { move(i, true); });
  });
  document.getElementById('regions').addEventListener('keydown', function (event) {
    var key = event.key;
    if (key === 'ArrowRight' || key === 'ArrowDown') { move(index + 1, false); }
    else if (key === 'ArrowLeft' || key === 'ArrowUp') { move(index - 1, false); }
    else if (key === 'Home') { move(0, false); }
    else if (key === 'End') { move(order.length - 1, false); }
    else if (key === 'Enter' || key === ' ') { move(index, true); }
    else { return; }
    event.preventDefault();
  });
  Array.prototype.forEach.call(document.querySelectorAll('#tour-list button'), function (button) {
    button.addEventListener('click', function () { move(Number(button.getAttribute('data-index')), true); });
  });
})();
"""


def tour_page(tour: Tour, graphic: Graphic2D, lang: str = "en") -> str:
    """The page's HTML: the plate at true size with its labelled regions, the live region, the tour list."""
    svg = labelled_svg(plain_svg(graphic, tour.title), tour)
    svg = svg[svg.index("<svg"):]
    w, d = tour.plate_mm
    data = script_json([{"id": r.id, "label": r.label, "description": r.description} for r in tour.regions])
    items = "\n".join(f'<li><button type="button" data-index="{i}" aria-describedby="announce">{escape(r.label)}</button> '
                      f"{escape(r.description)}</li>" for i, r in enumerate(tour.regions))
    return f"""<!DOCTYPE html>
<html lang={quoteattr(lang)}>
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta http-equiv="Content-Security-Policy" content="default-src 'none'; style-src 'unsafe-inline'; script-src 'unsafe-inline'; img-src data:">
<title>{escape("Touch tour: " + tour.title)}</title>
<style>{STYLE}</style>
</head>
<body>
<main>
<h1>{escape("Touch tour: " + tour.title)}</h1>
<p class="hint">{escape(tour.intro)} Lay the tablet beside or under the plate at zoom 100 % (the plate is drawn
{w:g} by {d:g} mm). Touch or click a region to hear what it is; or move into the graphic with Tab, step through the
regions with the arrow keys, and press Enter for the details.</p>
<div id="plate">
{svg}
</div>
<p id="announce" role="status" aria-live="polite" aria-atomic="true"></p>
<h2>The tour, in order</h2>
<ol id="tour-list">
{items}
</ol>
</main>
<script type="application/json" id="tour-data">{data}</script>
<script>{SCRIPT}</script>
</body>
</html>
"""


def write_tour(path, tour: Tour, graphic: Graphic2D, *, lang: str = "en") -> Path:
    text = tour_page(tour, graphic, lang)
    return write_atomic(Path(path), lambda fh: fh.write(text.encode("utf-8")))


DOCUMENT_SUFFIXES = {"ebraille": ".ebrl", "tour": ".tour.html"}


def build_documents(litho, graphic: Graphic2D, formats, *, stem: str, description: str) -> dict[str, bytes]:
    """The eBraille package and/or the touch tour of a lithograph whose 2-D graphic is `graphic`,
    by file name, made before any file of the set is written: a text braille cannot write refuses
    the whole set, never leaves half of it."""
    from .ebraille import book_from_lithograph, package_files, zip_bytes
    from .regions import tour_from_lithograph

    tour = tour_from_lithograph(litho, graphic)
    built = {}
    for fmt in formats:
        name = f"{stem}{DOCUMENT_SUFFIXES[fmt]}"
        if fmt == "ebraille":
            files, _ = package_files(book_from_lithograph(litho, tour, description), graphic, litho.picture.values)
            built[name] = zip_bytes(files)
        elif fmt == "tour":
            built[name] = tour_page(tour, graphic).encode("utf-8")
    return built


def write_documents(folder: Path, built: dict[str, bytes]) -> list[Path]:
    """Write what build_documents made into `folder`, each file atomically."""
    return [write_atomic(Path(folder) / name, lambda fh, data=data: fh.write(data)) for name, data in built.items()]

