"""Sensitivities where rows beside the supports carry forces: a rope over a drum in exact (unilateral) contact, a
beam on a penalty ground, a rigid body pinned to a rope. Reference: Richardson-extrapolated central differences of
re-solved scenes (truncation O(h^4) at h = 1e-2 |p|; exact contact is solved by IPOPT to a complementarity of about
1e-8, whose effect on the differences stays below 1e-7 relative here: the active set does not change within +-h),
against the 1e-6 the derivatives must meet."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.model_derivative import ParameterError
from ancf_sym.sensitivity.static import StaticSensitivity
from ancf_sym.statics import solve_static

DRUM = {"scene": {"name": "drum", "dim": 2, "gravity": [0.0, -9.81]},
        "materials": {"m": {"E": 2e9, "density": 1000.0}},
        "sections": {"s": {"shape": "circle", "diameter": 0.004}},
        "members": [{"name": "rope", "points": [[0, 0], [1, 0]], "elements": 16, "material": "m", "section": "s"}],
        "supports": [{"type": "pin", "member": "rope", "at": "start"}, {"type": "pin", "member": "rope", "at": "end"}],
        "loads": [{"type": "force", "member": "rope", "at": 4, "value": [0.0, -3.0]}],
        "contacts": [{"type": "circle", "member": "rope", "centre": [0.5, -0.18], "radius": 0.2, "method": "exact"}]}
GROUND = {"scene": {"name": "ground", "dim": 2, "gravity": [0.0, -9.81]},
          "materials": {"m": {"E": 1e8, "density": 2000.0}},
          "sections": {"s": {"area": 1e-3, "I": 1e-7}},
          "members": [{"name": "beam", "points": [[0, 0.05], [2, 0.05]], "elements": 10, "material": "m",
                       "section": "s", "bending": True}],
          "supports": [{"type": "clamp", "member": "beam", "at": "start"}],
          "loads": [{"type": "force", "member": "beam", "at": "end", "value": [0.0, -200.0]}],
          "contacts": [{"type": "ground", "member": "beam", "stiffness": 1e5, "thickness": 0.0, "gauss": 5}]}
BODY = {"scene": {"name": "body", "dim": 2, "gravity": [0.0, -9.81]},
        "materials": {"m": {"E": 1e9, "density": 1500.0}},
        "sections": {"s": {"area": 1e-4}},
        "members": [{"name": "rope", "points": [[0, 0], [1.0, -1.0]], "elements": 8, "material": "m", "section": "s",
                     "bending": False}],
        "supports": [{"type": "pin", "member": "rope", "at": "start"}],
        "bodies": [{"name": "tip", "mass": 5.0, "inertia": 0.1, "position": [1.0, -1.0], "pin": [["rope", "end"]],
                    "revolute": [1.5, -1.0]}]}


def outputs(doc):
    scene, _ = scene_from_dict(doc)
    r = solve_static(scene)
    assert r.success
    cf = r.constraint_forces
    return r, np.r_[r.x, r.potential, np.concatenate([np.asarray(cf[k]) for k in sorted(cf)])]


def check(doc, path, rel: float = 1e-2):
    res, _ = outputs(doc)
    S = StaticSensitivity(scene_from_dict(doc)[0], res, doc)
    d = S.derivative(path)
    exact = np.r_[S.dx(path), d["potential"],
                  np.concatenate([np.asarray(d["constraint_forces"][k]) for k in sorted(d["constraint_forces"])])]
    v = get_parameter(doc, path)
    h = rel * abs(v)

    def D(s):
        return (outputs(with_parameter(doc, path, v + s))[1] - outputs(with_parameter(doc, path, v - s))[1]) / (2 * s)
    fd = (4 * D(h / 2) - D(h)) / 3
    n = len(res.x)
    for part in (slice(0, n), slice(n, n + 1), slice(n + 1, None)):
        assert np.linalg.norm(exact[part] - fd[part]) <= 1e-6 * np.linalg.norm(fd[part]), (path, part)
    return res, d


@pytest.mark.parametrize("path", ["materials.m.E", "scene.gravity[1]", "loads[0].value[1]"])
def test_exact_drum_contact(path):
    """The points held on the drum are rows of the implicit function theorem; their forces' derivatives are the
    rows' multipliers (zero at points that lift off)."""
    res, d = check(DRUM, path)
    f = np.asarray(res.constraint_forces["contact"])
    df = d["constraint_forces"]["contact"]
    assert np.any(f > 1.0) and np.any(df != 0) and np.all(df[f < 1e-6 * f.max()] == 0)


def test_diameter_with_section_thickness_refused():
    res, _ = outputs(DRUM)
    S = StaticSensitivity(scene_from_dict(DRUM)[0], res, DRUM)
    with pytest.raises(ParameterError, match="exact contact on member .rope. takes its thickness from the section"):
        S.derivative("sections.s.diameter")


@pytest.mark.parametrize("path", ["contacts[0].stiffness", "materials.m.E"])
def test_penalty_ground(path):
    """The penalty law acts at Gauss points, each in contact or not: the equilibrium is smooth in p only while no
    point crosses the surface. Here one does within a 1 % change of the stiffness (the differences at 1e-2 then
    disagree by 8e-3 with a smooth derivative, at 1e-3 by 4e-7, at 1e-4 by 4e-9: the h^2 law of a smooth
    function), so the steps are 1e-3 of the value."""
    res, d = check(GROUND, path, rel=1e-3)
    assert res.energies["contact"] > 0  # (the beam presses into the ground)


@pytest.mark.parametrize("path", ["bodies[0].mass", "scene.gravity[1]", "sections.s.area"])
def test_planar_body(path):
    check(BODY, path)


TENSION = {"scene": {"name": "t", "dim": 2, "gravity": [0.0, -9.81]},
           "materials": {"m": {"E": 5e8, "density": 3000.0}}, "sections": {"s": {"area": 1e-4, "I": 2e-9}},
           "members": [{"name": "rod", "points": [[0, 0], [1.5, 0]], "elements": 8, "material": "m", "section": "s",
                        "bending": True}],
           "supports": [{"type": "clamp", "member": "rod", "at": "start"}],
           "loads": [{"type": "tension", "member": "rod", "at": "end", "value": 40.0},
                     {"type": "distributed", "member": "rod", "value": [1.0, -2.0]}]}


@pytest.mark.parametrize("path", ["loads[0].value", "loads[1].value[0]", "sections.s.I"])
def test_tension_and_distributed_loads(path):
    """A prescribed end tension (a dead force along the reference tangent) and a distributed load."""
    check(TENSION, path)


def test_penalty_support():
    """A penalty pin: its spring force k c differentiates through dx (k fixed); a stiffness parameter, which scales
    k (EA / 1 m), is refused by name."""
    pen = copy.deepcopy(TENSION)
    pen["supports"] = [{"type": "clamp", "member": "rod", "at": "start", "method": "penalty"}]
    check(pen, "materials.m.density")
    res, _ = outputs(pen)
    with pytest.raises(ParameterError, match="penalty supports and joints take their stiffness"):
        StaticSensitivity(scene_from_dict(pen)[0], res, pen).derivative("materials.m.E")
