"""Scene parameters by TOML path: what they name, what they refuse."""
from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.sensitivity import get_parameter, parse_path, with_parameter

SCENE = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "catenary.toml"


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


def test_node_force_sensitivity_matches_central_differences(doc):
    """dx*/df from the exact tangent against re-solved statics at f +- h. The central difference errs by
    h^2 x'''/6 (truncation) plus (solve tolerance)/h (round-off); h = 1e-2 N, small beside the 20 N load
    that sets the response's curvature in f, puts both far below 1e-6 relative (measured: 1.8e-7 at h = 0.1 N,
    100x less at 1e-2 N: the h^2 law)."""
    import numpy as np
    from ancf_sym.modal.linearize import linearize
    from ancf_sym.sensitivity.loads import load_value_sensitivity, node_force_sensitivity
    from ancf_sym.statics import solve_static

    def solved(f: float):
        d = dict(doc, members=[dict(doc["members"][0], elements=8)],
                 loads=[{"type": "force", "member": "rope", "at": 4, "value": [f, -20.0]}])
        scene, _ = scene_from_dict(d)
        return scene, solve_static(scene)

    scene, res = solved(0.0)
    assert res.success
    lin = linearize(scene, res, damping_matrix=False)
    dx = node_force_sensitivity(lin, "rope", 4, 0)
    d = dict(doc, loads=[{"type": "force", "member": "rope", "at": 4, "value": [0.0, -20.0]},
                         {"type": "distributed", "member": "rope", "value": [0.0, -1.0]}])
    assert np.array_equal(load_value_sensitivity(d, lin, "loads[0].value[0]"), dx)  # the same column by path
    with pytest.raises(ValueError, match="'distributed' load"):
        load_value_sensitivity(d, lin, "loads[1].value[1]")
    h = 1e-2
    fd = (solved(h)[1].x - solved(-h)[1].x) / (2 * h)
    assert np.linalg.norm(dx - fd) <= 1e-6 * np.linalg.norm(fd)
