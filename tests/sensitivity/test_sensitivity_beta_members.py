"""Stiffness-proportional Rayleigh damping per member (several [[dampings]] entries: C's elastic part is
sum_e beta_m(e) H_e, each member with the beta of the last entry naming it) and on beam3d members (elastic line and
continuum: the change of beta K_el(q_n) v with q_n from the beam kernels' compiled Hessian-vector companions), in
the dynamic sensitivities; and beam3d frequencies' sensitivities, which the same companions make available.

Forward = adjoint to 1e-8 (the same solves transposed; round-off of ~50 sparse solves). Against Richardson-
extrapolated central differences of runs converged to xtol = 1e-13 of the length: 1e-5 relative (the requirement).
The steps: 1e-2 of the value for the L frame (its runs' Newton round-off shows in differences at 1e-3 of a beta:
measured 8e-6 there against 1.5e-7 at 1e-2, whose O(h^4) truncation is ~1e-7), 1e-3 for the beam (a step of
1e-2 in E already needs more than 12 Newton iterations on its first, suddenly loaded step). Frequencies: 1e-6
relative (norm over the modes; differences of modal analyses at 1e-2 of the value agree to <= 1e-7 on these)."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from ancf_sym.dynamics import DynamicOptions
from ancf_sym.dynamics.newton import NewtonOptions
from ancf_sym.io.scene_toml import scene_from_dict
from ancf_sym.modal import modal_analysis
from ancf_sym.sensitivity import get_parameter, with_parameter
from ancf_sym.sensitivity.adjoint import EnergyOutput, SensorOutput, dynamic_gradient
from ancf_sym.sensitivity.dynamics import dynamic_sensitivity
from ancf_sym.sensitivity.modal import ModalSensitivity

TIGHT = NewtonOptions(xtol=1e-13, tol=1e-12, lte_fraction=0.0, single=False, max_iter=30)
# an L frame (rigid joint, a body at its tip) swinging from the reference; beta 2e-3 on member a (entry 0 names all
# members, entry 1 then gives b its own 5e-3)
FRAME = {"scene": {"name": "p", "dim": 2, "gravity": [0.0, -9.81]},
         "materials": {"m": {"E": 2e5, "density": 1200.0}}, "sections": {"s": {"area": 1e-4, "I": 2e-9}},
         "members": [{"name": "a", "points": [[0, 0], [0.5, 0]], "elements": 3, "material": "m", "section": "s",
                      "bending": True},
                     {"name": "b", "points": [[0.5, 0], [0.5, -0.5]], "elements": 3, "material": "m",
                      "section": "s", "bending": True}],
         "supports": [{"type": "pin", "member": "a", "at": "start"}],
         "joints": [{"type": "rigid", "a": ["a", "end"], "b": ["b", "start"]}],
         "bodies": [{"name": "tip", "mass": 0.05, "inertia": 1e-4, "position": [0.6, -0.5], "pin": [["b", "end"]]}],
         "dampings": [{"type": "rayleigh", "alpha": 2.0, "beta": 2e-3},
                      {"type": "rayleigh", "beta": 5e-3, "members": ["b"]}]}
FRAME_PATHS = ["dampings[0].beta", "dampings[1].beta", "materials.m.E", "sections.s.I", "dampings[0].alpha"]


def beam(method: str, elements: int) -> dict:
    """A beam3d cantilever under gravity and a tip force, released from the straight reference."""
    return {"scene": {"name": "b", "dim": 3, "gravity": [0.0, 0.0, -9.81]},
            "materials": {"m": {"E": 2e8, "density": 2000.0, "poisson": 0.3}},
            "sections": {"s": {"shape": "rectangle", "b": 0.02, "h": 0.03}},
            "members": [{"name": "beam", "points": [[0, 0, 0], [1, 0, 0]], "elements": elements, "material": "m",
                         "section": "s", "element": "beam3d", "beam_method": method}],
            "supports": [{"type": "clamp", "member": "beam", "at": "start"}],
            "loads": [{"type": "force", "member": "beam", "at": "end", "value": [0.0, 5.0, -20.0]}],
            "dampings": [{"type": "rayleigh", "beta": 2e-3}]}


LINE, CONTINUUM = beam("elastic_line", 4), beam("continuum", 2)
BEAM_PATHS = {"line": ["dampings[0].beta", "materials.m.E", "materials.m.density", "loads[0].value[2]"],
              "continuum": ["dampings[0].beta", "materials.m.density", "loads[0].value[2]"]}  # (continuum: no E)


def opts(member: str):
    return DynamicOptions(dt=2e-3, t_end=0.1, newton=TIGHT,
                          sensors=[{"name": "tip", "kind": "position", "member": member, "at": "end"}])


def trapezoid(t):
    w = np.zeros(len(t))
    w[:-1] += np.diff(t) / 2
    w[1:] += np.diff(t) / 2
    return w


def richardson(f, doc, path, rel):
    v = get_parameter(doc, path)
    s = rel * abs(v)

    def D(h):
        return (f(with_parameter(doc, path, v + h)) - f(with_parameter(doc, path, v - h))) / (2 * h)
    return (4 * D(s / 2) - D(s)) / 3


@pytest.mark.parametrize("doc,member,paths,comp", [(FRAME, "b", FRAME_PATHS, 1), (LINE, "beam", BEAM_PATHS["line"], 2),
                                                   (CONTINUUM, "beam", BEAM_PATHS["continuum"], 2)],
                         ids=["frame_per_member", "beam3d_line", "beam3d_continuum"])
def test_beta_adjoint_equals_forward(doc, member, paths, comp):
    o = opts(member)
    fw = dynamic_sensitivity(doc, paths, o)
    g = dynamic_gradient(doc, paths, o, SensorOutput("tip", comp, "integral"))
    for p in paths:
        ref = trapezoid(fw.t) @ fw.sensor(p, "tip")[:, comp]
        assert abs(g.gradient[p] - ref) <= 1e-8 * abs(ref), p


@pytest.mark.parametrize("doc,member,paths,out,rel", [
    (FRAME, "b", FRAME_PATHS[:4], SensorOutput("tip", 1, "integral"), 1e-2),
    (FRAME, "b", FRAME_PATHS[:2], EnergyOutput("kinetic"), 1e-2),
    (LINE, "beam", BEAM_PATHS["line"], SensorOutput("tip", 2, "integral"), 1e-3),
    (LINE, "beam", BEAM_PATHS["line"][:2], EnergyOutput("kinetic"), 1e-3),
    (CONTINUUM, "beam", BEAM_PATHS["continuum"], EnergyOutput("kinetic"), 1e-3)],
    ids=["frame_tip", "frame_kinetic", "line_tip", "line_kinetic", "continuum_kinetic"])
def test_beta_matches_central_differences(doc, member, paths, out, rel):
    o = opts(member)
    g = dynamic_gradient(doc, paths, o, out)
    for p in paths:
        fd = richardson(lambda d: dynamic_gradient(d, [], o, out).value, doc, p, rel)
        assert abs(g.gradient[p] - fd) <= 1e-5 * abs(fd), (p, g.gradient[p], fd)


def test_entry_overridden_everywhere_has_no_effect():
    """An entry whose members all take a later entry's beta damps nothing: its beta's derivative is zero."""
    doc = copy.deepcopy(FRAME)
    doc["dampings"].append({"type": "rayleigh", "beta": 1e-3, "members": ["a"]})
    g = dynamic_gradient(doc, ["dampings[0].beta", "dampings[2].beta"], opts("b"), EnergyOutput("kinetic"))
    assert g.gradient["dampings[0].beta"] == 0.0 and g.gradient["dampings[2].beta"] != 0.0


def frequencies(doc):
    return modal_analysis(scene_from_dict(doc)[0], modes=4).frequencies


@pytest.mark.parametrize("doc,path", [(LINE, "materials.m.E"), (LINE, "materials.m.density"),
                                      (LINE, "loads[0].value[2]"), (CONTINUUM, "loads[0].value[2]")])
def test_beam3d_frequencies(doc, path):
    """The prestress change along dx*/dp takes the beam kernels' third derivatives (the same companions)."""
    base = modal_analysis(scene_from_dict(doc)[0], modes=4)
    got = ModalSensitivity(base, scene_from_dict(doc)[0], doc).derivative(path)[0]
    fd = richardson(frequencies, doc, path, 1e-2)
    assert np.linalg.norm(got - fd) <= 1e-6 * np.linalg.norm(fd), (path, got, fd)


def test_beta_on_energies_without_companions_refused_by_name():
    """The companions exist at the default quadrature only: a beam at 3 Gauss points is refused, naming it."""
    from ancf_sym.scene import SceneError
    doc = copy.deepcopy(LINE)
    doc["members"][0]["gauss"] = 3
    with pytest.raises(SceneError, match=r"beam3d/line_\w+ energies \(gauss 3"):
        dynamic_gradient(doc, ["materials.m.E"], opts("beam"), EnergyOutput("kinetic"))
