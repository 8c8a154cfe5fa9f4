"""Scene parameters by TOML path: what they name, what they refuse."""
from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from ancf_sym.scene_toml import scene_from_dict
from ancf_sym.sensitivity import get_parameter, parse_path, with_parameter

SCENE = Path(__file__).resolve().parents[1] / "examples" / "scenes" / "catenary.toml"


@pytest.fixture()
def doc() -> dict:
    return tomllib.loads(SCENE.read_text())


def test_parse_path_keys():
    assert parse_path("loads[1].value[0]").keys == ("loads", 1, "value", 0)
    assert parse_path("members[0].points[1][0]").keys == ("members", 0, "points", 1, 0)
    with pytest.raises(ValueError, match="malformed part"):
        parse_path("materials..E")


def test_numbers_by_path(doc):
    assert get_parameter(doc, "materials.rubber.E") == 50e6
    assert get_parameter(doc, "scene.gravity[1]") == -9.81
    assert get_parameter(doc, "sections.rope.diameter") == 0.01
    assert get_parameter(doc, "members[0].points[1][0]") == 10.0


@pytest.mark.parametrize("path, message", [
    ("materials.steel.E", r"materials.steel names nothing \(keys there: rubber\)"),
    ("members[3].prestrain", "has 1 entries, index 3 names nothing"),
    ("members[0].prestrain", "members\\[0\\].prestrain names nothing"),
    ("members[0].elements", "= 40: a count"),
    ("members[0].axial", "= 'biot': a choice"),
    ("members[0].bending", "= False: a choice"),
    ("scene.dim", "= 2: a count"),
    ("scene.gravity", "names a list, not one number"),
])
def test_refused_paths_name_themselves(doc, path, message):
    with pytest.raises((KeyError, ValueError), match=message) as info:
        get_parameter(doc, path)
    assert repr(path) in str(info.value)


def test_with_parameter_changes_the_built_scene_only(doc):
    changed = with_parameter(doc, "materials.rubber.E", 60e6)
    assert doc["materials"]["rubber"]["E"] == 50e6  # the original document is untouched
    scene, _ = scene_from_dict(changed)
    assert scene.members["rope"].material.E == 60e6
