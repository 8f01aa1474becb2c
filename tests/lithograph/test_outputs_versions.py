"""outputs.dependency_versions reads a package's version from its metadata's header lines (faster than
importlib.metadata.version, which parses the whole file): it must give the same text for every package."""

from __future__ import annotations

from importlib.metadata import distributions, version

import pytest

from tamp_os.lithograph.outputs import _version_of, dependency_versions

pytestmark = pytest.mark.timeout(120)


def test_header_version_equals_importlib_for_every_installed_distribution():
    checked = 0
    for dist in distributions():
        assert _version_of(dist) == dist.version, dist.metadata["Name"]
        checked += 1
    assert checked > 20  # the venv holds the project's dependencies and theirs


def test_recipe_versions_are_importlibs():
    found = dependency_versions()
    assert {"numpy", "scipy", "manifold3d"} <= set(found) and "lib3mf" not in found  # lib3mf no longer writes the 3MF
    for name, text in found.items():
        assert text == "not installed" or text == version(name)
