"""The tamp-os command line. Plain text for screen readers; no traceback for user mistakes.

Only the standard library is imported at start-up so `tamp-os --help` is instant.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import functools
import gc
import json
import logging
import os
import re
import sys
from pathlib import Path
from types import MappingProxyType

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2
# Options named otherwise than their parameter (z_slice -> --slice); the rest are --name-with-dashes.
OPTION_NAMES = {"z_slice": "--slice", "slice_timeout_s": "--timeout"}
# Earlier option names, still accepted: parameter -> its old option.
OLD_OPTION_NAMES = {"depth_mm": "--height-mm"}
OPENBLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")  # in the order OpenBLAS reads them
_ONE_COMMAND = False  # set by run(): this process runs one command, then exits
# NumPy submodules a conversion never uses (see _defer_numpy_tools); numpy.ma is left out: np.median uses it.
NUMPY_TOOLS = ("f2py", "testing", "polynomial", "ctypeslib", "rec", "char", "strings")


def run() -> int:
    """The `tamp-os` program (the console script, `python -m tamp_os.cli`): main() in a process
    of its own, which may keep what it imports out of the cycle collector (see _loading) and
    ends without tearing its modules down (see _exit_now)."""
    global _ONE_COMMAND
    _ONE_COMMAND = True
    # One OpenBLAS thread unless the user set another number (before NumPy loads OpenBLAS, and
    # SciPy its own copy): each copy starts a thread per extra core that spins after loading and
    # after every BLAS call (~70 ms of CPU per conversion on 2 cores, taken from the OCR thread
    # and the machine's other work), while the pipeline makes no BLAS call large enough to share.
    # OpenBLAS also reads the two older variables when its own is unset: a user's setting of any wins.
    if not any(os.environ.get(name) for name in OPENBLAS_THREAD_VARIABLES):
        os.environ["OPENBLAS_NUM_THREADS"] = "1"
    return _exit_now(main())


def _exit_now(code: int) -> int:
    """Python's own exit less the teardown of every module and object, ~30 ms after a conversion
    spent freeing what the process is about to lose: as at any exit, other threads are waited
    for and the atexit handlers run (temporary folders, logging, worker processes), and the
    output is flushed; then the process ends. Returns `code` (a normal exit follows) where this
    Python lacks the two functions its own exit uses for that."""
    import atexit
    import threading

    wait_for_threads, run_atexit = getattr(threading, "_shutdown", None), getattr(atexit, "_run_exitfuncs", None)
    if wait_for_threads is None or run_atexit is None:
        return code
    wait_for_threads()
    run_atexit()
    for stream in (sys.stdout, sys.stderr):
        if stream is None:  # started with the output closed (`>&-`): Python's exit skips it too
            continue
        try:
            stream.flush()
        except (OSError, ValueError) as exc:  # a closed or full output: Python's exit says so, with 120
            if not code:  # (a failed command has said what failed; often this same output)
                code = 120
                _say_to_stderr(f"error: the output could not be written ({getattr(exc, 'strerror', None) or exc}).")
    os._exit(code)


def _say_to_stderr(line: str) -> None:
    """One line on the error output, if it can still take one (it may be the output that failed)."""
    with contextlib.suppress(OSError, ValueError, AttributeError):
        sys.stderr.write(line + "\n")
        sys.stderr.flush()


@contextlib.contextmanager
def _loading():
    """Around a command's imports, in run()'s process only: no cycle collection while NumPy,
    SciPy and scikit-image create their ~100,000 long-lived objects (collecting found nothing
    and cost ~20 ms of each `tamp-os convert`, one full pass included), then those objects are
    frozen, so neither later collections nor the collection at exit walk them again (~40 ms
    less at exit). Not in other callers of main(): freezing keeps the caller's objects too."""
    if _ONE_COMMAND:
        _defer_numpy_tools()
    if not (_ONE_COMMAND and gc.isenabled()):
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        gc.enable()


def _defer_numpy_tools() -> None:
    """NumPy's tool submodules (f2py, testing, ...) loaded on first use instead of at start-up, in
    run()'s process only. SciPy's array-API layer (1.17) copies NumPy's whole namespace when
    scipy.ndimage is imported, which imports every submodule NumPy loads lazily, ~50 ms of CPU of
    each `tamp-os convert` for modules a conversion never uses. Bound on numpy as the standard
    library's LazyLoader modules, they still work when something does use them: their first
    attribute read loads them. Skipped for any already imported or missing in this NumPy."""
    import importlib.util

    import numpy

    for name in NUMPY_TOOLS:
        full_name = f"numpy.{name}"
        if full_name in sys.modules or name in vars(numpy):
            continue
        spec = importlib.util.find_spec(full_name)
        if spec is None or spec.loader is None:
            continue
        spec.loader = importlib.util.LazyLoader(spec.loader)
        module = importlib.util.module_from_spec(spec)
        sys.modules[full_name] = module
        spec.loader.exec_module(module)
        setattr(numpy, name, module)


def _param_options(parser: argparse.ArgumentParser) -> None:
    """One option per LithoParams field, named after it (width_mm -> --width-mm), under one help
    heading per stage (params.SECTIONS), so `--help` reads as the pipeline does and a screen
    reader can jump from heading to heading."""
    from ..params import SECTIONS, LithoParams

    groups = {title: parser.add_argument_group(f"parameters: {title}", _format_list() if title == "outputs" else None)
              for title, _ in SECTIONS}
    group_of = {name: groups[title] for title, names in SECTIONS for name in names}
    flags_by_name = _flags()
    for f in dataclasses.fields(LithoParams):
        group = group_of[f.name]
        flag = flags_by_name[f.name]
        if f.name == "formats":
            group.add_argument(flag, dest=f.name, default=None, help=_format_help())
        elif isinstance(f.default, bool):
            group.add_argument(flag, dest=f.name, action="store_true", default=None, help=cli_words(f.metadata["help"]))
        else:  # typed later by params.parse_field, so every interface reports bad values alike
            flags = [flag] + ([OLD_OPTION_NAMES[f.name]] if f.name in OLD_OPTION_NAMES else [])
            group.add_argument(*flags, dest=f.name, default=None, metavar=f.metadata["unit"].upper() or "VALUE",
                               help=option_help(f))


def option_help(f: dataclasses.Field) -> str:
    """A parameter's help as an option's: its meaning, then what it takes and its default, each
    said once (a meaning that names its choices or its default is not followed by them again)."""
    from ..params import describe_range

    text = cli_words(f.metadata["help"])
    said = []
    choices = f.metadata["choices"]
    if f.metadata["lo"] is not None or (choices and not all(re.search(rf"\b{re.escape(c)}\b", text) for c in choices)):
        said.append(describe_range(f))
    if not re.search(r"\bdefault\b", text):
        said.append(f"default: {'none' if f.default is None else f.default}")
    return (f"{text} ({'; '.join(said)})" if said else text).replace("%", "%%")  # argparse formats help with %


@functools.cache  # read for every help text: building the parser asked for it ~375 times (~8 ms of each command)
def _flags() -> MappingProxyType[str, str]:
    """Each LithoParams field and its option here (width_mm -> --width-mm, z_slice -> --slice)."""
    from ..params import LithoParams

    return MappingProxyType({f.name: OPTION_NAMES.get(f.name, "--" + f.name.replace("_", "-")) for f in dataclasses.fields(LithoParams)})


def cli_words(message) -> str:
    """A library message (an error, a warning, a help text) with each parameter it names said as
    this command's option (pixel_size -> --pixel-size); see errors.Text. A warning quotes a short
    prefix of a long value too (errors.shorten_values): a line on a terminal, not the value again."""
    from ..errors import shorten_values, words

    return shorten_values(words(message, _flags().get))


def _format_help() -> str:
    from ..formats import NAMES

    return f"comma-separated, from the list above: {', '.join(NAMES)} (default: stl)"


def _format_list() -> str:
    """Each format and what it is for, one a line, from the format table (the outputs heading's text)."""
    from ..formats import TABLE

    return "\n".join(f"{f.name}: {f.purpose}" for f in TABLE)


class _HelpFormatter(argparse.HelpFormatter):
    """argparse's help, but a text of several lines (the formats under their heading) keeps one
    item a line, each wrapped on its own, instead of being run together into one paragraph."""

    def _fill_text(self, text, width, indent):
        if "\n" not in text:
            return super()._fill_text(text, width, indent)
        import textwrap

        return "\n".join(textwrap.fill(line, width, initial_indent=indent, subsequent_indent=indent + "    ")
                         for line in text.splitlines())


def _params_from_args(args, base=None):
    from ..params import LithoParams, parse_field

    changes = {}
    for f in dataclasses.fields(LithoParams):
        value = getattr(args, f.name, None)
        if value is not None:
            changes[f.name] = parse_field(f.name, value) if isinstance(value, str) else value
    return (base or LithoParams()).replace(**changes)


class _Parser(argparse.ArgumentParser):
    """argparse's parser, but help that cannot be written fails (argparse drops a failed write, so
    `tamp-os --help > file` on a full disk exited 0 with nothing written and nothing said), and
    lists keep one item a line (see _HelpFormatter)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", _HelpFormatter)
        super().__init__(*args, **kwargs)

    def print_help(self, file=None):
        file = file or sys.stdout
        if file is not None:  # None: started with the output closed (`>&-`), as print() skips it
            file.write(self.format_help())
            file.flush()

    def error(self, message):  # argparse quotes the whole value it could not use: a short prefix, as every error
        from ..errors import shorten_values

        super().error(shorten_values(message))


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="tamp-os",
        description="Turn images, above all microscopy images, into 3D-printable tactile lithographs.",
    )
    parser.add_argument("--debug", action="store_true", help="show full tracebacks and debug messages")
    parser.add_argument("--version", action="store_true", help="print the version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for add in (_add_convert_and_batch, _add_sweep_and_render, _add_slicing, _add_gui, _add_presets_and_plate, _add_check, _add_info):
        add(sub)
    return parser


def _add_convert_and_batch(sub) -> None:
    convert = sub.add_parser("convert", help="convert images to printable files", description="Convert images to printable files.")
    convert.add_argument("images", nargs="*", metavar="IMAGE", help="image files (read by content, any extension)")
    convert.add_argument("-o", "--output", default=".", metavar="DIR", help="output folder (default: current folder)")
    convert.add_argument("--recipe", metavar="FILE", help="rebuild exactly from a NAME.tamp.json recipe")
    convert.add_argument("--verbose", action="store_true", help="after each result line, the mesh, printer, scale and every file written")
    _param_options(convert)

    batch = sub.add_parser("batch", help="convert many images; resumes where it stopped", description=(
        "Convert every image in folders or lists. One bad file never stops the others; a rerun skips "
        "what is already done. batch-report.csv and .json in the output folder list every input."))
    batch.add_argument("inputs", nargs="+", metavar="DIR_OR_FILE")
    batch.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder")
    batch.add_argument("--recursive", action="store_true", help="look in sub-folders too (their structure is kept)")
    batch.add_argument("--include", action="append", metavar="GLOB", help="file-name pattern to convert (repeatable; default common image types)")
    batch.add_argument("--overrides", metavar="CSV", help="per-image parameters: a 'file' column, then parameter columns")
    batch.add_argument("--workers", type=int, metavar="N", help="worker processes (default: all cores)")
    batch.add_argument("--dask-scheduler", metavar="ADDRESS", help="run on a Dask cluster, e.g. tcp://127.0.0.1:8786")
    _param_options(batch)


def _add_sweep_and_render(sub) -> None:
    sweep = sub.add_parser("sweep", help="one image with parameters varied, and a contact sheet")
    sweep.add_argument("image", metavar="IMAGE")
    sweep.add_argument("--vary", action="append", required=True, metavar="NAME=V1,V2",
                       help="an option and its values, e.g. resolution=64,128,256 or relief-style=structure,levels (repeat for a grid)")
    sweep.add_argument("-o", "--output", default="sweep-output", metavar="DIR", help="output folder (default sweep-output)")
    sweep.add_argument("--no-render", action="store_true", help="skip the sheet of rendered previews")
    _param_options(sweep)

    render = sub.add_parser("render", help="rendered previews (full and close-up) of meshes, with alt text")
    render.add_argument("inputs", nargs="+", metavar="MESH_OR_DIR")
    render.add_argument("-o", "--output", default=".", metavar="DIR", help="folder for renders/full and renders/closeup")
    render.add_argument("--theme", choices=["light", "dark"], default="light")
    render.add_argument("--azimuth", type=float, default=-30.0, metavar="DEG", help="turn around the print (default -30)")
    render.add_argument("--elevation", type=float, default=35.0, metavar="DEG", help="height of the view, 0-90 (default 35)")
    render.add_argument("--zoom", type=float, default=1.0, help="zoom of the full view (default 1)")
    render.add_argument("--closeup-zoom", type=float, default=3.0, help="extra zoom of the close-up (default 3)")
    render.add_argument("--size", default="1200x900", metavar="WxH", help="image size in pixels (default 1200x900)")


def _add_slicing(sub) -> None:
    slicer = sub.add_parser("slice", help="slice meshes with PrusaSlicer: G-code, print time, grams, cost")
    slicer.add_argument("meshes", nargs="+", metavar="MESH")
    estimate = sub.add_parser("estimate", help="mass and cost of meshes without slicing (assumptions stated)")
    estimate.add_argument("meshes", nargs="+", metavar="MESH")
    for p in (slicer, estimate):
        p.add_argument("--printer", default="standard", help="printer profile (default standard)")
        p.add_argument("--material", default="PLA", help="PLA, PETG, ABS, rPLA, rPETG (recycled), resin or plant-resin "
                       "(default PLA; on a resin printer, resin)")
        # --filament-price-per-kg as convert names it; --filament-price, the name slice had before, still works
        p.add_argument("--filament-price-per-kg", "--filament-price", dest="filament_price_per_kg", type=float, default=None,
                       metavar="PER_KG", help="filament price per kg, in your currency (default 25, an assumed price)")
        p.add_argument("--resin-price-per-kg", type=float, default=None, metavar="PER_KG",
                       help="resin price per kg, in your currency (default 35, an assumed price)")
    slicer.add_argument("--timeout", type=float, default=600.0, metavar="S", help="stop PrusaSlicer after S seconds (default 600)")


def _add_gui(sub) -> None:
    gui = sub.add_parser("gui", help="start the accessible web app on this computer")
    gui.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1: this computer only)")
    gui.add_argument("--port", type=int, default=8765, help="port, 0 to 65535 (default 8765)")
    gui.add_argument("--no-browser", action="store_true", help="do not open a web browser")
    gui.add_argument("--max-file-mb", type=float, default=50.0, help="largest upload per image in MB (default 50)")
    gui.add_argument("--max-files", type=int, default=20, help="most images per job (default 20)")


def _add_presets_and_plate(sub) -> None:
    from ..tactile.braille import DEFAULT_TABLE

    presets = sub.add_parser("presets", help="show Low/Medium/High for a printer (and suggest one for an image)")
    presets.add_argument("image", nargs="?", metavar="IMAGE")
    _param_options(presets)

    printers = sub.add_parser("printers", help="list printer profiles and PrusaSlicer's system printers for --printer")
    printers.add_argument("--vendor", default=None, help="only this vendor's printers (e.g. prusa, bambu, creality)")

    plate = sub.add_parser(
        "braille-test-plate", help="a plate of the same braille at several dot heights and diameters",
        description="Print this, read it, and pick the dot height and diameter your printer makes legible.",
    )
    plate.add_argument("-o", "--output", default=".", metavar="DIR", help="output folder (default: current folder)")
    plate.add_argument("--text", default="Tactile 123", help="the text to repeat (default: Tactile 123)")
    plate.add_argument("--braille-table", default=DEFAULT_TABLE, help=f"liblouis table (default {DEFAULT_TABLE})")
    plate.add_argument("--heights", default="0.5,0.7,0.9", metavar="MM,...", help="dot heights in mm (default 0.5,0.7,0.9)")
    plate.add_argument("--diameters", default="1.4,1.5,1.6", metavar="MM,...", help="dot base diameters in mm (default 1.4,1.5,1.6)")
    plate.add_argument("--formats", default="stl", help="comma-separated output formats (default stl)")


def _add_check(sub) -> None:
    from ..formats import READABLE_MESH_SUFFIXES

    check = sub.add_parser("check", help="what a finger will find: the legibility report of an image or a mesh",
                           description="Measure a relief by touch: fine texture, height levels and steps, narrow "
                                       "features, slopes and objects, with advice. An image is made into a relief "
                                       f"first (with the options given); a mesh ({', '.join(READABLE_MESH_SUFFIXES)}) is measured as it is.")
    check.add_argument("inputs", nargs="+", metavar="IMAGE_OR_MESH")
    _param_options(check)


def _add_info(sub) -> None:
    info = sub.add_parser("info", help="describe an image file: size, bit depth, channels, metadata")
    info.add_argument("image", metavar="IMAGE")
    info.add_argument("--json", action="store_true", help="print JSON for scripts")
    info.add_argument("--page", type=int, default=None, help="TIFF page or series (default: the first, or the data page beside a preview)")
    info.add_argument("--slice", type=int, default=None, help="z-stack slice (default: maximum-intensity projection)")
    info.add_argument("--channel", default="luminance", help="channel number or name (default: luminance / first)")
    info.add_argument("--pixel-size", default=None, help="physical pixel size to use, e.g. 4.2nm")
    info.add_argument("--time", type=int, default=None, help="time point of a time series (default: the first)")
    info.add_argument("--scene", default=None, help="scene, series or image of a multi-scene file: a number from 0, or a LIF "
                                                    "series name (default: the first)")


def _volume_sections(argv: list[str]) -> list[str]:
    """'--volume sections:5' (the issue's and the docs' spelling) -> '--sections 5'."""
    out, i = [], 0
    while i < len(argv):
        if argv[i] == "--volume" and i + 1 < len(argv) and argv[i + 1].lower().startswith("sections:"):
            out += ["--sections", argv[i + 1].split(":", 1)[1]]
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out


def _values_may_start_with_a_dash(argv: list[str], parser: argparse.ArgumentParser) -> list[str]:
    """'--pixel-size -5um' -> '--pixel-size=-5um'. argparse takes a value starting with '-' for an
    option and says only 'expected one argument'; joined, the value reaches the parameter check,
    which names the allowed range."""
    parsers = [parser, *next(a for a in parser._actions if a.dest == "command").choices.values()]
    takes_value = {s for p in parsers for a in p._actions if a.nargs != 0 for s in a.option_strings}
    known = {s for p in parsers for a in p._actions for s in a.option_strings}
    out, i = [], 0
    while i < len(argv):
        if argv[i] in takes_value and i + 1 < len(argv) and argv[i + 1].startswith("-") and argv[i + 1] not in known:
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out


def main(argv=None) -> int:
    parser = build_parser()
    argv = _values_may_start_with_a_dash(_volume_sections(list(sys.argv[1:] if argv is None else argv)), parser)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:
        return int(exc.code or 0) and EXIT_USAGE
    except BrokenPipeError:  # --help piped into a program that stopped reading (| head), as for a command's output
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except OSError as exc:  # --help into a full disk
        _say_to_stderr(f"error: {last_resort_words(exc)}")
        return EXIT_FAILED
    logging.basicConfig(level=logging.DEBUG if args.debug else logging.ERROR, format="%(levelname)s: %(message)s")
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")  # offscreen rendering with no display
    from ..errors import ParameterError, TampError

    previous = _stop_on_signals()
    _never_fail_on_encoding()
    try:  # the version and the help too: their output may be a full disk or a closed pipe
        if args.version:
            from .. import __version__

            print(f"tamp-os {__version__}")
            return EXIT_OK
        if not args.command:
            parser.print_help()
            return EXIT_USAGE
        commands = {
            "convert": cmd_convert, "batch": cmd_batch, "presets": cmd_presets, "info": cmd_info,
            "braille-test-plate": cmd_braille_plate, "sweep": cmd_sweep, "render": cmd_render,
            "slice": cmd_slice, "estimate": cmd_estimate, "gui": cmd_gui, "printers": cmd_printers,
            "check": cmd_check,
        }
        return commands[args.command](args)
    except TampError as exc:
        if args.debug:
            raise
        print(f"error: {cli_words(exc)}", file=sys.stderr)
        return EXIT_USAGE if isinstance(exc, ParameterError) else EXIT_FAILED
    except KeyboardInterrupt:
        print("stopped.", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into a program that stopped reading (| head)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except Exception as exc:  # last resort: a bug or an unforeseen situation is one line, not a traceback
        if args.debug:
            raise
        print(f"error: {last_resort_words(exc)}", file=sys.stderr)
        return EXIT_FAILED
    finally:
        _restore_signals(previous)


def last_resort_words(exc: BaseException) -> str:
    """One line for an error nobody foresaw: what happened, and how to learn more."""
    if isinstance(exc, MemoryError):
        return "not enough memory for this image; make it smaller (or lower --resolution-px) and try again."
    if isinstance(exc, OSError) and exc.strerror:
        if not exc.filename:  # print() to a full disk or a closed output names no file
            return (f"{exc.strerror} (no file named: often the output itself); check where the output goes and the disk's free space. "
                    "(--debug shows the details.)")
        return f"{exc.filename}: {exc.strerror}; check the file or folder and its permissions. (--debug shows the details.)"
    text = str(exc).splitlines()[0][:200] if str(exc) else ""
    return (f"unexpected {exc.__class__.__name__}{': ' + text if text else ''}. Nothing half-written was left; "
            "run again with --debug to see where it happened, and please report it.")


def _stop_on_signals() -> dict:
    """SIGTERM and SIGHUP (a closed terminal, a service stopped) stop the run as Ctrl-C does, so
    temporary files are removed and the folder's lock is released, instead of being left behind.
    Returns the handlers replaced, for _restore_signals."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return {}  # signal handlers can only be set from the main thread (the CLI called from a worker)
    previous = {}
    for name in ("SIGTERM", "SIGHUP"):
        if hasattr(signal, name):
            number = getattr(signal, name)
            previous[number] = signal.signal(number, signal.default_int_handler)
    return previous


def _restore_signals(previous: dict) -> None:
    import signal

    for number, handler in previous.items():
        signal.signal(number, handler if handler is not None else signal.SIG_DFL)


def _never_fail_on_encoding() -> None:
    """A file name that is not valid UTF-8 must print (as an escape), not crash the output."""
    for stream in (sys.stdout, sys.stderr):
        if getattr(stream, "errors", None) == "strict" and hasattr(stream, "reconfigure"):
            try:
                stream.reconfigure(errors="backslashreplace")
            except (ValueError, OSError):
                pass


def _run_each(items, action, debug: bool = False) -> int:
    """Run `action(item)` for every item; print its lines, or one error line, and go on.

    Returns EXIT_FAILED when any item failed (each was named), else EXIT_OK.
    """
    from ..errors import TampError

    failed = 0
    for item in items:
        try:
            lines = action(item)
        except TampError as exc:
            if debug:
                raise
            print(f"error: {cli_words(exc)}", file=sys.stderr)
            failed += 1
            continue
        except (OSError, MemoryError) as exc:  # one input's unforeseen trouble must not stop the others
            if debug:
                raise
            print(f"error: {last_resort_words(exc)}", file=sys.stderr)
            failed += 1
            continue
        for line in lines:
            print(line)
    if failed and len(items) > 1:
        print(f"{failed} of {len(items)} failed.", file=sys.stderr)
    return EXIT_FAILED if failed else EXIT_OK


def cmd_convert(args) -> int:
    with _loading():
        from ..lithograph.outputs import distinct_stems, load_recipe
        from ..lithograph.products import convert
        from ..lithograph.sizing import check_up_front

    jobs = []
    if args.recipe:
        image, params, printer, _ = load_recipe(args.recipe)
        jobs.append((image, _params_from_args(args, params), printer))
    if not args.images and not jobs:
        print("error: give at least one IMAGE, or --recipe FILE.", file=sys.stderr)
        return EXIT_USAGE
    params = _params_from_args(args)  # validates options once, before any work
    check_up_front(params)
    jobs += [(Path(p), params, None) for p in args.images]
    stems = distinct_stems([image for image, _, _ in jobs])  # never overwrite an output of this run

    def convert_job(job_and_stem):
        (image, job_params, printer), stem = job_and_stem
        with _WorkingLine(Path(image).name):  # its line is cleared before the warnings and results are printed
            made = convert(image, job_params, Path(args.output), stem=stem, printer_profile=printer,
                           on_price=_say_price(Path(image).name))
        lines = _made_lines(made, args.verbose)
        if stem != (image.stem or "lithograph"):
            lines.append(f"  note: named {stem} because another input of this run has the same name")
        return lines

    from ..errors import TampError
    from ..lithograph.locks import output_lock

    try:
        with output_lock(Path(args.output)):  # one writer per folder: never a set mixed from two runs
            return _run_each(list(zip(jobs, stems)), convert_job, args.debug)
    except TampError as exc:  # the output folder cannot be used: nothing was converted
        if args.debug:
            raise
        print(f"error: {cli_words(exc)}", file=sys.stderr)
        return EXIT_FAILED


def _say_price(name: str):
    """A long 3-D model says its expected time before the work (volume_price.py)."""
    def say(price) -> None:
        from ..lithograph.volume_price import SAY_AFTER_S

        if price.seconds >= SAY_AFTER_S:
            print(f"note: {name}: priced at {price.words()}; working…", file=sys.stderr, flush=True)

    return say


def _made_lines(made, verbose: bool) -> list[str]:
    """A product's warnings to stderr; its lines returned: a 3-D model's summary and notes, or each
    relief print's lines (a figure's own files and layout notes after them), then the product's notes."""
    if made.model is not None:
        for warning in made.warnings:
            print(f"warning: {cli_words(warning)}", file=sys.stderr)
        return made.model.lines(cli_words)
    lines = []
    for conversion in made.conversions:
        lines += [line for each in conversion.prints for line in _say(each, verbose=verbose)]
        if conversion.figure_files:  # a figure's own files: NAME.pages.pdf (with pdf) and its recipe
            lines.append("  figure: wrote " + ", ".join(p.name for p in conversion.figure_files))
        lines += [f"  note: {cli_words(note)}" for note in conversion.layout_notes]
    return lines + [f"  note: {cli_words(note)}" for note in made.notes]


def _say(conversion, verbose: bool = False) -> list[str]:
    """One conversion's warnings to stderr; its lines (summary, notes, printing, and with `verbose`
    the details) returned."""
    from ..errors import is_decision
    from ..lithograph.report import advice_notes, detail_lines

    which = f"{conversion.label}: " if conversion.label else ""  # a figure's print: which panel warns
    # Warnings are for what the user must act on; the tool's own decisions are in the description and
    # the report, and here with --verbose (issue 33.9).
    for warning in conversion.report.warnings:
        if not is_decision(warning):
            print(f"warning: {which}{cli_words(warning)}", file=sys.stderr)
    decided = [f"  note: {cli_words(w)}" for w in conversion.report.warnings if is_decision(w)] if verbose else []
    if verbose:  # the description names no option: the verdicts' advice, in this command's words
        decided += [f"  advice: {cli_words(v)}" for v in advice_notes(conversion.report) if not is_decision(v)]
    # What the check doubts about the print (raised parts darker than their ground …), on its own line each.
    flags = [f"  check: {cli_words(f)}" for f in conversion.report.check_flags]
    lines = [conversion.summary()] + flags + [f"  note: {cli_words(n)}" for n in conversion.notes()] + decided
    printing = conversion.report.print
    if printing:  # the why of "for estimates only" on its own line, so that each line stays short
        note = printing.result.note if printing.result.for_estimates_only else None
        lines.append(f"  print: {cli_words(printing.summary.replace(f' ({note})', '') if note else printing.summary)}")
        if note:
            lines.append(f"  note: {cli_words(note)}")
    return lines + (detail_lines(conversion.report, conversion.names) if verbose else [])


def cmd_batch(args) -> int:
    from ..lithograph.batch import Job, collect_inputs, read_overrides, run_batch
    from ..lithograph.sizing import check_up_front

    params = _params_from_args(args)
    check_up_front(params)
    if args.workers is not None and args.workers < 1:
        print(f"error: --workers: give 1 or more worker processes; got {args.workers}.", file=sys.stderr)
        return EXIT_USAGE
    out = Path(args.output)
    overrides = read_overrides(Path(args.overrides)) if args.overrides else {}
    inputs = collect_inputs(args.inputs, args.recursive, tuple(args.include) if args.include else None, exclude_dir=out)
    if not inputs:
        print("error: no images found; check the folder, or use --include '*.ext' for other file types.", file=sys.stderr)
        return EXIT_USAGE
    jobs = [Job(path, out / rel.parent, params.replace(**overrides.get(str(rel), overrides.get(path.name, {}))))
            for path, rel in inputs]
    client = _dask_client(args.dask_scheduler) if args.dask_scheduler else None
    progress = _BatchProgress(len(jobs))
    try:
        outcomes = run_batch(jobs, out, executor=client.get_executor() if client else None, workers=args.workers, on_done=progress)
    finally:
        progress.close()
        if client:
            client.close()
    failed = [o for o in outcomes if o["status"] == "failed"]
    converted = sum(o["status"] == "converted" for o in outcomes)
    skipped = sum(o["status"].startswith("skipped") for o in outcomes)
    print(f"batch: {converted} converted, {skipped} already up to date, {len(failed)} failed; report in {out / 'batch-report.csv'}")
    return EXIT_FAILED if failed else EXIT_OK


DASK_CONNECT_S = 10.0  # how long a scheduler that does not answer is waited for


def _dask_client(address: str):
    from ..errors import InputError, require_extra

    require_extra("dask", "--dask-scheduler", "distributed")
    from distributed import Client

    try:
        return Client(address, timeout=f"{DASK_CONNECT_S}s")
    except (OSError, TimeoutError) as exc:
        raise InputError(
            f"--dask-scheduler: cannot reach a Dask scheduler at {address} ({exc}); check the address, "
            f"or start one with 'dask scheduler', or leave the option out to use this computer's cores."
        ) from None


class _WorkingLine:
    """On a terminal, one line on stderr once a single conversion has run PROGRESS_AFTER_S seconds,
    rewritten each second with the time so far and cleared at the end; nothing when not a terminal
    (a pipe, a log file or a screen reader's transcript gets only the result lines)."""

    PROGRESS_AFTER_S = 2.0

    def __init__(self, name: str, stream=None):
        self.name, self.stream = name, stream or sys.stderr
        self.shown = False
        self._stop = None

    def __enter__(self):
        import threading
        import time

        if not self.stream.isatty():
            return self
        self._stop = threading.Event()
        start = time.monotonic()

        def tick():
            if self._stop.wait(self.PROGRESS_AFTER_S):
                return
            while True:
                self.stream.write(f"\r{self.name}: working, {time.monotonic() - start:.0f} s so far…")
                self.stream.flush()
                self.shown = True
                if self._stop.wait(1.0):
                    return

        self._thread = threading.Thread(target=tick, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        if self._stop is not None:
            self._stop.set()
            self._thread.join()
            if self.shown:
                self.stream.write("\r\x1b[K")
                self.stream.flush()
        return False


class _BatchProgress:
    """A progress bar on a terminal; otherwise one plain line per finished input."""

    def __init__(self, total: int):
        self.bar = None
        if sys.stderr.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=total, unit="image", file=sys.stderr)

    def __call__(self, outcome: dict, count: int, total: int) -> None:
        name = Path(outcome["input"]).name
        if self.bar:
            self.bar.update(1)
            if outcome["status"] == "failed":
                self.bar.write(f"failed: {cli_words(outcome['error'])}")
        else:
            detail = cli_words(outcome["error"]) if outcome["status"] == "failed" else f"{outcome['seconds']:.1f} s"
            from ..lithograph.batch import FLAT_PLATE_NOTE  # loaded already: the batch is running

            if FLAT_PLATE_NOTE in (outcome.get("warnings") or ()):
                detail = f"a flat plate: the image is uniform, nothing is raised; {detail}"  # not heard only in the CSV
            print(f"{count} of {total}: {name} {outcome['status']} ({detail})", flush=True)

    def close(self) -> None:
        if self.bar:
            self.bar.close()


def _vary_in_field_names(specs: list[str]) -> list[str]:
    """--vary in this command's spellings (relief-style=…, --slice=…, height-mm=…) as the library's names."""
    by_option = {flag.lstrip("-"): name for name, flag in _flags().items()}
    by_option.update({old.lstrip("-"): name for name, old in OLD_OPTION_NAMES.items()})
    out = []
    for spec in specs:
        name, sep, values = spec.partition("=")
        key = name.strip().lstrip("-")
        out.append(f"{by_option.get(key, key)}{sep}{values}")
    return out


def cmd_sweep(args) -> int:
    from ..lithograph.sizing import check_up_front
    from ..lithograph.sweep import parse_vary, run_sweep

    params = _params_from_args(args)
    check_up_front(params)
    vary = parse_vary(_vary_in_field_names(args.vary))
    result = run_sweep(Path(args.image), params, vary, out_dir=Path(args.output), render=not args.no_render)
    for conversion in result.conversions:
        for line in _say(conversion):
            print(line)
    print(f"sweep: {len(result.conversions)} variants; contact sheets {', '.join(p.name for p in result.sheets)} in {args.output}")
    return EXIT_OK


def cmd_render(args) -> int:
    from ..errors import InputError, ParameterError
    from ..export.meshfile import read_mesh_file
    from ..lithograph.render import View, find_meshes, render_file

    try:
        width, height = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        raise ParameterError(f"--size: write WIDTHxHEIGHT in pixels, for example 1200x900; got {args.size!r}.") from None
    view = View(width, height, args.azimuth, args.elevation, args.zoom, args.closeup_zoom, args.theme)
    meshes = find_meshes(args.inputs)
    if not meshes:
        from ..formats import READABLE_MESH_SUFFIXES

        print(f"error: no meshes found ({', '.join(READABLE_MESH_SUFFIXES)}).", file=sys.stderr)
        return EXIT_USAGE

    def render(path):
        read_mesh_file(path)
        try:
            written = render_file(path, Path(args.output), view)
        except (OSError, ValueError) as exc:
            raise InputError(f"{path}: cannot be rendered ({exc}).") from None
        return [f"{path.name}: wrote {', '.join(str(p.relative_to(args.output)) for p in written if p.suffix == '.png')} with alt text"]

    return _run_each(meshes, render, args.debug)


def cmd_gui(args) -> int:
    from ..errors import ParameterError, require_extra

    if not 0 <= args.port <= 65535:  # (the socket's own error is an OverflowError, which reads as a bug)
        raise ParameterError(f"--port: must be a port number from 0 to 65535; got {args.port}.")
    require_extra("gui", "the web app", "fastapi", "uvicorn", "jinja2", "python_multipart")
    from ..gui import serve

    import socket

    with socket.socket() as probe:
        try:
            probe.bind((args.host, args.port))
        except OSError as exc:
            raise ParameterError(f"--port: cannot listen on {args.host}:{args.port} ({exc.strerror}); choose another port with --port.") from None
    from ..gui.security import is_loopback

    url, token = f"http://{args.host}:{args.port}/", None
    if not is_loopback(args.host):
        import secrets

        token = secrets.token_urlsafe(24)
        url += f"?token={token}"
        print(f"WARNING: --host {args.host} makes the web app reachable from other computers. Anyone who has the "
              "address below, with its token, can use it and see the images uploaded to it.", file=sys.stderr, flush=True)

    def ready() -> None:
        print(f"TAMP-OS web app at {url} (press Control-C to stop)", flush=True)
        if not args.no_browser:
            import threading
            import webbrowser

            threading.Thread(target=webbrowser.open, args=(url,), daemon=True).start()

    serve(args.host, args.port, on_ready=ready, max_file_mb=args.max_file_mb, max_files=args.max_files, access_token=token)
    return EXIT_OK


def cmd_slice(args) -> int:
    from ..export.meshfile import read_mesh_file
    from ..printing.printers import get_printer
    from ..printing.slicer import material_for, slice_mesh

    printer = get_printer(args.printer)
    mat = material_for(printer, args.material, filament_price_per_kg=args.filament_price_per_kg,
                       resin_price_per_kg=args.resin_price_per_kg)

    def slice_one(mesh):
        read_mesh_file(mesh)  # one clear error for a file that is not a mesh, before PrusaSlicer runs
        result = slice_mesh(mesh, printer, mat, timeout_s=args.timeout)
        return [f"{Path(mesh).name}: {result.sentence()}; {result.layers} layers of {result.layer_mm:g} mm; wrote {Path(result.gcode).name}"]

    return _run_each(args.meshes, slice_one, args.debug)


def cmd_estimate(args) -> int:
    from ..export.meshfile import read_mesh_file
    from ..printing.printers import get_printer
    from ..printing.slicer import FILAMENTS, RESINS, estimate, material, material_for

    printer = get_printer(args.printer)
    prices = (args.filament_price_per_kg, args.resin_price_per_kg)
    mat = material_for(printer, args.material, filament_price_per_kg=prices[0], resin_price_per_kg=prices[1])
    others = [material(m, *prices) for m in (RESINS if printer.is_resin else FILAMENTS) if m != mat.name]

    def estimate_one(mesh_path):
        mesh = read_mesh_file(mesh_path)
        if not mesh.is_watertight:
            print(f"warning: {mesh_path}: not a closed solid; the volume and estimate may be wrong.", file=sys.stderr)
        found = [estimate(float(mesh.volume), mesh.vertices, mesh.faces, printer=printer, mat=m) for m in (mat, *others)]
        e = found[0]
        # (whether the price is assumed is said once, with the assumptions)
        lines = [f"{Path(mesh_path).name}: about {_amount_words(e)}, costing about {e['cost']:.2f} at {e['price_per_kg']:g} "
                 f"per kg{_co2e_text(e)}. Assumes {e['assumptions']}."]
        lines += [f"  {o['material']}: about {_amount_words(o)}, costing about {o['cost']:.2f}{_co2e_text(o)}" for o in found[1:]]
        lines += [f"  CO₂e factor of {o['material']}: {o['co2e_source']}" for o in found]
        return lines

    return _run_each(args.meshes, estimate_one, args.debug)


def _amount_words(e: dict) -> str:
    """'12.3 g of PLA (9.92 cm³)' or '8.4 mL of resin (9.2 g)' from an estimate."""
    if "resin_ml" in e:
        return f"{e['resin_ml']:.2f} mL of {e['material']} ({e['filament_g']:.1f} g)"
    return f"{e['filament_g']:.1f} g of {e['material']} ({e['filament_cm3']:.2f} cm³)"


def _co2e_text(e: dict) -> str:
    return "" if e["co2e_kg"] is None else f", about {e['co2e_kg']:.3f} kg CO₂e"


def cmd_presets(args) -> int:
    from ..lithograph.presets import preset_rows, size_words
    from ..relief.touch import suggest_by_touch
    from ..lithograph.sizing import layout_for, resolve_printer
    from ..printing.printers import height_levels

    params = _params_from_args(args)
    printer = resolve_printer(params)
    layer = printer.layer_mm
    picture, suggestion = None, None
    if args.image:
        from ..lithograph.pipeline import read_source

        picture = read_source(args.image, params)  # the plane, level and limits the conversion would read
        width = layout_for(params, printer, picture.file.width, image_h_px=picture.file.height).width_mm
        suggestion = suggest_by_touch(picture.values, picture.alpha, width_mm=width, nozzle_mm=printer.nozzle_mm)
    if printer.is_resin:
        print(f"printer {printer.name}: resin, feature {printer.nozzle_mm:g} mm (4 pixels, at least 0.2 mm: the grid follows it "
              f"as it follows a nozzle), layer {layer:g} mm, mesher {params.mesher}")
    else:
        print(f"printer {printer.name}: nozzle {printer.nozzle_mm:g} mm, layer {layer:g} mm, mesher {params.mesher}")
    print(f"height levels: {height_levels(params.relief_mm, layer)} (relief {params.relief_mm:g} mm ÷ layer {layer:g} mm)")
    for row in preset_rows(params, picture=picture):
        sizes = size_words(row["bytes"])
        about = "" if row["exact"] or params.mesher == "grid" else "about "
        print(
            f"{row['preset'].capitalize()}: grid {row['cols']} × {row['rows']}, {row['mm_per_px']:.3f} mm per pixel, "
            f"blur {row['blur_px']:g} px, print {row['width_mm']:g} × {row['depth_mm']:.1f} mm, "
            f"{about}{row['triangles']:,} triangles, estimated {sizes}"
        )
    if suggestion:
        print(f"suggested for {Path(args.image).name}: {suggestion.preset.capitalize()}, because {cli_words(suggestion.reason)}.")
    return EXIT_OK


def cmd_printers(args) -> int:
    from ..printing.printer_table import installed_preset, printers_of, sla_preset, vendor_name
    from ..printing.printers import all_printers
    from ..printing.prusa_presets import system_printers

    print("Profiles (G-code from these is for estimates only, not for a real printer):")
    for p in all_printers().values():
        print(f"{p.name}: nozzle {p.nozzle_mm:g} mm, layer {p.layer_mm:g} mm, width {p.width_mm:g} mm, {p.description}")
    table = printers_of(args.vendor)
    nozzle = [m for m in table if not m.is_resin]
    resin = [m for m in table if m.is_resin]
    if nozzle:
        print(f"Today's nozzle (FDM) printers ({len(nozzle)}; --printer takes the name or a short form such as mk4 or 'a1 mini'; "
              "the 3MF carries their print settings):")
    for model in nozzle:
        preset = installed_preset(model)
        print(model.line() + (f"; G-code from PrusaSlicer's {preset!r}" if preset else "; no G-code here, print from the 3MF"))
        print(f"  source: {model.source}")
    if resin:
        print(f"Today's resin (MSLA and SLA) printers ({len(resin)}; --printer takes the name or a short form such as sl1s or "
              "'form 4'; print the STL or 3MF flat on the platform, no supports):")
    for model in resin:
        preset = sla_preset(model)
        print(model.line() + (f"; --gcode writes a .sl1s with PrusaSlicer's {preset!r}" if preset
                              else "; no slicer here, print from the vendor's slicer"))
        print(f"  short names: {', '.join(model.short_names)}")
        print(f"  source: {model.source}")
    wanted = vendor_name(args.vendor).replace(" ", "").lower() if args.vendor else None
    found = [p for p in system_printers() if not wanted or p.vendor.lower() == wanted]
    print(f"PrusaSlicer system printers ({len(found)}; give the name in quotes to --printer for G-code you can print):")
    for p in found:
        print(p.line())
    if not found and not table:
        print(f"none found for vendor {args.vendor!r}: try prusa, bambu or creality, or install PrusaSlicer (apt-get install prusa-slicer).")
    return EXIT_OK


def cmd_check(args) -> int:
    from ..lithograph.pipeline import make_lithograph
    from ..lithograph.sizing import resolve_printer
    from ..lithograph.check import MESH_SUFFIXES, check_mesh

    params = _params_from_args(args)
    printer = resolve_printer(params)

    def check_one(item):
        path = Path(item)
        if path.suffix.lower() in MESH_SUFFIXES:
            verdicts = check_mesh(path, nozzle_mm=printer.nozzle_mm, layer_mm=printer.layer_mm).verdicts
            head = f"{path.name} (mesh, measured as it is):"
        else:
            report = make_lithograph(path, params).report
            verdicts = report.legibility.verdicts
            head = f"{path.name} (relief style {report.relief_style}: {report.relief_reason}):"
        return [head] + [f"  {cli_words(v)}" for v in verdicts]  # advice names this command's options

    return _run_each(args.inputs, check_one, args.debug)


def _numbers(text: str, name: str) -> list[float]:
    from ..errors import ParameterError

    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ParameterError(f"{name}: give numbers in mm separated by commas, for example 0.5,0.7,0.9; got {text!r}.") from None
    if not values:
        raise ParameterError(f"{name}: give at least one number in mm.")
    return values


def cmd_braille_plate(args) -> int:
    from ..export import save_mesh
    from ..export.files import write_text
    from ..tactile.furniture import braille_test_plate

    heights = _numbers(args.heights, "--heights")
    diameters = _numbers(args.diameters, "--diameters")
    mesh, rows, _ = braille_test_plate(args.text, args.braille_table, heights, diameters_mm=diameters)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    key = "; ".join(f"row {i + 1}: dots {h:g} mm high, {d:g} mm across" for i, (h, d) in enumerate(rows))
    description = (
        f"A braille test plate. Each of its {len(rows)} rows starts with its number in braille, then reads "
        f"'{args.text}'. {key}. The cut corner is at the top right."
    )
    written = [save_mesh(mesh, out / f"braille-test-plate.{fmt.strip()}", {"title": "TAMP-OS braille test plate", "description": description})
               for fmt in args.formats.split(",")]
    written.append(write_text(out / "braille-test-plate.description.txt", description + "\n"))
    print(f"braille test plate: {len(rows)} rows, {mesh.n_triangles:,} triangles; wrote {', '.join(p.name for p in written)}")
    print(description)
    return EXIT_OK


def _pixel_xy(s, scale) -> list[float] | None:
    """[x, y] pixel size in metres: the vendor reader's pair when the scale is the file's own, else x twice."""
    if not scale.metres:
        return None
    pair = (s.metadata.get("vendor") or {}).get("pixel_size_m")
    if pair and abs(pair[0] - scale.metres) <= 1e-6 * scale.metres:
        return [float(pair[0]), float(pair[1])]
    return [scale.metres, scale.metres]


def _file_axes_lines(s) -> list[str]:
    """'axes: 3 scenes, T 20, C 2, Z 128', 'channel names: DAPI (450 nm), GFP', 'z step: 6 µm', 'read by: nd2 0.12.0'."""
    from ..units import format_length

    lines = []
    if s.axes:
        words = {"scenes": "scenes", "T": "time points", "C": "channels", "Z": "z slices", "λ": "emission wavelengths (λ)",
                 "Λ": "excitation wavelengths (Λ)"}
        lines.append("axes: " + ", ".join(f"{n} {words.get(a, a)}" for a, n in s.axes.items()))
    vendor = s.metadata.get("vendor") or {}
    names = vendor.get("scene_names") or []
    if len(names) > 1:
        lines.append("scenes: " + ", ".join(f"{i} {name!r}" + (" (this one)" if i == vendor.get("scene") else "")
                                            for i, name in enumerate(names)) + "; choose one with --scene, a number or a name")
    if s.channel_names:
        waves = s.wavelengths_nm or [None] * len(s.channel_names)
        lines.append("channel names: " + ", ".join(
            f"{name} ({w:g} nm)" if w and f"{w:g} nm" not in name else name
            for name, w in zip(s.channel_names, list(waves) + [None] * len(s.channel_names))))
    if s.z_step_m:
        lines.append(f"z step: {format_length(s.z_step_m)}")
    if s.reader:
        lines.append(f"read by: {s.reader}")
    return lines


def cmd_info(args) -> int:
    from ..clean.stage import clean_picture
    from ..errors import TampError
    from ..params import LithoParams, parse_field
    from ..read.image import read_image

    pixel_size_m = LithoParams(pixel_size=args.pixel_size).pixel_size_m if args.pixel_size else None  # as convert reads it
    scene = parse_field("scene", args.scene) if args.scene is not None else None  # a number, or a series name
    try:  # what does not fit this file fails the file (exit 1), as in convert; a malformed option is usage (2)
        picture = read_image(args.image, page=args.page, z_slice=args.slice, channel=args.channel, time=args.time,
                             scene=scene)  # the same size guard as convert
        cleaned = clean_picture(picture, pixel_size_m=pixel_size_m, remove_annotations=True)
    except TampError as exc:
        if args.debug:
            raise
        print(f"error: {cli_words(exc)}", file=sys.stderr)
        return EXIT_FAILED
    plan = _channel_plan(args, scene)
    facts = _info_facts(picture, cleaned, plan)
    if args.json:
        print(json.dumps(facts, indent=2, ensure_ascii=False))
        return EXIT_OK
    _print_info(args, picture.file, cleaned, facts, plan)
    return EXIT_OK


def _info_facts(picture, cleaned, plan) -> dict:
    """What info says about a file, as the JSON it prints with --json."""
    s = picture.file
    scale, crop, found = cleaned.pixel_size, cleaned.band.as_dict(), cleaned.annotations_with_text
    facts = {
        "file": s.path,
        "format": s.format,
        "width_px": s.width,
        "height_px": s.height,
        "dtype": s.dtype,
        "bit_depth": s.bit_depth,
        "channels": s.channel_count,
        "samples_per_pixel": s.channels,
        "channel_names": s.channel_names,
        "wavelengths_nm": s.wavelengths_nm,
        "axes": s.axes,
        "z_step_m": s.z_step_m,
        "reader": s.reader,
        "pages": s.pages,
        "sha256": s.sha256,
        "metadata_found": sorted(k for k in s.metadata if not k.startswith("_")),
        "pixel_size_m": scale.metres,
        "pixel_size_xy_m": _pixel_xy(s, scale),
        "pixel_size_source": scale.provenance,
        "chosen": {k: s.metadata["vendor"].get(k) for k in ("scene", "scene_name", "time", "z", "channels_used")} if "vendor" in s.metadata else None,
        "vendor": s.metadata.get("vendor"),  # the reader's facts with the keys they were read from
        "crop": crop,
        "annotations": [a.describe() for a in found],
        "nonfinite_pixels": s.nonfinite_pixels,
        "transparent_pixels": s.transparent_pixels,
        "notes": s.notes + list(scale.warnings),
        "instrument": cleaned.instrument.as_dict() if cleaned.instrument else None,
    }
    if plan is not None:  # convert prints the channels, not the channel the reader names
        facts["notes"] = [n for n in facts["notes"] if "using channel 0" not in str(n)]
        facts["convert_channels"] = {"why": plan.why, "key": [{"label": e.label, "encoding": e.encoding} for e in plan.key],
                                     "notes": [str(n) for n in plan.notes]}
    return facts


def _print_info(args, s, cleaned, facts: dict, plan) -> None:
    """info's plain text: one line per fact, notes last."""
    from ..lithograph.report import instrument_words
    from ..units import format_length

    scale, crop, found = cleaned.pixel_size, facts["crop"], cleaned.annotations_with_text
    meta_found = facts["metadata_found"]
    # A vendor file's scenes are said on the axes line (a reader's "pages" are its scenes); a TIFF's pages here.
    pages = "" if "vendor" in s.metadata else f", {s.pages} page{'s' if s.pages != 1 else ''}"
    print(f"{Path(args.image).name}: {s.format}, {s.width} × {s.height} pixels, {s.bit_depth}-bit {s.dtype}, "
          f"{s.channel_count} channel{'s' if s.channel_count != 1 else ''}{pages}")
    for line in _file_axes_lines(s):
        print(line)
    print(f"metadata found: {', '.join(meta_found) if meta_found else 'none'}")
    if scale.metres:
        xy = facts["pixel_size_xy_m"]
        across = f" × {format_length(xy[1])} (x × y)" if xy and abs(xy[1] / xy[0] - 1) > 0.005 else ""
        print(f"pixel size: {format_length(scale.metres)}{across}, from {scale.provenance}")
    else:
        print("pixel size: not known (give it with --pixel-size, for example --pixel-size 4.2nm)")
    removed = [f"{crop['top_rows']} rows at the top"] if crop["top_rows"] else []
    removed += [f"{crop['bottom_rows']} rows at the bottom"] if crop["bottom_rows"] else []
    print(f"data band: {' and '.join(removed)} ({crop['source']})" if removed else "data band: none found")
    print(f"annotations to remove: {'; '.join(a.describe() for a in found) if found else 'none found'}")
    if cleaned.instrument:
        print(f"instrument: {instrument_words(cleaned.instrument)}")
    if plan is not None:
        shown = "; ".join(f"{e.label} as {_ENCODING_WORDS.get(e.encoding, e.encoding)}" for e in plan.key)
        print(f"convert: prints {len(plan.key)} channels as textures with a braille key, because {plan.why}: {shown}. "
              f"--channel N prints one channel; --channels off prints the brightness.")
        for note in plan.notes:
            print(f"convert: {cli_words(note)}")
    for note in facts["notes"]:
        print(f"note: {cli_words(note)}")


_ENCODING_WORDS = {"domes": "domes", "ridges": "ridges", "dots": "dots", "plateau": "a plateau"}


def _channel_plan(args, scene):
    """What convert makes of the channels with the same options (lithograph.plan_channels), or None."""
    from ..lithograph.pipeline import plan_channels
    from ..params import LithoParams

    if str(args.channel).strip().lower() != "luminance":
        return None  # one channel asked for: convert prints that one, as the reader says
    params = LithoParams(page=args.page, z_slice=args.slice, time=args.time, scene=scene, pixel_size=args.pixel_size)
    return plan_channels(args.image, params)


if __name__ == "__main__":
    sys.exit(run())
