"""Frequency sensitivities to numbers that enter the kernels nonlinearly: a beam3d cantilever's Poisson ratio,
section b and h (the mass's b x h through its direction companion), and a penalty drum's radius and centre under
a rope (the contact kernel's third derivatives along the static sensitivity, the prestress change, come from its
direction companion); E of that rope, whose contact kernel had no third derivatives before.

Reference: Richardson-extrapolated central differences of re-solved scenes and modal analyses (truncation O(h^4)
at h = 1e-2 |p| for the beam, 1e-3 for the rope on the drum, where a penalty contact point crossing the surface
within a larger step breaks the h^2 law of the differences), against the 1e-6 the modal derivatives must meet.
(At h = 1e-3 |p| the beam's frequencies' own solve noise, ~1e-10 relative, is ~1e-6 of the Poisson ratio's weak
derivative: the larger step keeps both errors far below the bound.) A missing prestress term or mass derivative errs by O(1e-2) and more here."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.modal import modal_analysis
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.api import sensitivities

MODES = 4
BEAM = {"scene": {"name": "b", "dim": 3, "gravity": [0.0, 0.0, -9.81]},
        "materials": {"m": {"E": 2e8, "density": 2000.0, "poisson": 0.3}},
        "sections": {"s": {"shape": "rectangle", "b": 0.02, "h": 0.03}},
        "members": [{"name": "beam", "points": [[0, 0, 0], [1, 0, 0]], "elements": 4, "material": "m",
                     "section": "s", "element": "beam3d", "beam_method": "elastic_line"}],
        "supports": [{"type": "clamp", "member": "beam", "at": "start"}],
        "loads": [{"type": "force", "member": "beam", "at": "end", "value": [-300.0, 5.0, -20.0]}]}
CONTINUUM = copy.deepcopy(BEAM)
CONTINUUM["members"][0]["beam_method"] = "continuum"
DRUM = {"scene": {"name": "drum", "dim": 2, "gravity": [0.0, -9.81]},
        "materials": {"m": {"E": 2e9, "density": 1000.0}},
        "sections": {"s": {"shape": "circle", "diameter": 0.004}},
        "members": [{"name": "rope", "points": [[0, 0], [1, 0]], "elements": 16, "material": "m", "section": "s"}],
        "supports": [{"type": "pin", "member": "rope", "at": "start"}, {"type": "pin", "member": "rope", "at": "end"}],
        "loads": [{"type": "force", "member": "rope", "at": 4, "value": [0.0, -3.0]}],
        "contacts": [{"type": "circle", "member": "rope", "centre": [0.45, -0.18], "radius": 0.2, "stiffness": 1e6,
                      "thickness": 0.002}]}


def frequencies(doc) -> np.ndarray:
    return modal_analysis(scene_from_dict(doc)[0], modes=MODES).frequencies


def richardson(doc, path, rel):
    v = get_parameter(doc, path)
    h = rel * abs(v)
    D = lambda s: (frequencies(with_parameter(doc, path, v + s)) - frequencies(with_parameter(doc, path, v - s))) / (2 * s)
    return (4 * D(h / 2) - D(h)) / 3


@pytest.mark.parametrize("doc, path, rel", [
    (BEAM, "materials.m.poisson", 1e-2), (BEAM, "sections.s.b", 1e-2), (BEAM, "sections.s.h", 1e-2),
    (CONTINUUM, "materials.m.poisson", 1e-2), (CONTINUUM, "sections.s.h", 1e-2),
    (DRUM, "contacts[0].radius", 1e-3), (DRUM, "contacts[0].centre[1]", 1e-3), (DRUM, "materials.m.E", 1e-3)])
def test_frequency_sensitivity(doc, path, rel):
    got = np.asarray(sensitivities(doc, [path], modes=MODES)[path]["frequencies"])
    fd = richardson(doc, path, rel)
    assert np.all(np.isfinite(got)) and np.linalg.norm(fd) > 0
    assert np.linalg.norm(got - fd) <= 1e-6 * np.linalg.norm(fd), (path, got, fd)


@pytest.mark.parametrize("doc, path, rel", [(BEAM, "sections.s.h", 1e-2), (DRUM, "contacts[0].radius", 1e-3)])
def test_mode_shape_sensitivity(doc, path, rel):
    """Nelson's system with dK/dp from the direction companions (and dM of the beam's b x h): against differences of
    the M-normalised shapes, each perturbed mode signed like the base one."""
    from ancf_sym.sensitivity.modal import ModalSensitivity
    scene = scene_from_dict(doc)[0]
    base = modal_analysis(scene, modes=MODES)
    M = base.linearization.assembly.mass_matrix()
    got = ModalSensitivity(base, scene, doc).shape_derivative(path)
    v = get_parameter(doc, path)
    h = rel * abs(v)

    def shapes(d):
        s = modal_analysis(scene_from_dict(d)[0], modes=MODES).shapes
        return s * np.sign(np.sum(s * (M @ base.shapes), axis=0))
    D = lambda s: (shapes(with_parameter(doc, path, v + s)) - shapes(with_parameter(doc, path, v - s))) / (2 * s)
    fd = (4 * D(h / 2) - D(h)) / 3
    for k in range(MODES):
        assert np.linalg.norm(got[:, k] - fd[:, k]) <= 1e-6 * np.linalg.norm(fd[:, k]), (path, k)
