"""The dock widget: choose the layers, the printer, the level of detail, a braille caption, the
relief style, the files and their folder; "Make print" runs the same convert() as `tamp-os convert`
on a worker thread (napari's thread_worker), with a progress bar and a Cancel button, then adds
the relief (heights in mm) and the mesh beside the picture and shows the print's description.
Every control has a label a screen reader says and is reached with Tab."""

from __future__ import annotations

import threading
from pathlib import Path

from magicgui.widgets import ComboBox, Container, FileEdit, Label, LineEdit, ProgressBar, PushButton, Select, TextEdit
from qtpy.QtCore import QObject, Signal

from ..errors import TampError, is_decision
from ..lithograph.pipeline import STAGES
from ..printing.printers import PRESETS
from .controls import (CONTROLS, FORMAT_CHOICES, STYLE_WORDS, advice_words, label, params_for, printer_names, result_words,
                       widget_words)
from .layers import check_layer, layer_picture, print_source

STEPS = (*STAGES, "save")
STEP_WORDS = {"read": "Reading the picture", "annotations": "Removing annotations", "preprocess": "Preparing the picture",
              "relief": "Designing the relief", "legibility": "Checking what a finger finds", "mesh": "Making the mesh",
              "scale bar wait": "Reading the scale bar", "tactile": "Adding braille, scale bar and corner",
              "agreement": "Comparing the print with the picture", "save": "Writing the files"}
DEFAULT_OUTPUT = Path.home() / "tamp-os prints"


class Cancelled(Exception):
    """Raised at a stage boundary in the worker when Cancel was pressed (nothing is written)."""


class _Stages(QObject):
    """Carries each stage's name from the worker thread to the widget (a queued Qt signal)."""

    begun = Signal(str)


class PrintWidget(Container):
    """The "Make a tactile print" dock widget (npe2 widget contribution)."""

    def __init__(self, napari_viewer):
        self.viewer = napari_viewer
        self.layers = Select(label=label("layers"), choices=self._layer_choices, allow_multiple=True)
        self.printer = ComboBox(label=label("printer"), choices=printer_names(), value="standard")
        self.preset = ComboBox(label=label("preset"), choices=list(PRESETS), value="medium")
        self.caption = LineEdit(label=label("caption"))
        self.relief_style = ComboBox(label=label("relief_style"), choices=[(w, k) for k, w in STYLE_WORDS.items()], value="auto")
        self.formats = ComboBox(label=label("formats"), choices=list(FORMAT_CHOICES), value=FORMAT_CHOICES[0][1])
        self.output = FileEdit(label=label("output"), mode="d", value=DEFAULT_OUTPUT)
        self.make = PushButton(text=label("make"), label="")
        self.cancel = PushButton(text=label("cancel"), label="", enabled=False)
        self.progress = ProgressBar(label=label("progress"), min=0, max=len(STEPS), value=0)
        self.message = Label(label=label("message"), value="")
        self.description = TextEdit(label=label("description"), value="")
        super().__init__(widgets=[self.layers, self.printer, self.preset, self.caption, self.relief_style, self.formats,
                                  self.output, self.make, self.cancel, self.progress, self.message, self.description])
        self._label_controls()
        self.worker = None
        self.conversion = None  # the last print made (for tests and notebooks)
        self._cancel = threading.Event()
        self._stages = _Stages()
        self._stages.begun.connect(self._stage_begun)
        self.make.changed.connect(self.make_print)
        self.cancel.changed.connect(self.cancel_print)
        napari_viewer.layers.events.inserted.connect(self._refresh)
        napari_viewer.layers.events.removed.connect(self._refresh)
        napari_viewer.layers.selection.events.changed.connect(self._follow_selection)
        self._follow_selection()

    def _label_controls(self) -> None:
        """Each control's accessible name and help (what a screen reader says), and Tab reaches it."""
        from qtpy.QtCore import Qt
        from qtpy.QtWidgets import QLineEdit

        self.description.native.setReadOnly(True)
        self.message.native.setWordWrap(True)
        self.message.native.setTextInteractionFlags(Qt.TextSelectableByKeyboard | Qt.TextSelectableByMouse)
        self.message.native.setFocusPolicy(Qt.StrongFocus)
        for name in ("layers", "printer", "preset", "caption", "relief_style", "formats", "output", "make", "cancel",
                     "progress", "message", "description"):
            control = getattr(self, name)
            words, help_text = CONTROLS[name]
            control.tooltip = help_text
            control.native.setAccessibleName(words)
            control.native.setAccessibleDescription(help_text)
            for inner in control.native.findChildren(QLineEdit):  # the folder's text box inside its row
                inner.setAccessibleName(words)
        self.progress.native.setFocusPolicy(Qt.TabFocus)

    def _layer_choices(self, _widget=None) -> list:
        from napari.layers import Image, Labels

        return [(layer.name, layer) for layer in self.viewer.layers if isinstance(layer, (Image, Labels))]

    def _refresh(self, _event=None) -> None:
        self.layers.reset_choices()
        self._follow_selection()

    def _follow_selection(self, _event=None) -> None:
        """The layers to print follow the layers selected in the viewer (image and labels ones)."""
        offered = [layer for _, layer in self._layer_choices()]
        chosen = [layer for layer in offered if layer in self.viewer.layers.selection]
        if chosen:
            self.layers.value = chosen

    def say(self, text: str) -> None:
        self.message.value = text
        self.message.native.setAccessibleDescription(text)

    def make_print(self, _value=None) -> None:
        """Check the layers here (one clear message), then make the print on a worker thread."""
        try:
            pictures = [layer_picture(layer) for layer in self.layers.value]
            if not pictures:
                print_source(pictures, self.output.value)  # says which control to use
            for picture in pictures:
                check_layer(picture)
            settings = dict(printer=self.printer.value, preset=self.preset.value, caption=self.caption.value,
                            relief_style=self.relief_style.value, formats=tuple(self.formats.value))
            params_for(**settings)  # a bad setting is said now, by its control
        except TampError as exc:
            self.say(widget_words(exc))
            return
        from napari.qt.threading import create_worker

        self._cancel.clear()
        self.worker = create_worker(make_in_worker, pictures, settings=settings, out_dir=Path(self.output.value), heard=self._heard, _start_thread=False,
                                    _connect={"returned": self._made, "errored": self._failed, "finished": self._idle})
        self.make.enabled, self.cancel.enabled, self.progress.value = False, True, 0
        self.description.value = ""
        self.say("Making the print…")
        self.worker.start()

    def cancel_print(self, _value=None) -> None:
        self._cancel.set()
        self.say("Cancelling at the next step…")

    def _heard(self, stage: str) -> None:  # on the worker thread
        if self._cancel.is_set():
            raise Cancelled()
        self._stages.begun.emit(stage)

    def _stage_begun(self, stage: str) -> None:
        if stage in STEPS:
            self.progress.value = STEPS.index(stage) + 1
        self.say(f"{STEP_WORDS.get(stage, stage)}…")
        if stage == "save":
            self.cancel.enabled = False  # the files are being written: they are finished, never cut

    def _made(self, made) -> None:
        source, conversion = made
        self.conversion = conversion
        self.progress.value = len(STEPS)
        printed = list(self.layers.value)
        for each in conversion.prints:
            add_print_layers(self.viewer, each, beside=printed)
        self.viewer.layers.selection = set(printed)  # napari selects what it adds: keep the picture chosen, not its relief
        warnings = [widget_words(w) for each in conversion.prints for w in each.report.warnings if not is_decision(w)]
        folder = conversion.written[0].parent if conversion.written else self.output.value
        self.say(" ".join([result_words(conversion.summary(), folder), *warnings]))
        self.description.value = description_text(source, conversion)

    def _failed(self, exc: Exception) -> None:
        if isinstance(exc, Cancelled):
            self.say("Cancelled before any file was written.")
        elif isinstance(exc, TampError):
            self.say(widget_words(exc))
        else:
            self.say(f"The print could not be made: {exc}. Nothing was written.")

    def _idle(self) -> None:
        self.make.enabled, self.cancel.enabled = True, False


def make_in_worker(pictures, *, settings: dict, out_dir: Path, heard):
    """The worker's job: the source the layers give, then convert() as the command line runs it."""
    from ..lithograph.products import convert
    from ..lithograph.pipeline import stages_heard_by

    source = print_source(pictures, out_dir)
    params = params_for(**settings, pixel_size_m=source.pixel_size_m, channel=source.channel)
    with stages_heard_by(heard):
        return source, convert(source.source, params, out_dir, stem=source.stem).conversions[0]  # the widget makes reliefs


def add_print_layers(viewer, made, *, beside) -> None:
    """The print's heights (an image in mm) and its mesh (a surface in mm), right of the picture."""
    import numpy as np

    litho = made.litho
    name = made.written[0].stem if made.written else "print"
    right = max((float(layer.extent.world[1][-1]) for layer in beside), default=0.0)
    gap = 0.05 * max(right, 1.0)
    mm = litho.layout.mm_per_px
    viewer.add_image(litho.heightmap, name=f"{name} relief (mm)", scale=(mm, mm), units=("millimeter", "millimeter"),
                     translate=(0.0, right + gap), colormap="gray")
    v = litho.mesh.vertices
    depth = float(v[:, 1].max())
    vertices = np.column_stack([v[:, 2], depth - v[:, 1], v[:, 0]])  # napari's (height, row, column): +y is the far edge, row 0
    viewer.add_surface((vertices, np.asarray(litho.mesh.faces), v[:, 2]), name=f"{name} mesh (mm)",
                       units=("millimeter",) * 3, translate=(0.0, 0.0, right + gap), colormap="gray", visible=False)


def description_text(source, conversion) -> str:
    """What the description panel shows: where the picture came from, each print's description file
    (as the reader of the print hears it), and the notes."""
    parts = list(source.said)
    for each in conversion.prints:
        text = next((p.read_text(encoding="utf-8") for p in each.written if p.name.endswith(".description.txt")), "")
        parts += [text.strip()] if text.strip() else []
        parts += [widget_words(n) for n in each.notes()]
        parts += advice_words(each.report)  # the description names no control: the widget's own advice
    parts += [widget_words(n) for n in conversion.layout_notes]
    return "\n\n".join(parts)
