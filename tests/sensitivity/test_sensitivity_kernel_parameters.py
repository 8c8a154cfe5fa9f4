"""Static sensitivities to numbers that enter the kernels nonlinearly: a beam3d member's Poisson ratio, E with G
given, G, its section's b and h (elastic line and continuum), and a penalty contact's geometry (a drum's radius and
centre, the ground's level, a contact thickness), through the kernels' compiled parameter-direction companions.

Reference: Richardson-extrapolated central differences of re-solved scenes (truncation O(h^4); Newton solves to
round-off, whose effect on the differences is ~1e-12 / h relative), against the 1e-6 the static derivatives must
meet. Steps: 1e-3 of the value (a penalty contact point crossing the surface within the step breaks the smooth
h^2 law of the differences; at 1e-3 none does in these scenes)."""
from __future__ import annotations

import copy

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
                     "section": "s", "element": "beam3d", "beam_method": "elastic_line", "torsion": True}],
        "supports": [{"type": "clamp", "member": "beam", "at": "start"}],
        "loads": [{"type": "force", "member": "beam", "at": "end", "value": [20.0, 5.0, -20.0]},
                  {"type": "moment", "member": "beam", "at": "end", "value": [0.0, 3.0, 1.0]}]}
BEAM_G = copy.deepcopy(BEAM)
BEAM_G["materials"]["m"] = {"E": 2e8, "density": 2000.0, "G": 7e7}
CONTINUUM = copy.deepcopy(BEAM)
CONTINUUM["members"][0]["beam_method"] = "continuum"
CONTINUUM_G = copy.deepcopy(BEAM_G)
CONTINUUM_G["members"][0]["beam_method"] = "continuum"
EXPLICIT = copy.deepcopy(BEAM)  # b x h with the section's own area and moments: only the line strain sees them
EXPLICIT["sections"]["s"] = {"area": 6e-4, "Iy": 4.5e-8, "Iz": 2e-8, "J": 4e-8, "b": 0.02, "h": 0.03}
EXPLICIT_I = copy.deepcopy(BEAM)  # I sets Iy = Iz = I and J = 2 I
EXPLICIT_I["sections"]["s"] = {"area": 6e-4, "I": 3e-8, "b": 0.02, "h": 0.03}
DRUM = {"scene": {"name": "drum", "dim": 2, "gravity": [0.0, -9.81]},
        "materials": {"m": {"E": 2e9, "density": 1000.0}},
        "sections": {"s": {"shape": "circle", "diameter": 0.004}},
        "members": [{"name": "rope", "points": [[0, 0], [1, 0]], "elements": 16, "material": "m", "section": "s"}],
        "supports": [{"type": "pin", "member": "rope", "at": "start"}, {"type": "pin", "member": "rope", "at": "end"}],
        "loads": [{"type": "force", "member": "rope", "at": 4, "value": [0.0, -3.0]}],
        "contacts": [{"type": "circle", "member": "rope", "centre": [0.45, -0.18], "radius": 0.2, "stiffness": 1e6,
                      "thickness": 0.002}]}
DRUM3D = copy.deepcopy(DRUM)  # the same over a cylinder of axis y (cable3d, contact_drum with its axis)
DRUM3D["scene"].update(dim=3, gravity=[0.0, 0.0, -9.81])
DRUM3D["members"][0].update(points=[[0, 0, 0], [1, 0, 0]], element="cable3d")
DRUM3D["loads"][0]["value"] = [0.0, 0.0, -3.0]
DRUM3D["contacts"][0].update(centre=[0.45, 0.0, -0.18], axis=[0.0, 1.0, 0.0])
GROUND = {"scene": {"name": "ground", "dim": 2, "gravity": [0.0, -9.81]},
          "materials": {"m": {"E": 1e8, "density": 2000.0}},
          "sections": {"s": {"area": 1e-3, "I": 1e-7}},
          "members": [{"name": "beam", "points": [[0, 0.05], [2, 0.05]], "elements": 10, "material": "m",
                       "section": "s", "bending": True}],
          "supports": [{"type": "clamp", "member": "beam", "at": "start"}],
          "loads": [{"type": "force", "member": "beam", "at": "end", "value": [0.0, -200.0]}],
          "contacts": [{"type": "ground", "member": "beam", "stiffness": 1e5, "hertz": 1e6, "thickness": 0.01,
                        "level": 0.02, "normal": [0.1, 1.0]}]}
ROUND_GROUND = copy.deepcopy(GROUND)  # a round cable on the ground, its thickness the section's radius
ROUND_GROUND["sections"]["s"] = {"shape": "circle", "diameter": 0.03}
del ROUND_GROUND["contacts"][0]["thickness"]
AREA_GROUND = copy.deepcopy(GROUND)
del AREA_GROUND["contacts"][0]["thickness"]
BEAM_GROUND = copy.deepcopy(CONTINUUM)  # a beam3d on the ground, thickness h/2 from its section
BEAM_GROUND["members"][0]["points"] = [[0, 0, 0.02], [1, 0, 0.02]]
BEAM_GROUND["loads"] = [{"type": "force", "member": "beam", "at": "end", "value": [0.0, 5.0, -200.0]}]
BEAM_GROUND["contacts"] = [{"type": "ground", "member": "beam", "stiffness": 1e6, "level": 0.0}]


def solved(doc):
    scene, _ = scene_from_dict(doc)
    r = solve_static(scene)
    assert r.success
    return scene, r


def outputs(r):
    cf = r.constraint_forces
    return np.r_[r.x, r.potential, np.concatenate([np.asarray(cf[k]) for k in sorted(cf)])]


def check(doc, path, rel=1e-3):
    scene, r = solved(doc)
    S = StaticSensitivity(scene, r, doc)
    d = S.derivative(path)
    exact = np.r_[S.dx(path), d["potential"],
                  np.concatenate([np.asarray(d["constraint_forces"][k]) for k in sorted(d["constraint_forces"])])]
    v = get_parameter(doc, path)
    h = rel * abs(v)

    def D(s):
        return (outputs(solved(with_parameter(doc, path, v + s))[1]) -
                outputs(solved(with_parameter(doc, path, v - s))[1])) / (2 * s)
    fd = (4 * D(h / 2) - D(h)) / 3
    n = len(r.x)
    assert abs(v) * np.linalg.norm(fd[:n]) > 1e-6 * np.linalg.norm(r.x)  # (p moves the equilibrium: not 0 = 0)
    for part in (slice(0, n), slice(n, n + 1), slice(n + 1, None)):
        assert np.linalg.norm(exact[part] - fd[part]) <= 1e-6 * np.linalg.norm(fd[part]), (path, part)
    return r, d


@pytest.mark.parametrize("doc, path", [
    (BEAM, "materials.m.poisson"), (BEAM, "sections.s.b"), (BEAM, "sections.s.h"), (BEAM_G, "materials.m.E"),
    (BEAM_G, "materials.m.G"), (EXPLICIT, "sections.s.b"), (EXPLICIT, "sections.s.area"),
    (EXPLICIT, "sections.s.Iy"), (EXPLICIT, "sections.s.Iz"), (EXPLICIT, "sections.s.J"), (EXPLICIT_I, "sections.s.I"), (CONTINUUM, "materials.m.E"),
    (CONTINUUM, "materials.m.poisson"), (CONTINUUM, "sections.s.h"), (CONTINUUM_G, "materials.m.E")])
def test_beam_parameters(doc, path):
    check(doc, path)


@pytest.mark.parametrize("doc, path", [
    (DRUM, "contacts[0].radius"), (DRUM, "contacts[0].centre[0]"), (DRUM, "contacts[0].centre[1]"),
    (DRUM, "contacts[0].thickness"), (DRUM3D, "contacts[0].radius"), (DRUM3D, "contacts[0].centre[2]"),
    (GROUND, "contacts[0].level"), (GROUND, "contacts[0].normal[0]"), (GROUND, "contacts[0].normal[1]"), (GROUND, "contacts[0].thickness"),
    (BEAM_GROUND, "sections.s.h"), (ROUND_GROUND, "sections.s.diameter"), (AREA_GROUND, "sections.s.area")])
def test_contact_geometry(doc, path):
    r, d = check(doc, path)
    assert r.energies["contact"] > 0  # (the member presses on the obstacle: the derivative is not trivially 0)
