"""A front end hears each stage of convert() begin (its progress bar), and an exception its
listener raises stops the work there: before "save", nothing is written (its Cancel button)."""

from __future__ import annotations

import numpy as np
import pytest

from tamp_os.lithograph.convert import convert
from tamp_os.lithograph.pipeline import STAGES, stages_heard_by
from tamp_os.params import LithoParams

pytestmark = pytest.mark.timeout(300)


class Stop(Exception):
    pass


def ramp() -> np.ndarray:
    return np.tile(np.linspace(0, 255, 80, dtype=np.float32), (60, 1))


def test_every_stage_is_heard_in_order_then_save(tmp_path):
    heard: list[str] = []
    with stages_heard_by(heard.append):
        done = convert(ramp(), LithoParams(preset="low"), tmp_path, stem="ramp")
    assert heard[-1] == "save" and heard[:-1] == [s for s in STAGES if s in heard[:-1]]
    assert set(heard[:-1]) == set(STAGES)
    assert [p.name for p in done.written] == ["ramp.stl", "ramp.description.txt", "ramp.tamp.json"]
    heard.clear()
    convert(ramp(), LithoParams(preset="low"), tmp_path / "again", stem="ramp")
    assert heard == []  # outside the block nobody listens


@pytest.mark.parametrize("at", ["read", "mesh", "save"])
def test_a_listener_that_raises_stops_before_any_file(tmp_path, at):
    def listener(stage):
        if stage == at:
            raise Stop(stage)

    with stages_heard_by(listener), pytest.raises(Stop):
        convert(ramp(), LithoParams(preset="low"), tmp_path, stem="ramp")
    assert not list(tmp_path.iterdir())
