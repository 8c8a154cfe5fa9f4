"""What stays refused among the parameters that enter kernels nonlinearly, each by a ParameterError naming the path
and the reason, before any solving or stepping: an exact contact's geometry (its rows hold it), a dissipative
contact's (its damping and friction forces move with it too), and a beam's Poisson ratio in a run with stiffness-
proportional Rayleigh damping (d(K v)/dP of the elastic kernels is not compiled)."""
from __future__ import annotations

import copy

import pytest

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.sensitivity.alpha_run import check_dynamic_paths
from ancf_sym.sensitivity.model_derivative import ParameterError, check_model_paths

DRUM = {"scene": {"name": "drum", "dim": 2, "gravity": [0.0, -9.81]},
        "materials": {"m": {"E": 2e9, "density": 1000.0}}, "sections": {"s": {"area": 1e-5, "I": 1e-11}},
        "members": [{"name": "rope", "points": [[0, 0], [1, 0]], "elements": 8, "material": "m", "section": "s"}],
        "supports": [{"type": "pin", "member": "rope", "at": "start"}, {"type": "pin", "member": "rope", "at": "end"}],
        "contacts": [{"type": "circle", "member": "rope", "centre": [0.5, -0.18], "radius": 0.2, "method": "exact",
                      "thickness": 0.0}]}
BEAM = {"scene": {"name": "b", "dim": 3, "gravity": [0.0, 0.0, -9.81]},
        "materials": {"m": {"E": 5e6, "density": 1200.0, "poisson": 0.3}},
        "sections": {"s": {"shape": "rectangle", "b": 0.02, "h": 0.03}},
        "members": [{"name": "beam", "points": [[0, 0, 0], [1, 0, 0]], "elements": 3, "material": "m",
                     "section": "s", "element": "beam3d", "beam_method": "elastic_line"}],
        "supports": [{"type": "clamp", "member": "beam", "at": "start"}],
        "dampings": [{"type": "rayleigh", "beta": 1e-3}]}


def refused(doc, path, message):
    with pytest.raises(ParameterError, match=message) as e:
        check_model_paths(scene_from_dict(doc)[0], doc, [path])
    assert path in str(e.value)


def test_exact_contact_geometry():
    refused(DRUM, "contacts[0].radius", "exact contact's geometry")


def test_dissipative_contact_geometry():
    doc = copy.deepcopy(DRUM)
    doc["contacts"][0].update(method="penalty", stiffness=1e5, damping=10.0)
    refused(doc, "contacts[0].centre[1]", "damping and friction forces depend on its geometry")


def test_poisson_with_stiffness_damping():
    with pytest.raises(ParameterError, match="stiffness-proportional Rayleigh damping"):
        check_dynamic_paths(scene_from_dict(BEAM)[0], BEAM, ["materials.m.poisson"])
