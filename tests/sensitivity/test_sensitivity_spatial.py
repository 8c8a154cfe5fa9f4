"""Static sensitivities of spatial members: a beam3d elastic-line cantilever (stiffness coefficients EA, EIy, EIz,
GJ all proportional to E; moments about the section axes) and a cable3d with bending, against Richardson
differences (truncation O(h^4), round-off (Newton at round-off)/h: far below 1e-6 at the steps chosen: 1e-2 of
the value; the beam's response to its loads bends faster (a step of 1e-1 misses by 1e-1, 1e-2 by 1e-6), so
1e-3 of the value there)."""
from __future__ import annotations

import numpy as np
import pytest

from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.model_derivative import ParameterError
from ancf_sym.sensitivity.static import StaticSensitivity
from ancf_sym.statics import solve_static

BEAM = {"scene": {"name": "b", "dim": 3, "gravity": [0.0, 0.0, -9.81]},
        "materials": {"m": {"E": 2e8, "density": 2000.0, "poisson": 0.3}},
        "sections": {"s": {"shape": "rectangle", "b": 0.02, "h": 0.03}},
        "members": [{"name": "beam", "points": [[0, 0, 0], [1, 0, 0]], "elements": 4, "material": "m",
                     "section": "s", "element": "beam3d", "beam_method": "elastic_line"}],
        "supports": [{"type": "clamp", "member": "beam", "at": "start"}],
        "loads": [{"type": "force", "member": "beam", "at": "end", "value": [0.0, 5.0, -20.0]},
                  {"type": "moment", "member": "beam", "at": "end", "value": [0.0, 3.0, 1.0]}]}
CABLE = {"scene": {"name": "c", "dim": 3, "gravity": [0.0, 0.0, -9.81]},
         "materials": {"m": {"E": 2e9, "density": 2000.0}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
         "members": [{"name": "c", "points": [[0, 0, 0], [1, 0.2, 0]], "elements": 6, "material": "m",
                      "section": "s", "element": "cable3d", "bending": True}],
         "supports": [{"type": "clamp", "member": "c", "at": "start"}, {"type": "pin", "member": "c", "at": "end"}],
         "loads": [{"type": "force", "member": "c", "at": 3, "value": [0.0, 5.0, -20.0]}]}


def solved(doc):
    scene, _ = scene_from_dict(doc)
    r = solve_static(scene)
    assert r.success
    return scene, r


@pytest.mark.parametrize("doc, path, rel", [
    (BEAM, "materials.m.E", 1e-2), (BEAM, "materials.m.density", 1e-2), (BEAM, "scene.gravity[2]", 1e-2),
    (BEAM, "loads[0].value[1]", 1e-3), (BEAM, "loads[1].value[1]", 1e-3), (BEAM, "loads[1].value[2]", 1e-3),
    (CABLE, "materials.m.E", 1e-2), (CABLE, "sections.s.I", 1e-2), (CABLE, "sections.s.area", 1e-2),
    (CABLE, "scene.gravity[2]", 1e-2), (CABLE, "loads[0].value[2]", 1e-2)])
def test_spatial_sensitivity(doc, path, rel):
    scene, r = solved(doc)
    dx = StaticSensitivity(scene, r, doc).dx(path)
    v = get_parameter(doc, path)
    h = rel * abs(v)

    def D(s):
        return (solved(with_parameter(doc, path, v + s))[1].x - solved(with_parameter(doc, path, v - s))[1].x) / (2 * s)
    fd = (4 * D(h / 2) - D(h)) / 3
    assert np.linalg.norm(dx - fd) <= 1e-6 * np.linalg.norm(fd)


@pytest.mark.parametrize("change, path, message", [
    ({"sections": {"s": {"shape": "rectangle", "b": 0.03, "h": 0.03}}}, "sections.s.b", "kink at b = h"),
    ({"members": [dict(BEAM["members"][0], gauss=3)]}, "materials.m.poisson", "no compiled parameter-direction")])
def test_beam_refusals(change, path, message):
    """What stays refused: the square rectangle's J (max/min of b, h swap), and a kernel of another Gauss order
    than the one its direction companion is compiled for."""
    doc = dict(BEAM, **change)
    scene, r = solved(doc)
    with pytest.raises(ParameterError, match=message):
        StaticSensitivity(scene, r, doc).dx(path)
