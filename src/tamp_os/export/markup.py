"""Text into markup, whatever the text: XML and HTML element text and attributes, and JSON inside an
HTML <script> element. Captions, key labels and file names reach the eBraille package, the touch
tour and 3MF metadata as they were typed or named (issue 51.3: a caption holding `<!--<script>`
made the tour's data script swallow the program script, so the page had no keys and no speech).
"""

from __future__ import annotations

import json


def xml_text(value) -> str:
    """`value` as text XML 1.0 can hold: characters it forbids (control characters other than tab,
    newline and return; lone surrogates; U+FFFE/U+FFFF) become U+FFFD. Not escaped (see escape)."""
    return "".join(ch if ch in "\t\n\r" or ("\x20" <= ch <= "\ud7ff") or ("\ue000" <= ch <= "\ufffd") or ch >= "\U00010000" else "\ufffd" for ch in str(value))


def escape(value) -> str:
    """`value` as XML or HTML element text: &, < and > escaped, forbidden characters replaced
    (xml.sax's escape, without the urllib it imports)."""
    return xml_text(value).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def quoteattr(value) -> str:
    """`value` as a double-quoted XML or HTML attribute value (quotes included): as escape, and
    quotes, tabs and line ends as references, which attribute normalisation would otherwise turn into spaces."""
    text = escape(value).replace('"', "&quot;").replace("\n", "&#10;").replace("\r", "&#13;").replace("\t", "&#9;")
    return f'"{text}"'


# In a <script> element the HTML parser ends the script at "</script", and "<!--" followed by
# "<script" makes it look for two ends; JSON's own \u escapes for <, > and & keep every string
# out of the parser's sight. U+2028 and U+2029 end a line in older JavaScript.
_SCRIPT_ESCAPES = str.maketrans({"<": "\\u003c", ">": "\\u003e", "&": "\\u0026", "\u2028": "\\u2028", "\u2029": "\\u2029"})


def script_json(value) -> str:
    """`value` as JSON that can stand inside an HTML <script> element whatever its strings hold."""
    return xml_text(json.dumps(value, ensure_ascii=False)).translate(_SCRIPT_ESCAPES)  # xml_text: no lone surrogate
