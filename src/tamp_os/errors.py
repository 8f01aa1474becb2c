"""The few error types TAMP-OS raises, and `Text`, the one way a message names a parameter.

Each message names the file or parameter, the allowed range, the value received and what to do.
A library message writes a parameter's name between backticks (`pixel_size`); `str()` gives it as
the library says it (pixel_size), and `words(namer)` as a front end says it (its option on the
command line, the field's label in the web app). That is template filling, not rewriting:
nothing but a backticked parameter name is ever replaced.
"""

from __future__ import annotations

import re
from typing import Any, Callable

Namer = Callable[[str], "str | None"]  # a parameter's name -> a front end's word for it (None: keep it)


_PARAMETER_NAMES: set[str] = set()  # filled by params.py when LithoParams is defined (errors imports nothing)


def register_parameter_names(names) -> None:
    """Tell message templates which words are parameters (params.py does, once)."""
    _PARAMETER_NAMES.update(names)


def _known_names() -> set[str]:
    return _PARAMETER_NAMES


OPTIONAL = re.compile("⟦(.*?)⟧", re.S)  # a clause of advice a front end without its controls leaves out


def render(template: str, namer: Namer | None = None, offers: Callable[[str], bool] | None = None) -> str:
    """Fill a message template: each `name` of a parameter becomes namer(name) (or the name itself).

    Backticks around anything else (a user's own text) are kept as they were. A clause between ⟦ and
    ⟧ is advice that names controls: kept (without the brackets), unless `offers` says the front end
    has no control for one of the parameters it names; then the clause is left out."""
    if "⟦" in template:
        def clause(m: re.Match) -> str:
            return "" if offers is not None and not all(offers(n) for n in names_in(m.group(1))) else m.group(1)

        template = OPTIONAL.sub(clause, template)
    if "`" not in template:
        return template
    pieces = template.split("`")
    if len(pieces) % 2 == 0:  # an unpaired backtick: the text is not a template
        return template
    known = _known_names()
    out = []
    for i, piece in enumerate(pieces):
        if i % 2 == 0:
            out.append(piece)
        elif piece in known:
            out.append((namer(piece) if namer else None) or piece)
        else:
            out.append(f"`{piece}`")
    return "".join(out)


class Text(str):
    """A sentence that may name parameters: reads as the library says it, and `words(namer)` says
    it in a front end's words. Stored and serialised as the library's text."""

    template: str

    def __new__(cls, template: str):
        if isinstance(template, Text) and type(template) is cls:
            return template
        template = getattr(template, "template", template)
        self = super().__new__(cls, render(str(template)))
        self.template = str(template)
        return self

    def words(self, namer: Namer | None = None, offers: Callable[[str], bool] | None = None) -> str:
        return render(self.template, namer, offers)

    def __reduce__(self):  # pickles (batch workers) and copies keep the template (and the kind)
        return (type(self), (self.template,))

    def __deepcopy__(self, memo):
        return self


class Decision(Text):
    """A choice the tool made for the user, said for the record (the description, the report and
    the verbose output): not a warning, which is for what the user must act on (issue 33.9)."""


def is_decision(message: Any) -> bool:
    return isinstance(message, Decision)


def words(message: Any, namer: Namer | None = None, offers: Callable[[str], bool] | None = None) -> str:
    """Any message (an error, a Text, a plain string) in a front end's words; `offers`: whether the
    front end has a control for a parameter (advice naming one it lacks is left out)."""
    if isinstance(message, TampError):
        return message.words(namer)
    if isinstance(message, Text):
        return message.words(namer, offers)
    return render(str(message), namer, offers)


# A message quotes what the user gave to show what was received, not to repeat it: a 100,000-character
# `key_labels` made an error line of 100,078 characters (issue 51.7). Every error's text passes
# through shorten_values, so no message needs to cut its own values.
QUOTED_MAX_CHARS = 80  # a quoted value longer than this is cut to its first QUOTED_KEEP_CHARS
QUOTED_KEEP_CHARS = 60
BARE_MAX_CHARS = 300  # a run without spaces longer than this (a value said bare); paths are shorter
BARE_TAIL_CHARS = 20  # of a bare run its end is kept too: a path's end is its file name
# A Python repr of a string: its quote, never the same quote inside (repr escapes or switches it),
# and not an apostrophe in a word (the picture's, don't).
_QUOTED = re.compile(r"(?<!\w)(['\"])((?:\\.|(?!\1)[^\\\n]){%d,})\1(?!\w)" % (QUOTED_MAX_CHARS + 1))
_BARE = re.compile(r"\S{%d,}" % (BARE_MAX_CHARS + 1))


def shorten_values(text: str) -> str:
    """`text` with every long quoted value cut to a prefix that identifies it and its length
    ('DAPI=nuclei,GFP=…' (100,000 characters)), and every long run without spaces cut in its middle."""
    if len(text) <= QUOTED_MAX_CHARS:
        return text

    def quoted(m: re.Match) -> str:
        quote, inner = m.group(1), m.group(2)
        return f"{quote}{inner[:QUOTED_KEEP_CHARS]}…{quote} ({len(inner):,} characters)"

    def bare(m: re.Match) -> str:
        run = m.group(0)
        return f"{run[:QUOTED_KEEP_CHARS]}…{run[-BARE_TAIL_CHARS:]} ({len(run):,} characters)"

    return _BARE.sub(bare, _QUOTED.sub(quoted, text))


def file_words(message: Any) -> str:
    """A message as a file says it (a print's description, inside its 3MF, PDF and eBraille too):
    whoever reads the file has no controls, so advice that names one (a ⟦…⟧ clause) is left out,
    and the files are the same whichever front end made them; each front end says that advice
    beside them in its own words."""
    return words(message, None, lambda name: False)


class TampError(Exception):
    """Base class: a problem the user can fix; the CLI prints it without a traceback.

    `hint` is what to do, kept apart from what is wrong so that a front end that cannot offer the
    setting a hint names (the web app has no `max_megapixels`) can give its own advice instead.
    `in_file=True` marks a message about a file's own keys (a CSV column, a TOML key), which keep
    their names everywhere.
    """

    def __init__(self, message: str = "", *, hint: str | None = None, in_file: bool = False):
        self.problem = _template(message)
        self.hint = _template(hint) if hint else None
        self.in_file = in_file
        super().__init__(render(self.template))

    @property
    def template(self) -> str:
        return f"{self.problem} {self.hint}" if self.hint else self.problem

    def words(self, namer: Namer | None = None, *, hint: bool = True) -> str:
        return render(self.template if hint else self.problem, None if self.in_file else namer)

    def text(self) -> "Text | str":
        """The message as a Text (it keeps the parameter names for a front end to say), or as plain
        text for a message about a file's own keys."""
        return str(self) if self.in_file else Text(self.template)

    def __reduce__(self):  # batch workers send errors back pickled: keep the template and the data
        return (_restore, (type(self), dict(self.__dict__)))

    def hint_names(self) -> set[str]:
        """The parameters the hint names (to tell whether a front end can offer them)."""
        return names_in(self.hint or "")


def _restore(cls, state: dict) -> "TampError":
    error = cls.__new__(cls)
    error.__dict__.update(state)
    Exception.__init__(error, render(error.template))
    return error


def _template(message) -> str:
    return shorten_values(str(message.template if isinstance(message, Text) else message))


def names_in(template: str) -> set[str]:
    """The parameters a message template names between backticks."""
    pieces = str(template).split("`")
    return {p for p in pieces[1::2] if p in _known_names()} if len(pieces) % 2 else set()


class InputError(TampError):
    """An input file that cannot be read or used."""


_UNSET: Any = object()


class ParameterError(TampError, ValueError):
    """A parameter outside its allowed range. Besides the message it carries, as data, the
    `parameter` (a LithoParams field name, or None), the `value` received, what is `allowed`
    and a `hint` (what to do), so a front end can lay them out itself."""

    def __init__(self, message: str = "", *, parameter: str | None = None, value: Any = _UNSET,
                 allowed: str | None = None, hint: str | None = None, in_file: bool = False):
        self.parameter, self.allowed = parameter, allowed
        self.value = None if value is _UNSET else value
        self.has_value = value is not _UNSET
        super().__init__(message, hint=hint, in_file=in_file)


class MissingDependencyError(TampError):
    """An optional tool or library that is not installed."""


def install_hint(extra: str) -> str:
    """The command that installs the optional `extra` for how this copy of TAMP-OS was installed:
    from a clone (an editable install, or the source tree on the path), `make setup` there (it
    installs every extra) or `pip install -e '.[extra]'`; from a local folder, pip install of that
    folder; else from the package index, `pip install 'tamp-os[extra]'`."""
    root = source_tree()
    if root is not None:
        return f"in {root} run make setup (it installs every extra), or pip install -e '.[{extra}]'"
    folder, editable = _installed_from()
    if folder is not None:
        return f"pip install {'-e ' if editable else ''}'{folder}[{extra}]'"
    return f"pip install 'tamp-os[{extra}]' (or 'tamp-os[all]')"


def source_tree():
    """The clone this package runs from (the folder with its pyproject.toml), or None when it runs
    from an installed copy (site-packages)."""
    from pathlib import Path

    here = Path(__file__).resolve().parent
    root = here.parent.parent
    if here.parent.name != "src" or not (root / "pyproject.toml").is_file():
        return None
    try:
        named = 'name = "tamp-os"' in (root / "pyproject.toml").read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None
    return root if named else None


def _installed_from():
    """(the local folder pip installed this package from, whether editably), from the install's
    direct_url.json (PEP 610); (None, False) for an install from the package index."""
    import json
    from importlib import metadata
    from urllib.parse import unquote, urlparse

    try:
        said = json.loads(metadata.distribution("tamp-os").read_text("direct_url.json") or "{}")
    except (metadata.PackageNotFoundError, ValueError, OSError):
        return None, False
    url = urlparse(str(said.get("url", "")))
    if url.scheme != "file" or "dir_info" not in said:
        return None, False
    return unquote(url.path), bool(said["dir_info"].get("editable"))


def require_extra(extra: str, what: str, *modules: str) -> None:
    """Import `modules` (the libraries of the package's optional `extra`), or say in one line which
    extra to install and the command that installs it (install_hint)."""
    import importlib

    for name in modules:
        try:
            importlib.import_module(name)
        except ImportError:
            raise MissingDependencyError(
                f"{what} needs {name}, which comes with the {extra!r} extra: {install_hint(extra)}."
            ) from None


class ExportError(TampError):
    """An output that cannot be written."""
