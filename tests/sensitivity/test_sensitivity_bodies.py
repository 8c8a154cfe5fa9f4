"""Sensitivities to rigid bodies' numbers: a spatial body (natural coordinates: a constant mass matrix
diag(m, m, m) + C (x) I_3, C = tr(I)/2 - I, linear in the mass and the inertia) on a revolute joint of a tilted axis
with a non-principal inertia (so every diagonal moment changes the swing), held up by a rope; and a planar body's
inertia. Statics (mass, weight under gravity, dead force), frequencies and dynamics (forward, adjoint), against
Richardson-extrapolated central differences of re-solved scenes.

Tolerances: statics and frequencies 1e-6 relative (the requirement; the differences' truncation O(h^4) at h = 1e-2
of the value is ~2e-7 on the stiffest frequency, the equilibrium solves at round-off), dynamics 1e-5 (runs converged
to xtol = 1e-13 of the length); forward = adjoint to 1e-8 (the same solves transposed, round-off of ~50 sparse QR
solves)."""
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
from ancf_sym.sensitivity.model_derivative import ParameterError
from ancf_sym.sensitivity.static import StaticSensitivity
from ancf_sym.statics import solve_static

TIGHT = NewtonOptions(xtol=1e-13, tol=1e-12, lte_fraction=0.0, single=False)
INERTIA = [[0.030, 0.002, -0.001], [0.002, 0.025, 0.003], [-0.001, 0.003, 0.040]]  # not principal
PLATE = {"scene": {"name": "plate", "dim": 3, "gravity": [0.0, 0.0, -9.81]},
         "materials": {"m": {"E": 2e7, "density": 1500.0}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
         "members": [{"name": "rope", "points": [[0.6, 0.0, 0.0], [0.6, 0.1, 1.0]], "elements": 4, "material": "m",
                      "section": "s", "element": "cable3d", "bending": True}],
         "supports": [{"type": "pin", "member": "rope", "at": "end"}],
         "bodies": [{"name": "plate", "mass": 2.0, "inertia": INERTIA, "position": [0.3, 0.0, -0.05],
                     "force": [0.5, 1.0, 0.0], "revolute": {"point": [0.0, 0.0, 0.0], "axis": [0.3, 1.0, 0.4]},
                     "pin": [["rope", "start"]]}]}
DIAGONAL = ["bodies[0].inertia[0][0]", "bodies[0].inertia[1][1]", "bodies[0].inertia[2][2]"]
# a planar pendulum: a rope from a pin to a body on a revolute joint
PLANAR = {"scene": {"name": "body", "dim": 2, "gravity": [0.0, -9.81]},
          "materials": {"m": {"E": 1e7, "density": 1500.0}}, "sections": {"s": {"area": 1e-4, "I": 1e-9}},
          "members": [{"name": "rope", "points": [[0, 0], [1.0, -1.0]], "elements": 6, "material": "m",
                       "section": "s", "bending": True}],
          "supports": [{"type": "pin", "member": "rope", "at": "start"}],
          "bodies": [{"name": "tip", "mass": 0.5, "inertia": 0.02, "position": [1.2, -1.0], "pin": [["rope", "end"]],
                      "revolute": [1.5, -1.0]}]}


def richardson(f, doc, path, rel=1e-2):
    v = get_parameter(doc, path)
    s = rel * (abs(v) if v else 1.0)  # (a zero gravity component: a step of rel m/s^2)

    def D(h):
        return (f(with_parameter(doc, path, v + h)) - f(with_parameter(doc, path, v - h))) / (2 * h)
    return (4 * D(s / 2) - D(s)) / 3


def static_outputs(doc):
    r = solve_static(scene_from_dict(doc)[0])
    assert r.success
    cf = r.constraint_forces
    return np.r_[r.x, r.potential, np.concatenate([np.asarray(cf[k]).ravel() for k in sorted(cf)])]


@pytest.mark.parametrize("path", ["bodies[0].mass", "scene.gravity[2]", "scene.gravity[0]", "bodies[0].force[0]"])
def test_spatial_body_statics(path):
    """Coordinates, potential and reactions (the revolute's, the pins', the axes' rows)."""
    scene, _ = scene_from_dict(PLATE)
    r = solve_static(scene)
    S = StaticSensitivity(scene, r, PLATE)
    d = S.derivative(path)
    exact = np.r_[S.dx(path), d["potential"],
                  np.concatenate([np.asarray(d["constraint_forces"][k]).ravel() for k in sorted(d["constraint_forces"])])]
    fd = richardson(static_outputs, PLATE, path)
    n = len(r.x)
    for part in (slice(0, n), slice(n, n + 1), slice(n + 1, None)):
        assert np.linalg.norm(exact[part] - fd[part]) <= 1e-6 * np.linalg.norm(fd[part]), (path, part)


def frequencies(doc):
    return modal_analysis(scene_from_dict(doc)[0], modes=3).frequencies


@pytest.mark.parametrize("doc,path", [(PLATE, "bodies[0].mass"), (PLATE, "scene.gravity[2]")] +
                         [(PLATE, p) for p in DIAGONAL] + [(PLANAR, "bodies[0].inertia"), (PLANAR, "bodies[0].mass")])
def test_body_frequencies(doc, path):
    base = modal_analysis(scene_from_dict(doc)[0], modes=3)
    got = ModalSensitivity(base, scene_from_dict(doc)[0], doc).derivative(path)[0]
    fd = richardson(frequencies, doc, path)
    assert np.linalg.norm(got - fd) <= 1e-6 * np.linalg.norm(fd), (path, got, fd)


def test_principal_moments_and_refusals():
    """inertia = [I1, I2, I3] (principal moments): inertia[k] is the parameter; an off-diagonal product of a
    tensor is refused by name (one entry of a symmetric tensor cannot change alone)."""
    doc = copy.deepcopy(PLATE)
    doc["bodies"][0]["inertia"] = [0.03, 0.025, 0.04]
    base = modal_analysis(scene_from_dict(doc)[0], modes=3)
    ms = ModalSensitivity(base, scene_from_dict(doc)[0], doc)
    got = ms.derivative("bodies[0].inertia[2]")[0]
    fd = richardson(frequencies, doc, "bodies[0].inertia[2]")
    assert np.linalg.norm(got - fd) <= 1e-6 * np.linalg.norm(fd)
    base = modal_analysis(scene_from_dict(PLATE)[0], modes=3)
    with pytest.raises(ParameterError, match=r"bodies\[0\].inertia\[0\]\[1\].*off-diagonal"):
        ModalSensitivity(base, scene_from_dict(PLATE)[0], PLATE).derivative("bodies[0].inertia[0][1]")


SENSORS = [{"name": "pin", "kind": "position", "member": "rope", "at": "start"}]
DYN_PATHS = ["bodies[0].mass", "scene.gravity[2]", "bodies[0].force[0]"] + DIAGONAL


def test_spatial_body_dynamics_adjoint_equals_forward():
    """Released from the reference (the plate horizontal): it swings about the tilted axis."""
    o = DynamicOptions(dt=2e-3, t_end=0.1, newton=TIGHT, sensors=SENSORS)
    fw = dynamic_sensitivity(PLATE, DYN_PATHS, o)
    g = dynamic_gradient(PLATE, DYN_PATHS, o, SensorOutput("pin", 2, "integral"))
    w = np.zeros(len(fw.t))
    w[:-1] += np.diff(fw.t) / 2
    w[1:] += np.diff(fw.t) / 2
    for p in DYN_PATHS:
        ref = w @ fw.sensor(p, "pin")[:, 2]
        assert abs(g.gradient[p] - ref) <= 1e-8 * abs(ref), p


@pytest.mark.parametrize("start,out", [("reference", SensorOutput("pin", 2, "integral")),
                                       ("reference", EnergyOutput("kinetic")), ("static", EnergyOutput("kinetic"))],
                         ids=["released_pin", "released_kinetic", "static_start_kinetic"])
def test_spatial_body_dynamics_matches_central_differences(start, out):
    """From the reference, or from the equilibrium (the revolute, pin and axes rows carry multipliers) pushed
    sideways by a load pulse."""
    loads = [{"member": "rope", "at": "start", "force": [30.0, 0.0, 0.0],
              "history": [[0.0, 0.0], [0.05, 1.0], [0.1, 0.0]]}] if start == "static" else []
    o = DynamicOptions(dt=2e-3, t_end=0.1, newton=TIGHT, sensors=SENSORS, start=start, loads=loads)
    g = dynamic_gradient(PLATE, DYN_PATHS, o, out)
    for p in DYN_PATHS:
        fd = richardson(lambda d: dynamic_gradient(d, [], o, out).value, PLATE, p, 1e-3)
        assert abs(g.gradient[p] - fd) <= 1e-5 * abs(fd), (p, g.gradient[p], fd)


def test_planar_body_inertia_dynamics():
    o = DynamicOptions(dt=2e-3, t_end=0.1, newton=TIGHT, sensors=[{"name": "tip", "kind": "position",
                                                                   "member": "rope", "at": "end"}])
    out = SensorOutput("tip", 1, "integral")
    paths = ["bodies[0].inertia", "bodies[0].mass"]
    g = dynamic_gradient(PLANAR, paths, o, out)
    for p in paths:
        fd = richardson(lambda d: dynamic_gradient(d, [], o, out).value, PLANAR, p, 1e-3)
        assert abs(g.gradient[p] - fd) <= 1e-5 * abs(fd), (p, g.gradient[p], fd)
