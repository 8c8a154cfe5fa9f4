"""Frequency sensitivities with exact (unilateral) ground and drum contact: the points held at the equilibrium are rows of the
implicit function theorem and of the modes; against central differences of re-solved scenes where the active set
does not change, and refused where a point touches without pressing.

Reference: Richardson-extrapolated central differences (truncation O(h^4) at h = 1e-2 |p|). Exact contact is solved
by IPOPT, whose barrier leaves forces mu / g at the free points; with the free points' gaps here at >= 7 mm (relative
3.5e-3) those forces are ~1e-9 N and move the differences by ~1e-8 relative, far below the 1e-6 the derivatives must
meet; a missing contact row (the pressed point free to move in the static sensitivity) errs by O(1)."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.modal import modal_analysis
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.api import sensitivities
from ancf_sym.sensitivity.contact_state import ContactStateError
from ancf_sym.statics import solve_static

# a taut cable 0.1 m above the ground, pushed onto it at its middle by a point load: held at the two contact points
# beside the loaded node, free elsewhere
PRESSED = {"scene": {"name": "pressed", "dim": 2, "gravity": [0.0, -9.81]},
           "materials": {"m": {"E": 2e9, "density": 7800.0}},
           "sections": {"s": {"area": 1e-5, "I": 1e-11}},
           "members": [{"name": "c", "points": [[0, 0.1], [2, 0.1]], "elements": 10, "material": "m",
                        "section": "s", "bending": True, "prestrain": 1e-3}],
           "supports": [{"type": "pin", "member": "c", "at": "start"}, {"type": "pin", "member": "c", "at": "end"}],
           "loads": [{"type": "force", "member": "c", "at": 5, "value": [0.0, -100.0]}],
           "contacts": [{"type": "ground", "member": "c", "method": "exact", "thickness": 0.0, "gauss": 3}]}
MODES = 4


def frequencies(doc) -> np.ndarray:
    return modal_analysis(scene_from_dict(doc)[0], modes=MODES).frequencies


def richardson(f, doc, path):
    v = get_parameter(doc, path)
    h = 1e-2 * abs(v)
    D = lambda s: (f(with_parameter(doc, path, v + s)) - f(with_parameter(doc, path, v - s))) / (2 * s)
    return (4 * D(h / 2) - D(h)) / 3


@pytest.fixture(scope="module")
def pressed():
    paths = ["loads[0].value[1]", "materials.m.density", "scene.gravity[1]", "materials.m.E"]
    return paths, sensitivities(PRESSED, paths, modes=MODES)


def test_the_cable_is_held_at_two_points(pressed):
    r = solve_static(scene_from_dict(PRESSED)[0])
    f = np.asarray(r.constraint_forces["contact"])
    assert np.sum(f > 1e-3 * f.max()) == 2 and f.max() > 10.0  # (two points carry the load's part, > 10 N each)


@pytest.mark.parametrize("k", range(4))
def test_frequency_sensitivity_with_exact_contact(pressed, k):
    paths, out = pressed
    path = paths[k]
    fd = richardson(frequencies, PRESSED, path)
    got = np.asarray(out[path]["frequencies"])
    assert np.linalg.norm(got - fd) <= 1e-6 * np.linalg.norm(fd), (path, got, fd)
    # the held points' forces change with the parameter: the rows' multipliers
    assert np.any(np.asarray(out[path]["constraint_forces"]["contact"]) != 0)


def test_untouched_exact_contact_leaves_the_modes_free():
    """Where nothing touches, every contact force is at IPOPT's barrier level: no point is held, the frequencies are
    those without the contact (measured against the reactions, not against the largest barrier force)."""
    doc = copy.deepcopy(PRESSED)
    doc["loads"][0]["value"] = [0.0, -10.0]  # (the cable stays 9 cm above the ground)
    free = copy.deepcopy(doc)
    del free["contacts"]
    f_contact, f_free = frequencies(doc), frequencies(free)
    # (IPOPT's barrier forces ~1e-10 N against a tension of ~30 N: a relative effect far below 1e-6)
    assert np.allclose(f_contact, f_free, rtol=1e-6)
    out = sensitivities(doc, ["loads[0].value[1]"], modes=MODES)
    fd = richardson(frequencies, doc, "loads[0].value[1]")
    got = np.asarray(out["loads[0].value[1]"]["frequencies"])
    assert np.linalg.norm(got - fd) <= 1e-6 * np.linalg.norm(fd)


def test_touching_without_pressing_is_refused():
    """A beam lying flat on the ground, its contact points denser than its coordinates: many points sit at zero gap
    with zero force (the active set changes one-sidedly there), named in the refusal."""
    doc = {"scene": {"name": "flat", "dim": 2, "gravity": [0.0, -9.81]},
           "materials": {"m": {"E": 1e8, "density": 2000.0}}, "sections": {"s": {"area": 1e-3, "I": 1e-7}},
           "members": [{"name": "beam", "points": [[0, 0.05], [2, 0.05]], "elements": 10, "material": "m",
                        "section": "s", "bending": True}],
           "supports": [{"type": "clamp", "member": "beam", "at": "start"}],
           "loads": [{"type": "force", "member": "beam", "at": "end", "value": [0.0, -200.0]}],
           "contacts": [{"type": "ground", "member": "beam", "method": "exact", "thickness": 0.0}]}
    with pytest.raises(ContactStateError, match="touch without pressing.*member 'beam' element"):
        sensitivities(doc, ["materials.m.E"], modes=3)


# a rope pulled over a drum, held at four contact points on its arc (the statics' drum case, the drum raised)
DRUM = {"scene": {"name": "drum", "dim": 2, "gravity": [0.0, -9.81]},
        "materials": {"m": {"E": 2e9, "density": 1000.0}},
        "sections": {"s": {"shape": "circle", "diameter": 0.004}},
        "members": [{"name": "rope", "points": [[0, 0], [1, 0]], "elements": 16, "material": "m", "section": "s"}],
        "supports": [{"type": "pin", "member": "rope", "at": "start"}, {"type": "pin", "member": "rope", "at": "end"}],
        "loads": [{"type": "force", "member": "rope", "at": 4, "value": [0.0, -3.0]}],
        "contacts": [{"type": "circle", "member": "rope", "centre": [0.5, -0.1], "radius": 0.2, "method": "exact",
                      "gauss": 3}]}


@pytest.mark.parametrize("path", ["loads[0].value[1]", "materials.m.E", "materials.m.density"])
def test_frequency_sensitivity_with_exact_drum_contact(path):
    """The drum rows' curvature -sum f_i Hess g_i is in K_L: its change with the held points' forces and with the
    state (the gap kernels' compiled third derivatives), and the rows' turn, are in the derivative (without them the
    load's derivative errs by 2e-4 relative, 200 times the tolerance)."""
    r = solve_static(scene_from_dict(DRUM)[0])
    f = np.asarray(r.constraint_forces["contact"])
    assert np.sum(f > 0.1 * f.max()) == 4
    out = sensitivities(DRUM, [path], modes=MODES)
    fd = richardson(frequencies, DRUM, path)
    got = np.asarray(out[path]["frequencies"])
    assert np.linalg.norm(got - fd) <= 1e-6 * np.linalg.norm(fd), (path, got, fd)


@pytest.mark.parametrize("element", ["cable2d", "cable3d"])
def test_drum_gap_third_derivatives(element):
    """The drum gap kernel's compiled companion (q, p, v) -> (H v, d(H v)/dq) against its Hessian and central
    differences of H v (step 1e-6 on O(1) inputs: truncation ~1e-12, round-off ~1e-10 relative; 1e-6 leaves room)."""
    from ancf_sym import kernels, registry
    rng = np.random.default_rng(3)
    dim = registry.ELEMENTS[element].dim
    L = 0.7
    t = np.eye(dim)[0]
    centre = np.r_[0.3, -0.5, 0.1][:dim]
    q = np.concatenate([np.zeros(dim), t, t * L, t, centre]) + 0.05 * rng.standard_normal(5 * dim)
    names = kernels.parameters(element, "contact_circle_gap")
    values = {"L": L, "xi": 0.4, "t": 0.002, "R": 0.3, "ax": 0.0, "ay": 0.0, "az": 1.0}
    p = [values[n] for n in names]
    v = rng.standard_normal(len(q))
    k, hvp = kernels.load(element, "contact_circle_gap"), kernels.load_hvp(element, "contact_circle_gap")
    hv, dhv = (np.asarray(a) for a in hvp(q, p, v))
    H = np.asarray(k(q, p)[2])
    assert np.allclose(hv.ravel(), H @ v, rtol=1e-12, atol=1e-12 * np.abs(H).max())
    h = 1e-6
    fd = np.column_stack([(np.asarray(k(q + h * e, p)[2]) @ v - np.asarray(k(q - h * e, p)[2]) @ v) / (2 * h)
                          for e in np.eye(len(q))])
    assert np.abs(dhv - fd).max() < 1e-6 * np.abs(fd).max()
